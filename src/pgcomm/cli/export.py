"""``pgcomm export``: a model file's commutation law as generated C code or as a lookup table.

``--format c`` writes ``NAME.h``/``NAME.c`` (:func:`pgcomm.export.c.write_c`);
``--format lut`` writes the law table ``NAME.csv``/``NAME.h`` and the anti-cogging table
``NAME_cogging.csv`` (:mod:`pgcomm.export.lut`) and measures their worst-case force error
on the model. Both write ``results.json``. A model file that fails validation is refused
by the loader (one line, exit code 2, nothing written: the output is staged by
:func:`pgcomm.cli._common.staged_output`).

Current limit. Every format applies a peak phase current limit (A) by default: the model file's
(``pgcomm identify`` stores the motor description's ``current_limit``;
:func:`pgcomm.io.model.current_limit_of`). ``--current-limit A`` replaces it, ``--current-limit none``
turns it off; a model file without a limit and no ``--current-limit`` is refused with one line.
The files' comment blocks, the printed line and ``results.json`` (``current_limit``,
``current_limit_source``) say the limit and where it came from.

Drive commutation. The anti-cogging table is computed for the drive's own classical commutation
``k̂^l`` (N/A), ``ζ̂^l`` (rad) (:func:`pgcomm.export.lut.build_cogging_table`): ``--drive-k``,
``--drive-zeta`` (one value, or one per coil set, comma-separated), else the model file's ``drive``
entry (the motor description's ``[nominal]`` values the data were recorded with, or the calibrated
values of ``pgcomm fleet``), else the fit to the model's fundamental
(:func:`pgcomm.export.lut.classical_parameters`). The values and their source are written into the
table's comment lines, printed and stored in ``results.json`` (``cogging_table.drive``). With
``--format c`` the same values (when given or recorded) are embedded as ``NAME_drive_k_hat``,
``NAME_drive_zeta_hat`` for ``NAME_drive_inputs``.

Rotary drives: ``--format moteus|odrive|c-angle --table TABLE.csv`` export a compensation
table over one mechanical revolution (columns ``angle`` rad, ``iq`` A; :mod:`pgcomm.export.angle_table`)
instead of a model file: ``moteus`` writes ``NAME.cfg``, the ``conf set motor.cogging_dq_scale`` /
``motor.cogging_dq_comp.<i>`` lines for ``moteus_tool --write-config`` (:mod:`pgcomm.export.moteus`);
``odrive`` writes ``NAME.json``, the 3600-entry ``cogging_map`` (N·m) of ODrive's open firmware 0.5.x,
which needs ``--torque-constant`` and which stock firmware cannot load (:mod:`pgcomm.export.odrive`);
``c-angle`` writes ``NAME.h``, a safe C99 lookup by mechanical angle (:mod:`pgcomm.export.angle_lut`;
``--entries`` resamples). Every table format needs a current limit: the table's ``# current_limit`` line,
``--current-limit A`` or ``--current-limit none``; a table with an entry beyond it (beyond 10 kA with ``none``)
is refused, since the drive would clip it (:func:`pgcomm.export.angle_table.check_within_limit`). Each prints and stores in ``results.json`` its resampling and
quantisation error (RMS and max, A) and the assumptions it rests on.

``--format c-rotary --model MODEL.json`` exports a rotary model file (``pgcomm identify`` on a rotary motor)
as the whole law in C99, ``NAME.h``: cogging, the direction-dependent drag and the torque-constant ripple
that divides the demand, which no drive table can apply (:mod:`pgcomm.export.rotary_law`; ``--entries``
sets the table size, default 16 per period of the model's highest order; the limit as for ``c``).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_out_option, options_given, refuse_conflicts
from pgcomm.errors import ConfigError

HELP = "Export a model's commutation law as C code or a lookup table, verified against the model."

#: ``--f-max`` when the model's metadata has no training force (N).
DEFAULT_F_MAX = 100.0

#: Formats made from a compensation table over one revolution (``--table``), not a model file.
TABLE_FORMATS = ("moteus", "odrive", "c-angle")

#: The formats that read each option (argparse destination); an option the chosen format does not read is
#: refused (:func:`pgcomm.cli._common.refuse_conflicts`). ``--model``/``--table``, ``--name``, ``--current-limit``
#: and ``--quiet`` serve every format (the first two are checked with the input each format needs).
FORMAT_OPTIONS = {
    "torque_constant": ("odrive",),
    "entries": ("c-angle", "c-rotary"),
    "precision": ("c", "c-angle", "c-rotary"),
    "resolution": ("lut",),
    "drive_k": ("c", "lut"),
    "drive_zeta": ("c", "lut"),
    "f_max": ("lut",),
}

#: Default ``--name`` per format.
DEFAULT_NAMES = {"c": "pgcomm_law", "lut": "pgcomm_lut", "moteus": "pgcomm_moteus", "odrive": "pgcomm_odrive",
                 "c-angle": "pgcomm_angle_lut", "c-rotary": "pgcomm_rotary_law"}


def configure(p) -> None:
    """Options of ``pgcomm export``."""
    from pgcomm.defaults import DEFAULT_RESOLUTION

    p.add_argument("--model", type=Path, metavar="MODEL.json",
                   help="model file (pgcomm identify); for --format c and lut, and a rotary one for c-rotary")
    p.add_argument("--table", type=Path, metavar="TABLE.csv",
                   help="compensation table over one revolution (columns angle rad, iq A); for --format moteus, "
                        "odrive and c-angle")
    p.add_argument("--format", required=True, choices=("c", "lut") + TABLE_FORMATS + ("c-rotary",),
                   help="c: self-contained C99 law; lut: lookup table (CSV + C header) and anti-cogging table; "
                        "moteus: conf set lines of motor.cogging_dq_comp; odrive: ODrive 0.5.x cogging_map (JSON); "
                        "c-angle: C99 lookup of the table by mechanical angle; c-rotary: a rotary model's whole "
                        "law (cogging, drag, ripple) as C99")
    p.add_argument("--torque-constant", type=float, metavar="NM_PER_A",
                   help="the ODrive's motor.config.torque_constant (N m/A), for --format odrive (its map is in N m)")
    p.add_argument("--entries", type=int, metavar="N",
                   help="table size for --format c-angle (default: the input table's) and c-rotary (default: 16 "
                        "per period of the model's highest order)")
    add_out_option(p)
    p.add_argument("--precision", choices=("double", "single"),
                   help="C scalar type for --format c, c-angle and c-rotary (default double)")
    p.add_argument("--resolution", type=float, metavar="M",
                   help=f"largest table spacing in m for --format lut (default {DEFAULT_RESOLUTION:g} m); a table "
                        "whose worst-case force error exceeds the model's own standard error is refused, with the "
                        "coarsest spacing that would do")
    p.add_argument("--name", help="C identifier for file names and symbols "
                                  "(default pgcomm_law for c, pgcomm_lut for lut)")
    p.add_argument("--current-limit", metavar="A|none",
                   help="peak phase current limit (A) applied by the exported law; default: the model file's "
                        "(the motor description's current_limit); 'none' exports without a limit")
    p.add_argument("--drive-k", metavar="K[,K...]",
                   help="the drive's classical commutation constant k_hat (N/A), one value or one per coil set: "
                        "the anti-cogging table is computed for it (default: the model file's drive values, "
                        "else the fit to the model's fundamental)")
    p.add_argument("--drive-zeta", metavar="Z[,Z...]",
                   help="the drive's commutation phase offset zeta_hat (rad), one value or one per coil set "
                        "(default as --drive-k)")
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


def parse_current_limit(text: str | None) -> tuple[float | None, bool]:
    """``--current-limit``: ``(limit in A or None, given)``; ``"none"`` turns the limit off.

    Raises:
        ConfigError: anything but a plausible positive current in A or ``none`` (one line naming the value).
    """
    if text is None:
        return None, False
    if text.strip().lower() == "none":
        return None, True
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and 0 < v <= 1e4):
        raise ConfigError(f"--current-limit {text}: expected a peak phase current in A (0 < A <= 10000, e.g. 10) "
                          "or none to export without a limit")
    return v, True


def parse_per_coil_set(text: str | None, option: str, key: str, n_coil_sets: int):
    """``--drive-k`` / ``--drive-zeta``: one value or ``n_coil_sets`` comma-separated values, as an ``(L,)`` array.

    ``key`` is ``"k"`` (N/A, positive) or ``"zeta"`` (rad); values outside the motor TOML's plausible
    range (:data:`pgcomm.io.config.PLAUSIBLE`, e.g. a ``zeta`` in degrees) are refused with a hint.
    """
    import numpy as np

    from pgcomm.io.config import _plausible

    if text is None:
        return None
    parts = [t.strip() for t in text.split(",")]
    unit = "N/A" if key == "k" else "rad"
    try:
        values = [float(t) for t in parts]
    except ValueError:
        raise ConfigError(f"{option} {text}: expected numbers in {unit}, one or one per coil set "
                          f"({n_coil_sets}), comma-separated") from None
    if len(values) not in (1, n_coil_sets):
        raise ConfigError(f"{option} {text}: {len(values)} values for a model with {n_coil_sets} coil sets "
                          f"(give one value or {n_coil_sets})")
    for l, v in enumerate(values):
        _plausible(v, key, f"{option} {text}", f"coil set {l + 1}" if len(values) > 1 else "value")
    return np.broadcast_to(np.asarray(values, dtype=float), (n_coil_sets,)).copy()


def _fmt_values(a) -> str:
    return ", ".join(f"{x:.6g}" for x in a)


def drive_commutation(args, model, metadata) -> dict:
    """The drive's ``k̂`` (N/A), ``ζ̂`` (rad) per coil set and where each came from (see the module docstring).

    Returns:
        ``{"k_hat": (L,), "zeta_hat": (L,), "source": str, "given": bool}``; ``given`` is true when the
        values are the user's or the model file's (not the fit to the model's fundamental).
    """
    from pgcomm.export.lut import classical_parameters
    from pgcomm.io.model import drive_of

    L = model.n_coil_sets
    k = parse_per_coil_set(args.drive_k, "--drive-k", "k", L)
    z = parse_per_coil_set(args.drive_zeta, "--drive-zeta", "zeta", L)
    recorded = drive_of(metadata, args.model, L)
    if recorded is not None:
        k0, z0, src0 = recorded[0], recorded[1], f"the model file: {recorded[2]}"
    else:
        k0, z0 = classical_parameters(model)
        src0 = "fitted to the model's fundamental (the model file records no drive commutation)"
    parts = []
    if k is not None and z is not None:
        parts = ["--drive-k, --drive-zeta"]
    elif k is not None:
        parts, z = [f"k_hat from --drive-k, zeta_hat {src0}"], z0
    elif z is not None:
        parts, k = [f"zeta_hat from --drive-zeta, k_hat {src0}"], k0
    else:
        k, z, parts = k0, z0, [src0]
    return {"k_hat": k, "zeta_hat": z, "source": parts[0],
            "given": recorded is not None or args.drive_k is not None or args.drive_zeta is not None}


def refuse_unused_options(args) -> None:
    """The one conflict rule for ``export``: an option the chosen ``--format`` does not read (:data:`FORMAT_OPTIONS`)
    is an error naming both; then the defaults of ``--precision`` and ``--resolution`` are filled in."""
    from pgcomm.defaults import DEFAULT_RESOLUTION

    for dest, formats in FORMAT_OPTIONS.items():
        if args.format not in formats:
            refuse_conflicts(f"--format {args.format}", options_given(args, dest),
                             f"ignores ({'--' + dest.replace('_', '-')} is for --format {', '.join(formats)})")
    if args.precision is None:
        args.precision = "double"
    if args.resolution is None:
        args.resolution = DEFAULT_RESOLUTION


def run(args, out: Path, progress) -> None:
    """Export ``--model`` as C (``NAME.h/.c``) or lookup tables; write ``results.json``."""
    from pgcomm.io.model import current_limit_of, load_model
    from pgcomm.io.results import write_results

    t0 = time.perf_counter()
    refuse_unused_options(args)
    if args.format in TABLE_FORMATS:
        return _export_table(args, out, progress, t0)
    if args.format == "c-rotary":
        return _export_rotary_law(args, out, progress, t0)
    if args.model is None:
        raise ConfigError(f"--format {args.format} exports a model file: give --model MODEL.json")
    if args.table is not None:
        raise ConfigError(f"--table is for --format {', '.join(TABLE_FORMATS)}; --format {args.format} exports "
                          "--model")
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


def _limit_text(limit, source) -> str:
    return f"{limit:g} A ({source})" if limit is not None else f"none ({source})"


def _export_c(args, out, progress, model, metadata, name, results, limit, limit_source, drive):
    from pgcomm.export.c import write_c

    meta = {**metadata, "source": str(args.model)}
    # the drive's constants are embedded only when known (given or recorded), not the fit's
    embed = (drive["k_hat"], drive["zeta_hat"]) if drive["given"] else None
    with progress.stage(f"generate C ({args.precision} precision)"):
        try:
            # a spline file's mechanics travel with it: the feedforward is exported beside the law
            paths = write_c(model, out, name=name, precision=args.precision, metadata=meta,
                            current_limit=limit, mechanics=metadata.get("mechanics"), limit_source=limit_source,
                            drive=embed, drive_source=drive["source"] if embed else None)
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


def _entries_name_limit(args) -> tuple[str, float | None, bool]:
    """``--entries`` checked, ``--name`` (default per format) checked as a C identifier, ``--current-limit`` parsed:
    ``(name, limit, limit_given)``."""
    if args.entries is not None and not 8 <= args.entries <= 1 << 20:
        raise ConfigError(f"--entries {args.entries}: expected a table size from 8 to {1 << 20}")
    return (_c_name(args), *parse_current_limit(args.current_limit))


def _c_name(args) -> str:
    """``--name`` (default per format), checked as a C identifier prefix."""
    from pgcomm.export.c import check_c_name

    name = args.name or DEFAULT_NAMES[args.format]
    try:
        check_c_name(name)
    except ValueError as e:
        raise ConfigError(f"--name: {e}") from None
    return name


def _export_table(args, out, progress, t0) -> None:
    """``--format moteus|odrive|c-angle``: a compensation table over one revolution for a rotary drive."""
    from pgcomm.export.angle_table import check_within_limit, read_angle_table
    from pgcomm.io.results import write_results

    if args.table is None:
        raise ConfigError(f"--format {args.format} exports a compensation table: give --table TABLE.csv "
                          "(columns angle in rad, iq in A, one revolution)")
    if args.model is not None:
        raise ConfigError(f"--format {args.format} exports --table, not --model (a model file's law: --format c or lut)")
    k = args.torque_constant
    if args.format == "odrive" and k is None:
        raise ConfigError("--format odrive needs --torque-constant NM_PER_A, the ODrive's "
                          "motor.config.torque_constant (its cogging_map is in N m: entry = k_t x iq_comp)")
    if k is not None and not (math.isfinite(k) and 0 < k <= 1e3):
        raise ConfigError(f"--torque-constant {k:g}: expected the motor's torque constant in N m/A (0 < k_t <= 1000)")
    name, limit, limit_given = _entries_name_limit(args)
    table = read_angle_table(args.table)
    if limit_given:
        limit_source = "--current-limit" if limit is not None else "turned off with --current-limit none"
    elif table.current_limit is not None:
        limit, limit_source = table.current_limit, f"{args.table} (# current_limit, the motor description's)"
    else:
        raise ConfigError(f"{args.table}: the table records no current limit; give --current-limit A, the drive's "
                          f"q-current limit, or --current-limit none to export {args.format} without a limit")
    # an entry beyond the limit would be clipped: refused, beyond half the drive's step for moteus' int8 entries
    slack = 0.5 * limit / 127 if (args.format == "moteus" and limit is not None) else 0.0
    check_within_limit(table, limit, slack, limit_source)
    provenance = [f"input table {args.table} ({table.n} entries)", *table.comments]
    results = {"command": "export", "format": args.format, "table": str(args.table), "table_entries": table.n,
               "name": name, "current_limit": limit, "current_limit_source": limit_source}
    with progress.stage(f"{args.format} table from {table.n} entries"):
        if args.format == "moteus":
            path, figures, lines = _moteus(table, out, name, limit)
        elif args.format == "odrive":
            path, figures, lines = _odrive(args, table, out, name, limit, provenance)
        else:
            path, figures, lines = _c_angle(args, table, out, name, limit, limit_source, provenance)
    results.update(files=[path.name], **{args.format.replace("-", "_"): figures})
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
        for line in lines:
            print(line)
        print(f"wrote {args.out}/{path.name}, results.json")


def _moteus(table, out, name, limit):
    from pgcomm.export.moteus import build_moteus, write_moteus

    mt = build_moteus(table, current_limit=limit)
    path = write_moteus(mt, out / f"{name}.cfg")
    t, i = mt.total, mt.interpolation
    lines = [f"moteus: 1024 int8 entries, motor.cogging_dq_scale = {mt.scale:.6g} A/LSB; int8 quantisation max "
             f"{mt.quantisation:.3g} A (bound scale/2 = {0.5 * mt.scale:.3g} A), RMS {mt.quantisation_rms:.3g} A",
             f"drive's linear interpolation vs the input table: RMS {t.rms:.3g} A, max {t.max:.3g} A "
             f"(resampling alone: RMS {i.rms:.3g} A, max {i.max:.3g} A)"
             + (f"; {mt.clipped} entries clipped at {limit:g} A" if mt.clipped else ""),
             "assumes: " + "; ".join(mt.assumptions),
             f"load with: python -m moteus.moteus_tool --target ID --write-config {path.name}, then conf write"]
    return path, mt.as_dict(), lines


def _odrive(args, table, out, name, limit, provenance):
    from pgcomm.export.odrive import ASSUMPTIONS, build_odrive, write_odrive

    k = args.torque_constant
    om = build_odrive(table, k, current_limit=limit)
    path = write_odrive(om, out / f"{name}.json", provenance)
    p, n = om.positive, om.negative
    lines = [f"ODrive 0.5.x cogging_map: 3600 float32 entries in N m (k_t = {k:g} N m/A); zero-order hold vs the input "
             f"table: RMS {p.rms:.3g} A, max {p.max:.3g} A (negative positions: RMS {n.rms:.3g} A, max {n.max:.3g} A)"
             + (f"; {om.clipped} entries clipped at {limit:g} A" if om.clipped else ""),
             "NOT loadable by stock ODrive firmware (cogging_map has no protocol entry in 0.5.x); see the JSON",
             "assumes: " + "; ".join(ASSUMPTIONS[:3])]
    return path, om.as_dict(), lines


def _export_rotary_law(args, out, progress, t0) -> None:
    """``--format c-rotary --model MODEL.json``: the whole rotary law as C99 (module docstring)."""
    from pgcomm.export.rotary_law import build_rotary_law, write_rotary_law
    from pgcomm.io.results import write_results

    if args.model is None:
        raise ConfigError("--format c-rotary exports a rotary model file: give --model MODEL.json (pgcomm identify "
                          "on a rotary motor)")
    if args.table is not None:
        raise ConfigError("--format c-rotary exports --model, not --table (a table's formats: "
                          f"{', '.join(TABLE_FORMATS)})")
    name, limit, limit_given = _entries_name_limit(args)
    from pgcomm.io.model import load_rotary_model

    model = load_rotary_model(args.model)
    if limit_given:
        limit_source = "--current-limit" if limit is not None else "turned off with --current-limit none"
    else:
        recorded = model.info.get("current_limit")
        if recorded is None:
            raise ConfigError(f"{args.model}: the model file records no current limit (its motor description had "
                              "no current_limit); give --current-limit A, the drive's q-current limit, or "
                              "--current-limit none to export a law without a limit")
        limit, limit_source = float(recorded), "from the model file"
    try:
        tables = build_rotary_law(model, args.entries, args.precision, limit, str(args.model))
    except ValueError as e:
        raise ConfigError(f"{args.model}: {e}") from None
    with progress.stage(f"c-rotary law from {args.model}: {tables.n} entries per map"):
        path = write_rotary_law(tables, out / f"{name}.h", name, limit_source,
                                [f"model file {args.model} ({model.info.get('motor', 'rotary motor')})"])
    results = {"command": "export", "format": "c-rotary", "model": str(args.model), "name": name,
               "current_limit": limit, "current_limit_source": limit_source, "files": [path.name],
               "c_rotary": tables.as_dict(), "runtime_s": time.perf_counter() - t0}
    write_results(out / "results.json", results)
    if not args.quiet:
        e = tables.errors
        print(f"C law {name}: {tables.n} entries per map ({args.precision}, {tables.as_dict()['bytes']} bytes); "
              f"interpolation max: cogging {e['cogging']['max']:.3g} A, drag {e['direction']['max']:.3g} A, gain "
              f"{e['gain']['max']:.3g}; the law vs the model's: max {e['law']['max']:.3g} A; current limit "
              f"{_limit_text(limit, limit_source)}")
        print(f"wrote {args.out}/{path.name}, results.json")


def _c_angle(args, table, out, name, limit, limit_source, provenance):
    from pgcomm.export.angle_lut import build_angle_lut, write_angle_lut

    lut = build_angle_lut(table, args.entries, args.precision, current_limit=limit)
    path = write_angle_lut(lut, out / f"{name}.h", name, limit_source, provenance)
    e = lut.error
    lines = [f"C lookup {name}: {lut.n} entries ({args.precision}), periodic linear interpolation vs the input table: "
             f"RMS {e.rms:.3g} A, max {e.max:.3g} A; current limit {_limit_text(limit, limit_source)}"
             + (f"; {lut.clipped} entries clipped" if lut.clipped else "")]
    return path, lut.as_dict(), lines
