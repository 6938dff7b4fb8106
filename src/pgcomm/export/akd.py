"""Kollmorgen AKD / AKD2G cogging compensation: 8192 feedforward currents, ``COGCOMP.*`` keywords.

From Kollmorgen's web help:

* "Cogging Compensation" (AKD, KAS user manual): the AKD "uses a cogging compensation table that stores the
  feedforward values to apply depending on the motor's position. The table consists of **8192 entries** that
  are **evenly distributed over one revolution** (rotary axis) or **a range that can be specified by the user**
  (linear axis)"; the values are an additional **feedforward current** ("compensation values directly translate
  to current"); ``COGCOMP.EN`` enables it; with a non-absolute feedback the drive applies the table only after
  homing; WorkBench imports/exports the table as CSV (drive disabled);
* ``COGCOMP.TEACH`` (AKD parameter reference): with ``COGCOMP.RANGELOW`` and ``COGCOMP.RANGEHIGH`` both **0**
  the table covers **one turn**; otherwise (linear axes) it covers **RANGELOW ... RANGEHIGH**;
* "Cogging Compensation" (AKD2G user manual): the AKD1G keywords ``COGCOMP.TEACH``, ``.V``, ``.RANGELOW``,
  ``.RANGEHIGH``, ``.CORRECTIONVALUE``, ``.SAVE`` map to ``AXIS#.IL.COGCOMP.TEACH.MOVE``, ``...TEACH.V``,
  ``AXIS#.IL.COMPTABLE.MIN``, ``.MAX``, ``.DATA``, ``.ENABLE``.

The teach records the current the drive needs at each position: the table holds the current to add, pgcomm's
compensation in the drive's sign. One table for both directions (the forward/reverse average).

Assumed (not in the pages read): entry ``i`` at ``i/8192`` of the turn (or of the range) from position 0 (or
from RANGELOW), linear interpolation, no compensation outside the range of a linear axis; the keyword form
``COGCOMP.CORRECTIONVALUE <index> <value in A>`` and a linear position unit of mm (``UNIT.PLINEAR``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from pgcomm.errors import DataError
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

__all__ = ["ENTRIES", "SOURCES", "AkdTable", "build_akd", "write_akd", "read_akd", "akd_apply"]

#: "The table consists of 8192 entries".
ENTRIES = 8192

SOURCES = (
    Source("Kollmorgen AKD web help (KAS user manual)", "Cogging Compensation",
           "https://webhelp.kollmorgen.com/kas3.03/Content/UsersManual/Cogging%20Compensation.htm"),
    Source("Kollmorgen AKD parameter reference", "COGCOMP.TEACH",
           "http://webhelp.kollmorgen.com/AKD/English/Content/CommandParamRefGuide/COGCOMP/COGCOMP.TEACH.htm"),
    Source("Kollmorgen AKD2G user manual", "Cogging Compensation (AKD1G keyword equivalents)",
           "https://webhelp.kollmorgen.com/kas3.07/Content/AKD2G_User_Manual/Cogging_Compensation.htm"),
)

DOCUMENTED = (
    "8192 entries evenly distributed over one revolution (rotary) or over a user range (linear axis)",
    "the entries are feedforward currents added to the current command; COGCOMP.EN enables the table; a "
    "non-absolute feedback applies it only after homing",
    "COGCOMP.RANGELOW = COGCOMP.RANGEHIGH = 0: the table covers one turn; otherwise RANGELOW ... RANGEHIGH",
    "AKD2G: COGCOMP.RANGELOW/RANGEHIGH/CORRECTIONVALUE/SAVE are AXIS#.IL.COMPTABLE.MIN/MAX/DATA/ENABLE",
)

ASSUMED = (
    "entry i at i/8192 of the turn from the drive's position 0 (or of RANGELOW ... RANGEHIGH from RANGELOW), "
    "positive direction the drive's; linear interpolation between entries; no compensation outside a linear range",
    "the keyword form 'COGCOMP.CORRECTIONVALUE <index> <value in A>' (the pages read name the keyword, not its "
    "arguments); WorkBench's CSV import is the other documented way in",
    "linear positions in mm (UNIT.PLINEAR set to mm); convert RANGELOW/RANGEHIGH otherwise",
)


@dataclass(frozen=True)
class AkdTable:
    """AKD table ready to write.

    Attributes:
        kind: ``"rotary"``/``"linear"``; values: ``(8192,)`` A (float32); meant: before rounding.
        low, high: the range (m) of a linear table; ``None`` for rotary (RANGELOW = RANGEHIGH = 0).
        resolution: the drive's interpolation against the compensation on a grid 8 times finer (A).
        limit: bound (A) or ``None``; conversion: what the A rest on.
    """

    kind: str
    values: np.ndarray
    meant: np.ndarray = field(repr=False)
    low: float | None = None
    high: float | None = None
    resolution: object = None
    limit: float | None = None
    conversion: str = ""
    round_trip: RoundTrip | None = None

    @property
    def period(self) -> float:
        """Length (rad or m) the 8192 entries cover."""
        return 2.0 * math.pi if self.kind == "rotary" else float(self.high - self.low)

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"entries": ENTRIES, "unit": "A", "range_m": None if self.low is None else [self.low, self.high],
                "limit_A": self.limit, "conversion": self.conversion,
                "resolution": None if self.resolution is None else self.resolution.to_dict(),
                "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
                "sources": [s.text() for s in SOURCES], "assumptions": list(ASSUMED)}


def build_akd(comp, force_constant: float | None = None) -> AkdTable:
    """The 8192 feedforward currents (A) from ``comp`` (one table: the forward/reverse average).

    A linear table covers the model's stroke (RANGELOW ... RANGEHIGH); its force offset becomes A through the
    drive's force constant (``force_constant`` N/A, default :func:`pgcomm.export.compensation.drive_force_constant`).
    """
    scale, conversion = unit_factor(comp, "current", None, force_constant, "akd")
    x = comp.span[0] + comp.length * np.arange(ENTRIES) / ENTRIES
    meant = (comp.grid(ENTRIES) if comp.rotary else comp.values(x)) * scale
    vals = f32(meant)
    lo, hi = (None, None) if comp.rotary else (float(comp.span[0]), float(comp.span[1]))
    tab = AkdTable(comp.kind, vals, meant, lo, hi, None, None if comp.limit is None else comp.limit * scale,
                   conversion)
    xf = comp.span[0] + comp.length * np.arange(ENTRIES * FINE) / (ENTRIES * FINE)
    return replace(tab, resolution=error_of(akd_apply(tab, xf), comp.values(xf) * scale, xf))


def akd_apply(tab: AkdTable, x) -> np.ndarray:
    """What the drive adds (A) at positions ``x`` (rad any turn, or m); zero at a non-finite position and, for a
    linear table, outside RANGELOW ... RANGEHIGH."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    x0 = np.where(ok, x, 0.0)
    if tab.kind == "rotary":
        return np.where(ok, periodic_linear(tab.values, x0 / (2.0 * math.pi) * ENTRIES), 0.0)
    u = (x0 - tab.low) / tab.period * ENTRIES
    inside = ok & (x0 >= tab.low) & (x0 < tab.high)
    return np.where(inside, periodic_linear(tab.values, np.where(inside, u, 0.0)), 0.0)


def akd_script(tab: AkdTable, provenance=()) -> str:
    """The keyword script: disable, range, 8192 correction values, save, enable."""
    checks = [
        "read back COGCOMP.CORRECTIONVALUE for entries 0, 2048, 4096 and compare with the lines below (syntax "
        "assumed)",
        "turn slowly (or traverse) with the compensation on and off and compare the velocity ripple: a table of the "
        "wrong sign or origin doubles it",
    ]
    lines = [header("Kollmorgen AKD cogging compensation", SOURCES, DOCUMENTED, ASSUMED, checks,
                    [*provenance, f"unit: A ({tab.conversion})",
                     f"limit: {tab.limit:.6g} A" if tab.limit is not None else "limit: none"])]
    lines.append("COGCOMP.EN 0\n")
    if tab.kind == "rotary":
        lines += ["COGCOMP.RANGELOW 0\n", "COGCOMP.RANGEHIGH 0\n"]
    else:
        lines += [f"COGCOMP.RANGELOW {tab.low * 1e3:.9g}\n", f"COGCOMP.RANGEHIGH {tab.high * 1e3:.9g}\n"]
    lines += [f"COGCOMP.CORRECTIONVALUE {i} {fmt32(v)}\n" for i, v in enumerate(tab.values)]
    lines += ["COGCOMP.SAVE\n", "COGCOMP.EN 1\n"]
    return "".join(lines)


def write_akd(tab: AkdTable, path, provenance=()) -> AkdTable:
    """Write the keyword script atomically, read it back and check it (returns ``tab`` with its round trip)."""
    atomic_write_text(path, akd_script(tab, provenance))
    back = read_akd(path)
    return replace(tab, round_trip=round_trip(back["values"], tab.meant, float32_bound(tab.meant), str(path), "A"))


_CV = re.compile(r"^COGCOMP\.CORRECTIONVALUE\s+(\d+)\s+(\S+)$")
_RANGE = re.compile(r"^COGCOMP\.RANGE(LOW|HIGH)\s+(\S+)$")


def read_akd(path) -> dict:
    """Read a script of :func:`write_akd`: ``{"values": (8192,) A, "low": mm, "high": mm}``.

    Raises:
        DataError: a repeated, missing, out-of-range or non-finite entry (one line naming file and line).
    """
    src = str(path)
    vals, rng = {}, {}
    for lineno, k, m in parameter_lines(path, _CV, _RANGE):
        v = finite_value(src, lineno, m.group(2))
        if k == 1:
            rng[m.group(1).lower()] = v
            continue
        i = int(m.group(1))
        if i >= ENTRIES or i in vals:
            raise DataError(f"{src} line {lineno}: entry {i} is {'repeated' if i in vals else 'beyond 8191'}")
        vals[i] = v
    if len(vals) != ENTRIES:
        missing = next(i for i in range(ENTRIES) if i not in vals)
        raise DataError(f"{src}: COGCOMP.CORRECTIONVALUE {missing} missing ({len(vals)} of {ENTRIES} entries)")
    return {"values": f32([vals[i] for i in range(ENTRIES)]), "low": rng.get("low"), "high": rng.get("high")}
