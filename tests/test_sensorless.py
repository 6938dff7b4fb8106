"""Identification without a force sensor: the filter, Proposition 1 and the
projected Jacobian on filtered rows, and recovery of a twin's y row, friction and calibration."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm import identify as idf
from pgcomm.calibration import calibrate_from_datasets
from pgcomm.data import CoilSetData, coil_set_data_from_runs
from pgcomm.errors import DataError
from pgcomm.identify.layout import _Layout, _physics_columns
from pgcomm.models import CoilSetModel
from pgcomm.sensorless import (AccelerationFilter, filter_windows, filtered_acceleration, sensorless_data,
                               window_starts, with_classical_rows)
from test_identify import D_M, assert_normal_equations_match_fd, synthetic_coil_set

TS = 1e-3


# ----------------------------------------------------------------------------------------- filter


def test_filter_is_exact_on_zero_order_hold_motion():
    """A mass under a force held over each sample: ``m ÿ_f`` equals the filtered force exactly.

    Closed form of the sampled motion: ``y+ = y + v T + F T²/(2m)``, ``v+ = v + F T/m``; the
    second difference is ``T²/(2m)(F[i-1] + F[i])``, which the half-sample average of the
    regressor taps reproduces.
    """
    rng = np.random.default_rng(0)
    m, n = 23.0, 4000
    force = np.cumsum(rng.normal(size=n)) + 5 * np.sin(np.arange(n) * 0.01)
    y, v = np.zeros(n), np.zeros(n)
    for i in range(n - 1):
        y[i + 1] = y[i] + v[i] * TS + force[i] * TS**2 / (2 * m)
        v[i + 1] = v[i] + force[i] * TS / m
    for taps in (8, 21):
        filt = AccelerationFilter.of_length(taps, TS)
        starts = window_starts(filt, np.zeros(n, int))
        lhs = m * filtered_acceleration(filt, starts, y)
        rhs = filter_windows(filt, starts, force)
        # rounding of y (|y| ~ max) enters Δ² amplified by m / T²
        tol = 1e3 * np.finfo(float).eps * np.abs(y).max() * m / TS**2
        np.testing.assert_allclose(lhs, rhs, rtol=0, atol=tol)


def test_filter_taps_and_windows():
    filt = AccelerationFilter.of_length(12, TS)
    assert filt.taps.sum() == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(filt.taps, filt.taps[::-1], rtol=0, atol=1e-15)  # zero phase
    assert filt.regressor_taps.sum() == pytest.approx(1.0, abs=1e-15)
    labels = np.repeat([0, 1, 2], [100, 7, 200])
    keep = np.ones(labels.size, bool)
    keep[150:160] = False
    starts = window_starts(filt, labels, keep)
    assert starts.size > 0
    for s in starts:  # never across a label change or an excluded sample
        w = np.arange(s, s + filt.span)
        assert np.unique(labels[w]).size == 1 and keep[w].all()
    # no window fits the 7-sample segment
    assert not np.any((starts >= 100) & (starts < 107))


# ------------------------------------------------------------------- Proposition 1 and the Jacobian


@pytest.fixture(scope="module")
def sdata():
    return sensorless_data(synthetic_coil_set(), TS, D_M, 30.0)


def _model(sd, seed=0, gain=(2,), cog=(3,)):
    a, b = idf.fit_physics(sd, D_M)
    return CoilSetModel.init(jax.random.PRNGKey(seed), CoilSetModel.physics(a, b, D_M, 0.0, 0.1), gain, cog)


def test_proposition1_matches_lstsq_on_the_filtered_regressor(sdata):
    """Second formulation: the whole filtered regressor (model columns and friction) by numpy lstsq."""
    sd = sdata
    model = _model(sd)
    lam12 = np.full(12, 0.1)
    star = idf.theta_phy(*idf.fit_physics(sd, D_M))
    res = idf.proposition1(model, sd, lam12, star, damping=0.0)
    raw = sd.raw
    m = np.asarray(idf.regressor(model, raw.y, raw.currents))
    nk = _Layout.of(model).n_known
    nf = sd.n_friction
    mf = sd.filtered(m)
    mf = np.concatenate([mf[:, :nk], sd.filtered_friction(), mf[:, nk:]], axis=1)
    n, p = mf.shape
    ref = []
    for q in range(3):
        cols = _physics_columns(q)
        w, tgt = np.zeros(p), np.zeros(p)
        w[:4], tgt[:4] = lam12[cols], star[cols]
        a = np.vstack([mf, np.sqrt(n) * np.diag(w)])
        ref.append(np.linalg.lstsq(a, np.concatenate([sd.force[:, q], np.sqrt(n) * w * tgt]), rcond=None)[0])
    ref = np.stack(ref, axis=1)
    np.testing.assert_allclose(res.theta_L, ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    np.testing.assert_allclose(res.friction, ref[nk:nk + nf, 0], rtol=0, atol=1e-9 * np.abs(ref).max())
    # the model carries no friction rows; its y cost with that friction is the reported data term
    assert idf.cost(res.model, sd, lam12, star, friction=res.friction).data == pytest.approx(
        res.cost_data, rel=1e-9)


@pytest.mark.parametrize("gain,cog,method", [((2,), (3,), "structured"), ((2, 2), (3,), "generic")])
def test_projected_jacobian_matches_finite_differences(sdata, gain, cog, method):
    sub = sdata.take(slice(None, None, 4))
    assert_normal_equations_match_fd(_model(sub, seed=3, gain=gain, cog=cog), sub, method)


def test_direction_term_is_refused_without_force_sensor(sdata):
    with pytest.raises(ValueError, match="Coulomb"):
        idf.identify(sdata, D_M, idf.IdentifyOptions(direction=True, starts=1, max_iterations=1), check_data=False)


# ------------------------------------------------------------------------------------ bad input


def _moving(n=3000, speed=0.1, accel=True):
    t = np.arange(n) * TS
    y = 0.05 * np.sin(2 * np.pi * t / 2.0) if accel else -0.1 + speed * t
    cur = np.column_stack([np.sin(t), np.cos(t)])
    return CoilSetData(y, cur, np.zeros((n, 3)), name="coil set 1 (log.csv)")


def test_bad_input_names_what_is_missing():
    with pytest.raises(DataError, match=r"no acceleration above 0\.2 m/s\^2 in Z_1"):
        sensorless_data(_moving(accel=False), TS, D_M, 30.0)
    with pytest.raises(DataError, match="too short or too slow"):
        sensorless_data(_moving(n=12), TS, D_M, 30.0)
    with pytest.raises(DataError, match="mass"):
        sensorless_data(_moving(), TS, D_M, None)
    d = _moving()
    sat = CoilSetData(d.y, np.clip(d.currents * 20, -10, 10), d.force, name=d.name)
    with pytest.raises(DataError, match=r"log\.csv.*limit 10 A"):
        sensorless_data(sat, TS, D_M, 30.0, current_limit=10.0)


# ------------------------------------------------------------------------------ on the twin


@pytest.fixture(scope="module")
def twin_run():
    """Coil set 1 of the twin without its direction-dependent force (then the y row, the friction
    and the mass are all inside the sensorless model class), quick data-generation reference."""
    from dataclasses import replace

    from pgcomm import experiment
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig
    from pgcomm.reproduce import quick_config

    cfg = quick_config(ExperimentConfig())
    cfg = replace(cfg, twin=cfg.twin.without("direction"))
    setup = build_setup(cfg)
    ref = experiment.data_generation_reference(setup)
    runs = experiment.generate(setup, ref, setup.motor.k, setup.motor.zeta, seed=0, coil_sets=[0])
    return setup, runs


def test_twin_y_row_friction_and_calibration_without_force(twin_run):
    setup, runs = twin_run
    mech = setup.config.mechanics
    data = coil_set_data_from_runs(runs)[0]
    sd = sensorless_data(data, TS, setup.motor.pole_pitch, mech.mass, current_limit=setup.motor.current_limit)
    res = idf.identify(sd, setup.motor.pole_pitch, idf.IdentifyOptions(starts=2, max_iterations=40), seed=0)
    y = jnp.linspace(*setup.config.reference.span, 801)
    g_hat = np.asarray(res.model.gain(y))[:, 0, :]
    g = np.asarray(setup.plant.gain(y))[:, 0, 0, :]
    c_hat, c = np.asarray(res.model.cogging(y))[:, 0], np.asarray(setup.plant.cogging(y))[:, 0]
    # the y row against the twin's truth, relative to the size of the true gain / cogging
    assert np.sqrt(np.mean((g_hat - g) ** 2) / np.mean(g**2)) < 0.02
    assert np.sqrt(np.mean((c_hat - c) ** 2)) < 0.1 * np.sqrt(np.mean(c**2))
    me = res.mechanics
    assert me.coulomb == pytest.approx(mech.coulomb, rel=0.05)
    assert me.viscous == pytest.approx(mech.viscous, rel=0.05)
    # x/z rows become the classical model
    model = with_classical_rows(res.model, 61.0, -0.54, setup.motor.mu, setup.motor.lever_arms[0])
    np.testing.assert_allclose(np.asarray(model.gain(y))[:, 0, :], g_hat, rtol=0, atol=1e-12 * np.abs(g).max())
    assert np.asarray(model.cogging(y))[:, 1:].max() == 0.0
    # calibration from the same runs, no force data: one pass from the nominal values
    step = calibrate_from_datasets(runs, np.asarray(setup.motor.k), np.asarray(setup.motor.zeta),
                                   setup.config.calibration.delta, method="sensorless", mass=mech.mass,
                                   pole_pitch=setup.motor.pole_pitch)[0]
    assert step.k == pytest.approx(setup.true_k[0], rel=5e-3)
    assert step.zeta == pytest.approx(setup.true_zeta[0], abs=5e-3)


def test_friction_of_a_continuous_velocity_is_filtered_without_the_half_sample_shift():
    """Viscous friction acts on the continuous velocity: ``Δ²y`` weighs it by a triangle centred on
    the middle sample. Exact closed form for ``m ÿ = F - c v`` with held ``F``: integrate it
    finely and check that the filtered equation holds to the integration error."""
    rng = np.random.default_rng(1)
    m, c, n, sub = 20.0, 60.0, 3000, 200
    force = 30 * np.sin(np.arange(n) * 0.02) + rng.normal(size=n)
    y, v = np.zeros(n), np.zeros(n)
    h = TS / sub
    yy, vv = 0.0, 0.0
    for i in range(n):
        y[i], v[i] = yy, vv
        for _ in range(sub):  # exact for the linear ODE over one sub-step
            a = np.exp(-c * h / m)
            v_new = force[i] / c + (vv - force[i] / c) * a
            yy += force[i] / c * h + (vv - force[i] / c) * m / c * (1 - a)
            vv = v_new
    data = CoilSetData(y, np.zeros((n, 2)), np.zeros((n, 3)), velocity=v)
    filt = AccelerationFilter.of_length(16, TS)
    starts = window_starts(filt, np.zeros(n, int))
    lhs = m * filtered_acceleration(filt, starts, y)
    idx = starts[:, None] + 1 + np.arange(filt.length)
    rhs = filter_windows(filt, starts, force) - c * (v[idx] @ filt.taps)
    shifted = filter_windows(filt, starts, force) - c * filter_windows(filt, starts, v)
    scale = np.abs(force).max()
    err, err_shifted = np.abs(lhs - rhs).max(), np.abs(lhs - shifted).max()
    assert err < 1e-3 * scale
    assert err < 0.2 * err_shifted  # the half-sample average on friction is measurably worse
