"""Sensors: position-encoder quantisation and force-sensor noise (twin effect 8)."""

from __future__ import annotations

from dataclasses import dataclass, field

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np


@dataclass(frozen=True)
class Sensors:
    """Sensor model.

    Attributes:
        encoder_resolution: position quantum (m); 0 disables quantisation.
        force_noise: standard deviation of white noise on measured ``[Fy, Fx, Tz]``
            (N, N, N·m). Defaults follow the paper's Table Commutation_Performance:
            the gap between its unfiltered and 50 Hz-filtered MSE is the noise
            variance times ``1 - (1 - a)/(1 + a)`` with ``a = exp(-2π·50·Ts)``.
    """

    encoder_resolution: float = field(default=1e-7, metadata={"range": (0.0, 1e-2), "unit": "m",
                                                              "hint": "0 disables quantisation"})
    force_noise: tuple[float, float, float] = field(default=(0.8, 0.45, 0.9), metadata={
        "range": (0.0, 1e4), "hint": "standard deviations (N, N, N m) are >= 0"})

    def __post_init__(self):
        if not all(isinstance(v, (int, float)) for v in (self.encoder_resolution, *tuple(self.force_noise))):
            return  # traced or array values: checked where they are made
        if not self.encoder_resolution >= 0 or any(not s >= 0 for s in self.force_noise):
            raise ValueError(f"encoder_resolution = {self.encoder_resolution} m, force_noise = {self.force_noise}: "
                             "expected >= 0 (standard deviations and a quantum)")


def quantise(y, resolution):
    """Encoder reading of position ``y`` (m): rounded to multiples of ``resolution`` (m)."""
    if resolution <= 0:
        return y
    return jnp.round(y / resolution) * resolution


def force_noise(seed: int, n: int, sensors: Sensors) -> np.ndarray:
    """``(n, 3)`` white force-sensor noise (N, N, N·m) drawn from the NumPy stream ``seed``.

    NumPy's generator rather than JAX's: the noise is drawn on the host after the closed loop, and
    NumPy draws it about 5x faster than an eager ``jax.random.normal`` (which also compiles a program
    per length).
    """
    return np.random.default_rng(seed).standard_normal((int(n), 3)) * np.asarray(sensors.force_noise, dtype=float)
