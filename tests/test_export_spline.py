"""Spline models (pgcomm.spline_model.SplineModel) in model files, as generated C and as lookup tables.

The models are built directly from small random tables around a paper-like physics fundamental
(fast: no identification). The C tests compile the export with a harness
(``cc -std=c99 -O2 -Wall -Wextra -Werror -pedantic``), feed random samples inside and outside
the knot grids and compare with the Python ``ModelLaw(SplineModel)`` and
``pgcomm.control.feedforward_signal``.

Tolerances are derived from the scales of the inputs: the double export mirrors the Python
evaluation operation by operation, so what is left is the rounding of the trigonometric,
``tanh`` and ``floor`` functions of two libraries (a few ulp of each term). Each quantity is
compared relative to the size of its own terms in the batch (largest |current|, the sum of the
gain table's magnitudes, the feedforward's ``m|a| + f_v|v| + |D|``) at ``REL = 1e-12``, some
ten thousand ulp: far below any physical meaning, far above rounding.
"""

from __future__ import annotations

import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import _c_harness as c_harness
from pgcomm.commutation import ModelLaw, currents_to_drive_inputs
from pgcomm.control import feedforward_signal
from pgcomm.errors import DataError
from pgcomm.export.c import CLawOptions, c_source, write_c
from pgcomm.export.lut import build_cogging_table, build_lut, cogging_table_error, lut_currents, lut_error, write_lut
from pgcomm.io.model import SPLINE_SCHEMA, feedforward_from_metadata, load_model, save_model
from pgcomm.models import physics_from_ideal
from pgcomm.spline_model import SplineModel

D_M = 0.03
GRID = (-0.1, 0.1)           # knot range (m)
TRAIN = (-0.09, 0.09)        # training range (m): the return code flips there
Y_TEST = (-0.14, 0.14)       # test positions: inside and outside the knot grids
F_RANGE = np.array([100.0, 5.0, 1.0])  # |Fy| N, |Fx| N, |Tz| N m
REL = 1e-12


def make_spline(L=3, n_gain=9, n_cog=31, n_dir=7, direction=True, seed=0) -> SplineModel:
    """Paper-like fundamental (k ≈ 61 N/A, ζ ≈ -0.54, μ = 0.05) varying by ~3 % along the stroke."""
    rng = np.random.default_rng(seed)
    lever = np.linspace(-0.065, 0.075, L) if L > 1 else np.array([0.005])
    ab = np.stack([np.stack(physics_from_ideal(D_M, 61.0 + 0.5 * l, -0.54 - 0.01 * l, 0.05, lever[l]))
                   for l in range(L)])                                       # (L, 2, 3, 2)
    gain = ab[None] * (1.0 + 0.03 * rng.standard_normal((n_gain, L, 2, 3, 2)))
    # 5th/7th harmonics at 1 % of each row's fundamental (the Fx, Tz rows are ~20x, ~300x smaller than Fy)
    H = 0.01 * np.abs(ab).max(axis=(1, 3))[:, None, :, None] * rng.standard_normal((L, 4, 3, 2))
    cog = rng.standard_normal((n_cog, 3)) * [3.0, 0.5, 0.05]
    dir_table = rng.standard_normal((n_dir, 3)) * [2.0, 0.3, 0.03] if direction else None
    return SplineModel(
        gain_table=jnp.asarray(gain), H=jnp.asarray(H), cog_table=jnp.asarray(cog),
        dir_table=None if dir_table is None else jnp.asarray(dir_table),
        gain_knots=jnp.asarray(np.linspace(*GRID, n_gain)), cog_knots=jnp.asarray(np.linspace(*GRID, n_cog)),
        dir_knots=jnp.asarray(np.linspace(*GRID, n_dir)), pole_pitch=D_M, y_min=(TRAIN[0],) * L,
        y_max=(TRAIN[1],) * L, direction_velocity=2e-3)


def make_mechanics(seed=1, n=6) -> dict:
    """Mechanics block: mass (kg), viscous (N s/m), Coulomb table (m, N), v_eps (m/s)."""
    rng = np.random.default_rng(seed)
    return {"mass": 4.2, "viscous": 12.5, "coulomb_knots": np.linspace(-0.095, 0.095, n),
            "coulomb_table": 3.0 + rng.standard_normal(n), "direction_velocity": 1e-3}


_model_outputs = jax.jit(lambda m, y, v: (m.gain(y), m.cogging(y), m.direction_force(y, v)))


# ---------------------------------------------------------------------------------------------
# model files
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("direction", [True, False])
def test_model_file_round_trip_with_mechanics(tmp_path, direction):
    model, mech = make_spline(direction=direction), make_mechanics()
    json_path, _ = save_model(tmp_path / "m", model, {"seed": 5}, mechanics=mech)
    doc = json.loads(json_path.read_text())
    assert doc["schema"] == SPLINE_SCHEMA and doc["family"] == "spline"
    loaded, document = load_model(tmp_path / "m")
    assert isinstance(loaded, SplineModel) and document["metadata"] == {"seed": 5}
    assert (loaded.pole_pitch, loaded.y_min, loaded.y_max, loaded.has_direction) == \
        (model.pole_pitch, model.y_min, model.y_max, direction)
    y = np.linspace(-0.15, 0.15, 301)
    v = np.linspace(-0.01, 0.01, 301)
    for a, b in zip(_model_outputs(model, y, v), _model_outputs(loaded, y, v)):
        assert np.array_equal(np.asarray(a), np.asarray(b))  # bit-identical
    m = document["mechanics"]
    assert set(m) == {"mass", "viscous", "coulomb_knots", "coulomb_table", "direction_velocity"}
    assert m["coulomb_table"] == list(mech["coulomb_table"]) and m["mass"] == mech["mass"]
    ff = feedforward_from_metadata(document)
    assert (ff.mass, ff.viscous, ff.coulomb) == (mech["mass"], mech["viscous"], 0.0)
    assert ff.coulomb_knots == tuple(mech["coulomb_knots"])
    # without mechanics: no feedforward
    save_model(tmp_path / "n", model)
    assert feedforward_from_metadata(load_model(tmp_path / "n")[1]) is None


def _damage(tmp_path, edit_json=None, edit_arrays=None):
    save_model(tmp_path / "m", make_spline(), mechanics=make_mechanics())
    if edit_json:
        doc = json.loads((tmp_path / "m.json").read_text())
        edit_json(doc)
        (tmp_path / "m.json").write_text(json.dumps(doc))
    if edit_arrays:
        with np.load(tmp_path / "m.npz") as f:
            arrays = {k: f[k] for k in f.files}
        edit_arrays(arrays)
        np.savez(tmp_path / "m.npz", **arrays)
    return tmp_path / "m.json"


def _set(key, value):
    def edit(d):
        d[key] = value(d[key]) if callable(value) else value
    return edit


@pytest.mark.parametrize("edit_json,edit_arrays,message", [
    (None, lambda a: a.pop("cog_table"), r"m\.npz: array 'cog_table' missing"),
    (None, lambda a: a.pop("coulomb_table"), r"m\.npz: array 'coulomb_table' missing"),
    (None, _set("gain_table", lambda t: t[:-1]), r"m\.npz: array 'gain_table' has shape \(8, 3, 2, 3, 2\), "
                                                 r"expected \(9, 3, 2, 3, 2\)"),
    (None, _set("H", lambda t: t[..., :1]), r"m\.npz: array 'H' has shape"),
    (None, _set("dir_table", lambda t: np.where(t > 1, np.nan, t)), r"m\.npz: array 'dir_table' holds NaN or inf"),
    (None, _set("cog_knots", lambda k: k[::-1].copy()), r"m\.npz: array 'cog_knots' must be strictly increasing"),
    (None, _set("gain_knots", lambda k: k + np.r_[0, 1e-3, np.zeros(k.size - 2)]),
     r"m\.npz: array 'gain_knots' must be uniformly spaced"),
    (None, _set("coulomb_table", lambda t: t.astype(np.float32)), r"array 'coulomb_table' has dtype float32"),
    (None, _set("extra", np.zeros(2)), r"unexpected arrays \['extra'\]"),
    (_set("family", "pgnn"), None, r"m\.json: schema 'pgcomm-model/3' needs \"family\": \"spline\""),
    (_set("knots", lambda k: {**k, "cog": 0}), None, r"m\.json: knots\.cog = 0: expected 2 to"),
    (_set("knots", lambda k: {key: v for key, v in k.items() if key != "gain"}), None,
     r"m\.json: missing or invalid header field 'gain'"),
    (_set("mechanics", lambda m: {**m, "mass": "heavy"}), None, r"m\.json: missing or invalid header field"),
    (_set("direction", {"velocity": -1.0}), None, r"direction velocity must be positive"),
])
def test_corrupt_or_missing_arrays_refused(tmp_path, edit_json, edit_arrays, message):
    path = _damage(tmp_path, edit_json, edit_arrays)
    with pytest.raises(DataError, match=message) as err:
        load_model(path)
    assert "\n" not in str(err.value)


def test_missing_npz_and_bad_saves(tmp_path):
    path = _damage(tmp_path)
    (tmp_path / "m.npz").unlink()
    with pytest.raises(DataError, match=r"m\.npz: array file not found"):
        load_model(path)
    bad = dict(make_mechanics(), coulomb_knots=np.array([0.0, 0.01, 0.03, 0.04, 0.05, 0.06]))
    with pytest.raises(ValueError, match="coulomb_knots must be uniformly spaced"):
        save_model(tmp_path / "x", make_spline(), mechanics=bad)
    assert not (tmp_path / "x.json").exists()


# ---------------------------------------------------------------------------------------------
# C export
# ---------------------------------------------------------------------------------------------

def compile_law(cc, model, directory: Path, mechanics, precision="double", name="spl", **kwargs) -> Path:
    """Export ``model`` with the feedforward, compile it with the law harness (tests/_c_harness.py), return the
    executable."""
    options = {k: kwargs.pop(k) for k in list(kwargs) if k in CLawOptions.__dataclass_fields__}
    write_c(model, directory, CLawOptions(name, precision, **options), mechanics=mechanics, **kwargs)
    return c_harness.compile_law(cc, directory, name, direction="y, v" if model.has_direction else None,
                                 feedforward=True)


def samples(L, n=3000, seed=7):
    """Positions (m) inside and outside the grids, velocities (m/s, some exactly 0), forces, drive, r, a."""
    rng = np.random.default_rng(seed)
    y = rng.uniform(*Y_TEST, n)
    y[:4] = [GRID[0], GRID[1], TRAIN[0], 0.0]                  # knots and range ends exactly
    v = rng.uniform(-0.02, 0.02, n)
    v[::50] = 0.0                                              # sign(0) = 0 in the feedforward
    f = rng.uniform(-1.0, 1.0, (n, 3)) * F_RANGE
    k_hat = rng.uniform(55.0, 70.0, (n, L))
    zeta_hat = rng.uniform(-np.pi, np.pi, (n, L))
    r = rng.uniform(*Y_TEST, n)                                # also beyond the Coulomb knots
    a = rng.uniform(-20.0, 20.0, n)
    return y, v, f, k_hat, zeta_hat, r, a


def run_harness(exe: Path, L: int, y, v, f, k_hat, zeta_hat, r, a) -> dict:
    return c_harness.run_law(exe, L, y, f, k_hat, zeta_hat, v=v, r=r, a=a)


@jax.jit
def _python_law(law, y, v, f, k_hat, zeta_hat):
    i = law.currents(y, f, v if law.model.has_direction else None)
    fy, delta = jax.vmap(lambda y1, i1, k1, z1: currents_to_drive_inputs(y1, i1, k1, z1, law.model.pole_pitch))(
        y, i, k_hat, zeta_hat)
    return i, fy, delta, law.model.gain(y), law.model.cogging(y), law.model.direction_force(y, v)


def _close(c, p, scale, what):
    err = np.max(np.abs(np.asarray(c) - np.asarray(p)))
    assert err <= REL * scale, f"{what}: max error {err:.3g} > {REL:g} x {scale:.3g}"


@pytest.mark.parametrize("L,direction,limit", [(3, True, None), (3, False, 8.0), (1, True, None), (2, True, 8.0)])
def test_c_matches_python(tmp_path, cc, L, direction, limit):
    model, mech = make_spline(L=L, direction=direction, seed=L), make_mechanics()
    exe = compile_law(cc, model, tmp_path, mech, current_limit=limit)
    y, v, f, k_hat, zeta_hat, r, a = samples(L)
    c = run_harness(exe, L, y, v, f, k_hat, zeta_hat, r, a)
    law = ModelLaw(model, metric="phase", current_limit=limit)
    i, fy, delta, gain, cog, dirf = (np.asarray(x) for x in _python_law(law, *map(jnp.asarray, (y, v, f, k_hat,
                                                                                               zeta_hat))))
    inside = (y >= TRAIN[0]) & (y <= TRAIN[1])
    assert np.array_equal(c["ret"][:, 0], np.where(inside, 0, 1)) and np.array_equal(c["ret"][:, 1], c["ret"][:, 0])
    # scales: the gain's terms are bounded by the table magnitudes plus the harmonics
    g_scale = float(np.abs(model.gain_table).max() * 2 + np.abs(model.H).sum(axis=1).max())
    _close(c["gain"], gain, g_scale, "gain")
    _close(c["cogging"], cog, float(np.abs(model.cog_table).max()), "cogging")
    if direction:
        _close(c["direction"], dirf, float(np.abs(model.dir_table).max()), "direction force")
    i_scale = float(np.abs(i).max())
    # single coil set: always damped (eps2 = 1e-6); its rounding noise is amplified, as in test_export_c
    _close(c["currents"], i, i_scale * (100 if L == 1 else 1), "currents")
    _close(c["fy"], fy, float(np.abs(fy).max()) * (100 if L == 1 else 1), "Fy*")
    # Δ is an angle: compare on the circle, scaled by π; where Fy* ~ 0 the angle is undefined. Both sides
    # use one convention (signed Fy*, Δ in (-π/2, π/2]), so the signs of Fy* agree too (checked above)
    big = np.abs(fy) > 1e-6 * np.abs(fy).max()
    d = np.angle(np.exp(1j * (c["delta"] - delta)))[big]
    _close(d, 0.0 * d, np.pi * (100 if L == 1 else 1) * 10, "delta")
    assert np.all((c["delta"] > -np.pi / 2) & (c["delta"] <= np.pi / 2)) and np.any(c["fy"][big] < 0)
    if limit is not None:
        ph = np.concatenate([c["currents"], -c["currents"].sum(-1, keepdims=True)], axis=-1)
        assert np.abs(ph).max() <= limit * (1 + 1e-12)
    # feedforward: g and u_ff against pgcomm.control (the harness pairs sample k with k + 1, as it does)
    ff = feedforward_from_metadata({"mechanics": mech})
    g_py = feedforward_signal(ff, np.full(2, v[0]), np.full(2, a[0]), np.full(2, r[0]))  # constant: u = g
    ff_scale = float(ff.mass * np.abs(a).max() + ff.viscous * np.abs(v).max() + np.abs(ff.coulomb_table).max())
    _close(c["g"][0], g_py[0], ff_scale, "feedforward g (first sample)")
    _close(c["u_ff"], feedforward_signal(ff, v, a, r), ff_scale, "feedforward u_ff")
    g_all = ff.mass * a + ff.viscous * v + ff.coulomb_at(r) * np.sign(v)
    _close(c["g"], g_all, ff_scale, "feedforward g")
    assert np.all(c["g"][v == 0] == ff.mass * a[v == 0])  # sign(0) = 0: no Coulomb term at rest


def test_c_single_precision_compiles_and_agrees(tmp_path, cc):
    """float tables and float libm: agreement to float rounding amplified by the solve (measured ~1e-6)."""
    model, mech = make_spline(), make_mechanics()
    exe = compile_law(cc, model, tmp_path, mech, precision="single")
    y, v, f, k_hat, zeta_hat, r, a = samples(3, n=500)
    y, v, f, k_hat, zeta_hat, r, a = (np.asarray(x, np.float32).astype(float) for x in (y, v, f, k_hat, zeta_hat, r, a))
    c = run_harness(exe, 3, y, v, f, k_hat, zeta_hat, r, a)
    i = np.asarray(ModelLaw(model).currents(jnp.asarray(y), jnp.asarray(f), jnp.asarray(v)))
    err = np.max(np.abs(c["currents"] - i)) / np.abs(i).max()
    assert err < 1e-4, err
    ff = feedforward_from_metadata({"mechanics": mech})
    ff_scale = float(ff.mass * 20 + ff.viscous * 0.02 + 4.0)
    assert np.max(np.abs(c["u_ff"] - feedforward_signal(ff, v, a, r))) < 1e-5 * ff_scale


def test_c_source_without_mechanics_has_no_feedforward_and_pgnn_api():
    header, source = c_source(make_spline(direction=False), CLawOptions("s"))
    assert "s_feedforward" not in header and "int s_currents(double y, const double f_star[3]" in header
    assert "#define S_HAS_VELOCITY 0" in header and "s_locate" in source
    header, _ = c_source(make_spline(direction=True), CLawOptions("s"))
    assert "int s_currents(double y, double v, const double f_star[3]" in header
    assert "void s_direction(double y, double v, double force[3]);" in header
    with pytest.raises(ValueError, match="uniform"):
        c_source(make_spline(), CLawOptions("s"), mechanics=dict(make_mechanics(), coulomb_knots=[0.0, 0.01, 0.03, 0.04,
                                                                                          0.05, 0.06]))


# ---------------------------------------------------------------------------------------------
# lookup tables
# ---------------------------------------------------------------------------------------------


def test_lut_of_a_spline_model(tmp_path):
    model = make_spline()
    lut = build_lut(model, resolution=2e-4)
    assert lut.direction.shape == (lut.n, 3) and lut.y[0] == TRAIN[0] and lut.y[-1] == TRAIN[1]
    # at the grid rows the table law is the exact law, direction term included
    rng = np.random.default_rng(3)
    f = rng.uniform(-1, 1, (lut.n, 3)) * F_RANGE
    v = rng.uniform(-0.01, 0.01, lut.n)
    i_exact = np.asarray(ModelLaw(model).currents(jnp.asarray(lut.y), jnp.asarray(f), jnp.asarray(v)))
    i_lut = np.asarray(lut_currents(lut, lut.y, f, v))
    assert np.max(np.abs(i_lut - i_exact)) <= 1e-10 * np.abs(i_exact).max()
    # between the rows only linear interpolation errs: second order, halving h quarters the error
    # (its size, ~(7 ω h)²/8 of the 7th harmonic's share, is the caller's choice of resolution)
    err = lut_error(lut, model, 100.0)
    coarse = lut_error(build_lut(model, resolution=4e-4), model, 100.0)
    assert 3.0 < coarse.worst_rel / err.worst_rel < 5.0, (coarse.to_dict(), err.to_dict())
    assert err.worst_rel < 1e-2
    paths = write_lut(lut, tmp_path, "spl_lut")
    assert [p.name for p in paths] == ["spl_lut.csv", "spl_lut.h", "spl_lut_direction.csv"]
    assert "static const float spl_lut_dir[" in paths[1].read_text()


def test_anti_cogging_table_of_a_spline_model():
    model = make_spline()
    cog = build_cogging_table(model, resolution=2e-4)
    ce = cogging_table_error(cog, model, 100.0)
    # a kink of the cogging table between two rows: at most |Δ slope| dy / 4
    knots, fy_cog = np.asarray(model.cog_knots), np.asarray(model.cog_table)[:, 0]
    kink = np.abs(np.diff(np.diff(fy_cog) / np.diff(knots))).max()
    assert ce.interpolation <= kink * cog.dy / 4 * (1 + 1e-9) and np.all(np.isfinite(ce.law_abs))
    # the drive's classical k, zeta from the mean fundamental: near the tables' k ~ 61 N/A, zeta ~ -0.54 rad
    assert np.all(np.abs(ce.k_hat - 61.5) < 2.0) and np.all(np.abs(ce.zeta_hat + 0.55) < 0.05)


# ---------------------------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------------------------


def test_cli_inspect_and_export_spline_file(tmp_path, capsys):
    from pgcomm.cli import main

    # as identify --family spline writes it: with the motor's current limit, which the exports apply
    # with the spline fit's record: cross-validated Fy residual 16 N² against 2 N² in training per coil set, a
    # standard error of Fy of 4.6 N that bounds the table's error (export --format lut)
    fit = {"spline": {"cost": [{"y": 2.0}] * 3, "cost_validation": [{"y": 16.0}] * 3}}
    save_model(tmp_path / "m", make_spline(), {"seed": 2, "current_limit": 8.0, "identification": fit},
               mechanics=make_mechanics())
    assert main(["inspect", "--model", str(tmp_path / "m.json")]) == 0
    text = capsys.readouterr().out
    assert "family:         spline" in text and "gain knots:     9 on" in text and "parameters:     510" in text
    assert "mechanics:      m = 4.2 kg, f_v = 12.5 N s/m, Coulomb table D(r) 6 knots" in text
    assert main(["export", "--model", str(tmp_path / "m.json"), "--format", "c", "--out", str(tmp_path / "c"),
                 "--name", "spl"]) == 0
    header = (tmp_path / "c" / "spl.h").read_text()
    assert "double spl_feedforward_g(double r, double v, double a);" in header
    assert "Current limit: 8 A peak phase current (from the model file)" in header
    assert json.loads((tmp_path / "c" / "results.json").read_text())["feedforward"] is True
    assert main(["export", "--model", str(tmp_path / "m.json"), "--format", "lut", "--out", str(tmp_path / "lut"),
                 "--resolution", "1e-3", "--quiet"]) == 0
    assert (tmp_path / "lut" / "pgcomm_lut_direction.csv").read_text().startswith("y,Fy_dir,Fx_dir,Tz_dir,v_eps\n")
    # a damaged spline file: one line, exit code 2, nothing written
    np.savez(tmp_path / "m.npz", gain_table=np.zeros(3))
    capsys.readouterr()
    assert main(["export", "--model", str(tmp_path / "m.json"), "--format", "c", "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "m.npz" in err[0] and not (tmp_path / "bad").exists()
