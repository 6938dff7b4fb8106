"""Helpers shared by the command modules: common options, set-up from options, conflicts, tables.

Nothing here computes results; it turns options into library calls and library results
into text. The output folder's checks and staging are :mod:`pgcomm.cli._output`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pgcomm.errors import ConfigError, PgcommError
from pgcomm.io.config import load_experiment, load_motor, load_toml, motor_kind
from pgcomm.io.logs import load_column_mapping, read_logs
from pgcomm.io.references import read_reference

# Imports inside the functions below: the set-up's modules load JAX and SciPy only when a command builds one;
# `import pgcomm.cli` loads none of them (`--help` and a bad option answer at once).


def add_common_options(p: argparse.ArgumentParser, out: bool = True, plant: bool = True) -> None:
    """``--out DIR`` (if ``out``), ``--plant/--motor/--config/--seed`` (if ``plant``) and ``--quiet``."""
    if out:
        add_out_option(p)
    if plant:
        p.add_argument("--plant", type=Path, metavar="FORCEMAP.csv",
                       help="force map replacing the twin's electromagnetics (needs --motor)")
        p.add_argument("--motor", type=Path, metavar="MOTOR.toml", help="motor description for --plant")
        p.add_argument("--config", type=Path, metavar="FILE.toml",
                       help="experiment settings (see docs/formats.md); default: config.toml beside --plant, if there")
        p.add_argument("--truth", type=Path, metavar="TRUTH.json",
                       help="the plant's known k, zeta (default: truth.json beside --plant, if there); with a rotary "
                            "--motor, the twin's truth: a zoo truth.json, or identify's model.json (with its "
                            "results.json) to run the experiment on your motor as identified")
        p.add_argument("--seed", type=seed_value, default=0,
                       help="seed for noise and random starts, 0 to 2**32-1 (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def seed_value(text: str) -> int:
    """``--seed``: an integer in ``[0, 2**32 - 1]`` (JAX and NumPy seeds are unsigned 32-bit)."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 0 <= v <= 2**32 - 1:
        raise argparse.ArgumentTypeError(f"{text} is outside 0 to 2**32-1 = {2**32 - 1}; give a smaller seed")
    return v


def add_out_option(p: argparse.ArgumentParser, dest: str = "out", required: bool = True) -> None:
    """``--out DIR`` and ``--overwrite`` (replace a non-empty ``DIR`` as a whole)."""
    p.add_argument("--out", dest=dest, required=required, type=Path, metavar="DIR",
                   help="output folder (created with its parents; must be new or empty unless --overwrite)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a non-empty --out folder as a whole (its old files are deleted on success)")


def add_data_options(p: argparse.ArgumentParser) -> None:
    """``--data`` / ``--columns`` / ``--sample-time`` for commands reading logs."""
    p.add_argument("--data", nargs="+", metavar="LOG", help="log files or globs (CSV, Parquet, .mat, HDF5)")
    p.add_argument("--columns", type=Path, metavar="MAP.toml", help="column-mapping TOML (names and units)")
    p.add_argument("--sample-time", type=float, help="sample time (s) for logs without a t column")


def add_motor_option(p: argparse.ArgumentParser, what: str) -> None:
    """``--motor MOTOR.toml`` for the commands that read a rig's logs without a plant."""
    p.add_argument("--motor", type=Path, metavar="MOTOR.toml",
                   help=f"motor description: pole pitch, coil sets, the drive's k and zeta ({what}); "
                        "default: the twin's nominal motor (k = 67 N/A, zeta = -0.52 rad)")


def add_reference_options(p: argparse.ArgumentParser, help: str) -> None:
    """``--reference FILE`` and ``--reference-sample-time s``."""
    p.add_argument("--reference", type=Path, help=help)
    p.add_argument("--reference-sample-time", type=float, help="sample time (s) of --reference if it has no t")


#: The reading options of a rotary motor's logs on the command line: destination -> how its text reads (an
#: ``"integer"``, a ``"number"`` or comma-separated ``"numbers"``; the words none, held and detect pass as written).
#: Each is the :class:`pgcomm.settings.RotaryIdentifyOptions` field of the same name, which checks the value.
ROTARY_READING = {"current_delay": "integer", "current_lag": "number", "angle_pll": "numbers",
                  "current_noise": "number", "current_filter": "number", "time_lines": "numbers"}


def add_rotary_reading_options(p: argparse.ArgumentParser) -> None:
    """``--current-delay``, ``--current-lag``, ``--angle-pll``, ``--current-noise``, ``--current-filter`` and
    ``--time-lines``: how a rotary drive's logs are read (:data:`ROTARY_READING`), each in place of ``--config``'s
    ``[rotary]`` key of the same name."""
    p.add_argument("--current-delay", metavar="N",
                   help="rotary motors: samples by which the logged q-current lags the current that acted over each "
                        "sample (an integer; default: detected, the fit repeated with the current shifted by -2..2)")
    p.add_argument("--current-lag", metavar="L|held",
                   help="rotary motors: how the logged q-current runs between samples: held (the drive controls at its "
                        "log rate) or L, the smooth curve through the samples L samples late (a drive that controls K "
                        "times per logged sample: 1/(2K), e.g. 0.0625 for an 8 kHz loop logged at 1 kHz); default: "
                        "detected")
    p.add_argument("--angle-pll", metavar="W[,ZETA]",
                   help="rotary motors: the logged angle is a drive's PLL estimate of natural frequency W rad/s "
                        "(damping ZETA, default 1; ODrive's encoder bandwidth), or 'none' for the encoder's own "
                        "angle (default: detected when no logged angle sits on an encoder's lattice)")
    p.add_argument("--current-noise", metavar="A|none",
                   help="rotary motors: the logged q-current's white noise (A, standard deviation) that the fit "
                        "corrects for, or 'none' (default: read from the logged d-current id_1 where every log has "
                        "it, else from the q-current's own less what the logged angle predicts of it)")
    p.add_argument("--current-filter", metavar="S|none",
                   help="rotary motors: the time constant (s) of the first-order filter through which the drive "
                        "reports the q-current, or 'none' (default: detected; a real ODrive's report lags by about "
                        "0.08 s)")
    p.add_argument("--time-lines", metavar="HZ[,HZ...]",
                   help="rotary motors: frequencies (Hz) of time-periodic disturbances to fit beside the maps (a "
                        "current sensor's mains pickup, a fan, a resonance), or 'none' (default: detected as lines at "
                        "one frequency in the residuals of logs at two speeds)")


def motor_is_rotary(args) -> bool:
    """Whether ``--motor`` declares ``kind = "rotary"`` (the rotary pipeline then runs)."""
    if not getattr(args, "motor", None):
        return False

    return motor_kind(args.motor) == "rotary"


def require_data(args) -> None:
    """Refuse a command that needs ``--data`` without it."""
    if not args.data:
        raise ConfigError("--data: give at least one log file or glob (CSV, Parquet, .mat, HDF5)")


def read_data_logs(args, progress=None):
    """Logs named by ``--data`` (with ``--columns`` and ``--sample-time``): list of :class:`pgcomm.io.logs.Log`; each
    log's notes (how its time was read) said on ``progress``."""
    mapping = load_column_mapping(args.columns) if args.columns else None
    # a host's time stamps: resampled to a uniform grid (the linear identification's filters need one), with a note
    logs = read_logs(args.data, sample_time=args.sample_time, columns=mapping, resample=True)
    if progress is not None:
        for lg in logs:
            for note in lg.notes:
                progress.info(f"{lg.source}: {note}")
    return logs


def motor_from_args(args):
    """The drive's motor description: ``--motor`` or the twin's nominal motor (k̂ = 67 N/A, ζ̂ = −0.52 rad)."""
    if getattr(args, "motor", None):
        return load_motor(args.motor)
    from pgcomm.twin import TwinParams

    return TwinParams().motor()


def setup_from_args(args):
    """The :class:`pgcomm.setup.Setup` of ``--config``, ``--plant`` and ``--motor``."""
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig

    config_path = args.config
    if config_path is None and args.plant is not None and (Path(args.plant).parent / "config.toml").is_file():
        # a motor folder (the zoo writes one): its machine settings belong to the map
        config_path = Path(args.plant).parent / "config.toml"
        if not getattr(args, "quiet", False):
            print(f"pgcomm: using {config_path} (settings beside --plant; --config overrides)", file=sys.stderr)
    config = load_experiment(config_path) if config_path else ExperimentConfig()
    return build_setup(config, forcemap_path=args.plant, motor_path=args.motor,
                       truth_path=getattr(args, "truth", None))


def reference_from_args(args, setup):
    """``--reference`` (checked against the controller's sample time), else the data-generation reference."""
    from pgcomm.experiment import data_generation_reference
    from pgcomm.setup import check_reference

    if getattr(args, "reference", None):
        ref = read_reference(args.reference, sample_time=args.reference_sample_time)
        if abs(ref.sample_time - setup.motor.sample_time) > 1e-9 * setup.motor.sample_time:
            raise PgcommError(f"{args.reference}: sample time {ref.sample_time:g} s differs from the controller's "
                              f"{setup.motor.sample_time:g} s")
        check_reference(setup, ref, str(args.reference))
        return ref
    return data_generation_reference(setup)


def options_given(args, *dests: str) -> list[str]:
    """The options among ``dests`` (argparse destinations) that the user gave, as ``--name`` strings.

    An option counts as given when its value is neither ``None`` nor ``False``: options that a mode may
    ignore have no other default, so that giving one can be told from leaving it out.
    """
    return [f"--{d.replace('_', '-')}" for d in dests if getattr(args, d, None) not in (None, False)]


def settings_given(path, keys) -> list[str]:
    """Which of ``keys`` (``"section.key"`` or ``"key"``) the TOML file ``path`` sets, as ``"FILE [section] key"``."""
    doc = load_toml(path)
    found = []
    for key in keys:
        *sections, name = key.split(".")
        table = doc
        for sec in sections:
            table = table.get(sec) if isinstance(table, dict) else None
        if isinstance(table, dict) and name in table:
            found.append(f"{path} " + "".join(f"[{sec}] " for sec in sections) + name)
    return found


def refuse_conflicts(mode: str, given, what: str) -> None:
    """The one conflict rule: a setting that the chosen ``mode`` overrides or ignores is an error naming both.

    Args:
        mode: the choice as the user wrote it, e.g. ``"--format c"``, ``"--quick"``, ``"--family spline"``.
        given: the settings the user gave that ``mode`` overrides or ignores, as written (options from
            :func:`options_given`, file keys from :func:`settings_given`); empty: nothing to refuse.
        what: what ``mode`` does with them and why, completing "``mode`` ... it", e.g.
            ``"ignores (the table spacing of --format lut)"``.

    Raises:
        ConfigError: ``"SETTING conflicts with MODE: MODE WHAT it; give one or the other"`` for the first
        setting (the others are counted).
    """
    given = list(given)
    if not given:
        return
    more = f" (and {len(given) - 1} more: {', '.join(given[1:])})" if len(given) > 1 else ""
    verb, _, why = what.partition(" ")
    raise ConfigError(f"{given[0]} conflicts with {mode}: {mode} {verb} it{(' ' + why) if why else ''}{more}; "
                      "give one or the other")


def user_error_line(e: Exception) -> str:
    """The message of ``e`` on one line (``pgcomm: error: ...``)."""
    return " ".join(str(e).split())


def print_mse(results: dict, rows, stream=sys.stdout) -> None:
    """Table of tracking MSE (with its reducible share, when known) and filtered (unfiltered) commutation MSE
    per direction, one line per row in the order of ``rows``."""
    cm = results.get("commutation_mse", {})
    tm = results.get("tracking_mse", {})
    share = results.get("reducible_share", {})
    print(f"{'row':25s} {'tracking [m^2]':>15s} {'share':>6s} {'y [N^2]':>18s} {'x [N^2]':>18s} {'z [N^2m^2]':>18s}",
          file=stream)
    for r in rows:
        if r not in cm:
            continue
        cells = [f"{cm[r][d]['filtered']:.3g} ({cm[r][d]['unfiltered']:.3g})" for d in ("y", "x", "z")]
        sh = share.get(r, {}).get("tracking")
        sh = "" if sh is None else f"{100 * sh:5.1f}%"
        print(f"{r:25s} {tm.get(r, float('nan')):>15.3g} {sh:>6s} {cells[0]:>18s} {cells[1]:>18s} {cells[2]:>18s}",
              file=stream)


def print_calibration(c: dict, stream=sys.stdout) -> None:
    """The ``calibration.*`` keys of results.json on ``stream`` as a table with units (the paper's Table 1:
    initial and calibrated k̂ in N/A, ζ̂ in rad, and the true values where known)."""
    print(f"{'coil set':>8s} {'k init. N/A':>12s} {'k calib. N/A':>12s} {'k true N/A':>12s} {'zeta init. rad':>14s} "
          f"{'zeta calib. rad':>15s} {'zeta true rad':>14s}", file=stream)
    for l in range(len(c["calibrated"]["k"])):
        tk = c["true"]["k"][l] if c["true"]["k"] is not None else float("nan")
        tz = c["true"]["zeta"][l] if c["true"]["zeta"] is not None else float("nan")
        print(f"{l + 1:8d} {c['initial']['k'][l]:12.3f} {c['calibrated']['k'][l]:12.3f} {tk:12.3f} "
              f"{c['initial']['zeta'][l]:14.4f} {c['calibrated']['zeta'][l]:15.4f} {tz:14.4f}", file=stream)
