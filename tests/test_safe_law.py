"""Issue 16, safe laws (Python side): ModelLaw never asks for more than the current limit, never returns NaN or
inf, and holds the position at the end of the model's training range (fuzzed over ±10x the range, demands up to
10x the motor's capacity, NaN/inf inputs)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.commutation import ModelLaw
from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal
from pgcomm.motor import star_to_phases
from pgcomm.spline_model import SplineModel

D_M, LIMIT, K = 0.03, 10.0, 60.0


def _pgnn(seed=0):
    models = []
    for l, (z, d) in enumerate(((-0.54, -0.065), (-0.55, 0.005), (-0.55, 0.075))):
        a, b = physics_from_ideal(D_M, K, z, 0.05, d)
        m = CoilSetModel.init(jax.random.PRNGKey(seed + l), a, b, D_M, 0.0, 0.1, y_min=-0.1, y_max=0.1)
        # output layers large enough that the networks dominate far outside the range
        m = m.with_outputs(a, b, [(jnp.full((2, 3), 5.0), jnp.zeros(3))] * 2, (jnp.full((16, 3), 3.0), jnp.zeros(3)))
        models.append(m)
    return CombinedModel.from_coil_sets(models)


def _spline(rng):
    mg, mc, md = 9, 40, 12
    a, b = physics_from_ideal(D_M, K, -0.54, 0.05, 0.0)
    table = np.stack([np.stack([a, b])] * mg)[:, None] * (1 + 0.05 * rng.normal(size=(mg, 3, 1, 1, 1)))
    return SplineModel(jnp.asarray(table.transpose(0, 1, 2, 3, 4)), jnp.asarray(0.01 * rng.normal(size=(3, 4, 3, 2))),
                       jnp.asarray(rng.normal(size=(mc, 3))), jnp.asarray(rng.normal(size=(md, 3))),
                       jnp.linspace(-0.1, 0.1, mg), jnp.linspace(-0.1, 0.1, mc), jnp.linspace(-0.1, 0.1, md),
                       D_M, (-0.1,) * 3, (0.1,) * 3)


def _fuzz_inputs(rng, n=20000):
    y = rng.uniform(-1.0, 1.0, n)                                  # ±10x the 0.1 m range
    f = rng.uniform(-1, 1, (n, 3)) * np.array([10 * 3 * K * LIMIT, 100.0, 10.0])
    v = rng.normal(0, 1.0, n)
    bad = rng.random(n) < 0.05
    y[bad & (rng.random(n) < 0.3)] = np.nan
    f[bad & (rng.random(n) < 0.3), 0] = np.inf
    v[bad & (rng.random(n) < 0.3)] = -np.inf
    return y, f, v


@pytest.mark.parametrize("kind", ["pgnn", "spline"])
def test_model_law_is_safe_for_every_input(kind, rng):
    model = _pgnn() if kind == "pgnn" else _spline(rng)
    law = ModelLaw(model, current_limit=LIMIT)
    y, f, v = _fuzz_inputs(rng)
    i = np.asarray(jax.jit(law.currents)(jnp.asarray(y), jnp.asarray(f), jnp.asarray(v)))
    assert np.all(np.isfinite(i))
    phases = np.asarray(star_to_phases(jnp.asarray(i)))
    assert np.max(np.abs(phases)) <= LIMIT * (1 + 1e-12)
    bad = ~(np.isfinite(y) & np.all(np.isfinite(f), axis=1) & np.isfinite(v))
    assert np.all(i[bad] == 0.0)


def test_model_law_holds_the_range_end(rng):
    """Past the training range the law gives the currents of the range's end for the same demand."""
    law = ModelLaw(_pgnn(), current_limit=None)
    f = jnp.asarray([[300.0, 0.0, 0.0]] * 3)
    far = law.currents(jnp.asarray([0.1, 0.117, 0.5]), f)
    np.testing.assert_array_equal(np.asarray(far[1]), np.asarray(far[0]))
    np.testing.assert_array_equal(np.asarray(far[2]), np.asarray(far[0]))
    lo = law.currents(jnp.asarray([-0.1, -3.0]), f[:2])
    np.testing.assert_array_equal(np.asarray(lo[1]), np.asarray(lo[0]))
