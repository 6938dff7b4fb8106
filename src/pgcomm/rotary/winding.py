"""The twin's winding: the q-axis voltage a field-oriented drive logs beside its current.

A drive's current loop commands the voltage that drives its current through the winding; the q component,
in the drive's own frame, is::

    v_q = R i_q + L di_q/dt + e_q(θ, ω) + v_dt + noise                    (V)

with ``R``, ``L`` the phase resistance and inductance (a surface-magnet machine: ``L_d = L_q``, and the
drive's ``i_d`` is held at zero, so the cross-coupling ``ω_e L i_d`` vanishes). **The back-EMF is the torque
constant seen from the other side**: the power the magnets' field exchanges with the winding is
``(3/2) e_q i_q = T_em ω`` (amplitude-invariant Park transform, as the open drives use), so::

    e_q = (2/3) k0 (1 + ρ(θ)) ω

with the same ``k0 = k_t cos δ`` and the same relative ripple ``ρ`` as :mod:`pgcomm.rotary.twin`'s torque: the
drive's frame is off the motor's by ``δ``, which scales the back-EMF's q component by ``cos δ`` exactly as it
scales the torque of a q-current. Cogging exchanges no power with the winding and does not appear.

``v_dt`` is what the inverter's dead time leaves after the drive's compensation: each phase loses
``V_dt tanh(i_ph/i_ε)`` (the phase current's sign, smoothed over the PWM ripple ``i_ε``), which in the
drive's frame is a voltage against the current plus a sixth electrical harmonic; it does not scale with the
speed. The logged voltage is the drive's command at the sample instant (what ODrive's ``Vq_setpoint`` and
moteus's ``q_V`` are). Its noise is mostly the current loop's: the loop's proportional gain ``K_p`` acts on the
*measured* current, so the command carries ``−K_p n`` of the same noise ``n`` the logged current carries, plus a
little of its own (the converter's resolution). The two logged columns' noises are therefore not independent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Winding", "BackEmf", "q_voltage", "d_voltage", "logged_dq", "deadtime_q", "phase_saturation_q", "phase_saturation_dq", "draw_winding",
           "BACK_EMF_FACTOR"]

#: ``e_q = BACK_EMF_FACTOR · k (1 + ρ) ω``: the amplitude-invariant Park transform's power ``(3/2) v_q i_q``.
BACK_EMF_FACTOR = 2.0 / 3.0


@dataclass(frozen=True)
class Winding:
    """The winding and inverter behind the logged q-voltage (module docstring).

    Attributes:
        resistance: phase resistance ``R`` (Ω).
        inductance: phase inductance ``L`` (H).
        deadtime_voltage: ``V_dt`` (V), each phase's voltage error the dead time leaves after compensation.
        deadtime_current: ``i_ε`` (A), the current over which that error changes sign.
        loop_gain: ``K_p`` (V/A), the current loop's proportional gain: the logged ``v_q`` carries ``−K_p`` times the
            logged current's noise.
        voltage_noise: standard deviation of the logged ``v_q``'s own noise (V).
        voltage_lag: ``τ`` (s): how long after the sample instant the logged voltage command is applied, in the
            frame of the sample's angle (a PWM period and a half where the drive does not advance the angle for its
            inverse Park transform): the logged ``(v_d, v_q)`` is the applied one turned by ``p ω τ``
            (:func:`logged_dq`). 0 for a drive that compensates it (the zoo's).
    """

    resistance: float
    inductance: float
    deadtime_voltage: float
    deadtime_current: float
    loop_gain: float
    voltage_noise: float
    voltage_lag: float = 0.0

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in _FIELDS}

    @classmethod
    def from_dict(cls, d: dict) -> "Winding":
        # voltage_lag came later: truth files without it have none
        return cls(**{k: float(d[k]) for k in _FIELDS if k in d or k != "voltage_lag"})


_FIELDS = ("resistance", "inductance", "deadtime_voltage", "deadtime_current", "loop_gain", "voltage_noise",
           "voltage_lag")


def phase_saturation_dq(iq, theta_e, widths) -> tuple[np.ndarray, np.ndarray]:
    """The d and q components of ``tanh(i_ph / c)`` over the three phases, for each width ``c`` (A): a per-phase odd,
    saturating function of the phase current (the dead time, a switch's drop) seen in the drive's frame with ``i_d = 0``.

    Args:
        iq: ``(N,)`` q-current (A); theta_e: ``(N,)`` the drive's electrical angle (rad); widths: ``(M,)`` (A).

    Returns:
        ``(d, q)``, each ``(N, M)``: ``(2/3) Σ_k c_k tanh(i_q p_k / c)`` and ``(2/3) Σ_k p_k tanh(i_q p_k / c)``
        with ``c_k = cos(θ_e − 2πk/3)``, ``p_k = −sin(θ_e − 2πk/3)`` (amplitude-invariant Park transform: a q-current
        ``i_q`` is the phase currents ``i_q p_k``).
    """
    iq, theta_e = np.asarray(iq, float), np.asarray(theta_e, float)
    d, q = np.zeros((iq.size, len(widths))), np.zeros((iq.size, len(widths)))
    for k in range(3):
        a = theta_e - 2.0 * math.pi * k / 3.0
        c, p = np.cos(a), -np.sin(a)
        for m, w in enumerate(widths):
            s = (2.0 / 3.0) * np.tanh(iq * p / w)
            d[:, m] += c * s
            q[:, m] += p * s
    return d, q


def phase_saturation_q(iq, theta_e, widths) -> np.ndarray:
    """The q component of :func:`phase_saturation_dq`, ``(N, M)``."""
    return phase_saturation_dq(iq, theta_e, widths)[1]


def deadtime_q(iq, theta_e, deadtime_voltage: float, deadtime_current: float) -> np.ndarray:
    """The dead time's voltage error in the drive's q axis (V): each phase loses ``V_dt tanh(i_ph/i_ε)``.

    Args:
        iq: ``(N,)`` q-current (A), ``i_d = 0``; theta_e: ``(N,)`` the drive's electrical angle (rad).
        deadtime_voltage, deadtime_current: ``V_dt`` (V), ``i_ε`` (A).

    Returns:
        ``(N,)`` (V).
    """
    return -deadtime_voltage * phase_saturation_q(iq, theta_e, [deadtime_current])[:, 0]


@dataclass(frozen=True)
class BackEmf:
    """The magnets' field as the winding meets it in the drive's frame (module docstring).

    Attributes:
        k_t: the torque constant along the magnets' q axis (N·m/A).
        offset_error: ``δ`` (rad, electrical): the magnets' frame minus the drive's.
        ripple: ``ρ``, the torque constant's relative ripple (a callable of the mechanical angle in rad, -).
        pole_pairs: ``p``.
        offset: the drive's electrical offset (rad): its frame is ``p θ + offset``.
    """

    k_t: float
    offset_error: float
    ripple: object
    pole_pairs: int
    offset: float = 0.0

    @property
    def k0(self) -> float:
        """The torque constant seen from the drive's frame, ``k_t cos δ`` (N·m/A)."""
        return self.k_t * math.cos(self.offset_error)

    def electrical(self, theta) -> np.ndarray:
        """The drive's electrical angle ``p θ + offset`` (rad) at the mechanical angles ``theta`` (rad)."""
        return self.pole_pairs * np.asarray(theta, float) + self.offset


def q_voltage(winding: Winding, emf: BackEmf, theta, omega, iq, sample_time: float, noise=0.0,
              slope=None) -> np.ndarray:
    """The q-voltage a drive logs at each sample instant (module docstring)::

        v_q = R i_q + L di_q/dt + (2/3) k0 (1 + ρ(θ)) ω + v_dt + noise                    (V)

    Args:
        winding: :class:`Winding`; emf: :class:`BackEmf` (``k0 = k_t cos δ``, ``ρ``, ``p``, the drive's offset).
        theta, omega: ``(N,)`` true angle (rad) and speed (rad/s) at the sample instants.
        iq: ``(N,)`` q-current that flows from each sample instant (A).
        sample_time: ``T_s`` (s); noise: ``(N,)`` standard normal draws (the voltage's own noise), or ``0.0``.
        slope: ``(N,)`` the current's slope at the instants (A/s), or ``None``: its central difference over
            ``sample_time`` (a twin whose drive controls faster than it logs passes the control rate's, and the
            other arrays at the logged instants only).

    Returns:
        ``(N,)`` logged ``v_q`` (V), without the loop's ``−K_p n`` of the logged current's noise ``n`` (the caller's,
        who drew it).
    """
    th, om, iq = (np.asarray(v, float) for v in (theta, omega, iq))
    # the current's slope at the instant: the drive's loop moves the current from one sample's value to the next
    if slope is not None:
        di = np.asarray(slope, float)
    else:
        di = np.gradient(iq, sample_time) if iq.size > 1 else np.zeros_like(iq)
    back = BACK_EMF_FACTOR * emf.k0 * (1.0 + np.asarray(emf.ripple(th), float)) * om
    dt = deadtime_q(iq, emf.electrical(th), winding.deadtime_voltage, winding.deadtime_current)
    return winding.resistance * iq + winding.inductance * di + back + dt + winding.voltage_noise * np.asarray(noise)


def d_voltage(winding: Winding, emf: BackEmf, theta, omega, iq, noise=0.0) -> np.ndarray:
    """The d-voltage a drive logs at each sample instant, its d-current held at zero::

        v_d = −p ω L i_q − (2/3) k_t sin δ (1 + ρ(θ)) ω + v_dt,d + noise          (V)

    The first term is the rotating frame's cross-coupling; the second the back-EMF's d component: the magnets' q
    axis is ``δ`` ahead of the drive's (``emf.offset_error``, true frame minus drive frame), so the back-EMF
    ``(2/3) k_t (1 + ρ) ω`` along it has ``cos δ`` of itself on the drive's q axis (:func:`q_voltage`'s ``k0``) and
    ``−sin δ`` on its d axis. The drive's offset is therefore read off the two voltages; a drive with its offset
    right logs no back-EMF on d.

    Args:
        winding: :class:`Winding`; emf: :class:`BackEmf`.
        theta, omega: ``(N,)`` true angle (rad) and speed (rad/s) at the sample instants.
        iq: ``(N,)`` q-current that flows from each sample instant (A).
        noise: ``(N,)`` standard normal draws (the voltage's own noise), or ``0.0``.

    Returns:
        ``(N,)`` logged ``v_d`` (V), without the loop's ``−K_p n_d`` of the logged d-current's noise (the caller's).
    """
    th, om, iq = (np.asarray(v, float) for v in (theta, omega, iq))
    back = -BACK_EMF_FACTOR * emf.k_t * math.sin(emf.offset_error) * (1.0 + np.asarray(emf.ripple(th), float)) * om
    dt = -winding.deadtime_voltage * phase_saturation_dq(iq, emf.electrical(th), [winding.deadtime_current])[0][:, 0]
    return -emf.pole_pairs * om * winding.inductance * iq + back + dt + winding.voltage_noise * np.asarray(noise)


def logged_dq(vd, vq, pole_pairs: int, omega, lag: float) -> tuple[np.ndarray, np.ndarray]:
    """The ``(v_d, v_q)`` a drive logs when it applies its command ``lag`` seconds after the sample instant in the frame
    of the sample's angle: the voltage the winding needs, turned by ``φ = p ω τ`` (the rotor turns on while the command
    waits), so the back-EMF's logged d/q ratio reads ``δ + φ``.

    Args:
        vd, vq: ``(N,)`` the voltage the winding needs in the drive's frame (V); pole_pairs: ``p``; omega: ``(N,)``
            speed (rad/s); lag: ``τ`` (s).

    Returns:
        ``(v_d, v_q)`` logged, each ``(N,)`` (V).
    """
    phi = pole_pairs * np.asarray(omega, float) * float(lag)
    c, s = np.cos(phi), np.sin(phi)
    vd, vq = np.asarray(vd, float), np.asarray(vq, float)
    return c * vd - s * vq, s * vd + c * vq


def draw_winding(rng, k_t: float, current_noise: float) -> Winding:
    """A plausible winding for a motor of torque constant ``k_t`` (N·m/A).

    Phase resistance ``(0.5–2.5) Ω`` per N·m/A of ``k_t`` (small drones' motors of 0.03 N·m/A have 0.04 Ω,
    servo motors of 1.5 N·m/A 2 Ω); electrical time constant 0.3–3 ms; the dead time's residual 0.02–0.3 V
    per phase over a zero crossing 2–10 times the current's noise wide; the current loop's proportional gain
    ``L ω_c`` for a bandwidth of 0.5–2 kHz, and 5 mV of the voltage's own noise (the converter's resolution).

    Args:
        rng: :class:`numpy.random.Generator`; k_t: N·m/A; current_noise: std of the logged current (A).
    """
    r = float(k_t * rng.uniform(0.5, 2.5))
    ind = float(r * np.exp(rng.uniform(np.log(3e-4), np.log(3e-3))))
    v_dt = float(np.exp(rng.uniform(np.log(0.02), np.log(0.3))))
    i_eps = float(current_noise * rng.uniform(2.0, 10.0))
    kp = ind * 2 * math.pi * float(np.exp(rng.uniform(np.log(500.0), np.log(2000.0))))
    return Winding(r, ind, v_dt, i_eps, kp, 0.005)
