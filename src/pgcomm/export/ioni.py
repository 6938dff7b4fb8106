"""Granite Devices IONI cogging and torque-ripple compensation: two sinusoids in the motor's electrical angle.

From the Granite Devices wiki, "Configuring cogging torque compensation" (IONI Pro family):

* static, no-current cogging compensation **sums a fixed-amplitude waveform on the torque setpoint**; the default
  waveforms are **sinusoidal, their phase driven by the motor angle**: ``TRF1`` selects the function, ``TRA1``
  (cogging compensation current) its amplitude;
* dynamic torque-ripple compensation **scales the torque setpoint** with such a waveform: ``TRF2`` selects the
  function, ``TRA2`` its modulation depth;
* the function's frequency is found from the cogs per revolution: ``N = 2 × cogs / poles``, i.e. periods per
  electrical revolution.

So the drive can hold one sinusoid of the compensation current and one of the gain, each at a whole number
``N`` of periods per electrical revolution (order ``N p`` per mechanical revolution). pgcomm picks, for each,
the largest harmonic of the model at such an order: for ``TRF1/TRA1`` of the compensation (the forward/reverse
average), for ``TRF2/TRA2`` of ``1 / max(1 + r, ½) − 1``, the factor the law divides the demand by (from a rotary
model only: a table file has no ripple).

Assumed (the page read does not list the functions): the added current is ``TRA1 · sin(N θe + φ1)`` and the
scaling ``1 + TRA2 · sin(N θe + φ2)`` with ``θe = p θ`` from the encoder's zero, any phase ``φ`` selectable;
``TRA1`` in A, ``TRA2`` a fraction. The file names ``N`` and ``φ`` for the choice of ``TRF1/TRF2`` in Granity.
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
from pgcomm.rotary.law import MIN_GAIN

__all__ = ["SOURCE", "Sinusoid", "IoniTable", "build_ioni", "write_ioni", "read_ioni", "ioni_apply"]

SAMPLES = 8192

#: Largest ``TRA2`` written: the law keeps its gain ``1 + r`` at or above ½, i.e. scales the demand by at most 2;
#: a depth of ½ keeps the scaled demand's sign and within 1.5 times its size.
MAX_DEPTH = 0.5

SOURCE = Source("Granite Devices wiki", "Configuring cogging torque compensation",
                "https://granitedevices.com/wiki/Configuring_cogging_torque_compensation")

DOCUMENTED = (
    "TRF1/TRA1: a waveform of fixed amplitude TRA1 (cogging compensation current) summed on the torque setpoint",
    "TRF2/TRA2: a waveform scaling the torque setpoint with modulation depth TRA2 (torque ripple)",
    "the waveforms are sinusoids whose phase follows the motor angle; N = 2 x cogs / poles periods per electrical "
    "revolution",
)

ASSUMED = (
    "added current TRA1 sin(N1 theta_e + phi1), scaling 1 + TRA2 sin(N2 theta_e + phi2), theta_e = pole pairs x "
    "mechanical angle from the encoder's zero; any phase selectable; TRA1 in A, TRA2 a fraction (the functions TRF1 "
    "and TRF2 offer are not listed on the page read: choose the one with this N and phase)",
)


@dataclass(frozen=True)
class Sinusoid:
    """``amplitude · sin(N θe + phase)``: ``N`` periods per electrical revolution, phase (rad)."""

    n: int
    amplitude: float
    phase: float

    def at(self, theta_e) -> np.ndarray:
        """Values at electrical angles (rad)."""
        return self.amplitude * np.sin(self.n * np.asarray(theta_e, float) + self.phase)


@dataclass(frozen=True)
class IoniTable:
    """The two sinusoids ready to write.

    Attributes:
        pole_pairs: ``p``; cogging: :class:`Sinusoid` (A) or ``None``; ripple: :class:`Sinusoid` (-) or ``None``.
        meant: the two before float32 rounding; resolution: the cogging sinusoid against the compensation over
            one revolution (A); ripple_resolution: the scaling against ``1 / (1 + r)`` (-).
    """

    pole_pairs: int
    cogging: Sinusoid | None
    ripple: Sinusoid | None
    meant: tuple = (None, None)
    resolution: object = None
    ripple_resolution: object = None
    limit: float | None = None
    round_trip: RoundTrip | None = None

    def to_dict(self) -> dict:
        """Figures for results.json."""
        def s(x):
            return None if x is None else {"N": x.n, "amplitude": x.amplitude, "phase_deg": math.degrees(x.phase)}

        return {"pole_pairs": self.pole_pairs, "TRF1_TRA1": s(self.cogging), "TRF2_TRA2": s(self.ripple),
                "limit_A": self.limit,
                "resolution": None if self.resolution is None else self.resolution.to_dict(),
                "ripple_resolution": None if self.ripple_resolution is None else self.ripple_resolution.to_dict(),
                "round_trip": None if self.round_trip is None else self.round_trip.to_dict(),
                "source": SOURCE.text(), "assumptions": list(ASSUMED)}


def _largest(values, p: int) -> Sinusoid | None:
    """The largest harmonic at a multiple ``N p`` (``N >= 1``) of ``values`` (samples over one revolution)."""
    a, b = fourier_coefficients(values)
    orders = np.arange(a.size)
    ok = (orders >= p) & (orders % p == 0)
    if not np.any(ok):
        return None
    amp = np.where(ok, np.hypot(a, b), -1.0)
    h = int(np.argmax(amp))
    if amp[h] <= 0:
        return None
    # a cos hθ + b sin hθ = R sin(hθ + φ), R sin φ = a, R cos φ = b; hθ = N θe
    return Sinusoid(h // p, float(amp[h]), float(np.arctan2(a[h], b[h])))


def build_ioni(comp, pole_pairs: int | None = None) -> IoniTable:
    """The two sinusoids from a rotary ``comp`` (A).

    Raises:
        ConfigError: no pole-pair number (a table file does not record them).
    """
    unit_factor(comp, "current", None, None, "ioni")
    p = pole_pairs if pole_pairs is not None else comp.pole_pairs
    if p is None:
        raise ConfigError("--format ioni works in the electrical angle: give --pole-pairs P (a table file does not "
                          "record them)")
    p = int(p)
    theta = 2.0 * math.pi * np.arange(SAMPLES) / SAMPLES
    cog = _largest(comp.grid(SAMPLES), p)
    rip = None
    if comp.ripple is not None:
        rip = _largest(1.0 / np.maximum(1.0 + comp.ripple(theta), MIN_GAIN) - 1.0, p)
    if cog is not None and comp.limit is not None and cog.amplitude > comp.limit:
        cog = replace(cog, amplitude=float(comp.limit))
    if rip is not None and rip.amplitude > MAX_DEPTH:
        rip = replace(rip, amplitude=MAX_DEPTH)  # the scaled demand keeps its sign and at most 1.5 times its size
    rounded = tuple(None if s is None else Sinusoid(s.n, float(f32(s.amplitude)), float(f32(s.phase)))
                    for s in (cog, rip))
    tab = IoniTable(p, rounded[0], rounded[1], (cog, rip), None, None, comp.limit)
    xf = 2.0 * math.pi * np.arange(SAMPLES * 2) / (SAMPLES * 2)
    res = error_of(ioni_apply(tab, xf, 0.0), comp.values(xf), xf)
    rres = None
    if comp.ripple is not None:
        want = 1.0 / np.maximum(1.0 + comp.ripple(xf), MIN_GAIN)
        rres = error_of(ioni_apply(tab, xf, 1.0) - ioni_apply(tab, xf, 0.0), want, xf)
    return replace(tab, resolution=res, ripple_resolution=rres)


def ioni_apply(tab: IoniTable, x, demand=0.0) -> np.ndarray:
    """The q current (A) the drive makes of a demand (A) at mechanical angles ``x``:
    ``demand · (1 + ripple) + cogging``; zero at a non-finite angle or demand."""
    x = np.asarray(x, dtype=float)
    u = np.asarray(demand, dtype=float)
    ok = np.isfinite(x) & np.isfinite(u)
    te = tab.pole_pairs * np.where(ok, x, 0.0)
    scale = 1.0 + (tab.ripple.at(te) if tab.ripple is not None else 0.0)
    add = tab.cogging.at(te) if tab.cogging is not None else 0.0
    return np.where(ok, np.where(ok, u, 0.0) * scale + add, 0.0)


def ioni_list(tab: IoniTable, provenance=()) -> str:
    """The Granity settings: for each waveform ``N`` and phase (to choose TRF1/TRF2) and its amplitude."""
    checks = [
        "in Granity choose for TRF1 (TRF2) the sinusoid with N periods per electrical revolution and the phase below; "
        "the function list is not in the documentation read",
        "turn slowly with TRA1 = 0 and with the value below and compare the velocity ripple; try the phase + 180 deg "
        "if it grows (sign assumed)",
    ]
    lines = [header("Granite Devices IONI cogging / torque ripple compensation", [SOURCE], DOCUMENTED, ASSUMED, checks,
                    [*provenance, f"pole pairs: {tab.pole_pairs}",
                     f"limit: {tab.limit:.6g} A" if tab.limit is not None else "limit: none"])]
    for name, amp, s, unit in (("TRF1", "TRA1", tab.cogging, "A"), ("TRF2", "TRA2", tab.ripple, "")):
        if s is None:
            lines.append(f"{amp} = 0\n")
            continue
        lines.append(f"{name}: sine, N = {s.n} per electrical revolution, phase = {math.degrees(s.phase):.9g} deg\n")
        lines.append(f"{amp} = {s.amplitude:.9g}{(' ' + unit) if unit else ''}\n")
    return "".join(lines)


def write_ioni(tab: IoniTable, path, provenance=()) -> IoniTable:
    """Write the settings atomically, read them back and compare both waveforms over one electrical revolution."""
    atomic_write_text(path, ioni_list(tab, provenance))
    back = read_ioni(path)
    te = 2.0 * math.pi * np.arange(1024) / 1024
    read, meant, bound = [], [], 0.0
    for got, want in zip((back["cogging"], back["ripple"]), tab.meant):
        read.append(np.zeros(te.size) if got is None else got.at(te))
        meant.append(np.zeros(te.size) if want is None else want.at(te))
        bound += 0.0 if want is None else want.amplitude * 2.0**-24 * (1.0 + 2.0 * math.pi)
    return replace(tab, round_trip=round_trip(np.concatenate(read), np.concatenate(meant), bound, str(path), "A"))


_F = re.compile(r"^(TRF[12]): sine, N = (\d+) per electrical revolution, phase = (\S+) deg$")
_A = re.compile(r"^(TRA[12]) = (\S+)(?: A)?$")


def read_ioni(path) -> dict:
    """Read settings of :func:`write_ioni`: ``{"cogging": Sinusoid | None, "ripple": Sinusoid | None}``.

    Raises:
        DataError: a malformed line or value, an amplitude without its function.
    """
    src = str(path)
    fn, amp = {}, {}
    expected = "a TRF/TRA setting of pgcomm"
    for lineno, k, m in parameter_lines(path, _F, _A, expected=expected):
        try:
            if k == 0:
                fn[m.group(1)[-1]] = (int(m.group(2)), math.radians(float(m.group(3))))
            else:
                amp[m.group(1)[-1]] = float(m.group(2))
        except ValueError:
            raise DataError(f"{src} line {lineno}: '{m.string}' is not {expected}") from None
    out = {}
    for key, name in (("1", "cogging"), ("2", "ripple")):
        a = amp.get(key, 0.0)
        if not math.isfinite(a):
            raise DataError(f"{src}: TRA{key} = {a} is not finite")
        if a != 0.0 and key not in fn:
            raise DataError(f"{src}: TRA{key} without a TRF{key} line")
        out[name] = Sinusoid(fn[key][0], a, fn[key][1]) if a != 0.0 else None
    return out
