"""Tests of pgcomm.commutation: classical, single-direction and model-based commutation laws."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from pgcomm.commutation import (
    ClassicalLaw,
    ModelLaw,
    classical_single_direction,
    force_split,
    limit_currents,
)
from pgcomm.motor import Motor, ideal_gain_phases, star_to_phases, total_force
from pgcomm.twin import DEFAULT_TWIN

POLE_PITCH = 0.03

# name -> (lever_arms, k, zeta, mu); all full rank (L >= 2 with distinct lever arms)
MOTORS = {
    "L2_symmetric": ((-0.07, 0.07), (61.0, 63.0), (-0.54, -0.50), 0.05),
    "L2_same_side": ((0.01, 0.02), (60.0, 66.0), (0.3, 0.3), 0.08),
    "L3_paper": ((-0.065, 0.005, 0.075), (61.34, 61.62, 60.07), (-0.54, -0.55, -0.55), 0.05),
    "L3_large_mu": ((-0.2, 0.0, 0.3), (50.0, 70.0, 60.0), (1.0, -2.0, 0.5), 0.4),
    "L4_mixed": ((-0.1, -0.03, 0.04, 0.12), (58.0, 61.0, 64.0, 67.0), (-0.5, -0.6, 2.9, -3.0), 0.05),
}


def _motor(name, current_limit=None):
    d, k, z, mu = MOTORS[name]
    return Motor(pole_pitch=POLE_PITCH, lever_arms=d, k=k, zeta=z, mu=mu, current_limit=current_limit)


#: one batch size everywhere: the jitted helpers compile once per law structure
N_SAMPLES = 16


def _samples(rng, n=N_SAMPLES):
    y = rng.uniform(-0.1, 0.1, n)
    f = rng.normal(size=(n, 3)) * np.array([100.0, 20.0, 3.0])
    return y, f


def _full_phase_matrices(y, motor):
    """``(N, 3, 3L)`` phase gain matrices ``[K^1 ... K^L]`` (eq. 8) at positions ``y`` (N,), NumPy."""
    y = jnp.asarray(y)
    blocks = [np.asarray(ideal_gain_phases(y, motor.k[l], motor.zeta[l], motor.mu, motor.lever_arms[l],
                                           motor.pole_pitch)) for l in range(motor.n_coil_sets)]
    return np.concatenate(blocks, axis=-1)


def _reduced_matrix(gain):
    """``(L, 3, 2)`` star-reduced gain to the ``3 x 2L`` matrix ``[K^1 ... K^L]``."""
    g = np.asarray(gain)
    return np.hstack([g[l] for l in range(g.shape[0])])


@pytest.fixture(scope="module")
def currents_jit():
    """One jitted ``law.currents`` (laws are pytrees: recompiles only for new structures/shapes)."""
    return jax.jit(lambda law, y, f: law.currents(y, f))


@jax.jit
def _gain(law, y):
    return law.gain(y)


@jax.jit
def _force(law, y, i):
    """``Σ_l K^l(y) i^l`` with the law's own (ideal) gain."""
    return total_force(law.gain(y), i)


# ---------------------------------------------------------------------------
# classical law: minimum-energy pseudo-inverse
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(MOTORS))
def test_classical_law_equals_pinv_of_full_phase_matrix(name, rng, currents_jit):
    motor = _motor(name)
    law = ClassicalLaw.from_motor(motor)
    y, f = _samples(rng)
    got = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f)))
    k3s = _full_phase_matrices(y, motor)
    for n in range(len(y)):
        k3 = k3s[n]
        i3 = (np.linalg.pinv(k3) @ f[n]).reshape(motor.n_coil_sets, 3)
        # the pseudo-inverse solution satisfies the star constraint by itself
        np.testing.assert_allclose(i3.sum(axis=1), 0.0, atol=1e-12 * np.abs(i3).max())
        np.testing.assert_allclose(got[n], i3[:, :2], rtol=0, atol=1e-10 * np.abs(i3).max())


@pytest.mark.parametrize("name", list(MOTORS))
def test_classical_law_reproduces_desired_force(name, rng, currents_jit):
    law = ClassicalLaw.from_motor(_motor(name))
    y, f = _samples(rng)
    i = currents_jit(law, jnp.asarray(y), jnp.asarray(f))
    got = np.asarray(_force(law, jnp.asarray(y), i))
    for q in range(3):  # per row: N, N, N*m have different scales
        np.testing.assert_allclose(got[:, q], f[:, q], rtol=0, atol=1e-10 * np.abs(f[:, q]).max())


@pytest.mark.parametrize("name", list(MOTORS))
def test_star_metric_equals_pinv_of_reduced_matrix(name, rng, currents_jit):
    law = ClassicalLaw.from_motor(_motor(name), metric="star")
    y, f = _samples(rng)
    got = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f)))
    gains = np.asarray(_gain(law, jnp.asarray(y)))
    for n in range(len(y)):
        i = np.linalg.pinv(_reduced_matrix(gains[n])) @ f[n]
        np.testing.assert_allclose(got[n].ravel(), i, rtol=0, atol=1e-10 * np.abs(i).max())


def _phase_loss(currents):
    """``Σ ia² + ib² + ic²`` over coil sets with ``ic = -ia - ib`` (NumPy, ``(L, 2)``)."""
    c = np.asarray(currents)
    return float(np.sum(c**2) + np.sum(c.sum(axis=-1) ** 2))


@pytest.mark.parametrize("name", list(MOTORS))
def test_classical_law_is_minimum_phase_copper_loss(name, rng, currents_jit):
    law = ClassicalLaw.from_motor(_motor(name))
    y, f = _samples(rng)
    cur = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f)))
    gains = np.asarray(_gain(law, jnp.asarray(y)))
    for n in range(len(y)):
        i = cur[n]
        kred = _reduced_matrix(gains[n])
        null = scipy.linalg.null_space(kred)  # (2L, 2L - 3)
        assert null.shape[1] == 2 * law.k.shape[0] - 3
        base = _phase_loss(i)
        for _ in range(5):
            nv = null @ rng.normal(size=null.shape[1])
            nv *= 0.1 * np.linalg.norm(i) / np.linalg.norm(nv)
            other = i + nv.reshape(i.shape)
            # still a solution ...
            np.testing.assert_allclose(kred @ other.ravel(), f[n], rtol=0, atol=1e-9 * np.abs(f[n]).max())
            # ... with strictly more copper loss (phase metric: the cross term vanishes)
            assert _phase_loss(other) > base * (1.0 + 1e-6)
            assert _phase_loss(other) == pytest.approx(base + _phase_loss(nv.reshape(i.shape)), rel=1e-9)


# ---------------------------------------------------------------------------
# single-direction closed form
# ---------------------------------------------------------------------------


@jax.jit
def _single_direction(y, fy, k, zeta):
    return classical_single_direction(y, fy, k, zeta, POLE_PITCH)


@pytest.mark.parametrize("name", list(MOTORS))
def test_single_direction_equals_classical_law(name, rng, currents_jit):
    motor = _motor(name)
    law = ClassicalLaw.from_motor(motor)
    y = rng.uniform(-0.1, 0.1, N_SAMPLES)
    fy = rng.normal(size=N_SAMPLES) * 100.0
    f = np.stack([fy, np.zeros_like(fy), np.zeros_like(fy)], -1)
    ref = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f)))
    got = np.asarray(_single_direction(y, fy, jnp.asarray(motor.k), jnp.asarray(motor.zeta)))
    assert got.shape == (N_SAMPLES, motor.n_coil_sets, 2)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_single_direction_force_split_is_k_squared():
    """Each coil set carries ``k_l² / Σ k_m²`` of ``Fy*`` and no Fx, Tz (unequal k̂)."""
    motor = _motor("L4_mixed")
    k = np.asarray(motor.k)
    w_expected = k**2 / np.sum(k**2)
    np.testing.assert_allclose(np.asarray(force_split(k)), w_expected, rtol=1e-14)
    # differs from the paper's typo k_l / Σ k_m (the test would catch a k-linear split)
    assert np.max(np.abs(w_expected - k / k.sum())) > 1e-3
    y = np.linspace(-0.1, 0.1, N_SAMPLES)
    fy = np.full(N_SAMPLES, 80.0)
    i = _single_direction(y, fy, jnp.asarray(k), jnp.asarray(motor.zeta))
    gain = np.asarray(_gain(ClassicalLaw.from_motor(motor), jnp.asarray(y)))  # (N, L, 3, 2)
    per_set = np.einsum("nlqc,nlc->nlq", gain, np.asarray(i))
    np.testing.assert_allclose(per_set[..., 0], fy[:, None] * w_expected, rtol=1e-12)
    np.testing.assert_allclose(per_set[..., 1:], 0.0, atol=1e-12 * 80.0)


# ---------------------------------------------------------------------------
# rank-deficient K: damping
# ---------------------------------------------------------------------------


RANK_DEFICIENT = {
    "one_coil_set": Motor(pole_pitch=POLE_PITCH, lever_arms=(0.02,), k=61.0, zeta=-0.5, mu=0.05,
                          current_limit=None),
    "equal_lever_arms": Motor(pole_pitch=POLE_PITCH, lever_arms=(0.03, 0.03), k=(60.0, 62.0), zeta=-0.5,
                              mu=0.05, current_limit=None),
}


def _damped_reference(gain, f):
    """Minimum-phase-loss least-squares currents of the row-normalised system (the damped law's limit).

    With ``W^{-1/2}`` the square root of the per-coil-set inverse phase metric and
    ``D = diag(K W^{-1} K^T)^{-1/2}``: ``i = W^{-1/2} pinv(D K W^{-1/2}) D F``.
    """
    n_sets = gain.shape[0]
    qinv_half = scipy.linalg.sqrtm(np.array([[2.0, -1.0], [-1.0, 2.0]]) / 3.0).real
    wh = scipy.linalg.block_diag(*([qinv_half] * n_sets))
    k = _reduced_matrix(gain)
    d = np.diag(1.0 / np.sqrt(np.diag(k @ wh @ wh @ k.T)))
    return (wh @ np.linalg.pinv(d @ k @ wh, rcond=1e-10) @ d @ f).reshape(n_sets, 2)


@pytest.mark.parametrize("name", list(RANK_DEFICIENT))
def test_damped_law_stays_finite_and_reproduces_fy(name, rng, currents_jit):
    law = ClassicalLaw.from_motor(RANK_DEFICIENT[name])
    y, f = _samples(rng)  # random Fx, Tz: inconsistent with the rank-deficient K
    i = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f)))
    assert np.isfinite(i).all()
    got = np.asarray(_force(law, jnp.asarray(y), jnp.asarray(i)))
    np.testing.assert_allclose(got[:, 0], f[:, 0], rtol=2e-6, atol=0)
    # bounded: the least-squares compromise (damping 1e-6 moves it by ~1e-6 relative),
    # not a blow-up along the singular direction
    gains = np.asarray(_gain(law, jnp.asarray(y)))
    for n in range(len(y)):
        # one coil set meets Fy and Fx exactly (see min_energy_currents); more: the compromise
        ref = (np.linalg.solve(gains[n, 0, :2, :], f[n, :2])[None, :] if gains.shape[1] == 1
               else _damped_reference(gains[n], f[n]))
        np.testing.assert_allclose(i[n], ref, rtol=0, atol=1e-5 * np.abs(ref).max())


# ---------------------------------------------------------------------------
# current limit
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("limit", [0.5, 2.0, 5.0])
def test_limit_currents_bounds_phases_and_keeps_direction(limit, rng):
    i = rng.normal(size=(50, 3, 2)) * rng.uniform(0.02, 3.0, (50, 1, 1))
    out = np.asarray(limit_currents(jnp.asarray(i), limit))

    def peak(c):  # max |ia|, |ib|, |ic| per sample, ic = -ia - ib
        return np.maximum(np.abs(c).max(axis=(-2, -1)), np.abs(c.sum(axis=-1)).max(axis=-1))

    np.testing.assert_array_equal(np.asarray(star_to_phases(jnp.asarray(i)))[..., 2], -i.sum(axis=-1))
    peak_in, peak_out = peak(i), peak(out)
    assert np.all(peak_out <= limit * (1 + 1e-12))
    # over the limit: scaled onto it; under: unchanged
    over = peak_in > limit
    assert over.any() and (~over).any()
    np.testing.assert_allclose(peak_out[over], limit, rtol=1e-12)
    np.testing.assert_array_equal(out[~over], i[~over])
    # one positive factor per sample: same direction
    s = out.reshape(50, -1) / i.reshape(50, -1)
    assert np.all(s > 0)
    np.testing.assert_allclose(s, np.broadcast_to(s[:, :1], s.shape), rtol=1e-12)


def test_limit_currents_none_is_identity(rng):
    i = jnp.asarray(rng.normal(size=(4, 3, 2)) * 100.0)
    assert limit_currents(i, None) is i


def test_classical_law_applies_motor_current_limit(rng, currents_jit):
    motor = _motor("L3_paper", current_limit=1.0)
    law = ClassicalLaw.from_motor(motor)
    y, f = _samples(rng)
    i = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f * 10.0)))
    peak = np.abs(np.asarray(star_to_phases(jnp.asarray(i)))).max(axis=(-2, -1))
    assert np.all(peak <= 1.0 + 1e-12)
    np.testing.assert_allclose(peak, 1.0, rtol=1e-12)  # every sample of this batch needs more than 1 A


# ---------------------------------------------------------------------------
# model law on the twin's truth: the oracle is exact
# ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def twin_plant():
    return DEFAULT_TWIN.plant()


def test_model_law_on_twin_is_exact_oracle(twin_plant, rng, currents_jit):
    law = ModelLaw(twin_plant)
    lo, hi = twin_plant.y_range
    y = rng.uniform(lo, hi, N_SAMPLES)
    f = rng.normal(size=(N_SAMPLES, 3)) * np.array([100.0, 20.0, 3.0])
    i = currents_jit(law, jnp.asarray(y), jnp.asarray(f))
    static_force = jax.jit(lambda p, q, c: total_force(p.gain(q), c) + p.cogging(q))
    got = np.asarray(static_force(twin_plant, jnp.asarray(y), i))
    for q in range(3):
        np.testing.assert_allclose(got[:, q], f[:, q], rtol=0, atol=1e-10 * np.abs(f[:, q]).max())


# ---------------------------------------------------------------------------
# jit + vectorisation over a leading shape
# ---------------------------------------------------------------------------


def _laws(twin_plant):
    m = _motor("L3_paper")
    return {
        "classical": ClassicalLaw.from_motor(m),
        "classical_star": ClassicalLaw.from_motor(m, metric="star"),
        "model_twin": ModelLaw(twin_plant),
    }


@pytest.mark.parametrize("which", ["classical", "classical_star", "model_twin"])
def test_laws_jit_and_vectorise(which, twin_plant, rng, currents_jit):
    law = _laws(twin_plant)[which]
    y = rng.uniform(-0.1, 0.1, (2, 3))
    f = rng.normal(size=(2, 3, 3)) * np.array([100.0, 20.0, 3.0])
    batched = np.asarray(currents_jit(law, jnp.asarray(y), jnp.asarray(f)))
    assert batched.shape == (2, 3, 3, 2)
    for a in range(2):
        for b in range(3):
            single = np.asarray(currents_jit(law, jnp.asarray(y[a, b]), jnp.asarray(f[a, b])))
            np.testing.assert_allclose(batched[a, b], single, rtol=0, atol=1e-12 * np.abs(single).max())


def test_single_direction_jit_and_vectorise(rng):
    m = _motor("L3_paper")
    k, z = jnp.asarray(m.k), jnp.asarray(m.zeta)
    y = rng.uniform(-0.1, 0.1, (2, 3))
    fy = rng.normal(size=(2, 3)) * 50
    batched = np.asarray(_single_direction(y, fy, k, z))
    assert batched.shape == (2, 3, 3, 2)
    for a in range(2):
        for b in range(3):
            single = np.asarray(_single_direction(y[a, b], fy[a, b], k, z))
            np.testing.assert_allclose(batched[a, b], single, rtol=0, atol=1e-13 * np.abs(single).max())


def test_single_coil_set_meets_fy_and_fx_exactly(rng):
    # L = 1: two currents, three rows. The law meets Fy and Fx exactly (Tz follows), instead
    # of a least-squares compromise that gives up driving force.
    gain = rng.normal(size=(200, 1, 3, 2)) * np.array([60.0, 3.0, 0.2])[:, None]
    f_star = rng.normal(size=(200, 3)) * np.array([50.0, 2.0, 0.1])
    from pgcomm.commutation import metric_inverse, min_energy_currents

    i = min_energy_currents(jnp.asarray(gain), jnp.asarray(f_star), metric_inverse(1))
    f = np.einsum("nlrc,nlc->nr", gain, np.asarray(i))
    scale = np.abs(gain).max() * np.abs(np.asarray(i)).max()  # force scale of K i
    np.testing.assert_allclose(f[:, :2], f_star[:, :2], rtol=0, atol=1e-10 * scale)
    # the same as solving the 2 x 2 system directly
    direct = np.linalg.solve(gain[:, 0, :2, :], f_star[:, :2, None])[..., 0]
    np.testing.assert_allclose(np.asarray(i)[:, 0, :], direct, rtol=0, atol=1e-10 * np.abs(direct).max())
