"""Identification: cost, Proposition 1, the projected Jacobian, variable-projection LM, excitation checks.

Synthetic data (:func:`synthetic_coil_set`, also used by ``bench/bench_identify.py``): the
ideal gain of one coil set with a smooth position-dependent perturbation, a cogging force of a
few N and noise; positions from back-and-forth sweeps over [-0.1, 0.1] m at several speeds;
currents from a fixed-commutation drive with ``Δ = ±π/4`` and force demands of 20–60 N with
sign changes.
"""

from __future__ import annotations

import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm import data as pdata
from pgcomm import identify as idf
from pgcomm.identify import lm as idf_lm
from pgcomm.excitation import check_excitation
from pgcomm.identify.layout import _Layout, _physics_columns
from pgcomm.identify.projection import _prepare, _projected_residual
from pgcomm.models import warn_outside_training_range
from pgcomm.commutation import currents_to_drive_inputs, drive_currents
from pgcomm.errors import DataError, ExcitationError
from pgcomm.models import CoilSetModel, CombinedModel
from pgcomm.motor import Motor, ideal_gain

D_M = 0.03
K_HAT, ZETA_HAT = 67.0, -0.52
#: the drive's fixed commutation of the one coil set
DRIVE = Motor(pole_pitch=D_M, lever_arms=(0.0,), k=(K_HAT,), zeta=(ZETA_HAT,))


def sweep(n, speeds, dt=1e-3, stroke=0.1):
    """``n`` positions (m) of cosine-profile moves between ``±stroke`` at the given peak speeds (m/s), repeated."""
    ys, pos = [], -stroke
    while sum(a.size for a in ys) < n:
        for v in speeds:
            target = -pos
            duration = np.pi / 2 * abs(target - pos) / v
            t = np.arange(0.0, duration, dt)
            ys.append(pos + (target - pos) * (1 - np.cos(np.pi * t / duration)) / 2)
            pos = target
    return np.concatenate(ys)[:n]


def true_gain(y, lever_arm=0.005):
    """``(N, 3, 2)`` star-reduced truth: ideal gain (k = 61.34, ζ = -0.54) x (1 + 5 % ripple) + a bump."""
    motor = Motor(lever_arms=(lever_arm,), k=K_HAT, zeta=ZETA_HAT)
    k = np.asarray(ideal_gain(y, motor, k=[61.34], zeta=[-0.54], mu=0.05))[:, 0]
    k = k * (1 + 0.05 * np.sin(2 * np.pi * y / 0.13 + 0.4))[:, None, None]
    return k + np.exp(-(y / 0.06) ** 2)[:, None, None] * np.array([[3.0, -2.0], [0.5, 0.3], [0.02, -0.01]])


def true_cogging(y):
    """``(N, 3)`` smooth current-independent force (N, N, N·m)."""
    return np.stack([2.0 * np.sin(2 * np.pi * y / 0.11) + 1.5 * np.tanh(y / 0.04),
                     0.5 * np.cos(2 * np.pi * y / 0.09), 0.05 * np.sin(2 * np.pi * y / 0.1)], axis=-1)


def synthetic_coil_set(n_per=3000, seed=0, deltas=(np.pi / 4, -np.pi / 4), speeds=(0.25, 0.45, 0.7),
                       noise=(0.2, 0.05, 0.005), magnitude=(40.0, 20.0), sign_changes=True, name="coil set 1",
                       lever_arm=0.005):
    """One coil set's data sets ``Z_i`` (one per entry of ``deltas``) of ``n_per`` samples at 1 ms.

    ``Fy*(t) = (magnitude[0] + magnitude[1] sin(2π t / 1.3 s)) · sign(sin(2π t / 0.7 s))``.
    """
    rng = np.random.default_rng(seed)
    ys, fys, dls, exps = [], [], [], []
    for e, delta in enumerate(deltas):
        t = np.arange(n_per) * 1e-3
        fy = magnitude[0] + magnitude[1] * np.sin(2 * np.pi * t / 1.3 + e)
        if sign_changes:
            fy = fy * np.sign(np.sin(2 * np.pi * t / 0.7 + 0.3 + e))
        ys.append(sweep(n_per, speeds))
        fys.append(fy)
        dls.append(np.full(n_per, delta))
        exps.append(np.full(n_per, e))
    y, fy, delta, exp = (np.concatenate(a) for a in (ys, fys, dls, exps))
    cur = np.asarray(drive_currents(y, fy[:, None], delta[:, None], K_HAT, ZETA_HAT, D_M))[:, 0]
    force = (np.einsum("nqj,nj->nq", true_gain(y, lever_arm), cur) + true_cogging(y)
             + rng.normal(size=(y.size, 3)) * np.asarray(noise))
    return pdata.CoilSetData.from_drive_inputs(y, fy, delta, force, DRIVE, 0, exp, name)


@pytest.fixture(scope="module")
def data():
    return synthetic_coil_set()


def _model(data, seed=0, gain=(2,), cog=(3,)):
    a, b = idf.fit_physics(data, D_M)
    return CoilSetModel.init(jax.random.PRNGKey(seed), CoilSetModel.physics(a, b, D_M, 0.0, 0.1), gain, cog)


def _lstsq_theta(model, data, lam12, star, ridge=0.0):
    """Reference: ``numpy.linalg.lstsq`` on the full augmented problem of every direction q."""
    m = np.asarray(idf.regressor(model, data.y, data.currents))
    n, p = m.shape
    wmask = _Layout.of(model).output_weight_mask()
    out = []
    for q in range(3):
        cols = _physics_columns(q)
        w = np.zeros(p)
        w[:4] = lam12[cols]
        w[wmask] = np.sqrt(ridge)
        target = np.zeros(p)
        target[:4] = star[cols]
        a = np.vstack([m, np.sqrt(n) * np.diag(w)])
        b = np.concatenate([data.force[:, q], np.sqrt(n) * w * target])
        out.append(np.linalg.lstsq(a, b, rcond=None)[0])
    return np.stack(out, axis=1)


# ------------------------------------------------------------------------------------ Proposition 1


@pytest.mark.parametrize("ridge", [0.0, 1e-3])
def test_proposition1_matches_lstsq(data, ridge):
    model = _model(data)
    rng = np.random.default_rng(1)
    lam12 = 0.05 + 0.2 * rng.random(12)  # a non-uniform diagonal Λ
    star = idf.theta_phy(*idf.fit_physics(data, D_M)) + rng.normal(size=12)
    ref = _lstsq_theta(model, data, lam12, star, ridge)
    res = idf.proposition1(model, data, lam12, star, ridge_output=ridge, damping=0.0)
    np.testing.assert_allclose(res.theta_L, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    # the reported cost is eq. Identification_CostFunction of the returned model
    direct = idf.cost(res.model, data, lam12, star)
    assert res.cost == pytest.approx(direct.total, rel=1e-10)
    assert res.cost_data == pytest.approx(direct.data, rel=1e-10)


def test_proposition1_default_damping_is_negligible_when_well_conditioned(data):
    model = _model(data)
    exact = idf.proposition1(model, data, damping=0.0)
    damped = idf.proposition1(model, data)
    assert damped.cost == pytest.approx(exact.cost, rel=1e-9)
    assert 0 < damped.damping_term < 1e-7 * damped.cost


def test_proposition1_lowers_the_cost_below_physics(data):
    """Prop. 1: for ANY hidden weights the PGNN cost is below the physics model's (strictly here)."""
    a, b = idf.fit_physics(data, D_M)
    v_phys = idf.cost(CoilSetModel.physics(a, b, D_M), data).total
    for seed in range(3):
        v = idf.proposition1(_model(data, seed), data).cost
        assert v < 0.9 * v_phys, (seed, v, v_phys)


def test_regressor_reproduces_model_force(data):
    model = idf.proposition1(_model(data), data).model
    m = np.asarray(idf.regressor(model, data.y, data.currents))
    f_lip = m @ np.asarray(idf.theta_L_of(model))
    np.testing.assert_allclose(f_lip, np.asarray(model.force(data.y, data.currents)), rtol=0, atol=1e-10)
    assert m.shape == (data.n, 4 + 3 + 3 + 4)


# ------------------------------------------------------------------------------- projected Jacobian


def _fd_normal_equations(model, data, star, h=1e-6):
    """Central differences of :func:`idf.projected_residual` (its jitted core, called 2n times)."""
    flat = np.asarray(idf.hidden_vector(model))
    r0 = idf.projected_residual(model, data, theta_phy_star=star)
    layout, chunks, k = _prepare(model, data, idf.DEFAULT_LAMBDA, star, 0.0, idf.DEFAULT_DAMPING, None, "auto")
    jac = np.empty((r0.size, flat.size))
    for i in range(flat.size):
        e = np.zeros_like(flat)
        e[i] = h * max(1.0, abs(flat[i]))
        rp, rm = (np.asarray(_projected_residual(layout, flat + sign * e, chunks, k)) for sign in (1, -1))
        jac[:, i] = (rp - rm) / (2 * e[i])
    return 0.5 * r0 @ r0, jac.T @ jac, jac.T @ r0


def assert_normal_equations_match_fd(model, data, method):
    """The analytic ``f, JᵀJ, Jᵀr̃`` against central differences (relative to their largest entries)."""
    star = idf.theta_phy(*idf.fit_physics(data, D_M))
    f, jtj, jtr, _ = idf.projected_normal_equations(model, data, theta_phy_star=star, method=method)
    f_fd, jtj_fd, jtr_fd = _fd_normal_equations(model, data, star)
    assert f == pytest.approx(f_fd, rel=1e-10)
    np.testing.assert_allclose(jtj, jtj_fd, rtol=0, atol=1e-5 * np.abs(jtj_fd).max())
    np.testing.assert_allclose(jtr, jtr_fd, rtol=0, atol=1e-5 * np.abs(jtr_fd).max())


@pytest.mark.parametrize("gain,cog,method", [((2,), (3,), "structured"), ((2, 2), (3, 2), "generic")])
def test_jacobian_matches_finite_differences(data, gain, cog, method):
    sub = data.take(slice(None, None, 3))
    assert_normal_equations_match_fd(_model(sub, seed=4, gain=gain, cog=cog), sub, method)


def test_chunk_size_and_method_do_not_change_the_result(data):
    sub = data.take(slice(None, None, 3))
    model = _model(sub, seed=4)
    star = idf.theta_phy(*idf.fit_physics(sub, D_M))
    f0, jtj0, jtr0, th0 = idf.projected_normal_equations(model, sub, theta_phy_star=star)
    for chunk, method in ((777, "structured"), (333, "generic")):
        f, jtj, jtr, th = idf.projected_normal_equations(model, sub, theta_phy_star=star, chunk_size=chunk,
                                                         method=method)
        assert f == pytest.approx(f0, rel=1e-10)
        np.testing.assert_allclose(th, th0, rtol=0, atol=1e-10 * np.abs(th0).max())
        # JᵀJ and Jᵀr̃ depend on θ_L to first order (cond·u, see the module docstring)
        np.testing.assert_allclose(jtj, jtj0, rtol=0, atol=1e-8 * np.abs(jtj0).max())
        np.testing.assert_allclose(jtr, jtr0, rtol=0, atol=1e-8 * np.abs(jtr0).max())


# -------------------------------------------------------------------------------------- training


@pytest.fixture(scope="module")
def trained(data):
    return idf.identify(data, D_M, idf.IdentifyOptions(starts=4, max_iterations=25, subsample=1), seed=3)


def test_training_beats_physics_and_decreases_monotonically(trained):
    r = trained
    assert r.cost_pgnn < 0.2 * r.cost_physics
    assert r.cost_pgnn_validation < 0.5 * r.cost_physics_validation
    (hist,) = r.history  # one phase (subsample=1)
    assert len(hist) == r.iterations + 1
    assert all(b <= a for a, b in zip(hist, hist[1:]))
    assert hist[-1] < hist[0]
    # the history's last value is the reported objective (V + damping term)
    assert hist[-1] == pytest.approx(r.cost_pgnn + r.damping_term + r.slope_term, rel=1e-8)
    assert r.n_train + r.n_validation == 6000 and r.n_validation == 1000
    d = r.to_dict()
    assert d["cost_pgnn"] == r.cost_pgnn and d["n_starts"] == 4 and len(d["start_costs"]) == 4


def test_a_start_stopped_by_the_iteration_cap_is_reported_as_not_converged(trained):
    """25 iterations do not converge these starts: the result says so, in the results' keys and in one line, with
    the share the cost still fell over the last 10 iterations read off the history. A converged stop says nothing."""
    from dataclasses import replace

    from pgcomm.identify.result import FALL_WINDOW, STOP_REASONS

    r = trained
    assert r.stop_reason == STOP_REASONS[4] and not r.converged
    (hist,) = r.history
    assert r.final_fall == pytest.approx(1.0 - hist[-1] / hist[-1 - FALL_WINDOW], rel=1e-12)
    assert r.final_fall > 0.0
    text = r.convergence_text()
    assert "not converged" in text and "max_iterations" in text and r.name in text
    d = r.to_dict()
    assert d["converged"] is False and d["cost_fall_last_iterations"] == r.final_fall
    done = replace(r, stop_reason=STOP_REASONS[1])
    assert done.converged and done.convergence_text() is None and done.to_dict()["converged"] is True


def test_predicted_fall_is_the_gauss_newton_models_decrease():
    """The convergence test's predicted decrease against the quadratic model written out with an explicit ``J`` and
    ``r``: ``½||r||² - ½||r + J δ||²`` at the damped step ``(JᵀJ + λ D) δ = -Jᵀr``, ``D`` the floored diagonal.
    One column is nearly null (a unit that mimics another), as in a network's ``JᵀJ``."""
    rng = np.random.default_rng(5)
    jac = rng.normal(size=(200, 6)) * np.array([1.0, 3.0, 0.1, 10.0, 1.0, 1.0])
    jac[:, 5] = jac[:, 4] + 1e-9 * rng.normal(size=200)
    r = rng.normal(size=200)
    jtj, jtr = jac.T @ jac, jac.T @ r
    d = np.maximum(np.diag(jtj), idf_lm.DAMPING_FLOOR * np.diag(jtj).max())
    delta = np.linalg.solve(jtj + idf_lm.CONVERGENCE_LAMBDA * np.diag(d), -jtr)
    expected = 0.5 * r @ r - 0.5 * np.sum((r + jac @ delta) ** 2)
    got = float(idf_lm._predicted_fall(jnp.asarray(jtj), jnp.asarray(jtr)))
    # the two differ by rounding in sums of 200 terms of size |r|²
    assert got == pytest.approx(expected, abs=1e-12 * (r @ r) * 200)
    assert 0.0 < got < 0.5 * r @ r


def test_a_start_stops_as_converged_once_gauss_newton_predicts_little(data):
    """With a tolerance the starts reach (0.5 % of the cost), the kept start stops as converged on the predicted
    decrease, before the iteration cap, and says nothing on the terminal; its cost is then no further above what 100
    more iterations reach than a share of the cost: the predicted decrease is the quadratic model's, and along a
    curved valley the cost falls further than it predicts (measured 0.3 % with 100 more on these data)."""
    from pgcomm.identify.result import STOP_REASONS

    o = idf.IdentifyOptions(starts=2, max_iterations=200, subsample=1, tol=0.0, decrease_tol=5e-3)
    r = idf.identify(data, D_M, o, seed=3, check_data=False)
    assert r.stop_reason == STOP_REASONS[6] and r.converged and r.iterations < 200
    assert r.convergence_text() is None
    more = idf.identify(data, D_M, idf.IdentifyOptions(starts=1, max_iterations=100, subsample=1, tol=0.0,
                                                        decrease_tol=0.0), seed=3, start_from=r.model,
                        check_data=False)
    assert more.cost_pgnn <= r.cost_pgnn * (1 + 1e-9)
    assert r.cost_pgnn - more.cost_pgnn < 0.02 * r.cost_pgnn


def test_same_seed_same_parameters(data, trained):
    again = idf.identify(data, D_M, idf.IdentifyOptions(starts=4, max_iterations=25, subsample=1), seed=3)
    for a, b in zip(jax.tree_util.tree_leaves(trained.model), jax.tree_util.tree_leaves(again.model)):
        assert np.array_equal(np.asarray(a), np.asarray(b))
    other = idf.identify(data, D_M, idf.IdentifyOptions(starts=4, max_iterations=2, subsample=1), seed=4)
    assert not np.array_equal(np.asarray(other.model.A), np.asarray(trained.model.A))


def test_two_phases_and_identify_all(monkeypatch):
    monkeypatch.setattr(idf_lm, "_MIN_SUBSAMPLE", 1000)  # let small data use the subsampled first phase
    # same sizes as the `trained` fixture, so phase 2 reuses its compiled step
    sets = [synthetic_coil_set(seed=l, name=f"coil set {l + 1}", lever_arm=0.07 * (l - 1)) for l in range(2)]
    model, results = idf.identify_all(sets, D_M, idf.IdentifyOptions(starts=4, max_iterations=6, subsample=2, refine_starts=4))
    assert isinstance(model, CombinedModel) and model.n_coil_sets == 2
    assert [r.name for r in results] == ["coil set 1", "coil set 2"]
    for r in results:
        assert len(r.history) == 2 and len(r.start_costs) == 4  # phase 1 (all starts) and phase 2
        assert r.cost_pgnn < r.cost_physics
        assert r.history[1][-1] <= r.history[1][0]
    np.testing.assert_array_equal(np.asarray(model.coil_set(1).A), np.asarray(results[1].model.A))


# ---------------------------------------------------------------------------------- data handling


def test_split_is_deterministic_blocks():
    tr, va = pdata.split_indices(5000, 0.2, 500)
    assert va.size == 1000 and tr.size == 4000
    assert np.array_equal(va[:500], np.arange(2000, 2500))  # every 5th block of 500
    tr0, va0 = pdata.split_indices(100, 0.0)
    assert tr0.size == 100 and va0.size == 0
    with pytest.raises(ValueError, match="validation_fraction"):
        pdata.split_indices(100, 0.7)


def test_cost_is_the_paper_formula(data):
    a, b = idf.fit_physics(data, D_M)
    model = CoilSetModel.physics(a + 0.5, b, D_M)
    lam = np.linspace(0.1, 1.2, 12)
    star = idf.theta_phy(a, b)
    c = idf.cost(model, data, lam, star)
    f_hat = np.einsum("nqj,nj->nq", np.asarray(model.gain(data.y)), data.currents)
    assert c.data == pytest.approx(np.sum((data.force - f_hat) ** 2) / data.n, rel=1e-12)
    assert c.regularisation == pytest.approx(np.sum((lam * (idf.theta_phy(a + 0.5, b) - star)) ** 2), rel=1e-12)
    np.testing.assert_array_equal(idf.theta_phy_to_AB(idf.theta_phy(a, b))[0], a)


def test_drive_input_front_end(data):
    y = data.y[:50]
    cur = data.currents[:50]
    fy, delta = (np.asarray(v)[:, 0] for v in currents_to_drive_inputs(y, cur[:, None], K_HAT, ZETA_HAT, D_M))
    assert np.all((delta > -np.pi / 2) & (delta <= np.pi / 2))  # the sign convention of the logs
    d2 = pdata.CoilSetData.from_drive_inputs(y, fy, delta, data.force[:50], DRIVE)
    np.testing.assert_allclose(d2.currents, cur, rtol=0, atol=1e-12)


def test_bad_data_is_refused_with_the_row():
    y = np.zeros(20)
    f = np.zeros((20, 3))
    f[7, 1] = np.nan
    with pytest.raises(DataError, match=r"coil set 2: force is not finite in row 7"):
        pdata.CoilSetData(y, np.zeros((20, 2)), f, name="coil set 2")
    with pytest.raises(DataError, match=r"currents must have shape \(20, 2\)"):
        pdata.CoilSetData(y, np.zeros((20, 3)), np.zeros((20, 3)))


# ------------------------------------------------------------------------------------- excitation


def _ranges(message):
    return [(float(a), float(b)) for a, b in re.findall(r"y ∈ \[([-0-9.e]+), ([-0-9.e]+)\] m", message)]


def test_good_data_passes_the_excitation_check(data):
    assert check_excitation(data, D_M) == []


def test_single_delta_is_refused():
    d = synthetic_coil_set(2000, deltas=(np.pi / 4, np.pi / 4), name="coil set 3")
    problems = check_excitation(d, D_M)
    assert problems and all("one ratio ia:ib" in p for p in problems)
    with pytest.raises(ExcitationError) as err:
        idf.identify(d, D_M)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("coil set 3: ") and "one ratio ia:ib" in msg
    assert _ranges(msg) == [(-0.1, 0.1)]


def test_single_force_magnitude_is_refused():
    d = synthetic_coil_set(2000, magnitude=(40.0, 0.0), sign_changes=False)
    problems = check_excitation(d, D_M)
    assert problems and all("single force magnitude" in p for p in problems)


def test_position_gap_is_named():
    d = synthetic_coil_set(3000)
    keep = (d.y < 0.02) | (d.y > 0.05)
    problems = check_excitation(d.take(keep), D_M)
    assert len(problems) == 1 and "no data (gap)" in problems[0]
    (lo, hi), = _ranges(problems[0])
    assert lo == pytest.approx(0.02, abs=0.011) and hi == pytest.approx(0.05, abs=0.011)
    assert lo <= 0.03 and hi >= 0.04


def test_warning_outside_training_range(trained):
    model = trained.model
    assert warn_outside_training_range(model, np.linspace(-0.1, 0.1, 11)) is None
    msg = warn_outside_training_range(model, np.array([-0.12, 0.0, 0.05, 0.2]))
    assert msg.startswith("2 of 4 positions (50.0%) lie outside the training range [-0.1, 0.1] m")
    combined = CombinedModel.from_coil_sets([model, model.with_range(-0.05, 0.1)])
    assert "[-0.05, 0.1] m" in warn_outside_training_range(combined, np.array([-0.07]))
    assert warn_outside_training_range(model.with_range(None, None), np.array([5.0])) is None


# ------------------------------------------------------------------------- first-layer slope bound


def test_slope_penalty_jacobian_matches_finite_differences():
    from pgcomm.identify.lm import _with_slope_penalty
    from pgcomm.identify.projection import _Eval

    rng = np.random.default_rng(5)
    flats = jnp.asarray(rng.normal(0.0, 3.0, (2, 7)))
    mask = jnp.asarray([True, True, False, True, False, True, True])
    w_max, scale = 2.0, 3.5
    n = flats.shape[1]
    zero = _Eval(jnp.zeros(2), *(jnp.zeros(2) for _ in range(4)), jnp.zeros((2, 1, 3)), jnp.zeros((2, n, n)),
                 jnp.zeros((2, n)))
    ev = _with_slope_penalty(zero, flats, mask, w_max, scale)
    # f = ½ Σ r², r = scale·max(|w| - w_max, 0) on the mask: Jᵀr = ∇f (finite differences)
    f = lambda x: float(_with_slope_penalty(zero, x[None], mask, w_max, scale).f[0])  # noqa: E731
    h = 1e-6
    for s in range(2):
        x = np.asarray(flats[s])
        grad = [(f(jnp.asarray(x + h * e)) - f(jnp.asarray(x - h * e))) / (2 * h) for e in np.eye(n)]
        np.testing.assert_allclose(np.asarray(ev.jtr[s]), grad, rtol=0, atol=1e-6 * scale**2 * np.abs(x).max())
    # Gauss-Newton JᵀJ: diagonal scale² where the bound is active, 0 elsewhere
    active = np.asarray(mask) & (np.abs(np.asarray(flats)) > w_max)
    np.testing.assert_allclose(np.asarray(jnp.diagonal(ev.jtj, axis1=1, axis2=2)), scale**2 * active, rtol=1e-15)


def test_slope_bound_keeps_first_layer_within_the_supported_width(data):
    # a bound of 3 pole pitches (10-90 % width) is far below what an unbounded fit uses here
    r = idf.identify(data, D_M, idf.IdentifyOptions(gain_widths=(2,), cog_widths=(8,), starts=2, max_iterations=20,
                                                 subsample=1, min_feature_width=3.0), seed=1, check_data=False)
    free = idf.identify(data, D_M, idf.IdentifyOptions(gain_widths=(2,), cog_widths=(8,), starts=2, max_iterations=20,
                                                    subsample=1, min_feature_width=0.0), seed=1, check_data=False)
    mask = _Layout.of(r.model).first_layer_weight_mask()
    w = np.abs(np.asarray(idf.hidden_vector(r.model)))[mask]
    w_free = np.abs(np.asarray(idf.hidden_vector(free.model)))[mask]
    assert r.slope_bound == pytest.approx(2 * np.arctanh(0.8) * 0.1 / (3.0 * D_M), rel=0.05)
    assert w_free.max() > 1.5 * r.slope_bound  # the bound is active on these data
    # the penalty makes each unit of excess cost the whole signal power: what remains is tiny
    assert w.max() <= 1.05 * r.slope_bound
    assert r.slope_term < 1e-3 * r.cost_pgnn


def test_width_selection_keeps_the_best_validation_cost(data):
    r = idf_lm.identify_selecting_width(data, D_M, idf.IdentifyOptions(
        gain_width_candidates=(2, 4), cog_widths=(4,), starts=2, max_iterations=8, subsample=1), seed=2, check_data=False)
    widths = [w for w, _ in r.width_selection]
    costs = [c for _, c in r.width_selection]
    assert widths == [2, 4]
    assert r.model.gain_nets[0].widths == (widths[int(np.argmin(costs))],)
    assert r.cost_pgnn_validation == pytest.approx(min(costs), rel=1e-12)
    d = r.to_dict()
    assert d["gain_width"] == r.model.gain_nets[0].widths[0] and len(d["width_selection"]) == 2
