"""Tests of ``pgcomm export`` (pgcomm.cli.export) through :func:`pgcomm.cli.main`."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import re

from pgcomm.cli import main
from pgcomm.cli.export import f_max_from_metadata
from pgcomm.export.lut import build_cogging_table, classical_parameters
from pgcomm.models import MLP, CoilSetModel, CombinedModel, physics_from_ideal

from pgcomm.io import model as modelfile


def _model(L=3, seed=0):
    """Paper-like PGNN (d_m = 0.03 m, k ≈ 61 N/A) with random networks; training range ±0.05 m."""
    key = jax.random.PRNGKey(seed)
    sets = []
    for l, d in enumerate((-0.065, 0.005, 0.075)[:L]):
        key, k1, k2, k3, k4, k5 = jax.random.split(key, 6)
        A, B = physics_from_ideal(0.03, 61.0, -0.54, 0.05, d)
        gain = tuple(MLP(n.hidden, 0.3 * jax.random.normal(kw, (2, 3)), jnp.zeros(3))
                     for n, kw in ((MLP.init(k1, (2,)), k4), (MLP.init(k2, (2,)), k5)))
        c = MLP.init(k3, (16,))
        cog = MLP(c.hidden, 0.5 * jax.random.normal(k4, (16, 3)), jnp.zeros(3))
        sets.append(CoilSetModel(jnp.asarray(A), jnp.asarray(B), gain, cog, 0.03, 0.0, 0.05, -0.05, 0.05))
    return CombinedModel.from_coil_sets(sets)


#: the motor description's peak phase current (A) that identification stores in the model file
LIMIT = 7.5

#: the identification record pgcomm identify stores, of a noisy rig (Fy residual 7 N RMS over 2000 samples per coil
#: set): the model's standard error of Fy, 1.7 N, bounds the tables these tests export (export --format lut)
IDENTIFIED = {"identification": {"coil_sets": [{"cost_y": 49.0, "n_train": 2000}] * 3}}


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    """A model file as pgcomm identify writes it with a motor description: with its current limit."""
    d = tmp_path_factory.mktemp("model")
    modelfile.save_model(d / "model", _model(), {"seed": 0, "plant": "synthetic test model", "current_limit": LIMIT,
                                                     **IDENTIFIED})
    paths = sorted(d.glob("model*.json"))
    assert len(paths) == 1, paths
    return paths[0]


@pytest.fixture(scope="module")
def unlimited_path(tmp_path_factory):
    """A model file that records no current limit (a motor description without current_limit)."""
    d = tmp_path_factory.mktemp("unlimited")
    json_path, _ = modelfile.save_model(d / "model", _model(), {"seed": 0, "current_limit": None, **IDENTIFIED})
    return json_path


def test_export_c(tmp_path, model_path, capsys):
    out = tmp_path / "c"
    code = main(["export", "--model", str(model_path), "--format", "c", "--out", str(out), "--precision", "single",
                 "--name", "motor_law", "--current-limit", "10", "--quiet"])
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == ["motor_law.c", "motor_law.h", "results.json"]
    r = json.loads((out / "results.json").read_text())
    assert r["format"] == "c" and r["precision"] == "single" and r["files"] == ["motor_law.h", "motor_law.c"]
    assert r["n_coil_sets"] == 3 and r["current_limit"] == 10.0 and r["current_limit_source"] == "--current-limit"
    source = (out / "motor_law.c").read_text()
    assert str(model_path) in source and "tanhf(" in source and "10 A peak phase current (--current-limit)" in source
    assert "#define MOTOR_LAW_CURRENT_LIMIT 10.0" in source
    assert capsys.readouterr().out == ""  # --quiet


@pytest.mark.parametrize("fmt", ["c", "lut"])
def test_the_model_files_limit_is_the_default(tmp_path, model_path, capsys, fmt):
    out = tmp_path / fmt
    spacing = ["--resolution", "1e-3"] if fmt == "lut" else []
    assert main(["export", "--model", str(model_path), "--format", fmt, "--out", str(out), *spacing]) == 0
    r = json.loads((out / "results.json").read_text())
    assert r["current_limit"] == LIMIT and r["current_limit_source"] == "from the model file"
    header = (out / ("pgcomm_law.h" if fmt == "c" else "pgcomm_lut.h")).read_text()
    assert "Current limit: 7.5 A peak phase current (from the model file)" in " ".join(header.split())
    if fmt == "c":
        assert "#define PGCOMM_LAW_CURRENT_LIMIT 7.5" in (out / "pgcomm_law.c").read_text()
    else:
        assert re.search(r"sc = peak > 7\.5f \? 7\.5f / peak : 1\.0f;", header)
    assert "current limit 7.5 A (from the model file)" in capsys.readouterr().out


@pytest.mark.parametrize("fmt", ["c", "lut"])
def test_a_model_file_without_limit_is_refused_unless_told(tmp_path, unlimited_path, capsys, fmt):
    out = tmp_path / "refused"
    capsys.readouterr()
    code = main(["export", "--model", str(unlimited_path), "--format", fmt, "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("pgcomm: error:")
    assert str(unlimited_path) in err[0] and "--current-limit A" in err[0] and "--current-limit none" in err[0]
    assert not out.exists() and not list(tmp_path.glob(".refused*"))
    # opting out is explicit, and said in the header and results.json
    out = tmp_path / "none"
    spacing = ["--resolution", "5e-4"] if fmt == "lut" else []
    assert main(["export", "--model", str(unlimited_path), "--format", fmt, "--out", str(out), "--current-limit",
                 "none", *spacing, "--quiet"]) == 0
    r = json.loads((out / "results.json").read_text())
    assert r["current_limit"] is None and r["current_limit_source"] == "turned off with --current-limit none"
    header = (out / ("pgcomm_law.h" if fmt == "c" else "pgcomm_lut.h")).read_text()
    assert "Current limit: none (turned off with --current-limit none)." in " ".join(header.split())
    assert "CURRENT_LIMIT" not in header and "peak >" not in header


def test_export_lut(tmp_path, model_path, capsys):
    out = tmp_path / "lut"
    code = main(["export", "--model", str(model_path), "--format", "lut", "--out", str(out),
                 "--resolution", "5e-4"])
    assert code == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["pgcomm_lut.csv", "pgcomm_lut.h", "pgcomm_lut_cogging.csv", "results.json"]
    r = json.loads((out / "results.json").read_text())
    assert r["rows"] == 201 and r["entries"] == 201 * 21 and r["bytes"] == 4 * r["entries"]
    assert r["f_max"] == 100.0 and r["f_max_source"].startswith("default")
    assert r["current_limit"] == LIMIT
    for q in "yxz":
        assert 0 < r["error"][q]["abs"] and r["error"][q]["rel"] == pytest.approx(r["error"][q]["abs"] / 100.0)
    assert r["worst_rel"] < 1e-2
    assert set(r["cogging_table"]["classical_plus_table"]) == {"y", "x", "z"}
    text = capsys.readouterr().out
    assert "f_max = 100 N from default" in text and "bytes (float32)" in text
    # no drive commutation in the model file: the fit to the model's fundamental, said so
    k_fit, z_fit = classical_parameters(_model())
    drive = r["cogging_table"]["drive"]
    np.testing.assert_allclose(drive["k_hat"], k_fit, rtol=1e-12)
    assert drive["source"].startswith("fitted to the model's fundamental")
    assert f"anti-cogging table for a drive with k_hat = {k_fit[0]:.6g}, " in text
    lines = (out / "pgcomm_lut_cogging.csv").read_text().splitlines()
    assert lines[0].startswith("# anti-cogging table of ") and "fitted to the model's fundamental" in lines[0]
    assert lines[3] == "y,Fy_cog" and len(lines) == 4 + r["cogging_table"]["rows"]


def test_f_max_argument_and_metadata(tmp_path, model_path):
    out = tmp_path / "lut"
    assert main(["export", "--model", str(model_path), "--format", "lut", "--out", str(out), "--resolution", "1e-3",
                 "--f-max", "40", "--quiet"]) == 0
    r = json.loads((out / "results.json").read_text())
    assert r["f_max"] == 40.0 and r["f_max_source"] == "--f-max"
    assert f_max_from_metadata({"training": {"fy_abs_max": 87.5}}) == 87.5
    assert f_max_from_metadata({"fy_max": 12.0}) == 12.0
    assert f_max_from_metadata({"schema": "x", "metadata": {"training": {"f_max": 55.0}}}) == 55.0
    assert f_max_from_metadata({"seed": 0}) is None


def _corrupt_schema_version(path):
    """Set the model file's schema version to one no loader knows."""
    doc = json.loads(path.read_text())
    keys = [k for k in doc if "schema" in k.lower() or k.lower() in ("version", "format_version")]
    assert keys, f"no schema version key in {sorted(doc)}"
    doc[keys[0]] = 999
    path.write_text(json.dumps(doc))


@pytest.mark.parametrize("fmt", ["c", "lut"])
def test_corrupted_model_file_is_refused(tmp_path, model_path, capsys, fmt):
    bad_dir = tmp_path / "bad"
    bad_dir.mkdir()
    for f in model_path.parent.iterdir():
        (bad_dir / f.name).write_bytes(f.read_bytes())
    bad = bad_dir / model_path.name
    _corrupt_schema_version(bad)
    out = tmp_path / "out"
    capsys.readouterr()
    code = main(["export", "--model", str(bad), "--format", fmt, "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("pgcomm: error:"), err
    assert not out.exists() or not any(out.iterdir())
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out")] == []  # no staging left behind


@pytest.mark.parametrize("args, message", [
    (["--resolution", "0"], "--resolution"),
    (["--name", "9lives"], "--name"),
    (["--current-limit", "-3"], "--current-limit -3: expected a peak phase current in A"),
    (["--current-limit", "nan"], "--current-limit nan"),
    (["--current-limit", "10A"], "--current-limit 10A: expected"),
    (["--f-max", "0"], "--f-max"),
    (["--drive-k", "60,61"], "--drive-k 60,61: 2 values for a model with 3 coil sets"),
    (["--drive-k", "0"], "--drive-k 0: value = 0 N/A is implausible"),
    (["--drive-zeta", "-30"], "did you give degrees?"),
    (["--drive-zeta", "a,b,c"], "--drive-zeta a,b,c: expected numbers in rad"),
    (["--drive-k", "61", "--drive-zeta", "1.03"], "the drive's commutation makes only"),  # ζ̂ off by about π/2
])
def test_bad_options(tmp_path, model_path, capsys, args, message):
    out = tmp_path / "out"
    code = main(["export", "--model", str(model_path), "--format", "lut", "--out", str(out), "--quiet", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("pgcomm: error:") and message in err[0]
    assert not out.exists()


def test_missing_model_file(tmp_path, capsys):
    code = main(["export", "--model", str(tmp_path / "nope.json"), "--format", "c", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()  # without --quiet too: one line
    assert code == 2 and len(err) == 1 and err[0].startswith("pgcomm: error:") and "nope.json" in err[0]
    assert not (tmp_path / "o").exists()


def test_exported_model_matches_the_loaded_model(tmp_path, model_path):
    """The C files embed exactly the model the loader returns (weights round-trip)."""
    model, _ = modelfile.load_model(model_path)
    out = tmp_path / "c"
    assert main(["export", "--model", str(model_path), "--format", "c", "--out", str(out), "--quiet"]) == 0
    src = (out / "pgcomm_law.c").read_text()
    a = src[src.index("pgcomm_law_A[3][3][2] = "):]
    numbers = [float(x) for x in a[a.index("{"):a.index(";")].replace("{", " ").replace("}", " ").split(",")]
    assert np.array_equal(np.array(numbers), np.asarray(model.A).ravel())


def test_drive_commutation_from_the_options_and_the_model_file(tmp_path, capsys):
    """--drive-k/--drive-zeta, else the model file's drive entry: the table is computed for it and states it."""
    model = _model()
    d = tmp_path / "m"
    d.mkdir()
    drive = modelfile.drive_metadata([60.0, 61.0, 62.0], [-0.5, -0.55, -0.6], "motor.toml [nominal]")
    path, _ = modelfile.save_model(d / "model", model, {"current_limit": LIMIT, "drive": drive, **IDENTIFIED})
    out = tmp_path / "recorded"
    assert main(["export", "--model", str(path), "--format", "lut", "--out", str(out), "--resolution", "1e-3"]) == 0
    r = json.loads((out / "results.json").read_text())["cogging_table"]
    assert r["drive"] == {"k_hat": [60.0, 61.0, 62.0], "zeta_hat": [-0.5, -0.55, -0.6],
                          "source": "the model file: motor.toml [nominal]"} and r["k_hat"] == [60.0, 61.0, 62.0]
    text = capsys.readouterr().out
    assert ("anti-cogging table for a drive with k_hat = 60, 61, 62 N/A, zeta_hat = -0.5, -0.55, -0.6 rad "
            "(the model file: motor.toml [nominal])") in text
    table = np.loadtxt(out / "pgcomm_lut_cogging.csv", delimiter=",", skiprows=4)
    want = build_cogging_table(model, 1e-3, k_hat=[60.0, 61.0, 62.0], zeta_hat=[-0.5, -0.55, -0.6])
    scale = np.abs(np.asarray(want.values)).max()
    np.testing.assert_allclose(table[:, 1], np.asarray(want.values), rtol=0, atol=1e-12 * scale)
    # the options win; one value serves every coil set; the other parameter keeps its default source
    out = tmp_path / "given"
    assert main(["export", "--model", str(path), "--format", "lut", "--out", str(out), "--resolution", "1e-3",
                 "--drive-k", "67", "--quiet"]) == 0
    r = json.loads((out / "results.json").read_text())["cogging_table"]
    assert r["drive"]["k_hat"] == [67.0] * 3 and r["drive"]["zeta_hat"] == [-0.5, -0.55, -0.6]
    assert r["drive"]["source"] == "k_hat from --drive-k, zeta_hat the model file: motor.toml [nominal]"
    first = (out / "pgcomm_lut_cogging.csv").read_text().splitlines()[0]
    assert "k_hat = 67, 67, 67 N/A, zeta_hat = -0.5, -0.55, -0.6 rad (k_hat from --drive-k" in first
    # a table for a drive with a higher k_hat is larger: the drive makes less force per N commanded
    other = np.loadtxt(out / "pgcomm_lut_cogging.csv", delimiter=",", skiprows=4)
    assert np.max(np.abs(other[:, 1])) > 1.05 * np.max(np.abs(table[:, 1]))
    # the C export embeds the drive's constants and says where they came from
    out = tmp_path / "c"
    assert main(["export", "--model", str(path), "--format", "c", "--out", str(out), "--drive-k", "61,62,63",
                 "--drive-zeta", "-0.5", "--quiet"]) == 0
    source = (out / "pgcomm_law.c").read_text()
    assert re.search(r"const double pgcomm_law_drive_k_hat\[PGCOMM_LAW_L\] = \{61\.0, 62\.0, 63\.0\};", source)
    assert "rad (--drive-k, --drive-zeta)." in " ".join(source.split())


@pytest.mark.parametrize("limit", [6.0, None])
def test_identify_stores_the_motor_descriptions_limit_and_drive(tmp_path, limit):
    """What pgcomm identify puts into the model file (cli.identify.law_metadata) is what export reads back."""
    from pathlib import Path
    from types import SimpleNamespace

    from pgcomm.cli.identify import law_metadata

    motor = SimpleNamespace(current_limit=limit, k=np.array([60.0, 61.0, 62.0]), zeta=np.array([-0.5, -0.6, -0.7]))
    rig = law_metadata(SimpleNamespace(motor=Path("rig/motor.toml")), SimpleNamespace(motor=motor))
    twin = law_metadata(SimpleNamespace(motor=None), SimpleNamespace(motor=motor))
    assert twin == {"current_limit": limit}  # the twin's nominal k, zeta are not a drive's calibrated values
    path, _ = modelfile.save_model(tmp_path / "model", _model(), {"seed": 1, **rig})
    _, document = modelfile.load_model(path)
    assert modelfile.current_limit_of(document, path) == limit
    k, z, source = modelfile.drive_of(document, path, 3)
    assert k.tolist() == [60.0, 61.0, 62.0] and z.tolist() == [-0.5, -0.6, -0.7]
    assert source.startswith("rig/motor.toml [nominal]")


def test_bad_law_metadata_in_a_model_file_is_one_line(tmp_path, capsys):
    path, _ = modelfile.save_model(tmp_path / "model", _model(), {"current_limit": -4})
    capsys.readouterr()
    code = main(["export", "--model", str(path), "--format", "c", "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "metadata current_limit = -4 is not a positive" in err[0]
    path, _ = modelfile.save_model(tmp_path / "m2", _model(), {"current_limit": 5.0,
                                                               "drive": {"k_hat": [60.0], "zeta_hat": [0.1]}})
    code = main(["export", "--model", str(path), "--format", "lut", "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "metadata drive holds 1 k_hat and 1 zeta_hat values for 3" in err[0]
    assert not (tmp_path / "o").exists()
