"""What a drive's log holds beside the rotor's truth, for the rotary tests: ODrive's encoder PLL run at a fine rate,
the logs rewritten, a current sensor's pickup."""

import numpy as np


def odrive_pll(t_fine, theta_fine, bandwidth, every):
    """ODrive's encoder PLL (``k_p = 2 bw``, ``k_i = k_p² / 4``) run at the fine rate, sampled every ``every``-th
    step: the estimate a drive logs."""
    kp, ki = 2.0 * bandwidth, bandwidth**2
    dt = t_fine[1] - t_fine[0]
    pe, ve = theta_fine[0], (theta_fine[1] - theta_fine[0]) / dt
    out = np.empty(t_fine.size // every)
    for k in range(out.size * every):
        pe += dt * ve
        e = theta_fine[k] - pe
        pe += dt * kp * e
        ve += dt * ki * e
        if k % every == 0:  # the estimate after the update with the encoder's reading at the log's sample
            out[k // every] = pe
    return out


def pll_and_late(c: dict, bandwidth: float = 1000.0, every: int = 16):
    """A zoo log's columns ``c`` as an open drive logs them: ``(t, angle, iq)`` with the angle through ODrive's PLL
    (``bandwidth`` rad/s, run ``every`` times per sample on the cubic through the encoder samples) and the
    q-current written one sample late."""
    from scipy.interpolate import CubicSpline

    t = c["t"]
    fine = t[0] + (t[1] - t[0]) / every * np.arange(t.size * every)
    th = odrive_pll(fine, CubicSpline(t, c["theta"])(fine), bandwidth, every)
    return t, th, np.concatenate([[c["iq_1"][0]], c["iq_1"][:-1]])


def rewrite_logs(paths, folder, prefix: str, rows, header: str = "t,theta,iq_1", fmt: str = "%.15g") -> list:
    """Each CSV log of ``paths`` read, its columns turned into the rows ``rows(columns)`` returns (an ``(N, k)``
    array), and written as ``folder/{prefix}{k}.csv`` under ``header``. Returns the new paths."""
    from pgcomm.io.logs import read_log

    out = []
    for k, path in enumerate(paths):
        p = folder / f"{prefix}{k}.csv"
        with open(p, "w") as f:
            f.write(header + "\n")
            np.savetxt(f, rows(read_log(path, required=("theta",)).columns), delimiter=",", fmt=fmt)
        out.append(p)
    return out


def with_sensor_pickup(t, refs, amplitude: float, hz: float, seed: int = 11) -> list:
    """The running logs of ``refs`` on a drive whose current sensor picks up ``amplitude`` A at ``hz`` (a phase of its
    own per log): the current loop regulates the measured current, so the motor gets the demand less the pickup and
    the log shows the demand (the twin run with the pickup taken off the demand, and added back to the logged
    current)."""
    from pgcomm.rotary.twin import LawParams, Reference, default_gains, simulate

    a = t.inertia / t.k0
    rng = np.random.default_rng(seed)
    out = []
    for k, r in enumerate(refs):
        p = amplitude * np.sin(2 * np.pi * hz * t.motor.sample_time * np.arange(r.n) + rng.uniform(0, 2 * np.pi))
        d = (np.zeros(r.n) if r.dither is None else np.asarray(r.dither, float)) - p
        lg = simulate(t, Reference(r.theta, r.omega, r.alpha, r.mode, d), LawParams.classical(t.motor.pole_pairs),
                      default_gains(a), seed=k)
        out.append(dict(lg, iq_1=lg["iq_1"] + p))
    return out
