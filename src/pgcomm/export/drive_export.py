"""``pgcomm export --format <drive>``: a compensation into a drive's own table, checked and explained.

The formats and what they take (``--table`` a table file over one revolution, ``--model`` a rotary or a linear
model file):

====================  ===========================================  ===============  ====================
format                what is written                              input            motors
====================  ===========================================  ===============  ====================
``moteus``            ``conf set`` lines (:mod:`.moteus`)          table, rotary    rotary
``odrive``            0.5.x ``cogging_map`` JSON (:mod:`.odrive`)  table, rotary    rotary
``c-angle``           C99 lookup (:mod:`.angle_lut`)               table            rotary
``sinamics``          parameter-write script (:mod:`.sinamics`)    all              rotary, linear
``akd``               keyword script (:mod:`.akd`)                 all              rotary, linear
``moog``              parameter listing (:mod:`.moog`)             all              rotary, linear
``beckhoff``          CoE object list (:mod:`.beckhoff`)           all              rotary, linear
``summit``            register list (:mod:`.summit`)               table, rotary    rotary
``ioni``              TRF/TRA settings (:mod:`.ioni`)              table, rotary    rotary
====================  ===========================================  ===============  ====================

Each export reads its own file back and refuses it (one line, nothing written) when it differs from the
table meant by more than the drive's quantisation; prints what the drive's resolution loses against the
compensation between its entries; and says what it assumed and how to load the file. The compensation
itself is :mod:`pgcomm.export.compensation`.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

from pgcomm.errors import ConfigError, DataError
from pgcomm.export import akd, beckhoff, compensation as cs, ioni, moog, sinamics, summit
from pgcomm.export.angle_lut import build_angle_lut, write_angle_lut
from pgcomm.export.angle_table import check_within_limit, read_angle_table
from pgcomm.export.drive_common import parse_pair
from pgcomm.export.moteus import build_moteus, write_moteus
from pgcomm.export.odrive import ASSUMPTIONS, build_odrive, WORKAROUNDS, write_odrive
from pgcomm.export.options import c_name, drive_commutation, entries_name_limit, fmt_values, limit_text, \
    parse_current_limit
from pgcomm.export.rotary_law import build_rotary_law, write_rotary_law
from pgcomm.io.results import write_results
from pgcomm.io.rotary_model import load_rotary_model

__all__ = ["TABLE_FORMATS", "DRIVE_FORMATS", "LINEAR_FORMATS", "add_drive_options", "export_drive",
           "export_rotary_law"]

#: Formats written from a compensation (``--table`` or ``--model``), not the C law of a model.
TABLE_FORMATS = ("moteus", "odrive", "c-angle", "sinamics", "akd", "moog", "beckhoff", "summit", "ioni")

#: The industrial drives' formats of this module.
DRIVE_FORMATS = ("sinamics", "akd", "moog", "beckhoff", "summit", "ioni")

#: Formats that serve linear motors too.
LINEAR_FORMATS = ("sinamics", "akd", "moog", "beckhoff")

TITLES = {"sinamics": "SINAMICS S120", "akd": "Kollmorgen AKD", "moog": "Moog MSD", "beckhoff": "Beckhoff AX8000",
          "summit": "Novanta Summit", "ioni": "Granite Devices IONI"}

LOAD = {
    "sinamics": "load: write the p-parameters with the commissioning tool (expert list), then activate the compensation "
                "as section 8.15 describes and save (copy RAM to ROM)",
    "akd": "load: send the lines to the drive (WorkBench terminal) with the drive disabled; or import the table in "
           "WorkBench's Cogging Compensation view",
    "moog": "load: write the parameters with DriveAdministrator or your fieldbus, activate with P 382 > 0, save",
    "beckhoff": "load: add the objects to the axis' start-up list in TwinCAT (0x32CB:01 = 3 reads them from there)",
    "summit": "load: write the registers in order (MotionLab3 or your fieldbus), then 'store all'",
    "ioni": "load: set TRF1/TRA1 and TRF2/TRA2 in Granity as listed, then save the settings",
}


def add_drive_options(p) -> None:
    """The drive formats' options of ``pgcomm export``."""
    p.add_argument("--pole-pairs", type=int, metavar="P",
                   help="pole pairs, for --format summit and ioni from a --table (a rotary model records them)")
    p.add_argument("--force-constant", type=float, metavar="N_PER_A",
                   help="the drive's force constant (N/A) turning a linear table into A (akd, moog); default the "
                        "drive's k_hat: sum(k_hat^2)/max(k_hat)")
    p.add_argument("--directions", type=int, default=None, choices=(1, 2),
                   help="sinamics: 1 table (forward/reverse average, default) or 2 (one per direction, p5250.1 = 1; "
                        "needs a model with a direction term)")
    p.add_argument("--hysteresis", type=float, metavar="V",
                   help="sinamics: p5256, the speed hysteresis (rpm or m/min) switching the two tables")
    p.add_argument("--period", type=float, metavar="F",
                   help="sinamics: p5253 (rotary: 1/k of a revolution, default 1; linear: pole-pair widths, default "
                        "the model's stroke and two entries)")
    p.add_argument("--harmonics", type=int, metavar="K", help="beckhoff: coefficient sets to write, 1..10 (default 10)")
    p.add_argument("--scale", type=float, metavar="A_PER_LSB",
                   help="moteus: motor.cogging_dq_scale to use (default max|table|/127)")
    p.add_argument("--fade-out", metavar="START,END",
                   help="moog: P 447[3]/[4], the speeds (rpm) where the compensation starts and ends fading out")


def _read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as e:
        raise DataError(f"{path}: not a JSON model file ({' '.join(str(e).split())[:200]})") from None


def _is_rotary_model(path) -> bool:
    """Whether ``path`` is a rotary model file (a linear one is a ``.json`` + ``.npz`` pair)."""
    p = Path(path)
    p = p if p.suffix == ".json" else p.with_suffix(".json")
    if not p.is_file():
        return False
    doc = _read_json(p)
    return isinstance(doc, dict) and doc.get("schema") == "pgcomm.rotary_model"


def _limit(args, recorded, source_text, what):
    """``(limit A or None, source)`` from --current-limit, else the input's record; neither: one line (every table
    format needs a limit, as :mod:`pgcomm.cli.export` says)."""
    limit, given = parse_current_limit(args.current_limit)
    if given:
        return limit, "--current-limit" if limit is not None else "turned off with --current-limit none"
    if recorded is not None:
        return float(recorded), source_text
    raise ConfigError(f"{what} records no current limit; give --current-limit A, the drive's q-current limit, or "
                      f"--current-limit none to export {args.format} without a limit")


def _source(args):
    """The :class:`~pgcomm.export.compensation.Compensation` of ``--table`` or ``--model`` and the torque
    constant a rotary model records."""
    if args.table is not None and args.model is not None:
        raise ConfigError(f"--format {args.format}: give --table TABLE.csv or --model MODEL.json, not both")
    if args.table is None and args.model is None:
        raise ConfigError(f"--format {args.format} exports a compensation: give --table TABLE.csv (angle rad, iq A, one "
                          "revolution) or --model MODEL.json (a rotary or linear model file)")
    if args.table is not None:
        table = read_angle_table(args.table)
        limit, src = _limit(args, table.current_limit, f"{args.table} (# current_limit, the motor description's)",
                            f"{args.table}: the table")
        # an entry beyond the limit would be clipped: refused, beyond half the drive's step for moteus' int8 entries
        slack = 0.5 * limit / 127 if (args.format == "moteus" and limit is not None) else 0.0
        check_within_limit(table, limit, slack, src)
        return cs.from_angle_table(table, args.pole_pairs, limit, src), None, table
    if _is_rotary_model(args.model):
        model = load_rotary_model(args.model)
        limit, src = _limit(args, model.info.get("current_limit"), "from the model file",
                            f"{args.model}: the model file")
        return cs.from_rotary_model(model, limit, src, str(args.model)), model.k_t, None
    if args.format not in LINEAR_FORMATS:
        raise ConfigError(f"{args.model} is a linear model; --format {args.format} holds a table over a rotor's "
                          f"revolution (linear motors: --format {', '.join(LINEAR_FORMATS)})")
    from pgcomm.io.model import current_limit_of, load_model  # start-up cost: loads JAX only when this runs

    model, document = load_model(args.model)
    limit, src = _limit(args, current_limit_of(document, args.model), "from the model file",
                        f"{args.model}: the model file")
    drive = drive_commutation(args, model, document)
    text = (f"k_hat = {fmt_values(drive['k_hat'])} N/A, zeta_hat = {fmt_values(drive['zeta_hat'])} rad "
            f"({drive['source']})")
    comp = cs.from_linear_model(model, drive["k_hat"], drive["zeta_hat"], limit, src, str(args.model), text)
    return comp, None, None


def export_drive(args, out: Path, progress, t0: float) -> None:
    """``--format moteus|odrive|c-angle|sinamics|akd|moog|beckhoff|summit|ioni`` (module docstring)."""
    if args.format == "c-angle" and args.model is not None:
        raise ConfigError("--format c-angle exports --table, not --model (a rotary model's whole law: --format c-rotary)")
    if args.entries is not None and not 8 <= args.entries <= 1 << 20:
        raise ConfigError(f"--entries {args.entries}: expected a table size from 8 to {1 << 20}")
    for opt, unit in (("torque_constant", "N m/A"), ("force_constant", "N/A")):
        v = getattr(args, opt)
        if v is not None and not (math.isfinite(v) and 0 < v <= 1e4):
            raise ConfigError(f"--{opt.replace('_', '-')} {v:g}: expected the drive's constant in {unit} (0 < k <= 1e4)")
    if args.pole_pairs is not None and not 1 <= args.pole_pairs <= 1000:
        raise ConfigError(f"--pole-pairs {args.pole_pairs}: expected a pole-pair number from 1 to 1000")
    name = c_name(args)
    if args.format == "odrive" and args.torque_constant is None and args.model is None:
        raise ConfigError("--format odrive needs --torque-constant NM_PER_A, the ODrive's "
                          "motor.config.torque_constant (its cogging_map is in N m: entry = k_t x iq_comp)")
    comp, k_t_recorded, table = _source(args)
    cs.check_compensation(comp, 0.5 * comp.limit / 127 if (args.format == "moteus" and comp.limit) else 0.0)
    k_t = args.torque_constant if args.torque_constant is not None else k_t_recorded
    provenance = [f"input {comp.source}" + (f" ({table.n} entries)" if table is not None else ""),
                  *comp.comments] + ([f"drive commutation: {comp.drive}"] if comp.drive else [])
    results = {"command": "export", "format": args.format, "input": comp.source, "kind": comp.kind, "name": name,
               "current_limit": comp.limit if comp.unit == "A" else None, "current_limit_source": comp.limit_source}
    if table is not None:
        results.update(table=str(args.table), table_entries=table.n)
    # no progress stage: the builds take seconds, and a refused input must print exactly one line
    if args.format == "moteus":
        path, figures, lines = _moteus(args, comp, out, name)
    elif args.format == "odrive":
        path, figures, lines = _odrive(args, comp, k_t, out, name, provenance)
    elif args.format == "c-angle":
        path, figures, lines = _c_angle(args, table, comp, out, name, provenance)
    else:
        path, figures, lines = _industrial(args, comp, k_t, out, name, provenance)
    results.update(files=[path.name], **{args.format.replace("-", "_"): figures})
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
        for line in lines:
            print(line)
        print(f"wrote {args.out}/{path.name}, results.json")


def _limit_text(limit, source) -> str:
    return f"{limit:g} A ({source})" if limit is not None else f"none ({source})"


def _moteus(args, comp, out, name):
    mt = build_moteus(comp, scale=args.scale)
    path = write_moteus(mt, out / f"{name}.cfg")
    t, i = mt.total, mt.interpolation
    lines = [f"moteus: 1024 int8 entries, motor.cogging_dq_scale = {mt.scale:.6g} A/LSB; int8 quantisation max "
             f"{mt.quantisation:.3g} A (bound scale/2 = {0.5 * mt.scale:.3g} A), RMS {mt.quantisation_rms:.3g} A",
             f"drive's linear interpolation vs the input table: RMS {t.rms:.3g} A, max {t.max:.3g} A "
             f"(resampling alone: RMS {i.rms:.3g} A, max {i.max:.3g} A)"
             + (f"; {mt.clipped} entries clipped at {mt.current_limit:g} A" if mt.clipped else ""),
             "assumes: " + "; ".join(mt.assumptions),
             "applies in the position family of modes only (position, zero velocity, stay within bounds): command "
             "torque through position mode with kp = kd = 0",
             f"load with: python -m moteus.moteus_tool --target ID --write-config {path.name}, then conf write"]
    return path, mt.to_dict(), lines


def _odrive(args, comp, k_t, out, name, provenance):
    if k_t is None:
        raise ConfigError("--format odrive needs --torque-constant NM_PER_A, the ODrive's "
                          "motor.config.torque_constant (its cogging_map is in N m: entry = k_t x iq_comp)")
    om = build_odrive(comp, k_t)
    path = write_odrive(om, out / f"{name}.json", provenance)
    p, n = om.positive, om.negative
    lines = [f"ODrive 0.5.x cogging_map: 3600 float32 entries in N m (k_t = {k_t:g} N m/A); zero-order hold vs the input "
             f"table: RMS {p.rms:.3g} A, max {p.max:.3g} A (negative positions: RMS {n.rms:.3g} A, max {n.max:.3g} A)"
             + (f"; {om.clipped} entries clipped at {om.current_limit:g} A" if om.clipped else ""),
             "NOT loadable by stock ODrive firmware: 0.5.x has no command that writes cogging_map "
             "(odrive-interface.yaml exposes only get_anticogging_value). Ways around it:",
             *(f"  - {w}" for w in WORKAROUNDS),
             "assumes: " + "; ".join(ASSUMPTIONS[:3])]
    return path, om.to_dict(), lines


def _c_angle(args, table, comp, out, name, provenance):
    lut = build_angle_lut(table, args.entries, args.precision, current_limit=comp.limit)
    path = write_angle_lut(lut, out / f"{name}.h", name, comp.limit_source, provenance)
    e = lut.error
    lines = [f"C lookup {name}: {lut.n} entries ({args.precision}), periodic linear interpolation vs the input table: "
             f"RMS {e.rms:.3g} A, max {e.max:.3g} A; current limit {_limit_text(comp.limit, comp.limit_source)}"
             + (f"; {lut.clipped} entries clipped" if lut.clipped else "")]
    return path, lut.to_dict(), lines


def _industrial(args, comp, k_t, out, name, provenance):
    """SINAMICS, AKD, Moog, Beckhoff, Summit, IONI: build, write, read back; the printed lines."""
    f = args.format
    path = out / f"{name}.txt"
    if f == "sinamics":
        directions = args.directions or 1
        if directions == 2 and not comp.directional:
            raise ConfigError(f"--directions 2: {comp.source} has no direction term (a table file holds the "
                              "forward/reverse average); give a model identified with one, or --directions 1")
        tab = sinamics.write_sinamics(sinamics.build_sinamics(comp, k_t, directions, args.period, args.hysteresis),
                                      path, provenance)
        what = (f"{tab.directions} table{'s' if tab.directions == 2 else ''} x {sinamics.ENTRIES} entries in {tab.unit} "
                f"over {tab.period:.6g} {'rad' if comp.rotary else 'm'} (p5253 = {tab.factor:.6g})")
        res = "; ".join(f"{k} RMS {v.rms:.3g}, max {v.max:.3g}" for k, v in tab.resolution.items())
        assumed = sinamics.ASSUMED
    elif f == "akd":
        tab = akd.write_akd(akd.build_akd(comp, args.force_constant), path, provenance)
        what = f"{akd.ENTRIES} feedforward currents in A ({tab.conversion})"
        res = f"RMS {tab.resolution.rms:.3g}, max {tab.resolution.max:.3g}"
        assumed = akd.ASSUMED
    elif f == "moog":
        fade = parse_pair(args.fade_out, "--fade-out", "rpm")
        tab = moog.write_moog(moog.build_moog(comp, args.entries, args.force_constant, fade), path, provenance)
        what = f"{tab.size} q-current feedforward values in A ({tab.conversion})"
        res = f"RMS {tab.resolution.rms:.3g}, max {tab.resolution.max:.3g}"
        assumed = moog.ASSUMED
    elif f == "beckhoff":
        tab = beckhoff.write_beckhoff(beckhoff.build_beckhoff(comp, k_t, args.harmonics), path, provenance)
        kept = ", ".join(str(int(n)) for n in tab.orders)
        what = (f"{tab.orders.size} harmonics (n = {kept} per {'revolution' if comp.rotary else 'pole-pair pitch'}) in "
                f"{tab.unit}; not kept: RMS {tab.dropped:.3g} {tab.unit}")
        res = f"RMS {tab.resolution.rms:.3g}, max {tab.resolution.max:.3g}"
        assumed = beckhoff.ASSUMED
    elif f == "summit":
        tab = summit.write_summit(summit.build_summit(comp, args.entries, args.pole_pairs), path, provenance)
        what = f"{tab.n} entries in A over one electrical revolution (p = {tab.pole_pairs})"
        res = f"RMS {tab.resolution.rms:.3g}, max {tab.resolution.max:.3g}"
        assumed = summit.ASSUMED
    else:
        tab = ioni.write_ioni(ioni.build_ioni(comp, args.pole_pairs), path, provenance)
        c, r = tab.cogging, tab.ripple
        what = ("TRF1/TRA1 " + (f"N = {c.n}, {c.amplitude:.4g} A" if c else "off") + "; TRF2/TRA2 "
                + (f"N = {r.n}, depth {r.amplitude:.4g}" if r else "off (no ripple in the input)"))
        res = f"RMS {tab.resolution.rms:.3g}, max {tab.resolution.max:.3g}"
        assumed = ioni.ASSUMED
    unit = getattr(tab, "unit", "A")
    limit = f"{tab.limit:.6g} {unit} ({comp.limit_source})" if tab.limit is not None else f"none ({comp.limit_source})"
    lines = [f"{TITLES[f]}: {what}; limit {limit}",
             f"what the drive applies vs the compensation (between entries, on the model's span): {res} {unit}",
             tab.round_trip.line(), "assumes: " + "; ".join(assumed), LOAD[f]]
    return path, tab.to_dict(), lines


def export_rotary_law(args, out, progress, t0) -> None:
    """``--format c-rotary --model MODEL.json``: the whole rotary law as C99 (:mod:`pgcomm.export.rotary_law`)."""
    if args.model is None:
        raise ConfigError("--format c-rotary exports a rotary model file: give --model MODEL.json (pgcomm identify "
                          "on a rotary motor)")
    if args.table is not None:
        raise ConfigError("--format c-rotary exports --model, not --table (a table's formats: "
                          f"{', '.join(TABLE_FORMATS)})")
    name, limit, limit_given = entries_name_limit(args)
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
               "c_rotary": tables.to_dict(), "runtime_s": time.perf_counter() - t0}
    write_results(out / "results.json", results)
    if not args.quiet:
        e = tables.errors
        print(f"C law {name}: {tables.n} entries per map ({args.precision}, {tables.to_dict()['bytes']} bytes); "
              f"interpolation max: cogging {e['cogging']['max']:.3g} A, drag {e['direction']['max']:.3g} A, gain "
              f"{e['gain']['max']:.3g}; the law vs the model's: max {e['law']['max']:.3g} A; current limit "
              f"{limit_text(limit, limit_source)}")
        print(f"wrote {args.out}/{path.name}, results.json")
