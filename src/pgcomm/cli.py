"""The ``pgcomm`` command line.

User errors (bad files, bad options) print one line ``pgcomm: error: ...`` and exit
with code 2, without a traceback; outputs are staged in a temporary directory and
moved into ``--out`` only when the command succeeds, so a failed run leaves no
half-written files.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from pgcomm.errors import PgcommError

COMMANDS = {}


def command(name, help):
    """Register ``fn(args, out: Path, progress) -> dict | None`` as subcommand ``name``."""

    def deco(fn):
        COMMANDS[name] = (fn, help)
        return fn

    return deco


def _common(p: argparse.ArgumentParser, out: bool = True, plant: bool = True) -> None:
    if out:
        p.add_argument("--out", required=True, type=Path, help="output directory (created; files replaced)")
    if plant:
        p.add_argument("--plant", type=Path, metavar="FORCEMAP.csv",
                       help="force map replacing the twin's electromagnetics (needs --motor)")
        p.add_argument("--motor", type=Path, metavar="MOTOR.toml", help="motor description for --plant")
        p.add_argument("--config", type=Path, metavar="FILE.toml", help="experiment settings (see README)")
        p.add_argument("--seed", type=int, default=0, help="seed for noise and random starts (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    from pgcomm import __version__

    parser = argparse.ArgumentParser(prog="pgcomm", description="Physics-guided commutation for linear motors.")
    parser.add_argument("--version", action="version", version=f"pgcomm {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (fn, help) in COMMANDS.items():
        p = sub.add_parser(name, help=help, description=help)
        fn.configure(p)
    return parser


def main(argv=None) -> int:
    """Entry point of the ``pgcomm`` console script; returns the exit code."""
    _register_all()
    parser = build_parser()
    args = parser.parse_args(argv)
    fn, _ = COMMANDS[args.command]
    from pgcomm.progress import Progress

    progress = Progress(enabled=not args.quiet)
    try:
        out = getattr(args, "out", None)
        if out is None:
            fn(args, None, progress)
        else:
            with staged_output(out) as tmp:
                fn(args, tmp, progress)
    except PgcommError as e:
        print(f"pgcomm: error: {_one_line(e)}", file=sys.stderr)
        return 2
    except FileNotFoundError as e:
        print(f"pgcomm: error: {e.filename}: file not found", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pgcomm: interrupted", file=sys.stderr)
        return 130
    return 0


def _one_line(e: Exception) -> str:
    return " ".join(str(e).split())


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


def _setup(args):
    from pgcomm.experiment import ExperimentConfig, build_setup, load_experiment

    config = load_experiment(args.config) if args.config else ExperimentConfig()
    return build_setup(config, forcemap_path=args.plant, motor_path=args.motor)


def _write_results(path: Path, results: dict) -> None:
    from pgcomm.io.results import write_results

    write_results(path, results)


def _print_mse(results: dict, rows, stream=sys.stdout) -> None:
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


# ---------------------------------------------------------------------------------------- simulate


def _simulate_configure(p):
    _common(p)
    p.add_argument("--law", choices=("nominal", "true", "oracle"), default="nominal",
                   help="commutation: classical with the nominal k, zeta (default), classical with the twin's "
                        "true fundamental, or the oracle (exact static inverse)")
    p.add_argument("--model", type=Path, help="PGNN model file: use its commutation law instead of --law")
    p.add_argument("--reference", type=Path, help="reference file (CSV with r[,t], or .mat with r); "
                                                   "default: the paper's data-generation reference")
    p.add_argument("--reference-sample-time", type=float, help="sample time (s) of --reference if it has no t")
    p.add_argument("--no-feedforward", action="store_true",
                   help="feedback only (default: feedforward m, f_v, f_c identified in closed loop first)")
    p.add_argument("--format", choices=("csv", "parquet"), default="csv", help="log file format")


@command("simulate", "Closed-loop run on the twin (or a force-map plant): log, plot, results.json.")
def cmd_simulate(args, out: Path, progress):
    from pgcomm import pipeline, plots
    from pgcomm.commutation import ClassicalLaw, ModelLaw, oracle_law
    from pgcomm.control import Feedforward
    from pgcomm.errors import ConfigError
    from pgcomm.io.logs import Log, write_log

    t0 = time.perf_counter()
    setup = _setup(args)
    reference = _reference(args, setup)
    if args.model:
        from pgcomm.modelfile import load_model

        model, _ = load_model(args.model)
        law, name = ModelLaw(model, current_limit=setup.motor.current_limit), "pgnn"
    elif args.law == "nominal":
        law, name = ClassicalLaw.from_motor(setup.motor), "nominal"
    elif args.law == "true":
        if setup.true_k is None:
            raise ConfigError("--law true needs the twin (a force map has no known fundamental)")
        law, name = ClassicalLaw.from_motor(setup.motor, k=setup.true_k, zeta=setup.true_zeta), "true"
    else:
        law, name = oracle_law(setup.plant, current_limit=setup.motor.current_limit), "oracle"
    ff = Feedforward()
    if not args.no_feedforward:
        with progress.stage(f"identify feedforward with the {name} law ({setup.config.controller.ff_iterations} passes)"):
            ff = pipeline.tune_feedforward(setup, [law], reference, seed=args.seed)[0]
            progress.info(f"m = {ff.mass:.3f} kg, f_v = {ff.viscous:.3f} N s/m, f_c = {ff.coulomb:.3f} N")
    with progress.stage(f"simulate {len(reference.r)} samples ({reference.t[-1]:.1f} s) with the {name} law"):
        res = pipeline.run_laws(setup, [law], reference, [ff], seeds=[args.seed])[0]
    m = pipeline.run_metrics(res, setup.config.evaluation.lowpass_hz)
    write_log(out / f"log.{args.format}", Log(res.columns(), res.sample_time, source="simulate"))
    plots.save(plots.plot_run(res, setup.config.evaluation.lowpass_hz, title=f"{name} law on {setup.plant_name}"),
               out / "run.png")
    results = {"command": "simulate", "plant": setup.plant_name, "law": name,
               "feedforward": {"mass": ff.mass, "viscous": ff.viscous, "coulomb": ff.coulomb},
               "commutation_mse": {name: m["commutation_mse"]}, "tracking_mse": {name: m["tracking_mse"]},
               "samples": int(res.t.shape[0]), "runtime_s": time.perf_counter() - t0}
    _write_results(out / "results.json", results)
    if not args.quiet:
        _print_mse(results, [name])
        print(f"wrote {args.out}/log.{args.format}, run.png, results.json")


cmd_simulate.configure = _simulate_configure


def _reference(args, setup):
    from pgcomm import pipeline
    from pgcomm.trajectory import read_reference

    if getattr(args, "reference", None):
        ref = read_reference(args.reference, sample_time=args.reference_sample_time)
        if abs(ref.sample_time - setup.motor.sample_time) > 1e-9 * setup.motor.sample_time:
            raise PgcommError(f"{args.reference}: sample time {ref.sample_time:g} s differs from the controller's "
                              f"{setup.motor.sample_time:g} s")
        return ref
    return pipeline.data_generation_reference(setup)


# --------------------------------------------------------------------------------------- calibrate


def _calibrate_configure(p):
    _common(p)
    p.add_argument("--save-data", action="store_true", help="also write the data sets Z_i^l as logs (CSV)")


@command("calibrate", "Algorithm 1: calibrate k and zeta of every coil set from data sets with Delta = -/+ pi/4.")
def cmd_calibrate(args, out: Path, progress):
    from pgcomm import pipeline, plots

    t0 = time.perf_counter()
    setup = _setup(args)
    reference = pipeline.data_generation_reference(setup)
    cc = setup.config.calibration
    with progress.stage(f"Algorithm 1 on {setup.plant_name}: {setup.motor.n_coil_sets} coil sets x 2 data sets, "
                        f"{len(reference.r)} samples each, up to {cc.iterations} pass(es)"):
        cal, data = pipeline.run_calibration(setup, reference, seed=args.seed, progress=progress)
    results = {"command": "calibrate", "plant": setup.plant_name, "calibration": calibration_results(setup, cal),
               "runtime_s": time.perf_counter() - t0}
    plots.save(plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta, setup.true_k,
                                      setup.true_zeta), out / "calibration.png")
    if args.save_data:
        _write_datasets(out, data)
    _write_results(out / "results.json", results)
    if not args.quiet:
        print_calibration(results["calibration"])
        print(f"wrote {args.out}/results.json, calibration.png")


cmd_calibrate.configure = _calibrate_configure


def calibration_results(setup, cal) -> dict:
    """The ``calibration.*`` keys of results.json."""
    true = setup.true_k is not None
    return {"initial": {"k": cal.k_initial, "zeta": cal.zeta_initial},
            "calibrated": {"k": cal.k, "zeta": cal.zeta},
            "true": {"k": setup.true_k if true else None, "zeta": setup.true_zeta if true else None},
            "error": ({"k_relative": cal.k / setup.true_k - 1.0, "zeta_rad": cal.zeta - setup.true_zeta}
                      if true else None),
            "iterations": cal.iterations, "method": setup.config.calibration.method,
            "delta": setup.config.calibration.delta}


def print_calibration(c: dict, stream=sys.stdout) -> None:
    """Table Parameters_CLM analogue on ``stream``."""
    print(f"{'coil set':>8s} {'k initial':>10s} {'k calib.':>10s} {'k true':>10s} {'zeta init.':>11s} "
          f"{'zeta calib.':>12s} {'zeta true':>10s}", file=stream)
    for l in range(len(c["calibrated"]["k"])):
        tk = c["true"]["k"][l] if c["true"]["k"] is not None else float("nan")
        tz = c["true"]["zeta"][l] if c["true"]["zeta"] is not None else float("nan")
        print(f"{l + 1:8d} {c['initial']['k'][l]:10.3f} {c['calibrated']['k'][l]:10.3f} {tk:10.3f} "
              f"{c['initial']['zeta'][l]:11.4f} {c['calibrated']['zeta'][l]:12.4f} {tz:10.4f}", file=stream)


def _write_datasets(out: Path, data) -> None:
    from pgcomm.io.logs import Log, write_log

    for pair in data:
        for i, ds in enumerate(pair):
            cols = ds.columns()
            cols["experiment"] = np.full(ds.result.t.shape[0], float(i + 1))
            write_log(out / "data" / f"Z{i + 1}_coilset{ds.coil_set + 1}.csv",
                      Log(cols, ds.result.sample_time, source="dataset"))


def _register_all():
    """Import command modules that register themselves (kept lazy so ``--help`` is fast)."""
    for mod in ("pgcomm.cli_identify", "pgcomm.cli_reproduce", "pgcomm.cli_deploy", "pgcomm.cli_export"):
        try:
            __import__(mod)
        except ModuleNotFoundError as e:
            if e.name != mod:
                raise


if __name__ == "__main__":
    sys.exit(main())
