"""Siemens SINAMICS S120 cogging torque compensation: ``p5260[0..4095]`` over the period ``p5253``.

From the S120 Drive Functions function manual (11/2017, 6SL3097-4AB00-0BP5), §8.15 "Cogging torque
compensation", parameter table (p. 631):

* ``p5260[0...4095]`` (N·m or N): "compensation values for the cogging torque compensation", filled by the
  drive's own learning (``p5251``) and "can be changed" by hand: **4096 values per table**, in **N·m**
  (rotary) or **N** (linear);
* ``p5253``: the period as a factor: for a rotating motor of **one mechanical revolution** (0.5 = half a
  revolution), for a linear motor of **one pole-pair width** (``p0315``); for a synchronous linear motor the
  manual advises the whole traversing range (``p5253`` = traversing distance / ``p0315``), with a motor
  measuring system whose absolute position is unique over that period;
* ``p5250.1 = 1``: **two tables**, one per direction, switched at a direction reversal with the speed
  hysteresis ``p5256`` (rpm or m/min): within the band the table in use stays;
* ``r5255[0]``: the actual torque/force while learning, ``r5255[1]`` the precontrolled torque/force (the
  compensation output); ``r5254[1]`` the table index in use.

The learned values are the torque the drive needs to hold the speed, i.e. the torque to add: pgcomm's
compensation in the drive's sign (``k_t × iq_comp``, or the linear force offset).

Assumed (the page read does not say; each file repeats it and what to check):

* entry ``i`` is at ``i / 4096`` of the period from position 0 of the motor measuring system (mod the
  period), positive direction the drive's; the drive interpolates linearly between entries;
* with two tables, the positive-direction table is ``p5260`` and the negative-direction table
  ``p5261[0..4095]`` (the second table's parameter number is not on the page read; a drive without
  ``p5261`` refuses the write rather than holding a wrong table);
* the hysteresis band is ``±p5256 / 2`` around standstill.

:func:`build_sinamics` builds the table(s) from a :class:`pgcomm.export.compensation.Compensation`,
:func:`write_sinamics` writes the parameter-write script, :func:`read_sinamics` reads it back,
:func:`sinamics_apply` is what the drive adds at a position and direction (the model of the drive used by
the tests and ``bench/drive_tables.py``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.export.drive_common import (
    FINE,
    RoundTrip,
    Source,
    error_of,
    f32,
    finite_value,
    float32_bound,
    fmt32,
    header,
    parameter_lines,
    periodic_linear,
    round_trip,
    unit_factor,
)
from pgcomm.io.atomic import atomic_write_text

__all__ = ["ENTRIES", "SOURCE", "SinamicsTable", "build_sinamics", "write_sinamics", "read_sinamics",
           "sinamics_apply", "select_direction", "entry_positions"]

#: ``p5260[0...4095]``.
ENTRIES = 4096

SOURCE = Source("SINAMICS S120 Drive Functions, Function Manual 11/2017 (6SL3097-4AB00-0BP5)",
                "section 8.15 Cogging torque compensation, parameter table (p. 631)",
                "https://www.easymanua.ls/siemens/sirotec/manual/1480009?p=631")

DOCUMENTED = (
    "p5260[0...4095]: 4096 compensation values (N m for a rotating motor, N for a linear motor) of one table",
    "p5253: the period as a factor of one mechanical revolution (rotating) or of one pole-pair width p0315 "
    "(linear); for a synchronous linear motor the whole traversing range (p5253 = traversing distance / p0315) "
    "with a measuring system absolute over that period",
    "p5250.1 = 1: two tables, one per direction, switched at a direction reversal with the speed hysteresis p5256 "
    "(rpm or m/min); inside the band the table in use stays",
    "the values are learned from the actual torque (r5255[0]) the drive needs: the torque or force to add "
    "(r5255[1] is the precontrolled value, r5254[1] the table index in use)",
)

ASSUMED = (
    "entry i is at i/4096 of the period from position 0 of the motor measuring system (mod the period), positive "
    "direction the drive's; linear interpolation between entries",
    "two tables: positive direction in p5260, negative direction in p5261[0..4095] (the second table's number is not "
    "on the page read; a drive without p5261 refuses the write)",
    "the hysteresis band is +-p5256/2 around standstill",
)


@dataclass(frozen=True)
class SinamicsTable:
    """SINAMICS table(s) ready to write.

    Attributes:
        kind: ``"rotary"`` or ``"linear"``; unit: ``"N m"`` or ``"N"``.
        factor: ``p5253``; period: the period (rad or m).
        origin: the position (rad or m) of entry 0 in pgcomm's coordinate (0: the measuring system's zero).
        tables: ``{"both": (4096,)}`` or ``{"forward": ..., "reverse": ...}`` (unit), float32 values.
        meant: the same before float32 rounding (for the read-back check).
        hysteresis: ``p5256`` (rpm or m/min) or ``None`` (not written).
        resolution: per table, the drive's interpolation of its entries against the compensation on a grid
            8 times finer over the model's span (unit).
        limit: the bound applied (unit) or ``None``; conversion: what the unit conversion rests on.
    """

    kind: str
    unit: str
    factor: float
    period: float
    origin: float
    tables: dict
    meant: dict = field(repr=False, default_factory=dict)
    hysteresis: float | None = None
    resolution: dict = field(default_factory=dict)
    limit: float | None = None
    conversion: str = ""
    source: str = ""
    round_trip: RoundTrip | None = None

    @property
    def directions(self) -> int:
        """1 or 2 tables."""
        return 2 if "forward" in self.tables else 1

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"entries": ENTRIES, "tables": self.directions, "unit": self.unit, "p5253": self.factor,
                "period": self.period, "p5256": self.hysteresis, "limit": self.limit, "conversion": self.conversion,
                "resolution": {k: v.to_dict() for k, v in self.resolution.items()},
                "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
                "source": SOURCE.text(), "assumptions": list(ASSUMED)}


def entry_positions(kind: str, period: float, span) -> np.ndarray:
    """``(4096,)`` positions (rad or m) of the entries in pgcomm's coordinate: ``i·period/4096``; for a linear
    motor taken into ``[span[0] − s, span[0] − s + period)``, ``s = period/4096``, so that with a period of at
    least the stroke and two spacings the cell where the table wraps lies beyond the stroke's end."""
    x = period * np.arange(ENTRIES) / ENTRIES
    if kind == "linear":
        start = span[0] - period / ENTRIES
        x = start + np.mod(x - start, period)
    return x


def _period_factor(comp, factor):
    """``p5253`` and the period (rad or m), checked."""
    if comp.rotary:
        f = 1.0 if factor is None else float(factor)
        copies = round(1.0 / f) if f > 0 else 0
        if not (math.isfinite(f) and 0 < f <= 1 and copies >= 1 and abs(copies * f - 1.0) < 1e-9):
            raise ConfigError(f"--period {factor}: for a rotary motor p5253 is a fraction 1/k of a revolution "
                              "(1, 0.5, 0.25, ...) so the table repeats exactly")
        return f, 2.0 * math.pi * f, copies
    d = comp.pole_pitch
    # default: the stroke and two entries more, so the cell where the table wraps (last entry to first) lies
    # beyond the stroke (entry_positions)
    f = comp.length / d * ENTRIES / (ENTRIES - 2) if factor is None else float(factor)
    if not (math.isfinite(f) and f > 0 and f * d >= comp.length * (1 - 1e-12)):
        raise ConfigError(f"--period {factor}: p5253 is a number of pole-pair widths ({d:g} m) that covers the "
                          f"model's stroke of {comp.length:g} m (at least {comp.length / d:.6g}), so every position "
                          "has its own entry")
    return f, f * d, 1


def build_sinamics(comp, torque_constant: float | None = None, directions: int = 1, factor: float | None = None,
                   hysteresis: float | None = None) -> SinamicsTable:
    """The table(s) for ``p5260`` (and the second direction) from ``comp``.

    Args:
        comp: :class:`pgcomm.export.compensation.Compensation` (rotary A or linear N).
        torque_constant: ``k_t`` (N·m/A) for a rotary motor (its entries are N·m).
        directions: 1 (one table, the forward/reverse average) or 2 (``p5250.1 = 1``).
        factor: ``p5253``; default one revolution (rotary) or the model's stroke and two entry spacings
            (linear: the table's wrap then falls beyond the stroke).
        hysteresis: ``p5256`` (rpm or m/min), written when given.

    Raises:
        ConfigError: a bad ``factor``, ``directions`` or missing torque constant.
    """
    if directions not in (1, 2):
        raise ConfigError(f"--directions {directions}: SINAMICS holds 1 table or 2 (one per direction, p5250.1 = 1)")
    scale, conversion = unit_factor(comp, "torque", torque_constant, None, "sinamics")
    f, period, copies = _period_factor(comp, factor)
    unit = "N m" if comp.rotary else "N"
    keys = {"both": None} if directions == 1 else {"forward": +1, "reverse": -1}
    tables, meant, res = {}, {}, {}
    limit = None if comp.limit is None else comp.limit * scale
    for name, s in keys.items():
        if comp.rotary:
            v = comp.grid(ENTRIES * copies, s).reshape(copies, ENTRIES).mean(axis=0)
        else:
            v = comp.values(entry_positions(comp.kind, period, comp.span), s)
        v = v * scale
        meant[name], tables[name] = v, f32(v)
        xf = comp.span[0] + comp.length * np.arange(ENTRIES * FINE) / (ENTRIES * FINE)
        applied = _interp(tables[name], xf, period)
        res[name] = error_of(applied, comp.values(xf, s) * scale, xf)
    return SinamicsTable(comp.kind, unit, f, period, 0.0, tables, meant, hysteresis, res, limit, conversion,
                         comp.source)


def _interp(values, x, period):
    return periodic_linear(values, np.asarray(x, float) / period * ENTRIES)


def select_direction(velocity, previous, band: float) -> np.ndarray:
    """The table in use after a speed sample: +1 above ``band/2``, −1 below ``−band/2``, else ``previous``."""
    v = np.asarray(velocity, dtype=float)
    return np.where(v > 0.5 * band, 1.0, np.where(v < -0.5 * band, -1.0, previous))


def sinamics_apply(tab: SinamicsTable, x, direction=None) -> np.ndarray:
    """What the drive adds (``tab.unit``) at positions ``x`` (rad or m, any turn) with the table of ``direction``
    (+1 forward, −1 reverse, as :func:`select_direction` keeps it; ignored with one table). Zero at a
    non-finite position."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    x0 = np.where(ok, x, 0.0)
    if tab.directions == 1:
        out = _interp(tab.tables["both"], x0, tab.period)
    else:
        d = np.broadcast_to(np.asarray(1.0 if direction is None else direction, float), x0.shape)
        out = np.where(d < 0, _interp(tab.tables["reverse"], x0, tab.period),
                       _interp(tab.tables["forward"], x0, tab.period))
    return np.where(ok, out, 0.0)


def sinamics_script(tab: SinamicsTable, provenance=()) -> str:
    """The parameter-write script: header, ``p5253``, ``p5250.1``, ``p5256`` and the table entries."""
    checks = [
        "turn slowly (or traverse) forward and backward with the compensation on: r5254[1] (table index in use) "
        "must follow the position as entry = position / period x 4096; with two tables it must switch with the "
        "direction",
        "at standstill at a few positions compare r5255[1] with the entries below; a compensation of the wrong sign "
        "doubles the ripple instead of removing it",
    ]
    lines = [header("SINAMICS S120 cogging torque compensation (section 8.15)", [SOURCE], DOCUMENTED, ASSUMED, checks,
                    [*provenance, f"unit: {tab.unit} ({tab.conversion})",
                     f"limit: {tab.limit:.6g} {tab.unit}" if tab.limit is not None else "limit: none",
                     f"period: {tab.period:.9g} {'rad' if tab.kind == 'rotary' else 'm'} (p5253 = {tab.factor:.9g})"])]
    lines.append(f"p5253 = {tab.factor:.9g}\n")
    lines.append(f"p5250.1 = {1 if tab.directions == 2 else 0}\n")
    if tab.hysteresis is not None:
        lines.append(f"p5256 = {tab.hysteresis:.9g}\n")
    names = {"both": "p5260", "forward": "p5260", "reverse": "p5261"}
    for name, v in tab.tables.items():
        lines += [f"{names[name]}[{i}] = {fmt32(x)}\n" for i, x in enumerate(v)]
    return "".join(lines)


def write_sinamics(tab: SinamicsTable, path, provenance=()) -> SinamicsTable:
    """Write the script atomically, read it back (:func:`read_sinamics`) and check it; returns ``tab`` with its
    :class:`~pgcomm.export.drive_common.RoundTrip`."""
    atomic_write_text(path, sinamics_script(tab, provenance))
    back = read_sinamics(path)
    read = np.concatenate([back["p5260"]] + ([back["p5261"]] if tab.directions == 2 else []))
    meant = np.concatenate([tab.meant[k] for k in tab.tables])
    rt = round_trip(read, meant, float32_bound(meant), str(path), tab.unit)
    return replace(tab, round_trip=rt)


_LINE = re.compile(r"^p(\d{4})(?:\[(\d+)\]|\.(\d+))?\s*=\s*(\S+)$")


def read_sinamics(path) -> dict:
    """Read a script of :func:`write_sinamics`: ``{"p5253": f, "p5250.1": b, "p5256": h or None,
    "p5260": (4096,), "p5261": (4096,) or None}``.

    Raises:
        DataError: a malformed line, a missing, repeated or non-finite entry (one line naming file and line).
    """
    src = str(path)
    scalars, arrays = {}, {}
    for lineno, _, m in parameter_lines(path, _LINE, expected="'pNNNN[i] = value'"):
        v = finite_value(src, lineno, m.group(4))
        p = f"p{m.group(1)}"
        if m.group(2) is not None:
            i = int(m.group(2))
            arr = arrays.setdefault(p, {})
            if i >= ENTRIES or i in arr:
                raise DataError(f"{src} line {lineno}: {p}[{i}] is {'repeated' if i in arr else 'beyond 4095'}")
            arr[i] = v
        else:
            scalars[p + (f".{m.group(3)}" if m.group(3) else "")] = v
    out = {"p5253": scalars.get("p5253"), "p5250.1": scalars.get("p5250.1"), "p5256": scalars.get("p5256")}
    for p in ("p5260", "p5261"):
        arr = arrays.get(p)
        if arr is None:
            out[p] = None
            continue
        if len(arr) != ENTRIES:
            missing = next(i for i in range(ENTRIES) if i not in arr)
            raise DataError(f"{src}: {p}[{missing}] missing ({len(arr)} of {ENTRIES} entries)")
        out[p] = f32([arr[i] for i in range(ENTRIES)])  # what the drive holds
    if out["p5260"] is None or out["p5253"] is None:
        raise DataError(f"{src}: no p5260 table or no p5253 (not a SINAMICS script of pgcomm)")
    return out
