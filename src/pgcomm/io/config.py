"""TOML configuration: motor descriptions and a generic dataclass loader.

Motor config (DESIGN, "Formats")::

    pole_pitch = 0.03         # d_m (m)
    sample_time = 0.001       # controller sample time (s)
    current_limit = 10.0      # optional, peak phase current (A); absent = no limit
    mass = 30.0               # optional, moving mass of the translator (kg); needed by
                              # identification without a force sensor (identify --no-force-sensor)
    travel = [-0.1, 0.1]      # optional, positions a reference may cover (m): the usable travel
                              # less a few mm; pgcomm plan spans its experiments over it

    [nominal]
    k = [67.0, 67.0, 67.0]    # k̂ (N/A): one number for all coil sets or one per coil set
    zeta = -0.52              # ζ̂ (rad): idem
    mu = 0.05                 # optional μ̂ (-)

    [[coil_set]]              # one table per coil set, in order l = 1..L
    lever_arm = -0.065        # d^l (m)

A rotary motor on a field-oriented drive has ``kind = "rotary"`` (linear is the default;
:func:`load_rotary_motor`, :func:`motor_kind`)::

    kind = "rotary"
    pole_pairs = 7            # p: the electrical period 2π/p replaces the pole pitch
    slots = 12                # Q: with p it sets the cogging orders (LCM(Q, 2p) per revolution);
                              # leave it out if unknown: identify reads it from the logs
    sample_time = 0.001       # the drive's logging period (s)
    k_t = 0.1                 # optional, torque constant (N·m/A); needed only to report N·m
    inertia = 2e-4            # optional, rotor + load (kg·m²)
    current_limit = 20.0      # optional, q-current limit (A)
    commutation_offset = 0.0  # optional, the drive's electrical angle offset (rad, electrical)
    encoder_counts = 65536    # optional, counts per revolution
    friction = 0.01           # optional, nominal Coulomb friction (N·m)
    control_rate = 8000.0     # optional, how often the drive runs its loops (Hz; the twin's drive)

Every value is checked for plausibility, because the common mistake with such
files is a unit of the wrong magnitude (a pole pitch of 30 "m" that was meant
in mm). Unknown keys are refused with the closest valid key: a misspelt
optional key must not silently fall back to its default.

:func:`load_dataclass` does the same for any (nested) frozen dataclass schema:
:func:`load_experiment` reads an experiment config (:mod:`pgcomm.settings`) with it.
"""

from __future__ import annotations

import dataclasses
import difflib
import enum
import math
import tomllib
import types
import typing
from pathlib import Path

from pgcomm.errors import ConfigError
from pgcomm.io.atomic import atomic_write_text
from pgcomm.rotary.model import cogging_orders, fundamental_cogging_order, ripple_orders
from pgcomm.rotary.motor import RotaryMotor

__all__ = [
    "closest_match",
    "closest_hint",
    "load_toml",
    "load_dataclass",
    "load_motor",
    "load_rotary_motor",
    "motor_kind",
    "rotary_motor_to_toml",
    "motor_to_toml",
    "write_motor",
    "PLAUSIBLE",
]


# --------------------------------------------------------------------------- names


def closest_match(name: str, candidates, cutoff: float = 0.5) -> str | None:
    """The candidate most similar to ``name`` (case-insensitive), or ``None``.

    Uses :class:`difflib.SequenceMatcher` on lower-cased strings; ties go to
    the candidate listed first. ``cutoff`` is the minimum similarity ratio.
    """
    best, best_ratio = None, cutoff
    key = str(name).lower()
    for c in candidates:
        r = difflib.SequenceMatcher(None, key, str(c).lower()).ratio()
        if r > best_ratio or (best is None and r >= best_ratio):
            best, best_ratio = c, r
    return best


def closest_hint(name: str, candidates, what: str = "closest match") -> str:
    """``" (closest match: 'x')"`` or ``""`` when nothing is similar enough."""
    c = closest_match(name, candidates)
    return f" ({what}: '{c}')" if c is not None else ""


def list_names(names, limit: int = 12) -> str:
    """Comma-separated names, shortened to ``limit`` entries for one-line messages."""
    names = list(names)
    if len(names) <= limit:
        return ", ".join(names)
    return ", ".join(names[:limit]) + f", ... ({len(names) - limit} more)"


# --------------------------------------------------------------------------- TOML


def load_toml(path) -> dict:
    """Read a TOML file into a dict.

    Raises:
        ConfigError: file missing/unreadable, not UTF-8, or a TOML syntax error
            (the message names the file, line and column).
    """
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise ConfigError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a TOML file") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except tomllib.TOMLDecodeError as e:
        # tomllib's message already ends with "(at line N, column M)".
        msg = " ".join(str(e).split())
        raise ConfigError(f"{path}: TOML syntax error: {msg}") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot read ({e.strerror})") from None


# --------------------------------------------------------------------------- locations


class _Where:
    """A location in a TOML document for messages: file plus table path."""

    def __init__(self, file: str, table: str = ""):
        self.file, self.table = file, table

    @classmethod
    def parse(cls, where: str) -> "_Where":
        # "exp.toml [controller.fb]" -> file "exp.toml", table "controller.fb"
        where = str(where)
        if where.endswith("]") and " [" in where:
            file, table = where.rsplit(" [", 1)
            return cls(file, table[:-1])
        return cls(where)

    def sub(self, name) -> "_Where":
        if isinstance(name, int):
            return _Where(self.file, f"{self.table}[{name}]")
        return _Where(self.file, f"{self.table}.{name}" if self.table else str(name))

    def __str__(self) -> str:
        return f"{self.file} [{self.table}]" if self.table else self.file

    def table_desc(self) -> str:
        return f"table [{self.table}]" if self.table else "the top-level table"


def _check_keys(table: dict, valid, where: _Where, desc: str | None = None) -> None:
    """Refuse keys of ``table`` that are not in ``valid`` (with the closest valid key)."""
    valid = list(valid)
    for key in table:
        if key not in valid:
            hint = closest_hint(key, valid, "closest valid key")
            raise ConfigError(
                f"{where.file}: unknown key '{key}' in {desc or where.table_desc()}{hint}; valid keys: {', '.join(valid)}"
            )


def _fmt(v) -> str:
    return f"{v:g}" if isinstance(v, float) else repr(v) if isinstance(v, str) else str(v)


def _describe(value) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, int):
        return "an integer"
    if isinstance(value, float):
        return "a float"
    return type(value).__name__


# --------------------------------------------------------------------------- generic dataclass loader

_MISSING = dataclasses.MISSING


def _type_name(tp) -> str:
    origin = typing.get_origin(tp)
    if tp is float:
        return "a number"
    if tp is int:
        return "an integer"
    if tp is bool:
        return "true or false"
    if tp is str:
        return "a string"
    if tp is Path:
        return "a path (string)"
    if dataclasses.is_dataclass(tp):
        return "a table"
    if origin in (tuple, list):
        return "an array"
    if origin is dict:
        return "a table"
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in typing.get_args(tp))
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(tp) if a is not type(None))
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        return "one of " + ", ".join(repr(m.name) for m in tp)
    return getattr(tp, "__name__", str(tp))


def _convert(value, tp, where: _Where, key: str):
    """Convert a TOML value to type ``tp``; ``where``/``key`` are for messages."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)

    def bad(expected=None):
        shown = value if not isinstance(value, (dict, list)) else None
        val = f" = {_fmt(shown)}" if shown is not None else ""
        raise ConfigError(f"{where}: {key}{val} is {_describe(value)}, expected {expected or _type_name(tp)}")

    if tp is typing.Any:
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            bad()
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            bad()
        return value
    if tp is bool:
        if not isinstance(value, bool):
            bad()
        return value
    if tp is str:
        if not isinstance(value, str):
            bad()
        return value
    if tp is Path:
        if not isinstance(value, str):
            bad()
        return Path(value)
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            bad()
        return _load(tp, value, where.sub(key))
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        names = [m.name for m in tp]
        if isinstance(value, str) and value in names:
            return tp[value]
        try:
            return tp(value)
        except ValueError:
            hint = closest_hint(str(value), names) if isinstance(value, str) else ""
            raise ConfigError(f"{where}: {key} = {_fmt(value)} is not {_type_name(tp)}{hint}") from None
    if origin is typing.Literal:
        # compare types too: TOML true must not match a Literal[1]
        if any(type(a) is type(value) and a == value for a in args):
            return value
        hint = closest_hint(str(value), [str(a) for a in args]) if isinstance(value, str) else ""
        raise ConfigError(f"{where}: {key} = {_fmt(value)} is not {_type_name(tp)}{hint}")
    if origin in (typing.Union, types.UnionType):
        members = [a for a in args if a is not type(None)]
        errors = []
        for member in members:
            try:
                return _convert(value, member, where, key)
            except ConfigError as e:
                errors.append(e)
        if len(errors) == 1:
            raise errors[0]
        bad()
    if origin is tuple:
        if not isinstance(value, list):
            bad()
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(v, args[0], where, f"{key}[{i}]") for i, v in enumerate(value))
        if args == ():
            return tuple(value)
        if len(value) != len(args):
            raise ConfigError(f"{where}: {key} has {len(value)} entries, expected {len(args)}")
        return tuple(_convert(v, a, where, f"{key}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
    if origin is list:
        if not isinstance(value, list):
            bad()
        elem = args[0] if args else typing.Any
        return [_convert(v, elem, where, f"{key}[{i}]") for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            bad()
        vt = args[1] if len(args) == 2 else typing.Any
        return {k: _convert(v, vt, where.sub(key), k) for k, v in value.items()}
    if tp in (list, tuple, dict):
        return _convert(value, tp[typing.Any, ...] if tp is tuple else tp[typing.Any] if tp is list else dict[str, typing.Any], where, key)
    raise TypeError(f"load_dataclass: unsupported field type {tp!r} for {key}")


def _check_range(value, f: dataclasses.Field, where: _Where, key: str) -> None:
    """Check ``metadata={"range": (lo, hi), "unit": "m", "hint": "..."}`` of a field."""
    rng = f.metadata.get("range")
    if rng is None or value is None:
        return
    lo, hi = rng
    unit = f.metadata.get("unit", "")
    values = value if isinstance(value, (tuple, list)) else (value,)
    for i, v in enumerate(values):
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            continue
        if not (lo <= v <= hi):  # NaN fails too
            name = key if len(values) == 1 and not isinstance(value, (tuple, list)) else f"{key}[{i}]"
            hint = f"; {f.metadata['hint']}" if "hint" in f.metadata else ""
            u = f" {unit}" if unit else ""
            raise ConfigError(f"{where}: {name} = {_fmt(float(v))}{u} is out of range (expected {lo:g}–{hi:g}{u}{hint})")


def _load(cls, table: dict, where: _Where):
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table, found {_describe(table)}")
    hints = typing.get_type_hints(cls)
    fields = [f for f in dataclasses.fields(cls) if f.init]
    _check_keys(table, [f.name for f in fields], where)
    kwargs = {}
    for f in fields:
        if f.name in table:
            value = _convert(table[f.name], hints[f.name], where, f.name)
            _check_range(value, f, where, f.name)
            kwargs[f.name] = value
        elif f.default is _MISSING and f.default_factory is _MISSING:
            raise ConfigError(f"{where.file}: key '{f.name}' missing in {where.table_desc()} (expected {_type_name(hints[f.name])})")
    try:
        return cls(**kwargs)
    except (ValueError, TypeError) as e:
        # the dataclass's own __post_init__ validation, re-raised as a user error
        raise ConfigError(f"{where}: {' '.join(str(e).split())}") from None


def load_dataclass(cls, table: dict, where: str):
    """Build a (possibly nested) dataclass ``cls`` from a TOML table.

    Rules:

    * every key of ``table`` must be a field of ``cls`` (else :class:`ConfigError`
      naming the key, the table and the closest valid field);
    * fields without a default are required; absent fields keep their default;
    * ``float`` accepts TOML integers and floats (not booleans), ``int`` only
      integers, ``bool`` only booleans, ``str``/``Path`` only strings;
    * ``tuple[X, ...]``, ``tuple[X, Y]`` and ``list[X]`` from TOML arrays,
      ``dict[str, X]`` from tables, nested dataclasses from (arrays of) tables,
      ``Literal[...]`` and :class:`enum.Enum` by value/name, ``X | None`` (absent
      means the default; TOML has no null);
    * a field with ``metadata={"range": (lo, hi), "unit": "m", "hint": "..."}``
      is checked to lie in ``[lo, hi]`` (every entry of a tuple);
    * errors raised by ``cls.__post_init__`` (``ValueError``/``TypeError``) become
      :class:`ConfigError` with the location prefixed.

    Args:
        cls: a dataclass type.
        table: dict as returned by :func:`load_toml` (or a sub-table of it).
        where: location for messages: the file name, optionally followed by the
            table, e.g. ``"exp.toml"`` or ``"exp.toml [controller]"``.

    Returns:
        an instance of ``cls``.
    """
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"load_dataclass needs a dataclass type, got {cls!r}")
    return _load(cls, table, _Where.parse(where))


def load_experiment(path):
    """Read an experiment TOML into :class:`pgcomm.settings.ExperimentConfig` (unknown keys refused, by
    :func:`load_dataclass`): the linear experiment's tables, ``[rotary]`` (a rotary motor's identification,
    :class:`pgcomm.settings.RotaryIdentifyOptions`) and ``[rotary_experiment]``
    (:class:`pgcomm.settings.RotarySettings`).

    Raises:
        ConfigError: one line naming the file, table and key.
    """
    # start-up cost: the settings hold the twin's parameters (JAX); reading a motor or a log loads none
    from pgcomm.settings import ExperimentConfig

    return load_dataclass(ExperimentConfig, load_toml(path), str(path))


# --------------------------------------------------------------------------- motor

#: Plausibility ranges of motor-config values: key -> (lo, hi, unit). They catch
#: values given in the wrong unit (mm for m, ms for s, degrees for rad).
PLAUSIBLE = {
    "pole_pitch": (1e-3, 0.5, "m"),
    "sample_time": (1e-6, 0.1, "s"),
    "current_limit": (0.0, 1e4, "A"),  # lower bound exclusive
    "lever_arm": (-2.0, 2.0, "m"),
    "k": (0.01, 1e4, "N/A"),
    "zeta": (-2.0 * math.pi, 2.0 * math.pi, "rad"),
    "mu": (-10.0, 10.0, "-"),
    "mass": (1e-3, 1e4, "kg"),
}

_UNIT_HINTS = {
    # unit -> [(factor to apply to the given value, unit the user probably used)]
    "m": [(1e-3, "mm")],
    "s": [(1e-3, "ms"), (1e-6, "µs")],
    "rad": [(math.pi / 180.0, "degrees")],
    "A": [(1e-3, "mA")],
    "kg": [(1e-3, "g")],
}


def _plausible(value: float, key: str, where: str, name: str | None = None) -> float:
    """Return ``value`` if it lies in ``PLAUSIBLE[key]``, else raise with a unit hint."""
    lo, hi, unit = PLAUSIBLE[key]
    name = name or key
    lo_ok = (value > lo) if key == "current_limit" else (value >= lo)
    if lo_ok and value <= hi:
        return value
    shown_unit = "" if unit == "-" else f" {unit}"
    if not math.isfinite(value):
        raise ConfigError(f"{where}: {name} = {value:g} is not finite (expected {lo:g}–{hi:g}{shown_unit})")
    hint = ""
    for factor, guess in _UNIT_HINTS.get(unit, []):
        v = value * factor
        if (v > lo if key == "current_limit" else v >= lo) and v <= hi and abs(value) > hi:
            hint = f"; did you give {guess}?"
            break
    rng = f"{lo:g}–{hi:g}" if key != "current_limit" else f"0 < value ≤ {hi:g}"
    raise ConfigError(f"{where}: {name} = {value:g}{shown_unit} is implausible (expected {rng}{shown_unit}{hint})")


def _number(table: dict, key: str, where: str, required: bool = True, name: str | None = None):
    """``table[key]`` as a plausible float (``None`` if absent and not required)."""
    if key not in table:
        if required:
            lo, hi, unit = PLAUSIBLE[key]
            raise ConfigError(f"{where}: key '{key}' missing (expected a number in {unit})")
        return None
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        shown = f" = {_fmt(v)}" if not isinstance(v, (dict, list)) else ""
        raise ConfigError(f"{where}: {name or key}{shown} is {_describe(v)}, expected a number in {PLAUSIBLE[key][2]}")
    return _plausible(float(v), key, where, name)


def _per_coil_set(table: dict, key: str, where: str, n: int, required: bool = True):
    """Scalar or one-entry-per-coil-set list -> tuple of ``n`` floats (or None)."""
    if key not in table:
        if required:
            raise ConfigError(f"{where}: key '{key}' missing (a number, or an array with one entry per coil set)")
        return None
    v = table[key]
    if isinstance(v, list):
        if len(v) != n:
            raise ConfigError(f"{where}: {key} has {len(v)} entries but there are {n} [[coil_set]] tables")
        return tuple(_number({key: x}, key, where, True, name=f"{key}[{i}]") for i, x in enumerate(v))
    return (_number(table, key, where),) * n


def load_motor(path) -> Motor:
    """Load a motor description (TOML, format in the module docstring).

    Args:
        path: TOML file.

    Returns:
        :class:`pgcomm.motor.Motor` with ``L`` = number of ``[[coil_set]]`` tables; ``mass``
        (kg) is ``None`` when the file has no top-level ``mass`` (only identification without a
        force sensor needs it; a value in g is refused with a hint).

    Raises:
        ConfigError: syntax error, unknown or missing key, wrong type, an
            implausible value (wrong unit), or ``k``/``zeta`` arrays whose length
            is not the number of coil sets.
    """
    file = str(path)
    doc = load_toml(path)
    if _kind(doc, file) == "rotary":
        raise ConfigError(f"{file}: kind = \"rotary\": this command takes a linear motor (pole_pitch, [[coil_set]]); "
                          "a rotary --motor goes to 'pgcomm identify', 'plan' or 'reproduce'")
    top = ("kind", "pole_pitch", "sample_time", "current_limit", "mass", "travel", "nominal", "coil_set")
    _check_keys(doc, top, _Where(file))
    pole_pitch = _number(doc, "pole_pitch", file)
    sample_time = _number(doc, "sample_time", file)
    current_limit = _number(doc, "current_limit", file, required=False)
    mass = _number(doc, "mass", file, required=False)
    travel = _travel(doc, file)

    coil_sets = doc.get("coil_set")
    if coil_sets is None:
        raise ConfigError(f"{file}: no [[coil_set]] tables (one per coil set, each with lever_arm in m)")
    if not isinstance(coil_sets, list) or not all(isinstance(c, dict) for c in coil_sets):
        raise ConfigError(f"{file}: coil_set must be an array of tables ([[coil_set]]), found {_describe(coil_sets)}")
    if not coil_sets:
        raise ConfigError(f"{file}: no [[coil_set]] tables (one per coil set, each with lever_arm in m)")
    lever_arms = []
    for i, cs in enumerate(coil_sets, start=1):
        w = f"{file} [[coil_set]] {i}"
        _check_keys(cs, ("lever_arm",), _Where(file), desc=f"[[coil_set]] {i}")
        lever_arms.append(_number(cs, "lever_arm", w))
    n = len(lever_arms)

    nominal = doc.get("nominal")
    if nominal is None:
        raise ConfigError(f"{file}: table [nominal] missing (with k in N/A and zeta in rad)")
    if not isinstance(nominal, dict):
        raise ConfigError(f"{file}: nominal must be a table [nominal], found {_describe(nominal)}")
    _check_keys(nominal, ("k", "zeta", "mu"), _Where(file, "nominal"))
    w = f"{file} [nominal]"
    k = _per_coil_set(nominal, "k", w, n)
    zeta = _per_coil_set(nominal, "zeta", w, n)
    mu = _number(nominal, "mu", w, required=False)
    kwargs = {} if mu is None else {"mu": mu}
    # start-up cost: loads JAX only when this runs
    from pgcomm.motor import Motor  # here: reading a log or a setting needs no JAX

    return Motor(
        pole_pitch=pole_pitch,
        lever_arms=tuple(lever_arms),
        k=k,
        zeta=zeta,
        sample_time=sample_time,
        current_limit=current_limit,
        mass=mass,
        travel=travel,
        **kwargs,
    )


def _travel(doc: dict, file: str):
    """Top-level ``travel = [lo, hi]`` (m) as a tuple, ``None`` when absent."""
    if "travel" not in doc:
        return None
    v = doc["travel"]
    if not (isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                        for x in v)):
        raise ConfigError(f"{file}: travel = {_fmt(v) if not isinstance(v, dict) else 'a table'} must be two numbers "
                          "[lo, hi] in m, e.g. travel = [-0.12, 0.12]")
    lo, hi = (float(x) for x in v)
    for name, x in (("travel[0]", lo), ("travel[1]", hi)):
        if not (math.isfinite(x) and abs(x) <= 100.0):
            raise ConfigError(f"{file}: {name} = {x:g} m is implausible (expected |value| ≤ 100 m; did you give mm?)")
    if not hi > lo:
        raise ConfigError(f"{file}: travel = [{lo:g}, {hi:g}] m: the first entry must be below the second")
    return (lo, hi)


def _toml_float(x) -> str:
    """A float as TOML text that reads back bit-identically."""
    x = float(x)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)  # shortest round-trip form; always has '.', 'e' or is 'inf'/'nan'


def _toml_list(xs) -> str:
    return "[" + ", ".join(_toml_float(x) for x in xs) + "]"


def motor_to_toml(motor: Motor) -> str:
    """The TOML text of ``motor`` (readable back with :func:`load_motor`, bit-exact floats)."""
    lines = [
        "# pgcomm motor description (SI units: m, s, A, N, rad)",
        f"pole_pitch = {_toml_float(motor.pole_pitch)}  # d_m (m): length of two magnets",
        f"sample_time = {_toml_float(motor.sample_time)}  # controller sample time (s)",
    ]
    if motor.current_limit is not None:
        lines.append(f"current_limit = {_toml_float(motor.current_limit)}  # peak phase current of the drive (A)")
    if motor.mass is not None:
        lines.append(f"mass = {_toml_float(motor.mass)}  # moving mass of the translator (kg)")
    if motor.travel is not None:
        lines.append(f"travel = {_toml_list(motor.travel)}  # positions a reference may cover (m)")
    lines += [
        "",
        "[nominal]",
        f"k = {_toml_list(motor.k)}  # nominal motor constant per coil set (N/A)",
        f"zeta = {_toml_list(motor.zeta)}  # nominal commutation phase offset per coil set (rad)",
        f"mu = {_toml_float(motor.mu)}  # nominal out-of-plane force ratio (-)",
    ]
    for i, d in enumerate(motor.lever_arms, start=1):
        lines += ["", "[[coil_set]]", f"lever_arm = {_toml_float(d)}  # d^{i} (m): position of coil set {i} relative to the centre of mass"]
    return "\n".join(lines) + "\n"


def write_motor(path, motor: Motor) -> None:
    """Write ``motor`` as TOML to ``path`` (atomically)."""
    atomic_write_text(path, motor_to_toml(motor))


# --------------------------------------------------------------------------- rotary motors

#: Motor kinds a motor TOML may declare with ``kind = ...`` (absent: linear).
MOTOR_KINDS = ("linear", "rotary")

#: Plausibility of rotary-motor values: key -> (lo, hi, unit).
ROTARY_PLAUSIBLE = {
    "pole_pairs": (1, 200, ""),
    "slots": (3, 600, ""),
    "sample_time": (1e-6, 0.1, "s"),
    "k_t": (1e-4, 100.0, "N·m/A"),
    "inertia": (1e-9, 1e3, "kg·m²"),
    "current_limit": (0.0, 1e4, "A"),
    "commutation_offset": (-2.0 * math.pi, 2.0 * math.pi, "rad"),
    "encoder_counts": (16, 2**32, ""),
    "friction": (0.0, 1e4, "N·m"),
    "control_rate": (100.0, 1e6, "Hz"),
}
_ROTARY_INT = ("pole_pairs", "slots", "encoder_counts")

#: Highest harmonic order per revolution a rotary motor's model may reach (``3 LCM(Q, 2p)`` for the cogging,
#: ``12 p`` and ``Q`` for the ripple). Identification screens every order up to the highest, on running logs whose
#: length grows with it too (the alias guard slows the rotor), so its time grows with about its 2.5th power: one
#: round of the twin's running logs took 4.7 s of CPU at 252 (12N14P), 37 s at 756 (36N42P), 125 s at 1296
#: (54N48P); at 3600 (600N400P) it had not finished after 1.5 CPU-minutes of screening with 5.5 GB.
MAX_ROTARY_ORDER = 2048
_ROTARY_REQUIRED = ("kind", "pole_pairs", "sample_time")


def _kind(doc: dict, file: str) -> str:
    kind = doc.get("kind", "linear")
    if not isinstance(kind, str) or kind not in MOTOR_KINDS:
        hint = closest_hint(kind, MOTOR_KINDS) if isinstance(kind, str) else ""
        raise ConfigError(f"{file}: kind = {_fmt(kind)} is not one of {', '.join(repr(k) for k in MOTOR_KINDS)}{hint}")
    return kind


def motor_kind(path) -> str:
    """``"linear"`` or ``"rotary"``: the ``kind`` key of a motor TOML (absent: linear).

    Raises:
        ConfigError: unreadable file, TOML error, or an unknown kind (with the closest valid one).
    """
    return _kind(load_toml(path), str(path))


def load_rotary_motor(path):
    """Load a rotary motor description (``kind = "rotary"``, keys in the module docstring).

    Returns:
        :class:`pgcomm.rotary.motor.RotaryMotor`.

    Raises:
        ConfigError: one line naming the file and key: unknown or missing key, wrong type, a
            non-integer pole-pair/slot/count number, an implausible value (wrong unit), or
            ``slots``/``pole_pairs`` that make no three-phase motor.
    """
    file = str(path)
    doc = load_toml(path)
    if _kind(doc, file) != "rotary":
        raise ConfigError(f"{file}: not a rotary motor (set kind = \"rotary\")")
    _check_keys(doc, tuple(ROTARY_PLAUSIBLE) + ("kind",), _Where(file))
    vals = {}
    for key, (lo, hi, unit) in ROTARY_PLAUSIBLE.items():
        if key not in doc:
            if key in _ROTARY_REQUIRED:
                what = "an integer" if key in _ROTARY_INT else f"a number in {unit}"
                raise ConfigError(f"{file}: key '{key}' missing (expected {what})")
            continue
        v = doc[key]
        u = f" {unit}" if unit else ""
        if key in _ROTARY_INT:
            if isinstance(v, bool) or not isinstance(v, int):
                shown = f" = {_fmt(v)}" if not isinstance(v, (dict, list)) else ""
                raise ConfigError(f"{file}: {key}{shown} is {_describe(v)}, expected an integer")
        elif isinstance(v, bool) or not isinstance(v, (int, float)):
            shown = f" = {_fmt(v)}" if not isinstance(v, (dict, list)) else ""
            raise ConfigError(f"{file}: {key}{shown} is {_describe(v)}, expected a number in {unit}")
        x = float(v)
        lo_ok = x > lo if key == "current_limit" else x >= lo
        if not (math.isfinite(x) and lo_ok and x <= hi):
            hint = ""
            if key == "sample_time" and lo <= x * 1e-3 <= hi:
                hint = "; did you give ms?"
            elif key == "commutation_offset" and abs(x * math.pi / 180) <= hi:
                hint = "; did you give degrees?"
            elif key == "control_rate" and lo <= x * 1e3 <= hi:
                hint = "; did you give kHz?"
            raise ConfigError(f"{file}: {key} = {_fmt(v)}{u} is implausible (expected {lo:g}–{hi:g}{u}{hint})")
        vals[key] = int(v) if key in _ROTARY_INT else x
    if "slots" in vals and vals["slots"] % 3:
        raise ConfigError(f"{file}: slots = {vals['slots']} is not a multiple of 3 (a three-phase winding)")
    _check_rotary_orders(vals, file)
    try:
        return RotaryMotor(**vals)
    except ValueError as e:
        raise ConfigError(f"{file}: {' '.join(str(e).split())}") from None


def _check_rotary_orders(vals: dict, file: str) -> None:
    """Refuse a slot/pole combination whose model reaches beyond :data:`MAX_ROTARY_ORDER` (each value may be in its
    range, their least common multiple not)."""
    p, q = vals["pole_pairs"], vals.get("slots")
    if q is not None and int(cogging_orders(q, p).max()) > MAX_ROTARY_ORDER:
        lcm = fundamental_cogging_order(q, p)
        raise ConfigError(f"{file}: slots = {q} with pole_pairs = {p} put the cogging fundamental at LCM(Q, 2p) = "
                          f"{lcm} per revolution and the model's orders up to {int(cogging_orders(q, p).max())}, "
                          f"beyond the {MAX_ROTARY_ORDER} pgcomm identifies: identification screens every order up to "
                          "the highest, on logs slow enough to resolve it (its time grows with about the 2.5th power "
                          "of that order)")
    if int(ripple_orders(q, p).max()) > MAX_ROTARY_ORDER:
        raise ConfigError(f"{file}: pole_pairs = {p} puts the torque ripple at order 12p = {12 * p} per revolution, "
                          f"beyond the {MAX_ROTARY_ORDER} pgcomm identifies (at most pole_pairs = "
                          f"{MAX_ROTARY_ORDER // 12})")


def rotary_motor_to_toml(motor) -> str:
    """The TOML text of a :class:`pgcomm.rotary.motor.RotaryMotor` (readable by :func:`load_rotary_motor`)."""
    lines = ["# pgcomm rotary motor description (SI units: rad, s, A, N·m, kg·m²)",
             'kind = "rotary"',
             f"pole_pairs = {int(motor.pole_pairs)}  # p: electrical period 2π/p",
             (f"slots = {int(motor.slots)}  # Q: {motor.name}, cogging at LCM(Q, 2p) = {motor.cogging_fundamental} "
              "periods per revolution" if motor.slots is not None
              else "# slots unknown: pgcomm identify reads them from the logs"),
             f"sample_time = {_toml_float(motor.sample_time)}  # the drive's logging period (s)"]
    for key, comment in (("k_t", "torque constant (N·m/A)"), ("inertia", "rotor + load (kg·m²)"),
                         ("current_limit", "q-current limit (A)"), ("friction", "Coulomb friction (N·m)")):
        v = getattr(motor, key)
        if v is not None:
            lines.append(f"{key} = {_toml_float(v)}  # {comment}")
    lines.append(f"commutation_offset = {_toml_float(motor.commutation_offset)}  # drive's electrical offset (rad)")
    if motor.encoder_counts is not None:
        lines.append(f"encoder_counts = {int(motor.encoder_counts)}  # counts per revolution")
    if motor.control_rate is not None:
        lines.append(f"control_rate = {_toml_float(motor.control_rate)}  # the drive's loop rate (Hz)")
    return "\n".join(lines) + "\n"
