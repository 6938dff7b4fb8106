"""Linear interpolation of tabulated rows on a position grid: the one interpolator of the package.

Force maps (:class:`pgcomm.forcemap.ForceMapPlant`), the drive-style anti-cogging table
(:class:`pgcomm.compensation.CoggingTable`) and the exported lookup tables
(:mod:`pgcomm.export.lut`) all read their tables through :func:`interp_linear`.
"""

from __future__ import annotations

from functools import partial

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp

import numpy as np

__all__ = ["interp_linear", "hat_basis"]


# jitted: called outside a trace (a table read on the host), its eight operations would each be compiled for every
# new shape; as one program they are compiled once per shape
@partial(jax.jit, static_argnames=("uniform",))
def interp_linear(grid, table, y, uniform: bool = True):
    """Rows of ``table`` linearly interpolated at positions ``y``, clamped to the grid's ends.

    ``f(y) = (1 - w) table[i] + w table[i + 1]`` with ``grid[i] <= y <= grid[i + 1]`` and
    ``w = (y - grid[i]) / (grid[i + 1] - grid[i])``. Written as ``(1 - w) t0 + w t1`` (rather
    than ``t0 + w (t1 - t0)``) so that the result is exactly a table row at ``w = 0`` and
    ``w = 1``; the weight comes from the real grid, so grid points are hit exactly even when
    the index guess is off by rounding. Positions outside ``[grid[0], grid[-1]]`` read the end
    rows (callers that must refuse them check the range themselves). Jittable.

    Args:
        grid: ``(M,)`` positions (m), strictly increasing, ``M >= 2``.
        table: ``(M, ...)`` rows (any units).
        y: positions (m), any shape ``S``.
        uniform: ``grid`` is uniform: O(1) index arithmetic instead of a binary search.

    Returns:
        ``S + table.shape[1:]``.
    """
    g = grid
    m = g.shape[0]
    y = jnp.clip(jnp.asarray(y, dtype=g.dtype), g[0], g[-1])
    if uniform:
        h = (g[-1] - g[0]) / (m - 1)
        i = jnp.floor((y - g[0]) / h).astype(jnp.int32)
    else:
        i = jnp.searchsorted(g, y, side="right") - 1
    i = jnp.clip(i, 0, m - 2)
    g0 = g[i]
    w = jnp.clip((y - g0) / (g[i + 1] - g0), 0.0, 1.0)
    w = w.reshape(w.shape + (1,) * (table.ndim - 1))
    return (1.0 - w) * table[i] + w * table[i + 1]


def hat_basis(y, lo: float, hi: float, n_bins: int):
    """Piecewise-linear ("hat") basis on ``n_bins + 1`` uniform knots over ``[lo, hi]``: ``(N, n_bins + 1)``.

    Row ``t`` holds the weights with which :func:`interp_linear` on those knots reads position ``y[t]``
    (m; clamped to the ends), so a least-squares fit in this basis is a table the interpolator reads.
    """
    knots = np.linspace(lo, hi, n_bins + 1)
    h = knots[1] - knots[0] if n_bins > 0 else 1.0
    u = np.clip((y - lo) / h, 0, n_bins)
    j = np.minimum(np.floor(u).astype(int), n_bins - 1)
    w = u - j
    b = np.zeros((y.shape[0], n_bins + 1))
    rows = np.arange(y.shape[0])
    b[rows, j] = 1 - w
    b[rows, j + 1] += w
    return b
