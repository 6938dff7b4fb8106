"""Model files: a :class:`~pgcomm.models.CombinedModel` as ``NAME.json`` + ``NAME.npz`` (no pickle).

``NAME.json`` (human-readable, schema ``"pgcomm-model/2"``)::

    {"schema": "pgcomm-model/2", "kind": "CombinedModel", "arrays": "NAME.npz",
     "n_coil_sets": L, "pole_pitch": d_m, "activation": "tanh",
     "gain_widths": [2] | null, "cog_widths": [16] | null,
     "training_range": {"y_min": [...], "y_max": [...]} | null,
     "harmonics": false, "direction": {"velocity": v_eps} | null,
     "identification": "force_sensor" | "no_force_sensor",
     "array_shapes": {"A": [L, 3, 2], ...},
     "package_version": "0.1.0", "created": "ISO 8601 (UTC)",
     "metadata": {... user metadata: costs, seed, ...}}

``NAME.npz`` holds the float64 arrays (loaded with ``allow_pickle=False``, so loading never
executes code): ``A``, ``B`` ``(L, 3, 2)``; ``y_center``, ``y_scale`` ``(L,)``; per hidden layer
``i = 1..I`` of the gain networks ``gain_W{i}`` ``(L, 2, n_{i-1}, n_i)``, ``gain_b{i}``
``(L, 2, n_i)``, and ``gain_W_out`` ``(L, 2, n_I, 3)``, ``gain_b_out`` ``(L, 2, 3)``; likewise
``cog_W{i}`` ``(L, n_{i-1}, n_i)``, ``cog_b{i}``, ``cog_W_out`` ``(L, n_I, 3)``, ``cog_b_out``
``(L, 3)``; with the extensions of issue 10 also ``H`` ``(L, 4, 3, 2)`` (5th/7th harmonic gain
coefficients) and ``C`` ``(L, 3)`` (direction term, N, N, N·m). Schema ``"pgcomm-model/1"``
files (before the extensions) still load: they are the paper's model, identified with a
force sensor. Floats in the JSON are written with Python's shortest round-trip ``repr``, so a
loaded model gives bit-identical outputs.

Both files are written to temporary names in the target directory and renamed into place
(the ``.json`` last), so an interrupted save never leaves a half-written model.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import zipfile
from pathlib import Path

import jax.numpy as jnp
import numpy as np

import pgcomm
from pgcomm.errors import DataError, PgcommError
from pgcomm.io.atomic import atomic_open, atomic_write_text
from pgcomm.models import MLP, CombinedModel, activation_fn

#: Schema identifier written to every model file.
SCHEMA = "pgcomm-model/2"
#: Schemas this version reads (``/1``: no extensions; loaded as the paper's model).
READABLE_SCHEMAS = ("pgcomm-model/1", SCHEMA)
#: Values of the header field ``identification``.
IDENTIFICATION_MODES = ("force_sensor", "no_force_sensor")

#: Largest model header read (bytes): a real one is a few kB (metadata included).
MAX_JSON_BYTES = 16 * 2**20
#: Most coil sets and hidden-layer width a model file may declare (bounds what a header can make us allocate).
MAX_COIL_SETS = 64
MAX_WIDTH = 4096


def model_paths(path) -> tuple[Path, Path]:
    """``(NAME.json, NAME.npz)`` for ``path`` given with or without either suffix."""
    p = Path(path)
    if p.suffix in (".json", ".npz"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".json"), p.with_name(p.name + ".npz")


def save_model(path, model: CombinedModel, metadata: dict | None = None,
               identification: str = "force_sensor") -> tuple[Path, Path]:
    """Write ``model`` to ``NAME.json`` + ``NAME.npz`` (see the module docstring).

    Args:
        path: ``NAME``, ``NAME.json`` or ``NAME.npz``; the directory must exist.
        model: :class:`CombinedModel` (wrap a single coil set with ``CombinedModel.from_coil_sets``).
        metadata: JSON-serialisable dict (costs, seed, ...) stored under ``"metadata"``; numpy
            scalars and arrays are converted, non-finite floats become ``null``.
        identification: ``"force_sensor"`` or ``"no_force_sensor"`` (how the model was identified).

    Returns:
        ``(json_path, npz_path)``.
    """
    if not isinstance(model, CombinedModel):
        raise TypeError(f"save_model needs a CombinedModel, got {type(model).__name__}")
    if identification not in IDENTIFICATION_MODES:
        raise ValueError(f"identification must be one of {IDENTIFICATION_MODES}, got {identification!r}")
    json_path, npz_path = model_paths(path)
    arrays = _arrays_of(model)
    document = {
        "schema": SCHEMA,
        "kind": "CombinedModel",
        "arrays": npz_path.name,
        "n_coil_sets": model.n_coil_sets,
        "pole_pitch": float(model.pole_pitch),
        "activation": _activation(model),
        "gain_widths": None if model.gain_nets is None else list(model.gain_nets.widths),
        "cog_widths": None if model.cog_nets is None else list(model.cog_nets.widths),
        "training_range": None if model.y_min is None else {"y_min": list(model.y_min), "y_max": list(model.y_max)},
        "harmonics": model.H is not None,
        "direction": None if model.C is None else {"velocity": float(model.direction_velocity)},
        "identification": identification,
        "array_shapes": {k: list(v.shape) for k, v in arrays.items()},
        "package_version": pgcomm.__version__,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "metadata": _jsonable(dict(metadata or {})),
    }
    text = json.dumps(document, indent=2, allow_nan=False) + "\n"
    # Arrays first, the JSON (which names them) last: a reader never sees a JSON without its arrays.
    with atomic_open(npz_path, "wb") as f:
        np.savez(f, **arrays)
    atomic_write_text(json_path, text)
    return json_path, npz_path


def load_model(path) -> tuple[CombinedModel, dict]:
    """Read a model written by :func:`save_model`: the one loader of model files, used by every command.

    Args:
        path: ``NAME``, ``NAME.json`` or ``NAME.npz``.

    Returns:
        ``(model, document)``: the model and the file's JSON document (header fields such as
        ``schema``, ``package_version``, ``created``, and the user metadata under ``"metadata"``).

    Raises:
        DataError: one line naming the file and the problem (missing or unreadable file, wrong
        schema version, missing or extra arrays, wrong shapes or dtypes, NaN or inf); any other
        failure on a damaged file (numpy, zipfile, JAX giving up in another way) is turned into
        such a line too, so that a command prints one line and exits with code 2.
    """
    try:
        return _load_model(path)
    except (PgcommError, FileNotFoundError):
        raise
    except Exception as e:  # noqa: BLE001  (any failure of a damaged file is a user error here)
        raise DataError(f"{path}: not a readable pgcomm model file ({type(e).__name__}: "
                        f"{' '.join(str(e).split())})") from None


def _load_model(path) -> tuple[CombinedModel, dict]:
    """:func:`load_model` without the last-resort guard."""
    json_path, _ = model_paths(path)
    try:
        size = json_path.stat().st_size
    except FileNotFoundError:
        raise DataError(f"{json_path}: model file not found") from None
    if size > MAX_JSON_BYTES:
        raise DataError(f"{json_path}: {size} bytes is far more than a model header needs (at most "
                        f"{MAX_JSON_BYTES} bytes); not a pgcomm model file")
    try:
        document = json.loads(json_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise DataError(f"{json_path}: not a valid JSON model file ({' '.join(str(err).split())})") from None
    except RecursionError:
        raise DataError(f"{json_path}: JSON nested too deeply to be a model header; not a pgcomm model file") from None
    if not isinstance(document, dict) or document.get("schema") not in READABLE_SCHEMAS:
        found = document.get("schema") if isinstance(document, dict) else None
        raise DataError(f"{json_path}: schema {found!r} is not supported (expected one of {list(READABLE_SCHEMAS)})")
    try:
        n_l = int(document["n_coil_sets"])
        pole_pitch = float(document["pole_pitch"])
        activation = str(document["activation"])
        gain_widths = _widths(document["gain_widths"])
        cog_widths = _widths(document["cog_widths"])
        rng = document["training_range"]
        npz_name = str(document["arrays"])
        # schema /1 has no extensions (the paper's model, force sensor)
        harmonics = bool(document.get("harmonics", False))
        direction = document.get("direction")
        v_eps = None if direction is None else float(direction["velocity"])
        document.setdefault("identification", "force_sensor")
    except (KeyError, TypeError, ValueError) as err:
        raise DataError(f"{json_path}: missing or invalid header field {err}") from None
    if Path(npz_name).name != npz_name or npz_name in ("", ".", "..") or not npz_name.endswith(".npz"):
        raise DataError(f"{json_path}: \"arrays\": {npz_name!r} must be the plain name of a .npz file in the same "
                        f"folder (no folders, no absolute path), e.g. {json_path.with_suffix('.npz').name!r}")
    if document.get("metadata") is not None and not isinstance(document["metadata"], dict):
        raise DataError(f"{json_path}: \"metadata\" must be a JSON object (or null), found "
                        f"{type(document['metadata']).__name__}")
    if not 1 <= n_l <= MAX_COIL_SETS:
        raise DataError(f"{json_path}: n_coil_sets = {n_l}: expected 1 to {MAX_COIL_SETS}")
    for w in (gain_widths or ()) + (cog_widths or ()):
        if not 1 <= w <= MAX_WIDTH:
            raise DataError(f"{json_path}: network width {w}: expected 1 to {MAX_WIDTH}")
    if n_l < 1 or not pole_pitch > 0:
        raise DataError(f"{json_path}: n_coil_sets must be >= 1 and pole_pitch > 0, got {n_l} and {pole_pitch}")
    try:
        activation_fn(activation)
    except ValueError as err:
        raise DataError(f"{json_path}: {err}") from None

    npz_path = json_path.with_name(npz_name)
    if v_eps is not None and not v_eps > 0:
        raise DataError(f"{json_path}: direction velocity must be positive, got {v_eps}")
    expected = _expected_shapes(n_l, gain_widths, cog_widths, harmonics, v_eps is not None)
    try:
        arrays = _read_npz(npz_path, expected)
    except FileNotFoundError:
        raise DataError(f"{npz_path}: array file not found") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:  # damaged archive, or an object array
        raise DataError(f"{npz_path}: cannot read arrays ({' '.join(str(err).split())})") from None
    for k, shape in expected.items():
        a = arrays[k]
        if a.shape != shape:
            raise DataError(f"{npz_path}: array {k!r} has shape {a.shape}, expected {shape}")
        if a.dtype != np.float64:
            raise DataError(f"{npz_path}: array {k!r} has dtype {a.dtype}, expected float64")
        if not np.isfinite(a).all():
            raise DataError(f"{npz_path}: array {k!r} holds NaN or inf")
    if not (arrays["y_scale"] > 0).all():
        raise DataError(f"{npz_path}: array 'y_scale' must be positive")
    y_min = y_max = None
    if rng is not None:
        try:
            y_min = tuple(float(v) for v in rng["y_min"])
            y_max = tuple(float(v) for v in rng["y_max"])
        except (KeyError, TypeError, ValueError) as err:
            raise DataError(f"{json_path}: invalid training_range ({err!r})") from None
        if len(y_min) != n_l or len(y_max) != n_l:
            raise DataError(f"{json_path}: training_range needs {n_l} values per bound")
    model = _model_of(arrays, pole_pitch, activation, gain_widths, cog_widths, y_min, y_max)
    if harmonics or v_eps is not None:
        model = dataclasses.replace(model, H=jnp.asarray(arrays["H"]) if harmonics else None,
                                    C=jnp.asarray(arrays["C"]) if v_eps is not None else None,
                                    direction_velocity=v_eps if v_eps is not None else model.direction_velocity)
    return model, document


# --------------------------------------------------------------------------------------------


def _read_npz(npz_path: Path, expected: dict) -> dict:
    """The arrays of ``expected`` (name -> shape) from ``npz_path``, headers checked before any data is read.

    Every member must be a ``.npy`` array named in ``expected``; each header must declare
    float64 and exactly the expected shape, so a damaged or hostile file (a header declaring
    1e11 elements, a member that is not an array) is refused without allocating.
    """
    arrays = {}
    with zipfile.ZipFile(npz_path) as z:
        members = z.namelist()
        for m in members:
            if not m.endswith(".npy"):
                raise DataError(f"{npz_path}: member {m!r} is not a .npy array (a model's .npz holds only arrays "
                                f"{sorted(expected)})")
        names = {m[:-4] for m in members}
        for k in expected:
            if k not in names:
                raise DataError(f"{npz_path}: array {k!r} missing")
        extra = sorted(names - set(expected))
        if extra:
            raise DataError(f"{npz_path}: unexpected arrays {extra}")
        for k, shape in expected.items():
            with z.open(k + ".npy") as f:
                version = np.lib.format.read_magic(f)
                if version == (1, 0):
                    hdr_shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
                else:
                    hdr_shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            if dtype != np.float64:
                raise DataError(f"{npz_path}: array {k!r} has dtype {dtype}, expected float64")
            if tuple(hdr_shape) != shape:
                raise DataError(f"{npz_path}: array {k!r} has shape {tuple(hdr_shape)}, expected {shape}")
            with z.open(k + ".npy") as f:
                arrays[k] = np.lib.format.read_array(f, allow_pickle=False)
    return arrays


def _activation(model: CombinedModel) -> str:
    nets = [n for n in (model.gain_nets, model.cog_nets) if n is not None]
    acts = {n.activation for n in nets} or {"tanh"}
    if len(acts) != 1:
        raise ValueError(f"all networks must share one activation to be saved, got {sorted(acts)}")
    return acts.pop()


def _widths(v):
    return None if v is None else tuple(int(n) for n in v)


def _net_arrays(prefix: str, net: MLP) -> dict:
    out = {}
    for i, (w, b) in enumerate(net.hidden, start=1):
        out[f"{prefix}_W{i}"] = w
        out[f"{prefix}_b{i}"] = b
    out[f"{prefix}_W_out"] = net.W_out
    out[f"{prefix}_b_out"] = net.b_out
    return out


def _arrays_of(model: CombinedModel) -> dict:
    arrays = {"A": model.A, "B": model.B, "y_center": model.y_center, "y_scale": model.y_scale}
    if model.gain_nets is not None:
        arrays.update(_net_arrays("gain", model.gain_nets))
    if model.cog_nets is not None:
        arrays.update(_net_arrays("cog", model.cog_nets))
    if model.H is not None:
        arrays["H"] = model.H
    if model.C is not None:
        arrays["C"] = model.C
    return {k: np.asarray(v, dtype=np.float64) for k, v in arrays.items()}


def _expected_shapes(n_l, gain_widths, cog_widths, harmonics=False, direction=False) -> dict:
    shapes = {"A": (n_l, 3, 2), "B": (n_l, 3, 2), "y_center": (n_l,), "y_scale": (n_l,)}
    if harmonics:
        shapes["H"] = (n_l, 4, 3, 2)
    if direction:
        shapes["C"] = (n_l, 3)
    for prefix, lead, widths in (("gain", (n_l, 2), gain_widths), ("cog", (n_l,), cog_widths)):
        if widths is None:
            continue
        n_prev = 1
        for i, n in enumerate(widths, start=1):
            shapes[f"{prefix}_W{i}"] = lead + (n_prev, n)
            shapes[f"{prefix}_b{i}"] = lead + (n,)
            n_prev = n
        shapes[f"{prefix}_W_out"] = lead + (n_prev, 3)
        shapes[f"{prefix}_b_out"] = lead + (3,)
    return shapes


def _model_of(arrays, pole_pitch, activation, gain_widths, cog_widths, y_min, y_max) -> CombinedModel:
    def net(prefix, widths):
        if widths is None:
            return None
        hidden = tuple((jnp.asarray(arrays[f"{prefix}_W{i}"]), jnp.asarray(arrays[f"{prefix}_b{i}"]))
                       for i in range(1, len(widths) + 1))
        return MLP(hidden, jnp.asarray(arrays[f"{prefix}_W_out"]), jnp.asarray(arrays[f"{prefix}_b_out"]), activation)

    return CombinedModel(jnp.asarray(arrays["A"]), jnp.asarray(arrays["B"]), net("gain", gain_widths),
                         net("cog", cog_widths), jnp.asarray(arrays["y_center"]), jnp.asarray(arrays["y_scale"]),
                         pole_pitch, y_min, y_max)


def _jsonable(obj):
    """Plain JSON types from numpy scalars/arrays; non-finite floats -> None."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return _jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if obj is None or isinstance(obj, (str, int, float, bool)):
        return obj
    raise TypeError(f"metadata value of type {type(obj).__name__} is not JSON-serialisable")
