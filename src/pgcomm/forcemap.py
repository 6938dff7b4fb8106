"""A plant given as a table: the force map (e.g. from FEM or a measurement).

The file format (CSV; reader and writer in :mod:`pgcomm.io.forcemap`):

* ``y`` (m): positions, strictly increasing, at least 2 rows;
* for each coil set ``l = 1..L`` and phase ``p ∈ {a, b, c}``: ``Fy_{l}{p}``,
  ``Fx_{l}{p}`` (N/A) and ``Tz_{l}{p}`` (N·m/A): force and torque about the
  centre of mass produced by 1 A in that phase at position ``y``;
* optional ``Fy_cog``, ``Fx_cog`` (N), ``Tz_cog`` (N·m): current-independent
  force; zero when absent.

``L`` is read from the column names; coil sets must be numbered 1..L without
holes, each with all nine columns. The force is

    F(y, i) = Σ_l Σ_p K_lp(y) i_lp + F_cog(y),

linearly interpolated between rows. Positions outside ``[y_0, y_{M-1}]`` are an
error, not an extrapolation: :meth:`ForceMapPlant.in_range` tells (jittable)
and :func:`check_in_range` raises (host side); inside the interpolation such
positions are clamped to the ends so that a jitted loop never reads out of
bounds.
"""

from __future__ import annotations

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.errors import DataError
from pgcomm.interp import interp_linear
from pgcomm.motor import star_reduce
from pgcomm.plant import plant_force, zeros3
from pgcomm.protocols import Plant

__all__ = ["ForceMapPlant", "check_in_range"]


#: Relative deviation of grid points from an exactly uniform grid below which the
#: index-arithmetic fast path is used (weights always come from the real grid).
_UNIFORM_TOL = 1e-9


@pytree_dataclass
class ForceMapPlant:
    """Plant whose electromagnetics are a tabulated force map (interface of :mod:`pgcomm.plant`).

    Attributes:
        y_grid: ``(M,)`` positions (m), strictly increasing, ``M >= 2``.
        gain_table: ``(M, L, 3, 3)``: per coil set, rows ``[Fy, Fx, Tz]``
            (N/A, N/A, N·m/A), columns phases a, b, c.
        cog_table: ``(M, 3)`` current-independent force ``[Fy, Fx, Tz]`` (N, N, N·m).
        uniform: static; ``True`` if ``y_grid`` is uniform, which enables the
            index-arithmetic lookup instead of a binary search.
        source: static; name for messages (file name).

    Build with :meth:`from_arrays` (validates) or :func:`pgcomm.io.forcemap.load_forcemap`.
    """

    y_grid: jax.Array
    gain_table: jax.Array
    cog_table: jax.Array
    uniform: bool = static_field(default=False)
    source: str = static_field(default="force map")

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_arrays(cls, y, gain_phases, cogging=None, source: str = "force map") -> "ForceMapPlant":
        """Validated force map from arrays.

        Args:
            y: ``(M,)`` positions (m), strictly increasing, ``M >= 2``.
            gain_phases: ``(M, L, 3, 3)`` per-ampere forces/torques (N/A, N·m/A).
            cogging: ``(M, 3)`` (N, N, N·m), or ``None`` for zero.
            source: name for messages.

        Raises:
            DataError: wrong shapes, fewer than 2 rows, NaN/inf, ``y`` not strictly increasing.
        """
        y = np.asarray(y, dtype=np.float64)
        g = np.asarray(gain_phases, dtype=np.float64)
        c = np.zeros((len(y), 3)) if cogging is None else np.asarray(cogging, dtype=np.float64)
        if y.ndim != 1:
            raise DataError(f"{source}: y has shape {y.shape}, expected (M,)")
        m = len(y)
        if m < 2:
            raise DataError(f"{source}: {m} rows, a force map needs at least 2")
        if g.ndim != 4 or g.shape[0] != m or g.shape[2:] != (3, 3) or g.shape[1] < 1:
            raise DataError(f"{source}: gain table has shape {g.shape}, expected ({m}, L, 3, 3) with L >= 1")
        if c.shape != (m, 3):
            raise DataError(f"{source}: cogging table has shape {c.shape}, expected ({m}, 3)")
        for name, a in (("y", y), ("gain table", g), ("cogging table", c)):
            bad = ~np.isfinite(a.reshape(m, -1)).all(axis=1)
            if bad.any():
                raise DataError(f"{source} row {int(np.flatnonzero(bad)[0]) + 1}: {name} has NaN or inf")
        dy = np.diff(y)
        if (dy <= 0).any():
            i = int(np.flatnonzero(dy <= 0)[0])
            raise DataError(
                f"{source} row {i + 2}: y = {y[i + 1]:.17g} m is not greater than y = {y[i]:.17g} m of row {i + 1}"
                " (column 'y' must be strictly increasing)"
            )
        h = (y[-1] - y[0]) / (m - 1)
        uniform = bool(np.max(np.abs(y - (y[0] + h * np.arange(m)))) <= _UNIFORM_TOL * h)
        return cls(jnp.asarray(y), jnp.asarray(g), jnp.asarray(c), uniform=uniform, source=str(source))

    @classmethod
    def from_plant(cls, plant: Plant, y, source: str = "sampled plant") -> "ForceMapPlant":
        """Sample another plant's ``gain_phases`` and ``cogging`` at positions ``y`` (m, ``(M,)``)."""
        y = np.asarray(y, dtype=np.float64)
        gain, cog = _sample_plant(plant, jnp.asarray(y))
        return cls.from_arrays(y, np.asarray(gain), np.asarray(cog), source)

    # ------------------------------------------------------------------ properties

    @property
    def n_coil_sets(self) -> int:
        """Number of coil sets ``L``."""
        return self.gain_table.shape[1]

    @property
    def y_range(self):
        """``(y_min, y_max)`` (m): the positions where the map is defined (floats when concrete)."""
        g = self.y_grid
        try:
            return float(g[0]), float(g[-1])
        except (jax.errors.ConcretizationTypeError, jax.errors.TracerArrayConversionError):
            return g[0], g[-1]  # inside jit: traced values

    # ------------------------------------------------------------------ lookup (pgcomm.interp.interp_linear)

    def gain_phases(self, y):
        """Per-phase gains ``S + (L, 3, 3)`` (N/A, N·m/A) at positions ``y`` (m, shape ``S``)."""
        return interp_linear(self.y_grid, self.gain_table, y, self.uniform)

    def gain(self, y):
        """Star-reduced gains ``S + (L, 3, 2)`` for currents ``(ia, ib)``, ``ic = -ia - ib``."""
        return star_reduce(self.gain_phases(y))

    def cogging(self, y):
        """Current-independent force ``S + (3,)`` (N, N, N·m) at positions ``y`` (m)."""
        return interp_linear(self.y_grid, self.cog_table, y, self.uniform)

    def direction_force(self, y, v):
        """Direction-dependent force: a force map has none, ``S + (3,)`` zeros."""
        return zeros3(jnp.asarray(y))

    def force(self, y, currents, v=None):
        """``F = Σ_l K^l(y) i^l + F_cog(y)`` (N, N, N·m), ``S + (3,)``; currents ``S + (L, 2)`` (A)."""
        return plant_force(self, y, currents, v)

    def in_range(self, y):
        """``S`` booleans: position inside ``[y_min, y_max]`` of the map (NaN is outside). Jittable."""
        y = jnp.asarray(y)
        return (y >= self.y_grid[0]) & (y <= self.y_grid[-1])


def check_in_range(plant: Plant, y, where: str) -> None:
    """Raise :class:`DataError` if any position in ``y`` lies outside ``plant.y_range``.

    Host-side companion of :meth:`ForceMapPlant.in_range` (a jitted loop cannot
    raise): call it on the positions a simulation produced, or on a trajectory
    before simulating. Works for any plant with ``y_range``.

    Args:
        plant: a plant with ``y_range`` (and optionally ``source``).
        y: positions (m), any shape.
        where: what the positions are, for the message (e.g. ``"simulation of exp.toml"``).
    """
    lo, hi = (float(v) for v in plant.y_range)
    y = np.asarray(y, dtype=np.float64)
    ok = (y >= lo) & (y <= hi)
    if ok.all():
        return
    bad = np.flatnonzero(~ok.ravel())
    idx = int(bad[0])
    pos = idx if y.ndim <= 1 else tuple(int(k) for k in np.unravel_index(idx, y.shape))
    more = f", and {len(bad) - 1} more" if len(bad) > 1 else ""
    name = getattr(plant, "source", type(plant).__name__)
    raise DataError(
        f"{where}: position y = {y.ravel()[idx]:.9g} m (sample {pos}{more}) is outside the force map "
        f"{name} (y from {lo:.9g} to {hi:.9g} m; force maps are not extrapolated)"
    )


@jax.jit
def _sample_plant(plant, y):
    """``(gain_phases(y), cogging(y))`` of any plant in one compiled call (plants are pytrees)."""
    return plant.gain_phases(y), plant.cogging(y)
