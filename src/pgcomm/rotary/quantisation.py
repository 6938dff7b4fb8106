"""The encoder's quantisation in a logged angle: its step, and the noise it puts in the acceleration.

The identification without a torque sensor (:mod:`pgcomm.rotary.regression`) regresses the q-current on the
filtered second difference of the logged angle. An encoder rounds the angle to its step ``q``; the error
``e = θ_logged − θ`` is, for a rotor that crosses many counts between samples, uniform on ``±q/2`` and white
(Widrow's model of quantisation), so the filtered acceleration ``k ⊛ θ_logged / T_s²`` carries a noise of
variance::

    W = q²/12 · Σ_m k_m² / T_s⁴        (k = Hann window ⊛ [1, −2, 1])

(plus what the log's storage adds off the lattice, :func:`angle_noise`).

This noise sits in a *regressor*: least squares then pulls ``J/k0`` towards zero by the share of the
acceleration's variance it makes up (errors in variables), and the maps absorb what ``J/k0`` misses. At a
constant speed the true acceleration is the small, angle-periodic speed ripple, so a 16–17-bit encoder's
noise is of its size, and ``J/k0`` comes out tens of per cent low, the maps beyond their standard errors. The
identification subtracts ``n W`` from the acceleration's diagonal of the
normal equations (the corrected least squares of the errors-in-variables literature, with the noise variance
known from the encoder) where the logged angle sits on an encoder's lattice.

What the model leaves out: the drive reacts to ``e`` (its speed loop reads the encoder), so the true motion is
correlated with the noise, and the correction leaves part of ``J/k0``'s error (figures on the zoo's constant-speed
logs: ``bench/rotary_drive_logs.py``). A drive that runs its loops faster than it logs moves that balance the other
way, so the correction can overshoot there. The noise's variance ``W`` itself holds (the rounding errors' own
variance is what the model says); the rest is the noise's correlation with the motion and the regression's other
columns. The verdict therefore counts half the correction as uncertain
(:data:`pgcomm.rotary.regression.QUANTISATION_UNCERTAINTY`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["encoder_step", "angle_noise", "acceleration_noise", "LATTICE_RMS", "LATTICE_OUTLIERS"]

#: A logged angle is on an encoder's lattice when its first and second differences are whole numbers of a step
#: up to a small extra noise (an angle stored as float32, or written to text with few digits): their distance to
#: the nearest whole number has an RMS of at most this many steps (0.29 where there is no lattice) ...
LATTICE_RMS = 0.1
#: ... and at most this share of them is more than a quarter step off (glitches, a wrap of a single-turn column).
LATTICE_OUTLIERS = 0.01
#: Fewest nonzero second differences needed to trust a step, counted in whole steps (a multiple of the step passes
#: the lattice test on ``n`` of them with chance about ``2^-n``).
MIN_STEPS = 50
#: Most frequent second differences tried as the step.
CANDIDATES = 20


def encoder_step(theta) -> float | None:
    """The encoder's step (rad) a logged angle was rounded to, or ``None`` when it is not on a lattice.

    At any speed the rotor crosses counts irregularly, so the second differences of the logged angle are whole
    numbers of counts and most of them are ``0`` or ``±1`` count. The most frequent nonzero second differences
    are tried, the largest first; a step is kept when the first and second differences are whole numbers of it
    up to a small extra noise (:data:`LATTICE_RMS`, :data:`LATTICE_OUTLIERS`), refined by least squares. An angle from the drive's
    observer or PLL is not on a lattice; an angle written with few digits, or stored as float32, is on the
    lattice of its last digit as well, and the encoder's coarser one is found (:func:`angle_noise` counts what
    the storage adds).

    Args:
        theta: ``(N,)`` logged angle (rad, multi-turn or wrapped; the offset does not matter).

    Returns:
        ``q`` (rad), or ``None``.
    """
    th = np.asarray(theta, float)
    if th.size < MIN_STEPS + 2:
        return None
    d1 = np.diff(th)
    d2 = np.abs(np.diff(d1))
    floor = 1e-12 * max(float(np.max(np.abs(th))), 1.0)  # float64 rounding of a multi-turn angle
    nz = d2[d2 > floor]
    if nz.size < MIN_STEPS:
        return None
    # candidate steps: the most frequent second differences (a step, a few steps, or the jitter of an angle
    # written to text with few digits, itself a finer lattice); the coarsest lattice the angle sits on wins
    vals, freq = np.unique(_round_significant(nz, 4),
                           return_counts=True)
    for c in np.sort(vals[np.argsort(freq)[::-1][:CANDIDATES]])[::-1]:
        counts = np.round(nz / c)
        used = counts > 0
        # a step coarser than the differences themselves puts them all near zero, "on" its lattice: a host's gaps
        # (jumps of hundreds of counts) offered such steps, so the step must count MIN_STEPS nonzero differences
        if np.count_nonzero(used) < MIN_STEPS:
            continue
        q = float(np.sum(nz[used] * counts[used]) / np.sum(counts[used] ** 2))
        if all(_on_lattice(d / q) for d in (d2, d1)):
            return q
    return None


def _off(r: np.ndarray) -> np.ndarray:
    return r - np.round(r)


def _on_lattice(r: np.ndarray) -> bool:
    off = np.abs(_off(r))
    near = off <= 0.25
    return bool(np.mean(near) >= 1.0 - LATTICE_OUTLIERS and np.sqrt(np.mean(off[near] ** 2)) <= LATTICE_RMS)


def angle_noise(theta, q: float) -> float:
    """Variance (rad²) of the white noise in a logged angle on a lattice of step ``q``: the rounding, ``q²/12``,
    plus what sits off the lattice (float32 storage, few digits in a text file), from the second differences'
    distance to whole steps (``Δ²`` of white noise has 6 times its variance; glitches beyond a quarter step left
    out).

    Args:
        theta: ``(N,)`` logged angle (rad); q: its encoder step (rad, :func:`encoder_step`).

    Returns:
        The variance (rad²).
    """
    off = _off(np.diff(np.asarray(theta, float), 2) / q)
    off = off[np.abs(off) <= 0.25]
    extra = float(np.mean(off**2)) / 6.0 if off.size else 0.0
    return q * q * (1.0 / 12.0 + extra)


def _round_significant(x: np.ndarray, digits: int) -> np.ndarray:
    """``x`` (positive) rounded to ``digits`` significant digits."""
    e = np.floor(np.log10(x))
    return np.round(x / 10.0**e, digits - 1) * 10.0**e


def acceleration_noise(variance: float, taps: np.ndarray, sample_time: float) -> float:
    """Variance of a logged angle's white noise in a filtered acceleration (module docstring).

    Args:
        variance: the angle noise's variance (rad²), :func:`angle_noise`; ``q²/12`` for rounding alone.
        taps: ``(T,)`` the filter applied to the second difference (sums to 1).
        sample_time: ``T_s`` (s).

    Returns:
        ``W`` ((rad/s²)²): ``variance · Σ (taps ⊛ [1, −2, 1])² / T_s⁴``.
    """
    k = np.convolve(np.asarray(taps, float), [1.0, -2.0, 1.0])
    return float(variance * np.sum(k * k) / sample_time**4)
