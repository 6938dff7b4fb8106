"""Helpers shared by the command modules: common options, staged output, set-up from options, tables.

Nothing here computes results; it turns options into library calls and library results
into text.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

from pgcomm.errors import ConfigError, PgcommError


def add_common_options(p: argparse.ArgumentParser, out: bool = True, plant: bool = True) -> None:
    """``--out DIR`` (if ``out``), ``--plant/--motor/--config/--seed`` (if ``plant``) and ``--quiet``."""
    if out:
        p.add_argument("--out", required=True, type=Path, help="output directory (created; files replaced)")
    if plant:
        p.add_argument("--plant", type=Path, metavar="FORCEMAP.csv",
                       help="force map replacing the twin's electromagnetics (needs --motor)")
        p.add_argument("--motor", type=Path, metavar="MOTOR.toml", help="motor description for --plant")
        p.add_argument("--config", type=Path, metavar="FILE.toml",
                       help="experiment settings (see README); default: config.toml beside --plant, if there")
        p.add_argument("--truth", type=Path, metavar="TRUTH.json",
                       help="the plant's known k, zeta (default: truth.json beside --plant, if there)")
        p.add_argument("--seed", type=int, default=0, help="seed for noise and random starts (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


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


def require_data(args) -> None:
    """Refuse a command that needs ``--data`` without it."""
    if not args.data:
        raise ConfigError("--data: give at least one log file or glob (CSV, Parquet, .mat, HDF5)")


def read_data_logs(args):
    """Logs named by ``--data`` (with ``--columns`` and ``--sample-time``): list of :class:`pgcomm.io.logs.Log`."""
    from pgcomm.io.logs import load_column_mapping, read_logs

    mapping = load_column_mapping(args.columns) if args.columns else None
    return read_logs(args.data, sample_time=args.sample_time, columns=mapping)


def motor_from_args(args):
    """The drive's motor description: ``--motor`` or the twin's nominal motor (k̂ = 67 N/A, ζ̂ = −0.52 rad)."""
    if getattr(args, "motor", None):
        from pgcomm.io.config import load_motor

        return load_motor(args.motor)
    from pgcomm.twin import TwinParams

    return TwinParams().motor()


def setup_from_args(args):
    """The :class:`pgcomm.experiment.Setup` of ``--config``, ``--plant`` and ``--motor``."""
    from pgcomm.experiment import ExperimentConfig, build_setup, load_experiment

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
    from pgcomm.experiment import check_reference, data_generation_reference
    from pgcomm.io.references import read_reference

    if getattr(args, "reference", None):
        ref = read_reference(args.reference, sample_time=args.reference_sample_time)
        if abs(ref.sample_time - setup.motor.sample_time) > 1e-9 * setup.motor.sample_time:
            raise PgcommError(f"{args.reference}: sample time {ref.sample_time:g} s differs from the controller's "
                              f"{setup.motor.sample_time:g} s")
        check_reference(setup, ref, str(args.reference))
        return ref
    return data_generation_reference(setup)


@contextmanager
def staged_output(out: Path):
    """Yield a temporary directory next to ``out``; on success move its files into ``out``.

    On an exception the temporary directory is removed and ``out`` is left untouched.
    """
    out = Path(out)
    parent = out.resolve().parent
    if not parent.exists():
        raise PgcommError(f"--out {out}: parent directory {parent} does not exist")
    if out.exists() and not out.is_dir():
        raise PgcommError(f"--out {out}: exists and is not a directory")
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    try:
        yield tmp
        out.mkdir(exist_ok=True)
        for f in sorted(tmp.rglob("*")):
            if f.is_file():
                dest = out / f.relative_to(tmp)
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(f, dest)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def user_error_line(e: Exception) -> str:
    """The message of ``e`` on one line (``pgcomm: error: ...``)."""
    return " ".join(str(e).split())


def print_mse(results: dict, rows, stream=sys.stdout) -> None:
    """Table of filtered (unfiltered) commutation MSE per direction and tracking MSE."""
    cm = results.get("commutation_mse", {})
    tm = results.get("tracking_mse", {})
    print(f"{'row':18s} {'y [N^2]':>18s} {'x [N^2]':>18s} {'z [N^2m^2]':>18s} {'tracking [m^2]':>15s}", file=stream)
    for r in rows:
        if r not in cm:
            continue
        cells = [f"{cm[r][d]['filtered']:.3g} ({cm[r][d]['unfiltered']:.3g})" for d in ("y", "x", "z")]
        print(f"{r:18s} {cells[0]:>18s} {cells[1]:>18s} {cells[2]:>18s} {tm.get(r, float('nan')):>15.3g}",
              file=stream)


def print_calibration(c: dict, stream=sys.stdout) -> None:
    """Table Parameters_CLM analogue of the ``calibration.*`` keys of results.json on ``stream``."""
    print(f"{'coil set':>8s} {'k initial':>10s} {'k calib.':>10s} {'k true':>10s} {'zeta init.':>11s} "
          f"{'zeta calib.':>12s} {'zeta true':>10s}", file=stream)
    for l in range(len(c["calibrated"]["k"])):
        tk = c["true"]["k"][l] if c["true"]["k"] is not None else float("nan")
        tz = c["true"]["zeta"][l] if c["true"]["zeta"] is not None else float("nan")
        print(f"{l + 1:8d} {c['initial']['k'][l]:10.3f} {c['calibrated']['k'][l]:10.3f} {tk:10.3f} "
              f"{c['initial']['zeta'][l]:11.4f} {c['calibrated']['zeta'][l]:12.4f} {tz:10.4f}", file=stream)
