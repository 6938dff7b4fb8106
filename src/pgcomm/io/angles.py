"""Multi-turn angles from drive logs: wrapped or continuous, made continuous, or refused when ambiguous.

A rotary drive logs its position either unwrapped (a continuous multi-turn angle) or wrapped
to one revolution (``[0, 2π)``, ``[−π, π)``, ``[0, 360)`` deg, ``[0, 1)`` rev ...). A wrap shows as
a jump of about one revolution between consecutive samples. :func:`unwrap_angle` tells a wrap
from motion by comparing each step ``d_i = θ_{i+1} − θ_i`` (rad) with the step the motion predicts:

* with the logged velocity ``ω`` (rad/s): ``p_i = (ω_i + ω_{i+1}) T_s / 2`` (trapezoid);
* without it: ``p_i = 0`` — the log is then taken to turn less than a quarter revolution per
  sample (at 1 kHz: 1571 rad/s = 15000 rpm), and a faster log needs its velocity column.

``k_i = round((d_i − p_i) / 2π)`` whole revolutions are removed from step ``i``; the step is
*ambiguous* (refused, with one line naming the file, the column and the sample) when the residual
``|d_i − p_i − 2π k_i|`` exceeds :data:`AMBIGUITY` (a quarter revolution), since then neither "a
wrap" nor "motion" explains it — a glitch, a velocity in the wrong unit, or motion too fast for
the sample rate. A jump of more than one revolution (``|k_i| > 1``) is refused too: a wrapped
angle never jumps by more than one revolution. At 1 ms and ``ω`` = 100 rad/s the prediction is
off by ``δω·T_s``, far below the threshold for any sensible velocity estimate, so the rule is
conservative: it refuses rather than guesses.
"""

from __future__ import annotations

import math

import numpy as np

from pgcomm.errors import DataError

__all__ = ["AMBIGUITY", "REVOLUTION", "GLITCH_RATIO", "unwrap_angle", "check_glitches"]

#: One revolution (rad).
REVOLUTION = 2.0 * math.pi

#: Largest residual (rad) between a step and the predicted step, after removing whole revolutions,
#: that is still explained (a quarter revolution).
AMBIGUITY = 0.5 * math.pi


def unwrap_angle(theta, sample_time: float, velocity=None, source: str = "log", label: str = "'theta'"):
    """Make a multi-turn angle continuous; count the wraps removed.

    Args:
        theta: ``(N,)`` mechanical angle (rad), wrapped or continuous.
        sample_time: ``T_s`` (s), > 0; or ``(N − 1,)`` the time of each step (a log with dropped samples).
        velocity: ``(N,)`` angular velocity (rad/s) logged with it, or ``None``.
        source, label: file and column for messages (``label`` as the log reader prints columns,
            e.g. ``"'pos' (theta)"``).

    Returns:
        ``(theta_continuous, n_wraps)``: ``(N,)`` float64 angle (rad) equal to ``theta`` at the first
        sample, and the number of wraps removed (0: the log was continuous; the input array is
        returned as it is then).

    Raises:
        DataError: an ambiguous step or a jump of more than one revolution; the message names the
            file, the column, the sample (row = 1-based sample index) and the values.
    """
    th = np.asarray(theta, dtype=np.float64)
    if th.size < 2:
        return th, 0
    d = np.diff(th)
    dts = np.broadcast_to(np.asarray(sample_time, dtype=np.float64), d.shape)
    if velocity is not None:
        w = np.asarray(velocity, dtype=np.float64)
        pred = 0.5 * (w[1:] + w[:-1]) * dts
    else:
        pred = np.zeros_like(d)
    r = d - pred
    k = np.rint(r / REVOLUTION)
    e = np.abs(r - REVOLUTION * k)
    bad = np.flatnonzero((e > AMBIGUITY) | (np.abs(k) > 1))
    if bad.size:
        i = int(bad[0])
        rows = f"row {i + 2}"
        jump = f"{label} jumps by {d[i]:.6g} rad from {th[i]:.9g} (row {i + 1}) to {th[i + 1]:.9g}"
        if abs(k[i]) > 1 and e[i] <= AMBIGUITY:
            why = (f"{int(abs(k[i]))} revolutions in one sample is not a wrap (a wrapped angle jumps by one "
                   "revolution)")
        elif velocity is not None:
            why = (f"ambiguous: the logged velocity {0.5 * (w[i] + w[i + 1]):.6g} rad/s predicts a step of "
                   f"{pred[i]:.6g} rad per {dts[i]:.6g} s sample and the jump is {e[i]:.3g} rad away from that "
                   "plus any whole revolution (check the velocity's unit and sign, or the log for a glitch)")
        else:
            why = (f"ambiguous: {e[i]:.3g} rad from any whole revolution, more than a quarter revolution per "
                   f"{dts[i]:.6g} s sample (add the velocity column so that fast motion can be told from a "
                   "wrap, or check the log for a glitch)")
        # an angle in counts or degrees read as radians moves by far more than a revolution over the log
        span = float(np.max(th) - np.min(th)) / REVOLUTION
        unit = (f"; the angle spans {span:.0f} revolutions: if it is in encoder counts or degrees, declare it "
                "([units] theta = \"counts\" with encoder_counts, or \"deg\")") if span > 100 else ""
        raise DataError(f"{source} {rows}: {jump}: {why}{unit}")
    n = int(np.sum(np.abs(k)))
    if n == 0:
        return th, 0
    # whole revolutions only: the samples keep their digits (no cumulative sum of the steps)
    return th - REVOLUTION * np.concatenate(([0.0], np.cumsum(k))), n


#: A step of the angle is a glitch when it differs from the step the local speed predicts over its interval by more
#: than this many times that step plus the log's own step noise (:func:`check_glitches`). On the 26 logs of a real
#: ODrive rig (host-stamped, PLL angle, 0-77 rad/s, one with stiff gains that made it shake) the largest ratio is 1.0.
GLITCH_RATIO = 5.0
#: Steps on either side of a step whose median speed predicts it.
_GLITCH_NEIGHBOURS = 4


def check_glitches(theta, steps, source: str = "log", label: str = "'theta'") -> None:
    """Refuse an angle that jumps by far more than its motion explains and stays there (an encoder glitch, lost
    counts, a slip): every step after it would be read at the wrong angle, and the table with it.

    Step ``i`` (``d_i = θ_{i+1} − θ_i`` over ``h_i``) is predicted by the median speed ``v̄_i`` of the
    :data:`_GLITCH_NEIGHBOURS` steps on each side; its deviation ``|d_i − v̄_i h_i|`` over
    ``|v̄_i| h_i + 10 · median_j |d_j − v̄_j h_j|`` (the step the speed predicts, plus ten times the log's typical
    nonzero deviation: an encoder's counts, a PLL's noise, the host's timing) must stay below :data:`GLITCH_RATIO`. Steps of
    more than three median steps and their neighbours are left out (across a gap the speed may change).

    Args:
        theta: ``(N,)`` continuous angle (rad); steps: ``(N − 1,)`` step durations (s) or the sample time (s).
        source, label: file and column for the message.

    Raises:
        DataError: one line naming the file, the row, the jump and what the speed predicted.
    """
    th = np.asarray(theta, dtype=np.float64)
    if th.size < 4 * _GLITCH_NEIGHBOURS:
        return
    d = np.diff(th)
    h = np.broadcast_to(np.asarray(steps, dtype=np.float64), d.shape)
    from scipy.ndimage import maximum_filter, median_filter  # SciPy: loaded by the identification reading these logs

    size = 2 * _GLITCH_NEIGHBOURS + 1
    v = median_filter(d / h, size, mode="nearest")
    dev = np.abs(d - v * h)
    # the deviations that are not zero (a rotor at rest repeats its count): an encoder's step, a PLL's wander
    moved = dev[dev > 0]
    typical = float(np.median(moved)) if moved.size else 0.0
    ratio = dev / (np.abs(v) * h + 10.0 * typical + 1e-12 * (1.0 + float(np.max(np.abs(th)))))
    long = h > 3.0 * float(np.median(h))
    ratio[maximum_filter(long, size, mode="nearest")] = 0.0
    bad = np.flatnonzero(ratio > GLITCH_RATIO)
    if bad.size:
        i = int(bad[0])
        raise DataError(f"{source} row {i + 2}: {label} jumps by {d[i]:.6g} rad from {th[i]:.9g} (row {i + 1}) to "
                        f"{th[i + 1]:.9g}, where the speed around it ({v[i]:.6g} rad/s) predicts {v[i] * h[i]:.3g} rad: "
                        "an encoder glitch or a slip; every angle after it would be off by the jump. Cut the log "
                        "there (or re-record it)")
