"""results.json: the machine-readable summary every computing command writes.

The file is plain nested JSON. Keys in DESIGN ("results.json") are written as
dotted paths — ``calibration.initial.k``, ``commutation_mse.classical.y.filtered``,
``identification.coil_sets[0].cost_pgnn`` — and resolve by walking the JSON:
a ``.name`` step is a dict key, a ``[i]`` step a list index (coil sets are
lists, index 0 = coil set 1). :func:`get_key` and :func:`set_key` do that walk.

Values are converted to plain JSON on writing: numpy/JAX scalars and arrays to
numbers and (nested) lists, tuples to lists, NaN and ±inf to ``null`` (JSON has
neither; ``null`` reads as "not available", which is what a NaN metric means).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.io.atomic import atomic_write_text

__all__ = ["to_jsonable", "write_results", "read_results", "get_key", "set_key", "parse_key"]

_STEP = re.compile(r"\.?([^.\[\]]+)|\[(-?\d+)\]")


def parse_key(key: str) -> list[str | int]:
    """Split a dotted key into steps: ``"a.b[0].c"`` -> ``["a", "b", 0, "c"]``.

    Raises:
        ValueError: the key is empty or malformed (e.g. ``"a..b"``, ``"a[x]"``).
    """
    steps: list[str | int] = []
    pos = 0
    while pos < len(key):
        m = _STEP.match(key, pos)
        if m is None or (m.group(1) is not None and pos > 0 and key[pos] != "."):
            raise ValueError(f"malformed results key {key!r} at character {pos}")
        steps.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        pos = m.end()
    if not steps or key.startswith(".") or key.endswith("."):
        raise ValueError(f"malformed results key {key!r}")
    return steps


def to_jsonable(obj, _path: str = ""):
    """Convert ``obj`` to plain JSON types (dict/list/str/int/float/bool/None).

    numpy and JAX scalars/arrays become numbers/nested lists; tuples become
    lists; dataclasses become dicts; :class:`pathlib.Path` becomes a string;
    NaN and ±inf become ``None``. Dict keys must be strings (ints are converted).

    Raises:
        TypeError: an object that has no JSON form (names the key path).
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, int):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item(), _path)
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, dict):
        out = {}
        for k, v in obj.items():
            if isinstance(k, (int, np.integer)) and not isinstance(k, bool):
                k = str(int(k))
            if not isinstance(k, str):
                raise TypeError(f"results key {k!r} at {_path or '<root>'} is not a string")
            out[k] = to_jsonable(v, f"{_path}.{k}" if _path else k)
        return out
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v, f"{_path}[{i}]") for i, v in enumerate(obj)]
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return to_jsonable({f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}, _path)
    if hasattr(obj, "__array__"):  # numpy arrays, JAX arrays
        arr = np.asarray(obj)
        if arr.dtype.kind in "biuf":
            return to_jsonable(arr.tolist(), _path)
        if arr.dtype.kind in "U":
            return arr.tolist()
    raise TypeError(f"results value at {_path or '<root>'} of type {type(obj).__name__} has no JSON form")


def write_results(path, results: dict) -> None:
    """Write ``results`` as indented JSON to ``path`` (atomically).

    Args:
        path: target file, usually ``<out>/results.json``.
        results: nested dict (see module docstring); use :func:`set_key` to
            fill dotted DESIGN keys. Values are converted with :func:`to_jsonable`.
    """
    data = to_jsonable(results)
    text = json.dumps(data, indent=2, allow_nan=False, ensure_ascii=False)
    atomic_write_text(path, text + "\n")


def read_results(path) -> dict:
    """Read a results.json written by :func:`write_results`.

    Raises:
        DataError: file missing or not valid JSON (names file, line and column).
    """
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except json.JSONDecodeError as e:
        raise DataError(f"{path}: not valid JSON: {e.msg} (line {e.lineno}, column {e.colno})") from None


_RAISE = object()


def get_key(results, key: str, default=_RAISE):
    """Read a dotted key such as ``"identification.coil_sets[0].cost_pgnn"``.

    Args:
        results: nested dict/list as written by :func:`write_results` (or read back).
        key: dotted path (see :func:`parse_key`).
        default: returned when the path does not exist; without it a
            :class:`KeyError` naming the first missing step is raised.

    Returns:
        the value at the path (``None`` for a stored NaN).
    """
    node = results
    done = ""
    for step in parse_key(key):
        here = f"{done}[{step}]" if isinstance(step, int) else (f"{done}.{step}" if done else step)
        if isinstance(step, int):
            ok = isinstance(node, list) and -len(node) <= step < len(node)
        else:
            ok = isinstance(node, dict) and step in node
        if not ok:
            if default is not _RAISE:
                return default
            have = (
                f"keys: {', '.join(map(str, node))}" if isinstance(node, dict)
                else f"a list of {len(node)}" if isinstance(node, list)
                else f"a {type(node).__name__}"
            )
            raise KeyError(f"results key {key!r}: {here!r} not found ({done or '<root>'} has {have})")
        node = node[step]
        done = here
    return node


def set_key(results: dict, key: str, value) -> dict:
    """Set a dotted key in a nested dict, creating dicts and lists on the way.

    List steps (``[i]``) extend the list with ``None`` up to index ``i``, so
    ``set_key(r, "identification.coil_sets[2].seconds", 1.5)`` works on an empty
    ``r``. Returns ``results`` for chaining.
    """
    steps = parse_key(key)
    node = results
    for step, nxt in zip(steps[:-1], steps[1:]):
        empty = [] if isinstance(nxt, int) else {}
        if isinstance(step, int):
            while len(node) <= step:
                node.append(None)
            if node[step] is None:
                node[step] = empty
        else:
            if node.get(step) is None:
                node[step] = empty
        node = node[step]
    last = steps[-1]
    if isinstance(last, int):
        while len(node) <= last:
            node.append(None)
    node[last] = value
    return results
