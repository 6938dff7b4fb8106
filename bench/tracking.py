"""Targets over the zoo: the spline row's tracking against the drives' anti-cogging table and the oracle.

For each zoo motor (:mod:`pgcomm.zoo`; force maps, or with ``--twin-type`` the same motors with their
direction-dependent force) this runs the steps of :func:`pgcomm.reproduce.run` that the comparison
needs, in one process per motor:

* data sets ``Z_{1,2}^l`` at the nominal ``k̂, ζ̂``, Algorithm 1 from them;
* rows ``classical`` and ``cogging_table`` (classical + the table from its residual) with feedforwards
  tuned in closed loop, as a drive user tunes them; ``oracle`` with its perfect feedforward (tuned the
  same way on the exact inverse);
* row ``spline``: :func:`pgcomm.experiment.identify_spline_models` (model and mechanics from the same
  data sets) and the feedforward of that identification, no closed-loop tuning;
* evaluation on the long, slow and fast references.

Printed and written to ``OUT/tracking.json`` per motor: tracking MSE of every row per reference, the
ratios ``spline / cogging_table`` and ``spline / oracle``, the reducible shares of the commutation
error per direction (``null`` within noise), identification seconds; and the summary against the targets:
spline tracking ≤ 0.5× ``cogging_table`` on every reference (twin-type) and ≤ 3× the oracle (force
maps), y share ≥ 0.95, x and z ≥ 0.8 where reported.

Usage: ``python bench/tracking.py --motors 24 --seed 1 --out bench_out/tracking [--twin-type] [--jobs 2]``
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")

import numpy as np  # noqa: E402

ROWS = ("classical", "cogging_table", "spline", "oracle")


def run_motor(folder: str, seed: int, twin_type: bool) -> dict:
    """The comparison on one zoo motor folder (module docstring)."""
    from dataclasses import replace

    import pgcomm  # noqa: F401
    from pgcomm import experiment
    from pgcomm.setup import build_setup
    from pgcomm.io.config import load_experiment
    from pgcomm.commutation import ClassicalLaw, ModelLaw, OffsetLaw, oracle_law
    from pgcomm.compensation import fit_cogging_table
    from pgcomm.data import coil_set_data_from_runs
    from pgcomm.metrics import DIRECTIONS, lowpass, mse_difference_se, reducible_share
    from pgcomm.reproduce import reference_seed

    folder = Path(folder)
    setup = build_setup(load_experiment(folder / "config.toml"), folder / "plant.csv",
                                   folder / "motor.toml")
    if twin_type:
        from pgcomm.zoo import draw_motor

        setup = replace(setup, plant=draw_motor(seed, int(folder.name.split("_")[1]) - 1).plant(direction=True))
    cfg, motor = setup.config, setup.motor
    refs = {"long": experiment.data_generation_reference(setup),
            "slow": experiment.single_velocity_reference(setup, min(cfg.reference.velocities)),
            "fast": experiment.single_velocity_reference(setup, max(cfg.reference.velocities))}
    data0 = experiment.generate(setup, refs["long"], motor.k, motor.zeta, seed=seed)
    cal, _ = experiment.run_calibration(setup, refs["long"], seed=seed, first=data0)
    t0 = time.perf_counter()
    spline, mech = experiment.identify_spline_models(setup, coil_set_data_from_runs(data0))
    t_id = time.perf_counter() - t0
    lim = motor.current_limit
    laws = {"classical": ClassicalLaw.from_motor(motor, k=cal.k, zeta=cal.zeta),
            "oracle": oracle_law(setup.plant, current_limit=lim),
            "spline": ModelLaw(spline.model, current_limit=lim, velocity_source=cfg.identification.law_velocity)}
    ffs = dict(zip(("classical", "oracle"), experiment.tune_feedforward(
        setup, [laws["classical"], laws["oracle"]], refs["long"], seed=seed + 50)))
    run_c = experiment.run_laws(setup, [laws["classical"]], refs["long"], [ffs["classical"]], seeds=[seed + 60])[0]
    table = fit_cogging_table(run_c.y_meas, run_c.f_meas[:, 0] - run_c.f_star[:, 0],
                              cfg.evaluation.cogging_table_entries, cfg.reference.span)
    laws["cogging_table"] = OffsetLaw(laws["classical"], table)
    ffs["cogging_table"] = experiment.tune_feedforward(setup, [laws["cogging_table"]], refs["long"], seed=seed + 70)[0]
    ffs["spline"] = mech.feedforward()
    out = {"motor": folder.name, "identification_seconds": t_id, "spacing_m": spline.spacing,
           "mechanics": {"mass": mech.mass, "viscous": mech.viscous, "coulomb_mean": float(np.mean(mech.coulomb))},
           "simulated": {"mass": cfg.mechanics.mass, "viscous": cfg.mechanics.viscous,
                         "coulomb": cfg.mechanics.coulomb},
           "tracking_mse": {}, "commutation_mse": {}}
    lp = cfg.evaluation.lowpass_hz
    for rn, ref in refs.items():
        runs = experiment.run_laws(setup, [laws[r] for r in ROWS], ref, [ffs[r] for r in ROWS],
                                   seeds=[reference_seed(seed, rn)] * len(ROWS))
        res = dict(zip(ROWS, runs))
        met = {r: experiment.run_metrics(x, lp) for r, x in res.items()}
        out["tracking_mse"][rn] = {r: met[r]["tracking_mse"] for r in ROWS}
        if rn == "long":
            out["commutation_mse"] = {r: {d: met[r]["commutation_mse"][d]["filtered"] for d in DIRECTIONS}
                                      for r in ROWS}
            c, o = res["classical"], res["oracle"]
            block = max(int(round(20.0 / (2 * np.pi * lp * c.sample_time))), int(round(0.1 / c.sample_time)))
            fc, fo = lowpass(c.f_meas - c.f_star, c.sample_time, lp), lowpass(o.f_meas - o.f_star, c.sample_time, lp)
            cm = out["commutation_mse"]
            out["share"] = {r: {d: reducible_share(cm[r][d], cm["classical"][d], cm["oracle"][d],
                                                   mse_difference_se(fc[:, q], fo[:, q], block))
                                for q, d in enumerate(DIRECTIONS)} for r in ("cogging_table", "spline")}
    out["ratio_to_table"] = {rn: t["spline"] / t["cogging_table"] for rn, t in out["tracking_mse"].items()}
    out["ratio_to_oracle"] = {rn: t["spline"] / t["oracle"] for rn, t in out["tracking_mse"].items()}
    return out


def _safe(folder, seed, twin_type):
    try:
        return run_motor(folder, seed, twin_type)
    except Exception as e:  # noqa: BLE001 — a failed motor is reported, the others go on
        return {"motor": Path(folder).name, "error": f"{type(e).__name__}: {e}"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--motors", type=int, default=8)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("bench_out/tracking"))
    p.add_argument("--twin-type", action="store_true")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--only", default="", help="comma-separated motor folder names")
    args = p.parse_args(argv)
    import pgcomm  # noqa: F401
    from pgcomm.zoo import write_zoo

    zoo_dir = args.out / "zoo"
    folders = write_zoo(args.motors, args.seed, zoo_dir) if not zoo_dir.exists() else sorted(zoo_dir.glob("motor_*"))
    if args.only:
        folders = [f for f in folders if Path(f).name in args.only.split(",")]
    motors = []
    t0 = time.perf_counter()
    # spawn: the parent imported JAX (multithreaded), which a fork would copy mid-state
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futs = [pool.submit(_safe, str(f), args.seed, args.twin_type) for f in folders]
        for fut in as_completed(futs):
            m = fut.result()
            motors.append(m)
            if "error" in m:
                print(f"{m['motor']}: FAILED {m['error']}", flush=True)
                continue
            t = m["tracking_mse"]
            print(f"{m['motor']}: spline/table " + " ".join(f"{rn} {m['ratio_to_table'][rn]:.3f}" for rn in t)
                  + " | spline/oracle " + " ".join(f"{rn} {m['ratio_to_oracle'][rn]:.2f}" for rn in t)
                  + " | share y/x/z " + "/".join("-" if m["share"]["spline"][d] is None
                                                 else f"{m['share']['spline'][d]:.3f}" for d in "yxz")
                  + f" | id {m['identification_seconds']:.1f} s | m {m['mechanics']['mass']:.3g}"
                    f" ({m['simulated']['mass']:.3g}) kg", flush=True)
    ok = sorted((m for m in motors if "error" not in m), key=lambda m: m["motor"])
    summary = {}
    if ok:
        for key in ("ratio_to_table", "ratio_to_oracle"):
            summary[key] = {rn: {"median": float(np.median([m[key][rn] for m in ok])),
                                 "worst": float(np.max([m[key][rn] for m in ok]))} for rn in ok[0][key]}
        for d in "yxz":
            vals = [m["share"]["spline"][d] for m in ok if m["share"]["spline"][d] is not None]
            summary[f"share_{d}"] = {"reported": len(vals), "min": float(np.min(vals)) if vals else None,
                                     "median": float(np.median(vals)) if vals else None}
        summary["mass_rel_error_worst"] = float(np.max([abs(m["mechanics"]["mass"] / m["simulated"]["mass"] - 1)
                                                        for m in ok]))
        summary["failed"] = len(motors) - len(ok)
        summary["seconds"] = time.perf_counter() - t0
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "tracking.json").write_text(json.dumps({"motors": ok, "summary": summary}, indent=1))
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
