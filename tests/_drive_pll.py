"""A drive's angle estimate for the rotary tests: ODrive's encoder PLL, run at a fine rate."""

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
