"""``pgcomm calibrate``: Algorithm 1 on data sets generated on the plant; results.json and a figure."""

from __future__ import annotations

import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, print_calibration, setup_from_args

HELP = "Algorithm 1: calibrate k and zeta of every coil set from data sets with Delta = -/+ pi/4."


def configure(p) -> None:
    """Options of ``pgcomm calibrate``."""
    add_common_options(p)
    p.add_argument("--save-data", action="store_true", help="also write the data sets Z_i^l as logs (CSV)")
    p.add_argument("--no-force-sensor", action="store_true",
                   help="calibrate from the motion (m d2y/dt2 with the motor's mass), no force data")


def run(args, out: Path, progress) -> None:
    """Calibrate; write ``results.json`` (``calibration.*``), ``calibration.png`` and, with ``--save-data``,
    ``data/Z{i}_coilset{l}.csv``."""
    from pgcomm import experiment, plots
    from pgcomm.io.results import write_results

    t0 = time.perf_counter()
    setup = setup_from_args(args)
    reference = experiment.data_generation_reference(setup)
    cc = setup.config.calibration
    with progress.stage(f"Algorithm 1 on {setup.plant_name}: {setup.motor.n_coil_sets} coil sets x 2 data sets, "
                        f"{len(reference.r)} samples each, up to {cc.iterations} pass(es)"):
        cal, data = experiment.run_calibration(setup, reference, seed=args.seed, progress=progress,
                                               sensorless=args.no_force_sensor)
    calibration = experiment.calibration_results(setup, cal)
    if args.no_force_sensor:
        calibration.update(method="sensorless", mass=experiment.sensorless_mass(setup))
    results = {"command": "calibrate", "plant": setup.plant_name, "calibration": calibration,
               "force_sensor": not args.no_force_sensor, "runtime_s": time.perf_counter() - t0}
    plots.save(plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta, setup.true_k,
                                      setup.true_zeta), out / "calibration.png")
    if args.save_data:
        from pgcomm.io.logs import write_datasets

        write_datasets(out / "data", data)
    write_results(out / "results.json", results)
    if not args.quiet:
        print_calibration(results["calibration"])
        print(f"wrote {args.out}/results.json, calibration.png")

