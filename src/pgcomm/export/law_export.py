"""``pgcomm export --format c|lut``: a linear model's law as generated C code or as lookup tables.

``--format c`` writes ``NAME.h``/``NAME.c`` (:func:`pgcomm.export.c.write_c`); ``--format lut`` writes the law
table ``NAME.csv``/``NAME.h`` and the anti-cogging table ``NAME_cogging.csv`` (:mod:`pgcomm.export.lut`), measures
their worst-case force error on the model and refuses a table that errs more than the model's own standard error
(naming the coarsest spacing that would do). The command line is :mod:`pgcomm.cli.export`; the options it shares
with the other formats are :mod:`pgcomm.export.options`.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from pgcomm.errors import ConfigError
from pgcomm.export.options import (
    c_name as _c_name,
    drive_commutation,
    fmt_values as _fmt_values,
    limit_text as _limit_text,
    parse_current_limit,
)
from pgcomm.export.drive_export import TABLE_FORMATS
from pgcomm.io.results import write_results

__all__ = ["DEFAULT_F_MAX", "f_max_from_metadata", "export_law"]

#: ``--f-max`` when the model's metadata has no training force (N).
DEFAULT_F_MAX = 100.0


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


def export_law(args, out: Path, progress, t0: float) -> None:
    """``--format c|lut --model MODEL``: the law as C or lookup tables; writes ``results.json``."""
    from pgcomm.io.model import current_limit_of, load_model  # start-up cost: loads JAX only when this runs

    if args.model is None:
        raise ConfigError(f"--format {args.format} exports a model file: give --model MODEL.json")
    if args.table is not None:
        raise ConfigError(f"--table is for the drive tables (--format {', '.join(TABLE_FORMATS)}); "
                          f"--format {args.format} exports --model")
    limit, limit_given = parse_current_limit(args.current_limit)
    if args.f_max is not None and not (math.isfinite(args.f_max) and args.f_max > 0):
        raise ConfigError(f"--f-max must be a positive force in N, got {args.f_max}")
    if not (math.isfinite(args.resolution) and args.resolution > 0):
        raise ConfigError(f"--resolution must be a positive length in m, got {args.resolution}")
    name = _c_name(args)

    # no progress stage around the (fast) load: a refused file then prints exactly one line
    model, metadata = load_model(args.model)
    metadata = dict(metadata or {})
    if limit_given:
        limit_source = "--current-limit" if limit is not None else "turned off with --current-limit none"
    else:
        limit = current_limit_of(metadata, args.model)
        if limit is None:
            raise ConfigError(f"{args.model}: the model file records no current limit (its motor description "
                              "had no current_limit); give --current-limit A, the motor's peak phase current, or "
                              "--current-limit none to export a law without a limit")
        limit_source = "from the model file"
    drive = drive_commutation(args, model, metadata)
    results = {"command": "export", "format": args.format, "model": str(args.model), "name": name,
               "n_coil_sets": model.n_coil_sets, "pole_pitch": model.pole_pitch,
               "training_range": model.training_range, "current_limit": limit,
               "current_limit_source": limit_source}
    if args.format == "c":
        _export_c(args, out, progress, model, metadata, name, results, limit, limit_source, drive)
    else:
        _export_lut(args, out, progress, model, metadata, name, results, limit, limit_source, drive)
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)


def _export_c(args, out, progress, model, metadata, name, results, limit, limit_source, drive):
    from pgcomm.export.c import CLawOptions, write_c  # start-up cost: loads JAX only when this runs

    meta = {**metadata, "source": str(args.model)}
    # the drive's constants are embedded only when known (given or recorded), not the fit's
    embed = (drive["k_hat"], drive["zeta_hat"]) if drive["given"] else None
    with progress.stage(f"generate C ({args.precision} precision)"):
        try:
            # a spline file's mechanics travel with it: the feedforward is exported beside the law
            options = CLawOptions(name, args.precision, limit, limit_source=limit_source,
                                  drive_source=drive["source"] if embed else None)
            paths = write_c(model, out, options, metadata=meta, drive=embed, mechanics=metadata.get("mechanics"))
        except ValueError as e:
            raise ConfigError(f"{args.model}: {e}") from None
    results.update(files=[p.name for p in paths], precision=args.precision,
                   feedforward=metadata.get("mechanics") is not None,
                   drive=None if embed is None else {"k_hat": drive["k_hat"].tolist(),
                                                     "zeta_hat": drive["zeta_hat"].tolist(),
                                                     "source": drive["source"]})
    if not args.quiet:
        print(f"C law {name}: L = {model.n_coil_sets}, {args.precision} precision, current limit "
              f"{_limit_text(limit, limit_source)}"
              + (f"; feedforward {name}_feedforward (mechanics of the model file)" if metadata.get("mechanics") else ""))
        if embed is not None:
            print(f"drive constants {name}_drive_k_hat = {_fmt_values(drive['k_hat'])} N/A, {name}_drive_zeta_hat = "
                  f"{_fmt_values(drive['zeta_hat'])} rad ({drive['source']})")
        print(f"wrote {args.out}/{paths[0].name}, {paths[1].name}, results.json")


def _export_lut(args, out, progress, model, metadata, name, results, limit, limit_source, drive):
    # start-up cost: loads JAX only when this runs
    from pgcomm.export.lut import MAX_ROWS, build_cogging_table, build_lut, cogging_table_error, lut_error, \
        write_cogging_table, write_lut

    if model.training_range is None:
        raise ConfigError(f"{args.model}: the model has no training range, so the table has no extent")
    f_max, source = args.f_max, "--f-max"
    if f_max is None:
        f_max = f_max_from_metadata(metadata)
        source = "training data (model metadata)"
        if f_max is None:
            f_max, source = DEFAULT_F_MAX, "default (no training force in the model's metadata)"
    lo, hi = model.training_range
    if (hi - lo) / args.resolution > MAX_ROWS:
        raise ConfigError(f"--resolution {args.resolution:g} m over the training range [{lo:.6g}, {hi:.6g}] m of "
                          f"{args.model} gives {(hi - lo) / args.resolution:.3g} rows; at most {MAX_ROWS} "
                          f"(the table and its 10x finer error check must fit a drive and this machine); "
                          f"use --resolution {(hi - lo) / (MAX_ROWS - 1):.3g} or more")
    if args.resolution > hi - lo:
        raise ConfigError(f"--resolution {args.resolution:g} m: longer than the training range [{lo:.6g}, {hi:.6g}] m "
                          f"of {args.model} ({hi - lo:.4g} m), so the table would not hold the spacing asked for; "
                          "give a spacing below the range")
    k_hat, zeta_hat = drive["k_hat"], drive["zeta_hat"]
    drive_text = f"k_hat = {_fmt_values(k_hat)} N/A, zeta_hat = {_fmt_values(zeta_hat)} rad ({drive['source']})"
    with progress.stage(f"tabulate the law every {args.resolution:g} m over {model.training_range} m"):
        try:
            lut = build_lut(model, args.resolution, current_limit=limit)
        except ValueError as e:
            raise ConfigError(f"{args.model}: {e}") from None
        try:
            cog = build_cogging_table(model, args.resolution, k_hat=k_hat, zeta_hat=zeta_hat)
        except ValueError as e:
            raise ConfigError(f"anti-cogging table for the drive's commutation: {e}") from None
    with progress.stage(f"worst-case force error on a 10x finer grid at f_max = {f_max:g} N"):
        err = lut_error(lut, model, f_max)
        cog_err = cogging_table_error(cog, model, f_max, k_hat=k_hat, zeta_hat=zeta_hat, current_limit=limit)
    bound = _check_table_error(args, model, metadata, lut, err, f_max, limit, progress)
    paths = write_lut(lut, out, name, limit_source=limit_source)
    cog_path = write_cogging_table(cog, out, f"{name}_cogging", comments=[
        f"anti-cogging table of {args.model} for a drive with classical commutation {drive_text}",
        "the drive commutates Fy* - Fy_cog(y): Fy_cog = Fcog_y(y) / g(y), g the force the model makes per N the "
        "drive commands",
        f"y in m (uniform, {cog.n} rows, spacing {cog.dy:.9g} m; hold the end rows outside), Fy_cog in N",
    ])
    results.update(
        files=[p.name for p in paths] + [cog_path.name], rows=lut.n, resolution=args.resolution, dy=lut.dy,
        entries=lut.entries, bytes=lut.nbytes, f_max=f_max, f_max_source=source,
        error={q: {"abs": float(err.abs[k]), "rel": float(err.rel[k]), "y_worst": float(err.y_worst[k])}
               for k, q in enumerate("yxz")},
        worst_rel=err.worst_rel, error_bound={"fy_N": bound[0], "what": bound[1]},
        cogging_table={"rows": cog.n, "bytes": cog.nbytes, **cog_err.to_dict(),
                       "drive": {"k_hat": k_hat.tolist(), "zeta_hat": zeta_hat.tolist(), "source": drive["source"]}},
    )
    if not args.quiet:
        # the rows end on the range's ends: the spacing is the largest not above --resolution, said when it is less
        spacing = (f"spacing {lut.dy:.4g} m" if lut.dy >= 0.99 * args.resolution else
                   f"spacing {lut.dy:.4g} m (--resolution {args.resolution:g} m rounded down so that the rows end on "
                   "the training range's ends)")
        print(f"LUT {name}: {lut.n} rows x {lut.entries // lut.n} entries = {lut.nbytes} bytes (float32), "
              f"{spacing}; current limit {_limit_text(limit, limit_source)}")
        print(f"f_max = {f_max:g} N from {source}")
        print("worst-case force error vs the exact law: "
              + ", ".join(f"{q} {err.abs[k]:.3g} {'N m' if q == 'z' else 'N'} ({100 * err.rel[k]:.3g} %)"
                          for k, q in enumerate("yxz")))
        print(f"within the bound of {bound[1]}")
        ce = cog_err.law_abs
        print(f"anti-cogging table for a drive with {drive_text}: interpolation {cog_err.interpolation:.3g} N; "
              f"classical + table leaves y {ce[0]:.3g} N, x {ce[1]:.3g} N, z {ce[2]:.3g} N m")
        print(f"wrote {args.out}/{paths[0].name}, {paths[1].name}, {cog_path.name}, results.json")


def _check_table_error(args, model, document, lut, err, f_max, limit, progress) -> tuple[float, str]:
    """Refuse a table whose worst-case Fy error exceeds the model's own standard error or the table's float32
    rounding, whichever is larger (:func:`pgcomm.export.lut.table_error_bound`), naming the coarsest spacing that
    would do (:func:`pgcomm.export.lut.coarsest_resolution_within`). Returns the bound ``(N, what it is)``."""
    # start-up cost: loads JAX only when this runs
    from pgcomm.export.lut import coarsest_resolution_within, grid_rows, table_error_bound

    bound, what = table_error_bound(model, document, f_max)
    if err.abs[0] <= bound:
        return bound, what
    with progress.stage(f"search the coarsest spacing whose table errs at most {bound:.3g} N"):
        h = coarsest_resolution_within(model, bound, f_max, current_limit=limit, start=lut.dy,
                                       start_error=float(err.abs[0]))
    if h is None:
        hint = "no table of at most the rows a drive can hold errs that little: export --format c instead"
    else:
        e = math.floor(math.log10(h)) - 1
        shown = math.floor(h / 10.0**e) * 10.0**e  # two digits, rounded down: finer, so it holds too
        rows = grid_rows(model.training_range, shown)
        hint = (f"use --resolution {shown:.2g} or finer ({rows} rows, {rows * lut.entries // lut.n * 4} bytes "
                "of float32)")
    raise ConfigError(f"--resolution {args.resolution:g} m: the table of {args.model} errs by up to {err.abs[0]:.3g} N "
                      f"in Fy ({100 * err.rel[0]:.3g} % of f_max = {f_max:g} N), more than {what}; {hint}")
