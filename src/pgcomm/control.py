"""Position control: PID feedback with low-pass, feedforward (eq. FeedforwardController) and its identification.

Feedback (discrete, sample time ``Ts``)::

    u_pid[k] = kp e[k] + ki Ts Σ_{j<=k} e[j] + kd (e[k] - e[k-1]) / Ts
    u_fb[k]  = u_fb[k-1] + α (u_pid[k] - u_fb[k-1]),   α = 1 - exp(-2π f_lp Ts)

Feedforward (eq. FeedforwardController) with ``δ = (z + 1)/2``::

    g[k]    = m a_r[k] + f_v v_r[k] + f_c sign(v_r[k])
    u_ff[k] = (g[k+1] + g[k]) / 2

The default tuning is the classical loop-shaping rule for a mass ``m`` with a
target bandwidth ``f_bw``: ``kp = m ω²/3``, ``kd = m ω`` (lead around ``ω``),
``ki = kp ω/10`` (integrator well below crossover), low-pass at ``5 f_bw``. The
default ``f_bw = 6 Hz`` for the 30 kg translator is a soft industrial tuning; it is
what the paper's classical tracking-error MSE (2.75e-8 m² on its long reference)
implies for a commutation error of its size (27 N²): with 10 Hz the same
commutation error would give a tracking MSE about 15x smaller.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PID:
    """Discrete PID with first-order output low-pass.

    Attributes:
        kp: N/m; ki: N/(m·s); kd: N·s/m; lowpass_hz: Hz.
    """

    kp: float
    ki: float
    kd: float
    lowpass_hz: float

    @classmethod
    def tuned(cls, mass: float = 30.0, bandwidth_hz: float = 6.0) -> "PID":
        """Loop-shaping tuning for a mass ``mass`` (kg) and crossover ``bandwidth_hz`` (Hz)."""
        w = 2 * np.pi * bandwidth_hz
        kp = mass * w**2 / 3.0
        return cls(kp=kp, ki=kp * w / 10.0, kd=mass * w, lowpass_hz=5.0 * bandwidth_hz)

    def alpha(self, sample_time: float) -> float:
        """Low-pass coefficient ``α`` for sample time ``sample_time`` (s) (ZOH-exact first-order pole)."""
        return 1.0 - float(np.exp(-2 * np.pi * self.lowpass_hz * sample_time))


@dataclass(frozen=True)
class Feedforward:
    """Feedforward parameters: mass ``m`` (kg), viscous ``f_v`` (N·s/m), Coulomb ``f_c`` (N).

    Optionally a Coulomb term that varies along the stroke, ``D(r)`` (N) at ``coulomb_knots``
    (m, increasing; linearly interpolated, held at the ends), added to ``f_c``: the direction-
    dependent force of guides and cable slab is not one constant
    (:class:`pgcomm.identify.mechanics.MechanicsFit`).
    """

    mass: float = 0.0
    viscous: float = 0.0
    coulomb: float = 0.0
    coulomb_knots: tuple[float, ...] = ()
    coulomb_table: tuple[float, ...] = ()

    def coulomb_at(self, r):
        """``f_c + D(r)`` (N) at reference positions ``r`` (m), shape of ``r``."""
        r = np.asarray(r, float)
        if not self.coulomb_knots:
            return np.full(r.shape, float(self.coulomb))
        return self.coulomb + np.interp(r, self.coulomb_knots, self.coulomb_table)


def feedforward_regressor(v_ref, a_ref):
    """Regressor ``φ[k] = δ [a_r, v_r, sign(v_r)]`` with ``δ = (z+1)/2``, shape ``(N, 3)``.

    Args:
        v_ref, a_ref: ``(N,)`` reference velocity (m/s) and acceleration (m/s²).
    """
    g = np.stack([a_ref, v_ref, np.sign(v_ref)], axis=-1)
    nxt = np.concatenate([g[1:], g[-1:]], axis=0)  # hold the last sample: the reference ends at rest
    return 0.5 * (g + nxt)


def feedforward_signal(ff: Feedforward, v_ref, a_ref, r=None):
    """``u_ff[k]`` (N), shape ``(N,)``, of eq. FeedforwardController.

    With a Coulomb table (``ff.coulomb_knots``) the Coulomb term is ``(f_c + D(r)) sign(v_r)``
    at the reference positions ``r`` (m, required then).
    """
    if not ff.coulomb_knots:
        return feedforward_regressor(v_ref, a_ref) @ np.array([ff.mass, ff.viscous, ff.coulomb])
    if r is None:
        raise ValueError("a feedforward with a Coulomb table needs the reference positions r")
    g = (ff.mass * np.asarray(a_ref) + ff.viscous * np.asarray(v_ref)
         + ff.coulomb_at(r) * np.sign(np.asarray(v_ref)))
    return 0.5 * (g + np.concatenate([g[1:], g[-1:]]))


def identify_feedforward(v_ref, a_ref, force_demand) -> Feedforward:
    """Least-squares ``m, f_v, f_c`` from closed-loop data.

    Solves ``min_θ Σ_k (F*_y[k] - φ[k] θ)²`` with ``φ`` of :func:`feedforward_regressor`
    and ``F*_y`` the driving-force demand of the loop (N) — the force the commutation
    was asked for, so the identified values absorb that commutation's average gain.

    Args:
        v_ref, a_ref: ``(N,)`` reference velocity (m/s), acceleration (m/s²).
        force_demand: ``(N,)`` demanded driving force ``F*_y`` (N).
    """
    phi = feedforward_regressor(np.asarray(v_ref), np.asarray(a_ref))
    theta, *_ = np.linalg.lstsq(phi, np.asarray(force_demand), rcond=None)
    return Feedforward(mass=float(theta[0]), viscous=float(theta[1]), coulomb=float(theta[2]))
