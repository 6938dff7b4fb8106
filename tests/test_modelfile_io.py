"""Model files: bit-identical round trip and refusal of damaged files (one clear line each)."""

from __future__ import annotations

import json

import jax
import numpy as np
import pytest

from pgcomm.commutation import ModelLaw
from pgcomm.errors import DataError
from pgcomm.modelfile import load_model, save_model
from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal


def _model(widths=(2,), cog=(16,), L=3):
    ms = []
    for l in range(L):
        a, b = physics_from_ideal(0.03, 61.0 + l, -0.54, 0.05, 0.07 * (l - 1))
        m = CoilSetModel.init(jax.random.PRNGKey(l), a, b, 0.03, 0.0, 0.1, widths, cog, "tanh", -0.1, 0.1)
        # non-zero output layers so the networks matter
        m = jax.tree_util.tree_map(lambda x: x + 0.01 * np.arange(x.size).reshape(x.shape) if hasattr(x, "size") else x,
                                   m)
        ms.append(m)
    return CombinedModel.from_coil_sets(ms)


@pytest.mark.parametrize("widths,cog", [((2,), (16,)), ((3, 4), (8, 8)), (None, (16,)), ((2,), None)])
def test_round_trip_bit_identical(tmp_path, widths, cog):
    m = _model(widths, cog)
    save_model(tmp_path / "m", m, {"seed": 3})
    m2, doc = load_model(tmp_path / "m.json")
    assert doc["metadata"]["seed"] == 3 and doc["schema"] == "pgcomm-model/1"
    y = np.linspace(-0.1, 0.1, 257)
    f = np.random.default_rng(0).normal(size=(257, 3)) * [50, 2, 1]
    for fn in (lambda mm: mm.gain(y), lambda mm: mm.cogging(y), lambda mm: ModelLaw(mm).currents(y, f)):
        assert np.array_equal(np.asarray(fn(m)), np.asarray(fn(m2)))


def _damage(tmp_path, edit_json=None, edit_arrays=None):
    save_model(tmp_path / "m", _model())
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


def test_wrong_schema(tmp_path):
    p = _damage(tmp_path, edit_json=lambda d: d.update(schema="pgcomm-model/99"))
    with pytest.raises(DataError, match=r"m.json: schema 'pgcomm-model/99' is not supported"):
        load_model(p)


def test_missing_array(tmp_path):
    p = _damage(tmp_path, edit_arrays=lambda a: a.pop("cog_W_out"))
    with pytest.raises(DataError, match=r"array 'cog_W_out' missing"):
        load_model(p)


def test_shape_mismatch(tmp_path):
    p = _damage(tmp_path, edit_json=lambda d: d.update(cog_widths=[12]))
    with pytest.raises(DataError, match=r"array 'cog_W1' has shape \(3, 1, 16\), expected \(3, 1, 12\)"):
        load_model(p)


def test_nan_array(tmp_path):
    p = _damage(tmp_path, edit_arrays=lambda a: a["A"].__setitem__((0, 0, 0), np.nan))
    with pytest.raises(DataError, match=r"array 'A' holds NaN"):
        load_model(p)


def test_not_json(tmp_path):
    (tmp_path / "m.json").write_text("{not json")
    with pytest.raises(DataError, match=r"not a valid JSON model file"):
        load_model(tmp_path / "m.json")
