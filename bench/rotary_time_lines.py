"""Time-periodic disturbances in rotary running logs: what they do to the identification, and what finding them costs.

Usage: ``python bench/rotary_time_lines.py [--seed 0] [--motors 0,1,2,3,4,5,6,7] [--repeat 3] [--tracking | --several]``.

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

With ``--several``, per motor instead: the logs without lines (the angle as logged, through ODrive's PLL and read as
``identify`` reads it, and through the PLL misread as the rotor's, ``angle_pll=None``) and two sets of lines at once,
50, 100 and 150 Hz at 1, 0.5 and 0.3 % of the current limit, and 60 and 180 Hz at 1 and 0.5 % (mains and its
harmonics, 60 Hz a hertz from the running logs' 61 Hz dither); each identified with the search, printing the errors,
the lines found against those given, and each peak's share (its amplitude fitted beside the maps over the logged
current's own line, :data:`pgcomm.rotary.time_lines.LINE_CURRENT_SHARE`); the summary counts the lines found and
gives the largest share of a peak in the logs without lines (a dither's misfit).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def _logs(truth, refs, seed: int, lines) -> list:
    """The running logs of ``refs`` with currents ``lines`` (``[(amplitude A, Hz)...]``) taken off the demand (each a
    phase of its own per log) that the log does not show: a current sensor's pickup or a torque from the rig."""
    import numpy as np

    from pgcomm.rotary.experiment import running_log
    from pgcomm.rotary.twin import LawParams, Reference, default_gains
    from pgcomm.seeds import stream_seed

    m = truth.motor
    law, gains = LawParams.classical(m.pole_pairs), default_gains(truth.inertia / truth.k0)
    rng = np.random.default_rng([seed, 23])
    out = []
    for j, r in enumerate(refs):
        # the phase as (2π f T_s) n: the encoder's rounding turns a last-digit change of the logs into a visible one
        p = sum((a * np.sin(2 * np.pi * hz * m.sample_time * np.arange(r.n) + rng.uniform(0, 2 * np.pi))
                 for a, hz in lines), np.zeros(r.n))
        d = (np.zeros(r.n) if r.dither is None else np.asarray(r.dither, float)) - p
        lg = running_log(truth, Reference(r.theta, r.omega, r.alpha, r.mode, d), law, gains,
                         stream_seed(seed, "rotary running log", 0, j))
        out.append(dict(lg, iq_1=lg["iq_1"] + p))
    return out


def _pll_read(logs, bandwidth: float = 1000.0, every: int = 16) -> list:
    """``logs`` with the angle an open drive logs: the rotor's path through ODrive's encoder PLL (``bandwidth`` rad/s)
    run ``every`` times per sample (tests/_drive_pll.py)."""
    import sys
    from pathlib import Path

    import numpy as np
    from scipy.interpolate import CubicSpline

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from _drive_pll import odrive_pll

    out = []
    for lg in logs:
        t = np.asarray(lg["t"])
        fine = t[0] + (t[1] - t[0]) / every * np.arange(t.size * every)
        out.append(dict(lg, theta=odrive_pll(fine, CubicSpline(t, lg["theta_true"])(fine), bandwidth, every)))
    return out


def _motors(args):
    """Per zoo motor of ``args.motors`` (seed ``args.seed``): its index, truth, orders, the first round of
    ``reproduce``'s running references and the disturbances' size (1 % of the current limit, A)."""
    from pgcomm.rotary.experiment import running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.zoo import draw_rotary

    for idx in (int(x) for x in args.motors.split(",")):
        truth = draw_rotary(args.seed, idx, args.control_per_log)
        orders = Orders.for_motor(truth.motor)
        refs = running_references(truth.motor, truth.inertia / truth.k0, RotarySettings(), orders)
        yield idx, truth, orders, refs, 0.01 * truth.motor.current_limit


def _several(args) -> int:
    """``--several``: lines at several frequencies at once, and the dither's misfits with the angle misread."""
    from pgcomm.rotary.experiment import identification_errors
    from pgcomm.rotary.identify import identify
    from pgcomm.settings import RotaryIdentifyOptions

    sets = {"50+100+150 Hz": ((1.0, 50.0), (0.5, 100.0), (0.3, 150.0)), "60+180 Hz": ((1.0, 60.0), (0.5, 180.0))}
    found_total, given_total, misfit = 0, 0, []
    for idx, truth, orders, refs, amp in _motors(args):
        m = truth.motor
        clean = _logs(truth, refs, args.seed, ())
        pll = _pll_read(clean)
        print(f"zoo seed {args.seed} motor {idx} {m.name}: lines in shares of {amp:.3g} A", flush=True)
        for case, logs, kw, given in (("clean", clean, {}, ()), ("PLL read", pll, {}, ()),
                                      ("PLL misread", pll, {"angle_pll": None}, ()),
                                      *((k, _logs(truth, refs, args.seed, [(a * amp, f) for a, f in v]), {}, v)
                                        for k, v in sets.items())):
            res = identify(logs, m, RotaryIdentifyOptions(orders=orders, **kw))
            e = identification_errors(res.model, truth)
            info = res.time_lines
            # a line given at f is found at f or at an alias of it (the windows' grid)
            hit = [f for _, f in given if any(abs(x - f) < 0.5 or any(abs(y - f) < 0.5 for y in al)
                                               for x, al in zip(info["hz"], info["aliases"]))]
            found_total += len(hit)
            given_total += len(given)
            if not given:
                misfit += [c["share"] for c in info["current_share"]]
            shares = " ".join(f"{c['hz']:.1f}:{c['share']:.2f}" for c in info["current_share"])
            print(f"  {case:14s} cogging {100 * e['cogging_rel']:6.2f} %  ripple {100 * e['ripple_rel']:7.2f} %  "
                  f"found {', '.join(f'{x:.2f}' for x in info['hz']) or '-'}"
                  + (f" ({len(hit)} of {len(given)} given)" if given else "")
                  + f"  shares (Hz:share) {shares or '-'}", flush=True)
    print(f"lines found: {found_total} of {given_total}; largest share of a peak in the logs without lines "
          f"{max(misfit, default=0.0):.2f}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--control-per-log", type=int, default=None,
                    help="the drives' control cycles per logged sample (default: the zoo's, drawn per motor)")
    ap.add_argument("--motors", default="0,1,2,3,4,5,6,7", help="zoo indices, comma-separated")
    ap.add_argument("--repeat", type=int, default=3, help="alternating timed runs on the clean logs")
    ap.add_argument("--tracking", action="store_true", help="each model's law in closed loop against the table")
    ap.add_argument("--several", action="store_true",
                    help="lines at several frequencies at once (50+100+150 Hz, 60+180 Hz) and the logs without "
                         "lines with the angle through a PLL, read or misread, instead")
    args = ap.parse_args(argv)
    if args.several:
        return _several(args)
    import numpy as np

    from pgcomm.rotary.experiment import closed_loop, identification_errors
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.identify import fit_mechanics, identify
    from pgcomm.rotary.standstill import run_standstill
    from pgcomm.rotary.twin import LawParams, default_gains
    from pgcomm.seeds import stream_seed

    ratios = []
    for idx, truth, orders, refs, amp in _motors(args):
        m = truth.motor
        print(f"zoo seed {args.seed} motor {idx} {m.name}: disturbances of {amp:.3g} A", flush=True)
        laws = {}
        for case, (a, hz) in (("clean", (0.0, 50.0)), ("pickup 50 Hz", (amp, 50.0)), ("torque 23.7 Hz", (amp, 23.7))):
            logs = _logs(truth, refs, args.seed, [(a, hz)])
            for label, lines in (("detect", "detect"), ("none", ())):
                res = identify(logs, m, RotaryIdentifyOptions(orders=orders, time_lines=lines))
                laws[f"{case}, {label}"] = LawParams(res.model, None, res.model.inertia_ratio, res.model.viscous, 0.0)
                e = identification_errors(res.model, truth)
                info = res.time_lines
                found = ", ".join(f"{f:.3f} Hz ({x / amp:.3f}x)" if a else f"{f:.3f} Hz ({x:.3g} A)"
                                  for f, x in zip(info["hz"], info.get("amplitude_A", [])))
                print(f"  {case:15s} {label:6s} cogging {100 * e['cogging_rel']:6.2f} %  ripple "
                      f"{100 * e['ripple_rel']:7.2f} %  J/k0 {100 * e['inertia_ratio_rel']:5.2f} %  lines: "
                      f"{found or '-'}", flush=True)
            if a == 0.0 and args.tracking:
                gains = default_gains(truth.inertia / truth.k0)
                sweep = run_standstill(truth, gains, RotarySettings().standstill,
                                       seed=stream_seed(args.seed, "rotary standstill sweep"))
                mech = fit_mechanics(logs, m, RotaryIdentifyOptions(orders=orders))
                classical = LawParams.classical(m.pole_pairs)
                laws["standstill_table"] = LawParams(classical.model, sweep.table, mech["inertia_ratio"],
                                                     mech["viscous"], mech["coulomb"])
                laws["oracle"] = LawParams(truth.model(), None, truth.inertia / truth.k0, truth.viscous / truth.k0, 0.0)
            if a == 0.0:
                times = {"detect": [], "none": []}
                for _ in range(args.repeat):
                    for label, lines in (("detect", "detect"), ("none", ())):
                        t0 = time.perf_counter()
                        identify(logs, m, RotaryIdentifyOptions(orders=orders, time_lines=lines))
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
