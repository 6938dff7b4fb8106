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
}


@pytest.mark.parametrize("name", list(DELTAS))
@pytest.mark.parametrize("fy", [1e-6, 1.0, 250.0])
def test_T_inverse_inverts_T(name, fy):
    delta = DELTAS[name]
    f12 = transform_T(jnp.asarray(fy), jnp.asarray(delta))
    fy_back, d_back = (float(v) for v in transform_T_inverse(f12))
    assert fy_back == pytest.approx(fy, rel=1e-12)
    assert -np.pi < d_back <= np.pi
    assert abs(_wrap(d_back - delta)) <= 1e-9


def test_T_inverse_vectorised_and_zero_force(rng):
    fy = rng.uniform(0.0, 100.0, (4, 5))
    delta = rng.uniform(-np.pi, np.pi, (4, 5))
    fy[0, 0] = 0.0
    f12 = transform_T(jnp.asarray(fy), jnp.asarray(delta))
    assert f12.shape == (4, 5, 2)
    fb, db = (np.asarray(v) for v in transform_T_inverse(f12))
    np.testing.assert_allclose(fb, fy, rtol=1e-13, atol=0)
    mask = fy > 0
    np.testing.assert_allclose(_wrap(db - delta)[mask], 0.0, atol=1e-12)
    # zero force: Fy* = 0 and some finite Δ
    assert fb[0, 0] == 0.0 and np.isfinite(db[0, 0])
    z_fy, z_d = transform_T_inverse(jnp.zeros(2))
    assert float(z_fy) == 0.0 and np.isfinite(float(z_d))


def test_drive_currents_equal_gamma_times_T(rng):
    y = rng.uniform(-0.1, 0.1, 60)
    fy = rng.normal(size=(60, 3)) * 80.0
    delta = rng.uniform(-np.pi, np.pi, (60, 3))
    got = np.asarray(drive_currents(y, fy, delta, jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT), POLE_PITCH))
    assert got.shape == (60, 3, 2)
    g = np.asarray(gamma(y[:, None], jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT), POLE_PITCH))  # (60, 3, 2, 2)
    t = np.asarray(transform_T(jnp.asarray(fy), jnp.asarray(delta)))                          # (60, 3, 2)
    np.testing.assert_allclose(got, np.einsum("nlij,nlj->nli", g, t), rtol=0, atol=1e-12 * np.abs(got).max())


def test_drive_inputs_round_trip_positive_fy(rng):
    y = rng.uniform(-0.1, 0.1, 60)
    fy = rng.uniform(0.1, 150.0, (60, 3))
    delta = rng.uniform(-np.pi, np.pi, (60, 3))
    k, z = jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT)
    cur = drive_currents(y, fy, delta, k, z, POLE_PITCH)
    fy_b, d_b = (np.asarray(v) for v in currents_to_drive_inputs(jnp.asarray(y), cur, k, z, POLE_PITCH))
    assert fy_b.shape == d_b.shape == (60, 3)
    np.testing.assert_allclose(fy_b, fy, rtol=1e-10)
    np.testing.assert_allclose(_wrap(d_b - delta), 0.0, atol=1e-10)


def test_drive_inputs_negative_fy_gives_abs_and_delta_plus_pi(rng):
    y = rng.uniform(-0.1, 0.1, 60)
    fy = -rng.uniform(0.1, 150.0, (60, 3))
    delta = rng.uniform(-np.pi, np.pi, (60, 3))
    k, z = jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT)
    cur = np.asarray(drive_currents(y, fy, delta, k, z, POLE_PITCH))
    fy_b, d_b = (np.asarray(v) for v in currents_to_drive_inputs(jnp.asarray(y), jnp.asarray(cur), k, z,
                                                                 POLE_PITCH))
    np.testing.assert_allclose(fy_b, -fy, rtol=1e-10)
    np.testing.assert_allclose(_wrap(d_b - (delta + np.pi)), 0.0, atol=1e-10)
    # equivalent inputs: the same currents
    again = np.asarray(drive_currents(y, fy_b, d_b, k, z, POLE_PITCH))
    np.testing.assert_allclose(again, cur, rtol=0, atol=1e-10 * np.abs(cur).max())


def test_currents_round_trip_through_drive_inputs(rng):
    """Arbitrary star currents -> (Fy*, Δ) -> currents."""
    y = rng.uniform(-0.1, 0.1, 60)
    cur = rng.normal(size=(60, 3, 2))
    k, z = jnp.asarray(K_HAT), jnp.asarray(ZETA_HAT)
    fy, d = currents_to_drive_inputs(jnp.asarray(y), jnp.asarray(cur), k, z, POLE_PITCH)
    assert np.all(np.asarray(fy) >= 0)
    back = np.asarray(drive_currents(y, fy, d, k, z, POLE_PITCH))
    np.testing.assert_allclose(back, cur, rtol=0, atol=1e-10 * np.abs(cur).max())


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
def test_T_inverse_range_excludes_minus_pi(f12):
    """``Δ ∈ (-π, π]`` also when ``F2*`` is a negative zero, e.g. ``T(Fy* < 0, Δ = 0) = (Fy*, -0.0)``."""
    if f12 == "T(-5, 0)":
        arr = transform_T(jnp.asarray(-5.0), jnp.asarray(0.0))
    else:
        arr = jnp.asarray(f12)
    fy, d = (float(v) for v in transform_T_inverse(arr))
    assert fy > 0
    assert -np.pi < d <= np.pi
