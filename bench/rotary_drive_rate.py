"""A drive that controls faster than it logs: identification from snapshots of a moving current.

Usage: ``python bench/rotary_drive_rate.py [--seed 0] [--motors 0,1,...,7] [--rates 1,2,8,20] [--logs running|drive]
[--pll]``.

Real drives run their loops at 8-40 kHz (ODrive 8 kHz, moteus 15-40 kHz) and log at about 1 kHz: each logged q-current
is a snapshot of a current that moves between logged samples. The twin's drive does the same with
``RotaryTruth.control_per_log = K``. Per zoo motor and ``K``, on one round of ``reproduce``'s running logs (``--logs
running``, with the q-current dither) or on the drive-log mix without a dither (``--logs drive``: constant speeds,
accelerations, the slow sweep; :func:`pgcomm.rotary.experiment.drive_log_mix`):

* the current's reading :func:`pgcomm.rotary.identify.identify` detects: held, or smooth with its lag in samples (the
  truth ``1/(2K)``);
* cogging, ripple, direction map: RMS error over the revolution relative to the truth's RMS, and the cogging's and
  the ripple's standard error; ``J/k0``'s relative error;
* the same with the current read as held (``current_lag=None``), the reading before the smooth one existed;
* the identification's time with the detection.

``--pll`` logs the angle an ODrive logs instead of the encoder's: the rotor's path through its PLL (1000 rad/s) run at
the drive's rate (at least 8 kHz), as ``bench/rotary_time_lines.py`` does; the PLL's frequency read is printed too.
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
    ap.add_argument("--motors", default="0,1,2,3,4,5,6,7")
    ap.add_argument("--rates", default="1,2,8,20", help="control cycles per logged sample (K)")
    ap.add_argument("--logs", choices=("running", "drive"), default="running")
    ap.add_argument("--pll", action="store_true", help="the angle through ODrive's PLL (tests/_drive_pll.py)")
    args = ap.parse_args(argv)
    from dataclasses import replace

    from pgcomm.rotary.experiment import drive_log_mix, identification_errors, running_log, running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.identify import identify
    from pgcomm.settings import RotaryIdentifyOptions
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams, default_gains
    from pgcomm.rotary.zoo import draw_rotary
    from pgcomm.seeds import stream_seed

    def fmt(e, se=None):
        out = f"{100 * e['cogging_rel']:6.2f}% {100 * e['ripple_rel']:6.2f}% {100 * e['direction_rel']:6.2f}%"
        if se is not None:
            out += f" {100 * se['cogging']['relative']:6.2f}% {100 * se['ripple']['relative']:6.2f}%"
        return out + f" {100 * e['inertia_ratio_rel']:5.2f}%"

    print(f"{'#':>2} {'motor':7s} {'K':>3s} {'reading':>24s} | {'cog':>7s} {'rip':>7s} {'dir':>7s} {'cog SE':>7s} "
          f"{'rip SE':>7s} {'J/k0':>6s} | held: {'cog':>7s} {'rip':>7s} {'dir':>7s} {'J/k0':>6s} | {'id s':>5s}")
    for i in (int(x) for x in args.motors.split(",")):
        t0 = draw_rotary(args.seed, i)
        m = t0.motor
        orders = Orders.for_motor(m)
        a = t0.inertia / t0.k0
        refs = running_references(m, a, RotarySettings(), orders)
        for k in (int(x) for x in args.rates.split(",")):
            t = replace(t0, control_per_log=k)
            if args.logs == "running":
                logs = [running_log(t, r, LawParams.classical(m.pole_pairs), default_gains(a),
                                    stream_seed(args.seed, "rotary running log", 0, j)) for j, r in enumerate(refs)]
            else:
                mix = drive_log_mix(t, seed=args.seed)
                logs = mix["const"] + mix["accel"] + mix["sweep"]
            if args.pll:
                from rotary_time_lines import _pll_read

                logs = _pll_read(logs, every=max(k, 8))
            c0 = time.perf_counter()
            res = identify(logs, m, RotaryIdentifyOptions(orders=orders))
            wall = time.perf_counter() - c0
            held = identify(logs, m, RotaryIdentifyOptions(orders=orders, current_lag=None))
            tm = res.current_delay
            reading = "held" if tm["held"] else f"smooth {tm['lag']:.4f}"
            if tm["samples"]:
                reading += f" {tm['samples']:+d}"
            if args.pll:
                w = res.angle_pll["natural_frequency_rad_s"]
                reading += f" PLL {w:.0f}" if w else " no PLL"
            print(f"{i:2d} {m.name:7s} {k:3d} {reading:>24s} | {fmt(identification_errors(res.model, t), res.standard_error)}"
                  f" | held: {fmt(identification_errors(held.model, t))} | {wall:5.1f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
