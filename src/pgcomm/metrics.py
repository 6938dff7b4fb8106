"""Evaluation metrics: the paper's 50 Hz low-pass ``H(z)`` and mean-squared errors.

``H(s) = 1 / (s / (2π f_lp) + 1)`` discretised with a zero-order hold at sample time
``Ts``: ``H(z) = (1 - a) z^{-1} / (1 - a z^{-1})`` with ``a = exp(-2π f_lp Ts)``.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

DIRECTIONS = ("y", "x", "z")


def lowpass(x, sample_time: float, cutoff_hz: float = 50.0):
    """Filter ``x`` (N, ...) along axis 0 with the ZOH-discretised first-order low-pass ``H(z)``."""
    a = float(np.exp(-2 * np.pi * cutoff_hz * sample_time))
    return lfilter([0.0, 1.0 - a], [1.0, -a], np.asarray(x, float), axis=0)


def commutation_mse(f_meas, f_star, sample_time: float, cutoff_hz: float = 50.0) -> dict:
    """MSE of the commutation error ``F - F*`` per direction, filtered by ``H(z)`` and unfiltered.

    Args:
        f_meas, f_star: ``(N, 3)`` measured and desired ``[Fy, Fx, Tz]`` (N, N, N·m).

    Returns:
        ``{"y": {"filtered": .., "unfiltered": ..}, "x": .., "z": ..}`` in N² (N²m² for z).
    """
    err = np.asarray(f_meas, float) - np.asarray(f_star, float)
    filt = lowpass(err, sample_time, cutoff_hz)
    return {d: {"filtered": float(np.mean(filt[:, q] ** 2)), "unfiltered": float(np.mean(err[:, q] ** 2))}
            for q, d in enumerate(DIRECTIONS)}


def tracking_mse(e) -> float:
    """Mean-squared tracking error (m²) of ``e = r - y`` (N,)."""
    return float(np.mean(np.asarray(e, float) ** 2))


def reducible_share(row: float, classical: float, oracle: float) -> float:
    """Share of the reducible error a row removes: ``(classical - row) / (classical - oracle)``."""
    den = classical - oracle
    return float((classical - row) / den) if den != 0 else float("nan")
