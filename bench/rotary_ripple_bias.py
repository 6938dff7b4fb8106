"""The ripple at the fundamental cogging order from the true current and with its noise at 1x and 2x, fitted with and
without the correction for that noise.

Usage: ``python bench/rotary_ripple_bias.py [--motors 3:7,3:5,0:4] [--seconds 600] [--seeds 4] [--control-per-log K]
[--multiples 0,1,2] [--trajectories 1]``. Each motor is zoo motor ``seed:index``
(:func:`pgcomm.rotary.zoo.draw_rotary`). The rotary experiment's running logs (speed loop, two speeds, both
directions, q-current dither; classical commutation) are recorded for about ``--seconds`` of rig time once
(``--trajectories`` times, each with its own start angles and draws of the twin's noise, so the spread of the noise-
free row shows what the rotor's path alone leaves); then the identification (without a torque sensor) is run on them
with the logged q-current replaced by the twin's true current at the logged instants plus ``m`` times the motor's
current noise (fresh draws, ``--seeds`` of them per ``m`` of ``--multiples``; ``m = 0``: no noise). The reading of
the logs is the twin's own (no delay, the lag of a drive that controls ``K`` times per logged sample or held at ``K
= 1``, no PLL, no time lines) and the screening of outside orders is off, so only the current's noise differs
between the rows. With the screening off the truth's orders outside the basis leak into the fit; ``--inside-basis``
sets them to zero. Each is fitted twice: without the correction for the current's noise (``current_noise=None``) and
with it, the noise read from a logged d-current that carries the same noise (:mod:`pgcomm.rotary.regression`, "The
current's noise").

Per motor and ``m`` it prints, per ripple order of the basis, the identified coefficient over the true one (the real
part of the complex ratio, mean over the draws; 1 is unbiased), and the spread (standard deviation) over the draws:
the noise seeds times the trajectories; and the whole ripple map's error against the truth (RMS over the draws,
relative to the map's RMS) beside the standard error the fit reports for it. The order marked ``*`` is the
fundamental cogging order ``LCM(Q, 2p)``: on motors where the ripple's ``12p`` falls on it (36N42P, 24N20P, 12N10P)
the ripple's coefficient there shares its column's angle dependence with the largest cogging order, and the fit
tells them apart only by the q-current's variation at each angle. The figures (motors 3:7, 1:7, 2:7, 1:5, 3:5, 0:4)
are in docs/validation.md, "The ripple at the fundamental cogging order". A few minutes per motor: the twin runs 650 s
of a 36N42P's logs in about 35 s, and each of the eighteen identifications takes 10-20 s.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motors", default="3:7,3:5,0:4", help="zoo motors as seed:index, comma-separated")
    ap.add_argument("--seconds", type=float, default=600.0, help="rig time of running logs per motor (s)")
    ap.add_argument("--seeds", type=int, default=4, help="noise draws per noise multiple")
    ap.add_argument("--control-per-log", type=int, default=0, metavar="K",
                    help="run every motor's drive K times per logged sample (1: at its log rate, where the held reading "
                         "is exact); 0: each motor's own")
    ap.add_argument("--multiples", default="0,1,2", help="current-noise multiples m, comma-separated")
    ap.add_argument("--inside-basis", action="store_true",
                    help="set the truth's ripple and cogging orders outside the fit's slot/pole basis to zero (the "
                         "screening, which would add them, is off here)")
    ap.add_argument("--trajectories", type=int, default=1,
                    help="independent recordings of the running logs per motor (the m = 0 row's spread is theirs)")
    args = ap.parse_args(argv)
    if args.trajectories < 1 or args.seeds < 1:
        ap.error("--trajectories and --seeds must be at least 1")
    try:
        multiples = [float(x) for x in args.multiples.split(",")]
    except ValueError:
        ap.error(f"--multiples: expected numbers separated by commas, got {args.multiples!r}")
    from dataclasses import replace

    import numpy as np
    from pgcomm.rotary.experiment import _tuned_drive, identification_errors, running_log, running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.identify import identify
    from pgcomm.settings import RotaryIdentifyOptions
    from pgcomm.rotary.model import Fourier, fundamental_cogging_order
    from pgcomm.seeds import stream_seed
    from pgcomm.rotary.zoo import draw_rotary

    for item in args.motors.split(","):
        seed, index = (int(x) for x in item.split(":"))
        truth = draw_rotary(seed, index)
        if args.control_per_log:
            truth = replace(truth, control_per_log=args.control_per_log)
        m = truth.motor
        t0 = time.perf_counter()
        orders, a_nom, gains, classical = _tuned_drive(truth)
        if args.inside_basis:
            inside = {}
            for name, basis in (("ripple", orders.ripple), ("cogging", orders.cogging)):
                f = getattr(truth, name)
                keep = np.isin(f.orders, basis)
                print(f"{seed}:{index}: the truth's {name} orders {[int(h) for h in f.orders[~keep]]} set to zero")
                inside[name] = Fourier(f.orders[keep], np.asarray(f.coef)[keep])
            truth = replace(truth, **inside)
        refs = running_references(m, a_nom, RotarySettings(), orders)
        round_s = sum(r.n for r in refs) * m.sample_time
        rounds = max(1, math.ceil(args.seconds / round_s))
        # the first trajectory keeps the seeds the docs' figures were recorded with
        runs = [[running_log(truth, r, classical, gains,
                             stream_seed(seed, "rotary ripple bias", k, i) if not tr
                             else stream_seed(seed, "rotary ripple bias", tr, k, i))
                 for k in range(rounds) for i, r in enumerate(refs)] for tr in range(args.trajectories)]
        lcm = fundamental_cogging_order(m.slots, m.pole_pairs)
        true = {int(h): complex(*c) for h, c in zip(truth.ripple.orders, truth.ripple.coef)}
        basis = [int(h) for h in orders.ripple]
        print(f"{seed}:{index} {m.name}: {args.trajectories} x {rounds * round_s:.0f} s of logs "
              f"({time.perf_counter() - t0:.0f} s), K = "
              f"{truth.control_per_log}, current noise {truth.current_noise:.3g} A, LCM(Q, 2p) = {lcm}", flush=True)
        print("  m  " + " ".join(f"{str(h) + ('*' if h == lcm else ''):>14s}" for h in basis), flush=True)
        # the twin's own reading: held at its log rate, else the smooth curve half a control cycle late
        lag = None if truth.control_per_log == 1 else 0.5 / truth.control_per_log
        for mult in multiples:
            ratios = {"off": [], "detect": []}
            # the whole map's error against the truth and the standard error the fit reports for it (both relative to
            # the map's RMS): does the verdict see the spread?
            errors = {"off": [], "detect": []}
            for tr, logs in enumerate(runs):
                for s in range(args.seeds if mult else 1):
                    rng = np.random.default_rng([seed, index, s, int(10 * mult)] + ([tr] if tr else []))
                    # the d-current the drive logs beside it carries the same noise (the fit reads it from there)
                    sigma = mult * truth.current_noise
                    fed = [{**log, "iq_1": log["iq_true"] + sigma * rng.standard_normal(log["t"].size),
                            "id_1": sigma * rng.standard_normal(log["t"].size)} for log in logs]
                    for key, noise in (("off", None), ("detect", "detect")):
                        res = identify(fed, m, RotaryIdentifyOptions(
                            orders=orders, current_delay=0, current_lag=lag, angle_pll=None, time_lines=(),
                            extra_orders=False, current_noise=noise))
                        got = {int(h): complex(*c) for h, c in zip(res.model.ripple.orders, res.model.ripple.coef)}
                        ratios[key].append([(got[h] / true[h]).real for h in basis])
                        errors[key].append((identification_errors(res.model, truth)["ripple_rel"],
                                            res.standard_error["ripple"]["relative"]))
            for key, label in (("off", "uncorrected"), ("detect", "corrected")):
                r = np.asarray(ratios[key])
                e = np.asarray(errors[key])
                print(f"  {mult:.0f}  " + " ".join(f"{mean:7.3f} ±{sd:5.3f}" for mean, sd in zip(r.mean(0), r.std(0)))
                      + f"  {label}; map error {100 * np.sqrt(np.mean(e[:, 0] ** 2)):.1f} % RMS over the draws, "
                      f"standard error {100 * np.sqrt(np.mean(e[:, 1] ** 2)):.1f} %", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
