"""Force-map plant: file round trip, interpolation, ideal-motor accuracy, bad input."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pgcomm  # noqa: F401  (enables float64)
from pgcomm.errors import DataError
from pgcomm.forcemap import ForceMapPlant, check_in_range
from pgcomm.io.forcemap import forcemap_columns, load_forcemap, write_forcemap
from pgcomm.motor import Motor, ideal_gain_phases, star_reduce
from pgcomm.plant import plant_force


# Jitted entry points: one compilation per shape instead of one per primitive in eager mode.
_gain_phases = jax.jit(lambda p, y: p.gain_phases(y))
_gain = jax.jit(lambda p, y: p.gain(y))
_cogging = jax.jit(lambda p, y: p.cogging(y))


def _random_map(m=11, n_sets=2, seed=0, uniform=True):
    rng = np.random.default_rng(seed)
    y = np.linspace(-0.05, 0.05, m) if uniform else np.sort(rng.uniform(-0.05, 0.05, m))
    return y, rng.standard_normal((m, n_sets, 3, 3)) * 30.0, rng.standard_normal((m, 3))


def _ideal_tables(motor, y):
    """``(M, L, 3, 3)`` ideal per-phase gains of all coil sets of ``motor``."""
    f = jax.jit(lambda y: jnp.stack(
        [ideal_gain_phases(y, k, z, motor.mu, d, motor.pole_pitch) for k, z, d in zip(motor.k, motor.zeta, motor.lever_arms)],
        axis=1,
    ))
    return np.asarray(f(jnp.asarray(y)))


def _csv(tmp_path, header, rows, name="forcemap.csv"):
    p = tmp_path / name
    p.write_text(",".join(header) + "\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    return p


def _valid(n_sets=2, m=3, cog=True):
    names = forcemap_columns(n_sets, cog)
    rows = [[0.01 * i] + [1.0] * (len(names) - 1) for i in range(m)]
    return names, rows


# ----------------------------------------------------------------------------- round trip


def test_round_trip_identical(tmp_path):
    y, g, c = _random_map(n_sets=3)
    path = tmp_path / "fm.csv"
    write_forcemap(path, y, g, c)
    plant = load_forcemap(path)
    assert plant.n_coil_sets == 3
    assert np.array_equal(np.asarray(plant.y_grid), y)
    assert np.array_equal(np.asarray(plant.gain_table), g)
    assert np.array_equal(np.asarray(plant.cog_table), c)
    assert plant.y_range == (y[0], y[-1])
    assert path.read_text().splitlines()[0] == ",".join(forcemap_columns(3))
    assert [p.name for p in tmp_path.iterdir()] == ["fm.csv"]  # no temporary left behind


def test_round_trip_without_cogging_means_zero(tmp_path):
    y, g, _ = _random_map()
    path = tmp_path / "fm.csv"
    write_forcemap(path, y, g)
    assert "Fy_cog" not in path.read_text().splitlines()[0]
    plant = load_forcemap(path)
    assert np.array_equal(np.asarray(plant.cog_table), np.zeros((len(y), 3)))


def test_write_refuses_bad_arrays_and_leaves_nothing(tmp_path):
    y, g, c = _random_map()
    with pytest.raises(DataError, match=r"row 3: y = .* not greater"):
        write_forcemap(tmp_path / "fm.csv", y[[0, 1, 1, 3, 4, 5, 6, 7, 8, 9, 10]], g, c)
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- interpolation


@pytest.mark.parametrize("uniform", [True, False])
def test_interpolation_exact_at_grid_and_linear_between(uniform):
    y, g, c = _random_map(m=15, uniform=uniform, seed=3)
    plant = ForceMapPlant.from_arrays(y, g, c)
    assert plant.uniform is uniform
    # exactly the table rows at the grid points (including both ends)
    assert np.array_equal(np.asarray(_gain_phases(plant, y)), g)
    assert np.array_equal(np.asarray(_cogging(plant, y)), c)
    # linear in between: numpy.interp column by column, arbitrary leading shape
    yq = np.random.default_rng(1).uniform(y[0], y[-1], (4, 25))
    got = np.asarray(_gain_phases(plant, yq))
    assert got.shape == (4, 25, 2, 3, 3)
    flat = g.reshape(len(y), -1)
    ref = np.stack([np.interp(yq, y, flat[:, j]) for j in range(flat.shape[1])], axis=-1).reshape(got.shape)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12)
    ref_c = np.stack([np.interp(yq, y, c[:, j]) for j in range(3)], axis=-1)
    np.testing.assert_allclose(np.asarray(_cogging(plant, yq)), ref_c, rtol=1e-12, atol=1e-12)


def test_uniform_and_search_paths_agree_and_jit():
    y, g, c = _random_map(m=101)
    fast = ForceMapPlant.from_arrays(y, g, c)
    slow = ForceMapPlant(fast.y_grid, fast.gain_table, fast.cog_table, uniform=False)
    yq = jnp.linspace(y[0], y[-1], 1001)
    f = jax.jit(lambda p, q: p.gain(q))
    np.testing.assert_allclose(np.asarray(f(fast, yq)), np.asarray(f(slow, yq)), rtol=1e-12, atol=1e-11)
    assert f(fast, 0.0).shape == (2, 3, 2)
    reduced = jax.jit(lambda p, q: star_reduce(p.gain_phases(q)))(fast, yq)
    np.testing.assert_allclose(np.asarray(_gain(fast, yq)), np.asarray(reduced), rtol=1e-13, atol=1e-13)


def test_force_direction_and_range():
    y, g, c = _random_map()
    plant = ForceMapPlant.from_arrays(y, g, c)
    yq = jnp.array([0.0, 0.013])
    i = jnp.ones((2, 2, 2))
    expected = np.einsum("sljk,slk->sj", np.asarray(_gain(plant, yq)), np.asarray(i)) + np.asarray(_cogging(plant, yq))
    force = jax.jit(lambda p, y, v, i: p.force(y, i, v))
    np.testing.assert_allclose(np.asarray(force(plant, yq, jnp.ones(2), i)), expected, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(jax.jit(plant_force)(plant, yq, i, -jnp.ones(2))), expected, rtol=1e-12)
    assert np.array_equal(np.asarray(jax.jit(lambda p, y: p.direction_force(y, y))(plant, yq)), np.zeros((2, 3)))
    inside = np.asarray(jax.jit(plant.in_range)(jnp.array([-0.05, 0.0, 0.05, 0.0501, -1.0, jnp.nan])))
    assert inside.tolist() == [True, True, True, False, False, False]


def test_check_in_range():
    y, g, c = _random_map()
    plant = ForceMapPlant.from_arrays(y, g, c, source="fm.csv")
    check_in_range(plant, np.linspace(-0.05, 0.05, 7), "trajectory")
    with pytest.raises(DataError, match=r"^sim: position y = 0.07 m \(sample 2, and 1 more\) is outside the force map fm.csv \(y from -0.05 to 0.05 m"):
        check_in_range(plant, [0.0, 0.01, 0.07, 0.08], "sim")
    with pytest.raises(DataError, match=r"sample \(1, 0\)"):
        check_in_range(plant, [[0.0, 0.0], [-0.2, 0.0]], "sim")


def test_ideal_motor_reproduced_to_interpolation_accuracy():
    """Linear interpolation of a sinusoid ``A sin(2π y / d_m + φ)`` on a grid of
    spacing ``h`` errs by at most ``A (2π/d_m)² h² / 8``; with ``d_m = 30 mm`` and
    ``h = 0.1 mm`` that is 5.5e-5 of the amplitude."""
    motor = Motor()
    h = 1e-4
    y = np.arange(-0.1, 0.1 + h / 2, h)
    plant = ForceMapPlant.from_arrays(y, _ideal_tables(motor, y))
    yq = np.random.default_rng(7).uniform(-0.1, 0.1, 5000)
    ideal3 = _ideal_tables(motor, yq)
    amp = np.abs(ideal3).reshape(len(yq), -1).max()  # largest amplitude (N/A)
    bound = amp * (2 * np.pi / motor.pole_pitch) ** 2 * h**2 / 8
    err = np.abs(np.asarray(_gain_phases(plant, yq)) - ideal3).max()
    assert err <= bound
    assert err >= 0.5 * bound  # the bound is the actual accuracy, not a loose guess
    # star-reduced gain of the ideal motor, as pgcomm.motor.ideal_gain computes it
    from pgcomm.motor import ideal_gain

    err2 = np.abs(np.asarray(_gain(plant, yq)) - np.asarray(jax.jit(lambda q: ideal_gain(q, motor))(yq))).max()
    assert err2 <= 2 * bound
    # at the grid points the map is the ideal motor exactly
    np.testing.assert_allclose(np.asarray(_gain(plant, y[::97])), np.asarray(jax.jit(lambda q: ideal_gain(q, motor))(y[::97])), rtol=0, atol=1e-12)


def test_from_plant_samples():
    y, g, c = _random_map(m=21)
    a = ForceMapPlant.from_arrays(y, g, c)
    b = ForceMapPlant.from_plant(a, y[::2])
    assert np.array_equal(np.asarray(b.gain_table), g[::2])


# ----------------------------------------------------------------------------- bad input


def test_missing_phase_column(tmp_path):
    names, rows = _valid()
    i = names.index("Fy_2c")
    p = _csv(tmp_path, names[:i] + names[i + 1:], [r[:i] + r[i + 1:] for r in rows])
    with pytest.raises(DataError, match=r"^.*forcemap.csv: column 'Fy_2c' missing \(coil set 2 has Fy_2a, Fy_2b but no phase c\)$"):
        load_forcemap(p)


def test_missing_quantity(tmp_path):
    names, rows = _valid(n_sets=1)
    keep = [j for j, n in enumerate(names) if not n.startswith("Tz_1")]
    p = _csv(tmp_path, [names[j] for j in keep], [[r[j] for j in keep] for r in rows])
    with pytest.raises(DataError, match=r"column 'Tz_1a' missing \(coil set 1 has no Tz columns"):
        load_forcemap(p)


def test_misnamed_column_closest_match(tmp_path):
    names, rows = _valid()
    names[names.index("Fx_2b")] = "Fx_2B"
    with pytest.raises(DataError, match=r"forcemap.csv: column 'Fx_2B' unknown \(closest match: 'Fx_2b'\)"):
        load_forcemap(_csv(tmp_path, names, rows))


def test_unknown_column(tmp_path):
    names, rows = _valid()
    p = _csv(tmp_path, names + ["temperature"], [r + [20.0] for r in rows])
    with pytest.raises(DataError, match=r"column 'temperature' unknown; expected y, Fy_<l><p>"):
        load_forcemap(p)


def test_coil_set_zero_and_hole(tmp_path):
    names, rows = _valid(n_sets=1)
    names0 = [n.replace("_1", "_0") for n in names]
    with pytest.raises(DataError, match=r"column 'Fy_0a' unknown \(coil sets are numbered from 1\)"):
        load_forcemap(_csv(tmp_path, names0, rows))
    names3 = [n.replace("_1", "_3") for n in forcemap_columns(1, False)]
    names13 = forcemap_columns(1, False) + names3[1:]
    rows13 = [[0.01 * i] + [1.0] * 18 for i in range(3)]
    with pytest.raises(DataError, match=r"no columns for coil set 2 but coil set 3 has some"):
        load_forcemap(_csv(tmp_path, names13, rows13, "hole.csv"))


def test_missing_y(tmp_path):
    names, rows = _valid()
    with pytest.raises(DataError, match=r"column 'pos' unknown \(and there is no column 'y': is 'pos' the position in m\?\)"):
        load_forcemap(_csv(tmp_path, ["pos"] + names[1:], rows))
    with pytest.raises(DataError, match=r"column 'y' \(position in m\) missing"):
        load_forcemap(_csv(tmp_path, names[1:], [r[1:] for r in rows], "noy.csv"))


def test_nan_and_inf_named(tmp_path):
    names, rows = _valid(m=5)
    rows[3][names.index("Tz_1b")] = "nan"
    with pytest.raises(DataError, match=r"forcemap.csv row 4 column 'Tz_1b': nan is not a finite number"):
        load_forcemap(_csv(tmp_path, names, rows))
    names, rows = _valid(m=5)
    rows[1][names.index("Fy_cog")] = "-inf"
    with pytest.raises(DataError, match=r"row 2 column 'Fy_cog': -inf is not a finite number"):
        load_forcemap(_csv(tmp_path, names, rows, "inf.csv"))


def test_non_numeric_and_empty_cells(tmp_path):
    names, rows = _valid(m=5)
    rows[2][names.index("Fx_1c")] = "abc"
    with pytest.raises(DataError, match=r"forcemap.csv row 3 column 'Fx_1c': 'abc' is not a number"):
        load_forcemap(_csv(tmp_path, names, rows))
    names, rows = _valid(m=5)
    rows[4][names.index("Fx_1c")] = ""
    with pytest.raises(DataError, match=r"row 5 column 'Fx_1c' is empty"):
        load_forcemap(_csv(tmp_path, names, rows, "empty.csv"))


def test_y_not_increasing(tmp_path):
    names, rows = _valid(m=5)
    rows[3][0] = rows[2][0]
    with pytest.raises(DataError, match=r"forcemap.csv row 4: y = 0.02 m is not greater than y = 0.02 m of row 3"):
        load_forcemap(_csv(tmp_path, names, rows))


def test_too_few_rows(tmp_path):
    names, rows = _valid(m=1)
    with pytest.raises(DataError, match=r"forcemap.csv: 1 data rows, a force map needs at least 2"):
        load_forcemap(_csv(tmp_path, names, rows))


def test_file_problems(tmp_path):
    with pytest.raises(DataError, match=r"nothere.csv: file not found"):
        load_forcemap(tmp_path / "nothere.csv")
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(DataError, match=r"empty.csv: empty file"):
        load_forcemap(tmp_path / "empty.csv")
    names, rows = _valid()
    p = tmp_path / "ragged.csv"
    p.write_text(",".join(names) + "\n" + ",".join(map(str, rows[0])) + "\n1,2\n")
    with pytest.raises(DataError, match=r"ragged.csv row 2 has 2 fields, expected 22"):
        load_forcemap(p)
