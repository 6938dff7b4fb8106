"""The logged q-voltage on the rotary zoo: what the back-EMF measures, against the currents' identification.

Usage: ``python bench/rotary_back_emf.py [--seed 0] [--motors 0,1,...,7] [--fast 3,6] [--revolutions 10]``.
Per zoo motor, on one round of ``reproduce``'s running logs (the twin's winding, :mod:`pgcomm.rotary.winding`):

* the back-EMF constant's torque constant ``k0`` (amplitude-invariant) and the resistance, relative errors;
* the ripple's RMS error against the truth and its standard error (both relative to the truth's RMS), from the voltage
  and from the currents (:func:`pgcomm.rotary.identify.identify`), and the check between them (their RMS
  difference over what their errors give together);
* the voltage's ripple from constant-speed runs at ``--fast`` times the currents' alias-guard speed (``--revolutions``
  each way), where the currents' identification refuses every window: its error, standard error and log time;
* the drive's offset error ``δ`` from the d-voltage (:func:`pgcomm.rotary.back_emf.fit_voltage`): the truth's, the
  error (degrees electrical) and over its standard error, the torque constant along the magnets' axis, relative
  error, and the voltage's application lag ``τ`` (the zoo's drives have none); the last line gives the mean square of those ratios (1 where the standard errors are right);
* the voltage fit's time against the currents' identification's (one process, same logs).

``--fast none`` skips the fast runs.
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
    ap.add_argument("--fast", default="3,6", help="speeds of the voltage-only runs, times the alias guard's")
    ap.add_argument("--revolutions", type=float, default=10.0)
    args = ap.parse_args(argv)
    import numpy as np

    from pgcomm.rotary.back_emf import fit_voltage
    from pgcomm.rotary.experiment import identification_errors, running_log, running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.identify import identify
    from pgcomm.rotary.model import Fourier
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.twin import LawParams, default_gains
    from pgcomm.rotary.winding import BACK_EMF_FACTOR
    from pgcomm.rotary.zoo import draw_rotary

    th = 2 * np.pi * np.arange(4096) / 4096
    fast = () if args.fast == "none" else tuple(float(x) for x in args.fast.split(","))
    print(f"{'#':>2} {'motor':7s} {'k0 err':>7s} {'R err':>6s} {'log s':>6s} {'V rip err/SE %':>15s} "
          f"{'I rip err/SE %':>15s} {'diff/exp':>11s} {'fast s':>6s} {'fast V err/SE %':>16s} {'V/I time':>8s} "
          f"{'δ °':>7s} {'δ err °':>8s} {'z':>6s} {'k_t err':>7s} {'τ µs':>11s}")
    z2 = []
    for i in (int(x) for x in args.motors.split(",")):
        t = draw_rotary(args.seed, i, args.control_per_log)
        o = Orders.for_motor(t.motor)
        a = t.inertia / t.k0
        law, gains = LawParams.classical(t.motor.pole_pairs), default_gains(a)

        def logs_of(settings):
            refs = running_references(t.motor, a, settings, o)
            return [running_log(t, r, law, gains, seed=100 + k) for k, r in enumerate(refs)]

        def rel_err(vec, orders):
            return float(np.sqrt(np.mean((Fourier.from_vector(orders, vec)(th) - t.ripple(th)) ** 2))) / t.ripple.rms()

        logs = logs_of(RotarySettings())
        secs = sum(lg["t"].size for lg in logs) * t.motor.sample_time
        t0 = time.perf_counter()
        res = identify(logs, t.motor)
        t_i = time.perf_counter() - t0
        orders = res.model.ripple.orders
        t0 = time.perf_counter()
        fv = fit_voltage(logs, orders, t.motor.pole_pairs, t.motor.sample_time, offset=t.motor.commutation_offset)
        t_v = time.perf_counter() - t0
        v = res.back_emf
        e_i = identification_errors(res.model, t)["ripple_rel"]
        se_i = res.standard_error["ripple"]["rms_error"] / t.ripple.rms()
        se_v = float(np.sqrt(0.5 * np.trace(fv["cov"]))) / t.ripple.rms()
        if fast:
            fl = logs_of(RotarySettings(speed_shares=fast, revolutions=args.revolutions))
            f_secs = sum(lg["t"].size for lg in fl) * t.motor.sample_time
            ff = fit_voltage(fl, orders, t.motor.pole_pairs, t.motor.sample_time, offset=t.motor.commutation_offset)
            se_f = float(np.sqrt(0.5 * np.trace(ff["cov"]))) / t.ripple.rms()
            f_err = 100 * rel_err(ff["ripple"], orders)
        else:
            f_secs = se_f = f_err = float("nan")
        off = fv["offset_error"]
        z = (off["delta"] - t.offset_error) / off["delta_se"]
        z2.append(z * z)
        k0_err = fv["back_emf_constant"] / BACK_EMF_FACTOR / t.k0 - 1.0
        r_err = fv["resistance"] / t.winding.resistance - 1.0
        print(f"{i:>2} {t.motor.name:7s} {100 * k0_err:>6.2f}% {100 * r_err:>5.1f}% {secs:>6.1f} "
              f"{100 * rel_err(fv['ripple'], orders):>7.1f}/{100 * se_v:<7.1f} {100 * e_i:>7.1f}/{100 * se_i:<7.1f} "
              f"{v['rms_difference'] / v['expected_rms_difference']:>11.2f} {f_secs:>6.1f} "
              f"{f_err:>8.1f}/{100 * se_f:<7.1f} {t_v / t_i:>8.3f} {np.degrees(t.offset_error):>7.2f} "
              f"{np.degrees(off['delta'] - t.offset_error):>8.3f} {z:>6.2f} "
              f"{100 * (off['k_t_aligned'] / t.k_t - 1):>6.2f}% "
              f"{1e6 * off['voltage_lag_s']:>+5.0f}±{1e6 * off['voltage_lag_s_se']:<5.0f}", flush=True)
    print(f"offset error over its standard error: mean square {np.mean(z2):.2f} over {len(z2)} motors")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
