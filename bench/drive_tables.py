"""What each drive can hold: its table, applied as the drive applies it, in closed loop against pgcomm's law and the oracle.

For each motor the compensation comes from the model pgcomm identifies (linear: the spline model from the
data sets of Algorithm 1's calibration run, at the drive's calibrated ``k̂, ζ̂``; rotary: the model from running logs
without a torque sensor, :func:`pgcomm.rotary.experiment.record_running_logs`). Each drive's table is built from it
by the export (:mod:`pgcomm.export.sinamics` ...) and run by the twin as that drive reads it
(:mod:`pgcomm.export.drive_twin`): its resolution and interpolation, moteus' int8 steps, ODrive's 0.1° bins, a table
per direction switched with hysteresis, the 10 harmonics the AX8000 keeps, IONI's two sinusoids, Summit's
electrical-angle indexing, Moog's speed fade-out. Rows, all on the same references with the same noise:

* ``classical`` (no table), ``pgcomm`` (the whole law of the same model), ``oracle`` (the true map: the floor);
* linear: ``sinamics`` (one table over the stroke), ``sinamics_2`` (one per direction, hysteresis twice the speed
  quantum of the encoder), ``akd`` (8192 over the stroke), ``moog`` (4000), ``beckhoff`` (10 harmonics per
  pole-pair pitch);
* rotary: ``moteus``, ``odrive``, ``sinamics``, ``sinamics_2``, ``akd``, ``moog`` (4000), ``moog_250``,
  ``moog_fade`` (fading out from half to twice the evaluation speed), ``beckhoff``, ``summit`` (2048 entries over
  the electrical angle), ``ioni``.

Feedforward: linear rows tuned in closed loop as a drive user does (``pgcomm``: its own mechanics identification);
rotary rows as :func:`pgcomm.rotary.experiment.run` gives them (drive rows: the classical one; ``sinamics_2``, which
holds the direction term, without its Coulomb part).

Printed: per motor the tracking MSE of every row; then, per drive, the median and worst over motors of the
tracking MSE relative to ``pgcomm``'s and to the oracle's (linear: long and slow references; rotary: position and
speed loops), as one table. Written to ``OUT/drive_tables.json``.

Usage: ``python bench/drive_tables.py --linear-motors 5 --rotary-motors 8 --seed 1 --out bench_out/drive_tables
[--jobs 2] [--quick]``; ``--quick`` runs the rotary motors on :func:`pgcomm.rotary.experiment.quick_settings`.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import numpy as np  # noqa: E402

LINEAR_ROWS = ("classical", "sinamics", "sinamics_2", "akd", "moog", "beckhoff", "pgcomm", "oracle")
ROTARY_ROWS = ("classical", "moteus", "odrive", "sinamics", "sinamics_2", "akd", "moog", "moog_250", "moog_fade",
               "beckhoff", "summit", "ioni", "pgcomm", "oracle")


def run_linear(folder: str | None, seed: int) -> dict:
    """One linear motor: the twin (``folder`` ``None``) or a zoo folder."""
    import pgcomm  # noqa: F401
    from pgcomm import experiment
    from pgcomm.commutation import ClassicalLaw, ModelLaw, oracle_law
    from pgcomm.data import coil_set_data_from_runs
    from pgcomm.export import akd, beckhoff, moog, sinamics
    from pgcomm.export.compensation import from_linear_model
    from pgcomm.export.drive_twin import M_PER_MIN, linear_law
    from pgcomm.setup import build_setup
    from pgcomm.reproduce import reference_seed
    from pgcomm.io.config import load_experiment
    from pgcomm.settings import ExperimentConfig

    if folder is None:
        setup, name = build_setup(ExperimentConfig()), "twin"
    else:
        f = Path(folder)
        setup, name = build_setup(load_experiment(f / "config.toml"), f / "plant.csv", f / "motor.toml"), f.name
    cfg, motor = setup.config, setup.motor
    refs = {"long": experiment.data_generation_reference(setup),
            "slow": experiment.single_velocity_reference(setup, min(cfg.reference.velocities))}
    data0 = experiment.generate(setup, refs["long"], motor.k, motor.zeta, seed=seed)
    cal, _ = experiment.run_calibration(setup, refs["long"], seed=seed, first=data0)
    spline, mech = experiment.identify_spline_models(setup, coil_set_data_from_runs(data0))
    lim = motor.current_limit
    classical = ClassicalLaw.from_motor(motor, k=cal.k, zeta=cal.zeta)
    comp = from_linear_model(spline.model, np.asarray(cal.k), np.asarray(cal.zeta), lim, "motor", name)
    # hysteresis: twice the speed quantum of the encoder (one count per sample), in m/min
    band = 2.0 * cfg.sensors.encoder_resolution / motor.sample_time / M_PER_MIN
    tabs = {"sinamics": sinamics.build_sinamics(comp), "sinamics_2": sinamics.build_sinamics(comp, directions=2,
                                                                                               hysteresis=band),
            "akd": akd.build_akd(comp), "moog": moog.build_moog(comp), "beckhoff": beckhoff.build_beckhoff(comp)}
    laws = {"classical": classical, "oracle": oracle_law(setup.plant, current_limit=lim),
            "pgcomm": ModelLaw(spline.model, current_limit=lim, velocity_source=cfg.identification.law_velocity)}
    for row, tab in tabs.items():
        laws[row] = linear_law(tab, classical, comp.force_constant if row in ("akd", "moog") else 1.0)
    tuned = [r for r in LINEAR_ROWS if r != "pgcomm"]
    ffs = dict(zip(tuned, experiment.tune_feedforward(setup, [laws[r] for r in tuned], refs["long"], seed=seed + 50)))
    ffs["pgcomm"] = mech.feedforward()
    out = {"motor": name, "kind": "linear", "tracking_mse": {},
           "resolution_drive_unit": {r: max(e.max for e in (t.resolution.values() if isinstance(t.resolution, dict)
                                                    else [t.resolution])) for r, t in tabs.items()}}
    for rn, ref in refs.items():
        runs = experiment.run_laws(setup, [laws[r] for r in LINEAR_ROWS], ref, [ffs[r] for r in LINEAR_ROWS],
                                   seeds=[reference_seed(seed, rn)] * len(LINEAR_ROWS))
        out["tracking_mse"][rn] = {r: experiment.run_metrics(x, cfg.evaluation.lowpass_hz)["tracking_mse"]
                                   for r, x in zip(LINEAR_ROWS, runs)}
    return out


def run_rotary(index: int, seed: int, quick: bool) -> dict:
    """One rotary zoo motor (:func:`pgcomm.rotary.zoo.draw_rotary`)."""
    import pgcomm  # noqa: F401
    from pgcomm.export import akd, beckhoff, ioni, moog, sinamics, summit
    from pgcomm.export.compensation import from_rotary_model
    from pgcomm.export.drive_twin import RPM, rotary_law
    from pgcomm.export.moteus import build_moteus
    from pgcomm.export.odrive import build_odrive
    from pgcomm.rotary.experiment import _tuned_drive, closed_loop, quick_settings, record_running_logs, \
        tracking_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.identify import fit_mechanics
    from pgcomm.settings import RotaryIdentifyOptions
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams
    from pgcomm.rotary.zoo import draw_rotary

    truth = draw_rotary(seed, index)
    settings = quick_settings() if quick else RotarySettings()
    m = truth.motor
    orders, a_nom, gains, _ = _tuned_drive(truth)
    rec = record_running_logs(truth, settings, seed)
    model = rec.identification.model
    mech = fit_mechanics(rec.logs, m, RotaryIdentifyOptions(orders=orders, current_delay=rec.delay, current_lag=rec.lag,
                                                            time_lines=rec.identification.time_lines["hz"]))
    comp = from_rotary_model(model, m.current_limit, "motor", m.name)
    p = m.pole_pairs
    # the drives' speeds: hysteresis twice the encoder's speed quantum; fade-out from half to twice the
    # evaluation speed (the speed the tracking references cruise at)
    w_eval = float(np.max(np.abs(tracking_references(m, Orders.for_motor(m), settings)["position"].omega)))
    band_rpm = 2.0 * (2.0 * math.pi / truth.encoder_counts) / m.sample_time / RPM
    tabs = {"moteus": build_moteus(comp), "odrive": build_odrive(comp, 1.0),
            "sinamics": sinamics.build_sinamics(comp, 1.0),
            "sinamics_2": sinamics.build_sinamics(comp, 1.0, 2, hysteresis=band_rpm),
            "akd": akd.build_akd(comp), "moog": moog.build_moog(comp), "moog_250": moog.build_moog(comp, 250),
            "moog_fade": moog.build_moog(comp, fade_out=(0.5 * w_eval / RPM, 2.0 * w_eval / RPM)),
            "beckhoff": beckhoff.build_beckhoff(comp, 1.0), "summit": summit.build_summit(comp, 2048),
            "ioni": ioni.build_ioni(comp)}
    ff_drive = (mech["inertia_ratio"], mech["viscous"], mech["coulomb"])
    laws = {"classical": LawParams.classical(p, *ff_drive),
            "pgcomm": LawParams(model, None, model.inertia_ratio, model.viscous, 0.0),
            "oracle": LawParams(truth.model(), None, a_nom, truth.viscous / truth.k0, 0.0)}
    for row, tab in tabs.items():
        ff = ff_drive if row != "sinamics_2" else (ff_drive[0], ff_drive[1], 0.0)
        laws[row] = rotary_law(tab, ff, p)
    tracking, _ = closed_loop(truth, laws, gains, settings, seed)
    return {"motor": m.name, "kind": "rotary", "pole_pairs": p, "slots": m.slots,
            "tracking_mse": {loop: {r: tracking[r][loop] for r in ROTARY_ROWS} for loop in ("position", "speed")}}


def _safe(fn, *a):
    try:
        return fn(*a)
    except Exception as e:  # noqa: BLE001 — a failed motor is reported, the others go on
        return {"motor": str(a[0]), "error": f"{type(e).__name__}: {e}"}


def summarise(motors: list, rows, kind: str) -> dict:
    """Per drive row and reference/loop: median and worst of its tracking MSE over ``pgcomm``'s and the oracle's."""
    ok = [m for m in motors if m.get("kind") == kind]
    out = {}
    if not ok:
        return out
    for rn in ok[0]["tracking_mse"]:
        out[rn] = {}
        for r in rows:
            to_p = [m["tracking_mse"][rn][r] / m["tracking_mse"][rn]["pgcomm"] for m in ok]
            to_o = [m["tracking_mse"][rn][r] / m["tracking_mse"][rn]["oracle"] for m in ok]
            out[rn][r] = {"to_pgcomm": {"median": float(np.median(to_p)), "worst": float(np.max(to_p))},
                          "to_oracle": {"median": float(np.median(to_o)), "worst": float(np.max(to_o))}}
    return out


def table(summary: dict, rows) -> str:
    """Markdown: drive x (reference or loop) of median (worst) ratios to pgcomm's law and to the oracle."""
    keys = list(summary)
    head = "| row | " + " | ".join(f"{k}: / pgcomm | {k}: / oracle" for k in keys) + " |"
    lines = [head, "|---|" + "---|" * (2 * len(keys))]
    for r in rows:
        cells = []
        for k in keys:
            s = summary[k][r]
            cells += [f"{s['to_pgcomm']['median']:.3g} ({s['to_pgcomm']['worst']:.3g})",
                      f"{s['to_oracle']['median']:.3g} ({s['to_oracle']['worst']:.3g})"]
        lines.append(f"| {r} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--linear-motors", type=int, default=5, help="linear zoo motors besides the twin")
    p.add_argument("--rotary-motors", type=int, default=8)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("bench_out/drive_tables"))
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--quick", action="store_true", help="rotary motors on the quick settings")
    p.add_argument("--no-twin", action="store_true", help="leave the linear twin out")
    args = p.parse_args(argv)
    import pgcomm  # noqa: F401
    from pgcomm.zoo import write_zoo

    zoo_dir = args.out / "zoo"
    folders = []
    if args.linear_motors:
        folders = (write_zoo(args.linear_motors, args.seed, zoo_dir) if not zoo_dir.exists()
                   else sorted(zoo_dir.glob("motor_*")))[:args.linear_motors]
    jobs = [(run_linear, None, args.seed)] * (not args.no_twin)
    jobs += [(run_linear, str(f), args.seed) for f in folders]
    jobs += [(run_rotary, i, args.seed, args.quick) for i in range(args.rotary_motors)]
    t0 = time.perf_counter()
    motors = []
    # spawn: the parent imported JAX (multithreaded), which a fork would copy mid-state
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futs = [pool.submit(_safe, *j) for j in jobs]
        for fut in as_completed(futs):
            m = fut.result()
            motors.append(m)
            if "error" in m:
                print(f"{m['motor']}: FAILED {m['error']}", flush=True)
                continue
            rows = LINEAR_ROWS if m["kind"] == "linear" else ROTARY_ROWS
            for rn, t in m["tracking_mse"].items():
                print(f"{m['kind']} {m['motor']} {rn}: " + " ".join(f"{r} {t[r]:.3g}" for r in rows), flush=True)
    summary = {"linear": summarise(motors, LINEAR_ROWS, "linear"), "rotary": summarise(motors, ROTARY_ROWS, "rotary"),
               "motors": {k: sum(1 for m in motors if m.get("kind") == k) for k in ("linear", "rotary")},
               "failed": sum(1 for m in motors if "error" in m), "seconds": time.perf_counter() - t0}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "drive_tables.json").write_text(json.dumps({"motors": motors, "summary": summary}, indent=1))
    for kind, rows in (("linear", LINEAR_ROWS), ("rotary", ROTARY_ROWS)):
        if summary[kind]:
            print(f"\n{kind} ({summary['motors'][kind]} motors): tracking MSE over pgcomm's law and over the oracle, "
                  "median (worst)\n" + table(summary[kind], rows))
    print(f"\n{summary['failed']} failed; {summary['seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
