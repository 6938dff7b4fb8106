"""The nominal description of a rotary motor on a field-oriented drive (what its TOML holds)."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["RotaryMotor"]


@dataclass(frozen=True)
class RotaryMotor:
    """A rotary PMSM/BLDC as its user knows it (SI units: rad, s, A, N·m, kg·m²).

    Attributes:
        pole_pairs: ``p``; the electrical period ``2π/p`` (rad) takes the linear pole pitch's place.
        slots: ``Q`` stator slots; with ``p`` it sets the cogging orders (``LCM(Q, 2p)`` etc.); ``None``
            when unknown (``pgcomm identify`` then reads it from the logs, :mod:`pgcomm.rotary.slots`).
        sample_time: the period of the drive's logs (s), e.g. 0.001 (the drive may control faster and log snapshots:
            :mod:`pgcomm.rotary.readings`).
        k_t: nominal torque constant (N·m/A, q-axis, peak-current convention) or ``None``;
            only needed to report N·m.
        inertia: moment of inertia of rotor and load (kg·m²) or ``None``; without it (and
            without ``k_t``) identification reports ``J/k_t`` (A·s²/rad).
        current_limit: the drive's q-current limit (A) or ``None``.
        commutation_offset: the drive's electrical angle offset (rad, electrical): its frame is
            ``p θ + offset``; the analogue of the linear ``ζ̂``.
        encoder_counts: encoder counts per revolution (for the twin's quantisation) or ``None``.
        friction: nominal Coulomb friction (N·m) or ``None``.
        control_rate: how often the drive runs its loops (Hz), e.g. 8000 for an ODrive, or ``None`` when unknown: at
            least the log rate ``1/sample_time``. Only the twin uses it (``pgcomm reproduce`` on a description, whose
            drive then controls ``round(control_rate · sample_time)`` times per logged sample); the identification reads
            the drive's rate from the logs (:mod:`pgcomm.rotary.readings`).
    """

    pole_pairs: int
    slots: int | None = None
    sample_time: float = 1e-3
    k_t: float | None = None
    inertia: float | None = None
    current_limit: float | None = None
    commutation_offset: float = 0.0
    encoder_counts: int | None = None
    friction: float | None = None
    control_rate: float | None = None

    kind = "rotary"

    def __post_init__(self):
        if int(self.pole_pairs) != self.pole_pairs or self.pole_pairs < 1:
            raise ValueError(f"pole_pairs = {self.pole_pairs} must be a positive integer")
        if self.slots is not None and (int(self.slots) != self.slots or self.slots < 3):
            raise ValueError(f"slots = {self.slots} must be an integer >= 3")
        if not (self.sample_time > 0 and math.isfinite(self.sample_time)):
            raise ValueError(f"sample_time = {self.sample_time} must be positive")
        if self.control_rate is not None and not (math.isfinite(self.control_rate)
                                                  and self.control_rate * self.sample_time >= 1.0 - 1e-9):
            raise ValueError(f"control_rate = {self.control_rate} Hz is below the log rate 1/sample_time = "
                             f"{1.0 / self.sample_time:g} Hz (a drive logs at most once per control cycle)")

    @property
    def electrical_period(self) -> float:
        """``2π/p`` (rad, mechanical): the rotary counterpart of the pole pitch ``d_m``."""
        return 2.0 * math.pi / self.pole_pairs

    @property
    def cogging_fundamental(self) -> int | None:
        """``LCM(Q, 2p)``: cogging periods per revolution (``None`` while the slots are unknown)."""
        return None if self.slots is None else math.lcm(int(self.slots), 2 * int(self.pole_pairs))

    @property
    def control_per_log(self) -> int | None:
        """The drive's control cycles per logged sample, ``round(control_rate · sample_time)``, or ``None`` when the
        rate is unknown."""
        return None if self.control_rate is None else max(1, round(self.control_rate * self.sample_time))

    @property
    def name(self) -> str:
        """Slot/pole combination, e.g. ``"12N14P"`` (``"?N14P"`` while the slots are unknown)."""
        return f"{'?' if self.slots is None else self.slots}N{2 * self.pole_pairs}P"

    def to_dict(self) -> dict:
        return {"kind": "rotary", "pole_pairs": int(self.pole_pairs), "slots": None if self.slots is None else int(self.slots),
                "sample_time": self.sample_time, "k_t": self.k_t, "inertia": self.inertia,
                "current_limit": self.current_limit, "commutation_offset": self.commutation_offset,
                "encoder_counts": self.encoder_counts, "friction": self.friction,
                **({"control_rate": self.control_rate} if self.control_rate is not None else {})}
