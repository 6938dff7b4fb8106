"""Sensors: position-encoder quantisation and force-sensor noise (twin effect 8)."""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp


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

    encoder_resolution: float = 1e-7
    force_noise: tuple[float, float, float] = (0.8, 0.45, 0.9)


def quantise(y, resolution):
    """Encoder reading of position ``y`` (m): rounded to multiples of ``resolution`` (m)."""
    if resolution <= 0:
        return y
    return jnp.round(y / resolution) * resolution


def force_noise(key, n, sensors: Sensors):
    """``(n, 3)`` white force-sensor noise (N, N, N·m) drawn from ``key``."""
    return jax.random.normal(key, (n, 3)) * jnp.asarray(sensors.force_noise)
