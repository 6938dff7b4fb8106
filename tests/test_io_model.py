"""Model files: bit-identical round trip, atomic writes, and one clear refusal per damaged file."""

from __future__ import annotations

import json

import jax
import numpy as np
import pytest

import pgcomm
from pgcomm.commutation import ModelLaw
from pgcomm.errors import DataError
from pgcomm.io.model import SCHEMA, load_model, model_paths, save_model
from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal

D_M = 0.03


def _model(gain=(2,), cog=(16,), n_coil_sets=3):
    rng = np.random.default_rng(0)
    sets = []
    for l in range(n_coil_sets):
        a, b = physics_from_ideal(D_M, 61.0 + l, -0.54, 0.05, 0.07 * (l - 1))
        m = CoilSetModel.init(jax.random.PRNGKey(l), CoilSetModel.physics(a, b, D_M, 0.001 * l, 0.1, -0.1, 0.0999), gain,
                              cog, "tanh")
        leaves, tree = jax.tree_util.tree_flatten(m)
        sets.append(jax.tree_util.tree_unflatten(tree, [np.asarray(x) + rng.normal(size=x.shape) for x in leaves]))
    return CombinedModel.from_coil_sets(sets)


_outputs = jax.jit(lambda m, y, f: (m.gain(y), m.cogging(y), ModelLaw(m).currents(y, f)))


@pytest.mark.parametrize("gain,cog", [((2,), (16,)), ((3, 4), (5, 2)), (None, (16,)), (None, None)])
def test_round_trip_is_bit_identical(tmp_path, gain, cog):
    model = _model(gain, cog)
    meta = {"seed": 3, "costs": np.array([1.5, float("nan")]), "n": np.int64(7)}
    json_path, npz_path = save_model(tmp_path / "model", model, meta)
    assert (json_path, npz_path) == model_paths(tmp_path / "model.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json", "model.npz"]  # no temporary files left
    loaded, doc = load_model(tmp_path / "model")
    assert doc["schema"] == SCHEMA and doc["package_version"] == pgcomm.__version__ and doc["created"]
    assert doc["metadata"] == {"seed": 3, "costs": [1.5, None], "n": 7}
    assert (loaded.pole_pitch, loaded.y_min, loaded.y_max) == (model.pole_pitch, model.y_min, model.y_max)
    y = np.linspace(-0.1, 0.1, 101)
    f = np.random.default_rng(1).normal(size=(101, 3)) * [50.0, 2.0, 1.0]
    for a, b in zip(_outputs(model, y, f), _outputs(loaded, y, f)):
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_saving_again_replaces_both_files(tmp_path):
    save_model(tmp_path / "m", _model(), {"seed": 1})
    save_model(tmp_path / "m.json", _model(n_coil_sets=2), {"seed": 2})
    model, doc = load_model(tmp_path / "m.npz")
    assert model.n_coil_sets == 2 and doc["metadata"]["seed"] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json", "m.npz"]


def test_failed_save_leaves_nothing(tmp_path):
    with pytest.raises(TypeError, match="not JSON-serialisable"):
        save_model(tmp_path / "m", _model(), {"bad": object()})
    assert list(tmp_path.iterdir()) == []


def _damaged(tmp_path, edit_json=None, edit_arrays=None):
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


def _object_array(arrays):
    arrays["A"] = np.array([{"a": 1}], dtype=object)


@pytest.mark.parametrize("edit_json,edit_arrays,message", [
    (lambda d: d.update(schema="pgcomm-model/99"), None, r"m\.json: schema 'pgcomm-model/99' is not supported"),
    (lambda d: d.pop("pole_pitch"), None, r"m\.json: missing or invalid header field 'pole_pitch'"),
    (lambda d: d.update(activation="swish"), None, r"m\.json: unknown activation 'swish'"),
    (None, lambda a: a.pop("cog_b_out"), r"m\.npz: array 'cog_b_out' missing"),
    (None, lambda a: a.update(extra=np.zeros(1)), r"m\.npz: unexpected arrays \['extra'\]"),
    (lambda d: d.update(gain_widths=[3]), None,
     r"m\.npz: array 'gain_W1' has shape \(3, 2, 1, 2\), expected \(3, 2, 1, 3\)"),
    (None, lambda a: a["B"].__setitem__((1, 2, 0), np.nan), r"m\.npz: array 'B' holds NaN or inf"),
    (None, lambda a: a.update(y_scale=-a["y_scale"]), r"m\.npz: array 'y_scale' must be positive"),
    (None, _object_array, r"m\.npz: array 'A' has dtype object"),  # pickled objects are refused, never loaded
])
def test_damaged_files_are_refused(tmp_path, edit_json, edit_arrays, message):
    path = _damaged(tmp_path, edit_json, edit_arrays)
    with pytest.raises(DataError, match=message) as err:
        load_model(path)
    assert "\n" not in str(err.value)


def test_unreadable_files_are_refused(tmp_path):
    with pytest.raises(DataError, match=r"nope\.json: model file not found"):
        load_model(tmp_path / "nope")
    (tmp_path / "m.json").write_text("{not json")
    with pytest.raises(DataError, match=r"m\.json: not a valid JSON model file"):
        load_model(tmp_path / "m.json")
    path = _damaged(tmp_path)
    (tmp_path / "m.npz").write_bytes((tmp_path / "m.npz").read_bytes()[:300])
    with pytest.raises(DataError, match=r"m\.npz: cannot read arrays"):
        load_model(path)
    (tmp_path / "m.npz").unlink()
    with pytest.raises(DataError, match=r"m\.npz: array file not found"):
        load_model(path)
