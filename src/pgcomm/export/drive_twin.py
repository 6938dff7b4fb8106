"""The drives' tables as the twins apply them: what each drive can hold, in closed loop.

Each drive module models its drive in NumPy (``sinamics_apply``, ``akd_apply`` ...). Here the same rules act
inside the closed loops:

* **linear** (:mod:`pgcomm.simulate`): :class:`DriveTableLaw` is classical commutation (the drive's own ``k̂,
  ζ̂``) of the demand plus the table's force, read as the drive reads it: periodic over ``p5253`` (SINAMICS),
  over ``RANGELOW … RANGEHIGH`` and nothing outside (AKD), from ``PosStart`` in steps of ``PosDelta`` and nothing
  outside (Moog), linear interpolation; a table per direction kept through the speed hysteresis band (the law's
  state, carried by the simulation); a fade-out with speed. :class:`HarmonicDriveLaw` adds Beckhoff's harmonics.
  The drives switch on their own speed estimate (``velocity_source = "encoder"``).
* **rotary** (:mod:`pgcomm.rotary.twin`): :func:`rotary_law` turns a drive's table into the twin's
  :class:`~pgcomm.rotary.twin.LawParams`: a table over the revolution (moteus' int8 steps, AKD, Moog, SINAMICS
  repeated over its period, Summit's electrical-angle table unrolled over the ``p`` electrical revolutions), per
  direction with hysteresis, faded with speed, or harmonics (Beckhoff, IONI's two sinusoids) as the law's maps.
  ODrive's zero-order hold is approximated by a table 8 times finer than its bins (each step a ramp of an eighth
  of a bin).

``tests/test_export_drives.py`` checks each against its drive's NumPy model; ``bench/drive_tables.py`` runs them.
"""

from __future__ import annotations

import math

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.commutation import ClassicalLaw
from pgcomm.export import akd, beckhoff, ioni, moog, sinamics, summit
from pgcomm.export.moteus import MoteusTable
from pgcomm.export.odrive import odrive_apply, OdriveMap
from pgcomm.rotary.model import Fourier, RotaryModel

__all__ = ["DriveTableLaw", "HarmonicDriveLaw", "linear_law", "rotary_law", "RPM", "M_PER_MIN"]

#: rad/s per rpm; m/s per m/min.
RPM = 2.0 * math.pi / 60.0
M_PER_MIN = 1.0 / 60.0


def _fade(v, start, end):
    return jnp.where(end > start, jnp.clip((end - jnp.abs(v)) / jnp.where(end > start, end - start, 1.0), 0.0, 1.0),
                     1.0)


@pytree_dataclass
class DriveTableLaw:
    """Classical commutation of ``F* + [table(y), 0, 0]``, the table as a drive reads it (module docstring).

    Attributes:
        base: the drive's :class:`~pgcomm.commutation.ClassicalLaw`.
        fwd, rev: ``(M,)`` forward and reverse tables (N; the same for a drive with one).
        x0, dx: position (m) of entry 0 and the spacing (m).
        band: hysteresis band (m/s) of the direction switch; fade_start, fade_end: speeds (m/s) of the fade-out
            (``fade_end <= fade_start``: none).
        mode: ``"periodic"`` (wraps over ``M dx``), ``"range_wrap"`` (``[x0, x0 + M dx)``, wrapping inside, zero
            outside) or ``"range"`` (``[x0, x0 + (M−1) dx]``, zero outside).
    """

    base: ClassicalLaw
    fwd: jnp.ndarray
    rev: jnp.ndarray
    x0: jnp.ndarray
    dx: jnp.ndarray
    band: jnp.ndarray
    fade_start: jnp.ndarray
    fade_end: jnp.ndarray
    mode: str = static_field(default="periodic")
    velocity_source: str = static_field(default="encoder")

    def direction_state(self, d, v):
        """The table in use after a speed sample (+1 forward, −1 reverse), kept inside ``±band/2``."""
        return jnp.where(v > 0.5 * self.band, 1.0, jnp.where(v < -0.5 * self.band, -1.0, d))

    def offset(self, y, v, d):
        """The table's force (N) at ``y`` (m) with the table of ``d`` and the fade-out at speed ``v``."""
        m = self.fwd.shape[-1]
        u = (y - self.x0) / self.dx
        if self.mode == "range":
            inside = (u >= 0) & (u <= m - 1)
            uc = jnp.clip(u, 0.0, m - 1.0)
            k = jnp.minimum(jnp.floor(uc), m - 2).astype(jnp.int32)
            k1 = k + 1
        else:
            inside = (u >= 0) & (u < m) if self.mode == "range_wrap" else jnp.ones_like(u, dtype=bool)
            uc = jnp.mod(u, m)
            k = jnp.minimum(jnp.floor(uc), m - 1).astype(jnp.int32)
            k1 = (k + 1) % m
        t = uc - k.astype(uc.dtype)
        tab = jnp.where(d < 0, self.rev, self.fwd)
        val = tab[k] * (1 - t) + tab[k1] * t
        return jnp.where(inside, val, 0.0) * _fade(v, self.fade_start, self.fade_end)

    def currents_with_state(self, y, f_star, v, d):
        """Star currents (A) with the table of state ``d``."""
        off = self.offset(y, v, d)
        return self.base.currents(y, f_star + jnp.stack([off, 0.0 * off, 0.0 * off], axis=-1))

    def currents(self, y, f_star, v=None):
        """Stateless use (no hysteresis): the table of the sign of ``v`` (forward at rest)."""
        vv = jnp.zeros_like(y) if v is None else v
        return self.currents_with_state(y, f_star, vv, jnp.where(vv < 0, -1.0, 1.0))


@pytree_dataclass
class HarmonicDriveLaw:
    """Classical commutation of ``F* + [Σ r cos(2π n y/P + phi), 0, 0]`` (Beckhoff's form, N).

    Attributes:
        base: the drive's law; orders ``(K,)``; phi ``(K,)`` (rad); r ``(K,)`` (N); period ``P`` (m).
    """

    base: ClassicalLaw
    orders: jnp.ndarray
    phi: jnp.ndarray
    r: jnp.ndarray
    period: jnp.ndarray

    def offset(self, y):
        """The harmonics' force (N) at ``y`` (m)."""
        th = 2.0 * jnp.pi * jnp.mod(y, self.period) / self.period
        return jnp.sum(self.r * jnp.cos(self.orders * jnp.asarray(th)[..., None] + self.phi), axis=-1)

    def currents(self, y, f_star, v=None):
        """Star currents (A)."""
        off = self.offset(y)
        return self.base.currents(y, f_star + jnp.stack([off, 0.0 * off, 0.0 * off], axis=-1))


def linear_law(tab, base: ClassicalLaw, newton_per_unit: float = 1.0, hysteresis: float | None = None):
    """The closed-loop law of a linear drive table (SINAMICS, AKD, Moog or Beckhoff table of a linear motor).

    Args:
        tab: the drive's table (``build_sinamics`` ...); base: the drive's classical law.
        newton_per_unit: N per table unit (the force constant for AKD/Moog tables in A).
        hysteresis: SINAMICS ``p5256`` (m/min) when it has two tables; default ``tab.hysteresis``.
    """
    f = jnp.asarray
    none = (f(0.0), f(0.0))
    if isinstance(tab, beckhoff.BeckhoffTable):
        return HarmonicDriveLaw(base, f(tab.orders.astype(float)), f(np.radians(tab.phi)),
                                f(tab.r * tab.gain * newton_per_unit), f(tab.period))
    if isinstance(tab, sinamics.SinamicsTable):
        fwd = tab.tables.get("forward", tab.tables.get("both"))
        rev = tab.tables.get("reverse", fwd)
        h = hysteresis if hysteresis is not None else (tab.hysteresis or 0.0)
        return DriveTableLaw(base, f(fwd * newton_per_unit), f(rev * newton_per_unit), f(0.0),
                             f(tab.period / sinamics.ENTRIES), f(h * M_PER_MIN), *none, "periodic")
    if isinstance(tab, akd.AkdTable):
        v = f(tab.values * newton_per_unit)
        return DriveTableLaw(base, v, v, f(tab.low), f(tab.period / akd.ENTRIES), f(0.0), *none, "range_wrap")
    if isinstance(tab, moog.MoogTable):
        v = f(tab.values * newton_per_unit)
        return DriveTableLaw(base, v, v, f(tab.start), f(tab.delta), f(0.0), *none, "range")
    raise TypeError(f"no linear law for {type(tab).__name__}")


def rotary_law(tab, ff=(0.0, 0.0, 0.0), pole_pairs: int = 1, hysteresis_rpm: float | None = None):
    """The rotary twin's :class:`~pgcomm.rotary.twin.LawParams` for a drive's table in A (tables built with a
    torque constant of 1, so N·m read as A).

    Args:
        tab: ``MoteusTable``, ``OdriveMap``, ``SinamicsTable``, ``AkdTable``, ``MoogTable``, ``BeckhoffTable``,
            ``SummitTable`` or ``IoniTable``.
        ff: the feedforward ``(ff_a, ff_b, ff_d)`` of the row (as the model's row).
        pole_pairs: ``p`` (the law's maps need it).
        hysteresis_rpm: SINAMICS ``p5256`` (rpm) when it has two tables; default ``tab.hysteresis``.
    """
    # start-up cost: the rotary twin loads SciPy (0.9 s more), which the linear tables never need
    from pgcomm.rotary.twin import LawParams

    zero = RotaryModel.zero(pole_pairs)
    kw = dict(ff_a=ff[0], ff_b=ff[1], ff_d=ff[2])
    if isinstance(tab, MoteusTable):
        return LawParams(zero, tab.entries.astype(float) * tab.scale, **kw)
    if isinstance(tab, OdriveMap):
        n = 8 * tab.torque.size
        # sampled a quarter of a fine step in, so each step's edge falls between two samples
        return LawParams(zero, odrive_apply(tab, 2.0 * math.pi * (np.arange(n) + 0.25) / n), **kw)
    if isinstance(tab, sinamics.SinamicsTable):
        copies = round(2.0 * math.pi / tab.period)
        fwd = np.tile(tab.tables.get("forward", tab.tables.get("both")), copies)
        rev = np.tile(tab.tables["reverse"], copies) if "reverse" in tab.tables else None
        h = hysteresis_rpm if hysteresis_rpm is not None else (tab.hysteresis or 0.0)
        return LawParams(zero, fwd, **kw, table_reverse=rev, hysteresis=h * RPM)
    if isinstance(tab, akd.AkdTable):
        return LawParams(zero, tab.values, **kw)
    if isinstance(tab, moog.MoogTable):
        fade = None if tab.fade is None else (tab.fade[0] * RPM, tab.fade[1] * RPM)
        return LawParams(zero, tab.values, **kw, fade=fade)
    if isinstance(tab, summit.SummitTable):
        # the electrical table's breakpoints (bin centres) and its entries' bins' edges all fall on this grid
        n = 2 * tab.n * tab.pole_pairs
        return LawParams(zero, summit.summit_apply(tab, 2.0 * math.pi * np.arange(n) / n), **kw)
    if isinstance(tab, beckhoff.BeckhoffTable):
        # the drive adds Σ r cos(nθ + φ): the law's cogging map is its negative
        ph = np.radians(tab.phi)
        cog = Fourier(tab.orders.astype(int), np.stack([-tab.r * np.cos(ph), tab.r * np.sin(ph)], axis=1) * tab.gain)
        return LawParams(RotaryModel(pole_pairs, cog, Fourier.zeros([]), Fourier.zeros([])), None, **kw)
    if isinstance(tab, ioni.IoniTable):
        cog = Fourier.zeros([])
        if tab.cogging is not None:
            s = tab.cogging
            # the law subtracts c: c = −A sin(h θ + φ) = −A sin φ cos hθ − A cos φ sin hθ, h = N p
            cog = Fourier(np.array([s.n * tab.pole_pairs]),
                          np.array([[-s.amplitude * math.sin(s.phase), -s.amplitude * math.cos(s.phase)]]))
        rip = Fourier.zeros([])
        if tab.ripple is not None:
            # the law divides by 1 + r; the drive multiplies by 1 + A sin(hθ + φ): r = 1/(1 + A sin) − 1, whose
            # harmonics at multiples of h fall as A^k (six kept: below 1e-9 of the gain for A <= 0.03)
            s = tab.ripple
            m = 64
            th = 2.0 * math.pi * np.arange(m) / m
            r = 1.0 / (1.0 + s.amplitude * np.sin(th + s.phase)) - 1.0
            c = np.fft.rfft(r) / m
            k = np.arange(1, 7)
            h = k * s.n * tab.pole_pairs
            rip = Fourier(np.concatenate([[0], h]), np.concatenate([[[c[0].real, 0.0]],
                                                                    np.stack([2 * c[k].real, -2 * c[k].imag], 1)]))
        # the drive's sinusoid is added to the scaled demand; the twin's law divides the cogging term by (1 + r) too:
        # a product of the two amplitudes (second order), kept
        return LawParams(RotaryModel(pole_pairs, cog, rip, Fourier.zeros([])), None, **kw)
    raise TypeError(f"no rotary law for {type(tab).__name__}")
