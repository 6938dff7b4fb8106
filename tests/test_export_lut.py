"""Tests of pgcomm.export.lut: the tabulated law, its error, files, and the anti-cogging table."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import _c_harness as c_harness
from pgcomm.commutation import ModelLaw, classical_single_direction
from pgcomm.errors import DataError
from pgcomm.export.lut import (
    DEFAULT_RESOLUTION,
    build_cogging_table,
    build_lut,
    classical_parameters,
    cogging_table_error,
    drive_gain,
    f_star_set,
    lut_currents,
    lut_error,
    lut_header,
    read_lut,
    write_cogging_table,
    write_lut,
)
from pgcomm.models import MLP, CoilSetModel, CombinedModel, physics_from_ideal

POLE_PITCH = 0.03
#: paper's Table Parameters_CLM and lever arms
PAPER_K = (61.34, 61.62, 60.07)
PAPER_ZETA = (-0.54, -0.55, -0.55)
PAPER_LEVER = (-0.065, 0.005, 0.075)
#: paper-like magnitudes of the network outputs per row [Fy, Fx, Tz]
GAIN_SCALE = np.array([1.5, 0.1, 0.01])
COG_SCALE = np.array([3.0, 0.5, 0.05])


def _mlp(key, widths, scale):
    k1, k2, k3 = jax.random.split(key, 3)
    net = MLP.init(k1, widths)
    n = widths[-1]
    return MLP(net.hidden, jax.random.normal(k2, (n, 3)) * scale / np.sqrt(n), jax.random.normal(k3, (3,)) * scale)


def paper_model(seed=0, L=3, gain=True, cog_scale=COG_SCALE, y_range=(-0.1, 0.1)):
    """Paper-like PGNN (d_m = 0.03 m, k ≈ 61 N/A, μ = 0.05, paper lever arms) with random networks."""
    key = jax.random.PRNGKey(seed)
    sets = []
    for l in range(L):
        key, k1, k2, k3 = jax.random.split(key, 4)
        A, B = physics_from_ideal(POLE_PITCH, PAPER_K[l % 3], PAPER_ZETA[l % 3], 0.05, PAPER_LEVER[l % 3])
        nets = (_mlp(k1, (2,), GAIN_SCALE), _mlp(k2, (2,), GAIN_SCALE)) if gain else None
        sets.append(CoilSetModel(jnp.asarray(A), jnp.asarray(B), nets, _mlp(k3, (16,), cog_scale), POLE_PITCH,
                                 0.0, 0.1, *y_range))
    return CombinedModel.from_coil_sets(sets)


@pytest.fixture(scope="module")
def model():
    return paper_model(0)


@jax.jit
def _law_currents(law, y, f):
    return law.currents(y, f)


# ---------------------------------------------------------------------------------------------
# the table law
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("L, limit", [(3, None), (2, None), (3, 2.0)])
def test_exact_at_grid_points(L, limit):
    model = paper_model(1, L=L)
    lut = build_lut(model, 1e-3, current_limit=limit)
    assert lut.n == 201 and lut.dy == pytest.approx(1e-3, rel=1e-12)
    rng = np.random.default_rng(3)
    y = np.repeat(lut.y, 4)
    f = rng.uniform(-1, 1, (y.size, 3)) * [100.0, 5.0, 1.0]
    i_lut = np.asarray(lut_currents(lut, y, f))
    i_law = np.asarray(_law_currents(ModelLaw(model, current_limit=limit), jnp.asarray(y), jnp.asarray(f)))
    # relative to the largest |current| of the batch
    assert np.max(np.abs(i_lut - i_law)) <= 1e-12 * np.max(np.abs(i_law))


def test_error_decreases_quadratically(model):
    res = [1e-3, 5e-4, 2.5e-4]
    errs = np.array([lut_error(build_lut(model, r), model, 100.0).abs for r in res])  # (3 resolutions, 3 dirs)
    ratios = errs[:-1] / errs[1:]
    assert np.all((ratios > 3.0) & (ratios < 5.0)), ratios


def test_default_resolution_meets_a_tenth_of_a_percent():
    """The documented default: worst case < 0.1 % of f_max on paper-like models (d_m = 0.03 m, ~61 N/A)."""
    for seed in (0, 1, 2):
        m = paper_model(seed)
        lut = build_lut(m)
        assert lut.dy == pytest.approx(DEFAULT_RESOLUTION, rel=1e-9)
        e = lut_error(lut, m, 100.0)
        assert e.worst_rel < 1e-3, (seed, e.to_dict())
        assert e.points == (lut.n - 1) * 10 + 1


def test_error_is_measured_on_the_model(model):
    """A table built on another model shows that model's difference, not zero."""
    lut = build_lut(paper_model(5), 1e-3)
    assert lut_error(lut, model, 100.0).worst_rel > 1e-2


def test_f_star_set():
    fs = f_star_set(100.0)
    assert fs.shape == (18, 3)
    assert np.all(np.abs(fs[:, 0]) == 100.0) and set(np.abs(fs[:, 1:]).ravel()) == {0.0, 5.0}


def test_grid_ends_on_the_range_with_spacing_below_resolution(model):
    lut = build_lut(model, 3e-4, y_range=(-0.05, 0.07))
    assert lut.y[0] == -0.05 and lut.y[-1] == 0.07
    assert lut.dy <= 3e-4 * (1 + 1e-12) and lut.dy > 3e-4 * (1 - 1 / lut.n)
    assert np.allclose(np.diff(lut.y), lut.dy, rtol=1e-9, atol=0)
    assert lut.entries == lut.n * 21 and lut.nbytes == 4 * lut.entries


def test_bad_arguments(model):
    with pytest.raises(ValueError, match="resolution"):
        build_lut(model, 0.0)
    with pytest.raises(ValueError, match="y_range"):
        build_lut(model, 1e-3, y_range=(0.1, -0.1))
    no_range = CombinedModel(model.A, model.B, model.gain_nets, model.cog_nets, model.y_center, model.y_scale,
                             model.pole_pitch)
    with pytest.raises(ValueError, match="training range"):
        build_lut(no_range, 1e-3)
    with pytest.raises(ValueError, match="f_max"):
        lut_error(build_lut(model, 1e-3), model, 0.0)


# ---------------------------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------------------------


def test_csv_round_trip(tmp_path, model):
    lut = build_lut(model, 1e-3, current_limit=8.0)
    csv_path, h_path = write_lut(lut, tmp_path / "out", name="lut_a")
    assert (csv_path.name, h_path.name) == ("lut_a.csv", "lut_a.h")
    header = csv_path.read_text().splitlines()[0].split(",")
    assert header[:4] == ["y", "P_1a_y", "P_1a_x", "P_1a_z"] and header[-3:] == ["Fy_cog", "Fx_cog", "Tz_cog"]
    assert "P_3b_z" in header and len(header) == 1 + 18 + 3
    back = read_lut(csv_path, current_limit=8.0)
    assert np.array_equal(back.y, lut.y) and np.array_equal(back.P, lut.P)
    assert np.array_equal(back.cogging, lut.cogging) and back.current_limit == 8.0
    text = h_path.read_text()
    assert f"{lut.nbytes} bytes" in text and "static const float lut_a_P[201][3][2][3]" in text


def test_read_lut_refuses_bad_files(tmp_path, model):
    csv_path, _ = write_lut(build_lut(model, 1e-2), tmp_path)
    lines = csv_path.read_text().splitlines()
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join([lines[0].replace("P_2a_x", "P_2a_q"), *lines[1:]]))
    with pytest.raises(DataError, match="column 9 is 'P_2a_q', expected 'P_2a_x'"):
        read_lut(bad)
    rows = [r.split(",") for r in lines[1:]]
    rows[3][0] = str(float(rows[3][0]) + 1e-4)
    bad.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]))
    with pytest.raises(DataError, match="not uniformly spaced"):
        read_lut(bad)
    rows[3][0], rows[2][5] = lines[4].split(",")[0], "nan"
    bad.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]))
    with pytest.raises(DataError, match="row 3, column 'P_1b_x' is not finite"):
        read_lut(bad)


@pytest.mark.parametrize("limit", [None, 2.0])
def test_c_header_matches_python_table_law(cc, tmp_path, limit):
    model = paper_model(2)
    lut = build_lut(model, 1e-3, current_limit=limit)
    (tmp_path / "tab.h").write_text(lut_header(lut, "tab"))
    exe = c_harness.compile_lut(cc, tmp_path, "tab")
    rng = np.random.default_rng(0)
    y = np.concatenate([rng.uniform(-0.1, 0.1, 2000), [-0.2, 0.15]]).astype(np.float32).astype(float)
    f = (rng.uniform(-1, 1, (y.size, 3)) * [100.0, 5.0, 1.0]).astype(np.float32).astype(float)
    ret, i_c = c_harness.run_lut(exe, 3, y, f)
    assert ret.tolist() == [0] * 2000 + [1, 1]
    i_py = np.asarray(lut_currents(lut, y, f))
    # float32 table entries and arithmetic against the float64 table law
    assert np.max(np.abs(i_c - i_py)) <= 1e-5 * np.max(np.abs(i_py))


# ---------------------------------------------------------------------------------------------
# anti-cogging table
# ---------------------------------------------------------------------------------------------


def test_classical_parameters_recover_an_ideal_motor():
    m = paper_model(0, gain=False)
    k, zeta = classical_parameters(m)
    assert np.allclose(k, PAPER_K, rtol=1e-13) and np.allclose(zeta, PAPER_ZETA, atol=1e-13)


def test_cogging_table_interpolation_and_law_error(tmp_path):
    """On an ideal motor with cogging only in y, classical + table leaves just the table's interpolation error."""
    m = paper_model(3, gain=False, cog_scale=np.array([3.0, 0.0, 0.0]))
    errs = []
    for res in (1e-3, 5e-4):
        table = build_cogging_table(m, res)
        e = cogging_table_error(table, m, 100.0)
        assert np.allclose(e.k_hat, PAPER_K) and np.allclose(e.zeta_hat, PAPER_ZETA)
        assert e.law_abs[0] <= e.interpolation * (1 + 1e-6) + 1e-9  # Fy: exactly the table error
        assert np.all(e.law_abs[1:] <= 1e-9)  # an ideal motor makes no Fx, Tz from in-phase currents
        errs.append(e.interpolation)
    assert 3.0 < errs[0] / errs[1] < 5.0
    path = write_cogging_table(table, tmp_path, "cog")
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert path.read_text().startswith("y,Fy_cog\n")
    assert np.array_equal(data[:, 0], table.y) and np.array_equal(data[:, 1], np.asarray(table.values))
    assert np.allclose(np.asarray(table.offset(table.y)), np.asarray(table.values), rtol=0, atol=1e-12)


def test_cogging_table_on_a_pgnn_model_shows_what_the_full_law_corrects(model):
    table = build_cogging_table(model)
    e = cogging_table_error(table, model, 100.0)
    full = lut_error(build_lut(model), model, 100.0)
    assert e.interpolation < 1e-3  # N: the table itself is fine ...
    assert e.law_abs[0] > 10 * full.abs[0]  # ... the gain mismatch of classical commutation is not
    d = e.to_dict()
    assert set(d["classical_plus_table"]) == {"y", "x", "z"} and len(d["k_hat"]) == 3
    # explicit drive parameters are used as given (the table built for that drive)
    t2 = build_cogging_table(model, k_hat=67.0, zeta_hat=-0.52)
    e2 = cogging_table_error(t2, model, 100.0, k_hat=67.0, zeta_hat=-0.52)
    assert np.all(e2.k_hat == 67.0) and e2.law_abs[0] > e.law_abs[0] and e2.interpolation < 1e-3


@jax.jit
def _standstill_force(model, y, offset, k_hat, zeta_hat):
    """F̂_y when the drive commutates the demand 0 - offset(y) classically (N)."""
    i = classical_single_direction(y, -offset, k_hat, zeta_hat, model.pole_pitch)
    return jnp.sum(model.gain(y)[..., 0, :] * i, axis=(-2, -1)) + model.cogging(y)[..., 0]


def test_cogging_table_for_the_drives_commutation_cancels_cogging_at_standstill():
    """A drive whose k̂ is 10 % high and ζ̂ 0.05 rad off: the table built for it leaves only its interpolation error
    at zero demand; the plain cogging table (built for a matched drive) leaves the gain mismatch's share."""
    m = paper_model(4)
    k_fit, z_fit = classical_parameters(m)
    k_hat, zeta_hat = 1.1 * k_fit, z_fit + 0.05
    y = np.linspace(-0.1, 0.1, 4001)
    g = drive_gain(m, y, k_hat, zeta_hat)
    want = np.cos(0.05) / 1.1                                       # (k/k̂) cos(ζ - ζ̂) plus the model's ripple
    assert abs(np.mean(g) - want) < 0.05 * want
    cog = np.asarray(m.cogging(jnp.asarray(y)))[:, 0]
    cog_scale = np.abs(cog).max()
    for_drive = build_cogging_table(m, 2.5e-4, k_hat=k_hat, zeta_hat=zeta_hat)
    matched = build_cogging_table(m, 2.5e-4)                        # for the model's fitted k, zeta
    e = cogging_table_error(for_drive, m, 100.0, k_hat, zeta_hat)
    left = np.asarray(_standstill_force(m, jnp.asarray(y), for_drive.offset(jnp.asarray(y)), jnp.asarray(k_hat),
                                        jnp.asarray(zeta_hat)))
    left_matched = np.asarray(_standstill_force(m, jnp.asarray(y), matched.offset(jnp.asarray(y)),
                                                jnp.asarray(k_hat), jnp.asarray(zeta_hat)))
    assert e.interpolation < 1e-3 * cog_scale
    assert np.max(np.abs(left)) <= 1.01 * e.interpolation * np.max(g) + 1e-12 * cog_scale
    # the matched table under-compensates by about (1 - g) of the cogging force
    assert np.max(np.abs(left_matched)) > 0.5 * (1 - np.mean(g)) * cog_scale > 50 * np.max(np.abs(left))


def test_cogging_table_refuses_a_drive_that_makes_no_force():
    m = paper_model(1)
    k_fit, z_fit = classical_parameters(m)
    with pytest.raises(ValueError, match=r"makes only .* N per N commanded at y = .*check the drive's zeta_hat"):
        build_cogging_table(m, 1e-3, k_hat=k_fit, zeta_hat=z_fit + np.pi / 2)
    with pytest.raises(ValueError, match="makes only -"):  # ζ̂ off by π: the table would push the wrong way
        build_cogging_table(m, 1e-3, k_hat=k_fit, zeta_hat=z_fit + np.pi)
    with pytest.raises(ValueError, match="must be positive"):
        build_cogging_table(m, 1e-3, k_hat=-61.0, zeta_hat=z_fit)


def test_cogging_table_file_states_its_drive(tmp_path):
    m = paper_model(2)
    table = build_cogging_table(m, 1e-3, k_hat=60.0, zeta_hat=-0.5)
    path = write_cogging_table(table, tmp_path, "cog", comments=["drive k_hat = 60 N/A, zeta_hat = -0.5 rad",
                                                                  "from\n--drive-k"])
    text = path.read_text()
    assert text.startswith("# drive k_hat = 60 N/A, zeta_hat = -0.5 rad\n# from --drive-k\ny,Fy_cog\n")
    data = np.loadtxt(path, delimiter=",", skiprows=3)  # the two comment lines and the header
    assert np.array_equal(data[:, 0], np.asarray(table.y)) and np.array_equal(data[:, 1], np.asarray(table.values))
