"""What every drive export shares: cited sources, the file header, units, the read-back check, interpolation.

Each drive module (:mod:`pgcomm.export.sinamics`, :mod:`~pgcomm.export.akd`, :mod:`~pgcomm.export.moog`,
:mod:`~pgcomm.export.beckhoff`, :mod:`~pgcomm.export.summit`, :mod:`~pgcomm.export.ioni`) builds its table
from a :class:`pgcomm.export.compensation.Compensation`, writes it in the loading form its documentation
gives, reads its own file back (:func:`round_trip`) and models what the drive does with it (``apply``).

The header of every file (:func:`header`) has four parts: what the cited documentation fixes, what pgcomm
assumed where the documentation read is silent (sign, origin, phase, syntax), what to check on the first
run, and the sources (document, section, URL).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm import __version__

__all__ = ["Source", "RoundTrip", "round_trip", "header", "f32", "fmt32", "float32_bound", "unit_factor",
           "periodic_linear", "TableError", "error_of", "FINE", "parameter_lines", "finite_value"]

#: Error grid points per table entry for the between-entries error.
FINE = 8


@dataclass(frozen=True)
class Source:
    """A cited document: title, section, address."""

    document: str
    section: str
    url: str

    def text(self) -> str:
        """``document, section, url`` on one line."""
        return f"{self.document}, {self.section}, {self.url}"


@dataclass(frozen=True)
class TableError:
    """Error (drive unit) of what the drive applies against the compensation, on a fine grid."""

    rms: float
    max: float
    where: float

    def to_dict(self) -> dict:
        """``{"rms", "max", "at"}``."""
        return {"rms": self.rms, "max": self.max, "at": self.where}


def error_of(applied, reference, x) -> TableError:
    """:class:`TableError` of ``applied - reference`` (arrays over positions ``x``)."""
    e = np.asarray(applied, float) - np.asarray(reference, float)
    i = int(np.argmax(np.abs(e)))
    return TableError(float(np.sqrt(np.mean(e**2))), float(abs(e[i])), float(np.ravel(x)[i]))


@dataclass(frozen=True)
class RoundTrip:
    """The written file read back by pgcomm's reader, against the entries meant (drive unit).

    Attributes:
        max: largest ``|read − meant|``; rms: its RMS; bound: the drive's own quantisation (float32 rounding,
        int8 step ...) the file must stay within; unit: the drive unit.
    """

    max: float
    rms: float
    bound: float
    unit: str

    def to_dict(self) -> dict:
        """For results.json."""
        return {"max": self.max, "rms": self.rms, "bound": self.bound, "unit": self.unit}

    def line(self) -> str:
        """One printed line."""
        return (f"read back: max {self.max:.3g} {self.unit}, RMS {self.rms:.3g} {self.unit} from the entries meant "
                f"(the drive's quantisation {self.bound:.3g} {self.unit})")


def round_trip(read, meant, bound: float, what: str, unit: str) -> RoundTrip:
    """Compare the entries read back with those meant; refuse (one line) beyond ``bound``.

    Raises:
        DataError: the file differs from the table by more than the drive's quantisation (the export's
            output is then discarded).
    """
    r = np.asarray(read, float).ravel()
    m = np.asarray(meant, float).ravel()
    if r.shape != m.shape:
        raise DataError(f"{what}: read back {r.size} entries, {m.size} written; nothing written")
    e = np.abs(r - m)
    rt = RoundTrip(float(e.max(initial=0.0)), float(np.sqrt(np.mean(e**2))) if e.size else 0.0, float(bound), unit)
    tiny = 1e-30 + 1e-9 * bound
    if not (rt.max <= bound + tiny):
        j = int(np.argmax(e))
        raise DataError(f"{what}: read back, entry {j} differs from the table by {rt.max:.3g} {unit}, more than "
                        f"the drive's quantisation {bound:.3g} {unit}; nothing written")
    return rt


def f32(v) -> np.ndarray:
    """``v`` rounded to float32 (what a REAL32 parameter holds), as float64."""
    return np.asarray(v, dtype=float).astype(np.float32).astype(np.float64)


def fmt32(v: float) -> str:
    """A float32 value in 9 significant digits (reads back exactly)."""
    return "%.9g" % float(np.float32(v))


def float32_bound(values) -> float:
    """Half a float32 ulp of the largest magnitude: the rounding a REAL32 entry may add."""
    v = np.asarray(values, dtype=float)
    return float(np.max(np.abs(v), initial=0.0)) * 2.0**-24


def unit_factor(comp, want: str, torque_constant: float | None, force_constant: float | None,
                drive: str) -> tuple[float, str]:
    """Factor from the compensation's unit (A rotary, N linear) to the drive's, and what it rests on.

    ``want`` is ``"torque"`` (N·m rotary, N linear) or ``"current"`` (A).

    Raises:
        ConfigError: the constant the conversion needs was not given (one line naming the option).
    """
    if comp.rotary:
        if want == "current":
            return 1.0, "A of q current"
        if torque_constant is None:
            raise ConfigError(f"--format {drive} holds N m: give --torque-constant NM_PER_A (the drive's torque "
                              "constant; entry = k_t x iq_comp), or a rotary model file that records k_t")
        return float(torque_constant), f"N m = {torque_constant:g} N m/A x iq_comp"
    if want == "torque":
        return 1.0, "N of force"
    k = force_constant if force_constant is not None else comp.force_constant
    src = "--force-constant" if force_constant is not None else "the drive's k_hat: sum(k_hat^2)/max(k_hat)"
    return 1.0 / float(k), f"A = N / {k:.6g} N/A ({src})"


def periodic_linear(values, u) -> np.ndarray:
    """Linear interpolation of ``(m,)`` entries at entry coordinates ``u`` (any shape), periodic (entry ``m−1``
    blends into entry 0); ``u`` finite."""
    v = np.asarray(values, dtype=float)
    m = v.size
    u = np.mod(np.asarray(u, dtype=float), m)
    k = np.minimum(np.floor(u).astype(np.int64), m - 1)
    t = u - k
    return v[k] * (1.0 - t) + v[(k + 1) % m] * t


def header(title: str, sources, documented, assumed, checks, provenance=(), prefix: str = "# ",
           width: int = 110) -> str:
    """The comment block every drive file starts with (module docstring), each line prefixed."""
    def wrap(text: str, indent: str) -> list[str]:
        words, lines, cur = " ".join(str(text).split()).split(" "), [], ""
        for w in words:
            if cur and len(prefix) + len(indent) + len(cur) + 1 + len(w) > width:
                lines.append(cur)
                cur = w
            else:
                cur = f"{cur} {w}" if cur else w
        lines.append(cur)
        return [indent + lines[0]] + ["    " + s for s in lines[1:]]

    out = [f"{title} -- written by pgcomm {__version__}"]
    for name, items in (("What the documentation fixes:", documented),
                        ("What pgcomm assumed (the documentation read does not say):", assumed),
                        ("Check on the first run:", checks), ("Sources:", [s.text() for s in sources]),
                        ("Input:", provenance)):
        if items:
            out.append(name)
            for it in items:
                out += wrap(it, "  - ")
    return "".join(f"{prefix}{line}".rstrip() + "\n" for line in out)


def parameter_lines(path, *patterns, expected: str | None = None):
    """The parameter lines of a drive's file, as every reader of this package takes them.

    Text after ``#`` is a comment; blank lines are skipped. Each other line is matched against ``patterns`` in
    order, and the first that matches gives ``(lineno, k, match)``: the line's number (1-based), the pattern's index
    and the match (``match.string`` is the line without its comment).

    Args:
        path: the file (named in errors, with the line).
        patterns: compiled regular expressions.
        expected: what a line must look like, e.g. ``"'pNNNN[i] = value'"``: a line that matches no pattern is
            refused with it; ``None``: such lines are skipped (a drive's own dump carries its other settings).

    Yields:
        ``(lineno, k, match)``.

    Raises:
        DataError: ``FILE line N: 'LINE' is not EXPECTED``.
    """
    src = str(path)
    for lineno, raw in enumerate(Path(path).read_text().splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        for k, pattern in enumerate(patterns):
            m = pattern.match(line)
            if m:
                yield lineno, k, m
                break
        else:
            if expected is not None:
                raise DataError(f"{src} line {lineno}: '{line}' is not {expected}")


def finite_value(path, lineno: int, text: str) -> float:
    """``text`` of line ``lineno`` of ``path`` as a finite number.

    Raises:
        DataError: ``FILE line N: 'TEXT' is not a number``, or ``FILE line N: TEXT is not finite``.
    """
    try:
        v = float(text)
    except ValueError:
        raise DataError(f"{path} line {lineno}: '{text}' is not a number") from None
    if not math.isfinite(v):
        raise DataError(f"{path} line {lineno}: {text} is not finite")
    return v


def parse_pair(text: str | None, option: str, unit: str) -> tuple[float, float] | None:
    """``A,B`` (two non-negative numbers, ``A < B``) or ``None``; one line naming the option otherwise."""
    if text is None:
        return None
    try:
        a, b = (float(t) for t in text.split(","))
    except ValueError:
        a = b = math.nan
    if not (math.isfinite(a) and math.isfinite(b) and 0 <= a < b):
        raise ConfigError(f"{option} {text}: expected START,END in {unit} with 0 <= START < END")
    return a, b
