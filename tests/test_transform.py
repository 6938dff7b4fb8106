"""Tests of the current <-> drive-input transformation (Γ, T, T^{-1}; eq. Current_To_ForceDelta)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.commutation import (
    classical_single_direction,
    currents_to_drive_inputs,
    drive_currents,
    gamma,
    gamma_inverse,
    transform_T,
    transform_T_inverse,
)

POLE_PITCH = 0.03
K_HAT = np.array([67.0, 61.0, 55.5])
ZETA_HAT = np.array([-0.52, 0.3, 2.9])


def _wrap(a):
    """Angle to (-π, π]."""
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


@pytest.mark.parametrize("k_hat, zeta_hat", [(67.0, -0.52), (1.0, 0.0), (123.4, 3.0)])
def test_gamma_times_inverse_is_identity(k_hat, zeta_hat, rng):
    y = rng.uniform(-0.2, 0.2, 60)
    g = np.asarray(gamma(y, k_hat, zeta_hat, POLE_PITCH))
    gi = np.asarray(gamma_inverse(y, k_hat, zeta_hat, POLE_PITCH))
    eye = np.broadcast_to(np.eye(2), g.shape)
    np.testing.assert_allclose(g @ gi, eye, rtol=0, atol=1e-12)
    np.testing.assert_allclose(gi @ g, eye, rtol=0, atol=1e-12)
    # determinant -(√3/2)/k̂²: invertible everywhere
    np.testing.assert_allclose(np.linalg.det(g), -(np.sqrt(3) / 2) / k_hat**2, rtol=1e-12)


DELTAS = {
    "zero": 0.0,
    "small": 1e-3,
    "mid_pos": 1.2,
    "mid_neg": -2.0,
    "pi_exact": np.pi,
    "near_pi": np.pi - 1e-10,
    "near_minus_pi": -np.pi + 1e-10,
    "near_pi_9": np.pi - 9e-10,
    "near_minus_pi_9": -np.pi + 9e-10,
    "half_pi": np.pi / 2,
    "minus_half_pi": -np.pi / 2,
    "near_half_pi_above": np.pi / 2 + 1e-10,
    "near_half_pi_below": np.pi / 2 - 1e-10,
}


def _fold(fy, delta):
    """The convention spelled out: Δ wrapped to (-π, π], then folded by π onto (-π/2, π/2] with the sign in Fy."""
    d = _wrap(delta)
    flip = (d > np.pi / 2) | (d <= -np.pi / 2)
    return np.where(flip, -fy, fy), np.where(d > np.pi / 2, d - np.pi, np.where(d <= -np.pi / 2, d + np.pi, d))


@pytest.mark.parametrize("name", list(DELTAS))
@pytest.mark.parametrize("fy", [1e-6, 1.0, 250.0, -3.0])
def test_T_inverse_inverts_T(name, fy):
    """``T^{-1}`` returns an equivalent pair (same ``(F1*, F2*)``) in the convention: |Fy*| kept, Δ in (-π/2, π/2]."""
    delta = DELTAS[name]
    f12 = transform_T(jnp.asarray(fy), jnp.asarray(delta))
    fy_back, d_back = (float(v) for v in transform_T_inverse(f12))
    assert -np.pi / 2 < d_back <= np.pi / 2
    assert abs(fy_back) == pytest.approx(abs(fy), rel=1e-12)
    again = np.asarray(transform_T(jnp.asarray(fy_back), jnp.asarray(d_back)))
    np.testing.assert_allclose(again, np.asarray(f12), rtol=0, atol=1e-12 * abs(fy))
    # away from the fold's boundary (|Δ| = π/2, where rounding picks the side) the pair is the spelled-out one
    if abs(abs(_wrap(delta)) - np.pi / 2) > 1e-6:
        want_fy, want_d = _fold(fy, delta)
        assert fy_back == pytest.approx(float(want_fy), rel=1e-12)
        assert d_back == pytest.approx(float(want_d), abs=1e-9)


@pytest.mark.parametrize("f12, want", [
    ((0.0, 1.0), (1.0, np.pi / 2)),      # the boundary belongs to the positive side
    ((0.0, -1.0), (-1.0, np.pi / 2)),
    ((-0.0, 2.0), (2.0, np.pi / 2)),
    ((-1.0, 0.0), (-1.0, 0.0)),          # atan2 = π: folded
    ((-1.0, -0.0), (-1.0, 0.0)),         # atan2 = -π: folded as well
    ((1.0, -0.0), (1.0, 0.0)),
    ((0.0, 0.0), (0.0, 0.0)),            # zero force: (0, 0) whatever the zeros' signs
    ((-0.0, 0.0), (0.0, 0.0)),
    ((-0.0, -0.0), (0.0, 0.0)),
    ((0.0, -0.0), (0.0, 0.0)),
])
def test_T_inverse_boundary_and_zero_force(f12, want):
    fy, d = (float(v) for v in transform_T_inverse(jnp.asarray(f12)))
    assert fy == want[0] and d == pytest.approx(want[1], abs=1e-15)
    assert -np.pi / 2 < d <= np.pi / 2
    if want[0] == 0.0:
        assert not np.signbit(fy) and d == 0.0


def test_T_inverse_vectorised_and_zero_force(rng):
    fy = rng.uniform(-100.0, 100.0, (4, 5))
    delta = rng.uniform(-np.pi, np.pi, (4, 5))
    fy[0, 0] = 0.0
    f12 = transform_T(jnp.asarray(fy), jnp.asarray(delta))
    assert f12.shape == (4, 5, 2)
    fb, db = (np.asarray(v) for v in transform_T_inverse(f12))
    assert fb.shape == db.shape == (4, 5)
    want_fy, want_d = _fold(fy, delta)
    np.testing.assert_allclose(fb, want_fy, rtol=0, atol=1e-13 * np.abs(fy).max())
    mask = fy != 0
    np.testing.assert_allclose(db[mask], want_d[mask], rtol=0, atol=1e-12)
    assert np.all((db > -np.pi / 2) & (db <= np.pi / 2))
    assert fb[0, 0] == 0.0 and db[0, 0] == 0.0


def test_drive_currents_equal_gamma_times_T(rng):
    y = rng.uniform(-0.1, 0.1, 60)
    fy = rng.normal(size=(60, 3)) * 80.0
    delta = rng.uniform(-np.pi, np.pi, (60, 3))
    got = np.asarray(drive_currents(y, fy, delta, jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT), POLE_PITCH))
    assert got.shape == (60, 3, 2)
    g = np.asarray(gamma(y[:, None], jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT), POLE_PITCH))  # (60, 3, 2, 2)
    t = np.asarray(transform_T(jnp.asarray(fy), jnp.asarray(delta)))                          # (60, 3, 2)
    np.testing.assert_allclose(got, np.einsum("nlij,nlj->nli", g, t), rtol=0, atol=1e-12 * np.abs(got).max())


def test_drive_inputs_round_trip_keeps_the_sign_in_the_force(rng):
    """Inputs already in the convention (any sign of Fy*, Δ in (-π/2, π/2)) come back unchanged."""
    y = rng.uniform(-0.1, 0.1, 60)
    fy = rng.uniform(0.1, 150.0, (60, 3)) * rng.choice([-1.0, 1.0], (60, 3))
    delta = rng.uniform(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3, (60, 3))
    k, z = jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT)
    cur = drive_currents(y, fy, delta, k, z, POLE_PITCH)
    fy_b, d_b = (np.asarray(v) for v in currents_to_drive_inputs(jnp.asarray(y), cur, k, z, POLE_PITCH))
    assert fy_b.shape == d_b.shape == (60, 3)
    np.testing.assert_allclose(fy_b, fy, rtol=0, atol=1e-10 * np.abs(fy).max())
    np.testing.assert_allclose(d_b, delta, rtol=0, atol=1e-10)


def test_drive_inputs_fold_delta_beyond_half_pi_into_the_force_sign(rng):
    """``(Fy*, Δ ± π)`` is the same current as ``(-Fy*, Δ)``: the log shows the latter."""
    y = rng.uniform(-0.1, 0.1, 60)
    fy = rng.uniform(0.1, 150.0, (60, 3))
    delta = rng.uniform(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3, (60, 3))
    k, z = jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT)
    cur = np.asarray(drive_currents(y, fy, delta + np.pi, k, z, POLE_PITCH))
    fy_b, d_b = (np.asarray(v) for v in currents_to_drive_inputs(jnp.asarray(y), jnp.asarray(cur), k, z,
                                                                 POLE_PITCH))
    np.testing.assert_allclose(fy_b, -fy, rtol=0, atol=1e-10 * fy.max())
    np.testing.assert_allclose(d_b, delta, rtol=0, atol=1e-10)
    # equivalent inputs: the same currents
    again = np.asarray(drive_currents(y, fy_b, d_b, k, z, POLE_PITCH))
    np.testing.assert_allclose(again, cur, rtol=0, atol=1e-10 * np.abs(cur).max())


def test_currents_round_trip_through_drive_inputs(rng):
    """Arbitrary star currents -> (Fy*, Δ) -> currents: drive_currents ∘ currents_to_drive_inputs is the identity."""
    y = rng.uniform(-0.1, 0.1, 60)
    cur = rng.normal(size=(60, 3, 2))
    k, z = jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT)
    fy, d = currents_to_drive_inputs(jnp.asarray(y), jnp.asarray(cur), k, z, POLE_PITCH)
    d = np.asarray(d)
    assert np.all((d > -np.pi / 2) & (d <= np.pi / 2))
    assert np.any(np.asarray(fy) < 0) and np.any(np.asarray(fy) > 0)
    back = np.asarray(drive_currents(y, fy, d, k, z, POLE_PITCH))
    np.testing.assert_allclose(back, cur, rtol=0, atol=1e-10 * np.abs(cur).max())


def test_constant_delta_over_a_data_set_while_the_force_reverses(rng):
    """A data set ``Z_1`` (Δ = -π/4 throughout) logs Δ = -π/4 for both signs of the force, Fy* following the demand."""
    n = 400
    y = np.linspace(-0.1, 0.1, n)
    fy = 80.0 * np.sin(np.linspace(0.0, 6 * np.pi, n))            # reverses several times
    k, z = 61.0, -0.55
    cur = drive_currents(y, fy[:, None], np.full((n, 1), -np.pi / 4), k, z, POLE_PITCH)
    fy_b, d_b = (np.asarray(v)[:, 0] for v in currents_to_drive_inputs(jnp.asarray(y), cur, k, z, POLE_PITCH))
    moving = np.abs(fy) > 1e-9 * np.abs(fy).max()
    assert np.sum(fy[moving] < 0) > 100 and np.sum(fy[moving] > 0) > 100
    np.testing.assert_allclose(d_b[moving], -np.pi / 4, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fy_b, fy, rtol=0, atol=1e-12 * np.abs(fy).max())


@pytest.mark.parametrize("l", [0, 1, 2])
def test_drive_with_zero_delta_is_single_coil_set_classical(l, rng):
    y = rng.uniform(-0.1, 0.1, 60)
    fy = rng.normal(size=60) * 100.0
    k, z = K_HAT[l], ZETA_HAT[l]
    got = np.asarray(drive_currents(y, fy[:, None], np.zeros((60, 1)), k, z, POLE_PITCH))
    ref = np.asarray(classical_single_direction(y, fy, jnp.asarray([k]), jnp.asarray([z]), POLE_PITCH))
    assert got.shape == ref.shape == (60, 1, 2)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("f12", [(-1.0, -0.0), "T(-5, 0)"], ids=["minus_zero", "negative_fy_zero_delta"])
def test_T_inverse_keeps_a_negative_force_at_zero_delta(f12):
    """``T(Fy* < 0, Δ = 0) = (Fy*, -0.0)`` comes back as ``(Fy* < 0, 0)``, not as ``(|Fy*|, ±π)``."""
    if f12 == "T(-5, 0)":
        arr = transform_T(jnp.asarray(-5.0), jnp.asarray(0.0))
    else:
        arr = jnp.asarray(f12)
    fy, d = (float(v) for v in transform_T_inverse(arr))
    assert fy == float(arr[0]) < 0
    assert d == 0.0
