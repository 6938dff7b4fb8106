"""Identification of the physics-guided spline model (:class:`pgcomm.spline_model.SplineModel`).

Every parameter of the model enters linearly, so for coil set ``l`` and output row
``q ∈ {y, x, z}`` the fit is one regularised least-squares problem (Proposition 1 with no
hidden layer)::

    θ_q = argmin_θ  Σ_t (F_q(t) - M(t) θ)²  +  λ_q θᵀ P θ

    M(t) = [φ_k(y) cos θ · i_j,  φ_k(y) sin θ · i_j,        (gain envelopes A(y), B(y); k, j = a, b)
            cos nθ · i_j, sin nθ · i_j  (n = 5, 7),         (fixed higher harmonics)
            ψ_k(y),                                         (cogging table)
            χ_k(y) s(ẏ)]                                    (direction table)

with ``φ, ψ, χ`` the hat functions of three uniform knot grids and ``P`` the sum of the squared
second differences of every tabulated coefficient sequence, each family scaled by the mean
diagonal of its block of ``MᵀM`` (so ``λ`` is dimensionless). It is solved through the normal
equations: ``M`` has at most 20 non-zeros a row, so ``MᵀM`` costs ``O(20² N)``; the hat basis and
the penalty keep it well conditioned (``cond ≈ 1e6`` on the twin), and a ridge of
``1e-10 × mean diag`` keeps knots that no sample reaches finite.

**Model selection by cross-validation.** The knot spacings of the gain envelope, the cogging
and the direction tables and the weight ``λ`` are chosen by K-fold cross-validation over
contiguous time blocks (:data:`CV_BLOCK` samples, block ``b`` in fold ``b mod K``): a held-out
block is another pass over the same positions, never the same samples, so the choice is
judged on data that the fit has not seen. Spacings are fractions of the pole pitch (so the
grid is the same in electrical terms on every motor) searched coordinate-wise (gain, cogging,
direction; two sweeps) on the summed y-row validation error of all coil sets; ``λ`` is then
chosen per coil set and row. Per-fold normal equations are accumulated once per candidate
grid, so every ``λ`` and fold costs one small Cholesky solve.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np
import scipy.linalg
import scipy.sparse as sp

from pgcomm.data import CoilSetData
from pgcomm.errors import DataError
from pgcomm.models import DEFAULT_DIRECTION_VELOCITY, HARMONIC_ORDERS
from pgcomm.spline_model import Grid, SplineModel

__all__ = ["SplineOptions", "SplineFit", "identify_spline", "spline_regressor", "penalty_matrix", "Normal",
           "fold_labels", "second_difference",
           "GAIN_SPACINGS", "COG_SPACINGS", "DIR_SPACINGS", "LAMBDAS"]

#: Candidate knot spacings, in pole pitches, of the gain envelope (a magnet is half a pole pitch).
GAIN_SPACINGS = (2.0, 1.0, 0.5, 0.25, 0.125)
#: ... of the cogging table (cable forces are smooth; cogging periods are fractions of ``d_m``).
COG_SPACINGS = (0.5, 0.25, 0.125, 0.0625)
#: ... of the direction-force table.
DIR_SPACINGS = (2.0, 1.0, 0.5, 0.25)
#: Candidate smoothness weights ``λ`` (dimensionless, see the module docstring).
LAMBDAS = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)
#: Cross-validation folds and block length (samples).
CV_FOLDS = 5
CV_BLOCK = 500
#: Most knots of one table: bounds the normal equations (``4 · 128 + 8 + 2 · 128`` columns) on long strokes,
#: and with them the cost of every cross-validation solve (``O(p³)``).
MAX_KNOTS = 128
#: Ridge relative to the mean diagonal of ``MᵀM``.
RIDGE = 1e-10


@dataclass(frozen=True)
class SplineOptions:
    """Settings of :func:`identify_spline` (defaults: everything chosen by cross-validation).

    Attributes:
        gain_spacings, cog_spacings, dir_spacings: candidate knot spacings in pole pitches
            (one value = fixed).
        lambdas: candidate smoothness weights ``λ``.
        direction: identify the direction table ``C(y) s(ẏ)`` (needs velocities).
        direction_velocity: ``v_ε`` (m/s) of ``s(ẏ) = tanh(ẏ/v_ε)``.
        folds: cross-validation folds ``K >= 2``; block: samples per contiguous block.
    """

    gain_spacings: tuple[float, ...] = GAIN_SPACINGS
    cog_spacings: tuple[float, ...] = COG_SPACINGS
    dir_spacings: tuple[float, ...] = DIR_SPACINGS
    lambdas: tuple[float, ...] = LAMBDAS
    direction: bool = True
    direction_velocity: float = DEFAULT_DIRECTION_VELOCITY
    folds: int = CV_FOLDS
    block: int = CV_BLOCK

    def __post_init__(self):
        for name in ("gain_spacings", "cog_spacings", "dir_spacings", "lambdas"):
            vals = getattr(self, name)
            if not vals or not all(np.isfinite(v) and v > 0 for v in vals):
                raise ValueError(f"{name} = {vals}: expected a non-empty list of positive numbers")
        if self.folds < 2:
            raise ValueError(f"folds = {self.folds}: cross-validation needs at least 2 folds")


@dataclass(frozen=True)
class SplineFit:
    """The result of :func:`identify_spline`.

    Attributes:
        model: the combined :class:`SplineModel`.
        spacing: chosen knot spacings ``{"gain", "cogging", "direction"}`` (m).
        lambdas: per coil set, ``{y, x, z}`` chosen ``λ``.
        cost: per coil set, ``{y, x, z}`` mean squared training residual (N², N², N²m²) with all
            data (the final fit).
        cost_validation: per coil set, ``{y, x, z}`` cross-validated mean squared residual at the
            chosen settings (N², N², N²m²).
        search: the candidates tried: ``[{"gain", "cogging", "direction"} (m), y-row CV MSE (N²)]``.
        seconds: wall time (s).
    """

    model: SplineModel
    spacing: dict
    lambdas: list
    cost: list
    cost_validation: list
    search: list = field(default_factory=list)
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """JSON-ready summary (no computation)."""
        return {"spacing_m": dict(self.spacing), "lambda": self.lambdas, "cost": self.cost,
                "cost_validation": self.cost_validation, "parameters": self.model.n_parameters,
                "knots": {"gain": int(self.model.gain_knots.shape[0]), "cogging": int(self.model.cog_knots.shape[0]),
                          "direction": int(self.model.dir_knots.shape[0])},
                "search": self.search, "seconds": self.seconds}


# ----------------------------------------------------------------------------------------------
# regressor and penalty
# ----------------------------------------------------------------------------------------------


def _hat(y, grid: Grid):
    """Hat-function entries ``(index (N, 2), weight (N, 2))`` of positions ``y`` on ``grid`` (clamped)."""
    u = np.clip((np.asarray(y, float) - grid.lo) / grid.spacing, 0.0, grid.n)
    j = np.minimum(np.floor(u).astype(np.int64), grid.n - 1)
    w = u - j
    return np.stack([j, j + 1], axis=1), np.stack([1.0 - w, w], axis=1)


def _layout(grids):
    """Column offsets of the families ``gain, harmonics, cogging, direction`` and the total width."""
    g, c, d = grids
    sizes = {"gain": 4 * g.size, "harmonics": 4 * len(HARMONIC_ORDERS), "cogging": c.size,
             "direction": 0 if d is None else d.size}
    off, pos = {}, 0
    for name, n in sizes.items():
        off[name] = (pos, pos + n)
        pos += n
    return off, pos


def spline_regressor(y, currents, velocity, pole_pitch: float, grids, direction_velocity: float):
    """The sparse regressor ``M`` ``(N, p)`` of the module docstring (CSR).

    Args:
        y: ``(N,)`` m; currents: ``(N, 2)`` A; velocity: ``(N,)`` m/s (unused without a direction grid).
        grids: ``(gain Grid, cogging Grid, direction Grid or None)``.

    Column layout: gain ``[k, trig, j]`` (``k`` knot, ``trig`` cos/sin, ``j`` = a, b), then the
    harmonics ``[cos5, sin5, cos7, sin7] x [a, b]``, the cogging knots, the direction knots.
    """
    gg, cg, dg = grids
    off, p = _layout(grids)
    y = np.asarray(y, float)
    i = np.asarray(currents, float)
    n = y.shape[0]
    th = 2.0 * np.pi * y / pole_pitch
    trig = np.stack([np.cos(th), np.sin(th)], axis=1)                     # (N, 2)
    rows, cols, vals = [], [], []
    idx, w = _hat(y, gg)
    # gain: (N, 2 knots, 2 trig, 2 currents)
    v = w[:, :, None, None] * trig[:, None, :, None] * i[:, None, None, :]
    c = off["gain"][0] + 4 * idx[:, :, None, None] + 2 * np.arange(2)[None, None, :, None] + np.arange(2)
    rows.append(np.broadcast_to(np.arange(n)[:, None, None, None], v.shape).ravel())
    cols.append(np.broadcast_to(c, v.shape).ravel())
    vals.append(v.ravel())
    harm = []
    for order in HARMONIC_ORDERS:
        harm += [np.cos(order * th), np.sin(order * th)]
    hv = (np.stack(harm, axis=1)[:, :, None] * i[:, None, :]).reshape(n, -1)  # (N, 8)
    rows.append(np.repeat(np.arange(n), hv.shape[1]))
    cols.append(np.tile(off["harmonics"][0] + np.arange(hv.shape[1]), n))
    vals.append(hv.ravel())
    idx, w = _hat(y, cg)
    rows.append(np.repeat(np.arange(n), 2))
    cols.append((off["cogging"][0] + idx).ravel())
    vals.append(w.ravel())
    if dg is not None:
        s = np.tanh(np.asarray(velocity, float) / direction_velocity)
        idx, w = _hat(y, dg)
        rows.append(np.repeat(np.arange(n), 2))
        cols.append((off["direction"][0] + idx).ravel())
        vals.append((w * s[:, None]).ravel())
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, p))


def second_difference(n: int, stride: int = 1, start: int = 0, total: int | None = None):
    """Rows of ``x[k] - 2 x[k+1] + x[k+2]`` over ``n`` coefficients at ``start + stride·k``, width ``total``."""
    if n < 3:
        return np.zeros((0, total))
    d = np.zeros((n - 2, total))
    k = np.arange(n - 2)
    for shift, coef in ((0, 1.0), (1, -2.0), (2, 1.0)):
        d[k, start + stride * (k + shift)] = coef
    return d


def penalty_matrix(grids, gram: np.ndarray) -> np.ndarray:
    """``P`` ``(p, p)``: squared second differences of every table sequence, each family scaled by the
    mean diagonal of its block of ``gram = MᵀM`` (so that ``λ`` is dimensionless)."""
    gg, cg, dg = grids
    off, p = _layout(grids)
    pen = np.zeros((p, p))
    diag = np.diag(gram)

    def add(d, lo, hi):
        nonlocal pen
        if d.shape[0]:
            scale = float(np.mean(diag[lo:hi])) or 1.0
            pen += scale * d.T @ d

    lo, hi = off["gain"]
    for t in range(4):
        add(second_difference(gg.size, 4, lo + t, p), lo, hi)
    add(second_difference(cg.size, 1, off["cogging"][0], p), *off["cogging"])
    if dg is not None:
        add(second_difference(dg.size, 1, off["direction"][0], p), *off["direction"])
    return pen


# ----------------------------------------------------------------------------------------------
# cross-validated least squares
# ----------------------------------------------------------------------------------------------


@dataclass
class Normal:
    """Per-fold normal equations of a regularised least-squares problem with ``r`` right-hand sides.

    Attributes:
        gram: ``(K, p, p)`` ``M_fᵀ M_f`` per fold; rhs: ``(K, p, r)`` ``M_fᵀ F_f``; ss: ``(K, r)`` ``Σ F_f²``;
        count: ``(K,)`` samples per fold; penalty: ``(p, p)`` ``P``.
    """

    gram: np.ndarray
    rhs: np.ndarray
    ss: np.ndarray
    count: np.ndarray
    penalty: np.ndarray

    @classmethod
    def build(cls, m, target, fold, folds: int, penalty_fn) -> "Normal":
        """From a regressor ``m`` ``(N, p)`` (dense or sparse), targets ``(N, r)``, fold labels ``(N,)`` in
        ``0 .. folds - 1`` and ``penalty_fn(gram_total) -> P``."""
        target = np.asarray(target, float).reshape(m.shape[0], -1)
        p, r = m.shape[1], target.shape[1]
        gram, rhs, ss, cnt = np.zeros((folds, p, p)), np.zeros((folds, p, r)), np.zeros((folds, r)), np.zeros(folds)
        for f in range(folds):
            sel = fold == f
            mf = m[sel]
            g = mf.T @ mf
            gram[f] = g.toarray() if sp.issparse(g) else g
            rhs[f] = mf.T @ target[sel]
            ss[f] = np.sum(target[sel] ** 2, axis=0)
            cnt[f] = sel.sum()
        return cls(gram, rhs, ss, cnt, penalty_fn(gram.sum(axis=0)))

    def solve(self, lam, exclude=None, rows=slice(None)):
        """θ ``(p, r)`` (or the ``rows`` selected) from all folds but ``exclude`` with weight ``lam``."""
        keep = np.ones(self.gram.shape[0], bool)
        if exclude is not None:
            keep[exclude] = False
        g = self.gram[keep].sum(axis=0)
        ridge = RIDGE * max(float(np.mean(np.diag(g))), 1e-300)
        a = g + lam * self.penalty + ridge * np.eye(g.shape[0])
        return scipy.linalg.cho_solve(scipy.linalg.cho_factor(a, check_finite=False),
                                      self.rhs[keep].sum(axis=0)[:, rows], check_finite=False)

    def sse(self, theta, fold, rows=slice(None)):
        """``Σ (F - M θ)²`` on ``fold`` per right-hand side, from its normal equations."""
        g, b, s = self.gram[fold], self.rhs[fold][:, rows], self.ss[fold][rows]
        return s - 2.0 * np.sum(theta * b, axis=0) + np.sum(theta * (g @ theta), axis=0)

    def cv_mse(self, lam):
        """K-fold cross-validated MSE per right-hand side ``(r,)``."""
        tot = 0.0
        for f in range(self.gram.shape[0]):
            tot = tot + self.sse(self.solve(lam, exclude=f), f)
        return tot / self.count.sum()

    def fit(self, lambdas):
        """Per right-hand side the ``λ`` of least CV MSE: ``(θ (p, r), λ (r,), cv_mse (r,), train_mse (r,))``."""
        cvs = np.array([self.cv_mse(lam) for lam in lambdas])      # (n_lambda, r)
        best = np.argmin(cvs, axis=0)
        lam = np.array([lambdas[b] for b in best])
        theta = np.column_stack([self.solve(lam[q], rows=[q])[:, 0] for q in range(cvs.shape[1])])
        sse = sum(self.sse(theta, f) for f in range(self.gram.shape[0]))
        return theta, lam, cvs[best, np.arange(cvs.shape[1])], sse / self.count.sum()


def fold_labels(n: int, folds: int, block: int) -> np.ndarray:
    """Cross-validation fold of each of ``n`` samples: contiguous blocks of ``block`` samples, round-robin."""
    return (np.arange(n) // int(block)) % int(folds)


def _normal_equations(data: CoilSetData, pole_pitch, grids, options: SplineOptions) -> Normal:
    m = spline_regressor(data.y, data.currents, data.velocity, pole_pitch, grids, options.direction_velocity)
    return Normal.build(m, data.force, fold_labels(data.n, options.folds, options.block), options.folds,
                        lambda g: penalty_matrix(grids, g))


def _grids(lo, hi, d_m, spacing, direction: bool):
    def grid(fraction):
        g = Grid.with_spacing(lo, hi, fraction * d_m)
        return g if g.size <= MAX_KNOTS else Grid(lo, hi, MAX_KNOTS - 1)

    return grid(spacing["gain"]), grid(spacing["cogging"]), grid(spacing["direction"]) if direction else None


def identify_spline(data: list[CoilSetData], pole_pitch: float, options: SplineOptions = SplineOptions(),
                    progress=None) -> SplineFit:
    """Identify the :class:`SplineModel` of all coil sets from their data sets (module docstring).

    Args:
        data: one :class:`CoilSetData` per coil set (``Z_1^l ∪ Z_2^l``, with velocities when
            ``options.direction``).
        pole_pitch: ``d_m`` (m).
        options: :class:`SplineOptions`.
        progress: optional :class:`pgcomm.progress.Progress` (one line per search step).

    Raises:
        DataError: data without velocities while the direction table is on, or fewer samples
            than ``options.folds`` blocks.
    """
    t0 = time.perf_counter()
    data = list(data)
    if not data:
        raise DataError("spline identification needs the data of at least one coil set")
    for d in data:
        if options.direction and d.velocity is None:
            raise DataError(f"{d.name}: the direction table needs velocities (CoilSetData.with_velocity)")
        if d.n < options.folds * options.block:
            raise DataError(f"{d.name}: {d.n} samples; cross-validation needs at least "
                            f"{options.folds * options.block} ({options.folds} folds of {options.block})")
    lo = min(float(d.y.min()) for d in data)
    hi = max(float(d.y.max()) for d in data)
    if not hi > lo:
        raise DataError(f"the data do not move: all positions are {lo} m")
    cands = {"gain": tuple(options.gain_spacings), "cogging": tuple(options.cog_spacings),
             "direction": tuple(options.dir_spacings) if options.direction else (1.0,)}
    # start in the middle of each candidate list
    choice = {k: v[len(v) // 2] for k, v in cands.items()}
    cache: dict = {}
    search = []

    def score(ch):
        key = tuple(ch[k] for k in ("gain", "cogging", "direction"))
        if key not in cache:
            grids = _grids(lo, hi, pole_pitch, ch, options.direction)
            normals = [_normal_equations(d, pole_pitch, grids, options) for d in data]
            # y row: best λ per coil set, summed (every other λ of the grid: the search compares grids)
            total = sum(min(n.cv_mse(lam)[0] for lam in options.lambdas[::2]) for n in normals)
            cache[key] = (total, normals, grids)
            search.append({"spacing_m": {k: ch[k] * pole_pitch for k in ch}, "cv_mse_y": total / len(data)})
        return cache[key][0]

    for _ in range(2):
        changed = False
        for fam in ("gain", "cogging", "direction"):
            if len(cands[fam]) < 2:
                continue
            # coarse to fine, stopping at the first candidate worse than the one before: the validation
            # error falls while the grid resolves the data and rises once it fits noise
            ordered = sorted(cands[fam], reverse=True)
            best, prev = None, None
            for sp_ in ordered:
                sc = score({**choice, fam: sp_})
                if prev is not None and sc > prev:
                    break
                if best is None or sc < score({**choice, fam: best}):
                    best = sp_
                prev = sc
            if best != choice[fam]:
                choice[fam], changed = best, True
            if progress is not None:
                progress.info(f"spline knots: {fam} every {choice[fam]:g} d_m "
                              f"(CV y MSE {score(choice) / len(data):.4g} N^2)")
        if not changed:
            break
    score(choice)  # fills the cache also when every family has a single candidate
    _, normals, grids = cache[tuple(choice[k] for k in ("gain", "cogging", "direction"))]
    off, _ = _layout(grids)
    lambdas, costs, cv = [], [], []
    thetas = []
    for n in normals:
        theta, lam, cv_q, train_q = n.fit(options.lambdas)
        thetas.append(theta)
        lambdas.append(dict(zip("yxz", lam.tolist())))
        costs.append(dict(zip("yxz", train_q.tolist())))
        cv.append(dict(zip("yxz", cv_q.tolist())))
    model = _assemble(thetas, grids, off, pole_pitch, data, options)
    return SplineFit(model, {k: choice[k] * pole_pitch for k in choice}, lambdas, costs, cv, search,
                     time.perf_counter() - t0)


def _assemble(thetas, grids, off, pole_pitch, data, options) -> SplineModel:
    """Stack per-coil-set coefficients ``θ`` ``(p, 3)`` into a :class:`SplineModel`."""
    gg, cg, dg = grids
    gain, harm, cog, dirs = [], [], [], []
    for th in thetas:
        lo, hi = off["gain"]
        gain.append(th[lo:hi].reshape(gg.size, 2, 2, 3).transpose(0, 1, 3, 2))   # (M, trig, q, j)
        lo, hi = off["harmonics"]
        harm.append(th[lo:hi].reshape(4, 2, 3).transpose(0, 2, 1))               # (4, q, j)
        lo, hi = off["cogging"]
        cog.append(th[lo:hi])
        if dg is not None:
            lo, hi = off["direction"]
            dirs.append(th[lo:hi])
    dir_knots = dg.knots if dg is not None else np.array([gg.lo, gg.hi])
    return SplineModel(
        gain_table=jnp.asarray(np.stack(gain, axis=1)), H=jnp.asarray(np.stack(harm)),
        cog_table=jnp.asarray(np.mean(cog, axis=0)), dir_table=jnp.asarray(np.mean(dirs, axis=0)) if dirs else None,
        gain_knots=jnp.asarray(gg.knots), cog_knots=jnp.asarray(cg.knots), dir_knots=jnp.asarray(dir_knots),
        pole_pitch=float(pole_pitch), y_min=tuple(float(d.y.min()) for d in data),
        y_max=tuple(float(d.y.max()) for d in data), direction_velocity=float(options.direction_velocity))
