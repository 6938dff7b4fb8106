"""The oracle is the floor: no commutation beats it except by noise (DESIGN.md, The digital twin).

The oracle inverts everything the plant knows with the plant's true state, the
direction-dependent force included. Each law below is a better-informed inverse than
the one before it; on the same reference and the same sensor noise none may have a
filtered commutation error below the oracle's by more than the noise spread.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm import trajectory
from pgcomm._pytree import pytree_dataclass
from pgcomm.commutation import ClassicalLaw, ModelLaw, oracle_law
from pgcomm.control import Feedforward
from pgcomm.mechanics import Mechanics
from pgcomm.metrics import DIRECTIONS, lowpass, mse_difference_se
from pgcomm.sensors import Sensors
from pgcomm.simulate import ClosedLoop, simulate_many
from pgcomm.twin import DEFAULT_TWIN, true_fundamental

SENSORS = Sensors()  # the default noise and encoder


@pytree_dataclass
class _StaticTruth:
    """The plant's static part only (gain and cogging; no velocity-dependent force)."""

    plant: object

    def gain(self, y):
        return self.plant.gain(y)

    def cogging(self, y):
        return self.plant.cogging(y)


@pytest.fixture(scope="module")
def runs():
    tw = DEFAULT_TWIN
    plant = tw.plant()
    k, zeta = true_fundamental(tw)
    drive = tw.motor(k_hat=k, zeta_hat=zeta)
    ref = trajectory.single_velocity_reference(0.05, drive.sample_time, 0.09, 1.0, 1000.0, 0.2)
    laws = {"classical": ClassicalLaw.from_motor(drive),
            "static_truth": ModelLaw(_StaticTruth(plant), current_limit=drive.current_limit),
            "truth_reference_velocity": ModelLaw(plant, current_limit=drive.current_limit),
            "oracle": oracle_law(plant, current_limit=drive.current_limit)}
    mech = Mechanics()
    ff = Feedforward(mass=mech.mass, viscous=mech.viscous, coulomb=mech.coulomb)
    names = list(laws)
    out = []
    for name in names:  # one law type per call: each compiles once, the same noise seed for all
        out += simulate_many(plant, [laws[name]], ref, drive=drive, loop=ClosedLoop(mechanics=mech, sensors=SENSORS),
                             feedforwards=[ff], seeds=[11])
    return dict(zip(names, out))


def _filtered(res):
    return lowpass(res.f_meas - res.f_star, res.sample_time)


@pytest.mark.parametrize("row", ["classical", "static_truth", "truth_reference_velocity"])
def test_no_law_beats_the_oracle(runs, row):
    o = _filtered(runs["oracle"])
    r = _filtered(runs[row])
    block = 200  # 0.2 s: ~60 time constants of the 50 Hz filter
    for q, d in enumerate(DIRECTIONS):
        se = mse_difference_se(r[:, q], o[:, q], block)
        assert np.mean(r[:, q] ** 2) >= np.mean(o[:, q] ** 2) - 3 * se, (row, d)


def test_oracle_removes_the_direction_force(runs):
    # the static inverse leaves the twin's direction-dependent force (|c_y| = 1 N) in Fy;
    # the oracle removes it: what is left in y is sensor noise through the 50 Hz filter.
    st = _filtered(runs["static_truth"])[:, 0]
    o = _filtered(runs["oracle"])[:, 0]
    c_y = DEFAULT_TWIN.direction_force[0]
    assert np.mean(st**2) - np.mean(o**2) > 0.5 * c_y**2
    ts = runs["oracle"].sample_time
    a = np.exp(-2 * np.pi * 50.0 * ts)
    noise_floor = SENSORS.force_noise[0] ** 2 * (1 - a) / (1 + a)
    assert np.mean(o**2) < 2.0 * noise_floor


def test_adding_a_reference_leaves_the_other_runs_unchanged():
    """Noise is seeded per reference (DESIGN.md): an extra reference in the batch changes no other run."""
    from pgcomm.experiment import run_laws
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig
    from pgcomm.reproduce import reference_seed

    setup = build_setup(ExperimentConfig())
    law = ClassicalLaw.from_motor(setup.motor)
    ts = setup.motor.sample_time
    long = trajectory.single_velocity_reference(0.15, ts, 0.05, 1.0, 1000.0, 0.1)
    user = trajectory.single_velocity_reference(0.1, ts, 0.03, 1.0, 1000.0, 0.1)
    ff = Feedforward(mass=30.0)
    alone = run_laws(setup, [law], long, [ff], seeds=[reference_seed(0, "long")])[0]
    both = run_laws(setup, [law, law], [long, user], [ff, ff],
                    seeds=[reference_seed(0, "long"), reference_seed(0, "user")])[0]
    # the same noise draw (seeded by the reference's name), and the same motion up to the rounding of
    # the batched path: positions to the scale of the stroke, forces to the scale of the demand
    f_scale = np.abs(alone.f_star).max()
    np.testing.assert_allclose(both.f_meas - both.f_true, alone.f_meas - alone.f_true, rtol=0, atol=1e-10 * f_scale)
    np.testing.assert_allclose(both.y, alone.y, rtol=0, atol=1e-10 * np.abs(long.r).max())
    np.testing.assert_allclose(both.f_meas, alone.f_meas, rtol=0, atol=1e-10 * f_scale)
    assert reference_seed(0, "long") != reference_seed(0, "user") != reference_seed(0, "slow")
