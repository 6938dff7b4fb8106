"""Beckhoff AX8000 cogging compensation: object 0x32CB, up to 10 harmonics ``(n, phi, r)`` and a gain.

From the Beckhoff Information System, AX8000 object description (ax8xxx_object):

* ``32CB:x SynchronousMotor cogging compensation`` (36 subindices): ``32CB:01`` control (ENUM:
  0 encoder memory if available, 1 encoder memory, 2 drive memory, **3 start-up list**, 4 off), ``32CB:02``
  gain (REAL32, 0.0 ... 2.0, default 1.0), ``32CB:03..06`` status, and **10 coefficient sets**
  ``Coef k n`` (UINT32, 0 ... 200), ``Coef k phi`` (REAL32, 0.0 ... 360.0 **°**), ``Coef k r`` (REAL32, >= 0,
  **N·m**) at subindices ``07 + 3k``, ``08 + 3k``, ``09 + 3k``, ``k = 0 .. 9``; channel B is ``0x36CB``;
* ``3241:0C Cogging compensation torque demand value`` (REAL32, torque/force): the compensation in use;
* ``32D3:x LinearMotor cogging compensation parameter``: ``32D3:01`` control (ENUM: 0 off, **1 on**) and a
  connected TcCOM object (``32D3:07`` Id, ``32D3:08`` Version) that holds a linear motor's compensation; the
  object description gives no table format for it.

The description of every coefficient reads "ToDo": the formula is not documented. Assumed: the drive adds
``gain · Σ_k r_k cos(n_k θ + phi_k)`` to its torque setpoint, ``θ`` the motor's mechanical angle from the
encoder's zero (``n`` per revolution), so a harmonic ``a cos nθ + b sin nθ`` of the compensation is
``r = √(a² + b²)``, ``phi = atan2(−b, a)``. For a linear motor pgcomm writes the same form over one pole-pair
pitch (``n`` per pitch, ``r`` in N) for the connected object, to be entered by hand. One table (the
forward/reverse average); harmonics with ``n > 200`` cannot be held and are dropped. Where the harmonics kept
could add up beyond the limit (``Σ r`` above it) they are scaled down together so no angle exceeds it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.export.compensation import fourier_coefficients
from pgcomm.export.drive_common import RoundTrip, Source, error_of, f32, header, parameter_lines, round_trip, \
    unit_factor
from pgcomm.io.atomic import atomic_write_text

__all__ = ["MAX_HARMONICS", "MAX_ORDER", "SOURCES", "BeckhoffTable", "build_beckhoff", "write_beckhoff",
           "read_beckhoff", "beckhoff_apply", "harmonic_sum"]

#: Coefficient sets ``Coef 0 .. Coef 9``.
MAX_HARMONICS = 10

#: ``Coef k n``: UINT32, 0 ... 200.
MAX_ORDER = 200

#: Samples per period for the harmonic analysis.
SAMPLES = 8192

SOURCES = (
    Source("Beckhoff Information System, AX8000 object description", "32CB:x SynchronousMotor cogging compensation",
           "https://infosys.beckhoff.com/content/1033/ax8xxx_object/18801490571.html"),
    Source("Beckhoff Information System, AX8000 object description", "32CB:08 Cogging compensation Coef 0 phi",
           "https://infosys.beckhoff.com/content/1033/ax8xxx_object/18801503115.html"),
    Source("Beckhoff Information System, AX8000 object description", "32CB:09 Cogging compensation Coef 0 r",
           "https://infosys.beckhoff.com/content/1033/ax8xxx_object/11606416779.html"),
    Source("Beckhoff Information System, AX8000 object description", "32D3:x LinearMotor cogging compensation "
           "parameter", "https://infosys.beckhoff.com/content/1031/ax8xxx_object/18801882123.html"),
)

DOCUMENTED = (
    "0x32CB (channel B 0x36CB): :01 control (3 = start-up list parameters, 4 = off), :02 gain REAL32 0..2 "
    "(default 1), 10 coefficient sets n UINT32 0..200, phi REAL32 0..360 deg, r REAL32 >= 0 N m at subindices "
    "07+3k, 08+3k, 09+3k",
    "3241:0C shows the compensation torque/force in use",
    "0x32D3 (linear motors): :01 control (1 = on) and a connected TcCOM object (:07 Id, :08 Version) holding the "
    "compensation; its parameters are not in the object description",
)

ASSUMED = (
    "the drive adds gain x sum r_k cos(n_k theta + phi_k) to the torque setpoint, theta the mechanical angle from "
    "the encoder's zero, n per revolution, phi in degrees (the coefficients' descriptions read 'ToDo')",
    "linear motor: the same form over one pole-pair pitch (n per pitch, r in N), entered by hand into the object "
    "connected to 0x32D3",
)


def harmonic_sum(orders, phi_deg, r, x, period: float) -> np.ndarray:
    """``Σ r_k cos(n_k 2π x/period + phi_k)`` at positions ``x`` (any shape)."""
    x = np.asarray(x, dtype=float)
    th = 2.0 * math.pi * np.mod(x, period) / period
    out = np.zeros(x.shape)
    for n, p, a in zip(orders, phi_deg, r):
        out = out + a * np.cos(n * th + math.radians(p))
    return out


@dataclass(frozen=True)
class BeckhoffTable:
    """AX8000 coefficients ready to write.

    Attributes:
        kind: ``"rotary"``/``"linear"``; unit: ``"N m"``/``"N"``; period: one revolution (2π rad) or one
            pole-pair pitch (m).
        orders, phi, r: ``(K,)`` harmonics kept (``n`` int, ``phi`` ° float32, ``r`` float32), ``K <= 10``.
        meant: ``(orders, phi, r)`` before rounding; gain: ``32CB:02``.
        dropped: RMS (unit) of the harmonics not kept (beyond 200 or beyond the K largest).
        resolution: the sum against the compensation on the model's span (unit).
    """

    kind: str
    unit: str
    period: float
    orders: np.ndarray
    phi: np.ndarray
    r: np.ndarray
    meant: tuple
    gain: float = 1.0
    dropped: float = 0.0
    resolution: object = None
    limit: float | None = None
    conversion: str = ""
    round_trip: RoundTrip | None = None

    def to_dict(self) -> dict:
        """Figures for results.json."""
        return {"harmonics": [{"n": int(n), "phi_deg": float(p), "r": float(a)}
                              for n, p, a in zip(self.orders, self.phi, self.r)],
                "unit": self.unit, "period": self.period, "gain": self.gain, "dropped_rms": self.dropped,
                "limit": self.limit, "conversion": self.conversion,
                "resolution": None if self.resolution is None else self.resolution.to_dict(),
                "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
                "sources": [s.text() for s in SOURCES], "assumptions": list(ASSUMED)}


def _profile(comp, scale):
    """``(period, samples over one period)``: rotary one revolution; linear the mean over the stroke's whole
    pole-pair pitches."""
    if comp.rotary:
        return 2.0 * math.pi, comp.grid(SAMPLES) * scale
    d = comp.pole_pitch
    k = int(math.floor(comp.length / d * (1 + 1e-12)))
    if k < 1:
        raise ConfigError(f"{comp.source}: the model's stroke {comp.length:g} m is shorter than one pole-pair pitch "
                          f"{d:g} m; the harmonics per pitch need at least one")
    x = comp.span[0] + d * np.arange(k * SAMPLES) / SAMPLES
    return d, (comp.values(x) * scale).reshape(k, SAMPLES).mean(axis=0)


def build_beckhoff(comp, torque_constant: float | None = None, harmonics: int | None = None) -> BeckhoffTable:
    """The ``K`` largest harmonics (``n <= 200``) of ``comp`` as ``(n, phi, r)`` (N·m or N).

    Raises:
        ConfigError: ``harmonics`` outside 1 .. 10, or a missing torque constant.
    """
    k = MAX_HARMONICS if harmonics is None else int(harmonics)
    if not 1 <= k <= MAX_HARMONICS:
        raise ConfigError(f"--harmonics {harmonics}: the AX8000 holds 1 to {MAX_HARMONICS} coefficient sets "
                          "(0x32CB Coef 0 .. Coef 9)")
    scale, conversion = unit_factor(comp, "torque", torque_constant, None, "beckhoff")
    period, prof = _profile(comp, scale)
    a, b = fourier_coefficients(prof)
    amp = np.hypot(a, b)
    orders = np.arange(amp.size)
    cand = orders[orders <= MAX_ORDER]
    keep = cand[np.argsort(-amp[cand], kind="stable")[:k]]
    # harmonics below float32's resolution of the largest are rounding, not compensation
    keep = np.sort(keep[amp[keep] > 1e-9 * amp.max(initial=0.0)])
    r = amp[keep]
    phi = np.mod(np.degrees(np.arctan2(-b[keep], a[keep])), 360.0)
    rest = np.ones(amp.size, bool)
    rest[keep] = False
    dropped = float(np.sqrt(np.sum(np.where(orders[rest] == 0, 1.0, 0.5) * amp[rest] ** 2)))
    limit = None if comp.limit is None else comp.limit * scale
    if limit is not None and np.sum(r) > limit:
        # the sum can reach sum(r) where the harmonics align: keep it within the limit everywhere
        r = r * (limit / np.sum(r))
    tab = BeckhoffTable(comp.kind, "N m" if comp.rotary else "N", period, keep.astype(int), f32(phi), f32(r),
                        (keep.astype(int), phi, r), 1.0, dropped, None, limit, conversion)
    xf = comp.span[0] + comp.length * np.arange(SAMPLES * 2) / (SAMPLES * 2)
    return replace(tab, resolution=error_of(beckhoff_apply(tab, xf), comp.values(xf) * scale, xf))


def beckhoff_apply(tab: BeckhoffTable, x) -> np.ndarray:
    """What the drive adds (unit) at positions ``x`` (assumed formula, module docstring); zero at a non-finite
    position. Within the limit everywhere: :func:`build_beckhoff` keeps ``Σ r`` within it."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    v = tab.gain * harmonic_sum(tab.orders, tab.phi, tab.r, np.where(ok, x, 0.0), tab.period)
    return np.where(ok, v, 0.0)


def beckhoff_list(tab: BeckhoffTable, provenance=()) -> str:
    """The CoE object list (``index:subindex = value``)."""
    checks = [
        "with gain 1, read 3241:0C at standstill at a few angles and compare with the sum of the harmonics below; "
        "a mismatch of sign, cos/sin or phase shows there first (formula assumed)",
        "compare the speed ripple with 32CB:01 = 3 and = 4 (off)",
    ]
    lines = [header("Beckhoff AX8000 cogging compensation (CoE object list)", SOURCES, DOCUMENTED, ASSUMED, checks,
                    [*provenance, f"unit: {tab.unit} ({tab.conversion})",
                     f"harmonics not kept: RMS {tab.dropped:.3g} {tab.unit}",
                     f"period: {tab.period:.9g} {'rad' if tab.kind == 'rotary' else 'm'}"])]
    if tab.kind == "rotary":
        lines += ["0x32CB:01 = 3\n", f"0x32CB:02 = {tab.gain:.9g}\n"]
        for j in range(MAX_HARMONICS):
            n, p, a = (int(tab.orders[j]), tab.phi[j], tab.r[j]) if j < tab.orders.size else (0, 0.0, 0.0)
            lines += [f"0x32CB:{7 + 3 * j:02X} = {n}\n", f"0x32CB:{8 + 3 * j:02X} = {p:.9g}\n",
                      f"0x32CB:{9 + 3 * j:02X} = {a:.9g}\n"]
    else:
        lines += ["0x32D3:01 = 1\n"]
        lines += [f"coef {j}: n = {int(n)}, phi = {p:.9g}, r = {a:.9g}\n"
                  for j, (n, p, a) in enumerate(zip(tab.orders, tab.phi, tab.r))]
    return "".join(lines)


def write_beckhoff(tab: BeckhoffTable, path, provenance=()) -> BeckhoffTable:
    """Write the list atomically, read it back and compare the sums on a grid over one period."""
    atomic_write_text(path, beckhoff_list(tab, provenance))
    back = read_beckhoff(path)
    x = tab.period * np.arange(4096) / 4096
    n, p, r = tab.meant
    meant = harmonic_sum(n, p, r, x, tab.period)
    read = harmonic_sum(back["n"], back["phi"], back["r"], x, tab.period) * back["gain"] / tab.gain
    bound = float(np.sum(np.abs(r))) * 2.0**-24 * (1.0 + 2.0 * math.pi)
    return replace(tab, round_trip=round_trip(read, meant, bound, str(path), tab.unit))


_COE = re.compile(r"^0x(32CB|32D3):([0-9A-Fa-f]{2})\s*=\s*(\S+)$")
_COEF = re.compile(r"^coef (\d+): n = (\d+), phi = (\S+), r = (\S+)$")


def read_beckhoff(path) -> dict:
    """Read a list of :func:`write_beckhoff`: ``{"n", "phi", "r"}`` arrays (sets with ``r = 0`` left out) and
    ``"gain"``.

    Raises:
        DataError: a malformed or non-finite value, ``n`` beyond 200, ``phi`` outside 0..360 or ``r < 0``.
    """
    src = str(path)
    sub, coefs = {}, []
    expected = "'index:subindex = value'"
    for lineno, k, m in parameter_lines(path, _COE, _COEF, expected=expected):
        try:
            if k == 0:
                sub[(m.group(1), int(m.group(2), 16))] = float(m.group(3))
            else:
                coefs.append((int(m.group(2)), float(m.group(3)), float(m.group(4)), lineno))
        except ValueError:
            raise DataError(f"{src} line {lineno}: '{m.string}' is not {expected}") from None
    if ("32CB", 1) in sub:
        coefs = [(int(sub.get(("32CB", 7 + 3 * j), 0)), sub.get(("32CB", 8 + 3 * j), 0.0),
                  sub.get(("32CB", 9 + 3 * j), 0.0), 0) for j in range(MAX_HARMONICS)]
    out = {"n": [], "phi": [], "r": [], "gain": float(sub.get(("32CB", 2), 1.0))}
    for n, p, r, lineno in coefs:
        if not (math.isfinite(p) and math.isfinite(r) and 0 <= n <= MAX_ORDER and 0 <= p <= 360 and r >= 0):
            raise DataError(f"{src}{f' line {lineno}' if lineno else ''}: coefficient n = {n}, phi = {p}, r = {r} is "
                            f"outside n 0..{MAX_ORDER}, phi 0..360 deg, r >= 0")
        if r > 0:
            out["n"].append(n)
            out["phi"].append(p)
            out["r"].append(r)
    return {"n": np.asarray(out["n"], int), "phi": f32(out["phi"]), "r": f32(out["r"]), "gain": out["gain"]}
