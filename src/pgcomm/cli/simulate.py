"""``pgcomm simulate``: one closed-loop run on the twin (or a force-map plant): log, plot, results.json."""

from __future__ import annotations

import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_reference_options, print_mse, reference_from_args, \
    setup_from_args
from pgcomm.control import Feedforward
from pgcomm.errors import ConfigError
from pgcomm.io.logs import Log, write_log
from pgcomm.io.results import write_results

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = "Closed-loop run on the twin (or a force-map plant): log, plot, results.json."


def configure(p) -> None:
    """Options of ``pgcomm simulate``."""
    add_common_options(p)
    p.add_argument("--law", choices=("nominal", "true", "oracle"), default="nominal",
                   help="commutation: classical with the nominal k, zeta (default), classical with the twin's "
                        "true fundamental, or the oracle (exact static inverse)")
    p.add_argument("--model", type=Path,
                   help="model file (PGNN or spline, pgcomm identify): use its commutation law instead of --law")
    add_reference_options(p, "reference file (CSV with r[,t], or .mat with r); "
                             "default: the paper's data-generation reference")
    p.add_argument("--no-feedforward", action="store_true",
                   help="feedback only (default: feedforward m, f_v, f_c identified in closed loop first)")
    p.add_argument("--format", choices=("csv", "parquet"), default="csv", help="log file format")
    p.add_argument("--plan", type=Path, metavar="DIR",
                   help="run a plan's experiments (pgcomm plan) as a rig would, with the drive at the plan's k, "
                        "zeta: one log per experiment, named as the plan names it")


def _run_plan(args, out: Path, progress) -> None:
    """``--plan``: every experiment of the plan on the plant, logs ``out/<experiment>.csv``."""
    from pgcomm.setup import check_reference
    from pgcomm.data import generate_datasets
    from pgcomm.io.plan import log_identity, plan_id, read_plan, write_log_identity

    for opt, given in (("--model", args.model), ("--reference", args.reference),
                       ("--law", args.law != "nominal"), ("--no-feedforward", args.no_feedforward)):
        if given:
            raise ConfigError(f"{opt} does not go with --plan: a plan sets the reference and the commutation "
                              "(its drive values, no feedforward)")
    t0 = time.perf_counter()
    setup = setup_from_args(args)
    plan = read_plan(args.plan)
    m, drive = setup.motor, plan.motor
    for what, a, b in (("coil sets", m.n_coil_sets, drive.n_coil_sets), ("pole pitch (m)", m.pole_pitch,
                       drive.pole_pitch), ("sample time (s)", m.sample_time, drive.sample_time)):
        if abs(a - b) > 1e-9 * abs(a):
            raise ConfigError(f"--plan {args.plan}: {what} {b:g} in its motor.toml, but the plant "
                              f"({setup.plant_name}) has {a:g}")
    check_reference(setup, plan.reference, f"--plan {args.plan}")
    n = len(plan.experiments)
    with progress.stage(f"{n} experiments of the plan on {setup.plant_name} ({plan.duration:.1f} s each)"):
        runs = generate_datasets(setup.plant, drive, plan.reference, delta=plan.delta, loop=setup.loop, seed=args.seed)
    by_key = {(ds.coil_set, ds.delta > 0): ds.result for pair in runs for ds in pair}
    force_cols = () if plan.force_sensor else ("Fy", "Fx", "Tz")
    summary = {}
    for e in plan.experiments:
        res = by_key[(e.coil_set, e.delta > 0)]
        cols = {k: v for k, v in res.columns().items() if k not in force_cols}
        path = out / f"{e.name}.{args.format}"
        write_log(path, Log(cols, res.sample_time, source=e.name))
        write_log_identity(path, log_identity(plan, e))  # the log carries its round: calibrate checks it
        summary[e.name] = {"tracking_rms_m": float((res.e ** 2).mean() ** 0.5), "samples": int(res.t.shape[0])}
    write_results(out / "results.json", {"command": "simulate", "plant": setup.plant_name, "plan": str(args.plan),
                                         "plan_id": plan_id(plan), "force_sensor": plan.force_sensor, "experiments": summary,
                                         "runtime_s": time.perf_counter() - t0})
    if not args.quiet:
        print(f"wrote {n} logs ({', '.join(f'{e.name}.{args.format}' for e in plan.experiments)}), each with "
              f"its plan sidecar (.plan.json), and results.json to {args.out}")


def run(args, out: Path, progress) -> None:
    """Simulate, write ``log.csv|parquet``, ``run.png`` and ``results.json`` into ``out`` (with ``--plan``:
    one log per experiment, :func:`_run_plan`)."""
    if args.plan is not None:
        return _run_plan(args, out, progress)
    from pgcomm import experiment, plots
    from pgcomm.commutation import ClassicalLaw, ModelLaw, oracle_law

    t0 = time.perf_counter()
    setup = setup_from_args(args)
    reference = reference_from_args(args, setup)
    if args.model:
        from pgcomm.io.model import load_model

        model, _ = load_model(args.model)
        if model.n_coil_sets != setup.motor.n_coil_sets:
            raise ConfigError(f"{args.model}: the model has {model.n_coil_sets} coil set(s) but the plant "
                              f"({setup.plant_name}) has {setup.motor.n_coil_sets}; use a model identified on this motor")
        if abs(model.pole_pitch - setup.motor.pole_pitch) > 1e-9 * setup.motor.pole_pitch:
            raise ConfigError(f"{args.model}: pole pitch {model.pole_pitch:g} m differs from the motor's "
                              f"{setup.motor.pole_pitch:g} m; use a model identified on this motor")
        from pgcomm.spline_model import SplineModel

        name = "spline" if isinstance(model, SplineModel) else "pgnn"
        law = ModelLaw(model, current_limit=setup.motor.current_limit)
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
            ff = experiment.tune_feedforward(setup, [law], reference, seed=args.seed)[0]
            progress.info(f"m = {ff.mass:.3f} kg, f_v = {ff.viscous:.3f} N s/m, f_c = {ff.coulomb:.3f} N")
    with progress.stage(f"simulate {len(reference.r)} samples ({reference.t[-1]:.1f} s) with the {name} law"):
        res = experiment.run_laws(setup, [law], reference, [ff], seeds=[args.seed])[0]
    m = experiment.run_metrics(res, setup.config.evaluation.lowpass_hz)
    write_log(out / f"log.{args.format}", Log(res.columns(), res.sample_time, source="simulate"))
    plots.save(plots.plot_run(res, setup.config.evaluation.lowpass_hz, title=f"{name} law on {setup.plant_name}"),
               out / "run.png")
    results = {"command": "simulate", "plant": setup.plant_name, "law": name,
               "feedforward": {"mass": ff.mass, "viscous": ff.viscous, "coulomb": ff.coulomb},
               "commutation_mse": {name: m["commutation_mse"]}, "tracking_mse": {name: m["tracking_mse"]},
               "samples": int(res.t.shape[0]), "runtime_s": time.perf_counter() - t0}
    write_results(out / "results.json", results)
    if not args.quiet:
        print_mse(results, [name])
        print(f"wrote {args.out}/log.{args.format}, run.png, results.json")
