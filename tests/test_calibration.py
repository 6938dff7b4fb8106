"""Tests of pgcomm.calibration (Algorithm 1) and the data sets it runs on."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from pgcomm import trajectory
from pgcomm.calibration import CalibrationOptions, calibrate, calibrate_from_datasets, fit_coefficients, update
from pgcomm.data import generate_datasets
from pgcomm.simulate import ClosedLoop
from pgcomm.errors import DataError
from pgcomm.sensors import Sensors
from pgcomm.twin import DEFAULT_TWIN

EFFECTS = ("imbalance", "field", "harmonics", "out_of_plane", "cogging", "direction")
TWIN0 = DEFAULT_TWIN.without(*EFFECTS)
NO_NOISE = Sensors(encoder_resolution=0.0, force_noise=(0.0, 0.0, 0.0))
K0, ZETA0 = 67.0, -0.52
DELTA = np.pi / 4


def _c(k, zeta, k_hat, zeta_hat_i):
    """Ideal coefficient ``c_i = (k/k̂) cos(ζ - ζ̂_i)`` (eq. Generated_Forces_Ideal)."""
    return k / k_hat * np.cos(zeta - zeta_hat_i)


# ---------------------------------------------------------------------------
# update equations against the closed form
# ---------------------------------------------------------------------------

# (k, zeta, k_hat, zeta_hat, delta)
UPDATE_CASES = {
    "paper_values": (61.34, -0.54, 67.0, -0.52, np.pi / 4),
    "small_delta": (61.62, -0.55, 67.0, -0.52, 0.05),
    "negative_delta": (60.07, -0.55, 55.0, -0.3, -np.pi / 4),
    "large_phase_error": (40.0, 1.0, 60.0, 0.2, 0.6),
    "k_hat_low": (70.0, 2.5, 50.0, 2.9, np.pi / 3),
}


@pytest.mark.parametrize("name", list(UPDATE_CASES))
def test_update_recovers_k_zeta_from_ideal_coefficients(name):
    k, zeta, k_hat, zeta_hat, delta = UPDATE_CASES[name]
    c1 = _c(k, zeta, k_hat, zeta_hat - delta)
    c2 = _c(k, zeta, k_hat, zeta_hat + delta)
    k_new, zeta_new = update(c1, c2, k_hat, zeta_hat, delta)
    assert k_new == pytest.approx(k, rel=1e-12)
    assert zeta_new == pytest.approx(zeta, rel=0, abs=1e-12)


def test_update_rejects_zero_c1():
    with pytest.raises(DataError, match="c1"):
        update(0.0, 0.5, 67.0, -0.52, DELTA)


# ---------------------------------------------------------------------------
# coefficient fits
# ---------------------------------------------------------------------------


def _synthetic_pair(rng, c1, c2, n=2000, offset=None, direction=0.0):
    t = np.arange(n) * 1e-3
    y = 0.09 * np.sin(2 * np.pi * 0.7 * t)  # back and forth over the stroke
    fs1 = 60 * np.sin(2 * np.pi * 1.3 * t) + 20 * rng.normal(size=n)
    fs2 = 55 * np.cos(2 * np.pi * 1.1 * t) + 20 * rng.normal(size=n)
    sgn = np.sign(np.gradient(y))
    extra = (0.0 if offset is None else offset(y)) + direction * sgn
    return (c1 * fs1 + extra, fs1, y), (c2 * fs2 + extra, fs2, y)


@pytest.mark.parametrize("method, pole_pitch", [("paper", None), ("offset", None), ("offset", 0.03)],
                         ids=["paper", "offset", "offset_ripple"])
def test_fit_coefficients_exact_on_proportional_data(method, pole_pitch, rng):
    (f1, s1, y1), (f2, s2, y2) = _synthetic_pair(rng, 0.83, 0.41)
    c1, c2 = fit_coefficients((f1, s1, y1), (f2, s2, y2), CalibrationOptions(method=method), pole_pitch=pole_pitch)
    assert c1 == pytest.approx(0.83, rel=1e-12)
    assert c2 == pytest.approx(0.41, rel=1e-12)


def test_offset_method_removes_position_offset_and_direction_term(rng):
    knots_lo, knots_hi, n_bins = -0.09, 0.09, 40
    weights = rng.normal(size=n_bins + 1) * 3.0

    def offset(y):  # piecewise linear on the fit's knots: inside the "offset" model class
        return np.interp(y, np.linspace(knots_lo, knots_hi, n_bins + 1), weights) + 2.5

    (f1, s1, y1), (f2, s2, y2) = _synthetic_pair(rng, 0.83, 0.41, offset=offset, direction=1.5)
    c1, c2 = fit_coefficients((f1, s1, y1), (f2, s2, y2),
                              CalibrationOptions(method="offset", n_bins=n_bins, y_range=(knots_lo, knots_hi)))
    assert c1 == pytest.approx(0.83, rel=1e-9)
    assert c2 == pytest.approx(0.41, rel=1e-9)
    p1, p2 = fit_coefficients((f1, s1, y1), (f2, s2, y2), CalibrationOptions(method="paper"))
    assert abs(p1 - 0.83) > 1e-4 or abs(p2 - 0.41) > 1e-4  # eq. Ci alone is biased by the offsets


def test_fit_coefficients_rejects_zero_demand(rng):
    z = np.zeros(10)
    with pytest.raises(DataError, match="zero"):
        fit_coefficients((z, z, z), (z + 1, z + 1, z), CalibrationOptions(method="paper"))
    with pytest.raises(ValueError, match="method"):
        CalibrationOptions(method="magic")


# ---------------------------------------------------------------------------
# Algorithm 1 on noise-free twin data
# ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def reference():
    return trajectory.single_velocity_reference(0.15)


@pytest.fixture(scope="module")
def drive0():
    return TWIN0.motor(k_hat=K0, zeta_hat=ZETA0)


@pytest.fixture(scope="module")
def plant0():
    return TWIN0.plant()


@pytest.fixture(scope="module")
def datasets0(plant0, drive0, reference):
    return generate_datasets(plant0, drive0, reference, delta=DELTA, loop=ClosedLoop(sensors=NO_NOISE))


def test_datasets_layout(datasets0, drive0):
    assert len(datasets0) == drive0.n_coil_sets
    for l, pair in enumerate(datasets0):
        assert len(pair) == 2
        assert [z.coil_set for z in pair] == [l, l]
        assert [z.delta for z in pair] == [-DELTA, DELTA]  # Z_1: ζ̂ - Δ, Z_2: ζ̂ + Δ
        for z in pair:
            cur = z.result.currents
            others = [m for m in range(drive0.n_coil_sets) if m != l]
            np.testing.assert_array_equal(cur[:, others, :], 0.0)  # only the active coil set
            assert np.abs(cur[:, l, :]).max() > 0.1
            # the logged drive inputs of the active coil set are (Fy*, Δ): the sign stays in the force, and
            # Δ is the data set's one offset throughout, for both signs of the force (no jump by π)
            fs = z.result.f_star[:, 0]
            np.testing.assert_allclose(z.result.drive_fy[:, l], fs, rtol=0, atol=1e-12 * np.abs(fs).max())
            moving = np.abs(fs) > 1e-6 * np.abs(fs).max()
            assert np.sum(fs[moving] > 0) > 100 and np.sum(fs[moving] < 0) > 100
            np.testing.assert_allclose(z.result.drive_delta[moving, l], z.delta, rtol=0, atol=1e-9)
            assert z.columns()["active_coil_set"][0] == l + 1


def test_datasets_follow_ideal_coefficients(datasets0):
    """Effect-free twin, exact sensors: F_y = (k/k̂) cos(ζ - ζ̂_i) F_y* sample by sample."""
    for l, pair in enumerate(datasets0):
        for z in pair:
            c = _c(TWIN0.k[l], TWIN0.zeta[l], K0, ZETA0 + z.delta)
            fs = z.result.f_star[:, 0]
            np.testing.assert_allclose(z.result.f_meas[:, 0], c * fs, rtol=0, atol=1e-10 * np.abs(fs).max())


@pytest.mark.parametrize("method, pole_pitch", [("paper", None), ("offset", None)], ids=["paper", "offset"])
def test_algorithm1_recovers_k_zeta_on_noise_free_twin(method, pole_pitch, datasets0):
    k_hat = np.full(3, K0)
    zeta_hat = np.full(3, ZETA0)
    steps = calibrate_from_datasets(datasets0, k_hat, zeta_hat, DELTA, method=method, pole_pitch=pole_pitch)
    assert [s.coil_set for s in steps] == [0, 1, 2]
    np.testing.assert_allclose([s.k for s in steps], TWIN0.k, rtol=1e-9)
    np.testing.assert_allclose([s.zeta for s in steps], TWIN0.zeta, rtol=0, atol=1e-9)
    for s in steps:
        assert s.c1 == pytest.approx(_c(TWIN0.k[s.coil_set], TWIN0.zeta[s.coil_set], K0, ZETA0 - DELTA), rel=1e-9)
        assert s.c2 == pytest.approx(_c(TWIN0.k[s.coil_set], TWIN0.zeta[s.coil_set], K0, ZETA0 + DELTA), rel=1e-9)


def test_calibrate_iterates_on_twin_and_stops(plant0, drive0, reference):
    calls = []

    def generate(k_hat, zeta_hat):
        calls.append((k_hat.copy(), zeta_hat.copy()))
        return generate_datasets(plant0, drive0.with_nominal(k=k_hat, zeta=zeta_hat), reference, delta=DELTA,
                                 loop=ClosedLoop(sensors=NO_NOISE))

    res = calibrate(generate, np.full(3, K0), np.full(3, ZETA0),
                    CalibrationOptions(delta=DELTA, iterations=5, tol=1e-6, method="paper"))
    # the first pass is already exact on the effect-free twin, the second changes nothing: stop
    assert res.iterations == 2 and len(res.history) == 2 and len(calls) == 2
    np.testing.assert_allclose(res.k, TWIN0.k, rtol=1e-9)
    np.testing.assert_allclose(res.zeta, TWIN0.zeta, atol=1e-9)
    np.testing.assert_allclose(calls[1][0], TWIN0.k, rtol=1e-9)  # second pass ran with the update
    np.testing.assert_array_equal(res.k_initial, K0)
    np.testing.assert_array_equal(res.zeta_initial, ZETA0)


# ---------------------------------------------------------------------------
# calibrate(): stopping rule on synthetic data
# ---------------------------------------------------------------------------

K_TRUE = np.array([61.34, 61.62, 60.07])
ZETA_TRUE = np.array([-0.54, -0.55, -0.55])


def _moving_truth_generator(rng):
    """``generate`` whose truth at call ``c`` is ``k* (1 + 10^-c)``, ``ζ* + 10^-c``; ideal, noise-free data."""
    calls = []
    n = 500
    y = np.linspace(-0.1, 0.1, n)

    def generate(k_hat, zeta_hat):
        calls.append(1)
        c = len(calls)
        k_t, z_t = K_TRUE * (1 + 10.0**-c), ZETA_TRUE + 10.0**-c
        out = []
        for l in range(3):
            pair = []
            for sgn in (-1.0, 1.0):
                fs = rng.normal(size=n) * 50
                fy = _c(k_t[l], z_t[l], k_hat[l], zeta_hat[l] + sgn * DELTA) * fs
                f = np.zeros((n, 3))
                f[:, 0] = fy
                fstar = np.zeros((n, 3))
                fstar[:, 0] = fs
                res = SimpleNamespace(f_meas=f, f_star=fstar, y_meas=y, sample_time=1e-3)
                pair.append(SimpleNamespace(coil_set=l, delta=sgn * DELTA, result=res))
            out.append(pair)
        return out

    return generate, calls


@pytest.mark.parametrize("tol, expected", [(1e-4, 5), (1e-2, 3), (1.0, 1), (-1.0, 7)])
def test_calibrate_stops_when_change_below_tol(tol, expected, rng):
    # Pass 1 moves ζ̂ from -0.52 to ζ* + 0.1 (change 0.08, k̂ changes 0.7 %); pass c >= 2 changes
    # max(Δk̂/k̂, Δζ̂) = 0.9·10^-(c-1) (the ζ̂ step dominates). So tol = 1 stops after pass 1,
    # tol = 1e-2 after pass 3 (9e-3), tol = 1e-4 after pass 5 (9e-5); tol < 0 never stops early.
    generate, calls = _moving_truth_generator(rng)
    seen = []
    res = calibrate(generate, np.full(3, K0), np.full(3, ZETA0),
                    CalibrationOptions(delta=DELTA, iterations=7, tol=tol, method="paper"),
                    progress=lambda it, k, z: seen.append(it))
    assert res.iterations == expected == len(calls) == len(res.history)
    assert seen == list(range(1, expected + 1))
    c = expected
    np.testing.assert_allclose(res.k, K_TRUE * (1 + 10.0**-c), rtol=1e-12)
    np.testing.assert_allclose(res.zeta, ZETA_TRUE + 10.0**-c, rtol=0, atol=1e-12)
