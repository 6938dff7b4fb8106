"""Nominal motor description and the ideal (sinusoidal) electromagnetic model.

Implements eq. Electromagnetics_GainMatrix (ideal gain matrix of one coil set),
eq. Electromagnetics_Phase (commutation phase) and eq. Electromagnetics_Coilsets
(sum over coil sets), with the star connection ``ic = -ia - ib`` that leaves two
independent currents per coil set.

Phase order a, b, c corresponds to ``sin(eta), sin(eta + 2pi/3), sin(eta - 2pi/3)``.
The torque row of coil set ``l`` is ``d^l`` times its ``Fx`` row.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

#: Electrical offsets of phases a, b, c (rad).
PHASE_OFFSETS = (0.0, 2.0 * np.pi / 3.0, -2.0 * np.pi / 3.0)

#: Map from three phase currents to the two independent star currents:
#: ``i3 = STAR @ i2`` with ``i2 = [ia, ib]`` and ``ic = -ia - ib``.
STAR = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, -1.0]])


@dataclass(frozen=True)
class Motor:
    """Nominal description of a multi-coil-set three-phase linear motor.

    Attributes:
        pole_pitch: magnetic pole pitch ``d_m`` (m), the length of two magnets.
        lever_arms: ``d^l`` per coil set (m), position of coil set ``l`` along ``y``
            relative to the translator's centre of mass; length ``L``.
        k: nominal motor constants ``k̂^l`` (N/A), length ``L``.
        zeta: nominal commutation phase offsets ``ζ̂^l`` (rad), length ``L``.
        mu: nominal ratio ``μ̂`` of the out-of-plane force constant (-).
        sample_time: controller sample time (s).
        current_limit: peak phase current limit of the drive (A), or ``None``.
        mass: moving mass ``m`` of the translator (kg), or ``None`` (unknown). Needed only to
            identify without a force sensor (``m ÿ`` is then the measured force).
        travel: ``(lo, hi)`` (m), the positions a reference may cover on the rig (the usable travel
            less a few mm for the following error at reversals), or ``None`` (unknown).
            :mod:`pgcomm.plan` spans the experiments' reference over it.
    """

    pole_pitch: float = 0.03
    lever_arms: tuple[float, ...] = (-0.065, 0.005, 0.075)
    k: tuple[float, ...] = (67.0, 67.0, 67.0)
    zeta: tuple[float, ...] = (-0.52, -0.52, -0.52)
    mu: float = 0.05
    sample_time: float = 1e-3
    current_limit: float | None = 10.0
    mass: float | None = None
    travel: tuple[float, float] | None = None

    def __post_init__(self):
        if self.travel is not None:
            lo, hi = (float(x) for x in self.travel)
            if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
                raise ValueError(f"travel = {self.travel} m: expected [lo, hi] with lo < hi")
            object.__setattr__(self, "travel", (lo, hi))
        if self.mass is not None:
            m = float(self.mass)
            if not (np.isfinite(m) and m > 0):
                raise ValueError(f"mass = {self.mass} kg: expected a positive moving mass")
            object.__setattr__(self, "mass", m)
        n = len(self.lever_arms)
        for name in ("k", "zeta"):
            v = getattr(self, name)
            if np.ndim(v) == 0:
                object.__setattr__(self, name, (float(v),) * n)
            else:
                object.__setattr__(self, name, tuple(float(x) for x in v))
        object.__setattr__(self, "lever_arms", tuple(float(x) for x in self.lever_arms))
        if len(self.k) != n or len(self.zeta) != n:
            raise ValueError(f"k and zeta need one value per coil set ({n}); got {len(self.k)} and {len(self.zeta)}")

    @property
    def n_coil_sets(self) -> int:
        """Number of coil sets ``L``."""
        return len(self.lever_arms)

    def with_nominal(self, k=None, zeta=None) -> "Motor":
        """Copy with other nominal ``k̂`` (N/A) and/or ``ζ̂`` (rad) (scalars or length ``L``)."""
        return replace(self, k=self.k if k is None else k, zeta=self.zeta if zeta is None else zeta)


def commutation_phase(y, zeta, pole_pitch):
    """Commutation phase ``η = 2π y / d_m + ζ`` (eq. Electromagnetics_Phase).

    Args:
        y: position (m), any shape ``S``.
        zeta: phase offset (rad), broadcastable against ``y``.
        pole_pitch: ``d_m`` (m).

    Returns:
        ``η`` (rad), shape ``broadcast(S, zeta)``.
    """
    return 2.0 * jnp.pi * y / pole_pitch + zeta


def ideal_gain_phases(y, k, zeta, mu, lever_arm, pole_pitch):
    """Ideal gain matrix of one coil set over its three phases (eq. Electromagnetics_GainMatrix).

    Args:
        y: position (m), shape ``S``.
        k, zeta, mu, lever_arm: ``k^l`` (N/A), ``ζ^l`` (rad), ``μ`` (-), ``d^l`` (m);
            scalars or broadcastable against ``S``.
        pole_pitch: ``d_m`` (m).

    Returns:
        ``K^l(y)`` with shape ``S + (3, 3)``: rows ``[Fy, Fx, Tz]`` (N/A, N/A, N·m/A),
        columns phases a, b, c.
    """
    eta = commutation_phase(jnp.asarray(y), zeta, pole_pitch)[..., None] + jnp.asarray(PHASE_OFFSETS)
    amp = (2.0 / 3.0) * jnp.asarray(k)[..., None]
    mu = jnp.asarray(mu)[..., None]
    d = jnp.asarray(lever_arm)[..., None]
    fy = amp * jnp.sin(eta)
    fx = amp * mu * jnp.cos(eta)
    return jnp.stack([fy, fx, d * fx], axis=-2)


def star_reduce(gain3):
    """Reduce a ``(..., 3, 3)`` phase gain matrix to the star currents ``(ia, ib)``.

    With ``ic = -ia - ib`` the force is ``K3 @ STAR @ [ia, ib]``.

    Returns:
        shape ``(..., 3, 2)``.
    """
    # explicit columns instead of a matmul: tiny dots are slow inside XLA loops
    return jnp.stack([gain3[..., 0] - gain3[..., 2], gain3[..., 1] - gain3[..., 2]], axis=-1)


def ideal_gain(y, motor: Motor, k=None, zeta=None, mu=None):
    """Ideal star-reduced gain matrices of all coil sets (eqs. 8 and Electromagnetics_Coilsets).

    Args:
        y: position (m), shape ``S``.
        motor: gives ``d_m`` and lever arms; ``k``, ``zeta``, ``mu`` default to its
            nominal values and may be overridden with arrays of length ``L``.

    Returns:
        ``K(y)`` with shape ``S + (L, 3, 2)``; the total force is
        ``F = Σ_l K[..., l, :, :] @ i[..., l, :]`` with ``i`` of shape ``S + (L, 2)``.
    """
    k = jnp.asarray(motor.k if k is None else k, dtype=float)
    zeta = jnp.asarray(motor.zeta if zeta is None else zeta, dtype=float)
    mu = motor.mu if mu is None else mu
    d = jnp.asarray(motor.lever_arms)
    yb = jnp.asarray(y, dtype=float)[..., None]
    g3 = ideal_gain_phases(yb, k, zeta, mu, d, motor.pole_pitch)
    return star_reduce(g3)


def total_force(gain, currents):
    """``F = Σ_l K^l i^l`` (eq. Electromagnetics_Coilsets).

    Args:
        gain: ``(..., L, 3, 2)``.
        currents: ``(..., L, 2)`` star currents (A).

    Returns:
        ``(..., 3)`` force ``[Fy, Fx, Tz]`` (N, N, N·m).
    """
    return jnp.sum(gain * jnp.asarray(currents)[..., None, :], axis=(-3, -1))


def star_to_phases(currents):
    """``(..., 2)`` star currents ``(ia, ib)`` to ``(..., 3)`` phase currents ``(ia, ib, ic)`` (A)."""
    currents = jnp.asarray(currents)
    return jnp.concatenate([currents, -(currents[..., :1] + currents[..., 1:2])], axis=-1)
