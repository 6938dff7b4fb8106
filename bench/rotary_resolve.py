"""Log until resolved: does the ripple come within 5 % once the running logs are as long as its standard error asks?

Usage: ``python bench/rotary_resolve.py [--motors 0:1,1:7] [--max-seconds 3600]``. Each motor is zoo motor
``seed:index`` (:func:`pgcomm.rotary.zoo.draw_rotary`). The rotary experiment's running logs are recorded with
``stop_when_resolved`` and a budget of ``--max-seconds`` (:func:`pgcomm.rotary.experiment.record_running_logs`): a
round, then as many more as the cogging's and the ripple's standard errors ask for, re-estimated after every batch,
until both maps are resolved (within 5 % of their RMS with probability 0.9) or the budget is spent. No sweep and no
closed loop: only the identification and its error against the twin's truth.

Per motor it prints the truth's ripple RMS (share of the mean torque constant ``k0``), the log time the first round's
standard error asked for, the time recorded, the cogging's and the ripple's errors against the truth (share of the
truth's RMS) with their standard errors, and the wall time. The default motors are the zoo's ripple misses at the
experiment's default budget of half the standstill sweep's time (seeds 0-3); their figures are in
docs/validation.md, "Logged until resolved". Tens of minutes per
motor: the twin's time is about the logs' own.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

MISSES = "0:1,0:4,1:5,1:6,1:7,2:7,3:5,3:7"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motors", default=MISSES, help="zoo motors as seed:index, comma-separated")
    ap.add_argument("--max-seconds", type=float, default=3600.0, help="the running logs' budget (rig s)")
    args = ap.parse_args(argv)
    import numpy as np
    from pgcomm.rotary.experiment import identification_errors, record_running_logs
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.zoo import draw_rotary

    base = RotarySettings()
    print(f"{'motor':11s} {'K':>3s} {'ripple/k0':>9s} {'asked s':>8s} {'logged s':>8s} {'cog err':>8s} {'cog SE':>7s} "
          f"{'rip err':>8s} {'rip SE':>7s} {'wall s':>7s}", flush=True)
    for item in args.motors.split(","):
        seed, index = (int(x) for x in item.split(":"))
        truth = draw_rotary(seed, index)
        th = np.linspace(0.0, 2 * np.pi, 4096, endpoint=False)
        ripple_rms = float(np.sqrt(np.mean(truth.model().ripple(th) ** 2)))
        # the budget as a share of this motor's sweep (its sample time sets the sweep's duration)
        sweep_s = base.standstill.duration(truth.motor.sample_time)
        settings = RotarySettings(log_budget_share=args.max_seconds / sweep_s, stop_when_resolved=True)
        t0 = time.perf_counter()
        rec = record_running_logs(truth, settings, seed=seed)
        wall = time.perf_counter() - t0
        info = rec.identification.to_dict()
        first = info["first_round_standard_error"]
        asked = rec.round_seconds * max(first["cogging"]["log_time_factor_to_resolve"],
                                        first["ripple"]["log_time_factor_to_resolve"])
        e = identification_errors(rec.identification.model, truth)
        se = info["standard_error"]
        print(f"{seed}:{index} {truth.motor.name:7s} {truth.control_per_log:3d} {100 * ripple_rms:8.2f}% {asked:8.0f} "
              f"{rec.seconds:8.0f} {100 * e['cogging_rel']:7.1f}% {100 * se['cogging']['relative']:6.1f}% "
              f"{100 * e['ripple_rel']:7.1f}% {100 * se['ripple']['relative']:6.1f}% {wall:7.0f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
