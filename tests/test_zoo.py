"""Motor zoo: determinism, ranges, truth, file round trips, conventions."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pgcomm  # noqa: F401  (enables float64)
from pgcomm.setup import build_setup
from pgcomm.io.config import load_experiment
from pgcomm.forcemap import ForceMapPlant
from pgcomm.io.forcemap import load_forcemap
from pgcomm.io.config import load_motor
from pgcomm.motor import PHASE_OFFSETS
from pgcomm.plant import fundamental
from pgcomm.setup import reference_span
from pgcomm.zoo import EFFECTS, ZooMotor, draw_motor, motor_folder_name, write_motor, write_zoo

N_DRAWS = 50
FILES = ("plant.csv", "motor.toml", "config.toml", "truth.json")


def _wrapped(a):
    return np.angle(np.exp(1j * np.asarray(a)))


@pytest.fixture(scope="module")
def draws():
    return [draw_motor(7, i) for i in range(N_DRAWS)]


@pytest.fixture(scope="module")
def zoo(tmp_path_factory):
    out = tmp_path_factory.mktemp("zoo")
    return write_zoo(2, 11, out)


# ----------------------------------------------------------------------------- drawing


def test_same_seed_same_files(zoo, tmp_path):
    again = write_zoo(2, 11, tmp_path)
    assert [f.name for f in again] == ["motor_01", "motor_02"]
    for a, b in zip(zoo, again):
        for name in FILES:
            assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_index_independent_and_seed_matters():
    assert draw_motor(3, 5) == draw_motor(3, 5)
    assert draw_motor(3, 5) != draw_motor(4, 5)
    assert draw_motor(3, 5) != draw_motor(3, 6)


def test_folder_names():
    assert motor_folder_name(1, 9) == "motor_01"
    assert motor_folder_name(12, 99) == "motor_12"
    assert motor_folder_name(7, 100) == "motor_007"


def test_ranges_respected(draws):
    seen_l = set()
    for m in draws:
        L = m.n_coil_sets
        seen_l.add(L)
        assert 1 <= L <= 4
        assert 0.010 <= m.pole_pitch <= 0.060
        assert 0.05 <= m.stroke <= 0.5 and m.stroke >= 4 * m.pole_pitch
        k = np.asarray(m.k)
        assert np.all((k >= 10 * 0.97) & (k <= 200 * 1.03))
        assert np.ptp(k) <= 0.06 * k.mean()                       # coil sets within a few %
        z = np.asarray(m.zeta)
        assert np.all((z > -np.pi) & (z <= np.pi))
        assert np.max(np.abs(_wrapped(z - z[0]))) <= 0.06          # close to each other on the circle
        assert 0.01 <= abs(m.mu) <= 0.1
        assert np.max(np.abs(m.lateral_offsets)) <= 0.005
        assert set(m.effects) <= set(EFFECTS)
        # coil sets spaced by about a coil-set length, centre of mass among them
        d = np.sort(m.lever_arms)
        if L > 1:
            gaps = np.diff(d)
            assert np.all(gaps >= m.coil_set_length - m.pole_pitch / 2)
            assert np.all(gaps <= 1.3 * m.coil_set_length + m.pole_pitch)
            assert d[0] <= 0.3 * gaps[0] + 1e-12 and d[-1] >= -0.3 * gaps[-1] - 1e-12
        # track covers every coil at every map position
        assert m.track[0] <= -m.stroke / 2 + d[0] - m.coil_set_length / 2 + 1e-12
        assert m.track[1] >= m.stroke / 2 + d[-1] + m.coil_set_length / 2 - 1e-12
        assert len(m.magnet_remanence) * m.pole_pitch / 2 >= m.track[1] - m.track[0]
        if "magnets" in m.effects:
            assert 0.002 < np.std(m.magnet_remanence) < 0.03
        # starting guess off by a few % / tens of mrad
        assert 0.015 <= abs(m.k_hat / k.mean() - 1) <= 0.1
        assert 0.005 <= abs(_wrapped(m.zeta_hat - np.angle(np.mean(np.exp(1j * z))))) <= 0.08
        # the machine: positive, and the reference stays in the map
        assert m.mass > 0 and m.viscous > 0 and m.coulomb > 0 and m.current_limit > 0
        lo, hi = m.reference_range
        assert -m.stroke / 2 < lo < hi < m.stroke / 2 and np.isclose(lo, -hi)
        assert max(m.velocities) ** 2 / m.a_max <= hi * (1 + 1e-12)
    assert seen_l == {1, 2, 3, 4}
    for e in EFFECTS:  # every effect is sometimes present, sometimes absent
        n = sum(e in m.effects for m in draws)
        assert 0 < n < N_DRAWS, e


def test_force_budget(draws):
    """The reference's largest demand stays well inside one coil set's force at the current limit."""
    from pgcomm.zoo import FORCE_BUDGET, _cable_max

    for m in draws:
        f1 = min(m.k) * m.current_limit
        need = (m.mass * m.a_max + m.viscous * max(m.velocities) + m.coulomb
                + _cable_max(m.cable, m.cog_periodic)[0])
        assert need <= FORCE_BUDGET * f1 * (1 + 1e-9)
        cable = _cable_max(m.cable, (0.0, 0.0, 0.0))[0]
        assert cable <= 0.04 * m.force_capacity * (1 + 1e-9)  # up to a few % of the capacity


# ----------------------------------------------------------------------------- physics


def test_tz_row_is_lever_arm_times_fx_minus_offset_times_fy(draws):
    for m in draws[:10]:
        y = np.linspace(*m.y_range, 301)
        g = m.gain_phases(y)
        d = np.asarray(m.lever_arms)[:, None]
        x = np.asarray(m.lateral_offsets)[:, None]
        scale = np.max(np.abs(g[:, :, 2]))
        np.testing.assert_allclose(g[:, :, 2], d * g[:, :, 1] - x * g[:, :, 0], rtol=0, atol=1e-13 * scale)


def test_ideal_motor_projects_onto_its_k_and_zeta(draws):
    """Closed form: Σ_p Fy_p sin(w + φ_p) = k cos ζ and Σ_p Fy_p cos(w + φ_p) = k sin ζ at every y."""
    for m in draws[:10]:
        ideal = m.without(*EFFECTS)
        assert ideal.effects == ()
        y = np.linspace(*m.y_range, 501)
        fy = ideal.gain_phases(y)[:, :, 0, :]                      # (M, L, 3)
        w = 2 * np.pi * y[:, None] / m.pole_pitch + np.asarray(PHASE_OFFSETS)
        kc = np.einsum("mlp,mp->ml", fy, np.sin(w))
        ks = np.einsum("mlp,mp->ml", fy, np.cos(w))
        k, z = np.asarray(m.k), np.asarray(m.zeta)
        np.testing.assert_allclose(np.hypot(kc, ks), np.broadcast_to(k, kc.shape), rtol=1e-12)
        np.testing.assert_allclose(_wrapped(np.arctan2(ks, kc) - z), 0.0, atol=1e-12)
        # the general fit on a map whose rows are the fit points is interpolation-free
        lo, hi = m.reference_range
        yy = np.linspace(lo, hi, 2001)
        plant = ForceMapPlant.from_arrays(yy, ideal.gain_phases(yy))
        kf, zf = fundamental(plant, m.pole_pitch, (lo, hi), n=2001)
        np.testing.assert_allclose(kf, k, rtol=1e-9)
        np.testing.assert_allclose(_wrapped(zf - z), 0.0, atol=1e-9)


def test_zeta_wraps():
    """A motor with ζ near ±π: the fit returns ζ in (−π, π] equal to the generating value modulo 2π."""
    m = draw_motor(7, 0).without(*EFFECTS)
    for z in (np.pi - 1e-3, -np.pi + 1e-3, np.pi):
        mm = ZooMotor(**{**m.__dict__, "zeta": (z,) * m.n_coil_sets})
        lo, hi = mm.reference_range
        yy = np.linspace(lo, hi, 1001)
        kf, zf = fundamental(ForceMapPlant.from_arrays(yy, mm.gain_phases(yy)), mm.pole_pitch, (lo, hi), n=1001)
        assert np.all((zf > -np.pi) & (zf <= np.pi))
        np.testing.assert_allclose(_wrapped(zf - z), 0.0, atol=1e-9)
        np.testing.assert_allclose(kf, mm.k, rtol=1e-9)


def test_magnet_tolerances_vary_per_phase_and_smoothly(draws):
    """Per-phase gain envelopes differ between phases, vary along the track, and are continuous."""
    m = next(m for m in draws if "magnets" in m.effects)
    only = m.without(*[e for e in EFFECTS if e != "magnets"])
    y = np.linspace(*m.y_range, 20001)
    fy = only.gain_phases(y)[:, 0, 0, :]
    w = 2 * np.pi * y[:, None] / m.pole_pitch + m.zeta[0] + np.asarray(PHASE_OFFSETS)
    ideal = (2 / 3) * m.k[0] * np.sin(w)
    dev = (fy - ideal) / ((2 / 3) * m.k[0])
    assert 1e-3 < np.std(dev) < 0.05
    assert not np.allclose(dev[:, 0], dev[:, 1], atol=1e-4)
    # continuous (box-averaged, not white noise): neighbouring points differ by far less than the spread
    assert np.max(np.abs(np.diff(dev, axis=0))) < 0.1 * np.ptp(dev)


# ----------------------------------------------------------------------------- files


def test_files_load_with_existing_loaders(zoo):
    for folder in zoo:
        truth = json.loads((folder / "truth.json").read_text())
        m = draw_motor(truth["seed"], truth["index"])
        plant = load_forcemap(folder / "plant.csv")
        y = np.asarray(plant.y_grid)
        # the grid: strictly increasing, non-uniform, ≥ 60 rows per pole pitch, spans the map range
        h = np.diff(y)
        assert np.all(h > 0)
        assert np.ptp(h) > 0.05 * h.mean() and not plant.uniform
        assert h.max() <= m.pole_pitch / 60
        assert (y[0], y[-1]) == m.y_range
        np.testing.assert_array_equal(np.asarray(plant.gain_table), m.gain_phases(y))
        np.testing.assert_array_equal(np.asarray(plant.cog_table), m.cogging(y))
        motor = load_motor(folder / "motor.toml")
        assert motor.n_coil_sets == m.n_coil_sets == plant.n_coil_sets
        assert motor.lever_arms == m.lever_arms and motor.pole_pitch == m.pole_pitch
        assert motor.k == (m.k_hat,) * m.n_coil_sets
        config = load_experiment(folder / "config.toml")
        assert config.mechanics.mass == m.mass and config.reference.velocities == m.velocities
        setup = build_setup(config, folder / "plant.csv", folder / "motor.toml")
        assert setup.config.reference.stroke == truth["y_range"][1] == -truth["y_range"][0]
        assert truth["parameters"]["k"] == list(m.k)


def test_truth_is_fundamental_of_map_as_read_back(zoo):
    """Independent recomputation: interpolate the CSV columns with NumPy and fit (k cos ζ, k sin ζ)."""
    for folder in zoo:
        truth = json.loads((folder / "truth.json").read_text())
        d_m = truth["parameters"]["pole_pitch"]
        data = np.genfromtxt(folder / "plant.csv", delimiter=",", names=True)
        lo, hi = truth["y_range"]
        y = np.linspace(lo, hi, 20001)
        w = 2 * np.pi * y / d_m
        for l, (k, z) in enumerate(zip(truth["k"], truth["zeta"]), start=1):
            x = np.concatenate([(2 / 3) * np.stack([np.sin(w + f), np.cos(w + f)], -1) for f in PHASE_OFFSETS])
            rhs = np.concatenate([np.interp(y, data["y"], data[f"Fy_{l}{p}"]) for p in "abc"])
            (kc, ks), *_ = np.linalg.lstsq(x, rhs, rcond=None)
            assert abs(np.hypot(kc, ks) / k - 1) < 1e-9
            assert abs(_wrapped(np.arctan2(ks, kc) - z)) < 1e-9
            # near the generating values: only parasitic effects move it
            m = truth["parameters"]
            assert abs(k / m["k"][l - 1] - 1) < 0.05
            assert abs(_wrapped(z - m["zeta"][l - 1])) < 0.05


def test_reference_span():
    lo, hi = reference_span(-0.1, 0.1)
    assert (lo, hi) == pytest.approx((-0.095, 0.095))
    assert reference_span(-0.025, 0.025) == pytest.approx((-0.023, 0.023))   # 2 mm floor
    assert reference_span(-0.25, 0.25) == pytest.approx((-0.24, 0.24))      # 10 mm cap
    lo, hi = reference_span(0.0, 0.004)
    assert 0 < lo < hi < 0.004
    with pytest.raises(ValueError):
        reference_span(0.1, 0.1)


def test_twin_type_plant_adds_direction_force(draws):
    m = next(m for m in draws if "direction" in m.effects)
    plant = m.plant(direction=True)
    static = m.plant(direction=False)
    y = jnp.asarray(np.linspace(-0.01, 0.01, 5))
    v = jnp.asarray([-0.1, -1e-4, 0.0, 1e-4, 0.1])
    i = jnp.ones((5, m.n_coil_sets, 2))
    f = jax.jit(lambda p, y, v, i: p.force(y, i, v))
    diff = np.asarray(f(plant, y, v, i) - f(static, y, v, i))
    expected = np.asarray(m.direction_force) * np.tanh(np.asarray(v) / m.direction_velocity)[:, None]
    np.testing.assert_allclose(diff, expected, rtol=1e-12, atol=1e-12 * max(m.direction_force))
    assert plant.y_range == m.y_range
    assert bool(plant.in_range(jnp.asarray(0.0))) and not bool(plant.in_range(jnp.asarray(m.stroke)))


def test_write_motor_leaves_exactly_the_four_files(tmp_path):
    folder = write_motor(draw_motor(2, 3), tmp_path / "a" / "m")
    assert sorted(p.name for p in folder.iterdir()) == sorted(FILES)  # no temporary files left behind
