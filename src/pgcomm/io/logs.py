"""Measurement and simulation logs: CSV, Parquet, MATLAB .mat and HDF5.

Log format (DESIGN, "Formats"): one row per controller sample, columns

* ``t`` (s), uniformly sampled (a host's stamps: kept as recorded or resampled where a reader asks,
  :func:`read_log`'s ``stamps`` and ``resample``); may be absent if the sample time is given;
* ``y`` (m): position;
* ``Fy``, ``Fx`` (N), ``Tz`` (N·m): measured force, all three or none: a log without them
  is a log of a rig without a force sensor (:attr:`Log.has_force`; identification then uses
  the motion, ``pgcomm identify --no-force-sensor``); a log with only some of them is refused;
* per coil set ``l = 1..L`` the star currents ``ia_{l}``, ``ib_{l}`` (A), or the drive inputs
  ``Fy_ref_{l}`` (N), ``delta_{l}`` (rad), or the q/d-axis currents ``iq_{l}``, ``id_{l}`` (A) of a
  field-oriented drive in its own electrical frame (the q axis along the force, the paper's drive
  inputs seen from that drive; ``id_{l}`` may be absent — a drive holding ``i_d* = 0`` often does
  not log it — and is then taken as 0 A by :meth:`Log.dq_currents`, noted in :attr:`Log.notes`;
  an ``id_{l}`` without ``iq_{l}`` is refused), or several of these forms. Sign convention of
  the drive inputs (the one of :func:`pgcomm.commutation.transform_T_inverse`, of the exported
  C law and of every log pgcomm writes): ``Fy_ref_{l}`` is signed (it follows the force) and
  ``delta_{l}`` lies in ``(-π/2, π/2]``, so a data set driven at ``Δ = -π/4`` logs
  ``delta_{l} = -0.785`` throughout while ``Fy_ref_{l}`` changes sign with the demand. Logs
  from elsewhere may use the other equivalent pair ``(|Fy_ref|, Δ ± π)``: the readers accept
  both (the currents ``Γ(y) T(Fy_ref, Δ)`` are the same);
* optional ``r`` (m, reference), ``Fy_star``, ``Fx_star``, ``Tz_star`` (N, N,
  N·m, desired force), ``experiment`` and ``active_coil_set`` (integers stored
  as floats).

Rotary motors (DESIGN, "Rotary motors") log the mechanical angle ``theta`` (rad) in place of ``y``
(read them with ``required=ROTARY_REQUIRED``; a log with both ``y`` and ``theta`` is a linear
motor's, its ``theta`` an extra column left as it is), optionally ``velocity`` (the drive's velocity
estimate: rad/s beside ``theta``, m/s beside ``y``), the q/d-axis currents above, and optionally
the q/d-axis voltages ``vq_{l}``, ``vd_{l}`` and the supply voltage ``vbus`` (V). ``theta`` may be
multi-turn and either continuous or wrapped to one revolution (``[0, 2π)``, ``[−π, π)``, in any
angle unit): wraps are detected against the logged velocity (or, without it, assuming less than a
quarter revolution per sample) and removed (:func:`pgcomm.io.angles.unwrap_angle`); the log says so
in :attr:`Log.angle_wraps` and :attr:`Log.notes`; a jump that is neither a wrap nor motion is
refused with one line naming the file, column and sample. Angle units of ``theta``: ``rad``,
``mrad``, ``deg``, ``rev`` (``turn``); of ``velocity``: ``rad/s``, ``deg/s``, ``rev/s``, ``rpm``
(or ``m/s``, ``mm/s`` for a linear log).

File formats:

* ``.csv``: header line with the column names, one row per sample, ``,``
  separated. Read with ``pyarrow.csv`` (multi-threaded; tens of millions of
  rows); if pyarrow refuses the file, a plain Python parser finds the exact
  offending row for the message.
* ``.parquet``: one column per name (numeric types), written with pyarrow; the
  sample time is also kept in the schema metadata (``pgcomm.sample_time``).
* ``.mat``: MATLAB v5/v7 (read with :func:`scipy.io.loadmat`) or v7.3 (an HDF5
  file, read with h5py). Either every column is a top-level variable (a
  vector, N×1 or 1×N) named as in the log format or as in the column mapping,
  or all columns are fields of one struct: the struct named by ``group`` in
  the mapping's ``[options]``, or, without ``group``, the only struct in the
  file when no top-level variable has a log-column name.
* ``.h5`` / ``.hdf5``: one 1-D dataset per column, at the root or in the group
  named by ``group`` (a compound dataset with named fields named by ``group``
  works too).

For CSV and Parquet every numeric column is kept (extra numeric columns
survive a write/read round trip) and non-numeric columns with names that are
not log columns are ignored; for .mat/HDF5 only the log columns (and mapped
names) are read, since such files usually hold much else.

Column mapping (``--columns mapping.toml``) for files that use other names or
units::

    [columns]            # log-format name = name in the file
    y = "pos_mm"
    Fy = "force_y"
    ia_1 = "Ia1"
    [units]              # log-format name = unit of that column in the file
    y = "mm"
    Fy = "mN"
    # theta = "deg"      # rotary: rad, mrad, deg, rev; velocity = "rpm" (rad/s, deg/s, rev/s, rpm)
    [options]
    sample_time = 0.001  # s, when the file has no t column
    group = "data"       # HDF5 group / .mat struct holding the columns

Every reader validates what it returns (missing columns with the closest
match, incomplete coil sets, NaN/inf, non-numeric cells, non-uniform time) and
raises :class:`pgcomm.errors.DataError` with one line naming file, row and
column. Rows are numbered from 1 = first data row (for CSV also the file line).
"""

from __future__ import annotations

import glob
import math
import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.io.atomic import atomic_path
from pgcomm.io.config import closest_hint, list_names, load_toml
from pgcomm.io.tables import read_table
from pgcomm.io.angles import check_glitches, unwrap_angle

__all__ = [
    "Log",
    "ColumnMapping",
    "load_column_mapping",
    "with_encoder_counts",
    "column_mapping",
    "read_log",
    "read_logs",
    "write_log",
    "write_datasets",
    "is_log_column",
    "UNITS",
    "REQUIRED",
    "ROTARY_REQUIRED",
    "FORCE_COLUMNS",
    "KNOWN_COLUMNS",
    "TIME_TOLERANCE",
    "TIME_JITTER",
]

#: Columns a log must have (``t`` may be replaced by a given sample time).
REQUIRED = ("y",)

#: Columns a rotary motor's log must have: the mechanical angle in place of ``y``.
ROTARY_REQUIRED = ("theta",)

#: The measured force: a log has all of them (force sensor) or none (no force sensor).
FORCE_COLUMNS = ("Fy", "Fx", "Tz")

#: Log-format column names that are not per coil set.
#: Columns that label rows (which data set, which coil set drives) rather than measure: resampling holds them.
LABEL_COLUMNS = ("experiment", "active_coil_set")
KNOWN_COLUMNS = ("t", "y", "Fy", "Fx", "Tz", "r", "Fy_star", "Fx_star", "Tz_star", "experiment", "active_coil_set",
                 "theta", "velocity", "vbus")

#: Per-coil-set columns: ``ia_{l}``, ``ib_{l}``, ``Fy_ref_{l}``, ``delta_{l}``, ``iq_{l}``, ``id_{l}`` with ``l >= 1``.
_COIL_RE = re.compile(r"^(ia|ib|Fy_ref|delta|iq|id)_([0-9]+)$")

#: Optional per-coil-set voltages ``vq_{l}``, ``vd_{l}`` (V): logged, never a coil set's inputs.
_VOLT_RE = re.compile(r"^(vq|vd)_([1-9][0-9]*)$")

#: Relative tolerance between a given sample time and the one ``t`` has; below it ``t`` is uniform as stored.
TIME_TOLERANCE = 1e-6
#: ``t`` is uniform when every sample is within this share of a step of the uniform grid from its first to its
#: last value: a time stored as float32 (7.6e-6 s apart at 100 s) or with few digits is accepted and replaced by
#: the grid (with a note); a dropped sample or a change of the sample time moves samples by whole steps.
TIME_JITTER = 0.05

#: Plausibility bounds that catch a wrong unit: a controller sample beyond 0.1 s (t in ms), a
#: position beyond 10 m (y or r in mm).
MAX_SAMPLE_TIME = 0.1
MAX_POSITION = 10.0

#: Known units per quantity: unit string -> factor to SI.
UNITS = {
    "length": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "nm": 1e-9},
    "force": {"N": 1.0, "mN": 1e-3, "kN": 1e3},
    "torque": {
        "N*m": 1.0, "Nm": 1.0, "N·m": 1.0,
        "mN*m": 1e-3, "mNm": 1e-3, "mN·m": 1e-3,
        "Nmm": 1e-3, "N*mm": 1e-3, "N·mm": 1e-3,
    },
    "angle": {"rad": 1.0, "deg": math.pi / 180.0, "mrad": 1e-3},
    "current": {"A": 1.0, "mA": 1e-3},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6},
    # a rotary motor's mechanical angle: one revolution is 2π rad; "counts" (the encoder's) take their factor
    # 2π / encoder_counts from the mapping's [options] or the motor description (ColumnMapping.factor)
    "rotation": {"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180.0, "rev": 2.0 * math.pi, "turn": 2.0 * math.pi,
                 "counts": math.nan},
    # the drive's velocity estimate: angular beside theta, linear beside y
    "velocity": {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rev/s": 2.0 * math.pi, "rpm": 2.0 * math.pi / 60.0,
                 "counts/s": math.nan, "m/s": 1.0, "mm/s": 1e-3},
    "voltage": {"V": 1.0, "mV": 1e-3, "kV": 1e3},
}

#: Velocity units that are angular (the others are linear).
ANGULAR_VELOCITY_UNITS = ("rad/s", "deg/s", "rev/s", "rpm", "counts/s")
#: Units in encoder counts: their factor is 2π / ``encoder_counts`` (per revolution).
COUNT_UNITS = ("counts", "counts/s")
#: A host-stamped log is split where a step exceeds this many times its median step: the drive's state across such a
#: gap is not known, and no filter window may span it.
GAP_STEPS = 10.0

_QUANTITY = {
    "t": "time", "y": "length", "r": "length",
    "Fy": "force", "Fx": "force", "Fy_star": "force", "Fx_star": "force",
    "Tz": "torque", "Tz_star": "torque",
    "ia": "current", "ib": "current", "Fy_ref": "force", "delta": "angle",
    "theta": "rotation", "velocity": "velocity", "iq": "current", "id": "current",
    "vq": "voltage", "vd": "voltage", "vbus": "voltage",
}


def _coil(name: str):
    """``("ia", 2)`` for ``"ia_2"``; ``None`` for names that are not per coil set (or l < 1)."""
    m = _COIL_RE.match(name)
    if m is None or int(m.group(2)) < 1:
        return None
    return m.group(1), int(m.group(2))


def is_log_column(name: str) -> bool:
    """Whether ``name`` is a log-format column name (see module docstring)."""
    return name in KNOWN_COLUMNS or _coil(name) is not None or _VOLT_RE.match(name) is not None


def _quantity(name: str) -> str | None:
    c = _coil(name)
    v = _VOLT_RE.match(name)
    return _QUANTITY.get(c[0] if c else v.group(1) if v else name)


def _known_examples():
    return list(KNOWN_COLUMNS) + [f"{k}_{l}" for l in (1, 2, 3)
                                  for k in ("ia", "ib", "Fy_ref", "delta", "iq", "id", "vq", "vd")]


# --------------------------------------------------------------------------- column mapping


@dataclass(frozen=True)
class ColumnMapping:
    """How the columns of a user's file map onto the log format.

    Attributes:
        columns: log-format name -> name in the file.
        units: log-format name -> unit string of that column in the file (see :data:`UNITS`).
        sample_time: sample time (s) for files without ``t``, or ``None``.
        group: HDF5 group / .mat struct holding the columns, or ``None``.
        source: file the mapping came from (for messages).
        encoder_counts: counts per revolution for the unit ``counts`` (``counts/s``), or ``None``.
    """

    columns: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    sample_time: float | None = None
    group: str | None = None
    source: str = "column mapping"
    encoder_counts: int | None = None

    def factor(self, name: str) -> float:
        """Factor converting column ``name`` (log-format name) to SI (``2π / encoder_counts`` for counts).

        Raises:
            ConfigError: a column in counts without ``encoder_counts``.
        """
        unit = self.units.get(name)
        if unit is None:
            return 1.0
        if unit in COUNT_UNITS:
            if self.encoder_counts is None:
                raise ConfigError(f"{self.source}: [units] {name} = '{unit}' needs the encoder's counts per revolution: "
                                  "set [options] encoder_counts, or encoder_counts in the motor TOML")
            return 2.0 * math.pi / self.encoder_counts
        return UNITS[_quantity(name)][unit]


def column_mapping(table: dict, source: str = "column mapping") -> ColumnMapping:
    """Build a :class:`ColumnMapping` from a parsed TOML document.

    Args:
        table: dict with optional tables ``columns``, ``units``, ``options``.
        source: name for messages (the TOML file).

    Raises:
        ConfigError: unknown table/option, a key that is not a log-format
            column (with closest match), non-string values, two log columns
            mapped to the same file column, a bad ``sample_time``.
        DataError: an unknown unit string (lists the known units of that quantity).
    """
    for key in table:
        if key not in ("columns", "units", "options"):
            raise ConfigError(
                f"{source}: unknown table [{key}]{closest_hint(key, ['columns', 'units', 'options'], 'closest valid table')};"
                " valid tables: [columns], [units], [options]"
            )
    sections = {}
    for sec in ("columns", "units", "options"):
        v = table.get(sec, {})
        if not isinstance(v, dict):
            raise ConfigError(f"{source}: '{sec}' must be a table [{sec}]")
        sections[sec] = v
    examples = _known_examples()
    for sec in ("columns", "units"):
        for name, value in sections[sec].items():
            if not is_log_column(name):
                raise ConfigError(
                    f"{source}: [{sec}] '{name}' is not a log column{closest_hint(name, examples)};"
                    " known: t, y, Fy, Fx, Tz, r, Fy_star, Fx_star, Tz_star, experiment, active_coil_set,"
                    " theta, velocity, vbus, ia_<l>, ib_<l>, Fy_ref_<l>, delta_<l>, iq_<l>, id_<l>, vq_<l>, vd_<l>"
                )
            if not isinstance(value, str):
                raise ConfigError(f"{source}: [{sec}] {name} = {value!r} must be a string")
    seen = {}
    for name, user in sections["columns"].items():
        if user in seen:
            raise ConfigError(f"{source}: [columns] {seen[user]} and {name} are both mapped to '{user}'")
        seen[user] = name
    units = {}
    for name, unit in sections["units"].items():
        q = _quantity(name)
        if q is None:
            raise ConfigError(f"{source}: [units] {name} = '{unit}': column '{name}' has no unit")
        u = unit.strip()
        if u not in UNITS[q]:
            raise DataError(f"{source}: [units] {name} = '{unit}' is not a known {q} unit (known: {', '.join(UNITS[q])})")
        units[name] = u
    opts = sections["options"]
    valid = ["sample_time", "group", "encoder_counts"]
    for key in opts:
        if key not in valid:
            raise ConfigError(
                f"{source}: unknown key '{key}' in table [options]"
                f"{closest_hint(key, valid, 'closest valid key')}; valid keys: {', '.join(valid)}"
            )
    counts = opts.get("encoder_counts")
    if counts is not None and (isinstance(counts, bool) or not isinstance(counts, int) or not 4 <= counts <= 2**40):
        raise ConfigError(f"{source}: [options] encoder_counts = {counts!r} must be a whole number of counts per "
                          "revolution (at least 4)")
    ts = opts.get("sample_time")
    if ts is not None:
        if isinstance(ts, bool) or not isinstance(ts, (int, float)) or not (0 < ts < math.inf):
            raise ConfigError(f"{source}: [options] sample_time = {ts!r} must be a positive number of seconds")
        ts = float(ts)
    group = opts.get("group")
    if group is not None and not isinstance(group, str):
        raise ConfigError(f"{source}: [options] group = {group!r} must be a string")
    return ColumnMapping(dict(sections["columns"]), units, ts, group, source, counts)


def with_encoder_counts(mapping: "ColumnMapping | None", motor) -> "ColumnMapping | None":
    """``mapping`` with the motor description's ``encoder_counts`` (counts per revolution) where the mapping has none
    of its own: a rotary log's angle may then be given in counts (``[units] theta = "counts"``)."""
    counts = getattr(motor, "encoder_counts", None)
    if mapping is None or mapping.encoder_counts is not None or counts is None:
        return mapping
    return replace(mapping, encoder_counts=int(counts))


def load_column_mapping(path) -> ColumnMapping:
    """Read a column-mapping TOML file (format in the module docstring)."""
    return column_mapping(load_toml(path), str(path))


def _as_mapping(columns) -> ColumnMapping:
    if columns is None:
        return ColumnMapping()
    if isinstance(columns, ColumnMapping):
        return columns
    if isinstance(columns, dict):
        return column_mapping(columns)
    if isinstance(columns, (str, os.PathLike)):
        return load_column_mapping(columns)
    raise TypeError(f"columns must be None, a path, a dict or a ColumnMapping, not {type(columns).__name__}")


# --------------------------------------------------------------------------- Log


@dataclass
class Log:
    """One log: equal-length float64 columns plus the sample time.

    Attributes:
        columns: column name -> 1-D float64 array of length ``N`` (names as in
            the module docstring; extra names allowed). Converted on construction.
        sample_time: controller sample time (s).
        source: where the log came from (file name), used in messages.
        angle_wraps: number of one-revolution wraps :func:`read_log` removed from ``theta``
            (0: the file's angle was continuous, or the log has no ``theta``).
        notes: what the reader did beyond unit conversion, one sentence each (wraps removed,
            a missing ``id_{l}`` taken as 0 A), for the user's report.
        gaps: rows ``i`` (0-based) after which samples were dropped (``t[i+1] − t[i]`` a whole number of
            sample times above one; only when :func:`read_log` was asked to accept them): the log is then
            uniform between them, and :meth:`segments` gives those stretches; for a log with non-uniform
            stamps, the steps longer than :data:`GAP_STEPS` median steps.
        uniform: whether ``t`` is a uniform grid of ``sample_time`` (between gaps); ``False`` for a host's stamps kept
            as recorded (``read_log(..., stamps=True)``), ``sample_time`` then their median step.
    """

    columns: dict
    sample_time: float
    source: str = "log"
    angle_wraps: int = 0
    notes: tuple = ()
    gaps: tuple = ()
    uniform: bool = True

    def __post_init__(self):
        cols = {}
        n = None
        for name, v in self.columns.items():
            a = np.asarray(v, dtype=np.float64)
            if a.ndim != 1:
                raise DataError(f"{self.source}: column '{name}' has shape {a.shape}, expected 1-D")
            if n is None:
                n, first = len(a), name
            elif len(a) != n:
                raise DataError(f"{self.source}: column '{name}' has {len(a)} rows but '{first}' has {n}")
            cols[name] = a
        self.columns = cols
        ts = float(self.sample_time)
        if not (0.0 < ts < math.inf):
            raise DataError(f"{self.source}: sample time {ts:g} s must be positive and finite")
        self.sample_time = ts

    def segments(self) -> list[tuple[int, int]]:
        """``[(start, stop), ...]``: the row ranges between dropped samples (the whole log when there are none)."""
        cuts = [0, *(int(i) + 1 for i in self.gaps), self.n_samples]
        return [(a, b) for a, b in zip(cuts[:-1], cuts[1:])]

    def __len__(self) -> int:
        return self.n_samples

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    @property
    def n_samples(self) -> int:
        """Number of rows ``N``."""
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def t(self) -> np.ndarray:
        """Time (s), shape ``(N,)``: column ``t``, or ``arange(N) * sample_time``."""
        if "t" in self.columns:
            return self.columns["t"]
        return np.arange(self.n_samples) * self.sample_time

    @property
    def n_coil_sets(self) -> int:
        """``L``: the highest coil-set index among the per-coil-set columns (0 if none)."""
        ls = [c[1] for c in map(_coil, self.columns) if c is not None]
        return max(ls, default=0)

    def _stack(self, a: str, b: str):
        n = self.n_coil_sets
        if n == 0 or not all(f"{a}_{l}" in self.columns and f"{b}_{l}" in self.columns for l in range(1, n + 1)):
            return None
        return (
            np.stack([self.columns[f"{a}_{l}"] for l in range(1, n + 1)], axis=-1),
            np.stack([self.columns[f"{b}_{l}"] for l in range(1, n + 1)], axis=-1),
        )

    def currents(self) -> np.ndarray | None:
        """Star currents ``(N, L, 2)`` = ``[ia_l, ib_l]`` (A), or ``None`` if a coil set has none."""
        s = self._stack("ia", "ib")
        return None if s is None else np.stack(s, axis=-1)

    def drive_inputs(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Drive inputs ``(Fy_ref (N, L) in N, delta (N, L) in rad)``, or ``None`` if a coil set has none."""
        return self._stack("Fy_ref", "delta")

    def dq_currents(self) -> np.ndarray | None:
        """q/d-axis currents ``(N, L, 2)`` = ``[iq_l, id_l]`` (A) in the drive's frame, or ``None`` if a coil set has no ``iq_l``.

        A coil set without ``id_l`` gets ``id = 0`` (a field-oriented drive holding ``i_d* = 0``;
        :func:`read_log` says so in :attr:`notes`).
        """
        n = self.n_coil_sets
        if n == 0 or not all(f"iq_{l}" in self.columns for l in range(1, n + 1)):
            return None
        zero = np.zeros(self.n_samples)
        return np.stack([np.stack([self.columns[f"iq_{l}"], self.columns.get(f"id_{l}", zero)], axis=-1)
                         for l in range(1, n + 1)], axis=1)

    @property
    def is_rotary(self) -> bool:
        """Whether the log is a rotary motor's: the mechanical angle ``theta`` (rad) in place of ``y``."""
        return "theta" in self.columns and "y" not in self.columns

    @property
    def has_force(self) -> bool:
        """Whether the log holds the measured force ``Fy, Fx, Tz`` (False: a rig without a force sensor)."""
        return all(c in self.columns for c in FORCE_COLUMNS)

    def force(self) -> np.ndarray:
        """Measured force ``(N, 3)`` = ``[Fy, Fx, Tz]`` (N, N, N·m).

        Raises:
            DataError: the log has no force columns (no force sensor); check :attr:`has_force` first.
        """
        if not self.has_force:
            missing = ", ".join(c for c in FORCE_COLUMNS if c not in self.columns)
            raise DataError(f"{self.source}: no measured force (column(s) {missing} missing): a log without a "
                            "force sensor; this needs the force Fy, Fx, Tz")
        return np.stack([self.columns["Fy"], self.columns["Fx"], self.columns["Tz"]], axis=-1)

    def desired_force(self) -> np.ndarray | None:
        """Desired force ``(N, 3)`` = ``[Fy_star, Fx_star, Tz_star]``, or ``None`` when not logged."""
        names = ("Fy_star", "Fx_star", "Tz_star")
        if not all(n in self.columns for n in names):
            return None
        return np.stack([self.columns[n] for n in names], axis=-1)


# --------------------------------------------------------------------------- writing


def _ordered(log: Log) -> tuple[list[str], list[np.ndarray]]:
    """Column order for writing: ``t`` first (made from the sample time if absent), then as stored."""
    names = list(log.columns)
    arrays = [log.columns[n] for n in names]
    if "t" in log.columns:
        i = names.index("t")
        names.insert(0, names.pop(i))
        arrays.insert(0, arrays.pop(i))
    else:
        names.insert(0, "t")
        arrays.insert(0, log.t)
    for n in names:
        if not n or any(ch in n for ch in ',"\r\n'):
            raise ConfigError(f"{log.source}: column name {n!r} cannot be written (empty, or contains , \" or a newline)")
    return names, arrays


def write_log(path, log: Log) -> None:
    """Write ``log`` to ``path`` (atomically); the format follows the suffix.

    * ``.csv``: header line, then one row per sample. Numbers are written in
      the shortest form that reads back to the identical float64 (pyarrow's
      writer; the same guarantee as ``%.17g`` with fewer digits and ~20× faster).
    * ``.parquet``: pyarrow, float64 columns, ``pgcomm.sample_time`` in the metadata.

    A ``t`` column (s) is written first; if the log has none it is made from
    ``sample_time``, so that the file is self-describing.

    Raises:
        ConfigError: unsupported suffix or unwritable column name.
    """
    import pyarrow as pa  # start-up cost: PyArrow loads only when this runs

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise ConfigError(f"{path}: cannot write logs as '{suffix}' (supported: .csv, .parquet)")
    names, arrays = _ordered(log)
    table = pa.table(dict(zip(names, arrays)))
    if suffix == ".csv":
        import pyarrow.csv as pacsv  # start-up cost: PyArrow loads only when this runs

        with atomic_path(path) as tmp:
            with pa.OSFile(str(tmp), "wb") as sink:
                # Our own header: pyarrow would quote the names, which some tools keep as part of the name.
                sink.write((",".join(names) + "\n").encode())
                pacsv.write_csv(table, sink, write_options=pacsv.WriteOptions(include_header=False))
    else:
        import pyarrow.parquet as pq  # start-up cost: PyArrow loads only when this runs

        table = table.replace_schema_metadata({b"pgcomm.sample_time": repr(log.sample_time).encode()})
        with atomic_path(path) as tmp:
            pq.write_table(table, str(tmp))


def write_datasets(folder, datasets) -> list[Path]:
    """Write data sets ``Z_i^l`` as logs ``folder/Z{i}_coilset{l}.csv`` (1-based ``i``, ``l``; atomically).

    The files a production line (or ``pgcomm calibrate --save-data``) records: every column
    of :meth:`pgcomm.data.DataSet.columns` (log format plus ``Fy_star, Fx_star, Tz_star``,
    ``active_coil_set``) and ``experiment = i``.

    Args:
        folder: target directory (created with its parents).
        datasets: ``datasets[l][i]`` as returned by :func:`pgcomm.data.generate_datasets`
            (objects with ``.columns()``, ``.coil_set`` (0-based) and ``.result``).

    Returns:
        the written paths, in the order of ``datasets``.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for pair in datasets:
        for i, ds in enumerate(pair):
            cols = ds.columns()
            cols["experiment"] = np.full(ds.result.t.shape[0], float(i + 1))
            path = folder / f"Z{i + 1}_coilset{ds.coil_set + 1}.csv"
            write_log(path, Log(cols, ds.result.sample_time, source="dataset"))
            paths.append(path)
    return paths


# --------------------------------------------------------------------------- reading: validation


def _first_bad(a: np.ndarray) -> int | None:
    if np.isfinite(a).all():  # the common case: one vectorised pass
        return None
    return int(np.flatnonzero(~np.isfinite(a))[0])


def read_log(path, sample_time: float | None = None, columns=None, required=REQUIRED, min_coil_sets: int = 1,
             gaps: bool = False, stamps: bool = False, resample: bool = False) -> Log:
    """Read and validate one log file.

    Args:
        path: ``.csv``, ``.parquet``, ``.mat`` (v5/v7 or v7.3) or ``.h5``/``.hdf5``.
        sample_time: controller sample time (s); needed when the file has no ``t``
            column (else taken from ``t``, and checked against it when given).
            Overrides ``[options] sample_time`` of the mapping.
        columns: column mapping: ``None``, a TOML path, a parsed TOML dict or a
            :class:`ColumnMapping` (see module docstring).
        required: log-format columns that must be present.
        min_coil_sets: minimum number of coil sets ``L`` the log must describe.
        gaps: accept dropped samples (steps of ``t`` that are whole numbers of sample times): the log keeps
            them in :attr:`Log.gaps`, with a note; its user must not difference across them (the rotary
            identification uses each stretch between them as a log). Otherwise a dropped sample is refused.
        stamps: keep non-uniform time stamps as recorded (a host's clock: :attr:`Log.uniform` is then ``False`` and
            ``sample_time`` the median step), split where a step exceeds :data:`GAP_STEPS` median steps
            (:attr:`Log.gaps`); only stamps that repeat or go back are refused. For readers that use the real
            intervals (the rotary identification); otherwise non-uniform time is refused.
        resample: non-uniform time stamps (a host's clock) are interpolated, every column linearly (the labels of
            :data:`LABEL_COLUMNS` held), onto a uniform grid of their median step (or ``sample_time`` where given), with a note; a step over :data:`GAP_STEPS`
            median steps is refused with its row. For readers that need a uniform grid (the linear motor's
            commands).

    Returns:
        :class:`Log` whose columns use log-format names and SI units; it always
        has a ``t`` column (made as ``arange(N) * sample_time`` if the file has none).

    Raises:
        DataError: unreadable file, unsupported suffix, missing columns (with
            the closest match among the file's columns), incomplete coil sets,
            non-numeric or empty cells, NaN/inf, ``t`` not strictly increasing
            or not uniform (each sample within :data:`TIME_JITTER` of a step of its grid), fewer than
            2 rows, or no sample time.
        ConfigError: a bad column mapping.
    """
    mapping = _as_mapping(columns)
    src = str(path)
    p = Path(path)
    inverse = {user: name for name, user in mapping.columns.items()}

    def wanted(name: str) -> bool:
        return name in inverse or (is_log_column(name) and name not in mapping.columns)

    table = read_table(p, wanted, group=mapping.group, source=src, what="log")
    raw, found, file_ts, kind = table.columns, table.found, table.sample_time, table.kind
    found_short = [n.rsplit(".", 1)[-1].rsplit("/", 1)[-1] for n in found]

    # Rename to log-format names (file order); a log name that is mapped shadows a file column of that name.
    cols: dict[str, np.ndarray] = {}
    label: dict[str, str] = {}
    for name, arr in raw.items():
        if name in inverse:
            cols[inverse[name]] = arr
            label[inverse[name]] = f"'{name}' ({inverse[name]})"
        elif name not in mapping.columns:
            cols[name] = arr
    for name, user in mapping.columns.items():
        if name not in cols:
            raise DataError(
                f"{src}: {kind} '{user}' (mapped to {name} in {mapping.source}) missing; "
                f"found {list_names(found)}{closest_hint(user, found_short)}"
            )

    def lab(name):
        return label.get(name, f"'{name}'")

    # Units to SI, in place where the array is ours (no second copy).
    for name in list(cols):
        fac = mapping.factor(name) if name in mapping.units else 1.0
        if fac != 1.0:
            a = cols[name]
            if a.flags.writeable and a.flags.owndata:
                a *= fac
            else:
                cols[name] = a * fac

    lengths = {len(a) for a in cols.values()}
    if len(lengths) > 1:
        names = list(cols)
        n0 = len(cols[names[0]])
        other = next(n for n in names if len(cols[n]) != n0)
        raise DataError(f"{src}: {kind} {lab(other)} has {len(cols[other])} rows but {lab(names[0])} has {n0}")

    # Required columns; the closest match is sought among file columns not already used.
    unused = [n for n in found_short if not is_log_column(n) and n not in inverse]
    for name in required:
        if name not in cols:
            raise DataError(
                f"{src}: {kind} '{name}' missing; found {list_names(found) or 'nothing'}{closest_hint(name, unused)}"
            )

    # The force: all of Fy, Fx, Tz (force sensor) or none (no force sensor), never some.
    missing_force = [c for c in FORCE_COLUMNS if c not in cols]
    if 0 < len(missing_force) < len(FORCE_COLUMNS):
        names = ", ".join(f"'{c}'" for c in missing_force)
        raise DataError(
            f"{src}: {kind}{'s' if len(missing_force) > 1 else ''} {names} missing (a log has all of the force columns Fy, Fx, Tz, or none of them "
            f"without a force sensor); found {list_names(found) or 'nothing'}{closest_hint(missing_force[0], unused)}"
        )

    # Coil sets 1..L, each with both currents or both drive inputs.
    coil = {}
    for name in cols:
        c = _coil(name)
        if c is not None:
            coil.setdefault(c[1], set()).add(c[0])
    n_sets = max(coil, default=0)
    if n_sets < min_coil_sets:
        raise DataError(
            f"{src}: no columns for coil set {n_sets + 1} (expected ia_{n_sets + 1}, ib_{n_sets + 1} or "
            f"Fy_ref_{n_sets + 1}, delta_{n_sets + 1}); found {list_names(found) or 'nothing'}"
            f"{closest_hint(f'ia_{n_sets + 1}', unused)}"
        )
    notes = []
    for l in range(1, n_sets + 1):
        have = coil.get(l, set())
        if not have:
            raise DataError(
                f"{src}: no columns for coil set {l} but coil sets up to {n_sets} are present "
                f"(coil sets must be 1..L; expected ia_{l}, ib_{l} or Fy_ref_{l}, delta_{l} or iq_{l}[, id_{l}])"
            )
        if "id" in have and "iq" not in have:
            # a d-axis current alone says nothing about the force: never read it as a complete coil set
            raise DataError(
                f"{src}: {kind} 'iq_{l}' missing (coil set {l} has id_{l} but no iq_{l}; a field-oriented drive's "
                f"log gives the q-axis current iq_{l}, and id_{l} with it or not at all){closest_hint(f'iq_{l}', unused)}"
            )
        if "iq" in have and "id" not in have:
            notes.append(f"coil set {l}: no id_{l} in the log, taken as 0 A (a drive holding i_d* = 0)")
        if {"ia", "ib"} <= have or {"Fy_ref", "delta"} <= have or "iq" in have:
            continue
        pairs = (("ia", "ib"), ("Fy_ref", "delta"))
        part = next(p for p in pairs if set(p) & have)
        present = next(k for k in part if k in have)
        missing = next(k for k in part if k not in have)
        raise DataError(
            f"{src}: {kind} '{missing}_{l}' missing (coil set {l} has {present}_{l} but no {missing}_{l}; give both "
            f"currents ia_{l}, ib_{l} or both drive inputs Fy_ref_{l}, delta_{l}){closest_hint(f'{missing}_{l}', unused)}"
        )

    n = lengths.pop() if lengths else 0
    if n < 2:
        raise DataError(f"{src}: {n} data rows, a log needs at least 2")

    # NaN / inf: report the earliest row (first column at that row).
    worst = None
    for name, a in cols.items():
        i = _first_bad(a)
        if i is not None and (worst is None or i < worst[0]):
            worst = (i, name)
    if worst is not None:
        i, name = worst
        raise DataError(f"{src} row {i + 1} {kind} {lab(name)}: {cols[name][i]} is not a finite number")

    # Time base.
    gap_rows: tuple = ()
    given_ts = sample_time if sample_time is not None else mapping.sample_time
    if given_ts is not None:
        given_ts = float(given_ts)
        if not (0.0 < given_ts < math.inf):
            raise DataError(f"{src}: sample time {given_ts:g} s must be positive and finite")
    uniform = True
    if "t" in cols:
        t = cols["t"]
        dt = np.diff(t)
        nonpos = np.flatnonzero(dt <= 0)
        if nonpos.size:
            i = int(nonpos[0])
            what = "repeats the stamp" if dt[i] == 0 else "goes back"
            raise DataError(
                f"{src} row {i + 2} {kind} {lab('t')}: t = {t[i + 1]:.17g} s is not after t = {t[i]:.17g} s of row "
                f"{i + 1} (the time {what}; t must be strictly increasing)"
            )
        est = (t[-1] - t[0]) / (n - 1)
        # uniform up to the rounding of t's own values (float32, few digits in a text file): every sample within
        # TIME_JITTER of a step of the grid; a change of the sample time or a dropped sample moves them by steps
        grid = np.arange(n, dtype=float)
        dev = t - (t[0] + est * grid)
        if (gaps or stamps) and np.max(np.abs(dev)) > TIME_JITTER * est:
            # dropped samples: every sample on a grid of the median step, its index jumping where samples are missing
            step = float(np.median(dt))
            idx = np.rint((t - t[0]) / step)
            if np.max(np.abs(t - (t[0] + step * idx))) <= TIME_JITTER * step and np.all(np.diff(idx) >= 1):
                grid = idx
                est = float(np.polyfit(grid, t, 1)[0])
                dev = t - (t[0] + est * grid)
        if resample and not stamps and np.max(np.abs(dev)) > TIME_JITTER * est:
            # a host's stamps for a reader that needs a uniform grid: every column interpolated onto the grid of the
            # median step (or the sample time given); across a long gap nothing is known, so that is refused
            step = given_ts if given_ts is not None else float(np.median(dt))
            long = np.flatnonzero(dt > GAP_STEPS * step)
            if long.size:
                i = int(long[0])
                raise DataError(f"{src} row {i + 2} {kind} {lab('t')}: a gap of {dt[i] * 1e3:.4g} ms after t = "
                                f"{t[i]:.9g} s, over {GAP_STEPS:g} times the median step of {step * 1e3:.4g} ms: no "
                                "uniform grid is made across it (split the log there)")
            grid = np.arange(int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1, dtype=float)
            t_grid = t[0] + step * grid
            notes.append(f"t: non-uniform time stamps (steps {dt.min() * 1e3:.3g} to {dt.max() * 1e3:.3g} ms around "
                         f"{np.median(dt) * 1e3:.3g} ms), every column resampled to a uniform grid of {step * 1e3:.6g} "
                         "ms (linear interpolation)")
            held = np.searchsorted(t, t_grid, side="right") - 1  # each grid point's last sample at or before it
            for name in cols:
                if name in LABEL_COLUMNS:
                    cols[name] = cols[name][held]  # a label is not interpolated: the one in force
                elif name != "t":
                    cols[name] = np.interp(t_grid, t, cols[name])
            cols["t"] = t = t_grid
            n, est, dev = t.size, step, np.zeros(t.size)
        if stamps and np.max(np.abs(dev)) > TIME_JITTER * est:
            # a host's stamps: kept as recorded (the rotary regression integrates over the real intervals); a step
            # long against the median splits the log, since the state across it is not known
            uniform = False
            est = float(np.median(dt))
            long = np.flatnonzero(dt > GAP_STEPS * est)
            notes.append(f"t: non-uniform time stamps (steps {dt.min() * 1e3:.3g} to {dt.max() * 1e3:.3g} ms around "
                         f"{est * 1e3:.3g} ms), kept as recorded")
            if long.size:
                notes.append(f"t: split at {long.size} gap(s) longer than {GAP_STEPS:g} times the median step, the "
                             f"first after row {long[0] + 1} (t = {t[long[0]]:.9g} s, {dt[long[0]] * 1e3:.3g} ms): "
                             f"{long.size + 1} stretches")
                gap_rows = tuple(int(i) for i in long)
        elif np.max(np.abs(dev)) > TIME_JITTER * est:
            dt0 = dt[0]
            off = np.flatnonzero(np.abs(dt - dt0) > TIME_JITTER * dt0)
            i = int(off[0]) if off.size else int(np.argmax(np.abs(dev))) - 1
            raise DataError(
                f"{src} row {i + 2} {kind} {lab('t')}: time step changes from {dt0:.9g} s to {dt[i]:.9g} s "
                f"(t must be uniformly sampled, each sample within {100 * TIME_JITTER:g} % of a step of its grid; "
                "split or resample the log)"
            )
        if uniform:
            if np.max(np.abs(dev)) > TIME_TOLERANCE * est:
                notes.append(f"t: samples up to {np.max(np.abs(dev)) * 1e6:.3g} µs off a uniform grid of {est:.9g} s "
                             "(the rounding of its stored values), taken as that grid")
                cols["t"] = t = t[0] + est * grid
            jumps = np.flatnonzero(np.diff(grid) > 1.5)
            if jumps.size:
                dropped = int(round(float(np.sum(np.diff(grid)[jumps] - 1))))
                notes.append(f"t: {dropped} dropped sample(s) in {jumps.size} gap(s), the first after row "
                             f"{jumps[0] + 1} (t = {t[jumps[0]]:.9g} s): {jumps.size + 1} uniform stretches between them")
                gap_rows = tuple(int(i) for i in jumps)
        ts = est
        for cand, what in ((given_ts, "given"), (file_ts, "in the file metadata")):
            if cand is None or not uniform:
                continue
            if abs(cand - est) > TIME_TOLERANCE * est:
                if what == "given":
                    raise DataError(f"{src}: sample time {cand:g} s given but t has steps of {est:.9g} s")
                continue  # stale metadata: t wins
            ts = cand  # exact value when known
            break
    else:
        ts = given_ts if given_ts is not None else file_ts
        if ts is None:
            raise DataError(
                f"{src}: no {kind} 't' and no sample time given (pass the sample time, or set "
                f"[options] sample_time in the column mapping){closest_hint('t', unused)}"
            )
        cols = {"t": np.arange(n) * ts, **cols}
    if ts > MAX_SAMPLE_TIME:
        hint = ("; looks like milliseconds: declare it with [units] t = \"ms\" in a --columns mapping"
                if ts * 1e-3 <= MAX_SAMPLE_TIME else "")
        raise DataError(f"{src} {kind} {lab('t')}: sample time {ts:.6g} s is implausible for a motor controller "
                        f"(at most {MAX_SAMPLE_TIME:g} s){hint}")
    angle_wraps = 0
    # a rotary motor's log: theta in place of y (a linear log may carry a column named theta as an extra)
    rotary = "theta" in cols and "y" not in cols
    vunit = mapping.units.get("velocity")
    if vunit is not None and "velocity" in cols:
        angular = vunit in ANGULAR_VELOCITY_UNITS
        if angular and not rotary:
            raise DataError(f"{src} {kind} {lab('velocity')}: unit '{vunit}' is angular but the log is not a rotary "
                            "motor's (no angle 'theta' in place of 'y'; a linear log's velocity is in m/s or mm/s)")
        if not angular and rotary:
            raise DataError(f"{src} {kind} {lab('velocity')}: unit '{vunit}' is linear but the log is a rotary "
                            "motor's (it has 'theta'); give rad/s, deg/s, rev/s or rpm")
    if rotary:
        steps = np.diff(cols["t"]) if gap_rows or not uniform else ts  # the motion over a step is that of its time
        cols["theta"], angle_wraps = unwrap_angle(cols["theta"], steps, cols.get("velocity"), src, lab("theta"))
        check_glitches(cols["theta"], steps, src, lab("theta"))
        if angle_wraps:
            notes.append(f"theta: {angle_wraps} wrap(s) of one revolution removed (the file's angle was wrapped; "
                         "the log's theta is continuous)")
    for name in ("y", "r"):
        if name in cols and float(np.max(np.abs(cols[name]))) > MAX_POSITION:
            big = float(np.max(np.abs(cols[name])))
            hint = (f"; looks like mm: declare it with [units] {name} = \"mm\" in a --columns mapping"
                    if big * 1e-3 <= MAX_POSITION else "")
            raise DataError(f"{src} {kind} {lab(name)}: |{name}| reaches {big:.6g} m, implausible for a linear "
                            f"motor (at most {MAX_POSITION:g} m){hint}")
    return Log(cols, ts, src, angle_wraps, tuple(notes), gap_rows, uniform)


def read_logs(patterns, sample_time: float | None = None, columns=None, required=REQUIRED, min_coil_sets: int = 1,
              gaps: bool = False, stamps: bool = False, resample: bool = False) -> list[Log]:
    """Read several logs given as file names or glob patterns.

    Each pattern is expanded with :func:`glob.glob` (sorted; ``**`` recursive);
    files are read in pattern order, each file once. Other arguments as in
    :func:`read_log` (the column mapping is read once).

    Raises:
        DataError: a pattern that matches no file, or any :func:`read_log` error.
    """
    if isinstance(patterns, (str, os.PathLike)):
        patterns = [patterns]
    mapping = _as_mapping(columns)
    files: list[str] = []
    for pat in patterns:
        pat = str(pat)
        matches = sorted(glob.glob(pat, recursive=True)) if glob.has_magic(pat) else ([pat] if os.path.exists(pat) else [])
        if not matches:
            what = "no file matches" if glob.has_magic(pat) else "file not found"
            raise DataError(f"{pat}: {what}")
        for m in matches:
            if m not in files:
                files.append(m)
    if not files:
        raise DataError("no log files given")
    return [read_log(f, sample_time, mapping, required, min_coil_sets, gaps, stamps, resample) for f in files]
