"""The field-oriented drive's frame (pgcomm.drive_frame) against closed forms.

Tolerances: every quantity is O(1) A or rad, made with a handful of float64 operations, so
agreement is asked to 1e-12 relative to the input scale (rounding is ~1e-15).
"""

from __future__ import annotations

import numpy as np
import pytest

from pgcomm.commutation import drive_currents, transform_T_inverse
from pgcomm.drive_frame import dq_to_drive_inputs, dq_to_phase, drive_inputs_to_dq, electrical_angle, phase_to_dq
from pgcomm.motor import ideal_gain_phases, star_reduce

TOL = 1e-12


@pytest.fixture
def sample(rng):
    n = 2000
    scale = 7.0  # A
    return scale, scale * rng.standard_normal(n), scale * rng.standard_normal(n), rng.uniform(-50.0, 50.0, n)


def test_phase_round_trip(sample):
    scale, iq, id_, eta = sample
    i = np.asarray(dq_to_phase(iq, id_, eta))
    assert i.shape == (iq.size, 2)
    q, d = phase_to_dq(i, eta)
    np.testing.assert_allclose(q, iq, rtol=0, atol=TOL * scale * 50)  # |eta| up to 50 rad: sin/cos lose ~50 ulp
    np.testing.assert_allclose(d, id_, rtol=0, atol=TOL * scale * 50)


def test_textbook_park_clarke_is_this_frame_at_minus_eta(sample):
    scale, iq, id_, eta = sample
    ia, ib = np.asarray(dq_to_phase(iq, id_, eta)).T
    th = -eta
    # textbook inverse Park (amplitude invariant, phase b lagging by 2π/3)
    np.testing.assert_allclose(ia, id_ * np.cos(th) - iq * np.sin(th), atol=TOL * scale * 50)
    np.testing.assert_allclose(ib, id_ * np.cos(th - 2 * np.pi / 3) - iq * np.sin(th - 2 * np.pi / 3),
                               atol=TOL * scale * 50)
    # textbook Clarke + Park of our phase currents give back (i_d, i_q)
    alpha, beta = ia, (ia + 2 * ib) / np.sqrt(3.0)
    np.testing.assert_allclose(alpha * np.cos(th) + beta * np.sin(th), id_, atol=TOL * scale * 50)
    np.testing.assert_allclose(-alpha * np.sin(th) + beta * np.cos(th), iq, atol=TOL * scale * 50)
    # ... or, with the labels b and c swapped (a reflection), this frame at eta + pi with i_d reversed
    ta = id_ * np.cos(eta) - iq * np.sin(eta)  # textbook phases a, b, c at +eta
    tb = id_ * np.cos(eta - 2 * np.pi / 3) - iq * np.sin(eta - 2 * np.pi / 3)
    tc = id_ * np.cos(eta + 2 * np.pi / 3) - iq * np.sin(eta + 2 * np.pi / 3)
    a2, b2 = np.asarray(dq_to_phase(iq, -id_, eta + np.pi)).T
    np.testing.assert_allclose(a2, ta, atol=TOL * scale * 50)
    np.testing.assert_allclose(b2, tc, atol=TOL * scale * 50)
    np.testing.assert_allclose(-(a2 + b2), tb, atol=TOL * scale * 50)


def test_q_axis_makes_the_ideal_force_and_d_axis_none(rng):
    k, zeta, d_m = 61.3, -0.54, 0.03
    y = rng.uniform(-0.1, 0.1, 500)
    eta = 2 * np.pi * y / d_m + zeta
    iq, id_ = rng.uniform(-5, 5, 500), rng.uniform(-5, 5, 500)
    gain = np.asarray(star_reduce(ideal_gain_phases(y, k, zeta, 0.05, 0.0, d_m)))  # (N, 3, 2)
    f = np.einsum("nij,nj->ni", gain, np.asarray(dq_to_phase(iq, id_, eta)))
    np.testing.assert_allclose(f[:, 0], k * iq, atol=TOL * k * 5 * 300)


def test_drive_inputs_are_the_linear_drive_seen_from_dq(rng):
    k, zeta, d_m = 67.0, -0.52, 0.03
    y = rng.uniform(-0.1, 0.1, 800)
    fy, delta = rng.uniform(-300, 300, 800), rng.uniform(-4, 4, 800)
    ref = np.asarray(drive_currents(y, fy[:, None], delta[:, None], k, zeta, d_m))[:, 0]  # one coil set
    iq, id_ = drive_inputs_to_dq(fy, delta, k)
    eta = 2 * np.pi * y / d_m + zeta
    np.testing.assert_allclose(np.asarray(dq_to_phase(iq, id_, eta)), ref, atol=TOL * 300 / k * 50)
    # back to the package's one convention: signed magnitude, delta in (-pi/2, pi/2]
    f2, d2 = dq_to_drive_inputs(iq, id_, k)
    fr, dr = transform_T_inverse(np.stack([fy * np.cos(delta), fy * np.sin(delta)], -1))
    np.testing.assert_allclose(f2, fr, atol=TOL * 300)
    np.testing.assert_allclose(d2, dr, atol=TOL * 10)
    assert np.all(np.asarray(d2) > -np.pi / 2) and np.all(np.asarray(d2) <= np.pi / 2)


def test_q_current_alone_is_delta_zero_with_the_sign_in_the_magnitude():
    f, d = dq_to_drive_inputs(np.array([2.0, -3.0, 0.0]), np.zeros(3))
    np.testing.assert_array_equal(np.asarray(f), [2.0, -3.0, 0.0])
    np.testing.assert_array_equal(np.asarray(d), [0.0, 0.0, 0.0])
    f, d = dq_to_drive_inputs(0.0, -1.5)  # pure d axis: the boundary belongs to +pi/2
    assert float(d) == pytest.approx(np.pi / 2) and float(f) == pytest.approx(-1.5)


def test_electrical_angle():
    np.testing.assert_allclose(np.asarray(electrical_angle(np.array([0.0, 1.0]), 7, 0.25)), [0.25, 7.25])
