"""What each of a real drive's habits costs the identification, on rotary zoo motors (``pgcomm zoo --kind rotary
--real-drive``): one round of running logs per motor, identified as drawn with all habits, and again with one group
of habits taken off the same twin, so each row's difference is that group's cost.

Columns: the cogging's and ripple's RMS error against the truth (share of the truth's RMS), the identification's own
standard error of the cogging (what it says about itself), ``J/k0`` against the truth, and what the logs were read
as (the current report's filter, the current's delay and form, the angle's PLL).

Groups (:mod:`pgcomm.rotary.twin`, "A real drive's habits"):

* ``none``: the zoo motor without any habit (the plain zoo);
* ``all``: every habit as drawn;
* ``no host clock``: all but the host's clock (rows stamped at the drive's control cycles, no jitter or gaps);
* ``no report filter``, ``no PLL``, ``no current sensors``: all but that one;
* ``host clock only``: the host's clock and nothing else.

Usage: ``python bench/rotary_habits.py [--seed 0] [--motors 0 1] [--rounds 1] [--groups "host clock only,all"]``. About a minute per motor and
group on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace

os.environ.setdefault("JAX_PLATFORMS", "cpu")

HOST = dict(host_jitter=0.0, host_gaps=0.0, stamp_noise=0.0)
GROUPS = {
    "all": {},
    "no host clock": HOST,
    "host clock only": dict(report_filter=0.0, pll_bandwidth=0.0, sensor_offset=(0.0, 0.0), sensor_gain=(0.0, 0.0),
                            deadtime_error=0.0, deadtime_width=0.0),
    "no report filter": dict(report_filter=0.0),
    "no PLL": dict(pll_bandwidth=0.0),
    "no current sensors": dict(sensor_offset=(0.0, 0.0), sensor_gain=(0.0, 0.0), deadtime_error=0.0,
                               deadtime_width=0.0),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--motors", type=int, nargs="+", default=[0])
    ap.add_argument("--rounds", type=int, default=1, help="rounds of running logs (each one of every reference)")
    ap.add_argument("--groups", default=None, help="comma-separated groups to run (default: all)")
    args = ap.parse_args(argv)
    if args.rounds < 1:
        print("rotary_habits: --rounds must be at least 1", file=sys.stderr)
        return 2
    from pgcomm.rotary.experiment import (RotarySettings, _tuned_drive, identification_errors, running_log,
                                          running_references)
    from pgcomm.rotary.identify import identify
    from pgcomm.rotary.zoo import draw_rotary
    from pgcomm.seeds import stream_seed

    def pct(x, width):
        return f"{'-':>{width}s}" if x is None else f"{100 * x:{width - 1}.1f}%"

    settings = RotarySettings()
    print(f"{'motor':>10s} {'habits':20s} {'cogging':>8s} {'SE':>6s} {'ripple':>8s} {'J/k0 err':>8s} "
          f"{'filter ms':>9s} {'delay':>10s} {'PLL rad/s':>9s} {'s':>5s}")
    for index in args.motors:
        drawn = draw_rotary(args.seed, index, real_drive=True)
        twins = {"none": draw_rotary(args.seed, index, drawn.control_per_log)}
        twins.update({name: replace(drawn, **off) for name, off in GROUPS.items()})
        if args.groups:
            wanted = [g.strip() for g in args.groups.split(",")]
            unknown = [g for g in wanted if g not in twins]
            if unknown:
                print(f"rotary_habits: --groups {', '.join(unknown)}: not one of {', '.join(twins)}", file=sys.stderr)
                return 2
            twins = {name: twins[name] for name in wanted}
        for name, truth in twins.items():
            t0 = time.perf_counter()
            orders, a_nom, gains, classical = _tuned_drive(truth)
            refs = running_references(truth.motor, a_nom, settings, orders)
            logs = [running_log(truth, r, classical, gains, stream_seed(args.seed, "rotary running log", k, i))
                    for k in range(args.rounds) for i, r in enumerate(refs)]
            res = identify(logs, truth.motor)
            e = identification_errors(res.model, truth)
            se = res.standard_error["cogging"]["relative"]
            cd = res.current_delay
            form = "held" if cd["held"] else f"lag {cd['lag']:+.2f}"
            pll = (res.angle_pll or {}).get("natural_frequency_rad_s")
            print(f"{truth.motor.name + ' #' + str(index):>10s} {name:20s} {pct(e['cogging_rel'], 8)} "
                  f"{pct(se, 6)} {pct(e['ripple_rel'], 8)} {pct(e['inertia_ratio_rel'], 8)} "
                  f"{1e3 * res.current_filter['tau_s']:9.1f} {cd['samples']:>3d} {form:>6s} "
                  f"{'-' if pll is None else str(round(pll)):>9s} {time.perf_counter() - t0:5.0f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
