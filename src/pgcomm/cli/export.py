"""``pgcomm export``: a model file's commutation law as generated C code or as a lookup table.

``--format c`` writes ``NAME.h``/``NAME.c`` (:func:`pgcomm.export.c.write_c`);
``--format lut`` writes the law table ``NAME.csv``/``NAME.h`` and the anti-cogging table
``NAME_cogging.csv`` (:mod:`pgcomm.export.lut`) and measures their worst-case force error
on the model. Both write ``results.json``. A model file that fails validation is refused
by the loader (one line, exit code 2, nothing written: the output is staged by
:func:`pgcomm.cli._output.staged_output`).

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

Drive tables: ``--format moteus|odrive|c-angle|sinamics|akd|moog|beckhoff|summit|ioni`` write a compensation
(``--table`` over one revolution, or ``--model`` rotary or linear) in the drive's own table form, read it back
and say what it assumed (:mod:`pgcomm.export.drive_export`); every one needs a current limit, and refuses a table
beyond it. ``--format c-rotary --model`` writes a rotary model's whole law as C99
(:mod:`pgcomm.export.rotary_law`). The law formats ``c`` and ``lut`` are :mod:`pgcomm.export.law_export`.
"""

from __future__ import annotations

import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_out_option, options_given, refuse_conflicts
from pgcomm.defaults import DEFAULT_RESOLUTION
from pgcomm.export.drive_export import LINEAR_FORMATS, TABLE_FORMATS, add_drive_options, export_drive, export_rotary_law
from pgcomm.export.law_export import DEFAULT_F_MAX, export_law, f_max_from_metadata  # noqa: F401  (re-exported)
from pgcomm.export.options import (  # noqa: F401  (the command's option parsing lives beside the exports)
    drive_commutation,
    parse_current_limit,
    parse_per_coil_set,
)

HELP = ("Export a model's commutation law as C code or lookup tables, or a compensation as a drive's own table, "
        "verified against the model.")

#: The formats that read each option (argparse destination); an option the chosen format does not read is
#: refused (:func:`pgcomm.cli._common.refuse_conflicts`). ``--model``/``--table``, ``--name``, ``--current-limit``
#: and ``--quiet`` serve every format (the first two are checked with the input each format needs).
FORMAT_OPTIONS = {
    "torque_constant": ("odrive", "sinamics", "beckhoff"),
    "entries": ("c-angle", "c-rotary", "moog", "summit"),
    "precision": ("c", "c-angle", "c-rotary"),
    "resolution": ("lut",),
    "drive_k": ("c", "lut") + LINEAR_FORMATS,
    "drive_zeta": ("c", "lut") + LINEAR_FORMATS,
    "f_max": ("lut",),
    "force_constant": ("akd", "moog"),
    "pole_pairs": ("summit", "ioni"),
    "directions": ("sinamics",),
    "hysteresis": ("sinamics",),
    "period": ("sinamics",),
    "harmonics": ("beckhoff",),
    "scale": ("moteus",),
    "fade_out": ("moog",),
}


def configure(p) -> None:
    """Options of ``pgcomm export``."""
    p.add_argument("--model", type=Path, metavar="MODEL.json",
                   help="model file (pgcomm identify): for --format c and lut (linear), c-rotary (rotary) and the "
                        "drive tables (rotary or linear)")
    p.add_argument("--table", type=Path, metavar="TABLE.csv",
                   help="compensation table over one revolution (columns angle rad, iq A), for the drive tables")
    p.add_argument("--format", required=True, choices=("c", "lut") + TABLE_FORMATS + ("c-rotary",),
                   help="c: self-contained C99 law; lut: lookup table (CSV + C header) and anti-cogging table; "
                        "c-rotary: a rotary model's whole law as C99; c-angle: C99 lookup of a table by angle; "
                        "moteus, odrive, sinamics, akd, moog, beckhoff, summit, ioni: the drive's own table (see "
                        "docs/drives.md)")
    p.add_argument("--torque-constant", type=float, metavar="NM_PER_A",
                   help="the drive's torque constant (N m/A) for tables in N m (odrive, sinamics, beckhoff); default "
                        "the rotary model's k_t")
    p.add_argument("--entries", type=int, metavar="N",
                   help="table size for c-angle (default the input's), c-rotary (default 16 per period of the "
                        "highest order), moog (250 or 4000, default 4000), summit (required)")
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
    add_drive_options(p)
    add_common_options(p, out=False, plant=False)  # --quiet


def refuse_unused_options(args) -> None:
    """The one conflict rule for ``export``: an option the chosen ``--format`` does not read (:data:`FORMAT_OPTIONS`)
    is an error naming both; then the defaults of ``--precision`` and ``--resolution`` are filled in."""
    for dest, formats in FORMAT_OPTIONS.items():
        if args.format not in formats:
            refuse_conflicts(f"--format {args.format}", options_given(args, dest),
                             f"ignores ({'--' + dest.replace('_', '-')} is for --format {', '.join(formats)})")
    if args.precision is None:
        args.precision = "double"
    if args.resolution is None:
        args.resolution = DEFAULT_RESOLUTION


def run(args, out: Path, progress) -> None:
    """Export a law (``c``, ``lut``, ``c-rotary``) or a drive's table; write ``results.json``."""
    t0 = time.perf_counter()
    refuse_unused_options(args)
    if args.format in TABLE_FORMATS:
        return export_drive(args, out, progress, t0)
    if args.format == "c-rotary":
        return export_rotary_law(args, out, progress, t0)
    return export_law(args, out, progress, t0)
