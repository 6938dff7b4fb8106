"""Tests of pgcomm.control: feedforward regressor and identification, PID tuning."""

from __future__ import annotations

import numpy as np
import pytest

from pgcomm import trajectory
from pgcomm.control import PID, Feedforward, feedforward_regressor, feedforward_signal, identify_feedforward


@pytest.fixture(scope="module")
def back_and_forth():
    return trajectory.single_velocity_reference(0.15, stroke=0.05, dwell=0.1)


def test_regressor_implements_delta_half_z_plus_one(rng):
    n = 50
    v = rng.normal(size=n)
    a = rng.normal(size=n)
    v[[3, 17]] = 0.0  # sign(0) = 0
    phi = feedforward_regressor(v, a)
    assert phi.shape == (n, 3)
    g = np.stack([a, v, np.sign(v)], axis=-1)
    for k in range(n):
        nxt = g[min(k + 1, n - 1)]  # the reference ends at rest: the last sample is held
        np.testing.assert_allclose(phi[k], 0.5 * (g[k] + nxt), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(phi[-1], g[-1])


@pytest.mark.parametrize("m, fv, fc", [(30.0, 80.0, 40.0), (12.5, 0.0, 3.0), (80.0, 150.0, 0.0)])
def test_identify_feedforward_recovers_parameters_exactly(m, fv, fc, back_and_forth):
    ref = back_and_forth
    force = feedforward_signal(Feedforward(m, fv, fc), ref.v, ref.a)
    phi = feedforward_regressor(ref.v, ref.a)
    np.testing.assert_allclose(force, phi @ [m, fv, fc], rtol=0, atol=1e-12 * np.abs(force).max())
    ff = identify_feedforward(ref.v, ref.a, force)
    assert ff.mass == pytest.approx(m, rel=1e-10, abs=1e-10)
    assert ff.viscous == pytest.approx(fv, rel=1e-10, abs=1e-10)
    assert ff.coulomb == pytest.approx(fc, rel=1e-10, abs=1e-10)


def test_identify_feedforward_is_least_squares_under_noise(back_and_forth, rng):
    ref = back_and_forth
    force = feedforward_signal(Feedforward(30.0, 80.0, 40.0), ref.v, ref.a) + rng.normal(size=len(ref)) * 5.0
    ff = identify_feedforward(ref.v, ref.a, force)
    phi = feedforward_regressor(ref.v, ref.a)
    theta = np.array([ff.mass, ff.viscous, ff.coulomb])
    # normal equations: residual orthogonal to the regressor
    np.testing.assert_allclose(phi.T @ (force - phi @ theta), 0.0, atol=1e-8 * np.abs(phi.T @ force).max())


@pytest.mark.parametrize("mass, f_bw", [(30.0, 6.0), (30.0, 10.0), (5.0, 40.0), (120.0, 2.5)])
def test_pid_tuned_crossover_at_bandwidth(mass, f_bw):
    pid = PID.tuned(mass, f_bw)
    w = 2 * np.pi * f_bw
    s = 1j * w
    c = pid.kp + pid.ki / s + pid.kd * s  # continuous-time PID part
    p = 1.0 / (mass * s**2)
    assert abs(c * p) == pytest.approx(1.0, rel=0.05)
    # and it is a crossover: loop gain above 1 below, below 1 above (one decade around)
    for fac, above in ((0.3, True), (3.0, False)):
        sf = 1j * w * fac
        lf = abs((pid.kp + pid.ki / sf + pid.kd * sf) / (mass * sf**2))
        assert (lf > 1.0) == above
    assert pid.lowpass_hz == pytest.approx(5 * f_bw, rel=1e-15)


def test_pid_lowpass_alpha_is_zoh_pole():
    pid = PID.tuned(30.0, 6.0)
    ts = 1e-3
    assert pid.alpha(ts) == pytest.approx(1.0 - np.exp(-2 * np.pi * 30.0 * ts), rel=1e-14)
