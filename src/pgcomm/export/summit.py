"""Novanta Summit cogging compensation: a table indexed by the **electrical** angle, 0x2307 / 0x2308.

From the Novanta drives documentation, Summit, "Cogging compensation": the compensation "is a LUT (look-up
table) that uses the **electrical angle** as a selector of the index"; the table's value "is injected as an
offset in the torque loop output, and its unit is **Amperes**"; ``0x2306`` enables or disables it, ``0x2307``
(index) and ``0x2308`` (value) fill it, and a "store all" keeps it. The same documentation's "Absolute feedback
compensation" LUT (2048 values) puts value ``k`` at full effect in the middle of its bin and interpolates
linearly between bins.

A table over one electrical revolution repeats ``p`` times per mechanical revolution: it can hold only the
orders that are multiples of the pole-pair number ``p`` (the ideal cogging at ``LCM(Q, 2p)`` is one of them;
the orders from magnet and stator tolerances are not). pgcomm writes, for entry ``k``, the mean of the
compensation over the ``p`` mechanical angles with that electrical angle: the best table of this form.

Assumed (not on the page read): the table's length (pgcomm asks for it: ``--entries``), the electrical angle
``p θ`` (its zero at the encoder's zero, i.e. the drive's commutation offset zero), entry ``k`` at the middle of
its bin ``2π (k + ½) / N`` with linear interpolation as the absolute-feedback LUT, ``0x2306 = 1`` to enable.
One table (the forward/reverse average).
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

__all__ = ["MAX_ENTRIES", "SOURCES", "SummitTable", "build_summit", "write_summit", "read_summit", "summit_apply"]

#: Largest ``--entries`` accepted (a 16-bit index register, assumed).
MAX_ENTRIES = 65536

SOURCES = (
    Source("Novanta drives documentation, Summit", "Cogging compensation",
           "https://drives.novantamotion.com/summit/cogging-compensation"),
    Source("Novanta drives documentation, Summit", "Absolute feedback compensation (LUT bins and interpolation)",
           "https://drives.novantamotion.com/summit/absolute-feedback-compensation"),
)

DOCUMENTED = (
    "a look-up table indexed by the electrical angle; its value (A) is added to the torque loop's output",
    "0x2306 enables/disables it; 0x2307 selects the index and 0x2308 writes the value there; 'store all' keeps it",
)

ASSUMED = (
    "the table length (given with --entries; the page read does not state it) and a 16-bit index",
    "electrical angle = pole pairs x mechanical angle from the encoder's zero (the commutation offset's zero); "
    "positive direction the drive's",
    "entry k at the middle of its bin, electrical angle 2 pi (k + 1/2) / N, linear interpolation between bins (as the "
    "drive's documented absolute-feedback LUT); 0x2306 = 1 enables",
)


@dataclass(frozen=True)
class SummitTable:
    """Summit table ready to write: ``values`` ``(N,)`` A (float32) over one electrical revolution.

    Attributes:
        pole_pairs: ``p``; meant: values before rounding; resolution: what the drive applies against the
            compensation over one mechanical revolution (A): the orders that are not multiples of ``p`` are in it.
    """

    values: np.ndarray
    meant: np.ndarray = field(repr=False)
    pole_pairs: int = 1
    resolution: object = None
    limit: float | None = None
    round_trip: RoundTrip | None = None

    @property
    def n(self) -> int:
        """Entries ``N``."""
        return int(self.values.size)

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"entries": self.n, "unit": "A", "pole_pairs": self.pole_pairs, "limit_A": self.limit,
                "resolution": None if self.resolution is None else self.resolution.to_dict(),
                "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
                "sources": [s.text() for s in SOURCES], "assumptions": list(ASSUMED)}


def build_summit(comp, entries: int | None, pole_pairs: int | None = None) -> SummitTable:
    """The electrical-angle table (A) from a rotary ``comp``.

    Raises:
        ConfigError: no ``entries``, a size beyond :data:`MAX_ENTRIES`, or no pole-pair number.
    """
    unit_factor(comp, "current", None, None, "summit")
    if entries is None:
        raise ConfigError("--format summit needs --entries N, the length of the drive's cogging table (0x2307's index "
                          "range; the documentation read does not state it)")
    n = int(entries)
    if not 8 <= n <= MAX_ENTRIES:
        raise ConfigError(f"--entries {entries}: a Summit table of 8 to {MAX_ENTRIES} entries (16-bit index)")
    p = pole_pairs if pole_pairs is not None else comp.pole_pairs
    if p is None:
        raise ConfigError("--format summit indexes by the electrical angle: give --pole-pairs P (a table file does "
                          "not record them)")
    k = np.arange(n)
    theta = 2.0 * math.pi * ((k[None, :] + 0.5) / n + np.arange(p)[:, None]) / p
    meant = comp.values(theta).mean(axis=0)
    tab = SummitTable(f32(meant), meant, int(p), None, comp.limit)
    xf = 2.0 * math.pi * np.arange(n * p * FINE) / (n * p * FINE)
    return replace(tab, resolution=error_of(summit_apply(tab, xf), comp.values(xf), xf))


def summit_apply(tab: SummitTable, x) -> np.ndarray:
    """What the drive adds (A) at mechanical angles ``x`` (rad, any turn); zero at a non-finite angle."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    theta_e = np.mod(tab.pole_pairs * np.where(ok, x, 0.0), 2.0 * math.pi)
    return np.where(ok, periodic_linear(tab.values, theta_e / (2.0 * math.pi) * tab.n - 0.5), 0.0)


def summit_list(tab: SummitTable, provenance=()) -> str:
    """The register list: disable, N index/value pairs, enable."""
    checks = [
        "read 0x2308 back at a few indices after writing (0x2307 = k) and compare",
        "turn slowly with 0x2306 = 1 and = 0 and compare the velocity ripple; if it grows, the electrical angle's zero "
        "or the table's length differs from the assumptions above",
        "perform 'store all' to keep the table",
    ]
    lines = [header("Novanta Summit cogging compensation (register list)", SOURCES, DOCUMENTED, ASSUMED, checks,
                    [*provenance, f"pole pairs: {tab.pole_pairs}; unit: A",
                     f"limit: {tab.limit:.6g} A" if tab.limit is not None else "limit: none"])]
    lines.append("0x2306 = 0\n")
    for i, v in enumerate(tab.values):
        lines += [f"0x2307 = {i}\n", f"0x2308 = {fmt32(v)}\n"]
    lines.append("0x2306 = 1\n")
    return "".join(lines)


def write_summit(tab: SummitTable, path, provenance=()) -> SummitTable:
    """Write the list atomically, read it back and check it."""
    atomic_write_text(path, summit_list(tab, provenance))
    back = read_summit(path)
    return replace(tab, round_trip=round_trip(back, tab.meant, float32_bound(tab.meant), str(path), "A"))


_R = re.compile(r"^0x(2306|2307|2308)\s*=\s*(\S+)$")


def read_summit(path) -> np.ndarray:
    """Read a list of :func:`write_summit`: ``(N,)`` values (A) in index order.

    Raises:
        DataError: a value without an index before it, a repeated index, a gap, a non-finite value.
    """
    src = str(path)
    vals, index = {}, None
    for lineno, _, m in parameter_lines(path, _R, expected="'0x230N = value'"):
        v = finite_value(src, lineno, m.group(2))
        if m.group(1) == "2307":
            index = int(v)
        elif m.group(1) == "2308":
            if index is None or index in vals:
                raise DataError(f"{src} line {lineno}: a value without a new 0x2307 index before it")
            vals[index], index = v, None
    n = len(vals)
    if n == 0 or sorted(vals) != list(range(n)):
        raise DataError(f"{src}: the indices written are not 0 .. N-1")
    return f32([vals[i] for i in range(n)])
