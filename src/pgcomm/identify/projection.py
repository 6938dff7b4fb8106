"""Proposition 1 and the projected problem: the LIP regressor, the optimal ``θ_L`` for given
hidden weights, the cost, and the normal equations of the projected residual (jitted core).

See :mod:`pgcomm.identify` for the numerics (CholeskyQR2 with an eigenvalue floor, damping,
chunked sums, structured and generic Jacobian paths).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import partial

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax

from pgcomm._pytree import pytree_dataclass
from pgcomm.data import CoilSetData
from pgcomm.identify.layout import (
    DEFAULT_LAMBDA,
    _Layout,
    _physics_columns,
    _unflatten,
    hidden_vector,
    lambda_diagonal,
    theta_phy,
    with_theta_L,
)
from pgcomm.errors import DataError
from pgcomm.models import HARMONIC_ORDERS, CoilSetModel, activation_fn, harmonic_basis, smooth_sign

#: Samples per chunk of the accumulated sums (structured / generic Jacobian path). Small chunks
#: keep each chunk's features in cache: 512 ran 1.6x faster than 4096 with 8 starts.
DEFAULT_CHUNK = 512
DEFAULT_CHUNK_GENERIC = 128
#: Relative Tikhonov damping of Proposition 1's least squares (see :func:`proposition1`).
DEFAULT_DAMPING = 1e-6
#: Singular values below this fraction of the largest are dropped (guards exact rank loss only).
_SV_CUTOFF = 1e-14
#: Re-orthogonalisation passes after the first Gram factorisation (1 = CholeskyQR2). One pass
#: already reproduces numpy.linalg.lstsq (same column scaling) to ~1e-10 in cost
#: at condition numbers of 1e16; a second changed nothing measurable.
_REORTHOGONALISATIONS = 1
#: Eigenvalue floor of the Gram factorisations, relative to the largest eigenvalue, per column.
_FLOOR_PER_COLUMN = 10 * np.finfo(float).eps


# jitted (called on the host for every data set): one program instead of a dozen eager operations
@partial(jax.jit, static_argnames=("pole_pitch", "harmonics", "v_eps"))
def _position_data(y, currents, pole_pitch, y_center, y_scale, harmonics=False, velocity=None, v_eps=None):
    """Data-only (known) columns of the regressor ``x0`` ``(n_known, N)`` and the scaled position ``s`` ``(N,)``.

    ``x0 = [cos·ia, cos·ib, sin·ia, sin·ib]``, then with ``harmonics`` the same four for
    ``5θ`` and ``7θ`` (8 rows), then with a ``velocity`` (m/s) the direction column
    ``s(ẏ) = tanh(ẏ/v_ε)`` (see :mod:`pgcomm.identify.layout` for the order).
    """
    y = jnp.asarray(y, dtype=float)
    cur = jnp.asarray(currents, dtype=float)
    rows = []
    for order in ((1,) + HARMONIC_ORDERS if harmonics else (1,)):
        c, sn = harmonic_basis(y, pole_pitch, order)
        rows += [c * cur[:, 0], c * cur[:, 1], sn * cur[:, 0], sn * cur[:, 1]]
    if velocity is not None:
        rows.append(smooth_sign(velocity, v_eps))
    return jnp.stack(rows), (y - y_center) / y_scale


def _known_data(layout: _Layout, data_y, data_currents, velocity, pole_pitch, y_center, y_scale, name="data"):
    """:func:`_position_data` for ``layout`` (checks that a direction term has its velocity)."""
    if layout.direction and velocity is None:
        raise DataError(f"{name}: the direction term needs a velocity (CoilSetData.velocity, m/s); "
                        "build the data with velocity_from_positions")
    return _position_data(data_y, data_currents, pole_pitch, y_center, y_scale, layout.harmonics,
                          velocity if layout.direction else None, layout.direction_velocity)


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


def regressor(theta_nl: CoilSetModel, y, currents, velocity=None):
    """LIP regressor ``M(θ_NL, t)`` (eq. PGNN_Rewritten_LIP), the same for the three directions.

    ``F̂_q(t) = M(θ_NL, t) θ_L,q`` with ``θ_L = theta_L_of(model)``.

    Args:
        theta_nl: a :class:`CoilSetModel`; its hidden layers are ``θ_NL`` (its ``A, B`` and
            output layers are not used) and it gives ``d_m``, the input scaling and which
            extensions are on.
        y: ``(N,)`` (m); currents: ``(N, 2)`` (A); velocity: ``(N,)`` (m/s), needed with the direction term.

    Returns:
        ``(N, p)`` with columns ``[cos·ia, cos·ib, sin·ia, sin·ib, (8 harmonics), (s(ẏ)),
        h_1·ia, ia, h_2·ib, ib, h_φ, 1]`` (extensions and networks that are absent leave their
        columns out).
    """
    layout = _Layout.of(theta_nl)
    x0, s = _known_data(layout, y, currents, velocity, theta_nl.pole_pitch, theta_nl.y_center, theta_nl.y_scale)
    hidden = _unflatten(layout, hidden_vector(theta_nl)[None])
    return _rows(layout, hidden, x0, s, jnp.asarray(currents, dtype=float).T)[0].T


@pytree_dataclass
class _Chunks:
    """Training data padded to whole chunks of ``c`` samples (``C`` chunks); padded samples have ``mask = 0``.

    Feature-major like :func:`_rows`: ``x0`` ``(C, 4, c)`` and ``s`` ``(C, c)`` are the data-only
    parts of the regressor (:func:`_position_data`), computed once; currents ``(C, 2, c)``,
    force ``(C, 3, c)``, mask ``(C, c)``.

    Filtered (sensorless) data: every output sample is a window of ``W`` raw samples and its
    regressor row is ``Σ_w taps[w] M(raw_w)`` (:mod:`pgcomm.sensorless`); ``x0``, ``s`` and
    ``currents`` then hold the windows' raw samples, ``(C, ·, c W)`` with ``W`` minor, while
    ``force`` and ``mask`` stay per output sample. ``taps`` ``(W,)``; ``W = 1`` (``taps = [1]``)
    is the unfiltered case and takes the plain path. ``extra`` ``(C, e, c)``: known columns
    already filtered (the friction columns, whose filter differs by half a sample: see
    :meth:`~pgcomm.sensorless.SensorlessData.filtered_friction`), inserted after the model's
    own known columns; ``e = 0`` unfiltered.
    """

    x0: jnp.ndarray
    s: jnp.ndarray
    currents: jnp.ndarray
    force: jnp.ndarray
    mask: jnp.ndarray
    taps: jnp.ndarray
    extra: jnp.ndarray


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


def chunk_count(n: int, chunk: int) -> int:
    """Chunks ``C`` for ``n`` samples of ``chunk``: ``⌈n / chunk⌉`` rounded up to a power of two.

    The compiled identification depends on ``C`` only (not on ``n``): rounding ``C`` up to
    powers of two (padded samples have ``mask = 0`` and change no sum) lets data sets of
    different lengths (a fleet of motors) share one compilation per size instead of compiling
    per data set. A compilation costs ~15-20 s, the padded work (< 2x) about a second here.
    """
    need = max(1, -(-int(n) // int(chunk)))
    return 1 << (need - 1).bit_length()


def _to_chunks(layout: _Layout, data, chunk: int, pole_pitch, y_center, y_scale) -> _Chunks:
    n = data.n
    n_chunks = chunk_count(n, chunk)
    pad = n_chunks * chunk - n

    def padded(a, w=1):  # (k, N W) -> (C, k, c W)
        a = np.atleast_2d(a)
        a = np.concatenate([a, np.zeros((a.shape[0], pad * w))], axis=1)
        # device_put: jnp.asarray of a host array compiles a copy per shape
        return jax.device_put(np.ascontiguousarray(a.reshape(a.shape[0], n_chunks, chunk * w).transpose(1, 0, 2)))

    raw = data.raw
    x0, s = (np.asarray(a) for a in _known_data(layout, raw.y, raw.currents, raw.velocity, pole_pitch, y_center,
                                                 y_scale, data.name))
    windows = data.window_index()  # (n, W): each output sample's raw samples (W = 1: the sample itself)
    w = windows.shape[1]
    idx = windows.ravel()  # (n W,), window-major
    return _Chunks(padded(x0[:, idx], w), padded(s[idx], w)[:, 0], padded(raw.currents[idx].T, w),
                   padded(data.force.T), padded(np.ones(n))[:, 0], jnp.asarray(data.regressor_taps, dtype=float),
                   padded(data.filtered_friction().T))


def _filtered_rows(layout: _Layout, m, taps, extra):
    """Raw rows ``m`` ``(S, p - e, c W)`` -> filtered ``(S, p, c)`` with the prefiltered ``extra`` ``(e, c)`` inserted.

    Unfiltered (``W = 1``, ``e = 0``) ``m`` is returned as it is.
    """
    if taps.shape[0] > 1:
        m = _apply_taps(m, taps)
    if extra.shape[0] == 0:
        return m
    nk = layout.n_known - layout.friction
    ext = jnp.broadcast_to(extra, m.shape[:-2] + extra.shape)
    return jnp.concatenate([m[..., :nk, :], ext, m[..., nk:, :]], axis=-2)


def _apply_taps(a, taps):
    """``(..., c W) -> (..., c)``: each output sample's window of ``W`` raw samples weighted by ``taps`` ``(W,)``."""
    w = taps.shape[0]
    return jnp.einsum("...cw,w->...c", a.reshape(a.shape[:-1] + (a.shape[-1] // w, w)), taps)


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
    xs = (chunks.x0, chunks.s, chunks.currents, chunks.force, chunks.mask, chunks.extra)
    taps = chunks.taps
    filtered = taps.shape[0] > 1  # static: a window per output sample (sensorless)

    def rows(ch, with_u):
        """``A = [M, F]`` ``(S, m, c)`` of a chunk; with ``with_u`` also ``u`` (filtered: ``[u; u s]`` filtered)."""
        x0, s, cur, frc, msk, ext = ch
        out = _rows(layout, hidden, x0, s, cur, with_u)
        mm, u = out if with_u else (out, None)
        mm = _filtered_rows(layout, mm, taps, ext)
        if filtered:
            if with_u:  # filtering breaks V = u s^a into u and s: filter both powers
                u = _apply_taps(jnp.concatenate([u, u * s[None, None, :]], axis=1), taps)
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
        if filtered:  # u = [u_f; (u s)_f]: the full Gram of V and V A^T
            return (g_aa, g[1] + jnp.einsum("skc,slc->skl", u, a), g[2] + jnp.einsum("skc,slc->skl", u, u)), None
        s = ch[1][None, None, :]
        us = u * s
        g_ua = g[1] + jnp.einsum("skc,slc->skl", jnp.concatenate([u, us], axis=1), a)
        g_uu = g[2] + jnp.einsum("skc,slc->skl", u, jnp.concatenate([u, us, us * s], axis=1))
        return (g_aa, g_ua, g_uu), None

    init = (jnp.zeros((n_s, m, m)),)
    if structured:
        init += (jnp.zeros((n_s, 2 * n_u, m)), jnp.zeros((n_s, 2 * n_u, 2 * n_u) if filtered else (n_s, n_u, 3 * n_u)))
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
        s_aa, p_q, e_q = jax.vmap(partial(_structured_sums, layout, filtered=filtered))(g1[1], g1[2], theta_l)
    else:
        s_aa, p_q, e_q = _generic_sums(layout, flats, xs, theta_l, taps)

    def assemble(s_aa, p_q, e_q, sinv, vt, theta_l, d):
        d_m = d[:p, None]
        x = sinv[:, :, None] * (vt @ (p_q / d_m))  # (3, p, n)
        z = sinv[:, :, None] * (vt @ (e_q / d_m))
        jtj = jnp.sum(s_aa - jnp.swapaxes(x, 1, 2) @ x + jnp.swapaxes(z, 1, 2) @ z, axis=0)
        jtr = -jnp.einsum("qpn,pq->n", e_q, theta_l)
        return 0.5 * (jtj + jtj.T), jtr

    jtj, jtr = jax.vmap(assemble)(s_aa, p_q, e_q, sinv, vt, theta_l, d)
    return _Eval(f, data2, phys2, ridge2, damp2, theta_l, jtj, jtr)


def _structured_sums(layout: _Layout, g_ua, g_uu, theta_l, filtered=False):
    """``Σ_t a aᵀ``, ``P_q``, ``E_q`` (per q) of one start from the pass-1 sums (single hidden layer).

    Parameter ``i`` feeds unit ``k(i)`` and enters as ``s^{a(i)}`` (``a = 1`` weight, 0 bias), so
    ``V_t[i] = ∂M_t[col(i)]/∂θ_NL[i] = u_t,k(i) s_t^{a(i)}`` is the only non-zero of column ``i`` of
    ``∂M_t/∂θ_NL``. With ``w_q[i] = θ_L[col(i), q]``: ``a_t,q[i] = w_q[i] V_t[i]``, hence
    ``Σ a aᵀ = w wᵀ ⊙ VᵀV``, ``P_q = MᵀV diag(w_q)`` and ``E_q[col(i), i] = Σ_t r_t,q V_t[i] =
    (VᵀF - VᵀM θ_L)[i, q]``; ``VᵀV`` and ``Vᵀ[M, F]`` are gathered from
    ``g_uu = Σ u [u; u s; u s²]ᵀ`` and ``g_ua = Σ [u; u s] [M, F]ᵀ``. ``filtered``: ``V`` of a
    filtered output is the filtered ``u s^a``, not a product, so ``g_uu`` is the full Gram
    ``Σ [u; u s]_f [u; u s]_fᵀ``.
    """
    p = layout.p
    unit, power, col = layout.param_units()
    n_u = int(unit.max()) + 1
    if filtered:
        v = power * n_u + unit
        s_vv = g_uu[v[:, None], v[None, :]]
    else:
        s_vv = g_uu[unit[:, None], (power[:, None] + power[None, :]) * n_u + unit[None, :]]
    s_va = g_ua[power * n_u + unit]  # (n, m)
    s_vm, s_vf = s_va[:, :p], s_va[:, p:]
    wq = theta_l[col, :].T  # (3, n)
    s_aa = wq[:, :, None] * s_vv[None] * wq[:, None, :]
    p_q = s_vm.T[None] * wq[:, None, :]
    rho = s_vf.T - (s_vm @ theta_l).T
    onehot = jnp.asarray(np.arange(p)[:, None] == col[None, :], dtype=float)
    return s_aa, p_q, onehot[None] * rho[:, None, :]


def _generic_sums(layout: _Layout, flats, xs, theta_l, taps):
    """Chunked ``Σ_t a a^T``, ``P_q``, ``E_q`` with ``∂M/∂θ_NL`` from ``jax.jacfwd`` (any depth)."""
    p, n = layout.p, layout.n_nl

    def feats(fl, x0, s, cur, ext):
        return _filtered_rows(layout, _rows(layout, _unflatten(layout, fl[None]), x0, s, cur)[0], taps, ext).T  # (c, p)

    def per_start(fl, th, ch):
        x0, s, cur, frc, msk, ext = ch
        mm = feats(fl, x0, s, cur, ext) * msk[:, None]
        dm = jax.jacfwd(feats)(fl, x0, s, cur, ext) * msk[:, None, None]  # (c, p, n)
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


def filter_abs(data, column) -> np.ndarray:
    """``Σ_m |g'_m| |x[s_j + m]|`` ``(n,)``: bounds the filtered ``|h x|`` for any ``|h| <= 1``
    (``|x|`` itself for unfiltered data); ``data`` an :class:`~pgcomm.protocols.IdentificationData`."""
    return np.abs(np.asarray(column, float))[data.window_index()] @ np.abs(np.asarray(data.regressor_taps, float))


def fit_physics(data, pole_pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """Physics-only least squares: ``min Σ_t ||F - (A cos + B sin) i||²`` (no networks, no cogging, no Λ).

    Solved per direction ``q`` by ``numpy.linalg.lstsq`` on the columns
    ``[cos·ia, cos·ib, sin·ia, sin·ib]`` (through the data's filter) beside the data's nuisance and friction
    columns (:class:`~pgcomm.protocols.IdentificationData`); rows the data do not observe are 0.
    Sensorless data (:class:`~pgcomm.sensorless.SensorlessData`): the filtered columns, a position-only
    nuisance for the cogging and the friction columns against ``m ÿ_f``, the y row only.

    Returns:
        ``(A, B)``, each ``(3, 2)`` (N/A); ``θ_phy* = theta_phy(A, B)``.
    """
    raw = data.raw
    c, s = (np.asarray(x) for x in harmonic_basis(raw.y, pole_pitch))
    ia, ib = raw.currents[:, 0], raw.currents[:, 1]
    # beside the physics columns: the data's nuisance columns (sensorless: a position-only stand-in for the
    # cogging) and its friction columns, both fitted and dropped
    x = np.column_stack([data.filtered(np.column_stack([c * ia, c * ib, s * ia, s * ib])),
                         data.physics_nuisance(pole_pitch), data.filtered_friction()])
    obs = list(data.observed)
    coef = np.zeros((4, 3))  # rows not observed stay 0
    coef[:, obs] = np.linalg.lstsq(x, data.force[:, obs], rcond=None)[0][:4]
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


def cost(model: CoilSetModel, data, Lambda=DEFAULT_LAMBDA, theta_phy_star=None, friction=None) -> CostTerms:
    """Evaluate eq. Identification_CostFunction of ``model`` on ``data`` directly (no LIP rewrite).

    Args:
        model: :class:`CoilSetModel`; data: the samples (``2N = data.n``), :class:`CoilSetData` or
            :class:`~pgcomm.sensorless.SensorlessData` (then the y row only: ``mean (m ÿ_f - F̂_y,f - friction)²``);
        Lambda: ``Λ`` (see :func:`lambda_diagonal`); theta_phy_star: ``(12,)`` or ``None``
            (then the regularisation term is 0); friction: sensorless only, ``(F_c, c)`` (N, N s/m)
            or ``None`` (least-squares fit on ``data``).
    """
    if data.n == 0:
        return CostTerms(float("nan"), 0.0)
    dat = float(np.sum(data_residual(model, data, friction)[0] ** 2) / data.n)
    reg = 0.0
    if theta_phy_star is not None:
        reg = float(np.sum((lambda_diagonal(Lambda) * (theta_phy(model.A, model.B) - np.asarray(theta_phy_star))) ** 2))
    return CostTerms(dat, reg)


_force_jit = jax.jit(lambda model, y, currents, v: model.force(y, currents, v))


def _velocity_for(model, data: CoilSetData):
    """The data's velocity when the model has a direction term (which then needs one), else ``None``."""
    if getattr(model, "C", None) is None:
        return None
    if data.velocity is None:
        raise DataError(f"{data.name}: the model has a direction term; the data need a velocity (m/s)")
    return data.velocity


def cost_y(model: CoilSetModel, data, friction=None) -> float:
    """The paper's y identification cost of its Remark on ``sign(dy/dt)``: ``mean_t (Fy(t) - F̂y(t))²`` (N²).

    The mean over all samples of ``data`` of the squared driving-direction error (noise included).
    The Remark writes ``1/(2N) Σ`` with ``2N`` the number of samples of ``Z_1 ∪ Z_2``, i.e. this mean;
    for coil set 1 of the paper's motor: 3.52 N² (PGNN), 1.20 N² (PGNN with a direction term).
    """
    if data.n == 0:
        return float("nan")
    return float(np.mean(data_residual(model, data, friction)[0][:, 0] ** 2))


def data_residual(model: CoilSetModel, data, friction=None):
    """``(r, friction)``: the measured side minus the model through the data's filter minus the friction columns.

    ``r = force[:, observed] − (F̂(raw))_f[:, observed] − filtered_friction · friction``, ``(n, len(observed))``
    (N, N, N·m) for any :class:`~pgcomm.protocols.IdentificationData` (force-sensor data: ``force − F̂``).

    Args:
        friction: ``(n_friction,)`` coefficients; ``None``: the least-squares values for this model and data
            (none for data without friction columns).
    """
    raw = data.raw
    obs = list(data.observed)
    f_hat = np.asarray(_force_jit(model, raw.y, raw.currents, _velocity_for(model, raw)))[:, obs]
    rest = data.force[:, obs] - data.filtered(f_hat)
    cols = data.filtered_friction()
    if friction is None:
        friction = np.linalg.lstsq(cols, rest[:, 0], rcond=None)[0] if cols.shape[1] else np.zeros(0)
    friction = np.asarray(friction, float)
    return rest - (cols @ friction)[:, None], friction


def sensorless_residual(model: CoilSetModel, data, friction=None):
    """``(r, friction)``: ``r = m ÿ_f - (F̂_y)_f - [s(ẏ), ẏ]_f (F_c, c)`` ``(J,)`` (N) of a model on sensorless data
    (:func:`data_residual`'s driving row).

    ``friction`` ``(F_c, c)`` (N, N s/m); ``None``: the least-squares values for this model and data.
    """
    r, friction = data_residual(model, data, friction)
    return r[:, 0], friction


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
    # ||cos·i||, ||sin·i|| <= ||i||; filtered: ||Σ g' x|| <= ||Σ |g'| |x|||
    raw = data.raw
    norms = {k: np.linalg.norm(filter_abs(data, c)) for k, c in enumerate((raw.currents[:, 0], raw.currents[:, 1],
                                                                           np.ones(raw.n)))}
    bound = [norms[0], norms[1], norms[0], norms[1]]
    if layout.harmonics:
        bound += [norms[0], norms[1]] * 4
    if layout.direction:
        bound.append(norms[2])  # |tanh| <= 1
    if layout.friction:
        bound += [norms[2]] * (layout.friction - 1) + [np.linalg.norm(filter_abs(data, raw.velocity))]  # |tanh φ_j| <= 1
    for kind, widths in layout.blocks:
        bound += [norms[kind]] * (widths[-1] + 1)
    damp_w = damping * np.maximum(np.asarray(bound), 1e-300)
    return _Consts(*jax.device_put((np.asarray(float(data.n)), np.asarray(reg_w, float), np.asarray(theta_bar, float),
                                    np.asarray(damp_w, float))))


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
        friction: sensorless data only: the coefficients of the friction columns, else ``None``; ``theta_L`` then
            holds them in rows :attr:`_Layout.friction_rows` and ``model`` does not.
    """

    theta_L: np.ndarray
    model: CoilSetModel
    cost: float
    cost_data: float
    cost_regularisation: float
    ridge_term: float
    damping_term: float
    friction: np.ndarray | None = None


def _prepare(theta_nl, data, Lambda, theta_phy_star, ridge_output, damping, chunk_size, method):
    layout = _Layout.of(theta_nl, method)
    if data.n_friction:
        if layout.direction:
            raise ValueError("without a force sensor the direction term is the Coulomb friction column: "
                             "identify without direction=True")
        layout = dataclasses.replace(layout, friction=data.n_friction)
    if chunk_size is None:
        chunk_size = DEFAULT_CHUNK if layout.structured else DEFAULT_CHUNK_GENERIC
        w = np.asarray(data.regressor_taps).shape[0]
        if w > 1:  # windows of w raw samples: as many raw samples per chunk as unfiltered
            chunk_size = max(8, 1 << max(0, int(np.log2(max(1, chunk_size // w)))))
    star = _star_or_fit(data, theta_nl.pole_pitch, theta_phy_star)
    k = _consts(layout, data, Lambda, star, ridge_output, damping)
    chunks = _to_chunks(layout, data, int(chunk_size), theta_nl.pole_pitch, theta_nl.y_center, theta_nl.y_scale)
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
    theta_model, friction = split_friction(layout, theta_L)
    return Proposition1Result(theta_L, with_theta_L(theta_nl, theta_model), float(ev.data2 + ev.phys2) / two_n,
                              float(ev.data2) / two_n, float(ev.phys2) / two_n, float(ev.ridge2) / two_n,
                              float(ev.damp2) / two_n, friction)


def split_friction(layout: _Layout, theta_L):
    """``(θ_L of the model, friction)``: sensorless layouts carry the friction coefficients (of
    :meth:`~pgcomm.sensorless.SensorlessData.friction_columns`) in rows :attr:`_Layout.friction_rows`
    of the y column; they are mechanics, not part of the model. ``friction`` is ``None`` for other layouts."""
    theta_L = np.asarray(theta_L)
    if not layout.friction:
        return theta_L, None
    rows = layout.friction_rows
    return np.delete(theta_L, np.arange(rows.start, rows.stop), axis=0), theta_L[rows, 0].copy()


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

    def data_rows(x0, s, cur, frc, msk, ext):  # padded samples give zero rows
        m = _filtered_rows(layout, _rows(layout, hidden, x0, s, cur)[0], chunks.taps, ext)
        return ((frc - theta_l.T @ m) * msk).ravel()

    r_data = jax.vmap(data_rows)(chunks.x0, chunks.s, chunks.currents, chunks.force, chunks.mask, chunks.extra)
    r_reg = jnp.sqrt(k.two_n) * k.reg_w.T * (theta_l - k.theta_bar)
    return jnp.concatenate([r_data.ravel(), r_reg.ravel(), (k.damp_w[:, None] * theta_l).ravel()])
