"""Model files: ``NAME.json`` (structure, scaling, training range, metadata, schema version) + ``NAME.npz`` (arrays).

Never pickle: the arrays load with ``allow_pickle=False`` and the JSON is plain data, so
loading a model cannot execute code. Both files are written atomically (temporary
file, then rename), arrays first, so a reader never sees a JSON without its arrays.

Array names in the ``.npz`` (``L`` coil sets; widths ``n_1..n_I``)::

    A, B                          (L, 3, 2)   N/A
    y_center, y_scale             (L,)        m
    gain_W{i}, gain_b{i}          (L, 2, n_{i-1}, n_i), (L, 2, n_i)     i = 1..I, n_0 = 1
    gain_W_out, gain_b_out        (L, 2, n_I, 3), (L, 2, 3)
    cog_W{i}, cog_b{i}            (L, n_{i-1}, n_i), (L, n_i)
    cog_W_out, cog_b_out          (L, n_I, 3), (L, 3)
"""

from __future__ import annotations

import datetime as _dt
import io
import json
import math
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from pgcomm.errors import DataError
from pgcomm.models import MLP, CombinedModel

SCHEMA = "pgcomm-model/1"


def _base(path) -> Path:
    p = Path(path)
    return p.with_suffix("") if p.suffix in (".json", ".npz") else p


def _net_arrays(prefix: str, net: MLP | None) -> dict:
    if net is None:
        return {}
    out = {}
    for i, (w, b) in enumerate(net.hidden, start=1):
        out[f"{prefix}_W{i}"] = np.asarray(w)
        out[f"{prefix}_b{i}"] = np.asarray(b)
    out[f"{prefix}_W_out"] = np.asarray(net.W_out)
    out[f"{prefix}_b_out"] = np.asarray(net.b_out)
    return out


def save_model(path, model: CombinedModel, metadata: dict | None = None) -> tuple[Path, Path]:
    """Write ``model`` to ``PATH.json`` + ``PATH.npz`` (``path`` with or without suffix).

    Args:
        model: the combined model (PGNN or physics-only).
        metadata: JSON-able extras (costs, seed, data source, ...), stored under ``metadata``.

    Returns:
        ``(json_path, npz_path)``.
    """
    from pgcomm import __version__
    from pgcomm.io.atomic import atomic_write_bytes, atomic_write_text
    from pgcomm.io.results import to_jsonable

    base = _base(path)
    arrays = {"A": np.asarray(model.A), "B": np.asarray(model.B), "y_center": np.asarray(model.y_center),
              "y_scale": np.asarray(model.y_scale)}
    arrays.update(_net_arrays("gain", model.gain_nets))
    arrays.update(_net_arrays("cog", model.cog_nets))
    doc = {
        "schema": SCHEMA,
        "n_coil_sets": model.n_coil_sets,
        "pole_pitch": model.pole_pitch,
        "activation": (model.gain_nets or model.cog_nets).activation if (model.gain_nets or model.cog_nets) else None,
        "gain_widths": list(model.gain_nets.widths) if model.gain_nets is not None else None,
        "cog_widths": list(model.cog_nets.widths) if model.cog_nets is not None else None,
        "y_min": list(model.y_min) if model.y_min is not None else None,
        "y_max": list(model.y_max) if model.y_max is not None else None,
        "training_range": list(model.training_range) if model.training_range else None,
        "arrays": base.name + ".npz",
        "array_shapes": {k: list(v.shape) for k, v in arrays.items()},
        "package_version": __version__,
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "metadata": to_jsonable(metadata or {}),
    }
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    npz, js = base.with_suffix(".npz"), base.with_suffix(".json")
    atomic_write_bytes(npz, buf.getvalue())
    atomic_write_text(js, json.dumps(doc, indent=2, allow_nan=False) + "\n")
    return js, npz


def _expected_shapes(doc: dict) -> dict:
    L = doc["n_coil_sets"]
    shapes = {"A": [L, 3, 2], "B": [L, 3, 2], "y_center": [L], "y_scale": [L]}
    for prefix, lead, widths in (("gain", [L, 2], doc.get("gain_widths")), ("cog", [L], doc.get("cog_widths"))):
        if widths is None:
            continue
        n_prev = 1
        for i, n in enumerate(widths, start=1):
            shapes[f"{prefix}_W{i}"] = lead + [n_prev, n]
            shapes[f"{prefix}_b{i}"] = lead + [n]
            n_prev = n
        shapes[f"{prefix}_W_out"] = lead + [n_prev, 3]
        shapes[f"{prefix}_b_out"] = lead + [3]
    return shapes


def _net(arrays: dict, prefix: str, widths, activation: str) -> MLP | None:
    if widths is None:
        return None
    hidden = tuple((jnp.asarray(arrays[f"{prefix}_W{i}"]), jnp.asarray(arrays[f"{prefix}_b{i}"]))
                   for i in range(1, len(widths) + 1))
    return MLP(hidden, jnp.asarray(arrays[f"{prefix}_W_out"]), jnp.asarray(arrays[f"{prefix}_b_out"]), activation)


def load_model(path) -> tuple[CombinedModel, dict]:
    """Read a model written by :func:`save_model`; returns ``(model, document)``.

    The document is the JSON (structure and ``metadata``). Refuses, with one
    :class:`~pgcomm.errors.DataError` line naming the file: a missing file, invalid JSON,
    a wrong schema version, missing or extra arrays, mismatched shapes, non-finite values.
    """
    base = _base(path)
    js = base.with_suffix(".json")
    if not js.exists():
        raise DataError(f"{js}: model file not found")
    try:
        doc = json.loads(js.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise DataError(f"{js}: not a valid JSON model file ({e})") from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        found = doc.get("schema") if isinstance(doc, dict) else type(doc).__name__
        raise DataError(f"{js}: schema {found!r} is not supported (expected {SCHEMA!r})")
    for key in ("n_coil_sets", "pole_pitch", "arrays"):
        if key not in doc:
            raise DataError(f"{js}: key '{key}' missing")
    if not (isinstance(doc["n_coil_sets"], int) and doc["n_coil_sets"] >= 1):
        raise DataError(f"{js}: n_coil_sets = {doc['n_coil_sets']!r} (expected a positive integer)")
    pp = doc["pole_pitch"]
    if not (isinstance(pp, (int, float)) and math.isfinite(pp) and pp > 0):
        raise DataError(f"{js}: pole_pitch = {pp!r} (expected a positive number in m)")
    npz = js.with_name(str(doc["arrays"]))
    if npz.parent != js.parent or not npz.exists():
        raise DataError(f"{js}: array file {doc['arrays']!r} not found next to it")
    try:
        with np.load(npz, allow_pickle=False) as f:
            arrays = {k: f[k] for k in f.files}
    except (ValueError, OSError) as e:
        raise DataError(f"{npz}: cannot read arrays ({' '.join(str(e).split())})") from None
    expected = _expected_shapes(doc)
    for name, shape in expected.items():
        if name not in arrays:
            raise DataError(f"{npz}: array '{name}' missing (expected shape {tuple(shape)})")
        if list(arrays[name].shape) != shape:
            raise DataError(f"{npz}: array '{name}' has shape {arrays[name].shape}, expected {tuple(shape)}")
        if not np.all(np.isfinite(arrays[name])):
            raise DataError(f"{npz}: array '{name}' holds NaN or inf")
    extra = sorted(set(arrays) - set(expected))
    if extra:
        raise DataError(f"{npz}: unexpected array(s) {', '.join(extra)} for the structure in {js.name}")
    activation = doc.get("activation") or "tanh"
    y_min = tuple(float(v) for v in doc["y_min"]) if doc.get("y_min") else None
    y_max = tuple(float(v) for v in doc["y_max"]) if doc.get("y_max") else None
    model = CombinedModel(jnp.asarray(arrays["A"]), jnp.asarray(arrays["B"]),
                          _net(arrays, "gain", doc.get("gain_widths"), activation),
                          _net(arrays, "cog", doc.get("cog_widths"), activation),
                          jnp.asarray(arrays["y_center"]), jnp.asarray(arrays["y_scale"]), float(pp), y_min, y_max)
    return model, doc
