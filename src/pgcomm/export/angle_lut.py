"""C99 lookup of a compensation table indexed by the mechanical angle (header only, safe for every input).

For a drive whose firmware the user compiles (or a controller in front of any drive that takes
a q-current command): ``NAME.h`` holds the table as ``static const`` entries at ``θ_j = 2π j / N``
(rad, mechanical, from encoder angle 0) and two reentrant functions (``T`` = ``double`` or
``float``):

* ``int NAME_comp(T theta, T *iq_comp)`` — the compensating q current (A) at ``theta`` (rad, any
  turn: reduced modulo one revolution), periodic linear interpolation between entries (entry
  ``N−1`` blends into entry 0);
* ``int NAME_iq(T theta, T iq_star, T *iq)`` — the q-current command ``iq_star + iq_comp`` (A),
  limited to ``± NAME_CURRENT_LIMIT`` when the header has a limit.

Return codes: ``0`` = done; ``1`` = the command was limited to the current limit (``NAME_iq``);
``2`` = a non-finite input (NaN or ±inf in ``theta`` or ``iq_star``) or a result that would overflow:
the output is **zero current**. No dynamic memory, no global state, only ``<math.h>``,
``<stdint.h>`` and ``<string.h>`` (the non-finite tests read the IEEE-754 bits: they survive ``-ffast-math``).

The angle's resolution is that of ``theta``: in single precision a multi-turn angle of ``R``
revolutions is resolved to about ``R·4e-7`` rad, so pass the angle within a few turns there.
The comment block states units, size, the current limit and its source, the input table and the
reconstruction error. :func:`angle_lut_values` is the same lookup in Python (the tests compile
the header and compare).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.export.angle_table import (
    AngleTable,
    TableError,
    fine_grid_size,
    linear_on_grid,
    periodic_interpolant,
    reconstruction_error,
    resample_periodic,
)
from pgcomm import __version__
from pgcomm.export.c_text import DOUBLE, SINGLE, check_c_name, ieee_finite, macro_literal
from pgcomm.io.atomic import atomic_write_text

__all__ = ["AngleLut", "build_angle_lut", "angle_lut_header", "write_angle_lut", "angle_lut_values",
           "interpolate_periodic", "c_entry_coordinate", "c_limit", "c_current_tail"]


@dataclass(frozen=True)
class AngleLut:
    """The table for C, with its error.

    Attributes:
        values: ``(N,)`` entries (A) at ``2π j / N`` (rounded to float32 in single precision).
        precision: ``"double"`` or ``"single"``.
        current_limit: limit (A) on the command of ``NAME_iq`` (and on every entry), or ``None``.
        error: linear interpolation of the entries vs the input table's interpolant (A).
        clipped: entries limited to ``± current_limit``.
        source: the input table (file name).
    """

    values: np.ndarray
    precision: str
    current_limit: float | None
    error: TableError
    clipped: int
    source: str

    @property
    def n(self) -> int:
        """Entries ``N``."""
        return int(self.values.size)

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"entries": self.n, "precision": self.precision, "current_limit_A": self.current_limit,
                "error": self.error.to_dict(), "clipped_entries": self.clipped,
                "bytes": self.n * (8 if self.precision == "double" else 4)}


def build_angle_lut(table: AngleTable, entries: int | None = None, precision: str = "double",
                    current_limit: float | None = None) -> AngleLut:
    """Resample ``table`` to ``entries`` (default: its own size), clip to the limit, measure the error.

    Args:
        table: compensation table (A over one revolution).
        entries: ``N`` (>= 8), or ``None`` for ``table.n``.
        precision: ``"double"`` or ``"single"`` (entries rounded to float32, as the C holds them).
        current_limit: limit (A) or ``None``.

    Raises:
        ValueError: a bad ``entries``, ``precision`` or ``current_limit``.
    """
    if precision not in ("double", "single"):
        raise ValueError(f"precision {precision!r}: expected 'double' or 'single'")
    m = table.n if entries is None else entries
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or not 8 <= m <= 1 << 20:
        raise ValueError(f"entries = {entries!r}: expected an integer from 8 to {1 << 20}")
    if current_limit is not None and not (math.isfinite(current_limit) and current_limit > 0):
        raise ValueError(f"current limit {current_limit!r} must be a positive number of A")
    g = resample_periodic(table.iq, int(m))
    clipped = 0
    if current_limit is not None:
        clipped = int(np.count_nonzero(np.abs(g) > current_limit))
        g = np.clip(g, -current_limit, current_limit)
    if precision == "single":
        g = g.astype(np.float32).astype(np.float64)
    points = fine_grid_size(table.n, int(m))
    err = reconstruction_error(linear_on_grid(g, points), periodic_interpolant(table.iq, points))
    return AngleLut(g, precision, current_limit, err, clipped, table.source)


def interpolate_periodic(values: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Periodic linear interpolation of ``values`` (``(N,)``, at ``θ_j = 2π j / N``) at finite angles ``theta``
    (rad, any shape), as the generated C computes it (:func:`c_entry_coordinate`)."""
    n = values.size
    u = np.asarray(theta, dtype=np.float64) * (n / (2.0 * math.pi))
    u = u - n * np.floor(u / n)
    u = np.where((u >= 0) & (u < n), u, 0.0)
    k = np.minimum(np.floor(u).astype(np.int64), n - 1)
    t = u - k
    return values[k] * (1.0 - t) + values[(k + 1) % n] * t


def c_entry_coordinate(T: str, U: str, fl: str, out: str) -> list[str]:
    """C statements that turn ``theta`` into the entry ``k`` and the fraction ``t`` of a table of ``U_N`` entries
    (``U_PER_RAD`` per radian), reduced modulo one revolution; a non-finite ``theta`` or coordinate sets ``*out``
    to zero and returns 2. Declares nothing: the function has ``T u, t; int k;``."""
    return ["    /* a non-finite angle gives zero current and code 2 */\n",
            f"    if (!isfinite(theta)) {{\n        *{out} = 0;\n        return 2;\n    }}\n",
            f"    u = theta * {U}_PER_RAD;\n",
            f"    if (!isfinite(u)) {{\n        *{out} = 0;\n        return 2;\n    }}\n",
            "    /* entry coordinate in [0, N]; N itself only by rounding, read as entry 0 */\n",
            f"    u = u - ({T}){U}_N * {fl}(u / ({T}){U}_N);\n",
            f"    if (!(u >= 0) || u >= ({T}){U}_N)\n        u = 0;\n",
            f"    k = (int)u;\n    if (k > {U}_N - 1)\n        k = {U}_N - 1;\n",
            f"    t = u - ({T})k;\n"]


def c_limit(U: str, out: str) -> list[str]:
    """C statements that clip ``*out`` to ``± U_CURRENT_LIMIT`` and return 1 when they do."""
    return [f"    if (*{out} > {U}_CURRENT_LIMIT) {{\n        *{out} = {U}_CURRENT_LIMIT;\n        return 1;\n    }}\n",
            f"    if (*{out} < -{U}_CURRENT_LIMIT) {{\n        *{out} = -{U}_CURRENT_LIMIT;\n        return 1;\n    }}\n"]


def c_current_tail(U: str, out: str, limited: bool, guard: str) -> list[str]:
    """The end of a law function and of its header: zero current and code 2 for a non-finite ``*out``, the clip
    to the limit (:func:`c_limit`) when ``limited``, ``return 0``, and the include guard's ``#endif``."""
    return ([f"    if (!isfinite(*{out})) {{\n        *{out} = 0;\n        return 2;\n    }}\n"]
            + (c_limit(U, out) if limited else [])
            + ["    return 0;\n}\n\n", f"#endif /* {guard} */\n"])


def angle_lut_values(lut: AngleLut, theta, iq_star=None):
    """The header's lookup in float64 NumPy: ``(codes, currents)`` for angles ``theta`` (rad).

    ``iq_star=None``: ``NAME_comp`` (codes 0/2); else ``NAME_iq`` with the command ``iq_star`` (A).
    """
    th = np.asarray(theta, dtype=np.float64)
    ok = np.isfinite(th)
    c = interpolate_periodic(lut.values, np.where(ok, th, 0.0))
    if iq_star is None:
        return np.where(ok, 0, 2), np.where(ok, c, 0.0)
    s = np.asarray(iq_star, dtype=np.float64)
    ok = ok & np.isfinite(s)
    out = np.where(ok, np.where(np.isfinite(s), s, 0.0) + c, 0.0)
    code = np.where(ok, 0, 2)
    if lut.current_limit is not None:
        lim = lut.current_limit
        hit = ok & (np.abs(out) > lim)
        out = np.where(hit, np.sign(out) * lim, out)
        code = np.where(hit, 1, code)
    return code, out


def angle_lut_header(lut: AngleLut, name: str = "pgcomm_angle_lut", limit_source: str | None = None,
                     provenance=()) -> str:
    """Text of ``NAME.h`` (format in the module docstring).

    Args:
        lut: the table (:func:`build_angle_lut`).
        name: C identifier prefix.
        limit_source: where the limit (or its absence) came from, for the comment block.
        provenance: further comment lines (the input table's own ``#`` lines, the command).
    """
    check_c_name(name)
    num = SINGLE if lut.precision == "single" else DOUBLE
    T, lit, fl = num.ctype, num.lit, num.fn("floor")
    U = name.upper()
    guard = f"{U}_H_INCLUDED"
    src = f" ({limit_source})" if limit_source else ""
    limit = f"{lut.current_limit:.6g} A on the q-current command of {name}_iq{src}" if lut.current_limit is not None \
        else f"none{src}"
    e = lut.error
    lines = [
        f"{name}.h -- compensating q current indexed by the mechanical angle, generated by pgcomm {__version__}.",
        f"Table: {lut.n} entries iq_comp (A) at theta_j = 2*pi*j/{lut.n} rad (mechanical, from encoder angle 0),",
        "periodic linear interpolation; theta in rad, any turn (reduced modulo one revolution).",
        "Pass the angle at the middle of the interval the current is held: theta + omega * T / 2 (omega the",
        "velocity in rad/s, T the current reference's update period); at the sampled angle the compensation",
        "lags half a period (2 sin(pi/N) of a harmonic with N updates per period is left).",
        f"Input: {lut.source}; reconstruction error vs the input table's interpolant: RMS {e.rms:.3g} A, "
        f"max {e.max:.3g} A.",
        f"Current limit: {limit}.",
        "Return codes: 0 = done; 1 = the command was limited to the current limit; 2 = a non-finite input",
        "(NaN or inf in theta or iq_star) or an overflowing result: the output is zero current.",
        *[" ".join(str(p).split()) for p in provenance],
    ]
    vals = ",\n".join("    " + ", ".join(lit(v) for v in lut.values[i:i + 6]) for i in range(0, lut.n, 6))
    two_pi = 2.0 * math.pi
    out = ["/*\n", *(f" * {s.replace('*/', '* /')}\n" for s in lines), " */\n",
           f"#ifndef {guard}\n#define {guard}\n\n#include <math.h>\n\n",
           f"#define {U}_N {lut.n}\n",
           f"/* entries per radian: N / (2 pi) */\n#define {U}_PER_RAD {macro_literal(lit(lut.n / two_pi))}\n"]
    if lut.current_limit is not None:
        out.append(f"#define {U}_CURRENT_LIMIT {macro_literal(lit(lut.current_limit))}\n")
    out += [f"\n/* iq_comp (A) at theta_j = 2 pi j / {U}_N */\n",
            f"static const {T} {name}_table[{U}_N] = {{\n{vals}\n}};\n\n",
            f"static inline int {name}_comp({T} theta, {T} *iq_comp)\n{{\n",
            f"    {T} u, t;\n    int k;\n\n",
            *c_entry_coordinate(T, U, fl, "iq_comp"),
            f"    *iq_comp = {name}_table[k] * (1 - t) + {name}_table[(k + 1) % {U}_N] * t;\n",
            "    return 0;\n}\n\n",
            f"static inline int {name}_iq({T} theta, {T} iq_star, {T} *iq)\n{{\n",
            f"    {T} c;\n\n",
            "    if (!(isfinite(theta) && isfinite(iq_star)) || " + f"{name}_comp(theta, &c) != 0) {{\n",
            "        *iq = 0;\n        return 2;\n    }\n",
            "    *iq = iq_star + c;\n",
            *c_current_tail(U, "iq", lut.current_limit is not None, guard)]
    return ieee_finite("".join(out), name, lut.precision == "single")


def write_angle_lut(lut: AngleLut, path, name: str = "pgcomm_angle_lut", limit_source: str | None = None,
                    provenance=()) -> Path:
    """Write :func:`angle_lut_header` to ``path`` atomically."""
    atomic_write_text(path, angle_lut_header(lut, name, limit_source, provenance))
    return Path(path)
