"""Drive-style force-offset compensation: what today's drives ship on top of classical commutation.

Two position-indexed offsets ``F_off(y)`` on the driving force, learned from the
classical-commutation residual ``F_y - F_y*`` of a closed-loop run, and applied as
classical commutation of ``F* - F_off(y)`` (:class:`pgcomm.commutation.OffsetLaw`):

* :class:`CoggingTable` — an anti-cogging table: a uniform position grid with a few
  thousand entries, linearly interpolated (as a drive's table is);
* :class:`HarmonicCogging` — a constant plus up to ``H`` harmonics of the pole pitch,
  ``c0 + Σ_h a_h cos(2π h y/d_m) + b_h sin(2π h y/d_m)``.

Both act on ``F_y`` only (drives offer no out-of-plane compensation). Both are fitted by
linear least squares; the table's entries are the least-squares coefficients of its
piecewise-linear ("hat") basis, with a small second-difference penalty so that entries
no sample reaches stay finite.

Without a force sensor a drive learns the same table from its own effort:
:func:`fit_effort_table` turns the position controller's force demand at slow constant
velocity, one pass in each direction, into a :class:`CoggingTable`
(:func:`pgcomm.sensorless_table.sensorless_cogging_table` runs the passes).
"""

from __future__ import annotations

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.interp import interp_linear


@pytree_dataclass
class CoggingTable:
    """Anti-cogging table: a driving-force offset ``F_off,y(y)`` on a uniform position grid, linearly
    interpolated (:func:`pgcomm.interp.interp_linear`, clamped at the ends) as a drive's table is.

    The one table type of the package: fitted from a classical residual here
    (:func:`fit_cogging_table`) or tabulated from a model for a drive
    (:func:`pgcomm.export.lut.build_cogging_table`).

    Attributes:
        y: ``(M,)`` uniform grid (m), ``M >= 2``.
        values: ``(M,)`` offsets ``F_off,y`` (N) at the grid points.
    """

    y: jnp.ndarray
    values: jnp.ndarray

    def offset(self, y):
        """Interpolated ``F_off,y`` (N) at positions ``y`` (m), shape of ``y``."""
        return interp_linear(self.y, self.values, y)

    def __call__(self, y):
        """Offset force ``S + (3,)`` (N, N, N·m): only the ``y`` component is non-zero."""
        fy = self.offset(y)
        return jnp.stack([fy, jnp.zeros_like(fy), jnp.zeros_like(fy)], axis=-1)

    @property
    def n(self) -> int:
        """Number of grid points ``M``."""
        return int(self.y.shape[0])

    @property
    def dy(self) -> float:
        """Grid spacing (m)."""
        return float((self.y[-1] - self.y[0]) / (self.n - 1))

    @property
    def nbytes(self) -> int:
        """Size of the table in bytes as a drive stores it (float32 entries)."""
        return 4 * self.n


@pytree_dataclass
class HarmonicCogging:
    """``F_off,y(y) = c0 + Σ_h a_h cos(2π h y/d_m) + b_h sin(2π h y/d_m)``, ``h = 1..H``.

    Attributes:
        coef: ``(2H + 1,)`` ``[c0, a_1, b_1, ..., a_H, b_H]`` (N).
        pole_pitch: ``d_m`` (m).
    """

    coef: jnp.ndarray
    pole_pitch: float = static_field()

    def __call__(self, y):
        """Offset force ``S + (3,)`` (N, N, N·m): only the ``y`` component is non-zero."""
        fy = _harmonic_basis(jnp.asarray(y), (self.coef.shape[0] - 1) // 2, self.pole_pitch, jnp) @ self.coef
        return jnp.stack([fy, jnp.zeros_like(fy), jnp.zeros_like(fy)], axis=-1)


def fit_cogging_table(y, residual, entries: int = 2000, y_range=None, smooth: float = 1e-3) -> CoggingTable:
    """Least-squares anti-cogging table from the classical residual.

    Minimises ``Σ_k (r_k - Σ_j v_j φ_j(y_k))² + smooth · N/M · Σ_j (v_{j-1} - 2 v_j + v_{j+1})²``
    over the table entries ``v`` (hat basis ``φ_j`` on the grid).

    Args:
        y: ``(N,)`` measured positions (m); residual: ``(N,)`` ``F_y - F_y*`` (N).
        entries: table size ``M``; y_range: grid ends (m), default the data's range.
        smooth: weight of the second-difference penalty (dimensionless).
    """
    from scipy.sparse import coo_matrix, diags, vstack  # start-up cost: SciPy loads only when this runs
    from scipy.sparse.linalg import lsqr  # start-up cost: SciPy loads only when this runs

    y = np.asarray(y, float)
    lo, hi = (float(y.min()), float(y.max())) if y_range is None else y_range
    m = int(entries)
    u = np.clip((y - lo) / (hi - lo) * (m - 1), 0, m - 1)
    j = np.minimum(np.floor(u).astype(int), m - 2)
    w = u - j
    n = y.shape[0]
    rows = np.concatenate([np.arange(n), np.arange(n)])
    a = coo_matrix((np.concatenate([1 - w, w]), (rows, np.concatenate([j, j + 1]))), shape=(n, m))
    d2 = diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(m - 2, m)) * np.sqrt(smooth * n / m)
    sol = lsqr(vstack([a, d2]).tocsr(), np.concatenate([np.asarray(residual, float), np.zeros(m - 2)]),
               atol=1e-12, btol=1e-12, iter_lim=20 * m)[0]
    return CoggingTable(jnp.asarray(np.linspace(lo, hi, m)), jnp.asarray(sol))


def fit_effort_table(y_pos, fstar_pos, y_neg, fstar_neg, entries: int = 2000, y_range=None,
                     smooth: float = 1e-3) -> CoggingTable:
    """Anti-cogging table from the controller's effort at constant velocity, both directions averaged.

    At constant velocity (``ÿ = 0``) under classical commutation the motor force equals the
    friction: ``F*_y + e(y) + d(y) s = f(s v)``, where ``F*_y`` is the demand (feedback plus
    feedforward), ``e(y)`` the position-dependent force error of classical commutation (cable,
    cogging, gain ripple at that force), ``s = ±1`` the direction and ``d(y)`` a direction-dependent
    force. Averaging the demand of the two directions at the same position gives

        (F*_+(y) + F*_-(y)) / 2 = -e(y) + (f(+v) + f(-v)) / 2,

    and the table is ``F_off(y) = -(F*_+ + F*_-)/2 ≈ e(y)``: the same quantity the force-sensor table
    (:func:`fit_cogging_table` of ``F_y - F*_y``) estimates, for :class:`pgcomm.commutation.OffsetLaw`.
    Whatever is odd in the direction cancels: Coulomb and viscous friction, the feedforward's
    friction terms, ``d(y)``, the gain ripple acting on the (sign-flipping) friction force, and, to
    first order, the position shift of the loop's phase lag (opposite in the two directions).

    The friction's even part ``(f(+v) + f(-v))/2`` is a constant offset of the whole table. It is
    *not* removed: it is exactly zero for symmetric friction (the plant's model), whereas the
    table's mean is mostly the real mean of the cable force, which a mean-free table would lose.

    Each direction is fitted by :func:`fit_cogging_table` on its own range, then the two are
    averaged on the common grid (reuse of the one least-squares fit; each direction's samples
    weigh alike whatever their count). Near the ends a direction's pass has no settled samples (it
    starts from rest there), so only one direction covers them. There the table is that direction's
    effort minus the odd part ``o = (F*_+ - F*_-)/2`` held at its value at the nearest end of the
    overlap: friction and the direction force are nearly constant over that short distance, while
    the cable force (what the table is for) can be steep at the ends of the stroke.

    Args:
        y_pos, fstar_pos: ``(N+,)`` positions (m) and force demand ``F*_y`` (N) of the samples at
            constant positive velocity (settled).
        y_neg, fstar_neg: ``(N-,)`` the same at constant negative velocity.
        entries: table size ``M`` (grid points).
        y_range: ``(lo, hi)`` grid ends (m); default the union of the two directions' ranges.
            Grid points beyond the data read the nearest data's value.
        smooth: weight of each direction's second-difference penalty (:func:`fit_cogging_table`).

    Returns:
        :class:`CoggingTable` with ``M`` entries, ``F_off,y`` (N) on a uniform grid over ``y_range``.

    Raises:
        ValueError: fewer than 2 samples in a direction, or the two directions' ranges do not
            overlap (there is no position where both were measured).
    """
    ys = {}
    for name, y, f in (("positive", y_pos, fstar_pos), ("negative", y_neg, fstar_neg)):
        y, f = np.asarray(y, float).ravel(), np.asarray(f, float).ravel()
        if y.shape != f.shape:
            raise ValueError(f"fit_effort_table: {name} direction has {y.size} positions but {f.size} forces")
        if y.size < 2 or not np.ptp(y) > 0:
            raise ValueError(f"fit_effort_table: the {name} direction needs samples at 2 or more positions, "
                             f"got {y.size}")
        ys[name] = (y, f)
    (yp, fp), (yn, fn) = ys["positive"], ys["negative"]
    a, b = max(yp.min(), yn.min()), min(yp.max(), yn.max())   # overlap: both directions measured
    if not b > a:
        raise ValueError(f"fit_effort_table: the directions do not overlap (positive pass covers "
                         f"[{yp.min():.6g}, {yp.max():.6g}] m, negative [{yn.min():.6g}, {yn.max():.6g}] m)")
    u_lo, u_hi = min(yp.min(), yn.min()), max(yp.max(), yn.max())
    lo, hi = (u_lo, u_hi) if y_range is None else (float(y_range[0]), float(y_range[1]))
    m = int(entries)
    grid = np.linspace(lo, hi, m)

    def fit(y, f):
        # each direction on its own range, with about the final grid's spacing
        n = max(2, int(round((m - 1) * np.ptp(y) / (hi - lo))) + 1)
        tab = fit_cogging_table(y, f, n, (float(y.min()), float(y.max())), smooth)
        return lambda q: np.interp(q, np.asarray(tab.y), np.asarray(tab.values))

    tp, tn = fit(yp, fp), fit(yn, fn)
    g = np.clip(grid, u_lo, u_hi)              # beyond all data: the nearest data's value
    gc = np.clip(g, a, b)
    odd = 0.5 * (tp(gc) - tn(gc))             # held constant outside the overlap
    in_p = (g >= yp.min()) & (g <= yp.max())
    in_n = (g >= yn.min()) & (g <= yn.max())
    even = np.where(in_p & in_n, 0.5 * (tp(g) + tn(g)), np.where(in_p, tp(g) - odd, tn(g) + odd))
    return CoggingTable(jnp.asarray(grid), jnp.asarray(-even))


def fit_harmonic_cogging(y, residual, pole_pitch: float, harmonics: int = 10) -> HarmonicCogging:
    """Least-squares constant plus ``harmonics`` harmonics of the pole pitch ``d_m`` (m) fitted to the residual (N)."""
    basis = _harmonic_basis(np.asarray(y, float), harmonics, pole_pitch, np)
    coef, *_ = np.linalg.lstsq(basis, np.asarray(residual, float), rcond=None)
    return HarmonicCogging(jnp.asarray(coef), float(pole_pitch))


def _harmonic_basis(y, harmonics: int, pole_pitch: float, xp):
    h = xp.arange(1, harmonics + 1, dtype=float)
    ang = 2 * np.pi * y[..., None] * h / pole_pitch
    cs = xp.stack([xp.cos(ang), xp.sin(ang)], axis=-1).reshape(y.shape + (2 * harmonics,))
    return xp.concatenate([xp.ones(y.shape + (1,)), cs], axis=-1)
