"""Speed of the rotary pipeline's two inner loops: the twin and the identification, on zoo motors.

Usage: ``python bench/rotary_speed.py [--seed 0] [--motors 0,3,6] [--repeat 3]``.

Per zoo motor (its drive at the zoo's control rate), best of ``--repeat``:

* **columns**: the Fourier columns identification builds over a chunk's angles at its Gauss nodes (6000 angles, the
  union of the motor's cogging, ripple and direction orders), by :func:`pgcomm.rotary.model.harmonic_rows` against the
  closed form ``cos(h θ), sin(h θ)`` in this process (the baseline): the ratio, and the largest difference;
* **twin**: :func:`pgcomm.rotary.twin.simulate` on the quick running logs, seconds per second of log;
* **identify**: :func:`pgcomm.rotary.identify.identify` on those logs with the reading searched, and again with the
  reading it found handed back (:meth:`~pgcomm.rotary.identify.RotaryIdentification.reading`): seconds per second of
  log each, and the search's share;
* **kept x**: the searched identification with the angle's parts of the rows built afresh on every pass (the
  baseline, :class:`pgcomm.rotary.regression._AngleParts` with no budget) over the same with them kept: the ratio.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def _best(fn, repeat: int) -> tuple[float, object]:
    best, out = math.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--motors", default="0,3,6")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    import numpy as np

    from pgcomm.rotary.experiment import quick_settings, running_references
    from pgcomm.rotary.identify import identify
    from pgcomm.settings import RotaryIdentifyOptions
    from pgcomm.rotary.model import harmonic_rows
    from pgcomm.rotary import regression
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams, default_gains, simulate
    from pgcomm.rotary.zoo import draw_rotary

    print(f"{'#':>2} {'motor':7s} {'K':>3s} {'orders':>6s} {'columns x':>9s} {'max diff':>9s} {'log s':>6s} "
          f"{'twin s/s':>9s} {'ident s/s':>10s} {'read s/s':>9s} {'search':>7s} {'kept x':>7s}")
    for idx in (int(k) for k in args.motors.split(",")):
        t = draw_rotary(args.seed, idx)
        orders = Orders.for_motor(t.motor)
        union = np.union1d(np.union1d(orders.cogging, orders.ripple), orders.direction)
        theta = np.cumsum(np.random.default_rng(idx).uniform(0.0, 0.02, 6000)) + 100.0

        def closed():
            ph = union[:, None] * np.mod(theta, 2 * math.pi)[None, :]
            return np.concatenate([np.cos(ph), np.sin(ph)])

        t_closed, ref = _best(closed, args.repeat)
        t_rows, rows = _best(lambda: harmonic_rows(theta, union), args.repeat)
        diff = float(np.max(np.abs(rows - ref)))

        a = t.inertia / t.k0
        refs = running_references(t.motor, a, quick_settings(), orders)
        law, gains = LawParams.classical(t.motor.pole_pairs), default_gains(a)
        simulate(t, refs[0], law, gains, seed=0)  # compiled once, outside the timing
        t_twin, logs = _best(lambda: [simulate(t, r, law, gains, seed=k) for k, r in enumerate(refs)], args.repeat)
        secs = sum(r.n for r in refs) * t.motor.sample_time
        t_id, res = _best(lambda: identify(logs, t.motor), args.repeat)
        read = res.reading()
        t_read, _ = _best(lambda: identify(logs, t.motor, RotaryIdentifyOptions().with_reading(read)), args.repeat)
        kept = regression._angle_parts()
        budget, kept.budget = kept.budget, 0
        try:
            t_fresh, _ = _best(lambda: identify(logs, t.motor), args.repeat)
        finally:
            kept.budget = budget
        name = f"{t.motor.slots}N{2 * t.motor.pole_pairs}P"
        print(f"{idx:>2} {name:7s} {t.control_per_log:>3d} {union.size:>6d} {t_closed / t_rows:>9.1f} {diff:>9.1e} "
              f"{secs:>6.1f} {t_twin / secs:>9.3f} {t_id / secs:>10.3f} {t_read / secs:>9.3f} "
              f"{1 - t_read / t_id:>7.0%} {t_fresh / t_id:>7.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
