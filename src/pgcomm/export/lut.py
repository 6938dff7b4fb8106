"""Lookup-table export of the model-based commutation law, and an anti-cogging table.

Full law as a table
-------------------
The law ``i = K̂(y)^† (F* - F̂_cog(y))`` (eq. Commutation_Model_Currents, minimum copper
loss, damping as :func:`pgcomm.commutation.min_energy_currents`) is linear in the force,
so at each position it is one ``2L x 3`` matrix ``P(y)`` and one vector ``F̂_cog(y)``::

    i^l = P^l(y) (F* - F̂_cog(y)),      P(y)[:, j] = law currents for F = e_j

:func:`build_lut` tabulates ``P`` (A/N, A/N, A/(N·m)) and ``F̂_cog`` (N, N, N·m) on a
uniform grid; :func:`lut_currents` (and the generated C function) interpolates both
linearly, applies the product and then the current limit (one factor for all coil
sets, as :func:`pgcomm.commutation.limit_currents`). At grid points the table law IS
the exact law; between them the error is that of linear interpolation, ``O(h²)``.

Accuracy and the default resolution. ``P(y)`` turns with the commutation angle
``ω y``, ``ω = 2π/d_m``; linear interpolation of a harmonic misses by at most
``(ω h)²/8`` of its amplitude at mid-cell. The test forces of :func:`lut_error` include
``Tz = 5 % f_max`` (5 N·m at 100 N), which on a paper-like motor (``μ k d ≈ 0.2 N·m/A``)
takes currents several times those of ``Fy = f_max``; their interpolation error, seen
through the large Fy gain, dominates: the measured worst case is about 3.5 (ω h)²/8 of
``f_max``, in y.
:data:`DEFAULT_RESOLUTION` = 0.08 mm. On the PGNN that ``pgcomm reproduce`` identifies on
the digital twin the measured worst case is 0.058 % of ``f_max`` (82.8 N, the largest
demand of its evaluation run; y direction, x and z below 0.004 %), with 2587 rows x 21
float32 entries = 217 kB; 0.125 mm gave 0.135 % there (above the 0.1 % target), 0.1 mm
0.083 %. ``--resolution`` trades size against error: check the reported error.

:func:`lut_error` measures this on the model itself: the force ``F̂(y, i_table)`` against
``F̂(y, i_exact)`` on a grid ``factor`` times finer, for ``F*`` with ``|Fy| = f_max`` and
``Fx, Tz ∈ {0, ±0.05 f_max}``; worst case per direction (y, x, z).

Anti-cogging table
------------------
Many drives accept only a position -> force-offset table on top of their own classical
commutation. :func:`build_cogging_table` tabulates the offset for the drive's own commutation
``k̂, ζ̂``: ``F̂_cog,y(y) / g(y)`` (N), ``g`` the driving force the model makes per newton the drive
commands (:func:`drive_gain`; 1 for a drive matched to the motor). :func:`cogging_table_error` reports
(a) its interpolation error against that target and (b) the force error left when the drive runs
classical commutation (eq. Commutation_Solution_Ideal_SingleCoilset, ``Δ = 0``, force split
``k̂_l²/Σk̂_m²``) on ``Fy* - table(y)`` instead of the full law — evaluated on the model. The drive's
``k̂, ζ̂`` are arguments (``pgcomm export --drive-k/--drive-zeta``, or the model file's ``drive``), or
fitted to the Fy rows of the model's fundamental (:func:`classical_parameters`).

Drives' own table formats (SINAMICS S120, Kollmorgen AKD, Moog MSD, Beckhoff AX8000) are written by
``pgcomm export --format sinamics|akd|moog|beckhoff --model`` from the same offset (negated: those drives
add their table to the demand) with the direction force per direction where the drive holds two tables
(:mod:`pgcomm.export.compensation`, :mod:`pgcomm.export.drive_export`).

Direction term. A model with ``C^l s(ẏ)`` gives the table law an offset pair:
``i = P̃(y) (F* - F̂̃_cog(y) - C̄ s(v))`` with ``C̄ = mean_l C^l`` and ``s(v) = tanh(v/v_ε)``, i.e.
``F̂_cog ± C̄`` when moving forwards/backwards (smoothly blended through standstill). It is
stored as ``NAME_direction.csv`` (rows ``direction = +1, -1`` with the offsets ``±C̄`` and
``v_eps``), and the C function then takes the velocity ``v`` (m/s) as its second argument.

Spline models (:class:`pgcomm.spline_model.SplineModel`) tabulate like any model (only ``gain`` and
``cogging`` are read); their direction force ``C(y) s(ẏ)`` varies along the stroke, so the table then
holds ``C(y)`` per row (``Lut.direction`` ``(n, 3)``, interpolated like ``F̂_cog``; ``NAME_direction.csv``
has columns ``y, Fy_dir, Fx_dir, Tz_dir, v_eps``), and the drive's classical ``k̂, ζ̂`` of the
anti-cogging table come from the mean of its fundamental tables (:func:`classical_parameters`).

Files (:func:`write_lut`): ``NAME.csv`` with columns ``y``, ``P_{l}{a|b}_{y|x|z}`` (``l``
1-based: the current ``ia`` or ``ib`` of coil set ``l`` per newton of ``Fy``, ``Fx`` or per
N·m of ``Tz``), ``Fy_cog, Fx_cog, Tz_cog``; and ``NAME.h``, a header-only C99 table of
``static const float`` arrays with a ``static inline`` interpolation function.
"""

from __future__ import annotations

import csv
import functools
import io
import math
from dataclasses import dataclass
from pathlib import Path

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm.commutation import (
    DEFAULT_DET_MIN,
    ModelLaw,
    classical_single_direction,
    limit_currents,
    metric_inverse,
    min_energy_currents,
)
from pgcomm.compensation import CoggingTable
from pgcomm.errors import DataError
from pgcomm.interp import interp_linear

__all__ = [
    "DEFAULT_RESOLUTION", "MAX_ROWS", "grid_rows", "Lut", "LutError", "CoggingTable", "CoggingTableError",
    "build_lut", "lut_currents", "lut_error", "write_lut", "read_lut", "lut_header", "lut_columns",
    "build_cogging_table", "cogging_table_error", "write_cogging_table",
    "classical_parameters", "drive_gain", "MIN_DRIVE_GAIN", "f_star_set", "model_standard_error",
    "table_error_bound", "coarsest_resolution_within",
]

from pgcomm.defaults import DEFAULT_RESOLUTION  # noqa: E402  (re-exported)
from pgcomm import __version__
from pgcomm.export.c_text import SINGLE, check_c_name, ieee_finite, macro_literal
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.tables import read_csv_columns, read_csv_header

#: Fx and Tz of the test forces relative to |Fy| = f_max.
SIDE_FRACTION = 0.05

_DIRS = ("y", "x", "z")


# ----------------------------------------------------------------------------------------------
# full law
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Lut:
    """Table of the model-based law on a uniform position grid.

    Attributes:
        y: ``(n,)`` grid positions (m), uniform spacing :attr:`dy`.
        P: ``(n, L, 2, 3)`` pseudo-inverse entries: ``P[k, l, a, j]`` is current ``a`` (0: ia,
            1: ib) of coil set ``l`` per unit of force direction ``j`` (Fy, Fx in A/N; Tz in
            A/(N·m)).
        cogging: ``(n, 3)`` mean cogging force ``F̂_cog`` (N, N, N·m).
        current_limit: peak phase current (A) applied after interpolation, or ``None``.
        direction: ``(3,)`` the direction offset ``C̄`` (N, N, N·m; see the module docstring), or ``(n, 3)``
            one per grid point (a spline model's ``C(y)``, interpolated like the rest), or ``None``.
        direction_velocity: its ``v_ε`` (m/s).
    """

    y: np.ndarray
    P: np.ndarray
    cogging: np.ndarray
    current_limit: float | None = None
    direction: np.ndarray | None = None
    direction_velocity: float = 1e-3

    @property
    def n(self) -> int:
        """Number of grid points."""
        return int(self.y.shape[0])

    @property
    def n_coil_sets(self) -> int:
        """``L``."""
        return int(self.P.shape[1])

    @property
    def dy(self) -> float:
        """Grid spacing (m)."""
        return float((self.y[-1] - self.y[0]) / (self.n - 1))

    @property
    def entries(self) -> int:
        """Table entries without the implicit grid: ``n (6L + 3)``."""
        return int(self.P[0].size + self.cogging[0].size) * self.n

    @property
    def nbytes(self) -> int:
        """Size of the C table in bytes (float32 entries)."""
        return 4 * self.entries


#: Most rows of a table (law or anti-cogging): 200 000 rows of 21 float32 entries are 17 MB, far more
#: than a drive holds, and the error check on a 10x finer grid (2 million points) still runs in seconds.
MAX_ROWS = 200_000


def grid_rows(y_range, resolution: float) -> int:
    """Rows of the uniform grid over ``y_range`` (m) with spacing ``<= resolution`` (m), without allocating it."""
    y0, y1 = float(y_range[0]), float(y_range[1])
    return max(int(math.ceil((y1 - y0) / resolution * (1 - 1e-9))) + 1, 2)


def _grid(model, resolution, y_range):
    """Uniform grid covering ``y_range`` (or the training range) with spacing ``<= resolution``."""
    if not (isinstance(resolution, (int, float)) and math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive length in m, got {resolution!r}")
    if y_range is None:
        y_range = model.training_range
        if y_range is None:
            raise ValueError("the model has no training range; pass y_range=(y_min, y_max) in m")
    y0, y1 = float(y_range[0]), float(y_range[1])
    if not (math.isfinite(y0) and math.isfinite(y1) and y1 > y0):
        raise ValueError(f"y_range must be finite with y_max > y_min, got {y_range}")
    # the last point lands exactly on y_max (no extrapolation of the model); the spacing is the
    # largest (y1 - y0)/(n - 1) not above the requested resolution (a relative 1e-9 slack keeps
    # exact divisions, e.g. 0.2 m / 0.25 mm, at the requested spacing)
    span = y1 - y0
    if span / resolution > MAX_ROWS:
        raise ValueError(f"a table every {resolution:g} m over [{y0:.6g}, {y1:.6g}] m would have "
                         f"{span / resolution:.3g} rows; at most {MAX_ROWS} (use a resolution of at least "
                         f"{span / (MAX_ROWS - 1):.3g} m)")
    return np.linspace(y0, y1, grid_rows((y0, y1), resolution))


@jax.jit
def _p_and_cog(model, y, det_min):
    """``P(y)`` ``S + (L, 2, 3)`` and ``F̂_cog(y)`` ``S + (3,)`` with the law's damping."""
    gain = model.gain(y)
    winv = metric_inverse(gain.shape[-3], "phase")
    eye = jnp.eye(3)
    cols = [min_energy_currents(gain, jnp.broadcast_to(eye[j], y.shape + (3,)), winv, det_min=det_min)
            for j in range(3)]
    return jnp.stack(cols, axis=-1), model.cogging(y)


def build_lut(model, resolution: float = DEFAULT_RESOLUTION, y_range=None, current_limit: float | None = None,
              det_min: float = DEFAULT_DET_MIN) -> Lut:
    """Tabulate ``P(y)`` and ``F̂_cog(y)`` of ``ModelLaw(model, "phase", current_limit, det_min)``.

    Args:
        model: :class:`~pgcomm.models.CombinedModel` (or any pytree with ``gain``/``cogging``
            and ``training_range``).
        resolution: largest grid spacing (m); the grid covers ``y_range`` from end to end,
            so the actual spacing :attr:`Lut.dy` is ``(y_max - y_min)/(n - 1) <= resolution``.
            Default :data:`DEFAULT_RESOLUTION` (see the module docstring for its error).
        y_range: ``(y_min, y_max)`` (m); default the model's training range.
        current_limit: peak phase current (A) applied after interpolation, or ``None``.
        det_min: damping threshold of :func:`pgcomm.commutation.min_energy_currents`.

    Returns:
        :class:`Lut`.
    """
    if current_limit is not None and not (math.isfinite(current_limit) and current_limit > 0):
        raise ValueError(f"current_limit must be a positive number of amperes or None, got {current_limit}")
    y = _grid(model, resolution, y_range)
    P, cog = _p_and_cog(model, jnp.asarray(y), det_min)
    P, cog = np.asarray(P), np.asarray(cog)
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(cog))):
        raise ValueError("the law is not finite on the grid (model with non-finite parameters?)")
    direction = None
    if getattr(model, "C", None) is not None:
        c = np.asarray(model.C, dtype=float)
        direction = sum(c[l] for l in range(c.shape[0])) / c.shape[0]
    elif getattr(model, "dir_table", None) is not None:
        # a spline model's direction force C(y) varies along the stroke: one row per grid point
        direction = np.asarray(interp_linear(jnp.asarray(model.dir_knots), jnp.asarray(model.dir_table),
                                             jnp.asarray(y)))
    return Lut(y, P, cog, None if current_limit is None else float(current_limit), direction,
               float(getattr(model, "direction_velocity", 1e-3)))


def lut_currents(lut: Lut, y, f_star, v=None):
    """Star currents of the table law, ``S + (L, 2)`` (A), safe for every input as the generated C is.

    ``i = P̃(y) (F* - F̂̃_cog(y) [- C̄ tanh(v/v_ε)])`` with linearly interpolated entries
    (the end rows held outside the table), then the current limit. A sample with a non-finite
    ``y``, ``F*`` or ``v`` (or currents that would overflow) gets zero currents.

    Args:
        y: ``S`` (m); f_star: ``S + (3,)`` desired ``[Fy, Fx, Tz]`` (N, N, N·m);
        v: ``S`` velocity (m/s), used with a direction offset.
    """
    y = jnp.asarray(y, dtype=float)
    f_star = jnp.asarray(f_star, dtype=float)
    ok = jnp.isfinite(y) & jnp.all(jnp.isfinite(f_star), axis=-1)
    use_v = lut.direction is not None and v is not None
    if use_v:
        v = jnp.asarray(v, dtype=float)
        ok = ok & jnp.isfinite(v)
        v = jnp.where(ok, v, 0.0)
    # held inputs for the refused samples: nothing non-finite enters the arithmetic
    y = jnp.where(ok, y, float(lut.y[0]))
    f_star = jnp.where(ok[..., None], f_star, 0.0)
    if use_v:
        c = jnp.asarray(lut.direction)
        if c.ndim == 2:  # along the stroke (spline model)
            c = interp_linear(jnp.asarray(lut.y), c, y)
        f_star = f_star - c * jnp.tanh(v / lut.direction_velocity)[..., None]
    return _lut_currents(jnp.asarray(lut.y), jnp.asarray(lut.P), jnp.asarray(lut.cogging), lut.current_limit,
                         y, f_star, ok)


@functools.partial(jax.jit, static_argnums=(3,))
def _lut_currents(grid, P, cog, current_limit, y, f_star, ok):
    p = interp_linear(grid, P, y)
    c = interp_linear(grid, cog, y)
    i = limit_currents(jnp.sum(p * (f_star - c)[..., None, None, :], axis=-1), current_limit)
    ok = ok & jnp.all(jnp.isfinite(i), axis=(-2, -1))
    return jnp.where(ok[..., None, None], i, 0.0)


@dataclass(frozen=True)
class LutError:
    """Worst-case force error of a table law against the exact law, evaluated on the model.

    Attributes:
        abs: ``(3,)`` worst ``|F̂(y, i_table) - F̂(y, i_exact)|`` per direction y, x, z
            (N, N, N·m).
        rel: ``(3,)`` the same divided by ``f_max``.
        y_worst: ``(3,)`` positions (m) where each worst case occurs.
        f_max: ``|Fy|`` of the test forces (N).
        points: number of positions evaluated.
    """

    abs: np.ndarray
    rel: np.ndarray
    y_worst: np.ndarray
    f_max: float
    points: int

    @property
    def worst_rel(self) -> float:
        """Largest of :attr:`rel`."""
        return float(np.max(self.rel))

    def to_dict(self) -> dict:
        """``{"y": {"abs": N, "rel": -, "y_worst": m}, "x": ..., "z": ..., "f_max": N, "points": n}``."""
        d = {q: {"abs": float(self.abs[k]), "rel": float(self.rel[k]), "y_worst": float(self.y_worst[k])}
             for k, q in enumerate(_DIRS)}
        d.update(f_max=self.f_max, points=self.points, worst_rel=self.worst_rel)
        return d


def f_star_set(f_max: float) -> np.ndarray:
    """Test forces ``(18, 3)``: ``Fy = ±f_max``, ``Fx, Tz ∈ {0, ±0.05 f_max}`` (N, N, N·m)."""
    s = SIDE_FRACTION * f_max
    return np.array([[fy, fx, tz] for fy in (f_max, -f_max) for fx in (0.0, s, -s) for tz in (0.0, s, -s)])


@jax.jit
def _law_force_diff(model, law, y, f_star, i_other):
    """``F̂(y, i_other) - F̂(y, i_exact)`` = ``Σ_l K̂^l (i_other - i_exact)``, ``(m, nF, 3)``."""
    i_exact = law.currents(y[:, None], f_star[None, :, :])
    gain = model.gain(y)[:, None]
    return jnp.einsum("mflqj,mflj->mfq", jnp.broadcast_to(gain, i_exact.shape[:2] + gain.shape[2:]),
                      i_other - i_exact)


def _worst(diff, y, f_max) -> LutError:
    a = np.max(np.abs(diff), axis=1)  # (m, 3)
    k = np.argmax(a, axis=0)
    worst = a[k, np.arange(3)]
    return LutError(worst, worst / f_max, y[k], float(f_max), int(y.shape[0]))


def lut_error(lut: Lut, model, f_max: float, factor: int = 10, det_min: float = DEFAULT_DET_MIN) -> LutError:
    """Worst-case force error of the table law on a grid ``factor`` times finer than the table's.

    The force is evaluated on the model itself: ``|F̂(y, i_table) - F̂(y, i_exact)|`` with
    ``i_exact`` from ``ModelLaw(model, "phase", lut.current_limit, det_min)``, over every
    fine-grid position and every ``F*`` of :func:`f_star_set` (``|Fy| = f_max``, ``Fx, Tz`` at
    0 or ±5 % of it). The fine grid contains the cell midpoints for even ``factor``, where
    linear interpolation errs most.

    Args:
        f_max: largest driving force of interest (N); the relative errors are divided by it.
        factor: refinement of the evaluation grid (>= 2).

    Returns:
        :class:`LutError` (per direction y, x, z).
    """
    if not (f_max > 0 and math.isfinite(f_max)):
        raise ValueError(f"f_max must be a positive force in N, got {f_max}")
    if int(factor) < 2:
        raise ValueError(f"factor must be >= 2, got {factor}")
    y = np.linspace(lut.y[0], lut.y[-1], (lut.n - 1) * int(factor) + 1)
    fs = f_star_set(f_max)
    law = ModelLaw(model, metric="phase", current_limit=lut.current_limit, det_min=det_min)
    diffs = []
    # chunks of one size (the last padded with the last position) bound memory and compile the model's force
    # once, whatever the table's size: a search over spacings then compiles nothing new
    chunk = min(_ERROR_CHUNK, y.size)
    padded = np.concatenate([y, np.full(-y.size % chunk, y[-1])])
    for start in range(0, padded.size, chunk):
        yc = jnp.asarray(padded[start:start + chunk])
        i_lut = lut_currents(lut, yc[:, None], jnp.asarray(fs)[None])
        diffs.append(np.asarray(_law_force_diff(model, law, yc, jnp.asarray(fs), i_lut)))
    return _worst(np.concatenate(diffs)[: y.size], y, f_max)


#: Positions per chunk of :func:`lut_error` (18 test forces each: about 20 MB of float64 per chunk for L = 3).
_ERROR_CHUNK = 16384


# ----------------------------------------------------------------------------------------------
# what a table may cost: the model's own standard error
# ----------------------------------------------------------------------------------------------

#: Relative rounding of the table's float32 entries (half an ulp); the force passes through a few of them.
FLOAT32_ROUNDING = 2.0 ** -24


def _parameters_per_coil_set(model) -> float:
    """Fitted parameters per coil set of a PGNN (its arrays less the fixed input scaling ``y_center, y_scale``)."""
    leaves = jax.tree_util.tree_leaves(model)
    total = sum(int(np.size(x)) for x in leaves if hasattr(x, "shape") or isinstance(x, (int, float)))
    return max(total / model.n_coil_sets - 2.0, 1.0)


def model_standard_error(model, document) -> tuple[float | None, str]:
    """The standard error (N) of the model's driving force ``F̂y``, from what its file records, or ``None``.

    Per coil set, from the identification that ``pgcomm identify`` / ``reproduce`` record in the model
    file's metadata (``identification``):

    * PGNN: ``σ_y² p / (3 n)`` with ``σ_y² = cost_y`` (N², the mean squared Fy residual on the training
      data), ``p`` the coil set's parameters and ``3 n`` the force samples fitted (``n = n_train``): the
      mean variance of a least-squares fit's fitted values is ``σ² trace(H) / N = σ² p / N``;
    * spline model: ``(cv_y - cost_y) / 2`` from its cross-validated and training Fy residuals (N²): the
      cross-validation's excess over the training residual is twice the fitted values' variance for a
      linear smoother.

    The coil sets are fitted independently, so their variances add.

    Args:
        model: the loaded model; document: its file's document (:func:`pgcomm.io.model.load_model`).

    Returns:
        ``(standard error in N or None, how it was found)``.
    """
    meta = document.get("metadata") if isinstance(document, dict) else None
    ident = meta.get("identification") if isinstance(meta, dict) else None
    if not isinstance(ident, dict):
        return None, "the model file records no identification"
    var = []
    try:
        if isinstance(ident.get("spline"), dict):
            sp = ident["spline"]
            for c, cv in zip(sp["cost"], sp["cost_validation"]):
                var.append(max(float(cv["y"]) - float(c["y"]), 0.0) / 2.0)
            how = "the spline fit's cross-validated minus training Fy residual, halved"
        else:
            p = _parameters_per_coil_set(model)
            for cs in ident["coil_sets"]:
                var.append(float(cs["cost_y"]) * p / (3.0 * float(cs["n_train"])))
            how = "the training Fy residual (cost_y) x parameters / (3 x samples)"
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        return None, "the model file's identification record has no Fy residual"
    if len(var) != model.n_coil_sets or not all(math.isfinite(v) and v >= 0 for v in var):
        return None, "the model file's identification record has no usable Fy residual"
    return float(math.sqrt(sum(var))), how


def table_error_bound(model, document, f_max: float) -> tuple[float, str]:
    """The largest worst-case Fy error (N) a table law may add: the model's own standard error
    (:func:`model_standard_error`) or the float32 rounding of the table's entries at ``f_max``, whichever is larger.

    Returns:
        ``(bound in N, what it is)``.
    """
    quant = 4.0 * FLOAT32_ROUNDING * f_max
    se, how = model_standard_error(model, document)
    if se is not None and se >= quant:
        return se, f"the model's own standard error of Fy, {se:.3g} N ({how})"
    return quant, (f"the float32 rounding of the table at f_max, {quant:.3g} N"
                   + (f" (above the model's standard error {se:.3g} N)" if se is not None else f" ({how})"))


def coarsest_resolution_within(model, bound: float, f_max: float, current_limit=None, y_range=None,
                               start: float = DEFAULT_RESOLUTION, start_error: float | None = None,
                               evaluations: int = 6) -> float | None:
    """The largest table spacing (m, within about 10 %) whose worst-case Fy error (:func:`lut_error`) is at most
    ``bound`` (N), searched below ``start`` (a spacing whose error, ``start_error`` N if known, is above it);
    ``None`` if even a table of :data:`MAX_ROWS` rows errs more (or no spacing was found in ``evaluations``
    tables).

    Linear interpolation errs as the spacing squared: each next spacing is the closest failing one scaled by
    ``0.95 sqrt(bound / error)``, and the search stops once that law puts the limit within 10 % above the
    largest passing spacing.
    """
    rng = model.training_range if y_range is None else y_range
    span = float(rng[1]) - float(rng[0])
    finest = span / (MAX_ROWS - 1)

    def err(h):
        lut = build_lut(model, h, y_range=y_range, current_limit=current_limit)
        return float(lut_error(lut, model, f_max).abs[0])

    bad = (float(start), err(float(start)) if start_error is None else float(start_error))
    if bad[1] <= bound:
        return bad[0]
    good = None
    for _ in range(evaluations):
        if good is None:
            h = max(bad[0] * min(0.9, 0.95 * math.sqrt(bound / bad[1])), finest)
        else:
            limit = good[0] * math.sqrt(bound / max(good[1], 1e-300))
            if limit < 1.1 * good[0]:
                break
            h = min(0.97 * limit, math.sqrt(good[0] * bad[0]))
        e = err(h)
        if e <= bound:
            good = (h, e)
        elif h <= finest:
            return None
        else:
            bad = (h, e)
    return None if good is None else good[0]


# ----------------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------------


def lut_columns(n_coil_sets: int) -> list[str]:
    """CSV column names: ``y``, ``P_{l}{a|b}_{y|x|z}`` (l 1-based), ``Fy_cog, Fx_cog, Tz_cog``."""
    cols = ["y"]
    for l in range(n_coil_sets):
        for a in "ab":
            cols += [f"P_{l + 1}{a}_{q}" for q in _DIRS]
    return cols + ["Fy_cog", "Fx_cog", "Tz_cog"]


def _lut_rows(lut: Lut) -> np.ndarray:
    return np.concatenate([lut.y[:, None], lut.P.reshape(lut.n, -1), lut.cogging], axis=1)


def write_lut(lut: Lut, out_dir, name: str = "pgcomm_lut", limit_source: str | None = None) -> list[Path]:
    """Write ``NAME.csv`` (float64, round-trips) and ``NAME.h`` (float32 C table) into ``out_dir``.

    Each file is written atomically (:mod:`pgcomm.io.atomic`). The C table takes
    :attr:`Lut.nbytes` bytes; its comment block states the current limit and ``limit_source``
    (:func:`lut_header`). The CSV stays a plain table (read back by :func:`read_lut`).

    Returns:
        ``[csv_path, header_path]``.
    """
    check_c_name(name)
    header = lut_header(lut, name, limit_source)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(lut_columns(lut.n_coil_sets))
    for row in _lut_rows(lut):
        w.writerow(["%.17g" % v for v in row])
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"{name}.csv", out / f"{name}.h"]
    atomic_write_text(paths[0], buf.getvalue())
    atomic_write_text(paths[1], header)
    if lut.direction is not None and np.ndim(lut.direction) == 2:
        # along the stroke (spline model): C(y) per grid row, applied as C(y) tanh(v / v_eps)
        rows = ["y,Fy_dir,Fx_dir,Tz_dir,v_eps"]
        for yv, c in zip(lut.y, np.asarray(lut.direction)):
            rows.append(",".join(["%.17g" % yv] + ["%.17g" % x for x in c] + ["%.17g" % lut.direction_velocity]))
        paths.append(out / f"{name}_direction.csv")
        atomic_write_text(paths[2], "\n".join(rows) + "\n")
    elif lut.direction is not None:
        rows = ["direction,Fy_dir,Fx_dir,Tz_dir,v_eps"]
        for sgn in (1.0, -1.0):
            rows.append(",".join(["%+d" % sgn] + ["%.17g" % (sgn * c) for c in lut.direction]
                                 + ["%.17g" % lut.direction_velocity]))
        paths.append(out / f"{name}_direction.csv")
        atomic_write_text(paths[2], "\n".join(rows) + "\n")
    return paths


def _check_grid(path, y) -> None:
    """``y`` (m) strictly increasing and uniform, else DataError naming the file and row."""
    d = np.diff(y)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0))
        raise DataError(f"{path}: column 'y' must be strictly increasing; row {i + 2} ({y[i + 1]}) "
                        f"follows {y[i]}")
    if np.max(np.abs(d - d.mean())) > 1e-9 * max(abs(y[0]), abs(y[-1]), d.mean()):
        raise DataError(f"{path}: column 'y' is not uniformly spaced (spacing {d.min():.6g} to {d.max():.6g} m)")


def read_lut(path, current_limit: float | None = None) -> Lut:
    """Read a table written by :func:`write_lut` (the CSV). ``L`` comes from the column names.

    Args:
        current_limit: limit (A) to attach (the CSV does not store it), or ``None``.

    Raises:
        DataError: missing/misnamed columns, non-numbers, NaN/inf, non-uniform ``y``.
    """
    path = Path(path)
    head = read_csv_header(path)
    n_p = len(head) - 4
    if n_p <= 0 or n_p % 6:
        raise DataError(f"{path}: {len(head)} columns do not form y, 6 per coil set, Fy_cog, Fx_cog, Tz_cog")
    L = n_p // 6
    expected = lut_columns(L)
    for j, (got, want) in enumerate(zip(head, expected)):
        if got != want:
            raise DataError(f"{path}: column {j + 1} is '{got}', expected '{want}'")
    cols = read_csv_columns(path)
    data = np.column_stack([cols[h] for h in head])
    if data.shape[0] < 2:
        raise DataError(f"{path}: need at least 2 rows, got {data.shape[0]}")
    bad = ~np.isfinite(data)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise DataError(f"{path}: row {i + 1}, column '{head[j]}' is not finite ({data[i, j]})")
    _check_grid(path, data[:, 0])
    n = data.shape[0]
    return Lut(data[:, 0].copy(), data[:, 1:1 + n_p].reshape(n, L, 2, 3).copy(), data[:, 1 + n_p:].copy(),
               current_limit)


def _c_rows(a: np.ndarray, indent: str) -> str:
    """Nested C initializer of float32 literals (one innermost row per line)."""
    def rec(x, depth):
        if x.ndim == 1:
            return "{" + ", ".join(SINGLE.lit(v) for v in x) + "}"
        inner = ",\n".join(indent * (depth + 1) + rec(v, depth + 1) for v in x)
        return "{\n" + inner + "\n" + indent * depth + "}"

    return rec(a, 0)


def lut_header(lut: Lut, name: str = "pgcomm_lut", limit_source: str | None = None) -> str:
    """Text of the header-only C99 table (``static const float`` arrays, ``static inline`` lookup).

    The function ``int NAME_currents(float y, [float v,] const float f_star[3], float currents[L][2])``
    interpolates like :func:`lut_currents` and is safe for every input, with the return codes of
    the C law (:mod:`pgcomm.export.c`):

    * ``0``: ``y`` (m) inside the table;
    * ``1``: outside it: the end row is used (``y`` held at the table's end);
    * ``2``: a non-finite input (NaN or ±inf in ``y``, ``f_star`` or ``v``), or currents that would
      overflow: all currents are zero.

    The current limit :attr:`Lut.current_limit` (A, one factor for all coil sets) bounds every
    phase current ``ia, ib, ic = -ia - ib``.

    Args:
        lut: the table (:func:`build_lut`).
        name: C identifier prefix.
        limit_source: where the limit (or its absence) came from, written after it in the comment
            block (e.g. ``"from the model file"``); ``None``: not said.
    """
    check_c_name(name)
    U, L, lit = name.upper(), lut.n_coil_sets, SINGLE.lit
    guard = f"{U}_H_INCLUDED"
    src = f" ({limit_source})" if limit_source else ""
    limit = (f"{lut.current_limit:.6g} A peak phase current{src}; one factor for all coil sets keeps "
             "max(|ia|, |ib|, |ic|) <= limit" if lut.current_limit is not None else f"none{src}")
    vdecl = "float v, " if lut.direction is not None else ""
    finite = " && ".join(["isfinite(y)"] + [f"isfinite(f_star[{q}])" for q in range(3)]
                         + (["isfinite(v)"] if lut.direction is not None else []))
    dir_rows = lut.direction is not None and np.ndim(lut.direction) == 2
    # the direction offset of row k: a constant, or interpolated along the stroke like Fcog
    dir_term = ("" if lut.direction is None else
                f" - ({name}_dir[k][j] * (1.0f - t) + {name}_dir[k + 1][j] * t) * sg" if dir_rows else
                f" - {name}_dir[j] * sg")
    lines = [
        f"{name}.h -- lookup table of the model-based commutation law, generated by pgcomm {__version__}.",
        *(["Direction term: F* - Fcog(y) - Cdir tanh(v / V_EPS), v the controller's velocity (m/s)",
           "(offset pair +-Cdir when moving forwards / backwards)."] if lut.direction is not None and not dir_rows
          else []),
        *(["Direction term: F* - Fcog(y) - C(y) tanh(v / V_EPS), v the controller's velocity (m/s),",
           "C(y) tabulated per row and interpolated like Fcog (spline model)."] if dir_rows else []),
        "Law (eq. Commutation_Model_Currents): i^l = P^l(y) (F* - Fcog(y)), minimum copper loss,",
        "damped where Khat loses rank; P and Fcog interpolated linearly between grid rows.",
        f"Grid: {lut.n} rows, y from {lut.y[0]:.9g} to {lut.y[-1]:.9g} m, spacing {lut.dy:.9g} m.",
        f"Size: {lut.entries} float32 entries = {lut.nbytes} bytes.",
        f"Current limit: {limit}.",
        "Return codes: 0 = y inside the table; 1 = y outside it: the end row is used (y held there);",
        "2 = a non-finite input (NaN or inf in y, f_star" + (", v" if lut.direction is not None else "")
        + ") or currents that would overflow: all currents zero.",
        "Units: y m; F* = [Fy N, Fx N, Tz N m]; P in A/N (Fy, Fx columns) and A/(N m) (Tz);",
        "currents A (star: ia, ib; ic = -ia - ib).",
    ]
    out = ["/*\n", *(f" * {s}\n" for s in lines), " */\n", f"#ifndef {guard}\n#define {guard}\n\n",
           f"#define {U}_L {L}\n#define {U}_N {lut.n}\n",
           f"#define {U}_Y0 {macro_literal(lit(lut.y[0]))}\n#define {U}_INV_DY {macro_literal(lit(1.0 / lut.dy))}\n\n",
           f"/* P[k][l][a][j]: current a (ia, ib) of coil set l per unit force j (Fy, Fx, Tz) at row k */\n",
           f"static const float {name}_P[{lut.n}][{L}][2][3] = {_c_rows(lut.P, '    ')};\n\n",
           "/* mean cogging force [Fy, Fx, Tz] (N, N, N m) at row k */\n",
           f"static const float {name}_cog[{lut.n}][3] = {_c_rows(lut.cogging, '    ')};\n\n",
           *([f"/* direction offset Cdir [Fy, Fx, Tz] (N, N, N m) and v_eps (m/s) */\n",
              f"static const float {name}_dir[3] = {_c_rows(np.asarray(lut.direction), '')};\n",
              f"#define {U}_V_EPS {macro_literal(lit(lut.direction_velocity))}\n\n"] if lut.direction is not None and not dir_rows
             else []),
           *([f"/* direction force C(y) [Fy, Fx, Tz] (N, N, N m) at row k, and v_eps (m/s) */\n",
              f"static const float {name}_dir[{lut.n}][3] = {_c_rows(np.asarray(lut.direction), '    ')};\n",
              f"#define {U}_V_EPS {macro_literal(lit(lut.direction_velocity))}\n\n"] if dir_rows else []),
           f"static inline int {name}_currents(float y, {vdecl}const float f_star[3], float currents[{U}_L][2])\n{{\n",
           f"    float u, t, f[3];\n    int k, l, a, j, ret = 0;\n",
           *(["    float sg;\n"] if lut.direction is not None else []),
           "\n    /* a non-finite input gives zero currents and code 2 (as the C law and pgcomm's ModelLaw) */\n",
           f"    if (!({finite})) {{\n",
           f"        for (l = 0; l < {U}_L; ++l)\n            currents[l][0] = currents[l][1] = 0.0f;\n",
           "        return 2;\n    }\n",
           *([f"    sg = tanhf(v / {U}_V_EPS);\n"] if lut.direction is not None else []),
           f"    u = (y - {U}_Y0) * {U}_INV_DY;\n",
           "    if (!(u >= 0.0f)) { u = 0.0f; ret = 1; }\n",
           f"    if (u > (float)({U}_N - 1)) {{ u = (float)({U}_N - 1); ret = 1; }}\n",
           f"    k = (int)u;\n    if (k > {U}_N - 2)\n        k = {U}_N - 2;\n    t = u - (float)k;\n",
           "    /* a (1 - t) + b t is exact at grid rows, including the last one */\n",
           f"    for (j = 0; j < 3; ++j)\n        f[j] = f_star[j] - ({name}_cog[k][j] * (1.0f - t) + "
           f"{name}_cog[k + 1][j] * t){dir_term};\n",
           f"    for (l = 0; l < {U}_L; ++l)\n        for (a = 0; a < 2; ++a) {{\n",
           "            float s = 0.0f;\n            for (j = 0; j < 3; ++j)\n",
           f"                s += ({name}_P[k][l][a][j] * (1.0f - t) + {name}_P[k + 1][l][a][j] * t) * f[j];\n",
           "            currents[l][a] = s;\n        }\n",
           "    /* demands so large that the float sums overflow: zero currents, code 2 */\n",
           f"    for (l = 0; l < {U}_L; ++l)\n",
           "        if (!(isfinite(currents[l][0]) && isfinite(currents[l][1]))) {\n",
           f"            for (l = 0; l < {U}_L; ++l)\n                currents[l][0] = currents[l][1] = 0.0f;\n",
           "            return 2;\n        }\n"]
    if lut.current_limit is not None:
        out += ["    {\n        float peak = 0.0f, sc;\n",
                f"        for (l = 0; l < {U}_L; ++l) {{\n",
                "            const float ic = -(currents[l][0] + currents[l][1]);\n",
                "            if (fabsf(currents[l][0]) > peak) peak = fabsf(currents[l][0]);\n",
                "            if (fabsf(currents[l][1]) > peak) peak = fabsf(currents[l][1]);\n",
                "            if (fabsf(ic) > peak) peak = fabsf(ic);\n        }\n",
                f"        sc = peak > {lit(lut.current_limit)} ? {lit(lut.current_limit)} / peak : 1.0f;\n",
                f"        for (l = 0; l < {U}_L; ++l) {{\n",
                "            currents[l][0] *= sc;\n            currents[l][1] *= sc;\n        }\n    }\n"]
    out += ["    return ret;\n}\n\n", f"#endif /* {guard} */\n"]
    text = "".join(out)
    text = text.replace(f"#ifndef {guard}\n#define {guard}\n\n", f"#ifndef {guard}\n#define {guard}\n\n"
                        "#include <math.h>\n\n", 1)

    return ieee_finite(text, name, single=True)


# ----------------------------------------------------------------------------------------------
# anti-cogging table for drives with classical commutation
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CoggingTableError:
    """Errors of the anti-cogging table (see :func:`cogging_table_error`).

    Attributes:
        interpolation: worst ``|table(y) - F̂_cog,y(y)|`` on the fine grid (N).
        law_abs: ``(3,)`` worst force error (N, N, N·m) of classical commutation + table
            against the full law, per direction y, x, z, evaluated on the model.
        law_rel: ``(3,)`` the same divided by ``f_max``.
        k_hat, zeta_hat: ``(L,)`` the drive's commutation used (N/A, rad).
        f_max: ``|Fy*|`` of the test forces (N).
    """

    interpolation: float
    law_abs: np.ndarray
    law_rel: np.ndarray
    k_hat: np.ndarray
    zeta_hat: np.ndarray
    f_max: float

    def to_dict(self) -> dict:
        """Plain dict for results.json."""
        d = {q: {"abs": float(self.law_abs[k]), "rel": float(self.law_rel[k])} for k, q in enumerate(_DIRS)}
        return {"interpolation_abs": self.interpolation, "classical_plus_table": d,
                "k_hat": self.k_hat.tolist(), "zeta_hat": self.zeta_hat.tolist(), "f_max": self.f_max}


def _fundamental(model) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)``, each ``(L, 3, 2)`` (N/A): the model's fundamental ``A cos θ + B sin θ``.

    A PGNN has constant ``A, B``; a :class:`pgcomm.spline_model.SplineModel` tabulates them along
    the stroke, and a drive with one fixed commutation can only follow their mean: the mean over
    the gain knots inside the training range (all knots if none lie there, or without a range).
    """
    if hasattr(model, "A") and hasattr(model, "B"):
        return np.asarray(model.A), np.asarray(model.B)
    table = np.asarray(model.gain_table)             # (M_g, L, 2, 3, 2)
    knots = np.asarray(model.gain_knots)
    inside = np.ones(knots.shape, bool)
    if model.training_range is not None:
        lo, hi = model.training_range
        inside = (knots >= lo) & (knots <= hi)
        if not inside.any():
            inside[:] = True
    mean = table[inside].mean(axis=0)                # (L, 2, 3, 2)
    return mean[:, 0], mean[:, 1]


def classical_parameters(model) -> tuple[np.ndarray, np.ndarray]:
    """Classical ``k̂^l`` (N/A) and ``ζ̂^l`` (rad) fitted to the Fy rows of the model's physics part.

    The ideal star-reduced Fy row (eq. Electromagnetics_GainMatrix with ``ic = -ia - ib``) is
    ``(2/√3) k [sin(θ + ζ + π/6), sin(θ + ζ + π/2)]``, ``θ = 2πy/d_m``. For a spline model ``A, B``
    are the means of its tables over the training range (:func:`_fundamental`). Writing each column
    ``A_j cos θ + B_j sin θ`` as ``R_j sin(θ + ψ_j)``, i.e. ``B_j + i A_j = R_j e^{iψ_j}``, the
    least-squares fit over both columns is ``w = mean_j (B_j + i A_j) e^{-iφ_j}`` with
    ``φ = (π/6, π/2)``, ``k̂ = (√3/2)|w|``, ``ζ̂ = arg w``. Exact for an ideal motor
    (:func:`pgcomm.models.physics_from_ideal`).

    Returns:
        ``(k_hat, zeta_hat)``, each ``(L,)``.
    """
    A, B = _fundamental(model)
    A, B = A[:, 0, :], B[:, 0, :]
    phi = np.array([np.pi / 6, np.pi / 2])
    w = np.mean((B + 1j * A) * np.exp(-1j * phi), axis=-1)
    return np.sqrt(3.0) / 2.0 * np.abs(w), np.angle(w)


@jax.jit
def _cog_y(model, y):
    return model.cogging(y)[..., 0]


#: Smallest driving force per newton commanded (-) that a drive's classical commutation may make anywhere
#: on the table's grid: below it the table ``F̂_cog,y / g`` would be a large multiple of the cogging force
#: (near ``g = 0``, a ``ζ̂`` off by about π/2) or of the wrong sign (``g < 0``, ``ζ̂`` off by π).
MIN_DRIVE_GAIN = 0.25


@jax.jit
def _drive_gain(model, y, k_hat, zeta_hat):
    """``g(y) = Σ_l K̂^l_y(y) i_cl^l(y, 1 N)`` (-), shape of ``y``: see :func:`drive_gain`."""
    i1 = classical_single_direction(y, jnp.ones_like(y), k_hat, zeta_hat, model.pole_pitch)  # S + (L, 2), A/N
    return jnp.sum(model.gain(y)[..., 0, :] * i1, axis=(-2, -1))


def _drive(model, k_hat, zeta_hat):
    """``(k̂, ζ̂)`` as ``(L,)`` arrays; ``None`` (either): :func:`classical_parameters` of the model."""
    L = model.n_coil_sets
    if k_hat is None or zeta_hat is None:
        kf, zf = classical_parameters(model)
        k_hat = kf if k_hat is None else k_hat
        zeta_hat = zf if zeta_hat is None else zeta_hat
    k_hat = np.broadcast_to(np.asarray(k_hat, dtype=float), (L,)).copy()
    zeta_hat = np.broadcast_to(np.asarray(zeta_hat, dtype=float), (L,)).copy()
    if not (np.all(np.isfinite(k_hat)) and np.all(np.isfinite(zeta_hat)) and np.all(k_hat > 0)):
        raise ValueError(f"the drive's k_hat {k_hat.tolist()} N/A must be positive and zeta_hat "
                         f"{zeta_hat.tolist()} rad finite")
    return k_hat, zeta_hat


def drive_gain(model, y, k_hat=None, zeta_hat=None) -> np.ndarray:
    """Driving force the model makes per newton a drive's classical commutation commands, ``g(y)`` (-).

    The drive commutates ``u`` (N) as eq. Commutation_Solution_Ideal_SingleCoilset with its own
    ``k̂^l`` (N/A), ``ζ̂^l`` (rad) and ``Δ = 0``: ``i^l = u c^l(y)``; the model then makes
    ``F̂_y = g(y) u + F̂_cog,y(y)`` with ``g(y) = Σ_l K̂^l_y(y) c^l(y)`` — about
    ``(k/k̂) cos(ζ - ζ̂)`` plus the model's force ripple.

    Args:
        model: any model with ``gain``, ``n_coil_sets``, ``pole_pitch``; y: positions (m), any shape.
        k_hat, zeta_hat: the drive's ``(L,)`` (or scalar) commutation; ``None``: :func:`classical_parameters`.

    Returns:
        ``g`` with the shape of ``y``.
    """
    k_hat, zeta_hat = _drive(model, k_hat, zeta_hat)
    return np.asarray(_drive_gain(model, jnp.asarray(y, dtype=float), jnp.asarray(k_hat), jnp.asarray(zeta_hat)))


def _drive_offset(model, y, k_hat, zeta_hat):
    """The table's target ``F̂_cog,y(y) / g(y)`` (N) on ``y`` (m), after checking ``g >= MIN_DRIVE_GAIN``."""
    g = drive_gain(model, y, k_hat, zeta_hat)
    j = int(np.argmin(g))
    if not g[j] >= MIN_DRIVE_GAIN:
        raise ValueError(f"with k_hat {np.round(np.ravel(k_hat), 4).tolist()} N/A, zeta_hat "
                         f"{np.round(np.ravel(zeta_hat), 4).tolist()} rad the drive's commutation makes only "
                         f"{g[j]:.3g} N per N commanded at y = {float(np.ravel(y)[j]):.6g} m (at least "
                         f"{MIN_DRIVE_GAIN:g} needed); check the drive's zeta_hat (rad) and k_hat (N/A)")
    return np.asarray(_cog_y(model, jnp.asarray(y, dtype=float))) / g


def build_cogging_table(model, resolution: float = DEFAULT_RESOLUTION, y_range=None, k_hat=None,
                        zeta_hat=None) -> CoggingTable:
    """Anti-cogging table for a drive with classical commutation ``k̂, ζ̂``: ``F̂_cog,y(y) / g(y)`` (N).

    The drive commutates ``Fy* - table(y)`` (eq. Commutation_Solution_Ideal_SingleCoilset); the model then
    makes ``g(y) (Fy* - table(y)) + F̂_cog,y(y)``, so the table that cancels the cogging force for this
    drive is the cogging force divided by the drive's own force per newton commanded, :func:`drive_gain`
    (1 for a drive whose ``k̂, ζ̂`` match the motor; 1.1 for a drive whose ``k̂`` is 10 % high). At
    standstill (``Fy* = 0``) the cogging force is then cancelled up to the interpolation error.

    Grid as :func:`build_lut` (uniform, end to end over ``y_range`` or the training range,
    spacing ``<= resolution`` m).

    Args:
        k_hat, zeta_hat: the drive's ``(L,)`` (or scalar) commutation (N/A, rad); ``None`` (either):
            :func:`classical_parameters` of the model.

    Raises:
        ValueError: a bad grid, or a drive commutation that makes less than :data:`MIN_DRIVE_GAIN`
        newton per newton commanded somewhere on the grid.
    """
    y = _grid(model, resolution, y_range)
    k_hat, zeta_hat = _drive(model, k_hat, zeta_hat)
    return CoggingTable(jnp.asarray(y), jnp.asarray(_drive_offset(model, y, k_hat, zeta_hat)))


@jax.jit
def _classical_table_currents(model, y, fy_star, offset, k_hat, zeta_hat):
    return classical_single_direction(y, fy_star - offset, k_hat, zeta_hat, model.pole_pitch)


def cogging_table_error(table: CoggingTable, model, f_max: float, k_hat=None, zeta_hat=None, factor: int = 10,
                        current_limit: float | None = None) -> CoggingTableError:
    """Errors of a drive running classical commutation plus the anti-cogging table.

    (a) interpolation: ``max |table(y) - F̂_cog,y(y) / g(y)|`` on a grid ``factor`` times finer (N): the
    table against its target for this drive (:func:`build_cogging_table` with the same ``k̂, ζ̂``).
    (b) the force error left against the full law, on the model: the drive commutates
    ``Fy* - table(y)`` classically (eq. Commutation_Solution_Ideal_SingleCoilset with
    ``k̂, ζ̂``, ``Δ = 0``), giving ``i_tab``; the error is ``|F̂(y, i_tab) - F̂(y, i_exact)|``
    with ``i_exact`` from ``ModelLaw(model, "phase", current_limit)`` for ``F* = [±f_max, 0, 0]``
    (a force-offset drive cannot command Fx or Tz). This is mostly the gain mismatch the
    full law corrects, not the table's resolution.

    Args:
        k_hat, zeta_hat: the drive's ``(L,)`` (or scalar) commutation parameters (N/A, rad);
            ``None``: :func:`classical_parameters` of the model's physics part.
        f_max: ``|Fy*|`` (N).

    Returns:
        :class:`CoggingTableError`.
    """
    if not (f_max > 0 and math.isfinite(f_max)):
        raise ValueError(f"f_max must be a positive force in N, got {f_max}")
    k_hat, zeta_hat = _drive(model, k_hat, zeta_hat)
    y = np.linspace(float(table.y[0]), float(table.y[-1]), (table.n - 1) * int(factor) + 1)
    yj = jnp.asarray(y)
    off = table.offset(yj)
    interp = float(np.max(np.abs(np.asarray(off) - _drive_offset(model, y, k_hat, zeta_hat))))
    fs = np.array([[f_max, 0.0, 0.0], [-f_max, 0.0, 0.0]])
    law = ModelLaw(model, metric="phase", current_limit=current_limit)
    i_tab = _classical_table_currents(model, yj[:, None], jnp.asarray(fs[:, 0])[None, :], off[:, None],
                                      jnp.asarray(k_hat), jnp.asarray(zeta_hat))
    i_tab = limit_currents(i_tab, current_limit)
    diff = np.asarray(_law_force_diff(model, law, yj, jnp.asarray(fs), i_tab))
    e = _worst(diff, y, f_max)
    return CoggingTableError(interp, e.abs, e.rel, k_hat, zeta_hat, float(f_max))


def write_cogging_table(table: CoggingTable, out_dir, name: str = "pgcomm_cogging", comments=None) -> Path:
    """Write ``NAME.csv`` with columns ``y`` (m), ``Fy_cog`` (N), atomically. Returns the path.

    ``Fy_cog`` is the force offset the drive subtracts from its demand (:func:`build_cogging_table`).
    ``comments``: lines written first, each as ``# line`` (what the table is for: the drive's
    ``k̂, ζ̂`` and where they came from), e.g. ``pandas.read_csv(path, comment="#")`` skips them and
    ``numpy.loadtxt(path, delimiter=",", skiprows=len(comments) + 1)`` counts them. ``None``: a plain
    CSV, header first.
    """
    buf = io.StringIO()
    for line in comments or ():
        buf.write("# " + " ".join(str(line).split()) + "\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["y", "Fy_cog"])
    for yv, fv in zip(np.asarray(table.y), np.asarray(table.values)):
        w.writerow(["%.17g" % yv, "%.17g" % fv])
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{name}.csv"
    atomic_write_text(path, buf.getvalue())
    return path
