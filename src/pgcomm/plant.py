"""The electromagnetic truth a simulation runs against: the plant interface (:class:`pgcomm.protocols.Plant`).

A plant is a pytree with these methods (all vectorised over a leading shape ``S``
and jittable):

* ``gain_phases(y) -> S + (L, 3, 3)``: per coil set, rows ``[Fy, Fx, Tz]``
  (N/A, N/A, N·m/A), columns phases a, b, c;
* ``gain(y) -> S + (L, 3, 2)``: the same reduced to star currents ``(ia, ib)``;
* ``cogging(y) -> S + (3,)``: current-independent force (N, N, N·m);
* ``direction_force(y, v) -> S + (3,)``: velocity-direction-dependent force (N, N, N·m);
* ``force(y, currents, v) -> S + (3,)``: ``Σ_l K^l(y) i^l + F_cog(y) + F_dir(y, v)`` (the
  argument order of the force models', :class:`pgcomm.protocols.ForceModel`);
* ``y_range -> (y_min, y_max)`` in m, the positions where it is defined.

Two implementations: :class:`pgcomm.twin.TwinPlant` (parametric motor with parasitic
effects) and :class:`pgcomm.forcemap.ForceMapPlant` (a tabulated force map).
"""

from __future__ import annotations

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm.motor import PHASE_OFFSETS, total_force
from pgcomm.protocols import Plant


def plant_force(plant: Plant, y, currents, v=None):
    """``F = Σ_l K^l(y) i^l + F_cog(y) + F_dir(y, v)`` for any plant.

    Args:
        y: ``S`` position (m); currents: ``S + (L, 2)`` (A); v: ``S`` velocity (m/s), or ``None``
            for the static force (no direction-dependent term).

    Returns:
        ``S + (3,)`` force ``[Fy, Fx, Tz]`` (N, N, N·m).
    """
    f = total_force(plant.gain(y), currents) + plant.cogging(y)
    return f if v is None else f + plant.direction_force(y, v)


def static_force(plant: Plant, y, currents):
    """Static part ``Σ_l K^l(y) i^l + F_cog(y)`` (no direction-dependent term), ``S + (3,)``."""
    return total_force(plant.gain(y), currents) + plant.cogging(y)


def zeros3(y):
    """``S + (3,)`` zeros matching ``y``'s shape."""
    return jnp.zeros(jnp.shape(y) + (3,))


_gain_phases_jit = jax.jit(lambda plant, y: plant.gain_phases(y))


def fundamental(plant: Plant, pole_pitch: float, y_range, n: int = 20001):
    """True fundamental ``(k^l, ζ^l)`` per coil set of any plant: what calibration should recover.

    Parasitic effects (field drift, phase drift, winding imbalance, magnet tolerances) shift
    the fundamental that a balanced sinusoidal commutation sees, so the reference values are
    the least-squares fit of ``(2/3) k^l sin(2π y/d_m + ζ^l + φ_p)`` (``φ_p`` the phase offsets
    0, 2π/3, −2π/3 of phases a, b, c) to the plant's true ``Fy`` row of every phase, jointly
    over the three phases, on ``n`` points uniformly spaced in ``y`` over ``y_range``.
    The fit is linear in ``(k cos ζ, k sin ζ)``; ``ζ`` comes from ``atan2`` and lies in
    ``(−π, π]``.

    Args:
        plant: any plant with ``gain_phases(y) -> S + (L, 3, 3)`` (N/A; :mod:`pgcomm.plant`).
        pole_pitch: ``d_m`` (m).
        y_range: ``(y_lo, y_hi)`` (m), the positions the fit covers (e.g. the calibration
            reference's span); must lie inside the plant's range.
        n: number of fit points, ``>= 2``.

    Returns:
        ``(k (L,) N/A, zeta (L,) rad)`` as NumPy arrays.
    """
    lo, hi = (float(v) for v in y_range)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"fundamental: y_range = ({lo}, {hi}) m is not an increasing pair of finite numbers")
    y = np.linspace(lo, hi, int(n))
    g = np.asarray(_gain_phases_jit(plant, jnp.asarray(y)))  # (n, L, 3, 3)
    w = 2 * np.pi * y / pole_pitch
    x = np.concatenate([np.stack([np.sin(w + f), np.cos(w + f)], -1) * (2.0 / 3.0) for f in PHASE_OFFSETS])
    rhs = np.concatenate([g[:, :, 0, p] for p in range(3)])  # (3n, L): every coil set at once
    coef, *_ = np.linalg.lstsq(x, rhs, rcond=None)          # (2, L): k cos ζ, k sin ζ
    return np.hypot(coef[0], coef[1]), np.arctan2(coef[1], coef[0])
