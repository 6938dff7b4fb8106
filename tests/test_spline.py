"""The physics-guided spline model and its identification: regressor against the model's own force,
the regularised solve and its cross-validation against numpy.linalg.lstsq, recovery of a known model, the
merged mechanics on the twin, and the feedforward's Coulomb table in closed form."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.control import Feedforward, feedforward_signal
from pgcomm.data import CoilSetData
from pgcomm.identify.spline import (
    Normal,
    SplineOptions,
    _assemble,
    _layout,
    fold_labels,
    identify_spline,
    penalty_matrix,
    spline_regressor,
)
from pgcomm.spline_model import Grid, SplineModel

D_M = 0.03


def _grids(lo=-0.1, hi=0.1):
    return Grid.with_spacing(lo, hi, D_M / 2), Grid.with_spacing(lo, hi, D_M / 8), Grid.with_spacing(lo, hi, D_M)


def _samples(rng, n, lo=-0.1, hi=0.1):
    y = rng.uniform(lo, hi, n)
    cur = rng.normal(0, 2.0, (n, 2))
    v = rng.normal(0, 0.05, n)
    return y, cur, v


def test_grid_spacing_not_above_request():
    g = Grid.with_spacing(-0.1, 0.1, 0.007)
    assert g.spacing <= 0.007 and g.spacing > 0.007 * g.n / (g.n + 1)
    assert g.knots[0] == -0.1 and g.knots[-1] == pytest.approx(0.1, abs=1e-15)
    with pytest.raises(ValueError, match="spacing"):
        Grid.with_spacing(0.1, -0.1, 0.01)


def test_regressor_times_theta_is_the_models_force(rng):
    """Second formulation: ``M θ`` column layout against :meth:`SplineModel.force` of the assembled θ."""
    grids = _grids()
    off, p = _layout(grids)
    n_sets = 2
    thetas = [rng.normal(0, 1.0, (p, 3)) for _ in range(n_sets)]
    y, cur, v = _samples(rng, 400)
    data = [CoilSetData(y, cur, np.zeros((400, 3))) for _ in range(n_sets)]
    model = _assemble(thetas, grids, off, D_M, data, SplineOptions())
    # the model averages cogging and direction over coil sets: compare each coil set with the others'
    # current-independent parts removed
    for l in range(n_sets):
        m = spline_regressor(y, cur, v, D_M, grids, model.direction_velocity)
        f_reg = m @ thetas[l]
        cur_all = np.zeros((400, n_sets, 2))
        cur_all[:, l] = cur
        f_model = np.asarray(model.force(y, cur_all, v))
        ci = slice(*off["cogging"]), slice(*off["direction"])
        m_d = m.toarray()
        own = m_d[:, ci[0]] @ thetas[l][ci[0]] + m_d[:, ci[1]] @ thetas[l][ci[1]]
        mean = sum(m_d[:, ci[0]] @ t[ci[0]] + m_d[:, ci[1]] @ t[ci[1]] for t in thetas) / n_sets
        scale = np.max(np.abs(f_reg)) + np.max(np.abs(mean))
        np.testing.assert_allclose(f_model, f_reg - own + mean, rtol=0, atol=1e-12 * scale)


def test_normal_solve_matches_lstsq_on_the_augmented_system(rng):
    """``(MᵀM + λP + ridge) θ = MᵀF`` against ``lstsq([M; √λ R; √ridge I], [F; 0; 0])`` with ``P = RᵀR``."""
    grids = _grids()
    y, cur, v = _samples(rng, 3000)
    m = spline_regressor(y, cur, v, D_M, grids, 1e-3)
    f = rng.normal(0, 1.0, (3000, 3))
    fold = fold_labels(3000, 5, 100)
    normal = Normal.build(m, f, fold, 5, lambda g: penalty_matrix(grids, g))
    lam = 0.3
    theta = normal.solve(lam)
    g = normal.gram.sum(axis=0)
    ridge = 1e-10 * np.mean(np.diag(g))
    w, u = np.linalg.eigh(normal.penalty)
    r = (u * np.sqrt(np.clip(w, 0, None))).T                # P = Rᵀ R
    a = np.vstack([m.toarray(), np.sqrt(lam) * r, np.sqrt(ridge) * np.eye(m.shape[1])])
    b = np.vstack([f, np.zeros((2 * m.shape[1], 3))])
    ref = np.linalg.lstsq(a, b, rcond=None)[0]
    # compare predictions (the scale of F), not coefficients of poorly determined directions
    pred, pred_ref = m @ theta, m @ ref
    np.testing.assert_allclose(pred, pred_ref, rtol=0, atol=1e-8 * np.max(np.abs(f)))


def test_cross_validation_matches_explicit_refits(rng):
    """``cv_mse`` from per-fold normal equations equals refitting on K-1 folds and scoring the held-out one."""
    grids = _grids()
    y, cur, v = _samples(rng, 2000)
    m = spline_regressor(y, cur, v, D_M, grids, 1e-3)
    f = rng.normal(0, 1.0, (2000, 3))
    fold = fold_labels(2000, 4, 50)
    normal = Normal.build(m, f, fold, 4, lambda g: penalty_matrix(grids, g))
    lam = 0.05
    sse = np.zeros(3)
    for k in range(4):
        train = fold != k
        sub = Normal.build(m[train], f[train], np.zeros(train.sum(), int), 1, lambda g: normal.penalty)
        theta = sub.solve(lam)
        sse += np.sum((f[~train] - m[~train] @ theta) ** 2, axis=0)
    np.testing.assert_allclose(normal.cv_mse(lam), sse / 2000, rtol=1e-9)


def test_identify_recovers_a_model_in_its_class(rng):
    """Data from a known spline model (noise 0.05 N) give back its force within the noise's scale."""
    grids = (Grid.with_spacing(-0.1, 0.1, D_M / 4), Grid.with_spacing(-0.1, 0.1, D_M / 8),
             Grid.with_spacing(-0.1, 0.1, D_M / 2))
    off, p = _layout(grids)
    n = 6000
    data, thetas = [], []
    t = np.arange(n) * 1e-3
    y = 0.095 * np.sin(2 * np.pi * t / 3.0)
    v = np.gradient(y, 1e-3)
    for l in range(2):
        # a smooth truth: slowly varying envelopes around k = 60 N/A, smooth cogging and direction force
        th = np.zeros((p, 3))
        knots = grids[0].knots
        for q, amp in enumerate((40.0, 2.0, 0.1)):
            for c in range(4):
                th[off["gain"][0] + c:off["gain"][1]:4, q] = amp * (1 + 0.05 * np.sin(knots / 0.04 + c + l))
        th[off["cogging"][0]:off["cogging"][1], 0] = 3 * np.sin(grids[1].knots / 0.02)
        th[off["direction"][0]:off["direction"][1], 0] = 2 + np.cos(grids[2].knots / 0.03)
        cur = np.column_stack([3 * np.sin(2 * np.pi * t / 0.7), 3 * np.cos(2 * np.pi * t / 1.1 + l)])
        m = spline_regressor(y, cur, v, D_M, grids, 1e-3)
        f = m @ th + rng.normal(0, 0.05, (n, 3))
        data.append(CoilSetData(y, cur, f, np.zeros(n, int), f"coil set {l + 1}", v))
        thetas.append(th)
    opts = SplineOptions(gain_spacings=(0.25,), cog_spacings=(0.125,), dir_spacings=(0.5,))
    fit = identify_spline(data, D_M, opts)
    for l in range(2):
        cur_all = np.zeros((n, 2, 2))
        cur_all[:, l] = data[l].currents
        f_hat = np.asarray(fit.model.force(y, cur_all, v))
        m = spline_regressor(y, data[l].currents, v, D_M, grids, 1e-3).toarray()
        # the model's current-independent part is the mean over coil sets: compare the current-driven part
        ci = np.r_[off["cogging"][0]:off["direction"][1]]
        gain_part = m[:, :off["cogging"][0]] @ thetas[l][:off["cogging"][0]]
        indep = np.mean([m[:, ci] @ th[ci] for th in thetas], axis=0)
        rms = np.sqrt(np.mean((f_hat - gain_part - indep) ** 2, axis=0))
        assert np.all(rms < 0.05), rms          # below the noise: the fit averages it out
        assert fit.cost[l]["y"] == pytest.approx(0.05**2, rel=0.15)


def test_identify_refuses_short_data_and_missing_velocity(rng):
    y, cur, _ = _samples(rng, 100)
    d = CoilSetData(y, cur, np.zeros((100, 3)))
    from pgcomm.errors import DataError

    with pytest.raises(DataError, match="velocities"):
        identify_spline([d], D_M)
    with pytest.raises(DataError, match="cross-validation needs at least"):
        identify_spline([d], D_M, SplineOptions(direction=False))


def test_model_holds_its_tables_beyond_the_grid(rng):
    """Outside its knots the model reads the end coefficients (no growth) and the fundamental goes on: ten pole
    pitches past the grid's end it equals the model at the end (same electrical angle)."""
    grids = _grids()
    off, p = _layout(grids)
    y, cur, v = _samples(rng, 50)
    model = _assemble([rng.normal(0, 1, (p, 3))], grids, off, D_M, [CoilSetData(y, cur, np.zeros((50, 3)))],
                      SplineOptions())
    end, far = jnp.asarray([grids[0].hi]), jnp.asarray([grids[0].hi + 10 * D_M])
    scale = float(np.max(np.abs(np.asarray(model.gain_table)))) + float(np.max(np.abs(np.asarray(model.H))))
    np.testing.assert_allclose(np.asarray(model.gain(far)), np.asarray(model.gain(end)), rtol=0, atol=1e-9 * scale)
    np.testing.assert_array_equal(np.asarray(model.cogging(jnp.asarray([5.0]))), np.asarray(model.cogging(end)))
    assert model.n_parameters == (
        np.asarray(model.gain_table).size + np.asarray(model.H).size + np.asarray(model.cog_table).size
        + np.asarray(model.dir_table).size)


def test_feedforward_coulomb_table_closed_form():
    """``u_ff = δ [m a + f_v v + (f_c + D(r)) sign(v)]`` with ``δ = (z + 1)/2`` and ``D`` linearly interpolated."""
    r = np.linspace(-0.1, 0.1, 201)
    v = np.where(np.arange(201) < 100, 0.05, -0.05)
    a = np.linspace(-1, 1, 201)
    ff = Feedforward(mass=30.0, viscous=80.0, coulomb=1.0, coulomb_knots=(-0.1, 0.0, 0.1), coulomb_table=(10.0, 12.0, 14.0))
    d = np.interp(r, [-0.1, 0.0, 0.1], [10.0, 12.0, 14.0])
    g = 30.0 * a + 80.0 * v + (1.0 + d) * np.sign(v)
    expected = 0.5 * (g + np.concatenate([g[1:], g[-1:]]))
    np.testing.assert_allclose(feedforward_signal(ff, v, a, r), expected, rtol=1e-14, atol=1e-12)
    # without a table the old form is kept
    plain = Feedforward(mass=30.0, viscous=80.0, coulomb=12.0)
    g2 = 30.0 * a + 80.0 * v + 12.0 * np.sign(v)
    np.testing.assert_allclose(feedforward_signal(plain, v, a), 0.5 * (g2 + np.concatenate([g2[1:], g2[-1:]])),
                               rtol=1e-14, atol=1e-12)
    with pytest.raises(ValueError, match="reference positions"):
        feedforward_signal(ff, v, a)
