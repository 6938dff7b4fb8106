"""Tests of ``pgcomm export`` (pgcomm.cli.export) through :func:`pgcomm.cli.main`."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.cli import main
from pgcomm.cli.export import f_max_from_metadata
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


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    d = tmp_path_factory.mktemp("model")
    modelfile.save_model(d / "model", _model(), {"seed": 0, "plant": "synthetic test model"})
    paths = sorted(d.glob("model*.json"))
    assert len(paths) == 1, paths
    return paths[0]


def test_export_c(tmp_path, model_path, capsys):
    out = tmp_path / "c"
    code = main(["export", "--model", str(model_path), "--format", "c", "--out", str(out), "--precision", "single",
                 "--name", "motor_law", "--current-limit", "10", "--quiet"])
    assert code == 0
    assert sorted(p.name for p in out.iterdir()) == ["motor_law.c", "motor_law.h", "results.json"]
    r = json.loads((out / "results.json").read_text())
    assert r["format"] == "c" and r["precision"] == "single" and r["files"] == ["motor_law.h", "motor_law.c"]
    assert r["n_coil_sets"] == 3 and r["current_limit"] == 10.0
    source = (out / "motor_law.c").read_text()
    assert str(model_path) in source and "tanhf(" in source and "10 A peak phase current" in source
    assert capsys.readouterr().out == ""  # --quiet


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
    for q in "yxz":
        assert 0 < r["error"][q]["abs"] and r["error"][q]["rel"] == pytest.approx(r["error"][q]["abs"] / 100.0)
    assert r["worst_rel"] < 1e-2
    assert set(r["cogging_table"]["classical_plus_table"]) == {"y", "x", "z"}
    text = capsys.readouterr().out
    assert "f_max = 100 N from default" in text and "bytes (float32)" in text


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
    (["--current-limit", "-3"], "--current-limit"),
    (["--f-max", "0"], "--f-max"),
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
