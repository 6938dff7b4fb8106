"""The electromagnetic truth a simulation runs against: the plant interface.

A plant is a pytree with these methods (all vectorised over a leading shape ``S``
and jittable):

* ``gain_phases(y) -> S + (L, 3, 3)``: per coil set, rows ``[Fy, Fx, Tz]``
  (N/A, N/A, N·m/A), columns phases a, b, c;
* ``gain(y) -> S + (L, 3, 2)``: the same reduced to star currents ``(ia, ib)``;
* ``cogging(y) -> S + (3,)``: current-independent force (N, N, N·m);
* ``direction_force(y, v) -> S + (3,)``: velocity-direction-dependent force (N, N, N·m);
* ``force(y, v, currents) -> S + (3,)``: ``Σ_l K^l(y) i^l + F_cog(y) + F_dir(y, v)``;
* ``y_range -> (y_min, y_max)`` in m, the positions where it is defined.

Two implementations: :class:`pgcomm.twin.TwinPlant` (parametric motor with parasitic
effects) and :class:`pgcomm.forcemap.ForceMapPlant` (a tabulated force map).
"""

from __future__ import annotations

import jax.numpy as jnp

from pgcomm.motor import total_force


def plant_force(plant, y, v, currents):
    """``F = Σ_l K^l(y) i^l + F_cog(y) + F_dir(y, v)`` for any plant.

    Args:
        y: ``S`` position (m); v: ``S`` velocity (m/s); currents: ``S + (L, 2)`` (A).

    Returns:
        ``S + (3,)`` force ``[Fy, Fx, Tz]`` (N, N, N·m).
    """
    return total_force(plant.gain(y), currents) + plant.cogging(y) + plant.direction_force(y, v)


def static_force(plant, y, currents):
    """Static part ``Σ_l K^l(y) i^l + F_cog(y)`` (no direction-dependent term), ``S + (3,)``."""
    return total_force(plant.gain(y), currents) + plant.cogging(y)


def zeros3(y):
    """``S + (3,)`` zeros matching ``y``'s shape."""
    return jnp.zeros(jnp.shape(y) + (3,))
