"""Compensation tables over one mechanical revolution: reading, periodic resampling, reconstruction error.

The rotary exports (:mod:`pgcomm.export.moteus`, :mod:`pgcomm.export.odrive`,
:mod:`pgcomm.export.angle_lut`) start from one table: the compensating q-axis current
``iq_comp`` (A) to add to the drive's q-current command at ``n`` equally spaced mechanical angles
``θ_j = 2π j / n`` (rad), ``j = 0 .. n−1``, over one revolution starting at encoder angle 0 (what
``pgcomm.rotary``'s model gives with ``table(n)``).

Table file (CSV): optional ``#`` comment lines (provenance, units) anywhere before or between the
rows, a header with the columns ``angle`` (rad, mechanical) and ``iq`` (A) — other columns are
ignored — and one row per angle ``θ_j`` in order, without the repeated end point ``2π``
(:func:`read_angle_table`, :func:`write_angle_table`). A comment line ``# current_limit: 17.5 A`` records the
motor's q-current limit (the motor description's ``current_limit``), which the exports then use by default
(DESIGN: a law's current limit travels with it). A table that is not uniform, does not start
at 0 or does not cover exactly one revolution is refused with one line naming the file and row.

The continuous function a table stands for is its **trigonometric (periodic band-limited)
interpolant** — exact for a table sampled from a Fourier series whose highest order is below
``n/2``, which is what a model on the circle gives. Resampling to a drive's table size
(:func:`resample_periodic`) evaluates that interpolant at the new angles (zero-padding or
truncating the spectrum; harmonics at or above the target's Nyquist order ``m/2`` cannot be
represented and are dropped, which the error report then shows). Each export reconstructs what
the drive will apply between its entries (linear interpolation, zero-order hold, int8 steps ...)
on a fine grid and compares it with the interpolant (:func:`reconstruction_error`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.config import closest_hint

__all__ = [
    "AngleTable", "TableError", "read_angle_table", "write_angle_table", "resample_periodic",
    "periodic_interpolant", "bin_means", "linear_on_grid", "make_table", "reconstruction_error", "fine_grid_size", "ANGLE_TOLERANCE", "MIN_ENTRIES",
    "MAX_ENTRIES", "check_within_limit", "MAX_CURRENT",
]

#: The largest plausible current (A): a motor description's ``current_limit`` is at most this.
MAX_CURRENT = 1e4

#: Largest deviation (rad) of a table's angle from ``2π j / n`` (a table written with 7 significant
#: digits passes; an encoder count of a 16-bit encoder is 1e-4 rad).
ANGLE_TOLERANCE = 1e-6

#: Fewest and most rows of a table file.
MIN_ENTRIES = 8
MAX_ENTRIES = 1 << 20


@dataclass(frozen=True)
class AngleTable:
    """A compensation table over one revolution.

    Attributes:
        iq: ``(n,)`` compensating q current (A) at ``θ_j = 2π j / n``.
        source: where it came from (file name, for headers and messages).
        comments: the ``#`` lines of its file (without ``#``), carried into the exports' provenance.
        current_limit: the motor's q-current limit (A) the table was made for, or ``None`` (not recorded).
    """

    iq: np.ndarray
    source: str = "table"
    comments: tuple = ()
    current_limit: float | None = None

    @property
    def n(self) -> int:
        """Number of entries ``n``."""
        return int(self.iq.shape[0])

    @property
    def angles(self) -> np.ndarray:
        """``(n,)`` mechanical angles ``θ_j = 2π j / n`` (rad)."""
        return 2.0 * math.pi * np.arange(self.n) / self.n


@dataclass(frozen=True)
class TableError:
    """Error (A) of what a drive applies against the table's interpolant, on a fine grid over one revolution.

    Attributes:
        rms: root mean square (A).
        max: largest absolute error (A).
        theta_max: angle (rad) of the largest error.
    """

    rms: float
    max: float
    theta_max: float

    def to_dict(self) -> dict:
        """``{"rms_A", "max_A", "theta_max_rad"}`` for results.json."""
        return {"rms_A": self.rms, "max_A": self.max, "theta_max_rad": self.theta_max}


def _check_values(iq, source) -> np.ndarray:
    a = np.asarray(iq, dtype=np.float64)
    if a.ndim != 1 or not (MIN_ENTRIES <= a.size <= MAX_ENTRIES):
        raise DataError(f"{source}: a compensation table needs {MIN_ENTRIES} to {MAX_ENTRIES} values over one "
                        f"revolution, got shape {a.shape}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise DataError(f"{source}: entry {int(bad[0])} (theta = 2*pi*{int(bad[0])}/{a.size} rad) of the table is "
                        f"{a[bad[0]]}, not a finite current in A")
    return a


def make_table(iq, source: str = "table", comments=(), current_limit: float | None = None) -> AngleTable:
    """An :class:`AngleTable` from ``(n,)`` currents (A) at ``2π j / n`` (e.g. a model's ``table(n)``).

    Args:
        current_limit: the motor's q-current limit (A), recorded in the file, or ``None``.

    Raises:
        DataError: wrong shape, fewer than :data:`MIN_ENTRIES` values, a non-finite value, or a limit that
            is not a positive finite current.
    """
    if current_limit is not None and not (math.isfinite(float(current_limit)) and float(current_limit) > 0):
        raise DataError(f"{source}: current limit {current_limit} is not a positive current in A")
    return AngleTable(_check_values(iq, source), source, tuple(comments),
                      None if current_limit is None else float(current_limit))


#: The comment that records a table's current limit: ``# current_limit: 17.5 A``.
_LIMIT_PREFIX = "current_limit:"


def _limit_from_comment(src: str, lineno: int, text: str) -> float:
    body = text[len(_LIMIT_PREFIX):].strip()
    value = body[:-1].strip() if body.endswith("A") else None
    try:
        limit = float(value) if value is not None else math.nan
    except ValueError:
        limit = math.nan
    if not (math.isfinite(limit) and limit > 0):
        raise DataError(f"{src} line {lineno}: '# {text}' is not a current limit; write '# {_LIMIT_PREFIX} 17.5 A' "
                        "(a positive q-current in A) or leave the line out")
    return limit


def read_angle_table(path) -> AngleTable:
    """Read a table CSV (format in the module docstring).

    Raises:
        DataError: one line naming the file (and line): missing file or columns, a non-number,
            NaN/inf, fewer than :data:`MIN_ENTRIES` rows, angles not ``2π j / n`` within
            :data:`ANGLE_TOLERANCE` (not starting at 0, not uniform, not one revolution, a
            repeated end point ``2π``, degrees instead of radians).
    """
    src = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise DataError(f"{src}: file not found") from None
    except IsADirectoryError:
        raise DataError(f"{src}: is a directory, expected a table CSV") from None
    except UnicodeDecodeError:
        raise DataError(f"{src}: not a UTF-8 text file (expected a CSV with columns angle, iq)") from None
    comments, header, rows, limit = [], None, [], None
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            c = s[1:].strip()
            if c.startswith(_LIMIT_PREFIX):
                limit = _limit_from_comment(src, lineno, c)
            else:
                comments.append(c)
            continue
        cells = [c.strip() for c in s.split(",")]
        if header is None:
            header = cells
            for want, unit in (("angle", "rad"), ("iq", "A")):
                if want not in header:
                    raise DataError(f"{src} line {lineno}: no column '{want}' ({unit}) in the header "
                                    f"{header}{closest_hint(want, header)}; a table has columns angle (rad, "
                                    "mechanical) and iq (A)")
            ia, iiq = header.index("angle"), header.index("iq")
            continue
        if len(cells) != len(header):
            raise DataError(f"{src} line {lineno}: {len(cells)} cells, the header has {len(header)}")
        vals = []
        for j, name in ((ia, "angle"), (iiq, "iq")):
            try:
                v = float(cells[j])
            except ValueError:
                raise DataError(f"{src} line {lineno} column '{name}': '{cells[j]}' is not a number") from None
            if not math.isfinite(v):
                raise DataError(f"{src} line {lineno} column '{name}': {cells[j]} is not a finite number")
            vals.append(v)
        rows.append((lineno, *vals))
    if header is None:
        raise DataError(f"{src}: empty (expected a CSV with columns angle (rad), iq (A))")
    n = len(rows)
    if not MIN_ENTRIES <= n <= MAX_ENTRIES:
        raise DataError(f"{src}: {n} rows; a table over one revolution needs {MIN_ENTRIES} to {MAX_ENTRIES}")
    lines = np.array([r[0] for r in rows])
    ang = np.array([r[1] for r in rows])
    iq = np.array([r[2] for r in rows])
    _check_angles(src, lines, ang)
    return AngleTable(iq, src, tuple(comments), limit)


def _check_angles(src, lines, ang) -> None:
    n = ang.size
    expect = 2.0 * math.pi * np.arange(n) / n
    if abs(ang[0]) > ANGLE_TOLERANCE:
        raise DataError(f"{src} line {lines[0]}: the first angle is {ang[0]:.9g} rad; a table starts at encoder "
                        "angle 0 (theta_j = 2*pi*j/n, j = 0..n-1)")
    d = np.diff(ang)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0))
        raise DataError(f"{src} line {lines[i + 1]}: angle {ang[i + 1]:.9g} rad does not follow {ang[i]:.9g} rad "
                        "(angles must increase)")
    last = ang[-1]
    if abs(last - 2.0 * math.pi) <= 1e-3 * 2.0 * math.pi / n and n > MIN_ENTRIES:
        raise DataError(f"{src} line {lines[-1]}: the last angle {last:.9g} rad repeats angle 0 one revolution later; "
                        "give theta_j = 2*pi*j/n for j = 0..n-1 only (drop the last row)")
    step = last / (n - 1)
    if abs(step * n - 360.0) < 1.0:
        raise DataError(f"{src} column 'angle': the angles run to {last:.6g}, which looks like degrees; the table's "
                        "angle is in rad (multiply by pi/180)")
    off = np.abs(ang - expect)
    if np.max(off) > ANGLE_TOLERANCE:
        i = int(np.argmax(off))
        what = ("not uniformly spaced" if np.max(np.abs(d - d.mean())) > ANGLE_TOLERANCE
                else f"not one revolution (spacing {d.mean():.9g} rad, one revolution in {n} rows needs "
                     f"{2 * math.pi / n:.9g} rad)")
        raise DataError(f"{src} line {lines[i]}: angle {ang[i]:.9g} rad, expected 2*pi*{i}/{n} = {expect[i]:.9g} rad: "
                        f"the table is {what}; a table holds n equally spaced mechanical angles over one revolution "
                        f"(tolerance {ANGLE_TOLERANCE:g} rad)")


def check_within_limit(table: AngleTable, limit: float | None, slack: float = 0.0, limit_source: str = "") -> None:
    """Refuse a table with an entry beyond the current limit: a drive would clip it, and the compensation it
    applies would not be the table's.

    Args:
        table: the compensation table (A).
        limit: the q-current limit (A) the export applies, or ``None`` (turned off): then the largest plausible
            current :data:`MAX_CURRENT`.
        slack: how far (A) an entry may pass the limit unnoticed: half the drive's quantisation step at the limit
            (the step of its stored entries), 0 for a float table.
        limit_source: where the limit comes from (said in the message).

    Raises:
        DataError: one line naming the file, the entry and its angle, the value and the limit.
    """
    bound = MAX_CURRENT if limit is None else float(limit)
    j = int(np.argmax(np.abs(table.iq)))
    v = float(table.iq[j])
    if abs(v) > bound + slack:
        what = (f"the current limit {bound:g} A" + (f" ({limit_source})" if limit_source else "") if limit is not None
                else f"{bound:g} A, the largest plausible current (the limit is turned off)")
        n_over = int(np.count_nonzero(np.abs(table.iq) > bound + slack))
        raise DataError(f"{table.source}: entry {j} (theta = 2*pi*{j}/{table.n} rad) is iq = {v:.6g} A, beyond {what}; "
                        f"{n_over} of {table.n} entries are, and a drive would clip them: give a table within the "
                        "limit (in A), or the motor's own --current-limit")


def write_angle_table(path, table: AngleTable, comments=()) -> Path:
    """Write ``table`` as a table CSV (atomically): ``# comment`` lines, header ``angle,iq``, ``%.17g`` rows.

    ``comments`` (default: the table's own) say where the table came from; units are added, and the
    table's current limit when it has one.
    """
    lines = [f"# {' '.join(str(c).split())}" for c in (comments or table.comments)]
    if table.current_limit is not None:
        lines.append(f"# {_LIMIT_PREFIX} {table.current_limit:.9g} A")
    lines += [f"# angle: mechanical angle theta_j = 2*pi*j/{table.n} (rad) from encoder angle 0; "
              "iq: compensating q-axis current (A) added to the drive's q-current command", "angle,iq"]
    lines += ["%.17g,%.17g" % (a, v) for a, v in zip(table.angles, table.iq)]
    atomic_write_text(path, "\n".join(lines) + "\n")
    return Path(path)


def _spectrum_to(iq, m: int, weight=None) -> np.ndarray:
    """The trigonometric interpolant of ``iq`` (``n`` samples over one period) sampled at ``m`` points.

    ``weight``: optional function of the orders ``h`` (``(n//2 + 1,)`` ints) multiplying each order's
    coefficient first (a shift, a bin average).
    """
    n = iq.size
    c = np.fft.rfft(iq)
    if weight is not None:
        c = c * weight(np.arange(c.size))
    if n % 2 == 0:
        c = c.copy()
        c[-1] *= 0.5  # the Nyquist cosine is shared by +n/2 and -n/2: half of it on each
    out = np.zeros(m // 2 + 1, dtype=complex)
    k = min(c.size, out.size)
    out[:k] = c[:k]
    if m % 2 == 0 and k == out.size:
        out[-1] = 0.0  # downsampling: the order m/2 is not representable on m points (dropped, as documented)
    return np.fft.irfft(out, m) * (m / n)


def resample_periodic(iq, m: int) -> np.ndarray:
    """``(m,)`` values of the table's trigonometric interpolant at ``2π j / m`` (A).

    Exact (to rounding) for a table of a Fourier series with orders below ``min(n, m)/2``; ``m = n``
    returns the table. Orders at or above ``m/2`` are dropped.

    Args:
        iq: ``(n,)`` table values at ``2π j / n``.
        m: target size (>= 2).
    """
    iq = np.asarray(iq, dtype=np.float64)
    if m == iq.size:
        return iq.copy()
    return _spectrum_to(iq, int(m))


def bin_means(iq, m: int) -> np.ndarray:
    """``(m,)`` means (A) of the table's interpolant over the bins ``[2π k/m, 2π (k+1)/m)``.

    The best value (least squares) for a drive that holds one value per bin (zero-order hold): each
    order ``h`` is averaged over the bin exactly (``sinc(h/m)``) and evaluated at the bin centre.
    Orders at or above ``m/2`` are dropped.
    """
    iq = np.asarray(iq, dtype=np.float64)
    return _spectrum_to(iq, int(m), lambda h: np.sinc(h / m) * np.exp(1j * np.pi * h / m))


def periodic_interpolant(iq, points: int) -> np.ndarray:
    """The table's trigonometric interpolant on a fine grid of ``points`` angles ``2π j / points`` (A)."""
    return _spectrum_to(np.asarray(iq, dtype=np.float64), int(points))


def fine_grid_size(n: int, m: int) -> int:
    """Points of the error grid: a multiple of ``2 m`` (the entries and the midpoints between them lie
    on it), at least 8 per entry of the drive table and at least twice the input table's ``n``."""
    factor = 2 * max(8, math.ceil(n / m))
    return m * factor


def reconstruction_error(applied, reference) -> TableError:
    """Compare what a drive applies with the interpolant, both ``(M,)`` on the grid ``2π j / M`` (A)."""
    e = np.asarray(applied, dtype=np.float64) - np.asarray(reference, dtype=np.float64)
    i = int(np.argmax(np.abs(e)))
    return TableError(float(np.sqrt(np.mean(e**2))), float(abs(e[i])), 2.0 * math.pi * i / e.size)


def linear_on_grid(values, points: int) -> np.ndarray:
    """A drive's periodic linear interpolation of ``(m,)`` entries at ``2π j / m``, evaluated at ``2π i / points``."""
    v = np.asarray(values, dtype=np.float64)
    m = v.size
    u = np.arange(points) * (m / points)  # entry coordinate
    k = np.floor(u).astype(np.int64)
    t = u - k
    k %= m
    return v[k] * (1.0 - t) + v[(k + 1) % m] * t
