"""Tests of pgcomm.twin: the digital twin's electromagnetic truth."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.motor import Motor, ideal_gain
from pgcomm.plant import plant_force
from pgcomm.twin import DEFAULT_TWIN, TwinParams, true_fundamental

EFFECTS = ("imbalance", "field", "harmonics", "out_of_plane", "cogging", "direction")

#: what the ideal model still contains when all switchable effects are off
EFFECT_FREE = DEFAULT_TWIN.without(*EFFECTS)


def _ideal_motor(params: TwinParams) -> Motor:
    return Motor(pole_pitch=params.pole_pitch, lever_arms=params.lever_arms, k=params.k, zeta=params.zeta,
                 mu=params.mu)


#: one grid size for all gain evaluations (jitted functions compile once per shape)
N_GRID = 401


@jax.jit
def _evaluate(plant, y):
    """``(gain_phases, gain, cogging)`` of a plant at ``y`` in one compiled call."""
    return plant.gain_phases(y), plant.gain(y), plant.cogging(y)


def _grid(plant):
    return jnp.linspace(*plant.y_range, N_GRID)


@pytest.fixture(scope="module")
def force_jit():
    return jax.jit(lambda p, y, v, i: plant_force(p, y, i, v))


@pytest.fixture(scope="module")
def samples():
    rng = np.random.default_rng(7)
    lo, hi = DEFAULT_TWIN.plant().y_range
    n = 400
    y = rng.uniform(lo, hi, n)
    v = rng.uniform(-0.2, 0.2, n)
    i = rng.normal(size=(n, 3, 2)) * 2.0
    return jnp.asarray(y), jnp.asarray(v), jnp.asarray(i)


def test_without_switches_every_effect_off():
    p = EFFECT_FREE
    assert np.all(np.asarray(p.phase_gain_error) == 0) and np.all(np.asarray(p.phase_angle_error) == 0)
    assert p.field_slope == p.field_curvature == p.field_ripple == p.phase_drift == p.end_drop == 0
    assert p.harmonic_5 == p.harmonic_7 == 0
    assert all(x == 0 for x in p.lateral_offsets)
    for name in ("cog_offset", "cog_slope", "cog_curvature", "cog_wave", "cog_periodic", "direction_force"):
        assert all(x == 0 for x in getattr(p, name)), name
    # fundamental and out-of-plane coupling untouched
    assert p.k == DEFAULT_TWIN.k and p.zeta == DEFAULT_TWIN.zeta and p.mu == DEFAULT_TWIN.mu
    with pytest.raises(ValueError, match="unknown twin effect"):
        DEFAULT_TWIN.without("magic")


@pytest.mark.parametrize("params", [EFFECT_FREE,
                                    dataclasses.replace(EFFECT_FREE, k=(50.0, 60.0, 70.0), zeta=(0.1, -2.0, 3.0),
                                                        mu=0.2, lever_arms=(-0.1, 0.0, 0.02))],
                         ids=["default_fundamental", "other_fundamental"])
def test_effect_free_gain_equals_ideal_gain(params):
    plant = params.plant()
    y = _grid(plant)
    _, got, cog = (np.asarray(a) for a in _evaluate(plant, y))
    ref = np.asarray(jax.jit(ideal_gain, static_argnums=1)(y, _ideal_motor(params)))
    assert got.shape == ref.shape == (N_GRID, 3, 3, 2)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    np.testing.assert_array_equal(cog, 0.0)
    np.testing.assert_array_equal(np.asarray(plant.direction_force(y, jnp.full_like(y, 0.1))), 0.0)


def test_effect_free_phase_columns_are_balanced():
    """Without imbalance/harmonics the three phase columns sum to zero (star connection is lossless)."""
    plant = EFFECT_FREE.plant()
    y = _grid(plant)
    g = np.asarray(_evaluate(plant, y)[0])
    np.testing.assert_allclose(g.sum(axis=-1), 0.0, atol=1e-12 * np.abs(g).max())
    gi = np.asarray(_evaluate(DEFAULT_TWIN.without(*(e for e in EFFECTS if e != "imbalance")).plant(), y)[0])
    assert np.abs(gi.sum(axis=-1)).max() > 1e-3 * np.abs(gi).max()


@pytest.mark.parametrize("effect", EFFECTS)
def test_each_effect_changes_the_force(effect, force_jit, samples):
    y, v, i = samples
    off = EFFECT_FREE.plant()
    on = DEFAULT_TWIN.without(*(e for e in EFFECTS if e != effect)).plant()
    diff = np.asarray(force_jit(on, y, v, i) - force_jit(off, y, v, i))
    # at least 0.01 N (or N*m) somewhere, in the driving force or torque
    assert np.abs(diff).max() > 1e-2, effect
    if effect != "out_of_plane":  # lateral offsets act on Tz only
        assert np.abs(diff[:, 0]).max() > 1e-2, effect


def test_each_effect_is_switched_by_without_alone(force_jit, samples):
    """Switching one effect off changes the default twin's force (each effect matters in the default)."""
    y, v, i = samples
    full = np.asarray(force_jit(DEFAULT_TWIN.plant(), y, v, i))
    for effect in EFFECTS:
        part = np.asarray(force_jit(DEFAULT_TWIN.without(effect).plant(), y, v, i))
        assert np.abs(part - full).max() > 1e-2, effect


def test_true_fundamental_of_effect_free_twin_is_exact():
    k, zeta = true_fundamental(EFFECT_FREE)
    np.testing.assert_allclose(k, EFFECT_FREE.k, rtol=1e-9)
    np.testing.assert_allclose(zeta, EFFECT_FREE.zeta, rtol=0, atol=1e-9)


def test_true_fundamental_of_default_twin_is_close_to_table():
    """Parasitic effects shift the fundamental a little: within 2 % and 0.05 rad of Table Parameters_CLM."""
    k, zeta = true_fundamental(DEFAULT_TWIN)
    np.testing.assert_allclose(k, DEFAULT_TWIN.k, rtol=2e-2)
    np.testing.assert_allclose(zeta, DEFAULT_TWIN.zeta, atol=5e-2)


def test_torque_row_is_lever_arm_fx_minus_lateral_offset_fy():
    plant = DEFAULT_TWIN.plant()
    y = _grid(plant)
    g = np.asarray(_evaluate(plant, y)[0])  # (N, L, 3, 3)
    d = np.asarray(DEFAULT_TWIN.lever_arms)[None, :, None]
    x = np.asarray(DEFAULT_TWIN.lateral_offsets)[None, :, None]
    np.testing.assert_allclose(g[:, :, 2, :], d * g[:, :, 1, :] - x * g[:, :, 0, :], rtol=0,
                               atol=1e-14 * np.abs(g).max())
    # without lateral offsets: exactly d^l times the Fx row (eq. 8)
    g0 = np.asarray(_evaluate(DEFAULT_TWIN.without("out_of_plane").plant(), y)[0])
    np.testing.assert_allclose(g0[:, :, 2, :], d * g0[:, :, 1, :], rtol=0, atol=1e-14 * np.abs(g0).max())


def test_direction_force_is_odd_in_velocity():
    plant = DEFAULT_TWIN.plant()
    y = np.linspace(-0.1, 0.1, 51)
    v = np.linspace(-0.3, 0.3, 51)  # includes 0
    fp = np.asarray(plant.direction_force(y, v))
    fm = np.asarray(plant.direction_force(y, -v))
    np.testing.assert_allclose(fp, -fm, rtol=0, atol=1e-15)
    # saturates at ± the direction-force amplitude times its variation along the stroke, zero at rest
    tw = DEFAULT_TWIN
    for y0 in (-0.07, 0.0, 0.05):
        ripple = 1.0 + tw.direction_ripple * np.sin(2 * np.pi * y0 / tw.direction_ripple_length + 0.5)
        np.testing.assert_allclose(np.asarray(plant.direction_force(y0, 1.0)),
                                   np.asarray(tw.direction_force) * ripple, rtol=1e-12)
    # its mean along the stroke is the amplitude (what a constant C sign(v) can learn)
    ys = np.linspace(-0.105, 0.105, 200_001)  # three ripple lengths
    np.testing.assert_allclose(np.asarray(plant.direction_force(ys, 1.0)).mean(axis=0), tw.direction_force,
                               rtol=1e-4)
    np.testing.assert_array_equal(np.asarray(plant.direction_force(0.0, 0.0)), 0.0)


@pytest.mark.parametrize("track_ends, lever_arms", [((-0.2, 0.2), (-0.065, 0.005, 0.075)),
                                                    ((-0.5, 0.3), (0.0, 0.1, 0.2)),
                                                    ((-0.1, 0.4), (-0.05, -0.02, -0.01))])
def test_y_range_keeps_coil_sets_on_the_track(track_ends, lever_arms):
    params = dataclasses.replace(DEFAULT_TWIN, track_ends=track_ends, lever_arms=lever_arms)
    plant = params.plant()
    lo, hi = plant.y_range
    d = np.asarray(lever_arms)
    assert lo + d.min() == pytest.approx(track_ends[0], abs=1e-15)
    assert hi + d.max() == pytest.approx(track_ends[1], abs=1e-15)
    assert np.all(lo + d >= track_ends[0] - 1e-15) and np.all(hi + d <= track_ends[1] + 1e-15)
    y = np.array([lo, hi, 0.5 * (lo + hi), lo - 1e-6, hi + 1e-6])
    np.testing.assert_array_equal(np.asarray(plant.in_range(y)), [True, True, True, False, False])


def test_twin_is_jittable_and_vectorised(samples):
    plant = DEFAULT_TWIN.plant()
    y, v, _ = samples
    yb = y[:12].reshape(3, 4)
    gj, _, cj = (np.asarray(a) for a in _evaluate(plant, yb))
    assert gj.shape == (3, 4, 3, 3, 3) and cj.shape == (3, 4, 3)
    for a in range(3):
        for b in range(4):
            gs, _, cs = (np.asarray(x) for x in _evaluate(plant, yb[a, b]))
            np.testing.assert_allclose(gj[a, b], gs, rtol=0, atol=1e-12 * np.abs(gj).max())
            np.testing.assert_allclose(cj[a, b], cs, rtol=0, atol=1e-12 * np.abs(cj).max())
