"""Periodic maps over one mechanical revolution: the rotary model and its harmonic basis.

Everything position-dependent on a rotary motor repeats once per mechanical revolution, so the
natural basis is a Fourier series in the mechanical angle ``θ`` (rad, multi-turn allowed: the
basis is periodic, every angle is "inside")::

    f(θ) = Σ_h  a_h cos(h θ) + b_h sin(h θ)          h ∈ orders (harmonics per revolution)

The orders are not all harmonics up to some bound (a 36-slot, 42-pole motor cogs at 252 periods
per revolution; all orders up to 756 would be 1512 unknowns) but the ones the slot/pole
combination can produce (:func:`cogging_orders`, :func:`ripple_orders`, :func:`direction_orders`),
so the model stays small and linear in its coefficients.

The model is held in **current units** (DESIGN, "Rotary motors"): without a torque sensor and
without a known inertia only ratios are observable, and they are exactly what a drive's
compensation table holds. With ``k0`` the mean effective torque constant (N·m/A) over the
revolution, the motor obeys::

    J θ̈ = k0 [ (1 + r(θ)) i_q + c(θ) − d(θ) s(ω) − b ω ]

``r`` (-) the relative torque-constant ripple (mean zero), ``c`` (A) the cogging torque as an
equivalent q-current (an identified one may have an order 0: a constant load or the current sensor's offset,
compensated with it), ``d`` (A) the direction-dependent torque (Coulomb friction and the motor's
own drag, e.g. hysteresis) as an equivalent current, ``s(ω) = sign(ω)``, ``b`` (A·s/rad) viscous
friction, and ``J/k0`` (A·s²/rad) the one mechanical parameter. Multiply by ``k0`` for N·m when
``k_t`` is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["harmonic_columns", "harmonic_rows", "cogging_orders", "ripple_orders", "direction_orders", "Fourier", "RotaryModel",
           "fundamental_cogging_order"]


def harmonic_columns(theta, orders) -> np.ndarray:
    """Fourier columns ``[cos(h θ) for h in orders] + [sin(h θ) for h in orders]``.

    Args:
        theta: ``(N,)`` mechanical angle (rad, any turn).
        orders: ``(n,)`` integer harmonics per revolution (non-integer ones are taken as they are).

    Returns:
        ``(N, 2n)``: cosines first, then sines (the sine of order 0 is a zero column).
    """
    return np.ascontiguousarray(harmonic_rows(theta, orders).T)


def harmonic_rows(theta, orders) -> np.ndarray:
    """:func:`harmonic_columns` transposed, ``(2n, N)`` with each row contiguous: for sums over many angles.

    Integer orders are built by the angle-addition recurrence over the sorted orders. Identification builds
    these columns over every interval of minutes of logs, for hundreds of orders, and the sines and cosines were
    most of its time. Sorted, the orders step by few distinct differences ``d`` (multiples of the slot and pole
    numbers), so ``e^{i h θ}`` is the previous order's times ``e^{i d θ}``: two trigonometric calls per distinct
    step instead of per order (3-5x faster at 60-200 orders). Each step adds about one rounding, and a step's
    phase ``d θ`` is rounded as ``h θ`` is in the closed form: the rows agree with ``cos(h θ)`` within a few ulp
    per order plus the spacing of floats at ``2π h_max`` (tests/test_rotary_model.py).

    Args:
        theta: ``(N,)`` mechanical angle (rad, any turn).
        orders: ``(n,)`` harmonics per revolution.

    Returns:
        ``(2n, N)``: cosines first, then sines.
    """
    # reduce the angle first: cos(h θ) for a multi-turn θ of 1e3 rad and h = 756 would lose digits
    th = np.mod(np.asarray(theta, float).ravel(), 2.0 * math.pi)
    h = np.asarray(orders, float).ravel()
    if not np.array_equal(h, np.round(h)):
        ph = h[:, None] * th[None, :]
        return np.concatenate([np.cos(ph), np.sin(ph)], axis=0)
    n, size = h.size, th.size
    rows = np.empty((2 * n, size))
    steps: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    cos_prev, sin_prev, h_prev = np.ones(size), np.zeros(size), 0
    tmp = np.empty(size)
    for j in np.argsort(h, kind="stable"):
        c, s, hj = rows[j], rows[n + j], int(h[j])
        d = hj - h_prev
        if d == 0:
            c[:], s[:] = cos_prev, sin_prev
        else:
            if d not in steps:
                steps[d] = (np.cos(d * th), np.sin(d * th))
            cd, sd = steps[d]
            np.multiply(cos_prev, cd, out=c)
            c -= np.multiply(sin_prev, sd, out=tmp)
            np.multiply(sin_prev, cd, out=s)
            s += np.multiply(cos_prev, sd, out=tmp)
        cos_prev, sin_prev, h_prev = c, s, hj
    return rows


def fundamental_cogging_order(slots: int, pole_pairs: int) -> int:
    """``LCM(slots, 2 p)``: cogging periods per revolution of an ideal motor (e.g. 36N42P: 252)."""
    return math.lcm(int(slots), 2 * int(pole_pairs))


def cogging_orders(slots: int, pole_pairs: int, multiples: int = 3, low: int = 2) -> np.ndarray:
    """Harmonics per revolution at which a real motor cogs.

    The ideal motor cogs at multiples of ``L = LCM(Q, 2p)``; tolerances of the magnets (each its
    own remanence and position) break the rotor's symmetry and add multiples of the slot number
    ``Q``; stator tolerances and eccentricity add multiples of ``2p`` and the lowest orders.

    Args:
        slots: ``Q``; pole_pairs: ``p``; multiples: highest multiple of ``L`` kept (the bound of
        all orders is ``multiples · L``); low: orders ``1 .. low`` always included.

    Returns:
        sorted unique ``(n,)`` int array.
    """
    lcm = fundamental_cogging_order(slots, pole_pairs)
    top = multiples * lcm
    orders = set(range(1, low + 1))
    orders |= set(range(slots, top + 1, slots))
    orders |= set(range(2 * pole_pairs, top + 1, 2 * pole_pairs))
    return np.array(sorted(orders), int)


#: Multiples of the electrical order ``p`` at which a drive's own errors add torque (:func:`drive_orders`).
DRIVE_MULTIPLES = (1, 2, 3, 4, 6)


def drive_orders(pole_pairs: int) -> np.ndarray:
    """Harmonics per revolution at which a field-oriented drive adds torque of its own, whatever the motor.

    A current sensor's offset turns with the electrical angle: torque at order ``p``; a gain mismatch between the
    phase sensors: ``2p``; the inverter's dead time: ``6p``; and the measurement's ``3p`` and ``4p`` (all seen in a
    real ODrive's static map, ``p``, ``4p`` and ``2p`` larger than its slot cogging). Other orders (sidebands of an
    eccentric encoder) enter where the screening finds them (:mod:`pgcomm.rotary.regression`).

    Returns:
        sorted unique ``(n,)`` int array (orders ≥ 1).
    """
    p = int(pole_pairs)
    return np.array(sorted({k * p for k in DRIVE_MULTIPLES}), int)


def ripple_orders(slots: int | None, pole_pairs: int, low: int = 3) -> np.ndarray:
    """Harmonics per revolution of the torque-constant ripple.

    Eccentricity gives order 1 (and 2), magnet tolerances the low orders and an imbalance of the
    north and south poles order ``2p``; the 5th and 7th electrical harmonics of the back-EMF
    give the classical 6th-electrical torque ripple, order ``6p`` (and ``12p``); the slots
    modulate the gain at order ``Q``.

    Args:
        slots: ``Q``, or ``None`` for the orders that do not depend on it (while the slot count is unknown).

    Returns:
        sorted unique ``(n,)`` int array.
    """
    p = int(pole_pairs)
    orders = set(range(1, low + 1)) | {2 * p, 6 * p, 12 * p} | (set() if slots is None else {int(slots)})
    return np.array(sorted(orders), int)


def direction_orders(pole_pairs: int) -> np.ndarray:
    """Harmonics of the direction-dependent torque: 0 (Coulomb friction), 1, 2 (bearing load with
    eccentricity) and ``2p`` (iron hysteresis follows the poles)."""
    return np.array(sorted({0, 1, 2, 2 * int(pole_pairs)}), int)


@dataclass(frozen=True)
class Fourier:
    """A periodic function over one revolution: ``Σ a_h cos(hθ) + b_h sin(hθ)``.

    Attributes:
        orders: ``(n,)`` int harmonics per revolution.
        coef: ``(n, 2)`` float ``[a_h, b_h]`` in the function's unit.
    """

    orders: np.ndarray
    coef: np.ndarray

    @classmethod
    def zeros(cls, orders) -> "Fourier":
        o = np.asarray(orders, int)
        return cls(o, np.zeros((o.size, 2)))

    @classmethod
    def from_vector(cls, orders, vec) -> "Fourier":
        """From the ``(2n,)`` vector ``[a..., b...]`` that :func:`harmonic_columns` multiplies."""
        o = np.asarray(orders, int)
        v = np.asarray(vec, float)
        return cls(o, np.stack([v[: o.size], v[o.size:]], axis=1))

    def __call__(self, theta) -> np.ndarray:
        """Values at ``theta`` (rad, any shape); same shape as ``theta``."""
        th = np.asarray(theta, float)
        if self.orders.size == 0:
            return np.zeros_like(th)
        cols = harmonic_columns(th.ravel(), self.orders)
        return (cols @ np.concatenate([self.coef[:, 0], self.coef[:, 1]])).reshape(th.shape)

    def rms(self) -> float:
        """RMS over the revolution (Parseval): ``sqrt(a_0² + Σ_{h>0} (a_h² + b_h²)/2)``."""
        c = self.coef
        zero = self.orders == 0
        return float(np.sqrt(np.sum(c[zero, 0] ** 2) + 0.5 * np.sum(c[~zero] ** 2)))

    def mean(self) -> float:
        """Mean over the revolution (the order-0 cosine)."""
        return float(np.sum(self.coef[self.orders == 0, 0]))

    def scaled(self, factor: float) -> "Fourier":
        return Fourier(self.orders, self.coef * float(factor))

    def to_dict(self) -> dict:
        return {"orders": self.orders.tolist(), "cos": self.coef[:, 0].tolist(), "sin": self.coef[:, 1].tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> "Fourier":
        return cls(np.asarray(d["orders"], int), np.stack([np.asarray(d["cos"], float),
                                                             np.asarray(d["sin"], float)], axis=1))


def _sign(direction, shape):
    """The direction ``s`` broadcast to ``shape``: ``None`` -> 0 (the forward/reverse average)."""
    if direction is None:
        return np.zeros(shape)
    return np.broadcast_to(np.sign(np.asarray(direction, float)), shape)


@dataclass(frozen=True)
class RotaryModel:
    """The identified (or true) map of a rotary motor in current units (module docstring).

    Attributes:
        pole_pairs: ``p``.
        cogging: :class:`Fourier` ``c(θ)`` (A): cogging torque as an equivalent q-current (with a constant
            load or current offset at order 0, when identified).
        ripple: :class:`Fourier` ``r(θ)`` (-): relative torque-constant ripple (no order 0).
        direction: :class:`Fourier` ``d(θ)`` (A): direction-dependent drag (with Coulomb friction, order 0).
        viscous: ``b`` (A·s/rad).
        inertia_ratio: ``J/k0`` (A·s²/rad) or ``None`` when not identified.
        k_t: mean effective torque constant ``k0`` (N·m/A) when known (for N·m), else ``None``.
        info: free-form provenance (identification settings, validation choice).
    """

    pole_pairs: int
    cogging: Fourier
    ripple: Fourier
    direction: Fourier
    viscous: float = 0.0
    inertia_ratio: float | None = None
    k_t: float | None = None
    info: dict = field(default_factory=dict, compare=False)

    # ------------------------------------------------------------------ evaluation
    def cogging_current(self, theta) -> np.ndarray:
        """``c(θ)`` (A), same shape as ``theta`` (rad)."""
        return self.cogging(theta)

    def gain(self, theta) -> np.ndarray:
        """``1 + r(θ)`` (-): torque per ampere relative to the mean ``k0``."""
        return 1.0 + self.ripple(theta)

    def direction_current(self, theta) -> np.ndarray:
        """``d(θ)`` (A): drag against the motion as an equivalent current."""
        return self.direction(theta)

    def iq_comp(self, theta, direction=None, demand=0.0) -> np.ndarray:
        """The q-current (A) that makes the motor deliver ``k0 · demand``:
        ``(demand − c(θ) + d(θ) s) / (1 + r(θ))``.

        Args:
            theta: mechanical angle (rad), any shape.
            direction: ``s`` = sign of the velocity (+1, −1, an array) or ``None`` for the
                forward/reverse average (the direction term cancels, as in a drive's table).
            demand: demanded torque as a current at the mean torque constant (A), broadcast.

        Returns:
            array of the broadcast shape (A); no clipping (see :mod:`pgcomm.rotary.law`).
        """
        th = np.asarray(theta, float)
        shape = np.broadcast_shapes(th.shape, np.shape(demand), np.shape(direction) if direction is not None else ())
        th = np.broadcast_to(th, shape)
        s = _sign(direction, shape)
        return (np.asarray(demand, float) - self.cogging(th) + self.direction(th) * s) / self.gain(th)

    def table(self, n: int, direction=None) -> np.ndarray:
        """Compensating q-current (A) at ``n`` equally spaced mechanical angles ``θ_j = 2π j / n``,
        ``j = 0 .. n-1``, over one revolution starting at encoder angle 0: the current to add to
        the drive's command at zero torque demand.

        Args:
            n: number of entries (>= 1), e.g. 3600 (ODrive) or 1024 (moteus).
            direction: +1 (forward), −1 (reverse) or ``None``: the average of both, in which the
                direction term cancels (the drives' tables hold that average).

        Returns:
            ``(n,)`` float array (A).
        """
        n = int(n)
        if n < 1:
            raise ValueError(f"table needs n >= 1 entries, got {n}")
        theta = 2.0 * math.pi * np.arange(n) / n
        if direction is None:
            return 0.5 * (self.iq_comp(theta, +1.0) + self.iq_comp(theta, -1.0))
        return self.iq_comp(theta, float(np.sign(direction)) or 1.0)

    def in_newton_metres(self, k_t: float | None = None) -> dict:
        """Cogging and direction torque as N·m Fourier maps (needs ``k_t``, given or stored)."""
        k = k_t if k_t is not None else self.k_t
        if k is None:
            raise ValueError("N·m needs the torque constant k_t (N·m/A)")
        return {"cogging": self.cogging.scaled(k), "direction": self.direction.scaled(k),
                "viscous": self.viscous * k, "inertia": None if self.inertia_ratio is None else self.inertia_ratio * k}

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict:
        """Plain-JSON form (schema ``pgcomm.rotary_model`` version 1)."""
        return {"schema": "pgcomm.rotary_model", "version": 1, "units": "current (A), ripple relative (-)",
                "pole_pairs": int(self.pole_pairs), "cogging": self.cogging.to_dict(),
                "ripple": self.ripple.to_dict(), "direction": self.direction.to_dict(),
                "viscous": float(self.viscous), "inertia_ratio": self.inertia_ratio, "k_t": self.k_t,
                "info": self.info}

    @classmethod
    def from_dict(cls, d: dict) -> "RotaryModel":
        """Inverse of :meth:`to_dict`."""
        if d.get("schema") != "pgcomm.rotary_model":
            raise ValueError("not a pgcomm rotary model (schema 'pgcomm.rotary_model')")
        return cls(int(d["pole_pairs"]), Fourier.from_dict(d["cogging"]), Fourier.from_dict(d["ripple"]),
                   Fourier.from_dict(d["direction"]), float(d.get("viscous", 0.0)), d.get("inertia_ratio"),
                   d.get("k_t"), d.get("info", {}))

    @classmethod
    def zero(cls, pole_pairs: int) -> "RotaryModel":
        """No compensation (classical commutation): every map zero."""
        e = np.zeros(0, int)
        return cls(int(pole_pairs), Fourier.zeros(e), Fourier.zeros(e), Fourier.zeros(e))
