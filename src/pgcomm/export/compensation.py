"""What a drive's compensation table should hold: one source for every drive export, rotary or linear.

A drive with a compensation table adds a value to its own current, torque or force setpoint as a
function of the position it reads (and, for some, of the direction of motion). At zero demand the
value that makes the motor deliver nothing but the demand is, in pgcomm's models:

* **rotary** (current units, :class:`pgcomm.rotary.model.RotaryModel`): the q current
  ``iq_comp(θ, s) = (−c(θ) + d(θ) s) / (1 + r(θ))`` (A), ``θ`` the mechanical angle (rad, periodic over
  one revolution), ``s = ±1`` the direction, or the forward/reverse average (``s`` left out: the drag
  ``d`` cancels). A table file (:mod:`pgcomm.export.angle_table`) holds only that average;
* **linear** (:class:`pgcomm.models.CombinedModel`, :class:`pgcomm.spline_model.SplineModel`): the force
  offset ``f_comp(y, s) = −(F̂_cog,y(y) + C_y(y) s) / g(y)`` (N) added to the drive's force demand, ``g``
  the driving force the model makes per newton the drive's own classical commutation ``k̂, ζ̂`` commands
  (:func:`pgcomm.export.lut.drive_gain`; 1 for a drive matched to the motor), ``C_y`` the direction force.
  This is the negative of :func:`pgcomm.export.lut.build_cogging_table`'s offset (that table is
  *subtracted* from the demand), with the direction force added.

Both are clipped to the limit a table may ask for (the current limit in A; for a linear motor the force
the drive's commutation makes at the current limit, :func:`force_limit`), as the law itself clips, and
are zero at a non-finite position. :class:`Compensation` evaluates them at any positions; each drive
module (``pgcomm.export.sinamics`` ...) samples, averages or projects it the way that drive holds it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.export.angle_table import resample_periodic
from pgcomm.rotary.law import MIN_GAIN
from pgcomm.rotary.model import harmonic_rows

__all__ = ["Compensation", "from_angle_table", "from_rotary_model", "from_linear_model", "force_limit",
           "drive_force_constant", "trig_eval", "fourier_coefficients", "check_compensation"]


@dataclass(frozen=True)
class Compensation:
    """A compensation to load into a drive (module docstring).

    Attributes:
        kind: ``"rotary"`` (positions are mechanical angles, rad, periodic over ``2π``) or ``"linear"``
            (positions in m over ``span``).
        unit: ``"A"`` (rotary: q current) or ``"N"`` (linear: force offset).
        fn: ``fn(x, s)`` -> values (``unit``) at finite positions ``x`` (any shape), ``s`` = +1, -1 or
            ``None`` (forward/reverse average); unclipped.
        span: rotary ``(0, 2π)``; linear the stroke ``(y0, y1)`` (m) the model was identified over.
        limit: largest ``|value|`` (``unit``) a table may hold, or ``None``.
        limit_source: where the limit came from.
        source: the input (file name), for headers.
        comments: provenance lines.
        directional: whether forward and reverse differ (a model with a direction term).
        pole_pairs: ``p`` (rotary) when known.
        pole_pitch: ``d_m`` (m, linear): the magnet pitch of one electrical period.
        ripple: rotary model: ``r(θ)`` (-), the torque-constant ripple; else ``None``.
        table: the input table's ``(n,)`` values when the source is a table file (exact resampling).
        drive: linear: the drive's ``k̂, ζ̂`` and their source (text), for headers.
        force_constant: linear: the drive's force per ampere (N/A, :func:`drive_force_constant`) that turns
            the offset into a current for drives whose table is in A.
    """

    kind: str
    unit: str
    fn: Callable
    span: tuple
    limit: float | None = None
    limit_source: str = "none"
    source: str = "model"
    comments: tuple = ()
    directional: bool = False
    pole_pairs: int | None = None
    pole_pitch: float | None = None
    ripple: Callable | None = None
    table: np.ndarray | None = field(default=None, repr=False)
    drive: str = ""
    force_constant: float | None = None

    @property
    def rotary(self) -> bool:
        """Whether positions are mechanical angles."""
        return self.kind == "rotary"

    @property
    def length(self) -> float:
        """The span's length (rad or m)."""
        return float(self.span[1] - self.span[0])

    def values(self, x, direction=None) -> np.ndarray:
        """The compensation (``unit``) at positions ``x`` (rad or m, any shape), clipped to ``±limit``.

        A non-finite position gives 0 (never a NaN into a drive). Linear positions outside ``span`` take
        the end value (the models are not evaluated outside what they were identified on).
        """
        x = np.asarray(x, dtype=float)
        ok = np.isfinite(x)
        x0 = np.where(ok, x, self.span[0])
        if not self.rotary:
            x0 = np.clip(x0, self.span[0], self.span[1])
        v = np.asarray(self.fn(x0, direction), dtype=float)
        v = np.where(ok & np.isfinite(v), v, 0.0)
        if self.limit is not None:
            v = np.clip(v, -self.limit, self.limit)
        return v

    def grid(self, m: int, direction=None) -> np.ndarray:
        """``(m,)`` values at ``span[0] + length · j / m`` (one period for rotary; the stroke without its end)."""
        x = self.span[0] + self.length * np.arange(int(m)) / int(m)
        if self.table is not None and direction is None:
            v = resample_periodic(self.table, int(m))
            return np.clip(v, -self.limit, self.limit) if self.limit is not None else v
        return self.values(x, direction)


def trig_eval(iq, theta) -> np.ndarray:
    """The trigonometric interpolant of a table ``iq`` (``(n,)`` at ``2π j / n``) at angles ``theta`` (rad)."""
    iq = np.asarray(iq, dtype=float)
    n = iq.size
    c = np.fft.rfft(iq) / n
    w = np.full(c.size, 2.0)
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0  # the Nyquist cosine counted once
    th = np.asarray(theta, dtype=float)
    flat = th.ravel()
    out = np.empty(flat.size)

    orders = np.arange(c.size)
    for s in range(0, flat.size, 4096):  # chunks: (orders x points) rows stay small
        rows = harmonic_rows(flat[s:s + 4096], orders)
        out[s:s + 4096] = (w * c.real) @ rows[:c.size] - (w * c.imag) @ rows[c.size:]
    return out.reshape(th.shape)


def fourier_coefficients(values) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)`` of ``values`` (``(m,)`` samples over one period): ``v = Σ a_h cos hθ + b_h sin hθ``, ``h < m/2``."""
    v = np.asarray(values, dtype=float)
    m = v.size
    c = np.fft.rfft(v) / m
    a, b = 2.0 * c.real, -2.0 * c.imag
    a[0] *= 0.5
    if m % 2 == 0:
        a, b = a[:-1], b[:-1]  # the Nyquist order is not a sinusoid of either phase on m points
    return a, b


def from_angle_table(table, pole_pairs: int | None = None, limit: float | None = None,
                     limit_source: str = "none") -> Compensation:
    """A :class:`Compensation` from a table file (:class:`pgcomm.export.angle_table.AngleTable`, A): the
    forward/reverse average over one revolution, evaluated by its trigonometric interpolant."""
    iq = np.asarray(table.iq, dtype=float)
    return Compensation("rotary", "A", lambda x, s: trig_eval(iq, x), (0.0, 2.0 * math.pi), limit, limit_source,
                        str(table.source), tuple(table.comments), False, pole_pairs, table=iq)


def from_rotary_model(model, limit: float | None = None, limit_source: str = "none",
                      source: str = "model") -> Compensation:
    """A :class:`Compensation` from a :class:`pgcomm.rotary.model.RotaryModel` (A, per direction).

    The gain ``1 + r`` is kept at or above :data:`pgcomm.rotary.law.MIN_GAIN`, as the law keeps it.
    """
    def fn(x, s):
        g = np.maximum(model.gain(x), MIN_GAIN)
        if s is None:
            return -model.cogging(x) / g
        return (-model.cogging(x) + model.direction(x) * float(np.sign(s))) / g

    directional = bool(model.direction.orders.size and np.any(model.direction.coef != 0))
    return Compensation("rotary", "A", fn, (0.0, 2.0 * math.pi), limit, limit_source, source,
                        (f"rotary model {source} ({model.info.get('motor', 'rotary motor')})"
                         if isinstance(model.info, dict) else f"rotary model {source}",),
                        directional, int(model.pole_pairs), ripple=model.ripple)


def drive_force_constant(k_hat) -> float:
    """Driving force per ampere of the largest phase-current amplitude the drive's classical commutation
    commands (N/A): ``Σ k̂_l² / max k̂_l`` (``k̂`` for one coil set; eq. Commutation_Solution_Ideal_SingleCoilset
    gives coil set ``l`` the amplitude ``(k̂_l / Σ k̂_m²) F``)."""
    k = np.asarray(k_hat, dtype=float).ravel()
    return float(np.sum(k**2) / np.max(k))


def force_limit(k_hat, current_limit: float | None) -> float | None:
    """The force (N) a drive's classical commutation ``k̂`` makes at the phase-current limit (A), or ``None``."""
    return None if current_limit is None else float(current_limit) * drive_force_constant(k_hat)


def from_linear_model(model, k_hat, zeta_hat, current_limit: float | None = None, limit_source: str = "none",
                      source: str = "model", drive_text: str = "") -> Compensation:
    """A :class:`Compensation` from a linear model (N along the stroke, per direction) for a drive with
    classical commutation ``k̂`` (N/A), ``ζ̂`` (rad) per coil set (module docstring).

    Raises:
        ConfigError: the model has no training range (a table needs an extent) or the drive's commutation makes
            too little force somewhere on it (:data:`pgcomm.export.lut.MIN_DRIVE_GAIN`).
    """
    # start-up cost: a linear model's table needs JAX; the rotary tables of this module (on pgcomm's start-up path)
    # do not
    import jax.numpy as jnp
    from pgcomm.export.lut import MIN_DRIVE_GAIN, _cog_y, _drive, drive_gain

    if model.training_range is None:
        raise ConfigError(f"{source}: the model has no training range, so a drive table has no extent")
    lo, hi = (float(v) for v in model.training_range)
    k_hat, zeta_hat = _drive(model, k_hat, zeta_hat)
    probe = np.linspace(lo, hi, 2001)
    g = drive_gain(model, probe, k_hat, zeta_hat)
    if not np.min(g) >= MIN_DRIVE_GAIN:
        j = int(np.argmin(g))
        raise ConfigError(f"with k_hat {np.round(k_hat, 4).tolist()} N/A, zeta_hat {np.round(zeta_hat, 4).tolist()} "
                          f"rad the drive's commutation makes only {g[j]:.3g} N per N commanded at y = {probe[j]:.6g} "
                          f"m (at least {MIN_DRIVE_GAIN:g} needed); check --drive-zeta (rad) and --drive-k (N/A)")
    has_dir = bool(getattr(model, "has_direction", False))

    def fn(x, s):
        y = jnp.asarray(np.ravel(x))
        f = np.asarray(_cog_y(model, y))
        if s is not None and has_dir:
            f = f + float(np.sign(s)) * np.asarray(model.direction_force(y, jnp.full(y.shape, 1e9)))[..., 0]
        out = -f / drive_gain(model, np.asarray(y), k_hat, zeta_hat)
        return out.reshape(np.shape(x))

    limit = force_limit(k_hat, current_limit)
    if limit is not None:
        limit_source = f"{limit_source}: {current_limit:g} A x {drive_force_constant(k_hat):.6g} N/A"
    return Compensation("linear", "N", fn, (lo, hi), limit, limit_source, source, (f"linear model {source}",),
                        has_dir, pole_pitch=float(model.pole_pitch), drive=drive_text,
                        force_constant=drive_force_constant(k_hat))


def check_compensation(comp: Compensation, slack: float = 0.0, points: int = 4096) -> None:
    """Refuse (one line naming the input and the position) a compensation that is not finite somewhere on its span,
    or that goes beyond its limit by more than ``slack`` (its unit): a drive table must not hold a NaN, and a drive
    would clip an entry beyond the limit, so the compensation it applied would not be the model's.
    (:meth:`Compensation.values` makes the first zero and clips the second, for the drives' models.)"""
    x = comp.span[0] + comp.length * np.arange(points) / points
    unit = "rad" if comp.rotary else "m"
    for s in ((None, +1, -1) if comp.directional else (None,)):
        v = np.asarray(comp.fn(x, s), dtype=float)
        where = "" if s is None else f" (direction {s:+d})"
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise DataError(f"{comp.source}: the compensation is {v[bad[0]]} at {x[bad[0]]:.6g} {unit}{where}, not a "
                            "finite value; nothing written")
        if comp.limit is not None:
            j = int(np.argmax(np.abs(v)))
            if abs(v[j]) > comp.limit + slack:
                raise DataError(f"{comp.source}: the compensation reaches {v[j]:.6g} {comp.unit} at {x[j]:.6g} {unit}"
                                f"{where}, beyond the limit {comp.limit:.6g} {comp.unit} ({comp.limit_source}); a drive "
                                "would clip it: give the motor's own --current-limit")
