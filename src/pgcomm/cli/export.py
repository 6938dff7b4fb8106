"""``pgcomm export``: a model file's commutation law as generated C code or as a lookup table.

``--format c`` writes ``NAME.h``/``NAME.c`` (:func:`pgcomm.export.c.write_c`);
``--format lut`` writes the law table ``NAME.csv``/``NAME.h`` and the anti-cogging table
``NAME_cogging.csv`` (:mod:`pgcomm.export.lut`) and measures their worst-case force error
on the model. Both write ``results.json``. A model file that fails validation is refused
by the loader (one line, exit code 2, nothing written: the output is staged by
:func:`pgcomm.cli._common.staged_output`).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_out_option
from pgcomm.errors import ConfigError

HELP = "Export a model's commutation law as C code or a lookup table, verified against the model."

#: ``--f-max`` when the model's metadata has no training force (N).
DEFAULT_F_MAX = 100.0


def configure(p) -> None:
    """Options of ``pgcomm export``."""
    from pgcomm.defaults import DEFAULT_RESOLUTION

    p.add_argument("--model", required=True, type=Path, metavar="MODEL.json", help="model file (pgcomm identify)")
    p.add_argument("--format", required=True, choices=("c", "lut"),
                   help="c: self-contained C99 law; lut: lookup table (CSV + C header) and anti-cogging table")
    add_out_option(p)
    p.add_argument("--precision", choices=("double", "single"), default="double",
                   help="C scalar type for --format c (default double)")
    p.add_argument("--resolution", type=float, default=DEFAULT_RESOLUTION, metavar="M",
                   help=f"table spacing in m for --format lut (default {DEFAULT_RESOLUTION:g} m)")
    p.add_argument("--name", help="C identifier for file names and symbols "
                                  "(default pgcomm_law for c, pgcomm_lut for lut)")
    p.add_argument("--current-limit", type=float, metavar="A",
                   help="peak phase current limit embedded in the law (default: none)")
    p.add_argument("--f-max", type=float, metavar="N",
                   help="driving force for the table error (default: the largest |Fy| of the model's "
                        f"training data if its metadata has it, else {DEFAULT_F_MAX:g} N)")
    add_common_options(p, out=False, plant=False)  # --quiet


def f_max_from_metadata(metadata) -> float | None:
    """Largest ``|Fy|`` (N) of the training data recorded in a model file's metadata, or ``None``.

    ``metadata`` is the model document of :func:`pgcomm.io.model.load_model` (user metadata
    under its ``metadata`` key) or the user metadata itself. Looks for a positive number under
    ``fy_abs_max``, ``f_max``, ``fy_max``, ``max_abs_fy`` or ``training_fy_max``, at the top
    level or inside ``metadata``, ``training``, ``data`` or ``identification`` (one level each).
    """
    keys = ("fy_abs_max", "f_max", "fy_max", "max_abs_fy", "training_fy_max")
    subs = ("metadata", "training", "data", "identification")
    places = [metadata]
    if isinstance(metadata, dict):
        inner = [metadata.get(k) for k in subs]
        places += inner + [d.get(k) for d in inner if isinstance(d, dict) for k in subs]
    for place in places:
        if not isinstance(place, dict):
            continue
        for k in keys:
            v = place.get(k)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0:
                return float(v)
    return None


def run(args, out: Path, progress) -> None:
    """Export ``--model`` as C (``NAME.h/.c``) or lookup tables; write ``results.json``."""
    from pgcomm.io.model import load_model
    from pgcomm.io.results import write_results

    t0 = time.perf_counter()
    if args.current_limit is not None and not (math.isfinite(args.current_limit) and args.current_limit > 0):
        raise ConfigError(f"--current-limit must be a positive current in A, got {args.current_limit}")
    if args.f_max is not None and not (math.isfinite(args.f_max) and args.f_max > 0):
        raise ConfigError(f"--f-max must be a positive force in N, got {args.f_max}")
    if not (math.isfinite(args.resolution) and args.resolution > 0):
        raise ConfigError(f"--resolution must be a positive length in m, got {args.resolution}")
    name = args.name or ("pgcomm_law" if args.format == "c" else "pgcomm_lut")
    from pgcomm.export.c import check_c_name

    try:
        check_c_name(name)
    except ValueError as e:
        raise ConfigError(f"--name: {e}") from None

    # no progress stage around the (fast) load: a refused file then prints exactly one line
    model, metadata = load_model(args.model)
    metadata = dict(metadata or {})
    results = {"command": "export", "format": args.format, "model": str(args.model), "name": name,
               "n_coil_sets": model.n_coil_sets, "pole_pitch": model.pole_pitch,
               "training_range": model.training_range, "current_limit": args.current_limit}
    if args.format == "c":
        _export_c(args, out, progress, model, metadata, name, results)
    else:
        _export_lut(args, out, progress, model, metadata, name, results)
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)



def _export_c(args, out, progress, model, metadata, name, results):
    from pgcomm.export.c import write_c

    meta = {**metadata, "source": str(args.model)}
    with progress.stage(f"generate C ({args.precision} precision)"):
        try:
            # a spline file's mechanics travel with it: the feedforward is exported beside the law
            paths = write_c(model, out, name=name, precision=args.precision, metadata=meta,
                            current_limit=args.current_limit, mechanics=metadata.get("mechanics"))
        except ValueError as e:
            raise ConfigError(f"{args.model}: {e}") from None
    results.update(files=[p.name for p in paths], precision=args.precision,
                   feedforward=metadata.get("mechanics") is not None)
    if not args.quiet:
        limit = "none" if args.current_limit is None else f"{args.current_limit:g} A"
        print(f"C law {name}: L = {model.n_coil_sets}, {args.precision} precision, current limit {limit}"
              + (f"; feedforward {name}_feedforward (mechanics of the model file)" if metadata.get("mechanics") else ""))
        print(f"wrote {args.out}/{paths[0].name}, {paths[1].name}, results.json")


def _export_lut(args, out, progress, model, metadata, name, results):
    from pgcomm.export.lut import (
        build_cogging_table,
        build_lut,
        cogging_table_error,
        lut_error,
        write_cogging_table,
        write_lut,
    )

    if model.training_range is None:
        raise ConfigError(f"{args.model}: the model has no training range, so the table has no extent")
    f_max, source = args.f_max, "--f-max"
    if f_max is None:
        f_max = f_max_from_metadata(metadata)
        source = "training data (model metadata)"
        if f_max is None:
            f_max, source = DEFAULT_F_MAX, "default (no training force in the model's metadata)"
    from pgcomm.export.lut import MAX_ROWS

    lo, hi = model.training_range
    if (hi - lo) / args.resolution > MAX_ROWS:
        raise ConfigError(f"--resolution {args.resolution:g} m over the training range [{lo:.6g}, {hi:.6g}] m of "
                          f"{args.model} gives {(hi - lo) / args.resolution:.3g} rows; at most {MAX_ROWS} "
                          f"(the table and its 10x finer error check must fit a drive and this machine); "
                          f"use --resolution {(hi - lo) / (MAX_ROWS - 1):.3g} or more")
    with progress.stage(f"tabulate the law every {args.resolution:g} m over {model.training_range} m"):
        try:
            lut = build_lut(model, args.resolution, current_limit=args.current_limit)
            cog = build_cogging_table(model, args.resolution)
        except ValueError as e:
            raise ConfigError(f"{args.model}: {e}") from None
    with progress.stage(f"worst-case force error on a 10x finer grid at f_max = {f_max:g} N"):
        err = lut_error(lut, model, f_max)
        cog_err = cogging_table_error(cog, model, f_max, current_limit=args.current_limit)
    paths = write_lut(lut, out, name)
    cog_path = write_cogging_table(cog, out, f"{name}_cogging")
    results.update(
        files=[p.name for p in paths] + [cog_path.name], rows=lut.n, resolution=args.resolution, dy=lut.dy,
        entries=lut.entries, bytes=lut.nbytes, f_max=f_max, f_max_source=source,
        error={q: {"abs": float(err.abs[k]), "rel": float(err.rel[k]), "y_worst": float(err.y_worst[k])}
               for k, q in enumerate("yxz")},
        worst_rel=err.worst_rel,
        cogging_table={"rows": cog.n, "bytes": cog.nbytes, **cog_err.as_dict()},
    )
    if not args.quiet:
        print(f"LUT {name}: {lut.n} rows x {lut.entries // lut.n} entries = {lut.nbytes} bytes (float32), "
              f"spacing {lut.dy:.4g} m")
        print(f"f_max = {f_max:g} N from {source}")
        print("worst-case force error vs the exact law: "
              + ", ".join(f"{q} {err.abs[k]:.3g} {'N m' if q == 'z' else 'N'} ({100 * err.rel[k]:.3g} %)"
                          for k, q in enumerate("yxz")))
        ce = cog_err.law_abs
        print(f"anti-cogging table: interpolation {cog_err.interpolation:.3g} N; classical + table leaves "
              f"y {ce[0]:.3g} N, x {ce[1]:.3g} N, z {ce[2]:.3g} N m")
        print(f"wrote {args.out}/{paths[0].name}, {paths[1].name}, {cog_path.name}, results.json")
