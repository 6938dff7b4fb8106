"""Identification of the electromagnetic part: cost, Proposition 1 and variable-projection training.

What this module implements (labels of the paper):

* the cost eq. Identification_CostFunction for one coil set ``l``::

      V = 1/(2N) Σ_{t ∈ Z_1 ∪ Z_2} ||F(t) - F̂(t)||² + ||Λ (θ_phy - θ_phy*)||²

  with ``2N`` the total number of (training) samples of both data sets, ``Λ`` diagonal
  (12 entries, default ``0.1 I``) and ``θ_phy = [col(A); col(B)]``;
* the physics-only fit (linear least squares for ``A, B``) giving ``θ_phy*``;
* the linear-in-the-parameters rewrite (eqs. PGNN_Rewritten_LIP, Linear_Parameter_Vector):
  ``F̂_q(t) = M(θ_NL, t) θ_L,q`` for ``q ∈ {y, x, z}`` with ONE regressor row shared by the
  three directions (each network outputs ``R^3`` from shared hidden features)::

      M = [cos·ia, cos·ib, sin·ia, sin·ib, h_1(s)·ia, ia, h_2(s)·ib, ib, h_φ(s), 1]

  (``cos, sin`` of ``2πy/d_m``, ``h`` the last hidden layers, ``s`` the scaled position);
  ``θ_L,q = [A_q1, A_q2, B_q1, B_q2, W_1[:, q], b_1[q], W_2[:, q], b_2[q], W_φ[:, q], b_φ[q]]``;
* Proposition 1 (eq. Optimal_Initialization): the optimal ``θ_L`` for given hidden
  weights ``θ_NL``, solved as a least-squares problem through an orthogonal factorisation
  (never by inverting the normal matrix);
* Algorithm 2 by variable projection: Levenberg–Marquardt over ``θ_NL`` only, with
  ``θ_L = Prop1(θ_NL)`` inside the loop and the exact Jacobian of the projected residual,
  several random starts evaluated together (a leading start axis; ``jax.vmap`` over the
  small per-start solves), the best kept; all starts run first on a subsample of the data,
  the best is then refined on all of it (see :func:`identify`);
* the persistent-excitation check of the paper's Remark.

Numerics (why it is done this way)
----------------------------------
The regressor of a 16-unit cogging network is nearly rank deficient (condition numbers of
``1e13``–``1e15`` even on scaled positions), so Proposition 1 needs an orthogonal
factorisation. A Householder QR from JAX on CPU is two orders of magnitude slower than a
matrix product, so the factorisation ``[M, F] D^{-1} = Q R`` is computed as a *repeated
Gram factorisation* (CholeskyQR2 with an eigenvalue floor in place of the Cholesky shift):
each pass accumulates ``G = Σ_chunks (A_c R^{-1})ᵀ (A_c R^{-1})`` over chunks of samples
(matrix products only), factors ``G = R_kᵀ R_k`` by a symmetric eigendecomposition with
eigenvalues floored at ``10·m·u·λ_max``, and updates ``R <- R_k R``. ``R`` is square
(``m = p + 3``), not triangular; the small least-squares problems are then solved by SVD of
``[R_M; √(2N) W_q; α B]``. After two passes this reproduces ``numpy.linalg.lstsq`` on the
full (column-scaled) problem to about ``1e-10`` in cost even at condition numbers of ``1e16``;
exactly dependent directions are damped instead of producing NaN. Memory is bounded by the
chunk size, independent of ``N``.

Damping. Without it the minimum-norm solution has output weights of ``1e7``–``1e8`` in the
directions the data cannot resolve, and the variable-projection gradient there is noise
(off by orders of magnitude against finite differences), so Levenberg–Marquardt stalls. A
fixed Tikhonov term ``α² Σ_k (b_k θ_k)²`` (``α = 1e-6`` relative to data-only column-norm
bounds ``b_k``) makes the projected cost smooth and its derivative exact; it is reported
separately and is not part of ``V``.

Sensitivity. The gradient of the projected cost depends on ``θ_L`` to first order, so
``JᵀJ`` and ``Jᵀr̃`` carry relative errors of about ``cond·u`` (``1e-12``–``1e-7``): they
agree with finite differences to ``1e-6`` but change at that level with the chunk size or
the summation order, while the cost and ``θ_L`` agree to ``1e-11``.

Sums over samples are never formed as an ``N x n`` Jacobian: the structured path (single
hidden layer, the paper's networks) reads every sum it needs from one Gram matrix of
``[M, F, V]`` accumulated in the first pass (``V`` are the derivatives of the features with
respect to their own hidden weights, obtained with ``jax.jvp`` of the activation); the
generic path (deeper networks) makes one more chunked pass with ``jax.jacfwd`` of the
feature map. Both give the same ``JᵀJ`` and ``Jᵀr`` (tested).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from pgcomm._pytree import pytree_dataclass
from pgcomm.commutation import currents_to_drive_inputs, drive_currents
from pgcomm.errors import DataError, ExcitationError
from pgcomm.models import (
    DEFAULT_COG_WIDTHS,
    DEFAULT_GAIN_WIDTHS,
    MLP,
    CoilSetModel,
    CombinedModel,
    activation_fn,
    harmonic_basis,
)

#: Default regularisation weight (``Λ = 0.1 I``, paper §Experimental results).
DEFAULT_LAMBDA = 0.1
#: Samples per chunk of the accumulated sums (structured / generic Jacobian path). Small chunks
#: keep each chunk's features in cache: 512 ran 1.6x faster than 4096 with 8 starts.
DEFAULT_CHUNK = 512
DEFAULT_CHUNK_GENERIC = 128
#: Relative Tikhonov damping of Proposition 1's least squares (see :func:`proposition1`).
DEFAULT_DAMPING = 1e-6
#: Fewest samples the first (subsampled) training phase uses.
_MIN_SUBSAMPLE = 4096
#: Singular values below this fraction of the largest are dropped (guards exact rank loss only).
_SV_CUTOFF = 1e-14
#: Re-orthogonalisation passes after the first Gram factorisation (1 = CholeskyQR2). One pass
#: already reproduces numpy.linalg.lstsq (same column scaling) to ~1e-10 in cost
#: at condition numbers of 1e16; a second changed nothing measurable.
_REORTHOGONALISATIONS = 1
#: Eigenvalue floor of the Gram factorisations, relative to the largest eigenvalue, per column.
_FLOOR_PER_COLUMN = 10 * np.finfo(float).eps

_STOP_REASONS = {0: "running", 1: "relative cost change below tol", 2: "step below tol",
                 3: "damping above 1e10 (no further decrease)", 4: "maximum iterations", 5: "non-finite cost"}


# --------------------------------------------------------------------------------------------
# data
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CoilSetData:
    """Measurements of one coil set operated alone (data sets ``Z_1^l ∪ Z_2^l``, eq. DataSets).

    Attributes:
        y: ``(N,)`` positions (m).
        currents: ``(N, 2)`` star currents ``(ia, ib)`` of this coil set (A).
        force: ``(N, 3)`` measured ``[Fy, Fx, Tz]`` (N, N, N·m).
        experiment: ``(N,)`` integer label of the data set ``Z_i`` each sample belongs to.
        name: used in messages, e.g. ``"coil set 2"``.
    """

    y: np.ndarray
    currents: np.ndarray
    force: np.ndarray
    experiment: np.ndarray | None = None
    name: str = "coil set"

    def __post_init__(self):
        y = np.asarray(self.y, dtype=float)
        cur = np.asarray(self.currents, dtype=float)
        frc = np.asarray(self.force, dtype=float)
        n = y.shape[0] if y.ndim == 1 else -1
        if y.ndim != 1:
            raise DataError(f"{self.name}: positions y must be 1-D, got shape {y.shape}")
        if cur.shape != (n, 2):
            raise DataError(f"{self.name}: currents must have shape ({n}, 2), got {cur.shape}")
        if frc.shape != (n, 3):
            raise DataError(f"{self.name}: force must have shape ({n}, 3), got {frc.shape}")
        exp = np.zeros(n, dtype=int) if self.experiment is None else np.asarray(self.experiment)
        if exp.shape != (n,):
            raise DataError(f"{self.name}: experiment labels must have shape ({n},), got {exp.shape}")
        for label, arr in (("y", y), ("currents", cur), ("force", frc)):
            bad = ~np.isfinite(arr.reshape(n, -1)).all(axis=1)
            if bad.any():
                raise DataError(f"{self.name}: {label} is not finite in row {int(np.argmax(bad))} "
                                f"({int(bad.sum())} rows)")
        object.__setattr__(self, "y", y)
        object.__setattr__(self, "currents", cur)
        object.__setattr__(self, "force", frc)
        object.__setattr__(self, "experiment", exp.astype(int))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.y.shape[0])

    @classmethod
    def from_drive_inputs(cls, y, fy, delta, force, k_hat, zeta_hat, pole_pitch, experiment=None,
                          name="coil set") -> "CoilSetData":
        """Data logged as drive inputs ``(Fy^l*, Δ^l)`` (the dotted block of Fig. PGNN_Parametrization).

        The currents are ``i = Γ(y) T(Fy*, Δ)`` (:func:`pgcomm.commutation.drive_currents`).

        Args:
            y: ``(N,)`` (m); fy: ``(N,)`` commanded force (N); delta: ``(N,)`` phase offset (rad);
            force: ``(N, 3)``; k_hat (N/A), zeta_hat (rad): the drive's fixed commutation;
            pole_pitch: ``d_m`` (m); experiment: ``(N,)`` labels.
        """
        y = np.asarray(y, dtype=float)
        fy = np.asarray(fy, dtype=float)
        delta = np.asarray(delta, dtype=float)
        if fy.shape != y.shape or delta.shape != y.shape:
            raise DataError(f"{name}: fy and delta must have the shape of y {y.shape}, got {fy.shape}, {delta.shape}")
        cur = np.asarray(drive_currents(y, fy[:, None], delta[:, None], k_hat, zeta_hat, pole_pitch))[:, 0, :]
        return cls(y, cur, force, experiment, name)

    def take(self, index) -> "CoilSetData":
        """The samples ``index`` (integer array or boolean mask)."""
        return CoilSetData(self.y[index], self.currents[index], self.force[index], self.experiment[index], self.name)


def split_indices(n: int, validation_fraction: float = 0.2, block_size: int = 500):
    """Deterministic train/validation split of ``n`` samples by contiguous blocks.

    Samples are grouped in blocks of ``block_size``; with ``k = round(1 / validation_fraction)``
    the last block of every group of ``k`` goes to validation (``0.2`` -> every 5th block).
    Contiguous blocks keep the strongly correlated neighbouring samples on one side.

    Returns:
        ``(train_index, validation_index)`` integer arrays.
    """
    if not 0.0 <= validation_fraction <= 0.5:
        raise ValueError(f"validation_fraction must be in [0, 0.5], got {validation_fraction}")
    idx = np.arange(n)
    if validation_fraction == 0.0:
        return idx, idx[:0]
    k = max(2, int(round(1.0 / validation_fraction)))
    is_val = (idx // int(block_size)) % k == k - 1
    return idx[~is_val], idx[is_val]


def train_validation_split(data: CoilSetData, validation_fraction: float = 0.2, block_size: int = 500):
    """``(train, validation)`` :class:`CoilSetData` by :func:`split_indices`."""
    tr, va = split_indices(data.n, validation_fraction, block_size)
    return data.take(tr), data.take(va)


# --------------------------------------------------------------------------------------------
# parameters: θ_phy, Λ, θ_L layout
# --------------------------------------------------------------------------------------------


def theta_phy(A, B) -> np.ndarray:
    """``θ_phy = [col(A); col(B)]`` (12,) for ``A, B`` of shape ``(3, 2)`` (column stacking)."""
    return np.concatenate([np.asarray(A, float).T.ravel(), np.asarray(B, float).T.ravel()])


def theta_phy_to_AB(theta) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`theta_phy`: ``(A, B)``, each ``(3, 2)``."""
    theta = np.asarray(theta, float)
    return theta[:6].reshape(2, 3).T, theta[6:].reshape(2, 3).T


def lambda_diagonal(Lambda) -> np.ndarray:
    """The 12 diagonal entries of ``Λ`` from a scalar, a ``(12,)`` vector or a diagonal ``(12, 12)`` matrix."""
    lam = np.asarray(Lambda, dtype=float)
    if lam.ndim == 0:
        return np.full(12, float(lam))
    if lam.shape == (12,):
        return lam.copy()
    if lam.shape == (12, 12):
        if np.any(lam - np.diag(np.diag(lam))):
            raise ValueError("Λ must be diagonal (Proposition 1 needs a diagonal Λ)")
        return np.diag(lam).copy()
    raise ValueError(f"Λ must be a scalar, (12,) or (12, 12); got shape {lam.shape}")


def _physics_columns(q: int) -> np.ndarray:
    """Indices in ``θ_phy`` of ``A[q, 0], A[q, 1], B[q, 0], B[q, 1]`` (the first 4 entries of ``θ_L,q``)."""
    return np.array([q, 3 + q, 6 + q, 9 + q])


@dataclass(frozen=True)
class _Layout:
    """Static structure of the LIP rewrite: which networks, widths, activation, Jacobian method."""

    gain_widths: tuple | None
    cog_widths: tuple | None
    activation: str
    method: str = "auto"  # "structured" | "generic" | "auto"

    @classmethod
    def of(cls, model: CoilSetModel, method="auto") -> "_Layout":
        gw = None if model.gain_nets is None else model.gain_nets[0].widths
        if model.gain_nets is not None and model.gain_nets[1].widths != gw:
            raise ValueError("both gain networks must have the same widths")
        cw = None if model.cog_net is None else model.cog_net.widths
        acts = {net.activation for net in model.networks} or {"tanh"}
        if len(acts) != 1:
            raise ValueError(f"all networks must share one activation, got {sorted(acts)}")
        return cls(gw, cw, acts.pop(), method)

    @property
    def blocks(self) -> tuple:
        """``(multiplier, widths)`` per network in column order; multiplier 0 = ia, 1 = ib, 2 = 1."""
        out = []
        if self.gain_widths is not None:
            out += [(0, self.gain_widths), (1, self.gain_widths)]
        if self.cog_widths is not None:
            out.append((2, self.cog_widths))
        return tuple(out)

    @property
    def p(self) -> int:
        """Length of one regressor row (of ``θ_L,q``)."""
        return 4 + sum(w[-1] + 1 for _, w in self.blocks)

    @property
    def n_nl(self) -> int:
        """Number of hidden-layer parameters ``θ_NL``."""
        total = 0
        for _, widths in self.blocks:
            n_prev = 1
            for n in widths:
                total += n_prev * n + n
                n_prev = n
        return total

    @property
    def structured(self) -> bool:
        """Use the single-hidden-layer structure for the Jacobian sums."""
        single = all(len(w) == 1 for _, w in self.blocks)
        if self.method == "structured" and not single:
            raise ValueError("the structured Jacobian needs networks with one hidden layer")
        return single if self.method == "auto" else self.method == "structured"

    def feature_columns(self) -> list[int]:
        """First column in ``M`` of each network's hidden-feature block."""
        cols, c = [], 4
        for _, w in self.blocks:
            cols.append(c)
            c += w[-1] + 1
        return cols

    def output_weight_mask(self) -> np.ndarray:
        """``(p,)`` True at the columns of ``M`` whose parameters are network output WEIGHTS."""
        mask = np.zeros(self.p, bool)
        for c, (_, w) in zip(self.feature_columns(), self.blocks):
            mask[c:c + w[-1]] = True
        return mask

    def param_units(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Structured path (one hidden layer): for each entry ``i`` of ``θ_NL`` the hidden unit
        ``k(i)`` it feeds (counted over all networks), the power ``a(i)`` of ``s`` in its
        derivative (1 for a weight, 0 for a bias) and the column ``col(i)`` of ``M`` of that unit.
        """
        unit, power, col, offset = [], [], [], 0
        for c, (_, w) in zip(self.feature_columns(), self.blocks):
            units = np.arange(w[0])
            unit += [offset + units, offset + units]  # weights, then biases
            power += [np.ones(w[0], int), np.zeros(w[0], int)]
            col += [c + units, c + units]
            offset += w[0]
        if not unit:
            return np.zeros(0, int), np.zeros(0, int), np.zeros(0, int)
        return np.concatenate(unit), np.concatenate(power), np.concatenate(col)


def hidden_vector(model: CoilSetModel) -> jnp.ndarray:
    """``θ_NL`` of ``model`` as a flat vector.

    Order: networks ``f_1, f_2, f_φ`` (those present); per network its hidden layers in
    order; per layer ``W.ravel()`` (row-major ``(n_{i-1}, n_i)``) then ``b``.
    """
    parts = [jnp.ravel(a) for net in model.networks for wb in net.hidden for a in wb]
    return jnp.concatenate(parts) if parts else jnp.zeros(0)


def _unflatten(layout: _Layout, flat) -> list:
    """Hidden layers per network from a flat ``θ_NL`` of shape ``lead + (n,)`` (arrays get the leading dims)."""
    lead = flat.shape[:-1]
    out, i = [], 0
    for _, widths in layout.blocks:
        layers, n_prev = [], 1
        for n in widths:
            w = flat[..., i:i + n_prev * n].reshape(lead + (n_prev, n))
            i += n_prev * n
            b = flat[..., i:i + n]
            i += n
            layers.append((w, b))
            n_prev = n
        out.append(tuple(layers))
    return out


def with_hidden_vector(model: CoilSetModel, flat) -> CoilSetModel:
    """Copy of ``model`` with ``θ_NL`` replaced by the flat vector ``flat`` (order of :func:`hidden_vector`)."""
    layout = _Layout.of(model)
    hidden = iter(_unflatten(layout, jnp.asarray(flat, dtype=float)))
    gain = None
    if model.gain_nets is not None:
        gain = tuple(MLP(next(hidden), net.W_out, net.b_out, net.activation) for net in model.gain_nets)
    cog = None
    if model.cog_net is not None:
        cog = MLP(next(hidden), model.cog_net.W_out, model.cog_net.b_out, model.cog_net.activation)
    return CoilSetModel(model.A, model.B, gain, cog, model.pole_pitch, model.y_center, model.y_scale,
                        model.y_min, model.y_max)


def theta_L_of(model: CoilSetModel) -> jnp.ndarray:
    """``θ_L`` of ``model`` as a ``(p, 3)`` matrix whose column ``q`` is ``θ_L,q`` (eq. Linear_Parameter_Vector)."""
    rows = [model.A[:, 0], model.A[:, 1], model.B[:, 0], model.B[:, 1]]
    for net in model.networks:
        rows += list(net.W_out) + [net.b_out]
    return jnp.stack(rows)


def with_theta_L(model: CoilSetModel, theta_L) -> CoilSetModel:
    """Copy of ``model`` with the linear parameters from a ``(p, 3)`` ``θ_L`` (inverse of :func:`theta_L_of`)."""
    theta_L = jnp.asarray(theta_L)
    A = jnp.stack([theta_L[0], theta_L[1]], axis=1)
    B = jnp.stack([theta_L[2], theta_L[3]], axis=1)
    i = 4
    outs = []
    for net in model.networks:
        n = net.W_out.shape[0]
        outs.append((theta_L[i:i + n], theta_L[i + n]))
        i += n + 1
    gain_out = outs[:2] if model.gain_nets is not None else None
    cog_out = outs[-1] if model.cog_net is not None else None
    return model.with_outputs(A, B, gain_out, cog_out)


# --------------------------------------------------------------------------------------------
# regressor
# --------------------------------------------------------------------------------------------


def _position_data(y, currents, pole_pitch, y_center, y_scale):
    """Data-only parts of the regressor: ``x0 = [cos·ia, cos·ib, sin·ia, sin·ib]ᵀ`` ``(4, N)``, ``s`` ``(N,)``."""
    y = jnp.asarray(y, dtype=float)
    cur = jnp.asarray(currents, dtype=float)
    c, sn = harmonic_basis(y, pole_pitch)
    x0 = jnp.stack([c * cur[:, 0], c * cur[:, 1], sn * cur[:, 0], sn * cur[:, 1]])
    return x0, (y - y_center) / y_scale


def _rows(layout: _Layout, hidden, x0, s, currents, with_u=False):
    """Regressor for ``S`` sets of hidden weights at once, feature-major: ``Mᵀ`` ``(S, p, c)``, ``u`` ``(S, U, c)``.

    ``hidden`` holds arrays with a leading start axis ``S``; ``x0`` ``(4, c)``, ``s`` ``(c,)``,
    ``currents`` ``(2, c)`` are shared. Samples are the minor axis so that the Gram products
    below contract contiguous rows. With ``with_u`` (single hidden layer only) also
    ``u = α'(z)·mult`` of every hidden unit (``α'`` by ``jax.jvp``): the derivative of a
    unit's column of ``M`` is ``u·s`` with respect to its weight and ``u`` to its bias.
    """
    n_s = hidden[0][0][0].shape[0] if hidden else 1
    c = x0.shape[-1]
    mults = (currents[0], currents[1], jnp.ones(c))
    cols = [jnp.broadcast_to(x0, (n_s,) + x0.shape)]
    ucols = []
    act = activation_fn(layout.activation)
    for (kind, _), layers in zip(layout.blocks, hidden):
        mult = mults[kind][None, None, :]
        (w1, b1), *rest = layers
        z = w1[:, 0, :, None] * s[None, None, :] + b1[:, :, None]  # (S, n_1, c)
        if with_u:
            h, dh = jax.jvp(act, (z,), (jnp.ones_like(z),))
            ucols.append(dh * mult)
        else:
            h = act(z)
            for w, b in rest:
                h = act(jnp.einsum("sic,sij->sjc", h, w) + b[:, :, None])
        cols += [h * mult, jnp.broadcast_to(mult, (n_s, 1, c))]
    m = jnp.concatenate(cols, axis=1)
    return (m, jnp.concatenate(ucols, axis=1)) if with_u else m


def regressor(theta_nl: CoilSetModel, y, currents):
    """LIP regressor ``M(θ_NL, t)`` (eq. PGNN_Rewritten_LIP), the same for the three directions.

    ``F̂_q(t) = M(θ_NL, t) θ_L,q`` with ``θ_L = theta_L_of(model)``.

    Args:
        theta_nl: a :class:`CoilSetModel`; its hidden layers are ``θ_NL`` (its ``A, B`` and
            output layers are not used) and it gives ``d_m`` and the input scaling.
        y: ``(N,)`` (m); currents: ``(N, 2)`` (A).

    Returns:
        ``(N, p)`` with columns ``[cos·ia, cos·ib, sin·ia, sin·ib, h_1·ia, ia, h_2·ib, ib, h_φ, 1]``
        (networks that are absent leave their columns out).
    """
    layout = _Layout.of(theta_nl)
    x0, s = _position_data(y, currents, theta_nl.pole_pitch, theta_nl.y_center, theta_nl.y_scale)
    hidden = _unflatten(layout, hidden_vector(theta_nl)[None])
    return _rows(layout, hidden, x0, s, jnp.asarray(currents, dtype=float).T)[0].T


# --------------------------------------------------------------------------------------------
# the projected problem (jitted core)
# --------------------------------------------------------------------------------------------


@pytree_dataclass
class _Chunks:
    """Training data padded to whole chunks of ``c`` samples (``C`` chunks); padded samples have ``mask = 0``.

    Feature-major like :func:`_rows`: ``x0`` ``(C, 4, c)`` and ``s`` ``(C, c)`` are the data-only
    parts of the regressor (:func:`_position_data`), computed once; currents ``(C, 2, c)``,
    force ``(C, 3, c)``, mask ``(C, c)``.
    """

    x0: jnp.ndarray
    s: jnp.ndarray
    currents: jnp.ndarray
    force: jnp.ndarray
    mask: jnp.ndarray


@pytree_dataclass
class _Consts:
    """Numbers of the problem (traced, so other values do not recompile)."""

    two_n: jnp.ndarray  # 2N: number of training samples
    reg_w: jnp.ndarray  # (3, p) weight of each regularisation row (Λ_q on physics, sqrt(ridge) on W_out)
    theta_bar: jnp.ndarray  # (p, 3) regularisation targets (θ_phy* on physics, 0 elsewhere)
    damp_w: jnp.ndarray  # (p,) weight of each damping row: damping × bound of the regressor column norm


@pytree_dataclass
class _Eval:
    """Evaluations of the projected problem at ``S`` values of ``θ_NL`` (leading axis ``S``).

    ``f = ½ ||r̃||²`` with ``r̃`` all data, regularisation and damping rows (the objective is
    ``2f / (2N)``); ``data2, phys2, ridge2, damp2``: the parts of ``||r̃||²``; ``theta_L``
    ``(p, 3)``; ``jtj, jtr``: ``JᵀJ`` and ``Jᵀr̃``.
    """

    f: jnp.ndarray
    data2: jnp.ndarray
    phys2: jnp.ndarray
    ridge2: jnp.ndarray
    damp2: jnp.ndarray
    theta_L: jnp.ndarray
    jtj: jnp.ndarray
    jtr: jnp.ndarray


def _to_chunks(data: CoilSetData, chunk: int, pole_pitch, y_center, y_scale) -> _Chunks:
    n = data.n
    n_chunks = max(1, -(-n // chunk))
    pad = n_chunks * chunk - n
    x0, s = (np.asarray(a) for a in _position_data(data.y, data.currents, pole_pitch, y_center, y_scale))

    def padded(a):  # (k, N) -> (C, k, c)
        a = np.concatenate([np.atleast_2d(a), np.zeros((np.atleast_2d(a).shape[0], pad))], axis=1)
        return jnp.asarray(a.reshape(-1, n_chunks, chunk).transpose(1, 0, 2))

    return _Chunks(padded(x0), padded(s)[:, 0], padded(data.currents.T), padded(data.force.T), padded(np.ones(n))[:, 0])


def _gram_factor(g):
    """``G = Rᵀ R`` with ``R = Λ^{1/2} Vᵀ`` from ``eigh`` (eigenvalues floored); returns ``(R, R^{-1})``."""
    lam, vec = jnp.linalg.eigh(g)
    floor = _FLOOR_PER_COLUMN * g.shape[-1] * jnp.maximum(lam[..., -1:], 1e-300)
    sq = jnp.sqrt(jnp.maximum(lam, floor))
    return sq[..., :, None] * jnp.swapaxes(vec, -1, -2), vec / sq[..., None, :]


def _solve_small(r_tot, d, k: _Consts, p: int):
    """The three small least-squares problems of one start (see :func:`_evaluate`)."""
    m = p + 3
    d_m, d_f = d[:p], d[p:]
    sq2n = jnp.sqrt(k.two_n)

    def solve_q(q):
        w = sq2n * k.reg_w[q]
        a_small = jnp.concatenate([r_tot[:, :p], jnp.diag(w / d_m), jnp.diag(k.damp_w / d_m)], axis=0)
        b_small = jnp.concatenate([r_tot[:, p + q] * d_f[q], w * k.theta_bar[:, q], jnp.zeros(p)])
        u, sv, vt = jnp.linalg.svd(a_small, full_matrices=False)
        sinv = jnp.where(sv > _SV_CUTOFF * sv[0], 1.0 / jnp.where(sv > 0, sv, 1.0), 0.0)
        th_s = vt.T @ (sinv * (u.T @ b_small))
        return th_s / d_m, b_small - a_small @ th_s, sinv, vt

    theta_l, res, sinv, vt = jax.vmap(solve_q, out_axes=(1, 0, 0, 0))(jnp.arange(3))
    phys = jnp.arange(p) < 4
    reg2 = res[:, m:m + p] ** 2
    return (theta_l, jnp.sum(res[:, :m] ** 2), jnp.sum(jnp.where(phys, reg2, 0.0)),
            jnp.sum(jnp.where(phys, 0.0, reg2)), jnp.sum(res[:, m + p:] ** 2), sinv, vt)


def _evaluate(layout: _Layout, flats, chunks: _Chunks, k: _Consts, want_jac: bool = True) -> _Eval:
    """Proposition 1 at ``S`` values of ``θ_NL`` (``flats`` ``(S, n)``) and the projected normal equations.

    Per direction ``q`` the least-squares problem of eq. Identification_CostFunctionRewritten
    (times ``2N``) is::

        min_θ || [ M          ] θ  -  [ F_q              ] ||²
              || [ √(2N) W_q  ]       [ √(2N) W_q θ̄_q    ] ||
              || [ α B        ]       [ 0                ] ||

    with ``W_q`` diagonal (``Λ_q`` on the physics entries, ``√ridge`` on network output
    weights, 0 elsewhere) and the numerical damping ``α B`` (``B`` diagonal, data-only bounds
    of the column norms of ``M``); for ``α = 0`` its solution is eq. Optimal_Initialization.
    With ``[M, F] D^{-1} = Q R`` (module docstring) it becomes the small problem
    ``[R_M; √(2N) W_q D_M^{-1}; α B D_M^{-1}] θ_s ≈ [R_F,q d_q; √(2N) W_q θ̄_q; 0]`` in
    ``θ_s = D_M θ``, solved by the SVD ``Ũ Σ Ṽᵀ``.

    Jacobian of the projected residual (exact, Golub–Pereyra): with
    ``G = Σ_t M_tᵀM_t + 2N W_q²``, ``r = F - M θ_L``, ``a_t,q = (∂M_t/∂θ_NL)ᵀ θ_L,q``,
    ``P_q = Σ_t M_tᵀ a_t,qᵀ`` and ``E_q = Σ_t r_t,q ∂M_t/∂θ_NL``::

        dθ_L,q/dθ_NL = G^{-1}(E_q - P_q)
        J_t,q = -(a_t,q + M_t dθ_L,q/dθ_NL),   J_reg,q = -√(2N) W_q dθ_L,q/dθ_NL
        JᵀJ = Σ_q [ Σ_t a_t,q a_t,qᵀ - P_qᵀ G^{-1} P_q + E_qᵀ G^{-1} E_q ]
        Jᵀr̃ = -Σ_q E_qᵀ θ_L,q

    (``G`` includes the damping rows; ``Jᵀr̃`` has no ``dθ_L`` term because the normal
    equations hold at the solution); ``G^{-1}`` is applied as ``Ṽ Σ^{-2} Ṽᵀ`` from the same SVD.
    """
    n_s = flats.shape[0]
    hidden = _unflatten(layout, flats)
    p, m, n = layout.p, layout.p + 3, layout.n_nl
    structured = want_jac and layout.structured
    xs = (chunks.x0, chunks.s, chunks.currents, chunks.force, chunks.mask)

    def rows(ch, with_u):
        x0, s, cur, frc, msk = ch
        out = _rows(layout, hidden, x0, s, cur, with_u)
        mm, u = out if with_u else (out, None)
        a = jnp.concatenate([mm, jnp.broadcast_to(frc, (n_s,) + frc.shape)], axis=1) * msk
        return a, (None if u is None else u * msk)

    # Pass 1: Gram of A = [M, F]; structured, also the sums the Jacobian needs:
    # [u; u s] Aᵀ and u [u; u s; u s²]ᵀ (see _structured_sums). The start axis stays explicit
    # and the samples minor so that XLA emits batched "X Yᵀ" matrix products per chunk
    # (jax.vmap over starts of a per-start scan ran 2.4x slower: it transposed every chunk).
    n_u = int(layout.param_units()[0].max()) + 1 if structured else 0

    def pass1(g, ch):
        a, u = rows(ch, structured)
        g_aa = g[0] + jnp.einsum("skc,slc->skl", a, a)
        if not structured:
            return (g_aa,), None
        s = ch[1][None, None, :]
        us = u * s
        g_ua = g[1] + jnp.einsum("skc,slc->skl", jnp.concatenate([u, us], axis=1), a)
        g_uu = g[2] + jnp.einsum("skc,slc->skl", u, jnp.concatenate([u, us, us * s], axis=1))
        return (g_aa, g_ua, g_uu), None

    init = (jnp.zeros((n_s, m, m)),)
    if structured:
        init += (jnp.zeros((n_s, 2 * n_u, m)), jnp.zeros((n_s, n_u, 3 * n_u)))
    g1, _ = lax.scan(pass1, init, xs)
    ga = g1[0]
    d = jnp.sqrt(jnp.diagonal(ga, axis1=1, axis2=2))
    d = jnp.where(d > 0, d, 1.0)
    r_tot, r_inv = _gram_factor(ga / (d[:, :, None] * d[:, None, :]))

    # Pass 2: re-orthogonalise Q = [M, F] D^{-1} R^{-1} (CholeskyQR2 with eigenvalue floor).
    def gram_of_q(t_inv):
        # Qᵀ = (D^{-1} R^{-1})ᵀ Aᵀ as one plain batched matrix product (scaling folded in).
        tt = jnp.swapaxes(t_inv / d[:, :, None], 1, 2)

        def body(g, ch):
            a, _ = rows(ch, False)
            q = tt @ a
            return g + jnp.einsum("skc,slc->skl", q, q), None

        return lax.scan(body, jnp.zeros((n_s, m, m)), xs)[0]

    for _ in range(_REORTHOGONALISATIONS):
        rk, rk_inv = _gram_factor(gram_of_q(r_inv))
        r_tot, r_inv = rk @ r_tot, r_inv @ rk_inv

    theta_l, data2, phys2, ridge2, damp2, sinv, vt = jax.vmap(partial(_solve_small, k=k, p=p))(r_tot, d)
    f = 0.5 * (data2 + phys2 + ridge2 + damp2)
    if not want_jac:
        return _Eval(f, data2, phys2, ridge2, damp2, theta_l, jnp.zeros((n_s, n, n)), jnp.zeros((n_s, n)))

    if structured:
        s_aa, p_q, e_q = jax.vmap(partial(_structured_sums, layout))(g1[1], g1[2], theta_l)
    else:
        s_aa, p_q, e_q = _generic_sums(layout, flats, xs, theta_l)

    def assemble(s_aa, p_q, e_q, sinv, vt, theta_l, d):
        d_m = d[:p, None]
        x = sinv[:, :, None] * (vt @ (p_q / d_m))  # (3, p, n)
        z = sinv[:, :, None] * (vt @ (e_q / d_m))
        jtj = jnp.sum(s_aa - jnp.swapaxes(x, 1, 2) @ x + jnp.swapaxes(z, 1, 2) @ z, axis=0)
        jtr = -jnp.einsum("qpn,pq->n", e_q, theta_l)
        return 0.5 * (jtj + jtj.T), jtr

    jtj, jtr = jax.vmap(assemble)(s_aa, p_q, e_q, sinv, vt, theta_l, d)
    return _Eval(f, data2, phys2, ridge2, damp2, theta_l, jtj, jtr)


def _structured_sums(layout: _Layout, g_ua, g_uu, theta_l):
    """``Σ_t a aᵀ``, ``P_q``, ``E_q`` (per q) of one start from the pass-1 sums (single hidden layer).

    Parameter ``i`` feeds unit ``k(i)`` and enters as ``s^{a(i)}`` (``a = 1`` weight, 0 bias), so
    ``V_t[i] = ∂M_t[col(i)]/∂θ_NL[i] = u_t,k(i) s_t^{a(i)}`` is the only non-zero of column ``i`` of
    ``∂M_t/∂θ_NL``. With ``w_q[i] = θ_L[col(i), q]``: ``a_t,q[i] = w_q[i] V_t[i]``, hence
    ``Σ a aᵀ = w wᵀ ⊙ VᵀV``, ``P_q = MᵀV diag(w_q)`` and ``E_q[col(i), i] = Σ_t r_t,q V_t[i] =
    (VᵀF - VᵀM θ_L)[i, q]``; ``VᵀV`` and ``Vᵀ[M, F]`` are gathered from
    ``g_uu = Σ u [u; u s; u s²]ᵀ`` and ``g_ua = Σ [u; u s] [M, F]ᵀ``.
    """
    p = layout.p
    unit, power, col = layout.param_units()
    n_u = int(unit.max()) + 1
    s_vv = g_uu[unit[:, None], (power[:, None] + power[None, :]) * n_u + unit[None, :]]
    s_va = g_ua[power * n_u + unit]  # (n, m)
    s_vm, s_vf = s_va[:, :p], s_va[:, p:]
    wq = theta_l[col, :].T  # (3, n)
    s_aa = wq[:, :, None] * s_vv[None] * wq[:, None, :]
    p_q = s_vm.T[None] * wq[:, None, :]
    rho = s_vf.T - (s_vm @ theta_l).T
    onehot = jnp.asarray(np.arange(p)[:, None] == col[None, :], dtype=float)
    return s_aa, p_q, onehot[None] * rho[:, None, :]


def _generic_sums(layout: _Layout, flats, xs, theta_l):
    """Chunked ``Σ_t a a^T``, ``P_q``, ``E_q`` with ``∂M/∂θ_NL`` from ``jax.jacfwd`` (any depth)."""
    p, n = layout.p, layout.n_nl

    def feats(fl, x0, s, cur):
        return _rows(layout, _unflatten(layout, fl[None]), x0, s, cur)[0].T  # (c, p)

    def per_start(fl, th, ch):
        x0, s, cur, frc, msk = ch
        mm = feats(fl, x0, s, cur) * msk[:, None]
        dm = jax.jacfwd(feats)(fl, x0, s, cur) * msk[:, None, None]  # (c, p, n)
        r = (frc.T - mm @ th) * msk[:, None]
        a = jnp.einsum("cpn,pq->qcn", dm, th)
        return (jnp.einsum("qcn,qcm->qnm", a, a), jnp.einsum("cp,qcn->qpn", mm, a),
                jnp.einsum("cq,cpn->qpn", r, dm))

    def body(acc, ch):
        out = jax.vmap(per_start, in_axes=(0, 0, None))(flats, theta_l, ch)
        return jax.tree_util.tree_map(jnp.add, acc, out), None

    n_s = flats.shape[0]
    init = (jnp.zeros((n_s, 3, n, n)), jnp.zeros((n_s, 3, p, n)), jnp.zeros((n_s, 3, p, n)))
    return lax.scan(body, init, xs)[0]


_evaluate_jit = jax.jit(_evaluate, static_argnums=(0, 4))


# --------------------------------------------------------------------------------------------
# public: physics fit, cost, Proposition 1, projected residual
# --------------------------------------------------------------------------------------------


def fit_physics(data: CoilSetData, pole_pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """Physics-only least squares: ``min Σ_t ||F - (A cos + B sin) i||²`` (no networks, no cogging, no Λ).

    Solved per direction ``q`` by ``numpy.linalg.lstsq`` on the columns
    ``[cos·ia, cos·ib, sin·ia, sin·ib]``.

    Returns:
        ``(A, B)``, each ``(3, 2)`` (N/A); ``θ_phy* = theta_phy(A, B)``.
    """
    c, s = (np.asarray(x) for x in harmonic_basis(data.y, pole_pitch))
    ia, ib = data.currents[:, 0], data.currents[:, 1]
    x = np.column_stack([c * ia, c * ib, s * ia, s * ib])
    coef, *_ = np.linalg.lstsq(x, data.force, rcond=None)  # (4, 3)
    return coef[:2].T.copy(), coef[2:].T.copy()


@dataclass(frozen=True)
class CostTerms:
    """Parts of eq. Identification_CostFunction.

    Attributes:
        data: ``1/(2N) Σ_t ||F(t) - F̂(t)||²`` with ``2N`` the number of samples, i.e. the mean
            over samples of the squared error summed over ``[Fy, Fx, Tz]`` (N², N² and N²m² mixed
            as in the paper).
        regularisation: ``||Λ (θ_phy - θ_phy*)||²`` (0 if no ``θ_phy*`` was given).
        total: ``data + regularisation`` (the paper's ``V``).
    """

    data: float
    regularisation: float

    @property
    def total(self) -> float:
        return self.data + self.regularisation


def cost(model: CoilSetModel, data: CoilSetData, Lambda=DEFAULT_LAMBDA, theta_phy_star=None) -> CostTerms:
    """Evaluate eq. Identification_CostFunction of ``model`` on ``data`` directly (no LIP rewrite).

    Args:
        model: :class:`CoilSetModel`; data: the samples (``2N = data.n``);
        Lambda: ``Λ`` (see :func:`lambda_diagonal`); theta_phy_star: ``(12,)`` or ``None``
            (then the regularisation term is 0).
    """
    if data.n == 0:
        return CostTerms(float("nan"), 0.0)
    f_hat = np.asarray(_force_jit(model, data.y, data.currents))
    dat = float(np.sum((data.force - f_hat) ** 2) / data.n)
    reg = 0.0
    if theta_phy_star is not None:
        reg = float(np.sum((lambda_diagonal(Lambda) * (theta_phy(model.A, model.B) - np.asarray(theta_phy_star))) ** 2))
    return CostTerms(dat, reg)


_force_jit = jax.jit(lambda model, y, currents: model.force(y, currents))


def _consts(layout: _Layout, data: CoilSetData, Lambda, theta_phy_star, ridge_output, damping) -> _Consts:
    lam = lambda_diagonal(Lambda)
    if ridge_output < 0:
        raise ValueError(f"ridge_output must be >= 0, got {ridge_output}")
    p = layout.p
    reg_w = np.zeros((3, p))
    theta_bar = np.zeros((p, 3))
    star = np.asarray(theta_phy_star, float)
    for q in range(3):
        cols = _physics_columns(q)
        reg_w[q, :4] = lam[cols]
        theta_bar[:4, q] = star[cols]
        reg_w[q, layout.output_weight_mask()] = np.sqrt(ridge_output)
    if damping < 0:
        raise ValueError(f"damping must be >= 0, got {damping}")
    # Column-norm bounds that do not depend on θ_NL (|h| <= 1 for tanh/sigmoid), so the
    # damping rows are constants of the variable projection.
    # ||cos·i||, ||sin·i|| <= ||i||
    ia, ib = data.currents[:, 0], data.currents[:, 1]
    norms = {0: np.linalg.norm(ia), 1: np.linalg.norm(ib), 2: np.sqrt(data.n)}
    bound = [norms[0], norms[1], norms[0], norms[1]]
    for kind, widths in layout.blocks:
        bound += [norms[kind]] * (widths[-1] + 1)
    damp_w = damping * np.maximum(np.asarray(bound), 1e-300)
    return _Consts(jnp.asarray(float(data.n)), jnp.asarray(reg_w), jnp.asarray(theta_bar), jnp.asarray(damp_w))


def _star_or_fit(data, pole_pitch, theta_phy_star):
    if theta_phy_star is None:
        return theta_phy(*fit_physics(data, pole_pitch))
    if isinstance(theta_phy_star, tuple) and len(theta_phy_star) == 2:
        return theta_phy(*theta_phy_star)
    star = np.asarray(theta_phy_star, float)
    if star.shape != (12,):
        raise ValueError(f"theta_phy_star must be (12,) or (A, B); got shape {star.shape}")
    return star


@dataclass(frozen=True)
class Proposition1Result:
    """Result of :func:`proposition1`.

    Attributes:
        theta_L: ``(p, 3)``, column ``q`` is ``θ_L,q`` (eq. Optimal_Initialization).
        model: the input model with these linear parameters.
        cost: ``V`` (data + Λ term, eq. Identification_CostFunction) at that point.
        cost_data, cost_regularisation: its two parts.
        ridge_term: ``ridge·||W_out||²``; damping_term: ``α² Σ (b_k θ_k)² / (2N)`` (neither in ``V``).
    """

    theta_L: np.ndarray
    model: CoilSetModel
    cost: float
    cost_data: float
    cost_regularisation: float
    ridge_term: float
    damping_term: float


def _prepare(theta_nl, data, Lambda, theta_phy_star, ridge_output, damping, chunk_size, method):
    layout = _Layout.of(theta_nl, method)
    if chunk_size is None:
        chunk_size = DEFAULT_CHUNK if layout.structured else DEFAULT_CHUNK_GENERIC
    star = _star_or_fit(data, theta_nl.pole_pitch, theta_phy_star)
    k = _consts(layout, data, Lambda, star, ridge_output, damping)
    chunks = _to_chunks(data, int(chunk_size), theta_nl.pole_pitch, theta_nl.y_center, theta_nl.y_scale)
    return layout, chunks, k


def proposition1(theta_nl: CoilSetModel, data: CoilSetData, Lambda=DEFAULT_LAMBDA, theta_phy_star=None,
                 ridge_output: float = 0.0, damping: float = DEFAULT_DAMPING, chunk_size: int | None = None
                 ) -> Proposition1Result:
    """Optimal linear parameters ``θ_L`` for the hidden weights of ``theta_nl`` (Proposition 1).

    For each direction ``q`` (eq. Optimal_Initialization, multiplied by ``2N``)::

        θ_L,q = argmin || M θ - F_q ||² + 2N || Λ_q ([I 0] θ - θ_phy,q*) ||² + 2N·ridge·||W_out,q||²
              = (Σ_t M_tᵀ M_t + 2N diag(Λ_q², 0) + 2N·ridge·I_W)^{-1}
                (Σ_t F_q(t) M_tᵀ + 2N diag(Λ_q², 0) [θ_phy,q*; 0])

    solved through the orthogonal factorisation described in the module docstring (SVD of
    the reduced problem), never by forming and inverting the normal matrix.

    Two optional terms, both reported separately and not part of ``V``:

    * ``ridge_output`` (default 0, the paper's cost): an explicit ridge ``ridge·||W_out||²`` on
      the network output WEIGHTS (not biases) for badly conditioned cases;
    * ``damping = α`` (default ``1e-6``): numerical Tikhonov damping ``α² Σ_k (b_k θ_k)²`` with
      ``b_k`` a data-only bound of the norm of regressor column ``k`` (``||ia||``, ``||ib||`` or
      ``√(2N)``). It only acts on directions whose singular value is below ``α`` relative to the
      column norms — combinations of hidden units that the data cannot tell apart (condition
      numbers reach ``1e16`` with 16 units) — where the undamped solution is noise with output
      weights of ``1e7``–``1e8`` and the variable-projection derivative is numerically
      meaningless. ``damping = 0`` gives the plain minimum-norm least-squares solution.

    Args:
        theta_nl: :class:`CoilSetModel` providing ``θ_NL`` (hidden layers), ``d_m`` and scaling.
        data: training samples (``2N = data.n``).
        Lambda: ``Λ`` (scalar, ``(12,)`` or diagonal ``(12, 12)``).
        theta_phy_star: ``(12,)``, ``(A, B)`` or ``None`` (then the physics-only fit).
        ridge_output, damping: see above.
        chunk_size: samples per accumulated chunk (results do not depend on it).

    Returns:
        :class:`Proposition1Result`.
    """
    layout, chunks, k = _prepare(theta_nl, data, Lambda, theta_phy_star, ridge_output, damping, chunk_size, "auto")
    ev = jax.tree_util.tree_map(lambda a: a[0], _evaluate_jit(layout, hidden_vector(theta_nl)[None], chunks, k, False))
    theta_L = np.asarray(ev.theta_L)
    two_n = float(data.n)
    return Proposition1Result(theta_L, with_theta_L(theta_nl, theta_L), float(ev.data2 + ev.phys2) / two_n,
                              float(ev.data2) / two_n, float(ev.phys2) / two_n, float(ev.ridge2) / two_n,
                              float(ev.damp2) / two_n)


def projected_normal_equations(theta_nl: CoilSetModel, data: CoilSetData, Lambda=DEFAULT_LAMBDA, theta_phy_star=None,
                               ridge_output: float = 0.0, damping: float = DEFAULT_DAMPING,
                               chunk_size: int | None = None, method: str = "auto"):
    """``(f, JᵀJ, Jᵀr̃, θ_L)`` of the projected residual at ``θ_NL`` (see :func:`projected_residual`).

    ``f = ½||r̃||²``; ``JᵀJ`` ``(n, n)`` and ``Jᵀr̃`` ``(n,)`` with ``n = len(hidden_vector(theta_nl))``;
    ``method``: ``"structured"`` (single hidden layer), ``"generic"`` (``jax.jacfwd``) or ``"auto"``.
    """
    layout, chunks, k = _prepare(theta_nl, data, Lambda, theta_phy_star, ridge_output, damping, chunk_size, method)
    ev = jax.tree_util.tree_map(lambda a: a[0], _evaluate_jit(layout, hidden_vector(theta_nl)[None], chunks, k, True))
    return float(ev.f), np.asarray(ev.jtj), np.asarray(ev.jtr), np.asarray(ev.theta_L)


def projected_residual(theta_nl: CoilSetModel, data: CoilSetData, Lambda=DEFAULT_LAMBDA, theta_phy_star=None,
                       ridge_output: float = 0.0, damping: float = DEFAULT_DAMPING):
    """The projected residual ``r̃(θ_NL)`` as one vector (for checks; memory ``O(N)``).

    ``r̃ = [vec(F - M θ_L); √(2N) vec(W ⊙ (θ_L - θ̄)); α vec(B θ_L)]`` with ``θ_L = Prop1(θ_NL)``,
    ``W`` the regularisation weights (``Λ_q`` on the physics entries, ``√ridge`` on output
    weights), ``θ̄`` their targets and ``α B`` the damping (see :func:`proposition1`);
    ``||r̃||² = 2N·V`` plus the ridge and damping terms. It is the reference the analytic
    Jacobian is checked against by finite differences.
    """
    layout, chunks, k = _prepare(theta_nl, data, Lambda, theta_phy_star, ridge_output, damping, None, "auto")
    return np.asarray(_projected_residual(layout, hidden_vector(theta_nl), chunks, k))


@partial(jax.jit, static_argnums=0)
def _projected_residual(layout: _Layout, flat, chunks: _Chunks, k: _Consts):
    theta_l = _evaluate(layout, flat[None], chunks, k, False).theta_L[0]
    hidden = _unflatten(layout, flat[None])

    def data_rows(x0, s, cur, frc, msk):  # padded samples give zero rows
        return ((frc - theta_l.T @ _rows(layout, hidden, x0, s, cur)[0]) * msk).ravel()

    r_data = jax.vmap(data_rows)(chunks.x0, chunks.s, chunks.currents, chunks.force, chunks.mask)
    r_reg = jnp.sqrt(k.two_n) * k.reg_w.T * (theta_l - k.theta_bar)
    return jnp.concatenate([r_data.ravel(), r_reg.ravel(), (k.damp_w[:, None] * theta_l).ravel()])


# --------------------------------------------------------------------------------------------
# Levenberg–Marquardt with variable projection
# --------------------------------------------------------------------------------------------


@pytree_dataclass
class _LMState:
    flat: jnp.ndarray
    ev: _Eval
    lam: jnp.ndarray
    nu: jnp.ndarray
    done: jnp.ndarray
    reason: jnp.ndarray
    n_iter: jnp.ndarray


def _lm_init(layout: _Layout, flats, lam0):
    """State before the first step: ``f = inf`` and a zero step, so the first :func:`_lm_step`
    evaluates the starting points (one compiled function serves both)."""
    n_s, n = flats.shape
    # Explicit dtypes (not weakly typed) so that this state and the stepped ones share one compilation.
    ev = _Eval(jnp.full(n_s, np.inf, float), *(jnp.zeros(n_s) for _ in range(4)), jnp.zeros((n_s, layout.p, 3)),
               jnp.broadcast_to(jnp.eye(n), (n_s, n, n)), jnp.zeros((n_s, n)))
    return _LMState(flats, ev, jnp.full(n_s, lam0, float), jnp.full(n_s, 2.0, float), jnp.zeros(n_s, bool),
                    jnp.zeros(n_s, jnp.int32), jnp.full(n_s, -1, jnp.int32))


#: Largest damping before a start is declared converged (steps are then ~1e-10 of Gauss–Newton's).
_LAMBDA_MAX = 1e10


def _lm_delta(ev_jtj, ev_jtr, lam):
    """Solve ``(JᵀJ + λ D) δ = -Jᵀr̃`` with ``D = diag(max(diag(JᵀJ), 1e-12·max diag JᵀJ))``."""
    diag = jnp.diagonal(ev_jtj)
    dd = jnp.maximum(diag, 1e-12 * jnp.max(diag) + 1e-300)
    delta = jnp.linalg.solve(ev_jtj + lam * jnp.diag(dd), -ev_jtr)
    return jnp.where(jnp.all(jnp.isfinite(delta)), delta, 0.0)


def _lm_accept(st: _LMState, delta, new: _Eval, tol, max_iter):
    """Accept or reject one start's step; update ``λ`` by Nielsen's rule; test for convergence.

    ``ρ = (f - f_new) / (-δᵀJᵀr̃ - ½ δᵀJᵀJ δ)``; accepted (``f_new < f``): ``λ <- λ·max(1/3,
    1 - (2ρ - 1)³)``, else ``λ <- λ·ν``, ``ν <- 2ν``. Stops on an accepted relative decrease
    below ``tol``, ``||δ|| <= tol (||θ_NL|| + tol)``, ``λ > 1e10`` or ``max_iter``.
    """
    ev = st.ev
    first = ~jnp.isfinite(ev.f)  # the evaluation of the starting point (see _lm_init)
    pred = -(delta @ ev.jtr + 0.5 * delta @ ev.jtj @ delta)
    actual = ev.f - new.f
    accept = jnp.isfinite(new.f) & (first | (new.f < ev.f)) & ~st.done
    rho = actual / jnp.where(pred > 0, pred, jnp.inf)
    lam = jnp.where(accept, st.lam * jnp.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3), st.lam * st.nu)
    lam = jnp.where(first, st.lam, lam)
    nu = jnp.where(accept | first, 2.0, 2.0 * st.nu)
    n_iter = st.n_iter + jnp.where(st.done, 0, 1)
    small_f = accept & (actual <= tol * jnp.abs(new.f))
    small_x = jnp.linalg.norm(delta) <= tol * (jnp.linalg.norm(st.flat) + tol)
    reason = jnp.select([first & ~jnp.isfinite(new.f), first, small_f, small_x, lam > _LAMBDA_MAX, n_iter >= max_iter],
                        [5, 0, 1, 2, 3, 4], 0)
    reason = jnp.where(st.done, st.reason, reason)
    keep = lambda a, b: jnp.where(accept, a, b)  # noqa: E731
    return _LMState(keep(st.flat + delta, st.flat), jax.tree_util.tree_map(keep, new, ev),
                    jnp.where(st.done, st.lam, lam), jnp.where(st.done, st.nu, nu), st.done | (reason > 0), reason,
                    n_iter)


def _lm_step(layout, st: _LMState, chunks, k, tol, max_iter):
    """One Levenberg–Marquardt iteration of all starts (see :func:`_lm_delta`, :func:`_lm_accept`)."""
    delta = jax.vmap(_lm_delta)(st.ev.jtj, st.ev.jtr, st.lam)
    new = _evaluate(layout, st.flat + delta, chunks, k, True)
    return jax.vmap(_lm_accept, in_axes=(0, 0, 0, None, None))(st, delta, new, tol, max_iter)


_lm_step = jax.jit(_lm_step, static_argnums=(0,))


@dataclass(frozen=True)
class IdentifyResult:
    """Identification of one coil set (Algorithm 2).

    Costs follow eq. Identification_CostFunction with ``2N`` the number of samples of the set
    they are evaluated on:

    * ``cost_physics``: physics-only model on the training data (data term; its Λ term is 0
      because ``θ_phy = θ_phy*``);
    * ``cost_pgnn``: the paper's ``V`` of the PGNN on the training data (data + Λ term; the
      optional ``ridge`` and numerical ``damping`` terms, minimised with it, are NOT included,
      see ``ridge_term`` and ``damping_term``);
    * ``cost_pgnn_data``: data term only of ``cost_pgnn``;
    * ``cost_physics_validation``, ``cost_pgnn_validation``: DATA TERM ONLY on the validation
      data (a prediction error; comparable between models);
    * ``cost_pgnn_validation_full``: validation data term + the same Λ term (the full ``V``).

    Validation costs are NaN when ``n_validation == 0``.

    ``iterations``: LM iterations of the kept start over both phases; ``start_costs``: the
    objective of every start at the end of phase 1 (on its subsample; the single phase if
    there is only one); ``history``: per phase, the best objective (``V`` plus the ridge and
    damping terms) after each iteration, index 0 being the starting points.
    """

    name: str
    model: CoilSetModel
    physics_model: CoilSetModel
    cost_physics: float
    cost_pgnn: float
    cost_pgnn_data: float
    cost_physics_validation: float
    cost_pgnn_validation: float
    cost_pgnn_validation_full: float
    iterations: int
    seconds: float
    ridge: float
    ridge_term: float
    damping: float
    damping_term: float
    n_train: int
    n_validation: int
    seed: int
    n_starts: int
    start_costs: tuple = ()
    stop_reason: str = ""
    history: tuple = field(default=(), repr=False)

    def to_dict(self) -> dict:
        """JSON-ready summary (keys of ``results.json`` ``identification.coil_sets[l]``)."""
        keys = ("name", "cost_physics", "cost_pgnn", "cost_pgnn_data", "cost_physics_validation",
                "cost_pgnn_validation", "cost_pgnn_validation_full", "iterations", "seconds", "ridge",
                "ridge_term", "damping", "damping_term", "n_train", "n_validation", "seed", "n_starts", "stop_reason")
        out = {key: getattr(self, key) for key in keys}
        out["start_costs"] = list(self.start_costs)
        return {key: (None if isinstance(v, float) and not np.isfinite(v) else v) for key, v in out.items()}


def _progress_printer(name):
    def show(info):
        print(f"pgcomm: {name}: phase {info['phase']} iteration {info['iteration']:3d}  "
              f"best V = {info['best_cost']:.6g}  "
              f"lambda = {info['lambda']:.2e}  active starts {info['active']}/{info['starts']}",
              file=sys.stderr, flush=True)
    return show


def _run_lm(layout, flats, chunks, k, n, *, max_iter, tol, lambda0, show, phase):
    """Levenberg–Marquardt on all rows of ``flats`` at once until each start stops.

    Returns the final state and the best objective ``V`` (plus ridge and damping terms) after
    every iteration (index 0: the starting points).
    """
    st = _lm_step(layout, _lm_init(layout, flats, lambda0), chunks, k, tol, max_iter)
    # V = ||r̃||² / (2N) = 2 f / n
    history = [2.0 * float(jnp.nanmin(st.ev.f)) / n]
    it = 0
    while layout.n_nl > 0 and not bool(jnp.all(st.done)) and it < max_iter:
        st = _lm_step(layout, st, chunks, k, tol, max_iter)
        it += 1
        fs = np.asarray(st.ev.f)
        best = int(np.argmin(np.where(np.isfinite(fs), fs, np.inf)))
        history.append(2.0 * float(fs[best]) / n)
        if show is not None:
            show({"phase": phase, "iteration": it, "best_cost": history[-1], "lambda": float(st.lam[best]),
                  "active": int(np.sum(~np.asarray(st.done))), "starts": int(fs.size)})
    return st, tuple(history)


def identify(data: CoilSetData, pole_pitch: float, *, gain_widths=DEFAULT_GAIN_WIDTHS, cog_widths=DEFAULT_COG_WIDTHS,
             activation: str = "tanh", Lambda=DEFAULT_LAMBDA, theta_phy_star=None, ridge_output: float = 0.0,
             n_starts: int = 8, seed: int = 0, max_iter: int = 100, tol: float = 1e-6,
             subsample: int = 8, refine_starts: int = 2,
             validation_fraction: float = 0.2, block_size: int = 500, chunk_size: int | None = None,
             damping: float = DEFAULT_DAMPING, lambda0: float = 1e-3, method: str = "auto",
             check_data: bool = True, progress=None) -> IdentifyResult:
    """Identify the PGNN of one coil set (Algorithm 2) by variable-projection Levenberg–Marquardt.

    Steps: split the data (:func:`train_validation_split`); check excitation
    (:func:`check_excitation`, raises :class:`~pgcomm.errors.ExcitationError`); fit the
    physics-only model (``θ_phy*`` unless given); draw ``n_starts`` random hidden layers from
    ``jax.random.PRNGKey(seed)``; iterate, for several starts at once (one batched
    evaluation)::

        θ_L = Prop1(θ_NL)                                   (eq. Optimal_Initialization)
        (JᵀJ + λ D) δ = -Jᵀr̃,   θ_NL <- θ_NL + δ  if V decreases   (see _lm_delta, _lm_accept)

    where ``r̃`` is the projected residual (data rows and ``√(2N) Λ`` rows) and ``J`` its exact
    Jacobian in ``θ_NL`` (see ``_evaluate``). Two phases, because consecutive samples at
    1 kHz carry nearly the same information:

    1. all ``n_starts`` starts on every ``subsample``-th training sample (at least 4096
       samples; skipped when the data are too few for that);
    2. the ``refine_starts`` best of them on all training samples.

    The start with the lowest training cost is kept. ``subsample=1`` runs all starts on all
    samples in one phase. The result is deterministic for a given ``seed``.

    Args:
        data: samples of both data sets ``Z_1, Z_2`` of this coil set.
        pole_pitch: ``d_m`` (m).
        gain_widths, cog_widths: hidden widths of the gain-column and cogging networks
            (``None`` leaves the network out); paper: ``(2,)`` and ``(16,)``.
        Lambda: ``Λ`` (default ``0.1 I``); theta_phy_star: ``θ_phy*`` or ``None`` (physics fit).
        ridge_output: explicit ridge on the networks' output weights (0 = the paper's cost).
        n_starts, seed: random starts; seed of ``jax.random.PRNGKey``.
        max_iter, tol: LM limits per phase (iterations; relative cost decrease of an accepted
            step and relative step size).
        subsample, refine_starts: the two phases above.
        validation_fraction, block_size: see :func:`split_indices`.
        chunk_size: samples per accumulated chunk (memory bound; results independent of it).
        damping: numerical damping of Proposition 1's least squares (see :func:`proposition1`).
        lambda0: initial LM damping (relative to ``diag JᵀJ``).
        method: Jacobian sums, ``"auto"``, ``"structured"`` or ``"generic"``.
        check_data: run :func:`check_excitation` first.
        progress: ``None`` (silent), ``True`` (one line per iteration to stderr) or a callable
            receiving a dict ``{phase, iteration, best_cost, lambda, active, starts}``.

    Returns:
        :class:`IdentifyResult`.
    """
    t0 = time.perf_counter()
    name = data.name
    if data.n < 10:
        raise DataError(f"{name}: too few samples ({data.n}) to identify a model")
    if gain_widths is None and cog_widths is None:
        raise ValueError("identify needs at least one network; use fit_physics for the physics-only model")
    if check_data:
        problems = check_excitation(data, pole_pitch)
        if problems:
            raise ExcitationError(f"{name}: data do not persistently excite the model: " + "; ".join(problems))
    train, val = train_validation_split(data, validation_fraction, block_size)
    y_lo, y_hi = float(data.y.min()), float(data.y.max())
    y_center = 0.5 * (float(train.y.min()) + float(train.y.max()))
    y_scale = max(0.5 * (float(train.y.max()) - float(train.y.min())), 1e-9)

    a_phy, b_phy = fit_physics(train, pole_pitch)
    physics = CoilSetModel.physics(a_phy, b_phy, pole_pitch, y_center, y_scale, y_lo, y_hi)
    star = _star_or_fit(train, pole_pitch, theta_phy_star)
    lam12 = lambda_diagonal(Lambda)

    keys = jax.random.split(jax.random.PRNGKey(seed), n_starts)
    models0 = [CoilSetModel.init(kk, a_phy, b_phy, pole_pitch, y_center, y_scale, gain_widths, cog_widths, activation,
                                 y_lo, y_hi) for kk in keys]
    template = models0[0]
    flats = jnp.stack([hidden_vector(mm) for mm in models0])
    show = _progress_printer(name) if progress is True else (progress or None)
    opts = dict(max_iter=max_iter, tol=tol, lambda0=lambda0, show=show)
    history = []

    stride = max(1, min(int(subsample), train.n // _MIN_SUBSAMPLE))
    iters0 = np.zeros(n_starts, int)
    start_costs = None
    if stride > 1:
        sub = train.take(slice(None, None, stride))
        layout, chunks, k = _prepare(template, sub, lam12, star, ridge_output, damping, chunk_size, method)
        st1, hist1 = _run_lm(layout, flats, chunks, k, sub.n, phase=1, **opts)
        history.append(hist1)
        fs1 = np.where(np.isfinite(np.asarray(st1.ev.f)), np.asarray(st1.ev.f), np.inf)
        start_costs = 2.0 * fs1 / sub.n
        keep = np.argsort(fs1, kind="stable")[:max(1, min(refine_starts, n_starts))]
        flats, iters0 = st1.flat[keep], np.asarray(st1.n_iter)[keep]
    layout, chunks, k = _prepare(template, train, lam12, star, ridge_output, damping, chunk_size, method)
    st, hist2 = _run_lm(layout, flats, chunks, k, train.n, phase=2 if stride > 1 else 1, **opts)
    history.append(hist2)

    fs = np.asarray(st.ev.f)
    best = int(np.argmin(np.where(np.isfinite(fs), fs, np.inf)))
    if start_costs is None:
        start_costs = 2.0 * fs / train.n
    model = with_theta_L(with_hidden_vector(template, st.flat[best]), st.ev.theta_L[best])
    c_pgnn = cost(model, train, lam12, star)
    c_phys = cost(physics, train)
    nan = float("nan")
    c_pgnn_val = cost(model, val, lam12, star) if val.n else CostTerms(nan, nan)
    c_phys_val = cost(physics, val) if val.n else CostTerms(nan, 0.0)
    return IdentifyResult(
        name=name, model=model, physics_model=physics, cost_physics=c_phys.data, cost_pgnn=c_pgnn.total,
        cost_pgnn_data=c_pgnn.data, cost_physics_validation=c_phys_val.data, cost_pgnn_validation=c_pgnn_val.data,
        cost_pgnn_validation_full=c_pgnn_val.total, iterations=int(iters0[best] + np.asarray(st.n_iter)[best]),
        seconds=time.perf_counter() - t0, ridge=float(ridge_output), ridge_term=float(st.ev.ridge2[best]) / train.n,
        damping=float(damping), damping_term=float(st.ev.damp2[best]) / train.n,
        n_train=train.n, n_validation=val.n, seed=int(seed), n_starts=int(n_starts),
        start_costs=tuple(float(x) for x in start_costs),
        stop_reason=_STOP_REASONS[int(np.asarray(st.reason)[best])], history=tuple(history))


def identify_all(datasets, pole_pitch: float, *, seed: int = 0, progress=None, **kwargs):
    """Identify every coil set independently (Algorithm 2's loop) and combine them (eq. PGNN_Electromagnetics).

    Args:
        datasets: list of :class:`CoilSetData`, one per coil set (in coil-set order).
        pole_pitch: ``d_m`` (m). seed: coil set ``l`` (0-based) uses ``seed + l``.
        kwargs: passed to :func:`identify`.

    Returns:
        ``(CombinedModel, [IdentifyResult, ...])``.
    """
    results = []
    for l, data in enumerate(datasets):
        results.append(identify(data, pole_pitch, seed=seed + l, progress=progress, **kwargs))
    return CombinedModel.from_coil_sets([r.model for r in results]), results


# --------------------------------------------------------------------------------------------
# excitation and training range
# --------------------------------------------------------------------------------------------


def check_excitation(data: CoilSetData, pole_pitch: float, n_bins: int = 20, y_range=None, min_samples: int = 20,
                     min_angle: float = 0.1, min_spread: float = 0.1) -> list[str]:
    """Problems with persistent excitation (the paper's Remark), per position bin; empty = fine.

    The position range (``y_range`` or the data's own) is cut into ``n_bins`` equal bins. In
    each bin the model is ``F = K̂ i + F̂_cog`` with ``K̂`` rotating with the commutation angle,
    so the currents are judged in the rotating frame: ``p = Γ(y)^{-1} i = a [cos ψ, sin ψ]``
    (``Γ`` with ``k̂ = 1``, ``ζ̂ = 0``; for drive inputs ``ψ = Δ + ζ̂`` and ``a = Fy*/k̂``).
    Each bin must have:

    1. at least ``min_samples`` samples, else ``"no data (gap)"``; and some current, else
       ``"no current"``;
    2. more than one ratio ``ia : ib``: the directions ``ψ`` modulo π (a sign change of the
       force is not a new ratio) must spread over more than ``min_angle`` rad (5–95 % range
       around their circular mean; samples below 5 % of the median current are ignored),
       else ``"one ratio ia:ib (a single Δ)"``;
    3. currents that do not lie on one line, so that the two gain columns AND the cogging
       force are separable (different force magnitudes, or sign changes, per direction):
       ``sqrt(λ_min(cov p)) / rms|p| > min_spread``, else ``"a single force magnitude"``.

    Consecutive bins with the same problem are merged into one range.

    Args:
        data: one coil set's samples; pole_pitch: ``d_m`` (m).
        n_bins, y_range: position bins over ``y_range`` (m) or the data's range.
        min_samples, min_angle (rad), min_spread (-): the thresholds above.

    Returns:
        one-line messages such as ``"y ∈ [0.01, 0.03] m: one ratio ia:ib (a single Δ)"``.
    """
    amp, ang = currents_to_drive_inputs(data.y, data.currents[:, None, :], 1.0, 0.0, pole_pitch)
    amp, ang = np.asarray(amp)[:, 0], np.asarray(ang)[:, 0]
    psi = np.mod(ang, np.pi)
    p = np.stack([amp * np.cos(ang), amp * np.sin(ang)], axis=1)
    lo, hi = (float(data.y.min()), float(data.y.max())) if y_range is None else map(float, y_range)
    edges = np.linspace(lo, hi, n_bins + 1)
    which = np.clip(np.searchsorted(edges, data.y, side="right") - 1, 0, n_bins - 1)
    inside = (data.y >= lo) & (data.y <= hi)
    big = amp > 0.05 * max(float(np.median(amp)), 1e-300)
    issues = []
    for b in range(n_bins):
        sel = inside & (which == b)
        if sel.sum() < min_samples:
            issues.append("no data (gap)")
            continue
        sb = sel & big
        if sb.sum() < 2:
            issues.append("no current")
            continue
        z = np.exp(2j * psi[sb])
        dev = np.angle(z * np.conj(np.mean(z))) / 2.0
        if np.percentile(dev, 95) - np.percentile(dev, 5) < min_angle:
            issues.append("one ratio ia:ib (a single Δ)")
            continue
        pb = p[sel]
        lam_min = np.linalg.eigvalsh(np.cov(pb, rowvar=False))[0]
        rms = np.sqrt(np.mean(np.sum(pb ** 2, axis=1)))
        issues.append(None if np.sqrt(max(lam_min, 0.0)) > min_spread * rms else "a single force magnitude")
    out, b = [], 0
    while b < n_bins:
        e = b
        while e + 1 < n_bins and issues[e + 1] == issues[b]:
            e += 1
        if issues[b] is not None:
            out.append(f"y ∈ [{edges[b]:.4g}, {edges[e + 1]:.4g}] m: {issues[b]}")
        b = e + 1
    return out


def warn_outside_training_range(model, y) -> str | None:
    """A warning if positions ``y`` (m) leave the model's training range, else ``None``.

    Works for :class:`CoilSetModel` (``y_min, y_max``) and :class:`CombinedModel` (the range
    covered by every coil set). Models without a stored range give ``None``.
    """
    if isinstance(model, CombinedModel):
        rng = model.training_range
    else:
        rng = None if model.y_min is None or model.y_max is None else (model.y_min, model.y_max)
    if rng is None:
        return None
    y = np.asarray(y, dtype=float).ravel()
    out = (y < rng[0]) | (y > rng[1])
    if not out.any():
        return None
    return (f"{int(out.sum())} of {y.size} positions ({out.mean():.1%}) lie outside the training range "
            f"[{rng[0]:.4g}, {rng[1]:.4g}] m (data span [{y.min():.4g}, {y.max():.4g}] m); "
            "the model extrapolates there")
