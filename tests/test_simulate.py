"""Tests of pgcomm.simulate: the closed loop on the twin and on a force map."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm import trajectory
from pgcomm.commutation import ClassicalLaw, drive_currents
from pgcomm.control import PID, Feedforward
from pgcomm.errors import DataError
from pgcomm.forcemap import ForceMapPlant
from pgcomm.mechanics import Mechanics
from pgcomm.motor import star_to_phases
from pgcomm.sensors import Sensors
from pgcomm.simulate import ClosedLoop, SimResult, simulate, simulate_many
from pgcomm.twin import DEFAULT_TWIN

EFFECTS = ("imbalance", "field", "harmonics", "out_of_plane", "cogging", "direction")
TWIN0 = DEFAULT_TWIN.without(*EFFECTS)
FRICTIONLESS = Mechanics(viscous=0.0, coulomb=0.0)
NO_NOISE = Sensors(encoder_resolution=0.0, force_noise=(0.0, 0.0, 0.0))
NOISY = Sensors(encoder_resolution=0.0, force_noise=(0.8, 0.45, 0.9))  # same static resolution: no recompile


@pytest.fixture(scope="module")
def reference():
    """A short jerk-limited move (0.35 s)."""
    return trajectory.point_to_point(0.0, 0.05, 0.2, 2.0, 1000.0, 1e-3)


@pytest.fixture(scope="module")
def plant0():
    return TWIN0.plant()


@pytest.fixture(scope="module")
def exact_drive():
    """Drive/law parameters equal to the effect-free twin's truth (no current limit)."""
    return TWIN0.motor(k_hat=TWIN0.k, zeta_hat=TWIN0.zeta, current_limit=None)


@pytest.fixture(scope="module")
def double_integrator(plant0, exact_drive, reference):
    law = ClassicalLaw.from_motor(exact_drive)
    return simulate(plant0, law, reference, drive=exact_drive, feedforward=Feedforward(mass=FRICTIONLESS.mass),
                    loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NO_NOISE))


def test_double_integrator_commutation_is_exact(double_integrator):
    res = double_integrator
    scale = np.abs(res.f_star[:, 0]).max()
    assert scale > 10.0  # the move really demands force
    np.testing.assert_array_equal(res.f_star[:, 1:], 0.0)
    np.testing.assert_allclose(res.f_true, res.f_star, rtol=0, atol=1e-9 * scale)
    # no noise: measured = true
    np.testing.assert_array_equal(res.f_meas, res.f_true)
    np.testing.assert_array_equal(res.y_meas, res.y)


def test_double_integrator_tracks_with_exact_feedforward(double_integrator, reference):
    res = double_integrator
    # Exact mass feedforward with δ = (z+1)/2 and exact commutation leave only the ZOH mismatch of
    # the jerk phases, j Ts³ / 12 ≈ 1e-7 m per sample, corrected by the feedback: bound 1e-6 m
    # (0.002 % of the 0.05 m move).
    assert np.abs(res.e).max() < 1e-6
    np.testing.assert_allclose(res.e, res.r - res.y, rtol=0, atol=0)
    np.testing.assert_allclose(res.y[-1], reference.r[-1], rtol=0, atol=1e-6)
    np.testing.assert_allclose(res.t, np.arange(len(reference)) * 1e-3, rtol=0, atol=1e-15)
    # F*_y equals the mass times the averaged reference acceleration plus a tiny feedback share
    ff = 30.0 * 0.5 * (reference.a + np.append(reference.a[1:], reference.a[-1]))
    np.testing.assert_allclose(res.f_star[:, 0], ff, rtol=0, atol=1e-2 * np.abs(ff).max())


def test_log_columns_follow_design_format(double_integrator):
    res = double_integrator
    cols = res.columns()
    n = len(res.t)
    L = res.currents.shape[1]
    required = ["t", "y", "Fy", "Fx", "Tz", "r"]
    required += [f"ia_{l}" for l in range(1, L + 1)] + [f"ib_{l}" for l in range(1, L + 1)]
    required += [f"Fy_ref_{l}" for l in range(1, L + 1)] + [f"delta_{l}" for l in range(1, L + 1)]
    for name in required:
        assert name in cols, name
        assert np.shape(cols[name]) == (n,), name
    assert "ia_0" not in cols and f"ia_{L + 1}" not in cols  # 1-based coil sets
    np.testing.assert_array_equal(cols["y"], res.y_meas)  # the log holds what the encoder read
    np.testing.assert_array_equal(cols["Fy"], res.f_meas[:, 0])
    np.testing.assert_array_equal(cols["Tz"], res.f_meas[:, 2])
    np.testing.assert_array_equal(cols["ib_2"], res.currents[:, 1, 1])
    np.testing.assert_array_equal(cols["delta_3"], res.drive_delta[:, 2])
    assert res.currents.shape == (n, L, 2) and res.drive_fy.shape == (n, L)


def test_drive_inputs_reproduce_currents(plant0, reference):
    """Logged (Fy^l*, Δ^l) for a drive whose k̂, ζ̂ differ from the law's reproduce the currents."""
    drive = TWIN0.motor(k_hat=67.0, zeta_hat=-0.52, current_limit=None)
    law = ClassicalLaw.from_motor(TWIN0.motor(k_hat=TWIN0.k, zeta_hat=TWIN0.zeta, current_limit=None))
    res = simulate(plant0, law, reference, drive=drive, feedforward=Feedforward(mass=30.0),
                   loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NO_NOISE))
    cur = drive_currents(jnp.asarray(res.y_meas), jnp.asarray(res.drive_fy), jnp.asarray(res.drive_delta),
                         jnp.asarray(drive.k), jnp.asarray(drive.zeta), drive.pole_pitch)
    np.testing.assert_allclose(np.asarray(cur), res.currents, rtol=0, atol=1e-10 * np.abs(res.currents).max())
    # one sign convention: the force magnitude keeps the sign, Δ in (-π/2, π/2]
    assert np.all((res.drive_delta > -np.pi / 2) & (res.drive_delta <= np.pi / 2))
    assert np.any(res.drive_fy < -1.0) and np.any(res.drive_fy > 1.0)


@pytest.fixture(scope="module")
def batch_setup(plant0, exact_drive):
    laws = [ClassicalLaw.from_motor(exact_drive),
            ClassicalLaw.from_motor(exact_drive, k=67.0, zeta=-0.52)]
    ffs = [Feedforward(mass=30.0), Feedforward(mass=25.0, viscous=1.0, coulomb=0.5)]
    return laws, ffs, [11, 12]


def test_simulate_many_equals_per_run_simulate(plant0, exact_drive, reference, batch_setup):
    laws, ffs, seeds = batch_setup
    kw = dict(drive=exact_drive, loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NOISY))
    many = simulate_many(plant0, laws, reference, feedforwards=ffs, seeds=seeds, **kw)
    assert len(many) == 2
    for res_b, law, ff, seed in zip(many, laws, ffs, seeds):
        res_1 = simulate(plant0, law, reference, feedforward=ff, seed=seed, **kw)
        # Tolerances follow the scale of what each quantity is computed from, not its own size:
        # positions and the tracking error e = r - y are differences of positions of the size of
        # the reference, so a rounding of y (~1e-17 m at 0.1 m) shows in e (~1e-7 m) as is; the
        # forces and currents are computed from F* and the gain, of the size of the largest force.
        pos_scale = np.abs(reference.r).max()
        force_scale = np.abs(res_1.f_star).max()
        scales = {"y": pos_scale, "y_meas": pos_scale, "e": pos_scale, "f_star": force_scale,
                  "f_true": force_scale, "f_meas": force_scale,
                  "currents": np.abs(res_1.currents).max(), "drive_fy": force_scale}
        for name, scale in scales.items():
            a, b = getattr(res_b, name), getattr(res_1, name)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-10 * scale, err_msg=name)
        dd = np.angle(np.exp(1j * (res_b.drive_delta - res_1.drive_delta)))
        np.testing.assert_allclose(dd, 0.0, atol=1e-12)
    # the two runs really differ
    assert np.abs(many[0].f_star - many[1].f_star).max() > 1e-3


def test_simulation_is_deterministic_by_seed(plant0, exact_drive, reference, batch_setup):
    law = batch_setup[0][1]
    kw = dict(drive=exact_drive, feedforward=Feedforward(mass=30.0),
              loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NOISY))
    a = simulate(plant0, law, reference, seed=5, **kw)
    b = simulate(plant0, law, reference, seed=5, **kw)
    c = simulate(plant0, law, reference, seed=6, **kw)
    np.testing.assert_array_equal(a.f_meas, b.f_meas)
    np.testing.assert_array_equal(a.y, b.y)
    assert np.abs(a.f_meas - c.f_meas).max() > 1e-3
    # noise acts on the measurement only, not on the motion
    np.testing.assert_array_equal(a.y, c.y)
    np.testing.assert_array_equal(a.f_true, c.f_true)
    noise = a.f_meas - a.f_true
    np.testing.assert_allclose(noise.std(axis=0), NOISY.force_noise, rtol=0.15)


def test_current_limit_is_respected(plant0, reference):
    drive = TWIN0.motor(k_hat=67.0, zeta_hat=-0.52, current_limit=0.2)
    law = ClassicalLaw.from_motor(TWIN0.motor(k_hat=67.0, zeta_hat=-0.52, current_limit=None))
    res = simulate(plant0, law, reference, drive=drive, feedforward=Feedforward(mass=30.0),
                   loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NO_NOISE))
    peak = np.abs(np.asarray(star_to_phases(jnp.asarray(res.currents)))).max()
    assert peak <= 0.2 * (1 + 1e-12)
    assert peak == pytest.approx(0.2, rel=1e-9)  # the limit is reached on this move


#: force-map grid size shared by both force-map tests (same shapes: one compilation)
N_MAP = 3201


def test_force_map_plant_outside_range_raises(plant0, exact_drive, reference):
    fmap = ForceMapPlant.from_plant(plant0, np.linspace(-0.02, 0.03, N_MAP))  # the move goes to 0.05 m
    law = ClassicalLaw.from_motor(exact_drive)
    with pytest.raises(DataError, match="outside"):
        simulate(fmap, law, reference, drive=exact_drive, feedforward=Feedforward(mass=30.0),
                 loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NO_NOISE))


def test_force_map_plant_inside_range_matches_twin(plant0, exact_drive, reference, double_integrator):
    """A dense force map of the effect-free twin gives (nearly) the twin's closed loop."""
    fmap = ForceMapPlant.from_plant(plant0, np.linspace(-0.02, 0.06, N_MAP))
    law = ClassicalLaw.from_motor(exact_drive)
    a = simulate(fmap, law, reference, drive=exact_drive, feedforward=Feedforward(mass=30.0),
                 loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NO_NOISE))
    b = double_integrator
    # linear interpolation of sinusoids on 25 µm steps: gain error <= (2π h/d_m)²/8 ≈ 3e-5 relative
    np.testing.assert_allclose(a.f_true[:, 0], b.f_true[:, 0], rtol=0, atol=1e-4 * np.abs(b.f_true[:, 0]).max())
    assert np.abs(a.y - b.y).max() < 1e-6


def test_reference_sample_time_mismatch_raises(plant0, exact_drive, reference):
    drive = dataclasses.replace(exact_drive, sample_time=2e-3)
    with pytest.raises(DataError, match="sample time"):
        simulate(plant0, ClassicalLaw.from_motor(exact_drive), reference, drive=drive)


def test_unstable_mechanics_raises(plant0, exact_drive, reference):
    with pytest.raises(ValueError, match="substeps"):
        simulate(plant0, ClassicalLaw.from_motor(exact_drive), reference, drive=exact_drive,
                 loop=ClosedLoop(mechanics=Mechanics(coulomb_velocity=1e-5, substeps=1)))


def test_default_pid_is_tuned_for_mass(double_integrator):
    assert isinstance(double_integrator, SimResult)
    assert PID.tuned(FRICTIONLESS.mass) == PID.tuned(30.0)


def test_other_law_values_and_reference_lengths_reuse_the_compiled_loop(plant0, exact_drive, reference):
    """The law's values and the reference are arguments of one compiled program: a second law of the same
    class with other values, on a reference of another length, compiles nothing new."""
    from pgcomm import simulate as sim_mod

    kw = dict(drive=exact_drive, loop=ClosedLoop(mechanics=FRICTIONLESS, sensors=NO_NOISE))
    first = simulate(plant0, ClassicalLaw.from_motor(exact_drive), reference, feedforward=Feedforward(mass=30.0), **kw)
    compiled = sim_mod._chunk._cache_size()
    longer = trajectory.point_to_point(0.0, 0.08, 0.2, 2.0, 1000.0, 1e-3)
    assert len(longer) != len(reference) and max(len(longer), len(reference)) > 1  # another length
    other = simulate(plant0, ClassicalLaw.from_motor(exact_drive, k=60.0, zeta=-0.5), longer,
                     feedforward=Feedforward(mass=25.0), **kw)
    assert sim_mod._chunk._cache_size() == compiled
    assert np.abs(other.currents[: len(first.t)] - first.currents).max() > 1e-3  # the other values were used
