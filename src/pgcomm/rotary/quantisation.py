"""The encoder's quantisation in a logged angle: its step, and the noise it puts in the acceleration.

The identification without a torque sensor (:mod:`pgcomm.rotary.identify`) regresses the q-current on the
filtered second difference of the logged angle. An encoder rounds the angle to its step ``q``; the error
``e = θ_logged − θ`` is, for a rotor that crosses many counts between samples, uniform on ``±q/2`` and white
(Widrow's model of quantisation), so the filtered acceleration ``k ⊛ θ_logged / T_s²`` carries a noise of
variance::

    W = q²/12 · Σ_m k_m² / T_s⁴        (k = Hann window ⊛ [1, −2, 1])

This noise sits in a *regressor*: least squares then pulls ``J/k0`` towards zero by the share of the
acceleration's variance it makes up (errors in variables), and the maps absorb what ``J/k0`` misses. At a
constant speed the true acceleration is the small, angle-periodic speed ripple, so a 16–17-bit encoder's
noise is of its size: ``J/k0`` came out 13–56 % low and the cogging 8.5 % off on zoo seed 1 (it is 0 % and
2.8 % with the true angle). The identification subtracts ``n W`` from the acceleration's diagonal of the
normal equations (the corrected least squares of the errors-in-variables literature, with the noise variance
known from the encoder) where the logged angle sits on an encoder's lattice.

What the model leaves out: the drive reacts to ``e`` (its speed loop reads the encoder), so the true motion is
correlated with the noise. On the zoo this leaves ``J/k0`` within −4 to −11 % where it was −13 to −56 %.
"""

from __future__ import annotations

import numpy as np

__all__ = ["encoder_step", "acceleration_noise", "LATTICE_TOLERANCE"]

#: A logged angle is on an encoder's lattice when its first and second differences are within this share of a
#: step of a whole number of steps (a CSV written with 7 significant digits per radian stays well inside it).
LATTICE_TOLERANCE = 0.05
#: ...for at least this share of the samples (a few glitches, a wrap of a single-turn column, are allowed).
LATTICE_SHARE = 0.99
#: Fewest nonzero second differences needed to trust a step (a multiple of the step passes the lattice test
#: on ``n`` of them with chance about ``2^-n``).
MIN_STEPS = 50
#: Most frequent second differences tried as the step.
CANDIDATES = 20


def encoder_step(theta) -> float | None:
    """The encoder's step (rad) a logged angle was rounded to, or ``None`` when it is not on a lattice.

    At any speed the rotor crosses counts irregularly, so the second differences of the logged angle are whole
    numbers of counts and most of them are ``0`` or ``±1`` count. The most frequent nonzero second differences
    are tried, the largest first; a step is kept when the first and second differences are whole numbers of it
    (:data:`LATTICE_TOLERANCE`, :data:`LATTICE_SHARE`), refined by least squares. An angle from the drive's
    observer or PLL is not on a lattice; an angle written with few digits is on the lattice of its last digit
    as well, and the encoder's coarser one is found.

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
        q = float(np.sum(nz[used] * counts[used]) / np.sum(counts[used] ** 2))
        if all(np.mean(np.abs(d / q - np.round(d / q)) <= LATTICE_TOLERANCE) >= LATTICE_SHARE for d in (d2, d1)):
            return q
    return None


def _round_significant(x: np.ndarray, digits: int) -> np.ndarray:
    """``x`` (positive) rounded to ``digits`` significant digits."""
    e = np.floor(np.log10(x))
    return np.round(x / 10.0**e, digits - 1) * 10.0**e


def acceleration_noise(q: float, taps: np.ndarray, sample_time: float) -> float:
    """Variance of the encoder's quantisation noise in a filtered acceleration (module docstring).

    Args:
        q: encoder step (rad).
        taps: ``(T,)`` the filter applied to the second difference (sums to 1).
        sample_time: ``T_s`` (s).

    Returns:
        ``W`` ((rad/s²)²): ``q²/12 · Σ (taps ⊛ [1, −2, 1])² / T_s⁴``.
    """
    k = np.convolve(np.asarray(taps, float), [1.0, -2.0, 1.0])
    return float(q * q / 12.0 * np.sum(k * k) / sample_time**4)
