"""``pgcomm calibrate``: one round of Algorithm 1 from a rig's logs (``--data``), or Algorithm 1 on data sets
generated on the plant (twin or force map); results.json and a figure."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_data_options, motor_from_args, print_calibration, \
    read_data_logs, setup_from_args
from pgcomm.errors import ConfigError
from pgcomm.io.config import load_experiment, write_motor
from pgcomm.io.logs import write_datasets
from pgcomm.io.results import write_results

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("Algorithm 1: calibrate k and zeta of every coil set from data sets with Delta = -/+ pi/4: one round from "
        "a rig's logs (--data; writes the next round's motor.toml), or on the twin / a force map.")


def configure(p) -> None:
    """Options of ``pgcomm calibrate``."""
    add_common_options(p)
    p.add_argument("--save-data", action="store_true", help="also write the data sets Z_i^l as logs (CSV)")
    p.add_argument("--no-force-sensor", action="store_true",
                   help="calibrate from the motion (m d2y/dt2 with the motor's mass), no force data")
    add_data_options(p)


def _run_logs(args, out: Path, progress) -> None:
    """``--data``: one round from the logs of a plan's experiments, run with the drive at ``--motor``'s k, zeta."""
    from pgcomm import plots
    from pgcomm.calibration import calibrate_from_logs, convergence
    from pgcomm.settings import ExperimentConfig
    from pgcomm.io.plan import check_log_plans

    for opt, given in (("--plant", args.plant), ("--truth", args.truth), ("--save-data", args.save_data)):
        if given:
            raise ConfigError(f"{opt} does not go with --data: a rig's logs are calibrated as they are "
                              "(--motor: the drive's k, zeta the logs were recorded with)")
    t0 = time.perf_counter()
    motor = motor_from_args(args)
    cc = (load_experiment(args.config) if args.config else ExperimentConfig()).calibration
    method = "sensorless" if args.no_force_sensor else cc.method
    if method == "sensorless" and motor.mass is None:
        raise ConfigError(f"--motor {args.motor}: key 'mass' missing: calibration without a force sensor needs the "
                          "moving mass of the translator (kg); add e.g. mass = 30.0 at the top of the motor TOML")
    logs = read_data_logs(args, progress)
    # the drive values the logs were recorded at must be --motor's: another round's would give a wrong k
    notes = check_log_plans(logs, motor, f"--motor {args.motor}" if args.motor else "the twin's nominal motor")
    if not args.quiet:
        for note in notes:
            print(f"pgcomm: note: {note}", file=sys.stderr)
    with progress.stage(f"one round of Algorithm 1 from {len(logs)} logs ({method})"):
        cal = calibrate_from_logs(logs, motor, method=method, n_bins=cc.n_bins)
    conv = convergence(cal, cc.tol)
    nxt = motor.with_nominal(k=tuple(cal.k), zeta=tuple(cal.zeta))
    write_motor(out / "motor.toml", nxt)
    calibration = cal.to_dict() | {"true": {"k": None, "zeta": None}, "method": method, "convergence": conv}
    results = {"command": "calibrate", "logs": [str(lg.source) for lg in logs], "motor": str(args.motor or "twin"),
               "calibration": calibration, "force_sensor": not args.no_force_sensor, "notes": notes,
               "runtime_s": time.perf_counter() - t0}
    plots.save(plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta), out / "calibration.png")
    write_results(out / "results.json", results)
    if not args.quiet:
        print(f"{'coil set':>8s} {'k drive':>9s} {'k new':>9s} {'step':>8s} {'± SE':>7s}   "
              f"{'zeta drive':>10s} {'zeta new':>9s} {'step':>9s} {'± SE':>8s}")
        print(f"{'':>8s} {'(N/A)':>9s} {'(N/A)':>9s} {'(%)':>8s} {'(%)':>7s}   {'(rad)':>10s} {'(rad)':>9s} "
              f"{'(mrad)':>9s} {'(mrad)':>8s}")
        for l in range(len(cal.k)):
            print(f"{l + 1:8d} {cal.k_initial[l]:9.3f} {cal.k[l]:9.3f} {100 * conv['step']['k_relative'][l]:+8.3f} "
                  f"{100 * conv['standard_error']['k_relative'][l]:7.3f}   {cal.zeta_initial[l]:10.4f} "
                  f"{cal.zeta[l]:9.4f} {1e3 * conv['step']['zeta_rad'][l]:+9.3f} "
                  f"{1e3 * conv['standard_error']['zeta_rad'][l]:8.3f}")
        if conv["converged"]:
            print(f"converged: {conv['rule']}; identify from these logs (pgcomm identify --data ... --motor "
                  f"{args.motor or '<this motor>'})")
        else:
            print(f"not converged ({conv['rule']}): set the drive to {args.out}/motor.toml and run the experiments "
                  f"again: pgcomm plan --motor {args.out}/motor.toml --out <next plan>")
        print(f"wrote {args.out}/motor.toml (the next round's k, zeta), results.json, calibration.png")


def run(args, out: Path, progress) -> None:
    """Calibrate; write ``results.json`` (``calibration.*``), ``calibration.png`` and, with ``--save-data``,
    ``data/Z{i}_coilset{l}.csv``; with ``--data`` one round from logs (:func:`_run_logs`), also ``motor.toml``."""
    if args.data:
        return _run_logs(args, out, progress)
    from pgcomm import experiment, plots
    from pgcomm.setup import sensorless_mass, simulated_mass

    t0 = time.perf_counter()
    setup = setup_from_args(args)
    mass_source = None
    if args.no_force_sensor:
        # the simulated translator's mass, before the first computation (a motor TOML may have none)
        setup, mass_source = simulated_mass(setup)
        if not args.quiet:
            print(f"pgcomm: moving mass {mass_source}", file=sys.stderr)
    reference = experiment.data_generation_reference(setup)
    cc = setup.config.calibration
    with progress.stage(f"Algorithm 1 on {setup.plant_name}: {setup.motor.n_coil_sets} coil sets x 2 data sets, "
                        f"{len(reference.r)} samples each, up to {cc.iterations} pass(es)"):
        cal, data = experiment.run_calibration(setup, reference, seed=args.seed, progress=progress,
                                               sensorless=args.no_force_sensor)
    calibration = experiment.calibration_results(setup, cal)
    if args.no_force_sensor:
        calibration.update(method="sensorless", mass=sensorless_mass(setup), mass_source=mass_source)
    results = {"command": "calibrate", "plant": setup.plant_name, "calibration": calibration,
               "force_sensor": not args.no_force_sensor, "runtime_s": time.perf_counter() - t0}
    plots.save(plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta, setup.true_k,
                                      setup.true_zeta), out / "calibration.png")
    if args.save_data:
        write_datasets(out / "data", data)
    write_results(out / "results.json", results)
    if not args.quiet:
        print_calibration(results["calibration"])
        print(f"wrote {args.out}/results.json, calibration.png")

