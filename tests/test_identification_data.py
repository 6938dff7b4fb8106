"""One data interface for the optimiser (:class:`pgcomm.protocols.IdentificationData`).

Force-sensor data and data without a force sensor are its two implementations; the optimiser has no
branch on the data's type, so a third implementation that only delegates must identify exactly the
same model as the data it wraps (same floating-point path: compared to 1e-12 of each parameter's scale,
which allows nothing but reordering).
"""

from __future__ import annotations

import jax
import numpy as np
import pytest

from pgcomm import identify as idf
from pgcomm.data import CoilSetData
from pgcomm.protocols import IdentificationData
from pgcomm.sensorless import SensorlessData, sensorless_data

from test_identify import D_M, synthetic_coil_set

TS = 1e-3


class Delegating:
    """A third kind of data: every member of the interface forwarded to the wrapped data (nothing else)."""

    def __init__(self, inner):
        self.inner = inner

    name = property(lambda self: self.inner.name)
    n = property(lambda self: self.inner.n)
    raw = property(lambda self: self.inner.raw)
    force = property(lambda self: self.inner.force)
    observed = property(lambda self: self.inner.observed)
    n_friction = property(lambda self: self.inner.n_friction)
    regressor_taps = property(lambda self: self.inner.regressor_taps)
    y = property(lambda self: self.inner.y)
    velocity = property(lambda self: self.inner.velocity)

    def window_index(self):
        return self.inner.window_index()

    def filtered(self, columns):
        return self.inner.filtered(columns)

    def filtered_friction(self):
        return self.inner.filtered_friction()

    def physics_nuisance(self, pole_pitch):
        return self.inner.physics_nuisance(pole_pitch)

    def split(self, validation_fraction, block_size):
        return tuple(Delegating(d) for d in self.inner.split(validation_fraction, block_size))

    def mechanics(self, friction):
        return self.inner.mechanics(friction)


@pytest.fixture(scope="module")
def kinds():
    data = synthetic_coil_set()
    return {"force sensor": data, "no force sensor": sensorless_data(data, TS, D_M, 30.0)}


def test_both_kinds_implement_the_interface(kinds):
    assert isinstance(kinds["force sensor"], CoilSetData) and isinstance(kinds["no force sensor"], SensorlessData)
    for d in kinds.values():
        assert isinstance(d, IdentificationData)
        w = d.window_index()
        assert w.shape == (d.n, np.asarray(d.regressor_taps).shape[0])
        assert d.filtered(np.ones(d.raw.n)).shape == (d.n,)
        assert d.filtered_friction().shape == (d.n, d.n_friction)
    # a force sensor's samples are the unfiltered case: the filter is the identity, nothing else is fitted
    f = kinds["force sensor"]
    x = np.random.default_rng(1).standard_normal((f.n, 2))
    np.testing.assert_array_equal(f.filtered(x), x)
    assert f.n_friction == 0 and f.physics_nuisance(D_M).shape == (f.n, 0) and f.observed == (0, 1, 2)


@pytest.mark.parametrize("kind", ["force sensor", "no force sensor"])
def test_a_delegating_third_kind_identifies_the_same_model(kinds, kind):
    data = kinds[kind]
    opts = idf.IdentifyOptions(starts=1, max_iterations=8)
    a = idf.identify(data, D_M, opts, seed=3, check_data=False)
    b = idf.identify(Delegating(data), D_M, opts, seed=3, check_data=False)
    for x, y in zip(jax.tree_util.tree_leaves(a.model), jax.tree_util.tree_leaves(b.model)):
        x, y = np.asarray(x, float), np.asarray(y, float)
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-12 * max(float(np.max(np.abs(x), initial=0)), 1e-300))
    assert b.cost_pgnn == pytest.approx(a.cost_pgnn, rel=1e-12)
    assert (a.mechanics is None) == (kind == "force sensor") and (b.mechanics is None) == (a.mechanics is None)


def test_residual_is_the_force_error_for_force_data(kinds):
    """Second formulation: on force data the interface's residual is the measured force minus the model's."""
    data = kinds["force sensor"]
    a, b = idf.fit_physics(data, D_M)
    from pgcomm.identify.projection import data_residual
    from pgcomm.models import CoilSetModel

    model = CoilSetModel.physics(a, b, D_M, 0.0, 0.1, -0.1, 0.1)
    r, friction = data_residual(model, data)
    f_hat = np.asarray(model.force(data.y, data.currents))
    np.testing.assert_allclose(r, data.force - f_hat, rtol=0, atol=1e-12 * np.max(np.abs(data.force)))
    assert friction.shape == (0,)
