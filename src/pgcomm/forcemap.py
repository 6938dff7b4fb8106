"""A plant given as a table: the force map (e.g. from FEM or a measurement).

File format (DESIGN, "Formats"): CSV with a header line.

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

import re

import jax
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.errors import DataError
from pgcomm.io.atomic import atomic_open
from pgcomm.io.config import closest_hint
from pgcomm.io.logs import read_csv_columns, read_csv_header
from pgcomm.motor import star_reduce
from pgcomm.plant import plant_force, zeros3

__all__ = ["ForceMapPlant", "load_forcemap", "write_forcemap", "check_in_range", "forcemap_columns"]

_QUANTITIES = ("Fy", "Fx", "Tz")
_PHASES = ("a", "b", "c")
_COG = ("Fy_cog", "Fx_cog", "Tz_cog")
_GAIN_RE = re.compile(r"^(Fy|Fx|Tz)_([0-9]+)([abc])$")

#: Relative deviation of grid points from an exactly uniform grid below which the
#: index-arithmetic fast path is used (weights always come from the real grid).
_UNIFORM_TOL = 1e-9


def forcemap_columns(n_coil_sets: int, cogging: bool = True) -> list[str]:
    """Column names of a force map with ``n_coil_sets`` coil sets, in file order."""
    names = ["y"]
    for l in range(1, n_coil_sets + 1):
        names += [f"{q}_{l}{p}" for q in _QUANTITIES for p in _PHASES]
    return names + (list(_COG) if cogging else [])


def _interp(table, i, w):
    """Linear interpolation of ``table`` rows ``i``, ``i+1`` with weight ``w`` on row ``i+1``.

    ``(1 - w) t0 + w t1`` (rather than ``t0 + w (t1 - t0)``) so that the result is
    exactly a table row at ``w = 0`` and at ``w = 1``.
    """
    w = w.reshape(w.shape + (1,) * (table.ndim - 1))
    return (1.0 - w) * table[i] + w * table[i + 1]


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

    Build with :meth:`from_arrays` (validates) or :func:`load_forcemap`.
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
    def from_plant(cls, plant, y, source: str = "sampled plant") -> "ForceMapPlant":
        """Sample another plant's ``gain_phases`` and ``cogging`` at positions ``y`` (m, ``(M,)``)."""
        y = np.asarray(y, dtype=np.float64)
        # one compiled call instead of op-by-op dispatch (plants are pytrees)
        gain, cog = jax.jit(lambda p, q: (p.gain_phases(q), p.cogging(q)))(plant, jnp.asarray(y))
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

    # ------------------------------------------------------------------ lookup

    def _locate(self, y):
        """Cell index ``i`` and weight ``w`` of row ``i + 1`` for positions ``y`` (shape ``S``)."""
        g = self.y_grid
        m = g.shape[0]
        # Clamp: out-of-range positions read the end rows (see in_range / check_in_range).
        y = jnp.clip(jnp.asarray(y, dtype=g.dtype), g[0], g[-1])
        if self.uniform:
            # O(1) index arithmetic; called in every step of the simulation loop.
            h = (g[-1] - g[0]) / (m - 1)
            i = jnp.floor((y - g[0]) / h).astype(jnp.int32)
        else:
            i = jnp.searchsorted(g, y, side="right") - 1
        i = jnp.clip(i, 0, m - 2)
        g0 = g[i]
        # Weights from the real grid: exact at grid points even if the index guess is off by rounding.
        w = jnp.clip((y - g0) / (g[i + 1] - g0), 0.0, 1.0)
        return i, w

    def gain_phases(self, y):
        """Per-phase gains ``S + (L, 3, 3)`` (N/A, N·m/A) at positions ``y`` (m, shape ``S``)."""
        i, w = self._locate(y)
        return _interp(self.gain_table, i, w)

    def gain(self, y):
        """Star-reduced gains ``S + (L, 3, 2)`` for currents ``(ia, ib)``, ``ic = -ia - ib``."""
        return star_reduce(self.gain_phases(y))

    def cogging(self, y):
        """Current-independent force ``S + (3,)`` (N, N, N·m) at positions ``y`` (m)."""
        i, w = self._locate(y)
        return _interp(self.cog_table, i, w)

    def direction_force(self, y, v):
        """Direction-dependent force: a force map has none, ``S + (3,)`` zeros."""
        return zeros3(jnp.asarray(y))

    def force(self, y, v, currents):
        """``F = Σ_l K^l(y) i^l + F_cog(y)`` (N, N, N·m), ``S + (3,)``; currents ``S + (L, 2)`` (A)."""
        return plant_force(self, y, v, currents)

    def in_range(self, y):
        """``S`` booleans: position inside ``[y_min, y_max]`` of the map (NaN is outside). Jittable."""
        y = jnp.asarray(y)
        return (y >= self.y_grid[0]) & (y <= self.y_grid[-1])


def check_in_range(plant, y, where: str) -> None:
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


def _validate_names(header: list[str], src: str) -> int:
    """Check the column names of a force map; return ``L``."""
    sets: dict[int, set] = {}
    unknown = []
    for n in header:
        if n == "y" or n in _COG:
            continue
        m = _GAIN_RE.match(n)
        if m is not None and int(m.group(2)) >= 1:
            sets.setdefault(int(m.group(2)), set()).add((m.group(1), m.group(3)))
        else:
            unknown.append(n)
    n_sets = max(sets, default=0)
    expected = forcemap_columns(max(n_sets, 1))
    missing = [e for e in expected if e not in header and e not in _COG]
    if unknown:
        u = unknown[0]
        hint = closest_hint(u, missing or expected)
        why = " (coil sets are numbered from 1)" if _GAIN_RE.match(u) else ""
        if not hint and "y" not in header:
            hint = f" (and there is no column 'y': is '{u}' the position in m?)"
        raise DataError(
            f"{src}: column '{u}' unknown{why}{hint}; expected y, Fy_<l><p>, Fx_<l><p>, Tz_<l><p> "
            "(l = 1..L, p = a, b, c) and optionally Fy_cog, Fx_cog, Tz_cog"
        )
    if "y" not in header:
        raise DataError(f"{src}: column 'y' (position in m) missing; found {', '.join(header[:8])}")
    if n_sets == 0:
        raise DataError(f"{src}: no coil-set columns (expected Fy_1a, Fy_1b, Fy_1c, Fx_1a, ..., Tz_1c for coil set 1)")
    for l in range(1, n_sets + 1):
        have = sets.get(l, set())
        if not have:
            raise DataError(
                f"{src}: no columns for coil set {l} but coil set {n_sets} has some "
                "(coil sets must be numbered 1..L without holes)"
            )
        for q in _QUANTITIES:
            for p in _PHASES:
                if (q, p) in have:
                    continue
                same = [f"{q}_{l}{pp}" for pp in _PHASES if (q, pp) in have]
                if same:
                    why = f"coil set {l} has {', '.join(same)} but no phase {p}"
                else:
                    why = f"coil set {l} has no {q} columns; each coil set needs Fy, Fx and Tz for phases a, b, c"
                raise DataError(f"{src}: column '{q}_{l}{p}' missing ({why})")
    return n_sets


def load_forcemap(path) -> ForceMapPlant:
    """Read and validate a force-map CSV (format in the module docstring).

    Args:
        path: CSV file.

    Returns:
        :class:`ForceMapPlant` with ``L`` coil sets read from the column names.

    Raises:
        DataError: missing, misnamed or unknown columns; incomplete or
            non-consecutive coil sets; non-numeric or empty cells; NaN/inf
            (row and column); ``y`` not strictly increasing (row); fewer than 2 rows.
    """
    src = str(path)
    header = read_csv_header(path, src)  # names first: a misnamed column is the likelier mistake
    n_sets = _validate_names(header, src)
    data = read_csv_columns(path, src)
    m = len(data["y"])
    if m < 2:
        raise DataError(f"{src}: {m} data rows, a force map needs at least 2")
    for name in header:  # NaN/inf: name row and column
        a = data[name]
        if not np.isfinite(a).all():
            i = int(np.flatnonzero(~np.isfinite(a))[0])
            raise DataError(f"{src} row {i + 1} column '{name}': {a[i]} is not a finite number")
    gain = np.empty((m, n_sets, 3, 3))
    for l in range(n_sets):
        for r, q in enumerate(_QUANTITIES):
            for c, p in enumerate(_PHASES):
                gain[:, l, r, c] = data[f"{q}_{l + 1}{p}"]
    cog = np.stack([data[n] if n in data else np.zeros(m) for n in _COG], axis=-1)
    return ForceMapPlant.from_arrays(data["y"], gain, cog, source=src)


def write_forcemap(path, y, gain_phases, cogging=None) -> None:
    """Write a force-map CSV (atomically) that :func:`load_forcemap` reads back bit-identically.

    Args:
        path: target ``.csv`` file.
        y: ``(M,)`` positions (m), strictly increasing.
        gain_phases: ``(M, L, 3, 3)``: rows ``[Fy, Fx, Tz]`` (N/A, N·m/A), columns phases a, b, c.
        cogging: ``(M, 3)`` (N, N, N·m), or ``None`` to leave the cogging columns out (= zero).

    Raises:
        DataError: the arrays do not form a valid force map (shapes, NaN, ordering).
    """
    plant = ForceMapPlant.from_arrays(y, gain_phases, cogging, source=str(path))
    y = np.asarray(plant.y_grid)
    g = np.asarray(plant.gain_table)
    m, n_sets = g.shape[:2]
    blocks = [y[:, None], g.reshape(m, n_sets * 9)]  # (l, q, p) order = forcemap_columns
    if cogging is not None:
        blocks.append(np.asarray(plant.cog_table))
    table = np.concatenate(blocks, axis=1)
    names = forcemap_columns(n_sets, cogging is not None)
    with atomic_open(path, "w", newline="") as f:
        # %.17g: every float64 reads back to the identical value.
        np.savetxt(f, table, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
