"""The slot count read from running logs (:func:`pgcomm.rotary.slots.count_slots`) over the rotary zoo.

Usage: ``python bench/rotary_slots.py [--seeds 0,1] [--motors 8] [--control-per-log K]``.

Per zoo motor (its drive as drawn, 4-16 kHz logged at 1 kHz, or ``K`` control cycles per logged sample) it counts the
slots, as ``pgcomm identify`` does for a motor TOML without ``slots``, on two log sets:

* ``round``: one round of ``pgcomm reproduce``'s running logs (two speeds, both directions, a q-current dither);
* ``const``: the constant-speed runs of a drive user's logs (:func:`pgcomm.rotary.experiment.drive_log_mix`, no
  dither).

and prints the truth's ``LCM(Q, 2p)`` and ``Q``, the count's, how the current was read (held, or the smooth curve's
lag) and, beside it, the count on the logs read as written with the current held (:func:`detect_slots` alone, the
count before the reading), then how many fundamentals and slot counts came out right. A few minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1")
    ap.add_argument("--motors", type=int, default=8)
    ap.add_argument("--control-per-log", type=int, default=None, help="the drives' control cycles per logged sample")
    args = ap.parse_args(argv)
    from dataclasses import replace

    from pgcomm.rotary.experiment import drive_log_mix, running_log, running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.slots import count_slots, detect_slots
    from pgcomm.rotary.twin import LawParams, default_gains
    from pgcomm.rotary.zoo import draw_rotary
    from pgcomm.seeds import stream_seed

    print(f"{'seed':>4} {'#':>2} {'motor':7s} {'K':>3s} {'logs':5s} {'L':>4s} {'Q':>3s} {'L got':>5s} {'Q got':>5s} "
          f"{'current read':>14s} {'Q held':>6s} {'s':>5s}")
    right = {"round": [0, 0, 0], "const": [0, 0, 0]}
    for seed in (int(s) for s in args.seeds.split(",")):
        for i in range(args.motors):
            t = draw_rotary(seed, i, args.control_per_log)
            m = t.motor
            a = t.inertia / t.k0
            refs = running_references(m, a, RotarySettings(), Orders.for_motor(m))
            sets = {"round": [running_log(t, r, LawParams.classical(m.pole_pairs), default_gains(a),
                                          stream_seed(seed, "rotary running log", 0, k)) for k, r in enumerate(refs)],
                    "const": drive_log_mix(t, seed=seed)["const"]}
            for name, logs in sets.items():
                t0 = time.perf_counter()
                q, info = count_slots(logs, replace(m, slots=None))
                held = detect_slots(logs, m.pole_pairs, m.sample_time)[0]
                sec = time.perf_counter() - t0
                ok_l, ok_q = info["cogging_fundamental"] == m.cogging_fundamental, q == m.slots
                r = right[name]
                r[0] += ok_l
                r[1] += ok_q
                r[2] += 1
                rw = info["read_with"]
                how = ("held" if rw["current_lag"] is None else f"lag {rw['current_lag']:.3f}") + (
                    f" d{rw['current_delay']:+d}" if rw["current_delay"] else "")
                print(f"{seed:4d} {i:2d} {m.name:7s} {t.control_per_log:3d} {name:5s} {m.cogging_fundamental:4d} "
                      f"{m.slots:3d} {info['cogging_fundamental']:5d} {q:5d} {how:>14s} {held:6d} {sec:5.1f}"
                      + ("" if ok_q else "   <- slots" + ("" if ok_l else ", fundamental")), flush=True)
    for name, (l, q, n) in right.items():
        print(f"{name}: fundamental right on {l}/{n}, slot count on {q}/{n}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
