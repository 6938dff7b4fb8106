"""results.json: JSON conversion, dotted keys, atomic writing."""

import json
import math

import jax.numpy as jnp
import numpy as np
import pytest

from pgcomm.errors import DataError
from pgcomm.io.results import get_key, parse_key, read_results, set_key, to_jsonable, write_results


def _results():
    r = {}
    set_key(r, "calibration.initial.k", np.array([67.0, 67.0, 67.0]))
    set_key(r, "calibration.initial.zeta", (-0.52, -0.52, -0.52))
    set_key(r, "calibration.true.k", None)
    set_key(r, "commutation_mse.classical.y.filtered", np.float64(1.5e-3))
    set_key(r, "commutation_mse.classical.y.unfiltered", float("nan"))
    set_key(r, "commutation_mse.oracle.z.filtered", jnp.asarray(2e-6))
    for l in range(3):
        set_key(r, f"identification.coil_sets[{l}].cost_pgnn", np.float32(0.25) * (l + 1))
        set_key(r, f"identification.coil_sets[{l}].seconds", np.int64(l))
    set_key(r, "tracking_mse.classical", np.array([[1.0, np.inf], [np.nan, 2.0]]))
    r["runtime_s"] = 1.25
    return r


def test_parse_key():
    assert parse_key("identification.coil_sets[0].cost_pgnn") == ["identification", "coil_sets", 0, "cost_pgnn"]
    assert parse_key("a") == ["a"]
    assert parse_key("m[1][2]") == ["m", 1, 2]
    for bad in ("", "a..b", ".a", "a.", "a[x]", "a[0]b"):
        with pytest.raises(ValueError):
            parse_key(bad)


def test_write_read_and_walk(tmp_path):
    path = tmp_path / "results.json"
    write_results(path, _results())
    data = json.loads(path.read_text())  # plain JSON, no NaN tokens
    assert "NaN" not in path.read_text() and "Infinity" not in path.read_text()
    assert data == read_results(path)
    assert get_key(data, "calibration.initial.k") == [67.0, 67.0, 67.0]
    assert get_key(data, "calibration.initial.zeta") == [-0.52, -0.52, -0.52]
    assert get_key(data, "calibration.true.k") is None
    assert get_key(data, "commutation_mse.classical.y.filtered") == 1.5e-3
    assert get_key(data, "commutation_mse.classical.y.unfiltered") is None  # NaN -> null
    assert get_key(data, "commutation_mse.oracle.z.filtered") == 2e-6
    assert get_key(data, "identification.coil_sets[2].cost_pgnn") == 0.75
    assert get_key(data, "identification.coil_sets[1].seconds") == 1
    assert isinstance(get_key(data, "identification.coil_sets[1].seconds"), int)
    assert len(get_key(data, "identification.coil_sets")) == 3
    assert get_key(data, "tracking_mse.classical") == [[1.0, None], [None, 2.0]]
    assert get_key(data, "runtime_s") == 1.25
    assert [p.name for p in tmp_path.iterdir()] == ["results.json"]


def test_get_key_missing():
    data = to_jsonable(_results())
    with pytest.raises(KeyError, match=r"'commutation_mse.pgnn' not found \(commutation_mse has keys: classical, oracle\)"):
        get_key(data, "commutation_mse.pgnn.y.filtered")
    with pytest.raises(KeyError, match=r"'identification.coil_sets\[5\]' not found \(identification.coil_sets has a list of 3\)"):
        get_key(data, "identification.coil_sets[5].cost_pgnn")
    assert get_key(data, "commutation_mse.pgnn.y.filtered", default=None) is None
    assert get_key(data, "runtime_s.x", default="no") == "no"


def test_set_key_fills_lists():
    r = set_key({}, "identification.coil_sets[2].seconds", 1.5)
    assert r == {"identification": {"coil_sets": [None, None, {"seconds": 1.5}]}}
    set_key(r, "identification.coil_sets[0].seconds", 0.5)
    assert get_key(r, "identification.coil_sets[0].seconds") == 0.5


def test_to_jsonable_types():
    assert to_jsonable({"a": np.bool_(True), "b": np.arange(3), 1: math.inf}) == {"a": True, "b": [0, 1, 2], "1": None}
    with pytest.raises(TypeError, match=r"results value at x.y of type object has no JSON form"):
        to_jsonable({"x": {"y": object()}})


def test_failed_write_keeps_old_file(tmp_path):
    path = tmp_path / "results.json"
    write_results(path, {"runtime_s": 1.0})
    with pytest.raises(TypeError):
        write_results(path, {"runtime_s": object()})
    assert read_results(path) == {"runtime_s": 1.0}
    assert len(list(tmp_path.iterdir())) == 1


def test_read_results_errors(tmp_path):
    with pytest.raises(DataError, match=r"none.json: file not found"):
        read_results(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text('{"a": 1,\n}')
    with pytest.raises(DataError, match=r"bad.json: not valid JSON: .*\(line 2, column 1\)"):
        read_results(tmp_path / "bad.json")
