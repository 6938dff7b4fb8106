"""Time-periodic disturbances in rotary running logs: what they do to the identification, and what finding them costs.

Usage: ``python bench/rotary_time_lines.py [--seed 0] [--motors 0,1,2,3,4,5,6,7] [--repeat 3]``.

Per zoo motor (:func:`pgcomm.rotary.zoo.draw_rotary`) it records ``pgcomm reproduce``'s first round of running logs
(two speeds, both directions, the q-current dither) three ways, on the same references and noise seeds:

* ``clean``;
* ``pickup``: the current sensor picks up 1 % of the current limit at 50 Hz (mains), a phase of its own per log: the
  current loop regulates the measured current, so the motor gets the demand less the pickup and the log shows the
  demand (the twin run with the pickup taken off the demand, and added back to the logged current);
* ``torque``: a torque of 1 % of the current limit (as q-current) at 23.7 Hz from the rig (a fan, an unbalanced
  load on the frame), inside the speed loop's band: the log carries the drive's current, which fights it, and not
  the torque (the twin applies it as a current taken off the demand that the log does not show: the same as the
  pickup's, at another frequency).

Each is identified with the lines detected (``time_lines="detect"``, the default) and without (``()``); it prints the
cogging and ripple errors against the twin's truth (RMS over the revolution, relative to the truth's RMS), ``J/k0``'s
error, the lines found (Hz, amplitude over the disturbance's), and, on the clean logs, the median time of each over
``--repeat`` alternating runs in this process and their ratio (what the search costs when there is nothing to find).
With ``--tracking``, each model's law in closed loop on the (undisturbed) twin, as tracking MSE over the drives'
standstill table's (3600-point sweep; position and speed loop, :func:`pgcomm.rotary.experiment.closed_loop`), beside
the oracle's: what a disturbance in the identification's logs costs the user, and what the search gives back.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def _logs(truth, refs, seed: int, amplitude: float, hz: float) -> list:
    """The running logs of ``refs`` with a current of ``amplitude`` A at ``hz`` taken off the demand (a phase of its
    own per log) that the log does not show: a current sensor's pickup or a torque from the rig."""
    import numpy as np

    from pgcomm.rotary.experiment import running_log
    from pgcomm.rotary.twin import LawParams, Reference, default_gains
    from pgcomm.seeds import stream_seed

    m = truth.motor
    law, gains = LawParams.classical(m.pole_pairs), default_gains(truth.inertia / truth.k0)
    rng = np.random.default_rng([seed, 23])
    out = []
    for j, r in enumerate(refs):
        p = amplitude * np.sin(2 * np.pi * hz * m.sample_time * np.arange(r.n) + rng.uniform(0, 2 * np.pi))
        d = (np.zeros(r.n) if r.dither is None else np.asarray(r.dither, float)) - p
        lg = running_log(truth, Reference(r.theta, r.omega, r.alpha, r.mode, d), law, gains,
                         stream_seed(seed, "rotary running log", 0, j))
        out.append(dict(lg, iq_1=lg["iq_1"] + p))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--motors", default="0,1,2,3,4,5,6,7", help="zoo indices, comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="alternating timed runs on the clean logs")
    ap.add_argument("--tracking", action="store_true", help="each model's law in closed loop against the table")
    args = ap.parse_args(argv)
    import numpy as np

    from pgcomm.rotary.experiment import RotarySettings, closed_loop, identification_errors, running_references
    from pgcomm.rotary.identify import fit_mechanics, identify
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.standstill import run_standstill
    from pgcomm.rotary.twin import LawParams, default_gains
    from pgcomm.rotary.zoo import draw_rotary
    from pgcomm.seeds import stream_seed

    ratios = []
    for idx in (int(x) for x in args.motors.split(",")):
        truth = draw_rotary(args.seed, idx)
        m = truth.motor
        orders = Orders.for_motor(m)
        refs = running_references(m, truth.inertia / truth.k0, RotarySettings(), orders)
        amp = 0.01 * m.current_limit
        print(f"zoo seed {args.seed} motor {idx} {m.name}: disturbances of {amp:.3g} A", flush=True)
        laws = {}
        for case, (a, hz) in (("clean", (0.0, 50.0)), ("pickup 50 Hz", (amp, 50.0)), ("torque 23.7 Hz", (amp, 23.7))):
            logs = _logs(truth, refs, args.seed, a, hz)
            for label, lines in (("detect", "detect"), ("none", ())):
                res = identify(logs, m, orders, time_lines=lines)
                laws[f"{case}, {label}"] = LawParams(res.model, None, res.model.inertia_ratio, res.model.viscous, 0.0)
                e = identification_errors(res.model, truth)
                info = res.info["time_lines"]
                found = ", ".join(f"{f:.3f} Hz ({x / amp:.3f}x)" if a else f"{f:.3f} Hz ({x:.3g} A)"
                                  for f, x in zip(info["hz"], info.get("amplitude_A", [])))
                print(f"  {case:15s} {label:6s} cogging {100 * e['cogging_rel']:6.2f} %  ripple "
                      f"{100 * e['ripple_rel']:7.2f} %  J/k0 {100 * e['inertia_ratio_rel']:5.2f} %  lines: "
                      f"{found or '-'}", flush=True)
            if a == 0.0 and args.tracking:
                gains = default_gains(truth.inertia / truth.k0)
                sweep = run_standstill(truth, gains, RotarySettings().standstill,
                                       seed=stream_seed(args.seed, "rotary standstill sweep"))
                mech = fit_mechanics(logs, m, orders)
                classical = LawParams.classical(m.pole_pairs)
                laws["standstill_table"] = LawParams(classical.model, sweep.table, mech["inertia_ratio"],
                                                     mech["viscous"], mech["coulomb"])
                laws["oracle"] = LawParams(truth.model(), None, truth.inertia / truth.k0, truth.viscous / truth.k0, 0.0)
            if a == 0.0:
                times = {"detect": [], "none": []}
                for _ in range(args.repeat):
                    for label, lines in (("detect", "detect"), ("none", ())):
                        t0 = time.perf_counter()
                        identify(logs, m, orders, time_lines=lines)
                        times[label].append(time.perf_counter() - t0)
                td, tn = float(np.median(times["detect"])), float(np.median(times["none"]))
                ratios.append(td / tn)
                print(f"  identify on the clean logs: {td:.2f} s with the search, {tn:.2f} s without "
                      f"(median of {args.repeat}; ratio {td / tn:.2f})", flush=True)
        if args.tracking:
            laws.pop("clean, none")  # the same model as "clean, detect" where nothing is found
            tracking, _ = closed_loop(truth, laws, default_gains(truth.inertia / truth.k0), RotarySettings(),
                                      args.seed)
            table = tracking["standstill_table"]
            for row, mse in tracking.items():
                if row != "standstill_table":
                    print(f"  tracking {row:24s} over the standstill table: position "
                          f"{mse['position'] / table['position']:.3f}, speed {mse['speed'] / table['speed']:.3f}",
                          flush=True)
    print(f"search cost on clean logs: ratio {min(ratios):.2f}-{max(ratios):.2f} (median {np.median(ratios):.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
