"""Rotary zoo figures: identification error vs truth, tracking ratio law/standstill, time.

Usage: ``python bench/rotary.py [--motors 8] [--first 0] [--seed 0] [--quick] [--control-per-log K] [--real-drive]
[--speed-shares 0.3 0.5] [--host-clock-speed-shares 0.1 0.2] [--revolutions 2]`` (the last three: the running logs'
:class:`pgcomm.settings.RotarySettings`; ``--host-clock-speed-shares`` with no value keeps the faster runs where the
logs carry a host's clock)
(``--real-drive``: the zoo motors with a real drive's and host's habits, :func:`pgcomm.rotary.zoo.draw_rotary`). Per motor it runs
:func:`pgcomm.rotary.experiment.run` (running logs -> identification without a torque sensor,
standstill sweep of 3600 angles, four rows in closed loop) and prints:

* cogging and torque-constant ripple RMS error over the revolution, relative to the truth's RMS
  (target <= 5 %), and the direction map's; the ripple's error also as a share of the mean torque
  constant ``k0`` (what it costs in torque: ``k = k0 (1 + r)``);
* tracking MSE ratio model-law / standstill table in the position and speed loops (target <= 0.5), and the
  oracle's ratio (floor p/s: what the true map achieves; where it is above 0.5 the target is out of any law's reach
  and the summary gives the model's excess over the oracle instead, as a share of the table's: nan where the table
  tracks as well as the oracle or better);
* running-log vs standstill-table agreement (RMS difference vs the sweep's own error);
* running-log time vs standstill-sweep time (rig seconds);
* the ripple's standard error (the identification's own estimate, relative to its RMS) and the
  running-log time that would bring it to 5 % at the same excitation;
* the feedforward's ``J/k0`` error against the truth: the model law's own (identified with the maps) and the other
  rows' (the mechanics fit, maps left out);
* the orders outside the slot/pole basis that the identification added (each zoo motor has one cogging
  and one ripple order outside its basis).

Several minutes on 2 cores (the 3600-point sweeps dominate); ``--quick`` uses 720 points. The zoo's drives control at
4-16 kHz, drawn per motor, and log at 1 kHz (:attr:`pgcomm.rotary.twin.RotaryTruth.control_per_log`, printed as ``K``);
``--control-per-log K`` runs every motor's drive ``K`` times per logged sample instead (1: at its log rate).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motors", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--control-per-log", type=int, default=None, help="the drives' control cycles per logged sample")
    ap.add_argument("--real-drive", action="store_true", help="the zoo motors with a real drive's and host's habits")
    ap.add_argument("--first", type=int, default=0, help="the first motor's index")
    ap.add_argument("--speed-shares", type=float, nargs="+", default=None,
                    help="the running logs' speeds as shares of the alias guard's limit (RotarySettings.speed_shares)")
    ap.add_argument("--host-clock-speed-shares", type=float, nargs="*", default=None,
                    help="the speeds where the first round's angle carries a host's clock (RotarySettings."
                         "host_clock_speed_shares; none given: keep --speed-shares)")
    ap.add_argument("--revolutions", type=float, default=None,
                    help="revolutions per running-log segment (RotarySettings.revolutions)")
    args = ap.parse_args(argv)
    from pgcomm.rotary.experiment import quick_settings, run
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.zoo import draw_rotary

    settings = quick_settings() if args.quick else RotarySettings()
    if args.speed_shares:
        settings = replace(settings, speed_shares=tuple(args.speed_shares))
    if args.host_clock_speed_shares is not None:
        settings = replace(settings, host_clock_speed_shares=tuple(args.host_clock_speed_shares))
    if args.revolutions:
        settings = replace(settings, revolutions=args.revolutions)
    print(f"{'#':>2} {'motor':7s} {'K':>3s} {'cog err':>8s} {'rip err':>8s} {'dir err':>8s} {'pos ratio':>9s} "
          f"{'spd ratio':>9s} {'tab diff A':>10s} {'sweep err A':>11s} {'agree':>5s} {'run s':>6s} {'sweep s':>7s} "
          f"{'wall s':>6s} {'rip SE':>7s} {'s to 5%':>7s} {'floor p/s':>9s} {'J/k0 err':>8s} {'mech J/k0':>9s} "
          "orders added (outside the slot/pole basis)")
    rows = []
    for i in range(args.first, args.first + args.motors):
        t = draw_rotary(args.seed, i, args.control_per_log, real_drive=args.real_drive)
        t0 = time.perf_counter()
        r = run(t, settings, seed=args.seed)
        e = r["identification"]["errors"]
        q = r["tracking_ratio_model_over_standstill"]
        a = r["standstill"]["agreement"]
        tm = r["timing"]
        se = r["identification"]["standard_error"]
        mse = r["tracking_mse"]
        # the oracle (the true map) over the table: the ratio no law can beat in this run (encoder, loop)
        floor = {k: mse["oracle"][k] / mse["standstill_table"][k] for k in ("position", "speed")}
        # the feedforward's J/k0: the model law's own (identified with the maps), the other rows' from the mechanics
        # fit (the maps left out)
        mech_err = abs(r["identification"]["mechanics_fit"]["inertia_ratio"] / r["motor"]["inertia_ratio_true"] - 1)
        # the part of the table's MSE above that floor which the model leaves
        # undefined (nan) where the table tracks as well as the oracle or better
        excess = {k: ((mse["model"][k] - mse["oracle"][k]) / (mse["standstill_table"][k] - mse["oracle"][k])
                      if mse["standstill_table"][k] > mse["oracle"][k] else float("nan"))
                  for k in ("position", "speed")}
        rows.append((e["cogging_rel"], e["ripple_rel"], q["position"], q["speed"], se["ripple"]["relative"],
                     se["ripple"]["log_time_factor_to_resolve"] * tm["running_logs_s"], excess["position"],
                     excess["speed"], floor["position"], floor["speed"]))
        print(f"{i:2d} {t.motor.name:7s} {t.control_per_log:3d} {100 * e['cogging_rel']:7.1f}% {100 * e['ripple_rel']:7.1f}% {100 * e['ripple_rms']:5.2f}% "
              f"{100 * e['direction_rel']:7.1f}% {q['position']:9.2f} {q['speed']:9.2f} "
              f"{a['rms_model_minus_sweep_A']:10.3g} {a['rms_sweep_minus_truth_A']:11.3g} "
              f"{'yes' if a['within_noise'] else 'no':>5s} {tm['running_logs_s']:6.0f} {tm['standstill_s']:7.0f} "
              f"{time.perf_counter() - t0:6.0f} {100 * rows[-1][4]:6.1f}% {rows[-1][5]:7.0f} "
              f"{floor['position']:4.2f}/{floor['speed']:4.2f} {100 * e['inertia_ratio_rel']:7.1f}% "
              f"{100 * mech_err:8.1f}% {r['identification']['orders_added']}", flush=True)
    import numpy as np

    arr = np.array(rows)
    print(f"median: cogging {100 * np.median(arr[:, 0]):.1f} %, ripple {100 * np.median(arr[:, 1]):.1f} %, "
          f"tracking ratio position {np.median(arr[:, 2]):.2f}, speed {np.median(arr[:, 3]):.2f}; "
          f"cogging <= 5 % on {int(np.sum(arr[:, 0] <= 0.05))}/{len(rows)}, ripple <= 5 % on "
          f"{int(np.sum(arr[:, 1] <= 0.05))}/{len(rows)}, position ratio <= 0.5 on {int(np.sum(arr[:, 2] <= 0.5))}"
          f"/{len(rows)}, speed ratio <= 0.5 on {int(np.sum(arr[:, 3] <= 0.5))}/{len(rows)}; where the oracle itself is above "
          f"0.5 of the table (floor p/s), the model's excess over the oracle / the table's: position "
          f"{', '.join(f'{x:.2f}' for x in arr[arr[:, 8] > 0.5, 6]) or '-'}, speed "
          f"{', '.join(f'{x:.2f}' for x in arr[arr[:, 9] > 0.5, 7]) or '-'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
