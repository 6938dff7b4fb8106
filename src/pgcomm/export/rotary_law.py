"""The whole rotary commutation law as C99 (header only, safe for every input): cogging, direction, ripple.

The drives' tables (:mod:`pgcomm.export.moteus`, :mod:`~pgcomm.export.odrive`, :mod:`~pgcomm.export.angle_lut`)
hold one current to *add*, both directions averaged; the identified model also has the direction-dependent
drag and the torque-constant ripple, which a table cannot apply (the ripple *divides* the demand). For a
firmware the user compiles (or a controller in front of a drive that takes a q-current command), ``NAME.h``
holds :func:`pgcomm.rotary.law.iq_command`::

    i_q = (u − c(θ) + d(θ) s) / g(θ)        g = max(1 + r(θ), MIN_GAIN)

``u`` the demand as a current at the mean torque constant ``k0`` (A: the speed or position loop's output),
``θ`` the mechanical angle (rad, any turn), ``s`` the sign of the velocity (0: no direction term). The three
maps are ``static const`` tables at ``θ_j = 2π j / N`` with periodic linear interpolation; the gain is
clamped at :data:`pgcomm.rotary.law.MIN_GAIN` at every entry, so the interpolated divisor is never below it.

``int NAME_iq(T theta, T demand, T s, T *iq)`` (``T`` = ``double`` or ``float``; ``demand`` is ``u``) returns ``0`` = done, ``1`` = the
command was limited to ``± NAME_CURRENT_LIMIT``, ``2`` = a non-finite input (NaN or ±inf in ``theta``,
``demand`` or ``s``) or an overflowing result: the output is **zero current**, as the Python law gives. No dynamic
memory, no global state, only ``<math.h>``, ``<stdint.h>`` and ``<string.h>`` (non-finite tests on the IEEE-754 bits,
which survive ``-ffast-math``). :func:`rotary_law_values` is the same lookup in Python (the tests
compile the header and compare); the comment block and ``results.json`` state each map's interpolation error
and the law's, against the model's Fourier maps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pgcomm.export.angle_lut import c_current_tail, c_entry_coordinate, interpolate_periodic
from pgcomm.export.c_text import DOUBLE, SINGLE, check_c_name, ieee_finite, macro_literal
from pgcomm.rotary.law import MIN_GAIN, iq_command
from pgcomm.rotary.model import RotaryModel
from pgcomm import __version__
from pgcomm.io.atomic import atomic_write_text

__all__ = ["RotaryLawTables", "build_rotary_law", "default_entries", "rotary_law_values", "rotary_law_header",
           "write_rotary_law", "SAMPLES_PER_PERIOD"]

#: Default table entries per period of the model's highest order: linear interpolation then leaves at most
#: ``(2π/16)²/8`` ≈ 1.9 % of that harmonic's amplitude (the highest orders are the smallest).
SAMPLES_PER_PERIOD = 16


@dataclass(frozen=True)
class RotaryLawTables:
    """The law's tables for C, with their errors.

    Attributes:
        cogging, direction, gain: ``(N,)`` entries at ``2π j / N``: ``c`` (A), ``d`` (A), ``max(1 + r, MIN_GAIN)``
            (-); rounded to float32 in single precision.
        precision: ``"double"`` or ``"single"``.
        current_limit: ``|i_q|`` bound (A) or ``None``.
        errors: per map, the interpolated table against the model's map on a fine grid, ``{"rms", "max"}``
            (A, or relative for the gain); ``"law"``: the C law against :func:`pgcomm.rotary.law.iq_command` over
            the fine grid, demands ``u`` in ``{−u0, 0, u0}`` and both directions (A).
        source: the model file.
    """

    cogging: np.ndarray
    direction: np.ndarray
    gain: np.ndarray
    precision: str
    current_limit: float | None
    errors: dict
    source: str

    @property
    def n(self) -> int:
        """Entries ``N``."""
        return int(self.cogging.size)

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"entries": self.n, "precision": self.precision, "current_limit_A": self.current_limit,
                "errors": self.errors, "bytes": 3 * self.n * (8 if self.precision == "double" else 4)}


def default_entries(model: RotaryModel) -> int:
    """Entries for ``model``: the power of two with :data:`SAMPLES_PER_PERIOD` per period of its highest order,
    from 1024 to 65536."""
    top = max([1] + [int(np.max(f.orders, initial=0)) for f in (model.cogging, model.ripple, model.direction)])
    return int(min(1 << 16, max(1024, 1 << math.ceil(math.log2(SAMPLES_PER_PERIOD * top)))))


def rotary_law_values(tables: RotaryLawTables, theta, demand, direction):
    """The header's ``NAME_iq`` in float64 NumPy: ``(codes, currents)`` (A), broadcast over the inputs."""
    th, u, s = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (theta, demand, direction)))
    ok = np.isfinite(th) & np.isfinite(u) & np.isfinite(s)
    th0 = np.where(ok, th, 0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        # the angle coordinate overflows for |theta| near the largest double: zero current, as in C
        ok &= np.isfinite(th0 * (tables.n / (2.0 * math.pi)))
        th0 = np.where(ok, th0, 0.0)
        c, d, g = (interpolate_periodic(v, th0) for v in (tables.cogging, tables.direction, tables.gain))
        iq = (np.where(ok, u, 0.0) - c + d * np.sign(np.where(ok, s, 0.0))) / g
    ok &= np.isfinite(iq)
    iq = np.where(ok, iq, 0.0)
    code = np.where(ok, 0, 2)
    if tables.current_limit is not None:
        lim = tables.current_limit
        hit = ok & (np.abs(iq) > lim)
        iq = np.where(hit, np.sign(iq) * lim, iq)
        code = np.where(hit, 1, code)
    return code, iq


def build_rotary_law(model: RotaryModel, entries: int | None = None, precision: str = "double",
                     current_limit: float | None = None, source: str = "model") -> RotaryLawTables:
    """Sample the model's maps into tables, clamp the gain, measure the errors (module docstring).

    Args:
        model: the identified :class:`RotaryModel` (current units).
        entries: ``N`` (8 to 2^20) or ``None`` for :func:`default_entries`.
        precision: ``"double"`` or ``"single"`` (entries rounded to float32, as the C holds them).
        current_limit: ``|i_q|`` bound (A) or ``None``.
        source: where the model came from (for the comment block).

    Raises:
        ValueError: a bad ``entries``, ``precision`` or ``current_limit``, or a map that is not finite.
    """
    if precision not in ("double", "single"):
        raise ValueError(f"precision {precision!r}: expected 'double' or 'single'")
    n = default_entries(model) if entries is None else entries
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 8 <= n <= 1 << 20:
        raise ValueError(f"entries = {entries!r}: expected an integer from 8 to {1 << 20}")
    if current_limit is not None and not (math.isfinite(current_limit) and current_limit > 0):
        raise ValueError(f"current limit {current_limit!r} must be a positive number of A")
    th = 2.0 * math.pi * np.arange(int(n)) / int(n)
    maps = {"cogging": model.cogging(th), "direction": model.direction(th),
            "gain": np.maximum(model.gain(th), MIN_GAIN)}
    for k, v in maps.items():
        if not np.all(np.isfinite(v)):
            raise ValueError(f"the model's {k} map is not finite")
        if precision == "single":
            maps[k] = v.astype(np.float32).astype(np.float64)
    tables = RotaryLawTables(maps["cogging"], maps["direction"], maps["gain"], precision, current_limit, {}, source)
    fine = 2.0 * math.pi * np.arange(8 * int(n)) / (8 * int(n))
    errors = {}
    for k, truth in (("cogging", model.cogging(fine)), ("direction", model.direction(fine)),
                     ("gain", np.maximum(model.gain(fine), MIN_GAIN))):
        e = interpolate_periodic(maps[k], fine) - truth
        errors[k] = {"rms": float(np.sqrt(np.mean(e**2))), "max": float(np.max(np.abs(e)))}
    u0 = 0.5 * current_limit if current_limit is not None else 1.0
    worst = []
    for u in (-u0, 0.0, u0):
        for s in (-1.0, 1.0):
            _, c_law = rotary_law_values(tables, fine, u, s)
            worst.append(c_law - iq_command(model, u, fine, s, current_limit))
    e = np.concatenate(worst)
    errors["law"] = {"rms": float(np.sqrt(np.mean(e**2))), "max": float(np.max(np.abs(e))), "demand_A": u0}
    return RotaryLawTables(maps["cogging"], maps["direction"], maps["gain"], precision, current_limit, errors, source)


def rotary_law_header(tables: RotaryLawTables, name: str = "pgcomm_rotary_law", limit_source: str | None = None,
                      provenance=()) -> str:
    """Text of ``NAME.h`` (module docstring).

    Args:
        tables: :func:`build_rotary_law`'s result.
        name: C identifier prefix.
        limit_source: where the limit (or its absence) came from, for the comment block.
        provenance: further comment lines (the model file, the command).
    """
    check_c_name(name)
    num = SINGLE if tables.precision == "single" else DOUBLE
    T, lit, fl = num.ctype, num.lit, num.fn("floor")
    U = name.upper()
    guard = f"{U}_H_INCLUDED"
    src = f" ({limit_source})" if limit_source else ""
    limit = f"{tables.current_limit:.6g} A on |iq|{src}" if tables.current_limit is not None else f"none{src}"
    er = tables.errors
    lines = [
        f"{name}.h -- the rotary commutation law, generated by pgcomm {__version__}:",
        "iq = (demand - c(theta) + d(theta) * sign(s)) / g(theta), g = max(1 + r(theta), "
        f"{MIN_GAIN:g}) (pgcomm.rotary.law.iq_command).",
        "demand: u, the torque demand as a current at the mean torque constant k0 (A: the loop's output);",
        "theta: mechanical angle (rad, any turn, from encoder angle 0); s: the velocity (only its sign is used;",
        "0 leaves the drag out); iq: the q-current command (A).",
        f"Tables: {tables.n} entries each of c (A), d (A) and g (-) at theta_j = 2*pi*j/{tables.n}, periodic linear",
        "interpolation. Pass the angle at the middle of the interval the current is held: theta + omega * T / 2.",
        f"Model: {tables.source}. Interpolation vs the model's maps: cogging max {er['cogging']['max']:.3g} A, "
        f"drag max {er['direction']['max']:.3g} A, gain max {er['gain']['max']:.3g};",
        f"the law vs pgcomm's (u = 0, +-{er['law']['demand_A']:.3g} A, both directions): RMS {er['law']['rms']:.3g} A, "
        f"max {er['law']['max']:.3g} A.",
        f"Current limit: {limit}.",
        "Return codes: 0 = done; 1 = the command was limited to the current limit; 2 = a non-finite input",
        "(NaN or inf in theta, demand or s) or an overflowing result: the output is zero current.",
        *[" ".join(str(p).split()) for p in provenance],
    ]

    def table(suffix, values, doc):
        vals = ",\n".join("    " + ", ".join(lit(v) for v in values[i:i + 6]) for i in range(0, values.size, 6))
        return f"/* {doc} at theta_j = 2 pi j / {U}_N */\nstatic const {T} {name}_{suffix}[{U}_N] = {{\n{vals}\n}};\n\n"

    out = ["/*\n", *(f" * {s.replace('*/', '* /')}\n" for s in lines), " */\n",
           f"#ifndef {guard}\n#define {guard}\n\n#include <math.h>\n\n",
           f"#define {U}_N {tables.n}\n",
           f"/* entries per radian: N / (2 pi) */\n#define {U}_PER_RAD {macro_literal(lit(tables.n / (2.0 * math.pi)))}\n"]
    if tables.current_limit is not None:
        out.append(f"#define {U}_CURRENT_LIMIT {macro_literal(lit(tables.current_limit))}\n")
    out += ["\n", table("cog", tables.cogging, "cogging c (A)"), table("drag", tables.direction, "drag d (A)"),
            table("gain", tables.gain, f"gain g = max(1 + r, {MIN_GAIN:g}) (-)"),
            f"static inline int {name}_iq({T} theta, {T} demand, {T} s, {T} *iq)\n{{\n",
            f"    {T} u, t, c, d, g, sg;\n    int k, k1;\n\n",
            "    /* a non-finite demand or direction gives zero current and code 2 */\n",
            "    if (!(isfinite(demand) && isfinite(s))) {\n        *iq = 0;\n        return 2;\n    }\n",
            *c_entry_coordinate(T, U, fl, "iq"),
            f"    k1 = (k + 1) % {U}_N;\n",
            f"    c = {name}_cog[k] * (1 - t) + {name}_cog[k1] * t;\n",
            f"    d = {name}_drag[k] * (1 - t) + {name}_drag[k1] * t;\n",
            f"    g = {name}_gain[k] * (1 - t) + {name}_gain[k1] * t;\n",
            "    sg = (s > 0) ? 1 : ((s < 0) ? -1 : 0);\n",
            "    *iq = (demand - c + d * sg) / g;\n",
            *c_current_tail(U, "iq", tables.current_limit is not None, guard)]
    return ieee_finite("".join(out), name, tables.precision == "single")


def write_rotary_law(tables: RotaryLawTables, path, name: str = "pgcomm_rotary_law", limit_source: str | None = None,
                     provenance=()) -> Path:
    """Write :func:`rotary_law_header` to ``path`` atomically."""
    atomic_write_text(path, rotary_law_header(tables, name, limit_source, provenance))
    return Path(path)
