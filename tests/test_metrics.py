"""Tests of pgcomm.metrics: the paper's ZOH low-pass H(z) and the MSE tables."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import cont2discrete, lfilter

from pgcomm.metrics import commutation_mse, lowpass, mse_difference_se, reducible_share, tracking_mse


@pytest.mark.parametrize("sample_time, cutoff_hz", [(1e-3, 50.0), (1e-3, 10.0), (2e-4, 50.0), (5e-3, 20.0)])
def test_lowpass_equals_scipy_zoh_discretisation(sample_time, cutoff_hz, rng):
    w = 2 * np.pi * cutoff_hz
    num, den, _ = cont2discrete(([1.0], [1.0 / w, 1.0]), sample_time, method="zoh")
    x = rng.normal(size=(2000, 3))
    want = lfilter(np.ravel(num), den, x, axis=0)
    got = lowpass(x, sample_time, cutoff_hz)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("sample_time, cutoff_hz", [(1e-3, 50.0), (2e-4, 5.0)])
def test_lowpass_step_response_and_dc_gain(sample_time, cutoff_hz):
    n = 20000
    a = np.exp(-2 * np.pi * cutoff_hz * sample_time)
    step = lowpass(np.ones(n), sample_time, cutoff_hz)
    np.testing.assert_allclose(step, 1.0 - a ** np.arange(n), rtol=0, atol=1e-12)
    assert step[0] == 0.0  # strictly causal: H(z) has a one-sample delay (ZOH)
    assert step[-1] == pytest.approx(1.0, abs=1e-12)  # DC gain 1


def test_lowpass_filters_along_axis0_per_column(rng):
    x = rng.normal(size=(500, 4))
    got = lowpass(x, 1e-3)
    for q in range(4):
        np.testing.assert_allclose(got[:, q], lowpass(x[:, q], 1e-3), rtol=0, atol=0)


def test_commutation_mse_on_known_signal():
    n, ts = 5000, 1e-3
    a = np.exp(-2 * np.pi * 50.0 * ts)
    f_star = np.zeros((n, 3))
    f_star[:, 0] = np.linspace(-100, 100, n)  # any desired force: only the error counts
    err = np.array([2.0, -0.5, 0.0])
    f_meas = f_star + err
    out = commutation_mse(f_meas, f_star, ts)
    assert set(out) == {"y", "x", "z"}
    k = np.arange(n)
    for q, d in enumerate("yxz"):
        assert out[d]["unfiltered"] == pytest.approx(err[q] ** 2, rel=1e-12, abs=1e-300)
        want = np.mean((err[q] * (1 - a**k)) ** 2)  # filtered constant error: step response
        assert out[d]["filtered"] == pytest.approx(want, rel=1e-12, abs=1e-300)


def test_commutation_mse_of_white_noise_matches_filter_variance_gain(rng):
    """White noise of variance σ²: filtered MSE ≈ σ² (1 - a)/(1 + a) (the sensors docstring's formula)."""
    n, ts, sigma = 200_000, 1e-3, 0.8
    a = np.exp(-2 * np.pi * 50.0 * ts)
    noise = rng.normal(size=(n, 3)) * sigma
    out = commutation_mse(noise, np.zeros((n, 3)), ts)
    for d in "yxz":
        assert out[d]["unfiltered"] == pytest.approx(sigma**2, rel=0.02)
        assert out[d]["filtered"] == pytest.approx(sigma**2 * (1 - a) / (1 + a), rel=0.03)


def test_tracking_mse_and_reducible_share():
    assert tracking_mse(np.array([1e-4, -1e-4, 2e-4, 0.0])) == pytest.approx(1.5e-8, rel=1e-14)
    assert reducible_share(row=3.0, classical=10.0, oracle=2.0) == pytest.approx(7.0 / 8.0, rel=1e-15)
    assert reducible_share(1.0, 2.0, 2.0) is None  # nothing to reduce
    # reported only where classical - oracle >= max(5 se, 0.2 oracle)
    assert reducible_share(row=3.0, classical=10.0, oracle=2.0, se=1.6) == pytest.approx(7.0 / 8.0, rel=1e-15)
    assert reducible_share(row=3.0, classical=10.0, oracle=2.0, se=1.61) is None
    assert reducible_share(row=3.0, classical=11.9, oracle=10.0) is None


def test_mse_difference_se_matches_independent_blocks():
    # two runs whose squared-error difference is white with known variance: SE = sd / sqrt(N)
    rng = np.random.default_rng(3)
    n, block = 200_000, 100
    a = rng.normal(0.0, 2.0, n)
    b = rng.normal(0.0, 1.0, n)
    d_var = np.var(a**2) + np.var(b**2)  # 2·σ_a⁴ + 2·σ_b⁴ = 32 + 2 for independent Gaussians
    se = mse_difference_se(a, b, block)
    assert se == pytest.approx(np.sqrt(34.0 / n), rel=0.1)
    assert np.sqrt(d_var / n) == pytest.approx(np.sqrt(34.0 / n), rel=0.1)
    assert mse_difference_se(a[:150], b[:150], block) == np.inf
