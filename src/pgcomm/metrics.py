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
    acc = RunningMse(sample_time, cutoff_hz)
    acc.add(np.asarray(f_meas, float) - np.asarray(f_star, float))
    return acc.result()


class RunningMse:
    """The MSEs of :func:`commutation_mse` of an error ``(N, 3)`` given block by block.

    ``add(err[a:b])`` for consecutive blocks filters with ``H(z)``'s state carried from block to block,
    so the filtered signal is the one of filtering ``err`` whole; only the order of the sums differs
    (rounding). A long log is thus evaluated without its ``(N, 3)`` copies.

    Args:
        sample_time: s; cutoff_hz: ``H(z)``'s cut-off (Hz).
    """

    def __init__(self, sample_time: float, cutoff_hz: float = 50.0):
        a = float(np.exp(-2 * np.pi * cutoff_hz * sample_time))
        self._b, self._a = [0.0, 1.0 - a], [1.0, -a]
        self._zi = None
        self._sum = np.zeros(len(DIRECTIONS))
        self._sum_filtered = np.zeros(len(DIRECTIONS))
        self.n = 0

    def add(self, err) -> None:
        """Add the next block ``err`` ``(n, 3)`` (N, N, N·m)."""
        err = np.asarray(err, float)
        zi = np.zeros((1, err.shape[1])) if self._zi is None else self._zi
        filt, self._zi = lfilter(self._b, self._a, err, axis=0, zi=zi)
        # column by column: NumPy sums a contiguous column pairwise (a column of an (n, 3) array row by row)
        self._sum += [np.sum(err[:, q] ** 2) for q in range(err.shape[1])]
        self._sum_filtered += [np.sum(filt[:, q] ** 2) for q in range(err.shape[1])]
        self.n += err.shape[0]

    def result(self) -> dict:
        """``{"y": {"filtered", "unfiltered"}, "x": .., "z": ..}`` over every row added (N², N²m² for z)."""
        return {d: {"filtered": float(self._sum_filtered[q] / self.n), "unfiltered": float(self._sum[q] / self.n)}
                for q, d in enumerate(DIRECTIONS)}


def tracking_mse(e) -> float:
    """Mean-squared tracking error (m²) of ``e = r - y`` (N,)."""
    return float(np.mean(np.asarray(e, float) ** 2))


def mse_difference_se(err_a, err_b, block: int) -> float:
    """Standard error of ``mean(err_a²) - mean(err_b²)`` from the means of blocks of ``block`` samples.

    Args:
        err_a, err_b: ``(N,)`` error signals of two runs on the same reference (same units).
        block: samples per block; long enough that block means are nearly independent
            (several correlation times of the errors).

    Returns:
        the standard error (units²); ``inf`` with fewer than two blocks.
    """
    d = np.asarray(err_a, float) ** 2 - np.asarray(err_b, float) ** 2
    n_blocks = d.shape[0] // max(int(block), 1)
    if n_blocks < 2:
        return float("inf")
    means = d[: n_blocks * block].reshape(n_blocks, block).mean(axis=1)
    return float(np.std(means, ddof=1) / np.sqrt(n_blocks))


def reducible_share(row: float, classical: float, oracle: float, se: float = 0.0) -> float | None:
    """Share of the reducible error a row removes: ``(classical - row) / (classical - oracle)``.

    Reported only where the reducible error is real: ``classical - oracle >= max(5 se, 0.2 oracle)``
    with ``se`` the standard error of ``classical - oracle`` (:func:`mse_difference_se`);
    elsewhere ``None`` (the share of a difference lost in noise means nothing).
    """
    den = classical - oracle
    if den <= 0 or den < max(5.0 * se, 0.2 * oracle):
        return None
    return float((classical - row) / den)
