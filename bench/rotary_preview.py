"""The rotary preview (``pgcomm reproduce --truth model.json``) against the motor it previews: zoo figures.

Usage: ``python bench/rotary_preview.py [--seed 0] [--motors 0,1,...,7] [--full]``.

Per zoo motor: one round of the running logs a drive user records (:func:`pgcomm.rotary.zoo.running_logs`'s,
with the q- and d-voltages), identified without a torque sensor (:func:`pgcomm.rotary.identify.identify`); the twin
of the motor as identified (:func:`pgcomm.rotary.zoo.truth_from_identification`, as the CLI builds it); then the experiment (:func:`pgcomm.rotary.experiment.run`, quick settings unless ``--full``) on
the zoo's truth and on the preview, same seed. Printed: the preview's ``J`` and current noise against the truth's,
and the tracking ratio model / standstill table (position and speed loop) on each: how well the preview predicts
what the law gains on the motor.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--control-per-log", type=int, default=None,
                    help="the drives' control cycles per logged sample (default: the zoo's, drawn per motor)")
    ap.add_argument("--motors", default="0,1,2,3,4,5,6,7")
    ap.add_argument("--full", action="store_true", help="the full experiment (default: quick settings)")
    args = ap.parse_args(argv)

    from pgcomm.rotary.experiment import quick_settings, run, running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.identify import identify
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary, truth_from_identification

    settings = RotarySettings() if args.full else quick_settings()
    print(f"{'#':>2} {'motor':7s} {'log s':>6s} {'J err':>7s} {'noise x':>8s} {'truth p/s':>12s} {'preview p/s':>12s} "
          f"{'time s':>7s}")
    for i in (int(x) for x in args.motors.split(",")):
        t0 = time.perf_counter()
        t = draw_rotary(args.seed, i, args.control_per_log)
        a = t.inertia / t.k0
        refs = running_references(t.motor, a, RotarySettings(), Orders.for_motor(t.motor))
        # the zoo's running logs (pgcomm zoo --logs): the classical law, the drive's tuned gains, seeds as written
        logs = [simulate(t, r, LawParams.classical(t.motor.pole_pairs), default_gains(a), seed=args.seed * 1000 + k)
                for k, r in enumerate(refs, start=1)]
        secs = sum(lg["t"].size for lg in logs) * t.motor.sample_time
        res = identify(logs, t.motor)
        preview = truth_from_identification(res.model, res.to_dict(), t.motor, seed=args.seed)
        ratios = []
        for truth in (t, preview):
            r = run(truth, settings, seed=args.seed)["tracking_ratio_model_over_standstill"]
            ratios.append(f"{r['position']:.2f}/{r['speed']:.2f}")
        print(f"{i:>2} {t.motor.name:7s} {secs:>6.1f} {100 * (preview.inertia / t.inertia - 1):>6.2f}% "
              f"{preview.current_noise / t.current_noise:>8.2f} {ratios[0]:>12s} {ratios[1]:>12s} "
              f"{time.perf_counter() - t0:>7.0f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
