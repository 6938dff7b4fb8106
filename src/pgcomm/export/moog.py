"""Moog MSD detent torque compensation: ``CON_TCoggAddTab`` (ID 380, 250 values) or the 4000-value table.

From the MSD Servo Drive Device Help (CB40859-001, 11/2020), section 7.3.5 "Detent torque compensation"
(pp. 116-118; the 02/2018 edition has it as 7.3.4, pp. 112-115):

* the compensation is a **feedforward of the q current** (A); two tables: a **small one of 250 elements**,
  read and written through ``P 380[0..251] CON_TCoggAddTab`` (saved with the parameter record), and a **large
  one of 4000 elements**, written offline entry by entry through ``P 440[0] CON_TAB_TabIndex`` and
  ``P 441[0] CON_TAB_TabVal`` (A);
* **rotary** ("fixed" 32-bit mapping): ``index = (inpos / 2^32) · tabsize``, the whole 32-bit position one
  revolution; **linear/absolute** ("variable" mapping): the position maps to the large table through
  ``P 442 CON_TAB_PosStart`` and ``P 443 CON_TAB_PosDelta`` (units of the position source);
* the output (``P 446 CON_TAB_OutVal``) is the feedforward "interpolated using the compensation table";
* in the high speed range the compensation is **faded out linearly** between ``P 447[3] FadeOutStart`` and
  ``P 447[4] FadeOutEnd`` (rpm); ``P 447[2]`` scales the amplitude; ``P 382 CON_TCoggComp > 0`` activates it.

The teach imports the q-current ripple at slow constant speed: the table holds the current to add, pgcomm's
compensation in the drive's sign; one table (the forward/reverse average).

Assumed (not on the pages read): entry ``i`` at ``i / tabsize`` of the revolution from the position source's
zero; for a linear table entry ``i`` at ``PosStart + i · PosDelta`` (pgcomm spans the stroke with entries 0 and
3999), no compensation outside;
linear interpolation; the script's ``P id[index] = value`` lines are pgcomm's listing for the user's parameter
tool, with ``PosStart``/``PosDelta`` in m (convert to the position source's unit).
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

__all__ = ["SIZES", "SOURCE", "MoogTable", "build_moog", "write_moog", "read_moog", "moog_apply", "fade"]

#: The small and the large table.
SIZES = (250, 4000)

SOURCE = Source("Moog MSD Servo Drive Device Help, CB40859-001 (11/2020)",
                "section 7.3.5 Detent torque compensation, table 7.2 and the input mapping (pp. 116-118)",
                "https://manualshive.com/en/manual/moog/msd-servo-drive/1831638?page=117")

DOCUMENTED = (
    "a q-current feedforward (A): small table of 250 values P 380 CON_TCoggAddTab, large table of 4000 values "
    "written offline through P 440 CON_TAB_TabIndex / P 441 CON_TAB_TabVal",
    "rotary: index = (inpos / 2^32) x tabsize, the 32-bit position one revolution; linear/absolute: the large table "
    "through P 442 CON_TAB_PosStart and P 443 CON_TAB_PosDelta (position-source units)",
    "the output P 446 is interpolated from the table; the compensation fades out linearly between P 447[3] "
    "FadeOutStart and P 447[4] FadeOutEnd (rpm); P 382 CON_TCoggComp > 0 activates it",
)

ASSUMED = (
    "entry i at i/tabsize of the revolution from the position source's zero (rotary), at PosStart + i x PosDelta "
    "(linear); positive direction the drive's; linear interpolation; no compensation outside a linear table",
    "the 'P id[index] = value' lines are pgcomm's listing for your parameter tool; PosStart/PosDelta are written in "
    "m: convert them to the position source's unit",
)


def fade(speed, start: float | None, end: float | None) -> np.ndarray:
    """The fade-out factor at ``|speed|`` (rpm): 1 up to ``start``, linear to 0 at ``end``, 0 beyond; 1 without a
    fade-out."""
    s = np.abs(np.asarray(speed, dtype=float))
    if start is None or end is None:
        return np.ones_like(s)
    return np.clip((end - s) / (end - start), 0.0, 1.0)


@dataclass(frozen=True)
class MoogTable:
    """MSD table ready to write.

    Attributes:
        kind: ``"rotary"``/``"linear"``; values: ``(250,)`` or ``(4000,)`` A (float32); meant: before rounding.
        start, delta: PosStart, PosDelta (m) of a linear table, else ``None``.
        fade: ``(FadeOutStart, FadeOutEnd)`` rpm or ``None`` (not written).
    """

    kind: str
    values: np.ndarray
    meant: np.ndarray = field(repr=False)
    start: float | None = None
    delta: float | None = None
    fade: tuple | None = None
    resolution: object = None
    limit: float | None = None
    conversion: str = ""
    round_trip: RoundTrip | None = None

    @property
    def size(self) -> int:
        """250 or 4000."""
        return int(self.values.size)

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"entries": self.size, "unit": "A", "pos_start_m": self.start, "pos_delta_m": self.delta,
                "fade_out_rpm": None if self.fade is None else list(self.fade), "limit_A": self.limit,
                "conversion": self.conversion,
                "resolution": None if self.resolution is None else self.resolution.to_dict(),
                "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
                "source": SOURCE.text(), "assumptions": list(ASSUMED)}


def build_moog(comp, entries: int | None = None, force_constant: float | None = None, fade_out=None) -> MoogTable:
    """The MSD table (A) from ``comp``: 250 or 4000 values (default 4000; a linear motor uses the large table).

    Raises:
        ConfigError: a size the drive does not hold, or the small table for a linear motor.
    """
    n = 4000 if entries is None else int(entries)
    if n not in SIZES:
        raise ConfigError(f"--entries {entries}: the MSD holds a table of 250 (P 380) or 4000 values (P 440/441)")
    if not comp.rotary and n != 4000:
        raise ConfigError("--entries 250: a linear (absolute) position maps only to the 4000-value table on the MSD")
    scale, conversion = unit_factor(comp, "current", None, force_constant, "moog")
    if comp.rotary:
        meant = comp.grid(n) * scale
        start = delta = None
    else:
        start, delta = float(comp.span[0]), comp.length / (n - 1)  # entries 0 and n-1 on the stroke's ends
        meant = comp.values(start + delta * np.arange(n)) * scale
    tab = MoogTable(comp.kind, f32(meant), meant, start, delta, fade_out, None,
                    None if comp.limit is None else comp.limit * scale, conversion)
    xf = comp.span[0] + comp.length * np.arange(n * FINE) / (n * FINE)
    return replace(tab, resolution=error_of(moog_apply(tab, xf), comp.values(xf) * scale, xf))


def moog_apply(tab: MoogTable, x, speed_rpm=0.0) -> np.ndarray:
    """What the drive adds (A) at positions ``x`` (rad any turn, or m) and speed (rpm, for the fade-out); zero at a
    non-finite position and outside a linear table."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    x0 = np.where(ok, x, 0.0)
    f = fade(speed_rpm, *(tab.fade or (None, None)))
    f = np.where(np.isfinite(f), f, 0.0)
    if tab.kind == "rotary":
        return np.where(ok, periodic_linear(tab.values, x0 / (2.0 * math.pi) * tab.size) * f, 0.0)
    u = (x0 - tab.start) / tab.delta
    inside = ok & (u >= 0) & (u <= tab.size - 1)
    uc = np.clip(np.where(inside, u, 0.0), 0, tab.size - 1)
    k = np.minimum(np.floor(uc).astype(np.int64), tab.size - 2)
    t = uc - k
    v = tab.values[k] * (1 - t) + tab.values[k + 1] * t
    return np.where(inside, v * f, 0.0)


def moog_script(tab: MoogTable, provenance=()) -> str:
    """The parameter listing: (linear) PosStart/PosDelta, (fade-out) P 447[3]/[4], then the table."""
    checks = [
        "with the compensation on, turn slowly (or traverse) and watch P 440 (index) and P 446 (output): the output at "
        "a few positions must match the entries below",
        "compare the speed ripple with the compensation on and off: a table of the wrong sign or origin doubles it",
    ]
    lines = [header("Moog MSD detent torque compensation (section 7.3.5)", [SOURCE], DOCUMENTED, ASSUMED, checks,
                    [*provenance, f"unit: A ({tab.conversion})",
                     f"limit: {tab.limit:.6g} A" if tab.limit is not None else "limit: none",
                     "activate afterwards with P 382 CON_TCoggComp > 0 (section 7.3.5.2) and save the parameters"])]
    if tab.kind == "linear":
        lines += [f"P 442[0] = {tab.start:.9g}\n", f"P 443[0] = {tab.delta:.9g}\n"]
    if tab.fade is not None:
        lines += [f"P 447[3] = {tab.fade[0]:.9g}\n", f"P 447[4] = {tab.fade[1]:.9g}\n"]
    if tab.size == 250:
        lines += [f"P 380[{i}] = {fmt32(v)}\n" for i, v in enumerate(tab.values)]
    else:
        for i, v in enumerate(tab.values):
            lines += [f"P 440[0] = {i}\n", f"P 441[0] = {fmt32(v)}\n"]
    return "".join(lines)


def write_moog(tab: MoogTable, path, provenance=()) -> MoogTable:
    """Write the listing atomically, read it back and check it."""
    atomic_write_text(path, moog_script(tab, provenance))
    back = read_moog(path)
    return replace(tab, round_trip=round_trip(back["values"], tab.meant, float32_bound(tab.meant), str(path), "A"))


_P = re.compile(r"^P\s*(\d+)\[(\d+)\]\s*=\s*(\S+)$")


def read_moog(path) -> dict:
    """Read a listing of :func:`write_moog`: ``{"values": (n,) A, "start", "delta", "fade"}``.

    Raises:
        DataError: a malformed line, a value without its index, a repeated or missing entry.
    """
    src = str(path)
    small, big, scal, index = {}, {}, {}, None
    for lineno, _, m in parameter_lines(path, _P, expected="'P id[index] = value'"):
        pid, sub = int(m.group(1)), int(m.group(2))
        v = finite_value(src, lineno, m.group(3))
        if pid == 380:
            if sub >= 250 or sub in small:
                raise DataError(f"{src} line {lineno}: P 380[{sub}] is {'repeated' if sub in small else 'beyond 249'}")
            small[sub] = v
        elif pid == 440:
            index = int(v)
        elif pid == 441:
            if index is None or index in big or not 0 <= index < 4000:
                raise DataError(f"{src} line {lineno}: P 441 value without a new P 440 index in 0..3999 before it")
            big[index], index = v, None
        else:
            scal[(pid, sub)] = v
    table, n = (small, 250) if small else (big, 4000)
    if len(table) != n:
        missing = next(i for i in range(n) if i not in table)
        raise DataError(f"{src}: entry {missing} missing ({len(table)} of {n})")
    fade_ = (scal[(447, 3)], scal[(447, 4)]) if (447, 3) in scal and (447, 4) in scal else None
    return {"values": f32([table[i] for i in range(n)]), "start": scal.get((442, 0)),
            "delta": scal.get((443, 0)), "fade": fade_}
