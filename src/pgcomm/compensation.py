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
"""

from __future__ import annotations

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
    from scipy.sparse import coo_matrix, diags, vstack
    from scipy.sparse.linalg import lsqr

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
