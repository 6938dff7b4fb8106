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
``(L, 3)``; with the extensions beyond the paper also ``H`` ``(L, 4, 3, 2)`` (5th/7th harmonic gain
coefficients) and ``C`` ``(L, 3)`` (direction term, N, N, N·m). Schema ``"pgcomm-model/1"``
files (before the extensions) still load: they are the paper's model, identified with a
force sensor. Floats in the JSON are written with Python's shortest round-trip ``repr``, so a
loaded model gives bit-identical outputs.

Spline models (:class:`pgcomm.spline_model.SplineModel`) are written with schema
``"pgcomm-model/3"`` and ``"family": "spline"``::

    {"schema": "pgcomm-model/3", "family": "spline", "kind": "SplineModel", "arrays": "NAME.npz",
     "n_coil_sets": L, "pole_pitch": d_m, "training_range": {...} | null,
     "direction": {"velocity": v_eps} | null,
     "knots": {"gain": M_g, "cog": M_c, "dir": M_d, "coulomb": M_f | null},
     "mechanics": {"mass": m, "viscous": f_v, "direction_velocity": v_eps} | null,
     "identification": ..., "array_shapes": {...}, "package_version": ..., "created": ..., "metadata": {...}}

with arrays ``gain_table`` ``(M_g, L, 2, 3, 2)`` (N/A), ``H`` ``(L, 4, 3, 2)`` (N/A),
``cog_table`` ``(M_c, 3)`` (N, N, N·m), ``dir_table`` ``(M_d, 3)`` (only with a direction
term), the uniform knot vectors ``gain_knots`` ``(M_g,)``, ``cog_knots`` ``(M_c,)``,
``dir_knots`` ``(M_d,)`` (m) and, with mechanics, ``coulomb_knots`` ``(M_f,)`` (m) and
``coulomb_table`` ``(M_f,)`` (N): the feedforward's Coulomb table ``D(r)``
(:class:`pgcomm.identify.mechanics.MechanicsFit`). Knots must be strictly increasing and
uniform (the exported C reads the tables by index arithmetic). :func:`load_model` puts the
mechanics into the returned document as ``document["mechanics"]`` (plain dict: ``mass`` kg,
``viscous`` N s/m, ``coulomb_knots`` m, ``coulomb_table`` N, ``direction_velocity`` m/s);
:func:`feedforward_from_metadata` turns it into a :class:`pgcomm.control.Feedforward`.

Both files are written to temporary names in the target directory and renamed into place
(the ``.json`` last), so an interrupted save never leaves a half-written model.

User metadata the exports read (both families): ``current_limit`` (A, peak phase current, or
``null``: the motor description's limit, stored by ``pgcomm identify``; :func:`current_limit_of`)
and ``drive`` (``{"k_hat": [...] N/A, "zeta_hat": [...] rad, "source": "..."}``: the commutation
the drive runs, :func:`drive_metadata`, :func:`drive_of`).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import zipfile
from pathlib import Path

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

import pgcomm
from pgcomm.errors import DataError, PgcommError
from pgcomm.io.atomic import atomic_open, atomic_write_text
from pgcomm.models import MLP, CombinedModel, activation_fn
from pgcomm.control import Feedforward
from pgcomm.defaults import MAX_JSON_BYTES
from pgcomm.io.config import _plausible
from pgcomm.spline_model import SplineModel

#: Schema identifier written to every PGNN model file (:class:`CombinedModel`).
SCHEMA = "pgcomm-model/2"
#: Schema identifier of spline model files (:class:`pgcomm.spline_model.SplineModel`, ``"family": "spline"``).
SPLINE_SCHEMA = "pgcomm-model/3"
#: Schemas this version reads (``/1``: no extensions; loaded as the paper's model; ``/3``: spline family).
READABLE_SCHEMAS = ("pgcomm-model/1", SCHEMA, SPLINE_SCHEMA)
#: Values of the header field ``identification``.
IDENTIFICATION_MODES = ("force_sensor", "no_force_sensor")

#: Most coil sets and hidden-layer width a model file may declare (bounds what a header can make us allocate).
MAX_COIL_SETS = 64
MAX_WIDTH = 4096
#: Most knots of one table of a spline model file (a real one has tens to hundreds).
MAX_KNOTS = 100_000
#: Relative tolerance on the uniformity of a knot vector (the C export and interp_linear assume uniform knots).
KNOT_UNIFORMITY = 1e-9


def model_paths(path) -> tuple[Path, Path]:
    """``(NAME.json, NAME.npz)`` for ``path`` given with or without either suffix."""
    p = Path(path)
    if p.suffix in (".json", ".npz"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".json"), p.with_name(p.name + ".npz")


def save_model(path, model, metadata: dict | None = None,
               identification: str = "force_sensor", mechanics=None) -> tuple[Path, Path]:
    """Write ``model`` to ``NAME.json`` + ``NAME.npz`` (see the module docstring).

    Args:
        path: ``NAME``, ``NAME.json`` or ``NAME.npz``; the directory must exist.
        model: :class:`CombinedModel` (wrap a single coil set with ``CombinedModel.from_coil_sets``;
            schema ``/2``) or :class:`pgcomm.spline_model.SplineModel` (schema ``/3``).
        metadata: JSON-serialisable dict (costs, seed, ...) stored under ``"metadata"``; numpy
            scalars and arrays are converted, non-finite floats become ``null``.
        identification: ``"force_sensor"`` or ``"no_force_sensor"`` (how the model was identified).
        mechanics: spline models only: the translator's mechanics for the feedforward, a
            :class:`pgcomm.identify.mechanics.MechanicsFit` (``mass`` kg, ``viscous`` N s/m,
            ``knots`` m, ``coulomb`` N, ``direction_velocity`` m/s) or a dict with ``mass``,
            ``viscous``, ``coulomb_knots``, ``coulomb_table``, ``direction_velocity``; or ``None``.

    Returns:
        ``(json_path, npz_path)``.

    Raises:
        TypeError: another model type, or mechanics with a PGNN model.
        ValueError: bad ``identification``, non-finite or non-uniform spline tables or mechanics.
    """
    if identification not in IDENTIFICATION_MODES:
        raise ValueError(f"identification must be one of {IDENTIFICATION_MODES}, got {identification!r}")
    if isinstance(model, SplineModel):
        return _save_spline(path, model, metadata, identification, mechanics)
    if not isinstance(model, CombinedModel):
        raise TypeError(f"save_model needs a CombinedModel or a SplineModel, got {type(model).__name__}")
    if mechanics is not None:
        # schema /2 has no mechanics block; the sensorless path keeps its mechanics in the metadata
        raise TypeError("mechanics can only be stored with a SplineModel (schema pgcomm-model/3)")
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
    }
    return _write(json_path, npz_path, document, arrays, identification, metadata)


def load_model(path) -> tuple:
    """Read a model written by :func:`save_model`: the one loader of model files, used by every command.

    Args:
        path: ``NAME``, ``NAME.json`` or ``NAME.npz``.

    Returns:
        ``(model, document)``: the model (:class:`CombinedModel` for schemas ``/1``, ``/2``;
        :class:`pgcomm.spline_model.SplineModel` for ``/3``) and the file's JSON document (header
        fields such as ``schema``, ``package_version``, ``created``, the user metadata under
        ``"metadata"``; for a spline file with mechanics, ``"mechanics"`` as a plain dict with the
        Coulomb table's lists, see :func:`feedforward_from_metadata`).

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


def _load_model(path) -> tuple:
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
    if document["schema"] == SPLINE_SCHEMA:
        return _load_spline(json_path, document)
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
    _check_header(json_path, document, npz_name, n_l)
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
    _check_plausible(json_path, pole_pitch, v_eps, y_min, y_max)
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


# --------------------------------------------------------------------------------------------
# spline family (schema pgcomm-model/3)
# --------------------------------------------------------------------------------------------

#: Keys of the plain mechanics dict in a loaded document (``document["mechanics"]``).
MECHANICS_KEYS = ("mass", "viscous", "coulomb_knots", "coulomb_table", "direction_velocity")


def _uniform_knots_problem(knots: np.ndarray) -> str | None:
    """Why ``knots`` (m) is not a usable uniform knot vector, or ``None``."""
    if knots.ndim != 1 or knots.shape[0] < 2:
        return f"needs at least 2 knots, got shape {knots.shape}"
    if not np.isfinite(knots).all():
        return "holds NaN or inf"
    d = np.diff(knots)
    if not (d > 0).all():
        i = int(np.argmax(~(d > 0)))
        return f"must be strictly increasing (knot {i + 1} = {knots[i + 1]!r} follows {knots[i]!r})"
    h = (knots[-1] - knots[0]) / (knots.shape[0] - 1)
    if np.max(np.abs(d - h)) > KNOT_UNIFORMITY * max(abs(knots[0]), abs(knots[-1]), h):
        return f"must be uniformly spaced (spacings {d.min():.6g} to {d.max():.6g} m)"
    return None


def _mechanics_dict(mechanics) -> dict:
    """The plain mechanics dict (keys :data:`MECHANICS_KEYS`) of a MechanicsFit-like object or a dict."""
    if isinstance(mechanics, dict):
        try:
            d = {k: mechanics[k] for k in MECHANICS_KEYS}
        except KeyError as err:
            raise ValueError(f"mechanics needs the keys {list(MECHANICS_KEYS)}; missing {err}") from None
    else:
        d = {"mass": mechanics.mass, "viscous": mechanics.viscous, "coulomb_knots": mechanics.knots,
             "coulomb_table": mechanics.coulomb, "direction_velocity": mechanics.direction_velocity}
    out = {"mass": float(d["mass"]), "viscous": float(d["viscous"]),
           "coulomb_knots": np.asarray(d["coulomb_knots"], dtype=np.float64),
           "coulomb_table": np.asarray(d["coulomb_table"], dtype=np.float64),
           "direction_velocity": float(d["direction_velocity"])}
    if not all(math.isfinite(out[k]) for k in ("mass", "viscous", "direction_velocity")):
        raise ValueError(f"mechanics: mass, viscous and direction_velocity must be finite, got "
                         f"{out['mass']}, {out['viscous']}, {out['direction_velocity']}")
    if not out["direction_velocity"] > 0:
        raise ValueError(f"mechanics: direction_velocity must be positive, got {out['direction_velocity']}")
    problem = _uniform_knots_problem(out["coulomb_knots"])
    if problem:
        raise ValueError(f"mechanics: coulomb_knots {problem}")
    if out["coulomb_table"].shape != out["coulomb_knots"].shape or not np.isfinite(out["coulomb_table"]).all():
        raise ValueError(f"mechanics: coulomb_table must be finite with the shape of coulomb_knots "
                         f"{out['coulomb_knots'].shape}, got {out['coulomb_table'].shape}")
    return out


def _spline_arrays(model) -> dict:
    """The npz arrays of a :class:`SplineModel` (float64), tables and knots."""
    arrays = {"gain_table": model.gain_table, "H": model.H, "cog_table": model.cog_table,
              "gain_knots": model.gain_knots, "cog_knots": model.cog_knots, "dir_knots": model.dir_knots}
    if model.dir_table is not None:
        arrays["dir_table"] = model.dir_table
    return {k: np.asarray(v, dtype=np.float64) for k, v in arrays.items()}


def _save_spline(path, model, metadata, identification, mechanics) -> tuple[Path, Path]:
    """:func:`save_model` for a :class:`SplineModel` (schema ``/3``, module docstring)."""
    json_path, npz_path = model_paths(path)
    arrays = _spline_arrays(model)
    for k, a in arrays.items():
        if not np.isfinite(a).all():
            raise ValueError(f"SplineModel array {k!r} holds NaN or inf; refusing to save it")
    for k in ("gain_knots", "cog_knots", "dir_knots"):
        problem = _uniform_knots_problem(arrays[k])
        if problem:
            raise ValueError(f"SplineModel {k} {problem}")
    mech = None if mechanics is None else _mechanics_dict(mechanics)
    if mech is not None:
        arrays["coulomb_knots"] = mech["coulomb_knots"]
        arrays["coulomb_table"] = mech["coulomb_table"]
    document = {
        "schema": SPLINE_SCHEMA,
        "family": "spline",
        "kind": "SplineModel",
        "arrays": npz_path.name,
        "n_coil_sets": model.n_coil_sets,
        "pole_pitch": float(model.pole_pitch),
        "training_range": None if model.y_min is None else {"y_min": [float(v) for v in model.y_min],
                                                            "y_max": [float(v) for v in model.y_max]},
        "direction": None if model.dir_table is None else {"velocity": float(model.direction_velocity)},
        "knots": {"gain": int(arrays["gain_knots"].shape[0]), "cog": int(arrays["cog_knots"].shape[0]),
                  "dir": int(arrays["dir_knots"].shape[0]),
                  "coulomb": None if mech is None else int(mech["coulomb_knots"].shape[0])},
        "mechanics": None if mech is None else {k: mech[k] for k in ("mass", "viscous", "direction_velocity")},
    }
    return _write(json_path, npz_path, document, arrays, identification, metadata)


def _write(json_path: Path, npz_path: Path, document: dict, arrays: dict, identification: str, metadata) -> tuple:
    """Add the keys every model file has to ``document`` and write both files (arrays first)."""
    document = {**document, "identification": identification,
                "array_shapes": {k: list(v.shape) for k, v in arrays.items()},
                "package_version": pgcomm.__version__,
                "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                "metadata": _jsonable(dict(metadata or {}))}
    text = json.dumps(document, indent=2, allow_nan=False) + "\n"
    # Arrays first, the JSON (which names them) last: a reader never sees a JSON without its arrays.
    with atomic_open(npz_path, "wb") as f:
        np.savez(f, **arrays)
    atomic_write_text(json_path, text)
    return json_path, npz_path


def _check_header(json_path: Path, document: dict, npz_name: str, n_l: int) -> None:
    """The header checks every model file shares: the arrays file's plain name, metadata, coil-set count."""
    if Path(npz_name).name != npz_name or npz_name in ("", ".", "..") or not npz_name.endswith(".npz"):
        raise DataError(f"{json_path}: \"arrays\": {npz_name!r} must be the plain name of a .npz file in the same "
                        f"folder (no folders, no absolute path), e.g. {json_path.with_suffix('.npz').name!r}")
    if document.get("metadata") is not None and not isinstance(document["metadata"], dict):
        raise DataError(f"{json_path}: \"metadata\" must be a JSON object (or null), found "
                        f"{type(document['metadata']).__name__}")
    if not 1 <= n_l <= MAX_COIL_SETS:
        raise DataError(f"{json_path}: n_coil_sets = {n_l}: expected 1 to {MAX_COIL_SETS}")


#: Plausible ``v_ε`` (m/s) of a direction term's smooth sign (as ``[identification] direction_velocity``).
DIRECTION_VELOCITY_RANGE = (0.0, 1.0)


def _check_plausible(json_path: Path, pole_pitch: float, v_eps, y_min, y_max) -> None:
    """The plausibility checks every linear model file shares, with the motor TOML's ranges
    (:data:`pgcomm.io.config.PLAUSIBLE`): a pole pitch in the wrong unit (or absurd) is refused as it would be in a
    motor description (the recorded current limit and drive commutation are checked where the exports read them,
    :func:`current_limit_of`, :func:`drive_of`); the training range must be finite and ordered.

    Raises:
        ConfigError: one line naming the file and the key.
    """
    where = str(json_path)
    _plausible(pole_pitch, "pole_pitch", where)
    lo, hi = DIRECTION_VELOCITY_RANGE
    if v_eps is not None and not (math.isfinite(v_eps) and lo < v_eps < hi):
        raise DataError(f"{json_path}: direction velocity = {v_eps!r} m/s is implausible (expected {lo:g} < v_eps < "
                        f"{hi:g} m/s, the smooth sign's width)")
    if y_min is not None:
        for l, (a, b) in enumerate(zip(y_min, y_max)):
            if not (math.isfinite(a) and math.isfinite(b) and b > a):
                raise DataError(f"{json_path}: training_range of coil set {l + 1} is [{a!r}, {b!r}] m; expected "
                                "finite y_min < y_max")


def _load_spline(json_path: Path, document: dict):
    """:func:`load_model` for a schema ``/3`` document (header already parsed)."""
    if document.get("family") != "spline":
        raise DataError(f"{json_path}: schema {SPLINE_SCHEMA!r} needs \"family\": \"spline\", "
                        f"found {document.get('family')!r}")
    try:
        n_l = int(document["n_coil_sets"])
        pole_pitch = float(document["pole_pitch"])
        rng = document["training_range"]
        npz_name = str(document["arrays"])
        direction = document["direction"]
        v_eps = None if direction is None else float(direction["velocity"])
        knots = document["knots"]
        counts = {k: int(knots[k]) for k in ("gain", "cog", "dir")}
        mech_hdr = document.get("mechanics")
        n_coulomb = None
        if mech_hdr is not None:
            n_coulomb = int(knots["coulomb"])
            mech_scalars = {k: float(mech_hdr[k]) for k in ("mass", "viscous", "direction_velocity")}
        document.setdefault("identification", "force_sensor")
    except (KeyError, TypeError, ValueError) as err:
        raise DataError(f"{json_path}: missing or invalid header field {err}") from None
    _check_header(json_path, document, npz_name, n_l)
    if not (math.isfinite(pole_pitch) and pole_pitch > 0):
        raise DataError(f"{json_path}: pole_pitch must be a positive length in m, got {pole_pitch}")
    if v_eps is not None and not (math.isfinite(v_eps) and v_eps > 0):
        raise DataError(f"{json_path}: direction velocity must be positive, got {v_eps}")
    for k, n in list(counts.items()) + ([("coulomb", n_coulomb)] if mech_hdr is not None else []):
        if not 2 <= n <= MAX_KNOTS:
            raise DataError(f"{json_path}: knots.{k} = {n}: expected 2 to {MAX_KNOTS}")
    if mech_hdr is not None:
        bad = [k for k, v in mech_scalars.items() if not math.isfinite(v)]
        if bad or not mech_scalars["direction_velocity"] > 0:
            raise DataError(f"{json_path}: mechanics: {', '.join(bad) or 'direction_velocity'} must be finite"
                            f"{'' if bad else ' and positive'}, got {mech_scalars}")
    m_g, m_c, m_d = counts["gain"], counts["cog"], counts["dir"]
    expected = {"gain_table": (m_g, n_l, 2, 3, 2), "H": (n_l, 4, 3, 2), "cog_table": (m_c, 3),
                "gain_knots": (m_g,), "cog_knots": (m_c,), "dir_knots": (m_d,)}
    if v_eps is not None:
        expected["dir_table"] = (m_d, 3)
    if mech_hdr is not None:
        expected["coulomb_knots"] = (n_coulomb,)
        expected["coulomb_table"] = (n_coulomb,)

    npz_path = json_path.with_name(npz_name)
    try:
        arrays = _read_npz(npz_path, expected)
    except FileNotFoundError:
        raise DataError(f"{npz_path}: array file not found") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise DataError(f"{npz_path}: cannot read arrays ({' '.join(str(err).split())})") from None
    for k, shape in expected.items():
        a = arrays[k]
        if a.shape != shape:
            raise DataError(f"{npz_path}: array {k!r} has shape {a.shape}, expected {shape}")
        if a.dtype != np.float64:
            raise DataError(f"{npz_path}: array {k!r} has dtype {a.dtype}, expected float64")
        if not np.isfinite(a).all():
            raise DataError(f"{npz_path}: array {k!r} holds NaN or inf")
    for k in ("gain_knots", "cog_knots", "dir_knots") + (("coulomb_knots",) if mech_hdr is not None else ()):
        problem = _uniform_knots_problem(arrays[k])
        if problem:
            raise DataError(f"{npz_path}: array {k!r} {problem}")
    y_min = y_max = None
    if rng is not None:
        try:
            y_min = tuple(float(v) for v in rng["y_min"])
            y_max = tuple(float(v) for v in rng["y_max"])
        except (KeyError, TypeError, ValueError) as err:
            raise DataError(f"{json_path}: invalid training_range ({err!r})") from None
        if len(y_min) != n_l or len(y_max) != n_l:
            raise DataError(f"{json_path}: training_range needs {n_l} values per bound")
    _check_plausible(json_path, pole_pitch, v_eps, y_min, y_max)
    if mech_hdr is not None:
        _plausible(mech_scalars["mass"], "mass", str(json_path), "mechanics mass")
        if not mech_scalars["viscous"] >= 0:
            raise DataError(f"{json_path}: mechanics viscous = {mech_scalars['viscous']!r} N s/m: expected >= 0")
    model = SplineModel(
        gain_table=jnp.asarray(arrays["gain_table"]), H=jnp.asarray(arrays["H"]),
        cog_table=jnp.asarray(arrays["cog_table"]),
        dir_table=jnp.asarray(arrays["dir_table"]) if v_eps is not None else None,
        gain_knots=jnp.asarray(arrays["gain_knots"]), cog_knots=jnp.asarray(arrays["cog_knots"]),
        dir_knots=jnp.asarray(arrays["dir_knots"]), pole_pitch=pole_pitch, y_min=y_min, y_max=y_max,
        **({"direction_velocity": v_eps} if v_eps is not None else {}))
    if mech_hdr is not None:
        document["mechanics"] = {**mech_scalars,
                                 "coulomb_knots": [float(x) for x in arrays["coulomb_knots"]],
                                 "coulomb_table": [float(x) for x in arrays["coulomb_table"]]}
    return model, document


def _or_empty(v):
    """``v``, or an empty tuple for ``None``."""
    return () if v is None else v


def feedforward_from_metadata(metadata):
    """The feedforward stored with a model, or ``None``.

    Args:
        metadata: the document of :func:`load_model` (mechanics under ``"mechanics"``, as a spline
            file has them, or under ``"metadata" -> "mechanics"``, as identification without a
            force sensor records them), or such a mechanics dict itself: ``mass`` (kg),
            ``viscous`` (N s/m) and either ``coulomb_knots`` (m, increasing) with
            ``coulomb_table`` (N) or a constant ``coulomb`` (N).

    Returns:
        :class:`pgcomm.control.Feedforward` (``u_ff[k] = (g[k] + g[k+1]) / 2`` with
        ``g = m a_r + f_v v_r + (f_c + D(r)) sign(v_r)``, :func:`pgcomm.control.feedforward_signal`),
        or ``None`` when there are no mechanics.

    Raises:
        DataError: mechanics present but incomplete or not finite (one line).
    """
    if not isinstance(metadata, dict):
        return None
    mech = metadata.get("mechanics")
    if mech is None and isinstance(metadata.get("metadata"), dict):
        mech = metadata["metadata"].get("mechanics")
    if mech is None and "mass" in metadata and "viscous" in metadata:
        mech = metadata
    if not isinstance(mech, dict):
        return None
    try:
        mass, viscous = float(mech["mass"]), float(mech["viscous"])
        # lists (a loaded document) or arrays (a dict built in Python)
        knots = tuple(float(x) for x in np.ravel(_or_empty(mech.get("coulomb_knots"))))
        table = tuple(float(x) for x in np.ravel(_or_empty(mech.get("coulomb_table"))))
        # with a table the constant f_c is its mean (identify --no-force-sensor records both): not added again
        coulomb = 0.0 if knots else float(mech.get("coulomb", 0.0))
    except (KeyError, TypeError, ValueError) as err:
        raise DataError(f"mechanics: missing or invalid field {err}") from None
    values = (mass, viscous, coulomb) + knots + table
    if not all(math.isfinite(v) for v in values):
        raise DataError("mechanics: mass, viscous and the Coulomb table must be finite")
    if len(knots) != len(table) or (knots and (len(knots) < 2 or not all(np.diff(knots) > 0))):
        raise DataError(f"mechanics: coulomb_knots ({len(knots)}) must increase and match coulomb_table "
                        f"({len(table)})")
    return Feedforward(mass=mass, viscous=viscous, coulomb=coulomb, coulomb_knots=knots, coulomb_table=table)


def drive_metadata(k_hat, zeta_hat, source: str) -> dict:
    """The metadata entry ``"drive"`` of a model file: the commutation a drive runs, and where it comes from.

    Args:
        k_hat: ``(L,)`` (or scalar) the drive's ``k̂`` (N/A); zeta_hat: ``(L,)`` (or scalar) its ``ζ̂`` (rad).
        source: plain words, e.g. ``"motor.toml [nominal]: the drive's commutation while the data were recorded"``.

    Returns:
        ``{"k_hat": [...], "zeta_hat": [...], "source": source}`` (JSON-ready).
    """
    k = [float(x) for x in np.ravel(k_hat)]
    z = [float(x) for x in np.ravel(zeta_hat)]
    return {"k_hat": k, "zeta_hat": z, "source": str(source)}


def current_limit_of(document, path) -> float | None:
    """The peak phase current limit (A) a model file records (user metadata key ``current_limit``), or ``None``.

    ``pgcomm identify`` stores the motor description's ``current_limit`` there; every export applies
    it by default.

    Args:
        document: the document of :func:`load_model`; path: the model file (named in errors).

    Raises:
        DataError: a recorded limit that is not a positive, finite number of amperes.
    """
    meta = document.get("metadata") if isinstance(document, dict) else None
    v = meta.get("current_limit") if isinstance(meta, dict) else None
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
        raise DataError(f"{path}: metadata current_limit = {v!r} is not a positive peak phase current in A")

    return _plausible(float(v), "current_limit", str(path), "metadata current_limit")


def drive_of(document, path, n_coil_sets: int):
    """The drive's commutation a model file records (user metadata key ``drive``), or ``None``.

    Args:
        document: the document of :func:`load_model`; path: the model file (named in errors);
        n_coil_sets: ``L`` of the model.

    Returns:
        ``(k_hat (L,) N/A, zeta_hat (L,) rad, source)`` or ``None``.

    Raises:
        DataError: a ``drive`` entry with missing, non-finite or non-positive values, or another
        number of coil sets.
    """
    meta = document.get("metadata") if isinstance(document, dict) else None
    d = meta.get("drive") if isinstance(meta, dict) else None
    if d is None:
        return None
    try:
        k = np.asarray(d["k_hat"], dtype=float).reshape(-1)
        z = np.asarray(d["zeta_hat"], dtype=float).reshape(-1)
        source = str(d.get("source", "the model file"))
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise DataError(f"{path}: metadata drive: missing or invalid field {err}") from None
    if k.shape != (n_coil_sets,) or z.shape != (n_coil_sets,):
        raise DataError(f"{path}: metadata drive holds {k.size} k_hat and {z.size} zeta_hat values for "
                        f"{n_coil_sets} coil sets")
    if not (np.all(np.isfinite(k)) and np.all(np.isfinite(z)) and np.all(k > 0)):
        raise DataError(f"{path}: metadata drive: k_hat {k.tolist()} N/A must be positive and zeta_hat "
                        f"{z.tolist()} rad finite")

    for l in range(n_coil_sets):
        _plausible(float(k[l]), "k", str(path), f"metadata drive k_hat[{l}]")
        _plausible(float(z[l]), "zeta", str(path), f"metadata drive zeta_hat[{l}]")
    return k, z, source
