"""Algorithm 2 by variable projection: Levenberg–Marquardt over ``θ_NL`` with ``θ_L = Prop1(θ_NL)``,
several random starts at once, two phases (subsample, then all samples); :func:`identify`
for one coil set and :func:`identify_all` for a motor.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass
from pgcomm.data import CoilSetData
from pgcomm.errors import DataError, ExcitationError
from pgcomm.excitation import check_excitation
from pgcomm.identify.layout import (
    _Layout,
    hidden_vector,
    lambda_diagonal,
    with_hidden_vector,
    with_theta_L,
)
from pgcomm.identify.projection import (
    CostTerms,
    _Eval,
    _evaluate,
    _prepare,
    _star_or_fit,
    cost,
    cost_y,
    fit_physics,
    data_residual,
    split_friction,
)
from pgcomm.seeds import stream_seed
from pgcomm.identify.options import IdentifyOptions
from pgcomm.identify.result import STOP_REASONS, IdentifyResult
from pgcomm.models import CoilSetModel, CombinedModel


#: Fewest samples the first (subsampled) training phase uses.
_MIN_SUBSAMPLE = 4096


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
    # Explicit dtypes (not weakly typed) so that this state and the stepped ones share one compilation; built on
    # the host and placed (jnp constructors outside a trace compile a program per shape)
    ev = _Eval(np.full(n_s, np.inf), *(np.zeros(n_s) for _ in range(4)), np.zeros((n_s, layout.p, 3)),
               np.broadcast_to(np.eye(n), (n_s, n, n)).copy(), np.zeros((n_s, n)))
    return jax.device_put(_LMState(flats, ev, np.full(n_s, float(lam0)), np.full(n_s, 2.0), np.zeros(n_s, bool),
                                   np.zeros(n_s, np.int32), np.full(n_s, -1, np.int32)))


#: Largest damping before a start is declared converged (steps are then ~1e-10 of Gauss–Newton's).
_LAMBDA_MAX = 1e10


#: Floor of the damping's scale ``D``, as a share of the largest diagonal entry of ``JᵀJ`` (:func:`_lm_delta`).
DAMPING_FLOOR = 0.03


def _lm_delta(ev_jtj, ev_jtr, lam):
    """Solve ``(JᵀJ + λ D) δ = -Jᵀr̃`` with ``D = diag(max(diag(JᵀJ), ε · max diag JᵀJ))``, ``ε`` =
    :data:`DAMPING_FLOOR`.

    Marquardt's ``D = diag(JᵀJ)`` gives a parameter whose column of ``J`` is small where it now stands (a unit whose
    output weight is near 0, a saturated unit's bias) almost no damping: its step is Gauss–Newton's, far beyond where
    the quadratic model holds, the step is refused and ``λ`` grows for every parameter, and the descent crawls. The
    floor damps such a parameter as if its column were a few per cent of the largest (Levenberg's damping where
    Marquardt's vanishes). On the twin's three coil sets, two seeds each, 100 + 100 iterations: ``V`` 5.53-5.68
    (mean 5.62) with a floor of 1e-12, 5.39-5.49 (mean 5.43) with 0.03; floors from 0.003 to 1 gave means of
    5.43-5.47, and Moré's running maximum of ``diag(JᵀJ)`` 5.58.
    """
    diag = jnp.diagonal(ev_jtj)
    dd = jnp.maximum(diag, DAMPING_FLOOR * jnp.max(diag) + 1e-300)
    delta = jnp.linalg.solve(ev_jtj + lam * jnp.diag(dd), -ev_jtr)
    return jnp.where(jnp.all(jnp.isfinite(delta)), delta, 0.0)


#: ``λ`` of the Gauss–Newton step whose predicted decrease decides convergence (:func:`_predicted_fall`).
CONVERGENCE_LAMBDA = 1e-6


def _predicted_fall(jtj, jtr):
    """The decrease of ``f`` that the Gauss–Newton model predicts for its own step from where a start stands:
    ``-(δᵀJᵀr̃ + ½ δᵀJᵀJ δ)``, ``δ`` of :func:`_lm_delta` at ``λ`` = :data:`CONVERGENCE_LAMBDA`.

    ``JᵀJ`` of a network is singular to rounding (units that mimic each other), and there the undamped step's
    prediction is rounding noise; ``λ D`` (``D`` floored, :data:`DAMPING_FLOOR`) bounds it at ``1e-6`` of the
    scale of every column, and leaves the step Gauss–Newton's wherever ``JᵀJ`` holds information.
    """
    delta = _lm_delta(jtj, jtr, CONVERGENCE_LAMBDA)
    return -(delta @ jtr + 0.5 * delta @ jtj @ delta)


def _lm_accept(st: _LMState, delta, new: _Eval, tol, max_iter, decrease_tol):
    """Accept or reject one start's step; update ``λ`` by Nielsen's rule; test for convergence.

    ``ρ = (f - f_new) / (-δᵀJᵀr̃ - ½ δᵀJᵀJ δ)``; accepted (``f_new < f``): ``λ <- λ·max(1/3,
    1 - (2ρ - 1)³)``, else ``λ <- λ·ν``, ``ν <- 2ν``. Converged where, after an accepted step, the
    Gauss–Newton step from the new point would lower ``f`` by at most ``decrease_tol · f``
    (:func:`_predicted_fall`: the cost is then within about that share of its local minimum), or on an
    accepted relative decrease below ``tol``, or ``||δ|| <= tol (||θ_NL|| + tol)``; stopped on ``λ > 1e10``
    or at ``max_iter``.
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
    keep = lambda a, b: jnp.where(accept, a, b)  # noqa: E731
    kept = jax.tree_util.tree_map(keep, new, ev)
    small_pred = accept & (_predicted_fall(kept.jtj, kept.jtr) <= decrease_tol * kept.f)
    reason = jnp.select([first & ~jnp.isfinite(new.f), first, small_pred, small_f, small_x, lam > _LAMBDA_MAX,
                         n_iter >= max_iter], [5, 0, 6, 1, 2, 3, 4], 0)
    reason = jnp.where(st.done, st.reason, reason)
    return _LMState(keep(st.flat + delta, st.flat), kept,
                    jnp.where(st.done, st.lam, lam), jnp.where(st.done, st.nu, nu), st.done | (reason > 0), reason,
                    n_iter)


def _with_slope_penalty(ev: _Eval, flats, mask, w_max, scale) -> _Eval:
    """Add the first-layer slope bound to an evaluation: rows ``scale · max(|w| - w_max, 0)``.

    Each first-layer weight ``w`` (``mask``) beyond ``w_max`` (slope in scaled position ``s``)
    adds a residual row ``r = scale (|w| - w_max)`` with Jacobian ``scale · sign(w)`` (one
    entry): ``f += ½ r²``, ``Jᵀr += J r``, ``JᵀJ += J²`` on the diagonal. Below the bound the
    objective is the paper's ``V`` unchanged.
    """
    excess = jnp.where(mask, jnp.maximum(jnp.abs(flats) - w_max, 0.0), 0.0)
    r = scale * excess
    jd = jnp.where(excess > 0, scale * jnp.sign(flats), 0.0)
    pen = 0.5 * jnp.sum(r * r, axis=-1)
    jtj = ev.jtj + jax.vmap(jnp.diag)(jd * jd)
    return _Eval(ev.f + pen, ev.data2, ev.phys2, ev.ridge2, ev.damp2, ev.theta_L, jtj, ev.jtr + jd * r)


def _lm_step(layout, st: _LMState, chunks, k, tol, max_iter, slope, decrease_tol):
    """One Levenberg–Marquardt iteration of all starts (see :func:`_lm_delta`, :func:`_lm_accept`).

    ``slope = (mask, w_max, scale)``: the first-layer slope bound (:func:`_with_slope_penalty`).
    """
    delta = jax.vmap(_lm_delta)(st.ev.jtj, st.ev.jtr, st.lam)
    new = _with_slope_penalty(_evaluate(layout, st.flat + delta, chunks, k, True), st.flat + delta, *slope)
    return jax.vmap(_lm_accept, in_axes=(0, 0, 0, None, None, None))(st, delta, new, tol, max_iter, decrease_tol)


_lm_step = jax.jit(_lm_step, static_argnums=(0,))


def _progress_printer(name):
    def show(info):
        print(f"pgcomm: {name}: phase {info['phase']} iteration {info['iteration']:3d}  "
              f"best V = {info['best_cost']:.6g}  "
              f"lambda = {info['lambda']:.2e}  active starts {info['active']}/{info['starts']}",
              file=sys.stderr, flush=True)
    return show


def _run_lm(layout, flats, chunks, k, n, *, max_iter, tol, decrease_tol, lambda0, show, phase, slope):
    """Levenberg–Marquardt on all rows of ``flats`` at once until each start stops.

    Returns the final state and the best objective ``V`` (plus ridge, damping and slope terms)
    after every iteration (index 0: the starting points).
    """
    st = _lm_step(layout, _lm_init(layout, flats, lambda0), chunks, k, tol, max_iter, slope, decrease_tol)
    # V = ||r̃||² / (2N) = 2 f / n
    history = [2.0 * float(jnp.nanmin(st.ev.f)) / n]
    it = 0
    while layout.n_nl > 0 and not bool(jnp.all(st.done)) and it < max_iter:
        st = _lm_step(layout, st, chunks, k, tol, max_iter, slope, decrease_tol)
        it += 1
        fs = np.asarray(st.ev.f)
        best = int(np.argmin(np.where(np.isfinite(fs), fs, np.inf)))
        history.append(2.0 * float(fs[best]) / n)
        if show is not None:
            show({"phase": phase, "iteration": it, "best_cost": history[-1], "lambda": float(st.lam[best]),
                  "active": int(np.sum(~np.asarray(st.done))), "starts": int(fs.size)})
    return st, tuple(history)


def identify(data: CoilSetData, pole_pitch: float, options: IdentifyOptions | None = None, *, seed: int = 0,
             theta_phy_star=None, start_from: CoilSetModel | None = None, check_data: bool = True,
             progress=None) -> IdentifyResult:
    """Identify the PGNN of one coil set (Algorithm 2) by variable-projection Levenberg–Marquardt.

    Steps: split the data (the data's ``split``); check excitation
    (:func:`check_excitation`, raises :class:`~pgcomm.errors.ExcitationError`); fit the
    physics-only model once (the physics row of the result and ``θ_phy*`` unless given); draw
    ``options.starts`` random hidden layers from ``jax.random.PRNGKey(seed)``; iterate, for several starts at once (one batched
    evaluation)::

        θ_L = Prop1(θ_NL)                                   (eq. Optimal_Initialization)
        (JᵀJ + λ D) δ = -Jᵀr̃,   θ_NL <- θ_NL + δ  if V decreases   (see _lm_delta, _lm_accept)

    where ``r̃`` is the projected residual (data rows and ``√(2N) Λ`` rows) and ``J`` its exact
    Jacobian in ``θ_NL`` (see ``_evaluate``). Two phases, because consecutive samples at
    1 kHz carry nearly the same information:

    1. all ``options.starts`` starts on every ``subsample``-th training sample (at least 4096
       samples; skipped when the data are too few for that), for ``screen_iterations`` each;
    2. the ``refine_starts`` best of them on all training samples, each until it converges: until the
       Gauss–Newton step from where it stands would lower its cost by at most ``decrease_tol`` of it
       (:func:`_predicted_fall`), with ``max_iterations`` as a safety net (the result then says it did not
       converge, :attr:`IdentifyResult.converged`).

    The start with the lowest training cost is kept. ``subsample=1`` runs all starts on all
    samples in one phase. The result is deterministic for a given ``seed``.

    No feature narrower than the motor supports: the field reaches a coil through magnets
    ``d_m/2`` long, averaged over the coil, so no gain or cogging feature is narrower than a
    fraction of the pole pitch. A tanh unit ``tanh(w s + b)`` rises from 10 % to 90 % over
    ``2 atanh(0.8) / |w|`` in ``s``; first-layer slopes beyond the ``w_max`` of a 10–90 % width
    of ``min_feature_width · d_m`` are penalised (:func:`_with_slope_penalty`; each unit of
    excess costs as much as the mean square of the measured force), so the optimiser cannot
    build steps the data cannot support (they fit noise and jump in the law).

    Args:
        data: samples of both data sets ``Z_1, Z_2`` of this coil set: a :class:`CoilSetData` (force
            sensor) or a :class:`~pgcomm.sensorless.SensorlessData` (the motion's ``m ÿ``).
        pole_pitch: ``d_m`` (m).
        options: what to fit and how (:class:`~pgcomm.identify.options.IdentifyOptions`; default:
            the paper's networks and cost).
        seed: seed of ``jax.random.PRNGKey`` for the random starts (a named stream,
            :func:`pgcomm.seeds.stream_seed`, when called from a pipeline).
        theta_phy_star: ``θ_phy*`` of the regularisation, or ``None`` for the physics fit of the
            training data.
        start_from: a model of the same network widths (e.g. the paper's PGNN of this coil set)
            whose hidden layers are the first start (a warm start: an extension adds only
            linear columns, so the trained hidden layers are already close); the other
            ``options.starts - 1`` starts stay random.
        check_data: run :func:`check_excitation` first.
        progress: ``None`` (silent), ``True`` (one line per iteration to stderr) or a callable
            receiving a dict ``{phase, iteration, best_cost, lambda, active, starts}``.

    Options worth knowing (:class:`~pgcomm.identify.options.IdentifyOptions`): ``harmonics`` adds
    the 5th/7th harmonic gain columns, not regularised (no network can mimic a 6 mm ripple, so
    there is no over-parametrisation for ``Λ`` to resolve, and pulling them to 0 would only bias
    them); ``direction`` adds ``C s(ẏ)`` (one linear parameter per direction, not regularised;
    ``data.velocity`` is then required; without a force sensor the direction term is the Coulomb
    friction column, so it is refused there).

    Returns:
        :class:`IdentifyResult`.
    """
    t0 = time.perf_counter()
    o = IdentifyOptions() if options is None else options
    name = data.name
    if data.n < 10:
        raise DataError(f"{name}: too few samples ({data.n}) to identify a model")
    if data.n_friction and o.direction:
        raise ValueError(f"{name}: without a force sensor the direction term is the Coulomb friction column; "
                         "identify with direction=False")
    if o.direction and data.velocity is None:
        raise DataError(f"{name}: the direction term needs the velocity of every sample; "
                        "build the data with CoilSetData.with_velocity(sample_time)")
    if check_data:
        problems = check_excitation(data.raw, pole_pitch)
        if problems:
            raise ExcitationError(f"{name}: data do not persistently excite the model: " + "; ".join(problems))
    train, val = data.split(o.validation_fraction, o.block_size)
    y_lo, y_hi = float(data.y.min()), float(data.y.max())
    y_center = 0.5 * (float(train.y.min()) + float(train.y.max()))
    y_scale = max(0.5 * (float(train.y.max()) - float(train.y.min())), 1e-9)

    # the physics-only fit, once: the result's physics model, the starts' physics part and θ_phy*
    a_phy, b_phy = fit_physics(train, pole_pitch)
    physics = CoilSetModel.physics(a_phy, b_phy, pole_pitch, y_center, y_scale, y_lo, y_hi)
    star = _star_or_fit(train, pole_pitch, (a_phy, b_phy) if theta_phy_star is None else theta_phy_star)
    lam12 = lambda_diagonal(o.regularisation)

    keys = jax.random.split(jax.random.PRNGKey(seed), o.starts)
    models0 = [CoilSetModel.init(kk, physics, o.gain_widths, o.cog_widths, o.activation, o.harmonics, o.direction,
                                 o.direction_velocity) for kk in keys]
    template = models0[0]
    flats = jnp.stack([hidden_vector(mm) for mm in models0])
    if start_from is not None:
        warm = hidden_vector(start_from)
        if warm.shape != flats.shape[1:]:
            raise ValueError(f"start_from has {warm.shape[0]} hidden parameters, this structure {flats.shape[1]}")
        flats = flats.at[0].set(warm)
    show = _progress_printer(name) if progress is True else (progress or None)
    opts = dict(max_iter=o.max_iterations, tol=o.tol, decrease_tol=o.decrease_tol, lambda0=o.lambda0, show=show)
    history = []
    mask = jax.device_put(np.asarray(_Layout.of(template).first_layer_weight_mask()))
    w_max = (2.0 * np.arctanh(0.8) * y_scale / (o.min_feature_width * pole_pitch) if o.min_feature_width > 0
             else np.inf)
    force_ms = float(np.mean(train.force ** 2)) + 1e-300

    def slope(n):
        return (mask, *jax.device_put((np.asarray(w_max, float), np.asarray(np.sqrt(n * force_ms), float))))

    stride = max(1, min(int(o.subsample), train.n // _MIN_SUBSAMPLE))
    iters0 = np.zeros(o.starts, int)
    start_costs = None
    if stride > 1:
        sub = train.take(slice(None, None, stride))
        layout, chunks, k = _prepare(template, sub, lam12, star, o.ridge_output, o.damping, o.chunk_size, o.method)
        # phase 1 screens the starts for screen_iterations each: a start on a plateau of the subsample's cost
        # (its Gauss–Newton step predicting little) may still descend from it, and only the final phase must converge
        st1, hist1 = _run_lm(layout, flats, chunks, k, sub.n, phase=1, slope=slope(sub.n),
                             **{**opts, "decrease_tol": 0.0, "max_iter": min(o.screen_iterations, o.max_iterations)})
        history.append(hist1)
        fs1 = np.where(np.isfinite(np.asarray(st1.ev.f)), np.asarray(st1.ev.f), np.inf)
        start_costs = 2.0 * fs1 / sub.n
        keep = np.argsort(fs1, kind="stable")[:max(1, min(o.refine_starts, o.starts))]
        flats, iters0 = st1.flat[keep], np.asarray(st1.n_iter)[keep]
    layout, chunks, k = _prepare(template, train, lam12, star, o.ridge_output, o.damping, o.chunk_size, o.method)
    st, hist2 = _run_lm(layout, flats, chunks, k, train.n, phase=2 if stride > 1 else 1, slope=slope(train.n),
                        **opts)
    history.append(hist2)

    fs = np.asarray(st.ev.f)
    best = int(np.argmin(np.where(np.isfinite(fs), fs, np.inf)))
    if start_costs is None:
        start_costs = 2.0 * fs / train.n
    theta_model, friction = split_friction(layout, st.ev.theta_L[best])
    model = with_theta_L(with_hidden_vector(template, st.flat[best]), theta_model)
    c_pgnn = cost(model, train, lam12, star, friction=friction)
    # sensorless: the physics model's friction from the training data, reused on validation (refitted
    # there, the 30-odd friction-table entries absorbed part of its missing cogging: 8.8 vs 25.7 N²)
    phys_friction = data_residual(physics, train)[1]
    c_phys = cost(physics, train, friction=phys_friction)
    nan = float("nan")
    c_pgnn_val = cost(model, val, lam12, star, friction=friction) if val.n else CostTerms(nan, nan)
    c_phys_val = cost(physics, val, friction=phys_friction) if val.n else CostTerms(nan, 0.0)
    mechanics = data.mechanics(friction)
    return IdentifyResult(
        name=name, model=model, physics_model=physics, cost_physics=c_phys.data, cost_pgnn=c_pgnn.total,
        cost_pgnn_data=c_pgnn.data, cost_physics_validation=c_phys_val.data, cost_pgnn_validation=c_pgnn_val.data,
        cost_pgnn_validation_full=c_pgnn_val.total, iterations=int(iters0[best] + np.asarray(st.n_iter)[best]),
        seconds=time.perf_counter() - t0, ridge=float(o.ridge_output), ridge_term=float(st.ev.ridge2[best]) / train.n,
        damping=float(o.damping), damping_term=float(st.ev.damp2[best]) / train.n,
        n_train=train.n, n_validation=val.n, seed=int(seed), n_starts=int(o.starts),
        cost_y=cost_y(model, train, friction), cost_y_physics=cost_y(physics, train, phys_friction), mechanics=mechanics,
        start_costs=tuple(float(x) for x in start_costs),
        stop_reason=STOP_REASONS[int(np.asarray(st.reason)[best])], history=tuple(history),
        slope_bound=float(w_max),
        slope_term=float(force_ms * np.sum(np.where(np.asarray(mask), np.maximum(
            np.abs(np.asarray(st.flat[best])) - w_max, 0.0), 0.0) ** 2)))


def identify_selecting_width(data: CoilSetData, pole_pitch: float, options: IdentifyOptions | None = None, *,
                             seed: int = 0, progress=None, check_data: bool = True) -> IdentifyResult:
    """:func:`identify` for each gain-network width in ``options.gain_width_candidates``; keep the best on validation.

    The paper's width 2 is a start, not a rule: a motor whose magnets vary one by one needs
    more capacity along the stroke than one with a smooth field. Every candidate is trained
    on the same split with the same seed; the one with the lowest validation data cost
    (``cost_pgnn_validation``, a prediction error comparable across widths) is kept, and
    ``width_selection`` records every candidate's ``(width, validation cost)``. Without
    validation data the first candidate is kept (nothing to choose by).

    Args:
        data, pole_pitch, seed, progress, check_data: as :func:`identify`.
        options: :class:`~pgcomm.identify.options.IdentifyOptions` whose ``gain_width_candidates``
            (single-hidden-layer widths of the two gain networks, default ``(2, 4, 8)`` when empty)
            replace ``gain_widths`` one by one.
    """
    o = IdentifyOptions() if options is None else options
    cands = o.gain_width_candidates or (2, 4, 8)
    results = [identify(data, pole_pitch, replace(o, gain_widths=(w,)), seed=seed, progress=progress,
                        check_data=check_data) for w in cands]
    val = [r.cost_pgnn_validation for r in results]
    best = int(np.nanargmin(val)) if np.isfinite(val).any() else 0
    return replace(results[best], width_selection=tuple((w, float(v)) for w, v in zip(cands, val)),
                   seconds=float(sum(r.seconds for r in results)))


def identify_all(datasets, pole_pitch: float, options: IdentifyOptions | None = None, *, seed: int = 0,
                 progress=None, check_data: bool = True):
    """Identify every coil set independently (Algorithm 2's loop) and combine them (eq. PGNN_Electromagnetics).

    Args:
        datasets: list of :class:`CoilSetData` (or :class:`~pgcomm.sensorless.SensorlessData`), one
            per coil set (in coil-set order).
        pole_pitch: ``d_m`` (m).
        options: :class:`~pgcomm.identify.options.IdentifyOptions` for every coil set; with
            ``gain_width_candidates`` each coil set's gain width is chosen by validation
            (:func:`identify_selecting_width`), so coil sets may differ (narrower networks are
            padded with inert units when combined).
        seed: the run's seed; coil set ``l`` (0-based) starts from the named stream
            ``stream_seed(seed, "starts", l)`` (:func:`pgcomm.seeds.stream_seed`).
        progress, check_data: as :func:`identify`.

    Returns:
        ``(CombinedModel, [IdentifyResult, ...])``.
    """
    o = IdentifyOptions() if options is None else options
    results = []
    for l, data in enumerate(datasets):
        kw = dict(seed=stream_seed(seed, "starts", l), progress=progress, check_data=check_data)
        if o.gain_width_candidates:
            results.append(identify_selecting_width(data, pole_pitch, o, **kw))
        else:
            results.append(identify(data, pole_pitch, o, **kw))
    return CombinedModel.from_coil_sets([r.model for r in results]), results
