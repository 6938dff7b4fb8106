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


@pytree_dataclass
class CoggingTable:
    """Anti-cogging table: ``F_off,y(y)`` linearly interpolated on a uniform grid (clamped at the ends).

    Attributes:
        values: ``(M,)`` offsets (N) at ``y_min + j (y_max - y_min)/(M - 1)``.
        y_min, y_max: grid ends (m).
    """

    values: jnp.ndarray
    y_min: float = static_field()
    y_max: float = static_field()

    def __call__(self, y):
        """Offset force ``S + (3,)`` (N, N, N·m): only the ``y`` component is non-zero."""
        m = self.values.shape[0]
        u = jnp.clip((jnp.asarray(y) - self.y_min) / (self.y_max - self.y_min) * (m - 1), 0.0, m - 1.0)
        j = jnp.clip(jnp.floor(u).astype(jnp.int32), 0, m - 2)
        w = u - j.astype(u.dtype)
        fy = (1 - w) * self.values[j] + w * self.values[j + 1]
        return jnp.stack([fy, jnp.zeros_like(fy), jnp.zeros_like(fy)], axis=-1)

    @property
    def nbytes(self) -> int:
        """Size of the table in bytes as a drive stores it (float32 entries)."""
        return 4 * int(self.values.shape[0])


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
    return CoggingTable(jnp.asarray(sol), lo, hi)


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
