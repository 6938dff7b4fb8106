"""Models: MLP, physics-only / PGNN coil-set models, the combined model and its commutation law."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from pgcomm.commutation import ModelLaw, drive_currents
from pgcomm.models import (
    ACTIVATIONS,
    MLP,
    CoilSetModel,
    CombinedModel,
    force_from_drive_inputs,
    physics_from_ideal,
)
from pgcomm.motor import Motor, ideal_gain

D_M = 0.03
Y = np.linspace(-0.1, 0.1, 401)


def _randomised(model, scale, seed):
    """``model`` with every array leaf perturbed by ``scale`` x N(0, 1) (non-zero output layers)."""
    rng = np.random.default_rng(seed)
    leaves, tree = jax.tree_util.tree_flatten(model)
    return jax.tree_util.tree_unflatten(tree, [np.asarray(x) + scale * rng.normal(size=x.shape) for x in leaves])


# One compilation per model structure instead of one per primitive (eager mode) keeps the tests fast.
_gain = jax.jit(lambda m, y: m.gain(y))
_cogging = jax.jit(lambda m, y: m.cogging(y))
_force = jax.jit(lambda m, y, i: m.force(y, i))
_call = jax.jit(lambda net, s: net(s))


def _coil_sets(n, seed=0, gain=(2,), cog=(16,), scale=0.3):
    motor = Motor()
    out = []
    for l in range(n):
        a, b = physics_from_ideal(D_M, 61.0 + l, -0.54 + 0.01 * l, 0.05, motor.lever_arms[l])
        m = CoilSetModel.init(jax.random.PRNGKey(seed + l), CoilSetModel.physics(a, b, D_M, 0.0, 0.1, -0.1, 0.1), gain,
                              cog, "tanh")
        out.append(_randomised(m, scale, seed + 10 + l))
    return out


@pytest.mark.parametrize("k,zeta,mu,d", [(61.34, -0.54, 0.05, -0.065), (67.0, 0.3, 0.1, 0.075), (50.0, 2.5, 0.0, 0.0)])
def test_physics_from_ideal_is_the_ideal_gain(k, zeta, mu, d):
    a, b = physics_from_ideal(D_M, k, zeta, mu, d)
    model = CoilSetModel.physics(a, b, D_M)
    truth = np.asarray(ideal_gain(Y, Motor(lever_arms=(d,), k=k, zeta=zeta), mu=mu))[:, 0]
    np.testing.assert_allclose(np.asarray(_gain(model, Y)), truth, rtol=0, atol=1e-12 * k)
    np.testing.assert_array_equal(np.asarray(_cogging(model, Y)), 0.0)


def test_pgnn_with_zero_output_layers_is_the_physics_model():
    a, b = physics_from_ideal(D_M, 61.34, -0.54, 0.05, 0.005)
    pgnn = CoilSetModel.init(jax.random.PRNGKey(0), CoilSetModel.physics(a, b, D_M, 0.01, 0.1))  # zero output layers
    phys = pgnn.physics_only()
    truth = np.asarray(ideal_gain(Y, Motor(lever_arms=(0.005,), k=61.34, zeta=-0.54), mu=0.05))[:, 0]
    np.testing.assert_allclose(np.asarray(_gain(pgnn, Y)), np.asarray(_gain(phys, Y)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(_gain(pgnn, Y)), truth, rtol=0, atol=1e-12 * 61.34)
    np.testing.assert_array_equal(np.asarray(_cogging(pgnn, Y)), 0.0)
    i = np.random.default_rng(0).normal(size=(Y.size, 2))
    np.testing.assert_allclose(np.asarray(_force(pgnn, Y, i)), np.einsum("nqj,nj->nq", truth, i), rtol=0, atol=1e-10)


def test_coil_set_model_is_eq_gain_matrix_cogging():
    (m,) = _coil_sets(1)
    s = (Y - m.y_center) / m.y_scale
    th = 2 * np.pi * Y / D_M
    expect = (np.asarray(m.A) * np.cos(th)[:, None, None] + np.asarray(m.B) * np.sin(th)[:, None, None]
              + np.stack([np.asarray(_call(net, s)) for net in m.gain_nets], axis=-1))
    np.testing.assert_allclose(np.asarray(_gain(m, Y)), expect, rtol=0, atol=1e-14 * 61.0)
    np.testing.assert_allclose(np.asarray(_cogging(m, Y)), np.asarray(_call(m.cog_net, s)), rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("widths,activation", [((2,), "tanh"), ((4, 4, 2), "tanh")]
                         + [((5, 3), a) for a in sorted(ACTIVATIONS)])
def test_mlp_is_eq_neural_network(widths, activation):
    net = _randomised(MLP.init(jax.random.PRNGKey(1), widths, activation), 0.5, 2)
    s = np.linspace(-1.2, 1.2, 7)
    h = s[:, None]
    act = {"tanh": np.tanh, "sigmoid": lambda z: 1 / (1 + np.exp(-z)), "relu": lambda z: np.maximum(z, 0),
           "softplus": lambda z: np.log1p(np.exp(z)), "linear": lambda z: z,
           "gelu": lambda z: np.asarray(jax.nn.gelu(z))}[activation]
    for w, b in net.hidden:
        h = act(h @ np.asarray(w) + np.asarray(b))
    np.testing.assert_allclose(np.asarray(_call(net, s)), h @ np.asarray(net.W_out) + np.asarray(net.b_out), rtol=1e-12,
                               atol=1e-12)
    assert net.widths == widths


def test_stacked_networks_equal_separate_ones():
    nets = [_randomised(MLP.init(jax.random.PRNGKey(k), (3, 2)), 0.5, k) for k in range(3)]
    stacked = jax.tree_util.tree_map(lambda *x: np.stack(x), *nets)
    s = np.random.default_rng(0).uniform(-1, 1, size=(11, 3))
    out = np.asarray(_call(stacked, s))
    for g, net in enumerate(nets):
        np.testing.assert_allclose(out[:, g], np.asarray(_call(net, s[:, g])), rtol=1e-14, atol=1e-14)


def test_combined_model_stacks_coil_sets():
    sets = _coil_sets(3)
    cm = CombinedModel.from_coil_sets(sets)
    assert cm.n_coil_sets == 3 and cm.training_range == (-0.1, 0.1)
    g = np.asarray(_gain(cm, Y))
    assert g.shape == (Y.size, 3, 3, 2)
    for l, m in enumerate(sets):
        np.testing.assert_allclose(g[:, l], np.asarray(_gain(m, Y)), rtol=1e-14, atol=1e-13)
        np.testing.assert_array_equal(np.asarray(cm.coil_set(l).A), np.asarray(m.A))
    # eq. PGNN_Electromagnetics: the MEAN of the coil sets' cogging forces
    mean_cog = np.mean([np.asarray(_cogging(m, Y)) for m in sets], axis=0)
    np.testing.assert_allclose(np.asarray(_cogging(cm, Y)), mean_cog, rtol=1e-13, atol=1e-13)
    i = np.random.default_rng(1).normal(size=(Y.size, 3, 2))
    f = np.einsum("nlqj,nlj->nq", g, i) + mean_cog
    np.testing.assert_allclose(np.asarray(_force(cm, Y, i)), f, rtol=1e-12, atol=1e-12)
    phys = cm.physics_only()
    assert phys.gain_nets is None and np.all(np.asarray(_cogging(phys, Y)) == 0)


def test_combined_model_refuses_mismatched_coil_sets():
    a, b = _coil_sets(2)
    # one hidden layer of another width is padded (see the padding test); deeper networks are not
    two = _coil_sets(1, cog=(8, 4))[0]
    with pytest.raises(ValueError, match="coil set 2: network widths differ"):
        CombinedModel.from_coil_sets([two, _coil_sets(1, cog=(8, 6))[0]])
    with pytest.raises(ValueError, match="coil set 2: pole pitch"):
        CombinedModel.from_coil_sets([a, CoilSetModel(b.A, b.B, b.gain_nets, b.cog_net, 0.02)])


@pytest.mark.parametrize("n_coil_sets", [2, 3])
def test_model_law_reproduces_the_desired_force(n_coil_sets):
    """eq. Commutation_Model_Currents: F̂(y, i(F*)) = F* on the model itself."""
    cm = CombinedModel.from_coil_sets(_coil_sets(n_coil_sets, seed=5))
    rng = np.random.default_rng(2)
    y = rng.uniform(-0.1, 0.1, 500)
    f_star = rng.normal(size=(500, 3)) * np.array([50.0, 3.0, 0.5])
    i = jax.jit(lambda m, y, f: ModelLaw(m).currents(y, f))(cm, y, f_star)
    f_hat = np.asarray(_force(cm, y, i))
    np.testing.assert_allclose(f_hat, f_star, rtol=0, atol=1e-9 * np.abs(f_star).max())


def test_force_from_drive_inputs():
    (m,) = _coil_sets(1)
    rng = np.random.default_rng(3)
    fy, delta = rng.normal(size=Y.size) * 40, rng.uniform(-1, 1, Y.size)
    i = np.asarray(drive_currents(Y, fy[:, None], delta[:, None], 67.0, -0.52, D_M))[:, 0]
    np.testing.assert_allclose(np.asarray(force_from_drive_inputs(m, Y, fy, delta, 67.0, -0.52)),
                               np.asarray(_force(m, Y, i)), rtol=1e-14, atol=1e-12)


def test_init_is_deterministic_and_validated():
    a = MLP.init(jax.random.PRNGKey(7), (16,))
    b = MLP.init(jax.random.PRNGKey(7), (16,))
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    with pytest.raises(ValueError, match="unknown activation 'swish'"):
        MLP.init(jax.random.PRNGKey(0), (2,), "swish")
    with pytest.raises(ValueError, match="widths must be a non-empty tuple"):
        MLP.init(jax.random.PRNGKey(0), ())


def test_padded_network_is_the_same_function_and_stacks():
    import jax.numpy as jnp

    from pgcomm.models import MLP, CoilSetModel, CombinedModel

    phys = CoilSetModel.physics(np.ones((3, 2)), np.zeros((3, 2)), 0.03, 0.0, 0.1)
    a = CoilSetModel.init(jax.random.PRNGKey(1), phys, (2,), (4,))
    b = CoilSetModel.init(jax.random.PRNGKey(2), phys, (8,), (4,))
    net = MLP.init(jax.random.PRNGKey(3), (2,))
    net = MLP(net.hidden, jax.random.normal(jax.random.PRNGKey(4), (2, 3)), jnp.ones(3), net.activation)
    s = jnp.linspace(-1.2, 1.2, 50)
    np.testing.assert_array_equal(np.asarray(net.padded(8)(s)), np.asarray(net(s)))
    both = CombinedModel.from_coil_sets([a, b])  # widths 2 and 8: the 2 is padded
    y = jnp.linspace(-0.1, 0.1, 40)
    for l, m in enumerate((a, b)):
        np.testing.assert_allclose(np.asarray(both.coil_set(l).gain(y)), np.asarray(m.gain(y)), rtol=0, atol=1e-15)
