"""The rotary commutation law: the q-current that delivers a demanded torque, safe for any input.

Given a torque demand ``T*`` (N·m) — or the same demand as a current ``u = T*/k0`` (A), which is
what a drive's speed or position loop outputs — the law inverts the identified map::

    i_q = (u − c(θ) + d(θ) s) / (1 + r(θ))           u = T*/k0

``c`` the cogging as an equivalent current, ``d`` the direction-dependent drag (``s`` the sign of
the velocity, or ``None`` to leave the direction term out), ``r`` the torque-constant ripple
(:class:`pgcomm.rotary.model.RotaryModel`). Every angle is inside (the maps are periodic over one
revolution, multi-turn angles included). A NaN or infinite demand, angle or direction gives zero
current (never a NaN into a drive); the result is clipped to ``±current_limit``; the gain
``1 + r`` is kept at or above :data:`MIN_GAIN` so a wildly wrong model cannot ask for an
unbounded current.

**Which angle.** A drive holds the current it computes for one update period ``T`` (its current
reference rate). Evaluate the law at the angle the rotor has in the middle of that hold,
:func:`hold_angle` ``= θ + ω T/2``, not at the sampled ``θ``: a compensation read at the sample's
start lags half a period, which leaves ``2 sin(π/N)`` of a cogging harmonic that has ``N`` updates
per period uncompensated (20 % at ``N = 16``; 0.3 % at a 20 kHz current loop and 1000 periods per
second).
"""

from __future__ import annotations

import numpy as np

from pgcomm.rotary.model import RotaryModel

__all__ = ["iq_command", "iq_for_torque", "hold_angle", "MIN_GAIN"]

#: Smallest relative gain ``1 + r(θ)`` the law divides by.
MIN_GAIN = 0.5


def iq_command(model: RotaryModel, demand, theta, direction=None, current_limit: float | None = None) -> np.ndarray:
    """q-current command (A) for a demand in current units.

    Args:
        model: the identified (or true) :class:`RotaryModel`.
        demand: ``u`` (A): demanded torque divided by the mean torque constant ``k0``; any shape.
        theta: mechanical angle (rad, multi-turn) at which the current acts, broadcast with ``demand``
            (:func:`hold_angle` of the sampled angle for a held current).
        direction: sign of the velocity (+1/−1/0 or an array, broadcast) or ``None`` (no
            direction term).
        current_limit: ``|i_q|`` bound (A) or ``None``.

    Returns:
        ``(broadcast shape)`` float array (A); zero where any input is NaN/inf.
    """
    u = np.asarray(demand, float)
    th = np.asarray(theta, float)
    s = np.zeros(()) if direction is None else np.sign(np.asarray(direction, float))
    shape = np.broadcast_shapes(u.shape, th.shape, s.shape)
    u, th, s = (np.broadcast_to(x, shape) for x in (u, th, s))
    ok = np.isfinite(u) & np.isfinite(th) & np.isfinite(s)
    th0 = np.where(ok, th, 0.0)
    u0 = np.where(ok, u, 0.0)
    s0 = np.where(ok, s, 0.0)
    gain = np.maximum(model.gain(th0), MIN_GAIN)
    iq = (u0 - model.cogging(th0) + model.direction(th0) * s0) / gain
    iq = np.where(ok & np.isfinite(iq), iq, 0.0)
    if current_limit is not None:
        iq = np.clip(iq, -float(current_limit), float(current_limit))
    return iq


def iq_for_torque(model: RotaryModel, torque, theta, direction=None, k_t: float | None = None,
                  current_limit: float | None = None) -> np.ndarray:
    """q-current command (A) for a torque demand ``T*`` (N·m): :func:`iq_command` with ``u = T*/k_t``.

    Args:
        k_t: mean torque constant (N·m/A); default ``model.k_t``.

    Raises:
        ValueError: no torque constant known (identify in current units and use :func:`iq_command`).
    """
    k = k_t if k_t is not None else model.k_t
    if k is None or not np.isfinite(k) or k <= 0:
        raise ValueError("a torque demand in N·m needs the torque constant k_t (N·m/A) > 0; "
                         "without it use iq_command with the demand in A")
    return iq_command(model, np.asarray(torque, float) / float(k), theta, direction, current_limit)


def hold_angle(theta, velocity, hold_time: float, advance: float = 0.5) -> np.ndarray:
    """The angle at which to evaluate the law for a current held over ``hold_time``: ``θ + advance · ω · T``.

    Args:
        theta: sampled mechanical angle (rad, multi-turn), any shape.
        velocity: the drive's velocity estimate (rad/s), broadcast with ``theta``.
        hold_time: ``T`` (s): the period over which the computed current is held (the current
            reference's update period).
        advance: share of ``T`` (½: the middle of the hold, module docstring).

    Returns:
        ``(broadcast shape)`` angle (rad); NaN where an input is NaN (the law then gives zero current).
    """
    return np.asarray(theta, float) + float(advance) * float(hold_time) * np.asarray(velocity, float)
