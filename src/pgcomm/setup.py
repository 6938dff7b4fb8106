"""A resolved experiment (:class:`Setup`): the plant, the nominal motor and what is known of the truth,
with the checks and ranges that depend on the plant.

Pure functions of settings and a plant: the span a default reference may cover on a force map
(:func:`reference_span`, :func:`resolve_reference`), the check that a reference stays on the plant
(:func:`check_reference`), and the moving mass of identification without a force sensor
(:func:`sensorless_mass`, :func:`simulated_mass`). Reading a set-up from files is
:func:`pgcomm.io.setup.build_setup`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from pgcomm.control import PID
from pgcomm.errors import ConfigError
from pgcomm.motor import Motor
from pgcomm.settings import ExperimentConfig, ReferenceConfig

__all__ = ["Setup", "reference_span", "resolve_reference", "check_reference", "sensorless_mass", "simulated_mass"]


@dataclass(frozen=True)
class Setup:
    """A resolved experiment: the plant, the nominal motor (drive) and what is known of the truth.

    Attributes:
        plant: electromagnetic truth (twin or force map).
        motor: nominal description with the initial ``k̂ = k0``, ``ζ̂ = zeta0``.
        config: the :class:`ExperimentConfig`.
        true_k, true_zeta: ``(L,)`` true fundamental (twin only, else ``None``).
        plant_name: ``"twin"`` or the force-map file name.
    """

    plant: object
    motor: Motor
    config: ExperimentConfig
    true_k: np.ndarray | None
    true_zeta: np.ndarray | None
    plant_name: str

    @property
    def pid(self) -> PID:
        """Feedback controller of this experiment."""
        return self.config.controller.pid()



def reference_span(y_lo: float, y_hi: float) -> tuple[float, float]:
    """The positions a default reference may cover on a force map spanning ``[y_lo, y_hi]`` (m).

    The map's range minus a margin at each end for the following error of the loop (the true
    position overshoots the reference at reversals): ``margin = clip(0.025 (y_hi − y_lo),
    2 mm, 10 mm)``, and never more than a quarter of the span. On a map centred on 0 the
    data-generation reference's ``stroke`` (half stroke, m) is the returned ``hi``.

    Args:
        y_lo, y_hi: ends of the map (m), ``y_hi > y_lo``.

    Returns:
        ``(lo, hi)`` (m) with ``y_lo < lo < hi < y_hi``.
    """
    y_lo, y_hi = float(y_lo), float(y_hi)
    span = y_hi - y_lo
    if not (math.isfinite(span) and span > 0):
        raise ValueError(f"reference_span: need y_hi > y_lo (m), got {y_lo}, {y_hi}")
    margin = min(max(0.025 * span, 2e-3), 1e-2, 0.25 * span)
    return y_lo + margin, y_hi - margin


def resolve_reference(rc: ReferenceConfig, y_lo: float, y_hi: float, where: str) -> ReferenceConfig:
    """``rc`` with ``stroke``/``center`` filled in for a plant defined on ``[y_lo, y_hi]`` (m), checked to fit."""
    lo, hi = reference_span(y_lo, y_hi)
    center = rc.center if rc.center is not None else (0.0 if rc.stroke is not None else 0.5 * (lo + hi))
    stroke = rc.stroke if rc.stroke is not None else 0.5 * (hi - lo)
    if center - stroke < y_lo or center + stroke > y_hi:
        raise ConfigError(f"{where}: covers y in [{y_lo:.6g}, {y_hi:.6g}] m but the reference spans "
                          f"[{center - stroke:.6g}, {center + stroke:.6g}] m; set [reference] stroke (and center) "
                          "in --config, or leave them out to span the plant's range")
    return replace(rc, stroke=float(stroke), center=float(center))



def check_reference(setup: "Setup", reference, where: str) -> None:
    """Fail before any work if a reference leaves the plant's range (checked to the sample).

    Args:
        reference: a :class:`~pgcomm.trajectory.Reference`; where: its source for the message.

    Raises:
        ConfigError: naming ``where``, the first sample outside and the plant's range.
    """
    lo, hi = setup.plant.y_range
    r = np.asarray(reference.r)
    bad = (r < lo) | (r > hi)
    if bad.any():
        k = int(np.argmax(bad))
        raise ConfigError(f"{where}: sample {k} (t = {k * reference.sample_time:.6g} s) has r = {r[k]:.6g} m, "
                          f"outside the plant's range [{lo:.6g}, {hi:.6g}] m"
                          + ("; is it in mm?" if np.abs(r).max() > 100 * max(abs(lo), abs(hi)) else ""))


def sensorless_mass(setup: Setup, motor_path=None) -> float:
    """The moving mass (kg) identification without a force sensor is given: the motor's ``mass``
    (motor TOML key ``mass``; :func:`build_setup` sets it to the mechanics' mass on the built-in twin).

    Raises:
        ConfigError: a motor description without a mass (naming ``motor_path`` when given).
    """
    if setup.motor.mass is None:
        where = f"--motor {motor_path}" if motor_path is not None else "the motor description"
        raise ConfigError(f"{where}: key 'mass' missing: identification without a force sensor needs the moving "
                          "mass of the translator (kg); add e.g. mass = 30.0 at the top of the motor TOML")
    return float(setup.motor.mass)


def simulated_mass(setup: Setup) -> tuple[Setup, str]:
    """The moving mass for a run that simulates its plant, and where it comes from.

    A run that simulates the translator knows its mass (``[mechanics] mass``): a motor
    description without ``mass`` takes it, so identification without a force sensor is not
    refused after minutes of computation. Call it before the first computation, and only where
    the data are simulated (logs from a rig have no simulated translator).

    Returns:
        ``(setup, source)``: ``setup`` with ``motor.mass`` set (kg), and one phrase saying where the
        mass comes from, e.g. ``"30 kg from the simulated mechanics ([mechanics] mass; the motor
        description has none)"``; it names a motor mass that differs from the simulated one.
    """
    sim = float(setup.config.mechanics.mass)
    if setup.motor.mass is None:
        return (replace(setup, motor=replace(setup.motor, mass=sim)),
                f"{sim:.4g} kg from the simulated mechanics ([mechanics] mass; the motor description has none)")
    m = float(setup.motor.mass)
    if setup.plant_name == "twin" and m == sim:
        return setup, f"{m:.4g} kg from the simulated mechanics ([mechanics] mass)"
    differs = "" if abs(m - sim) <= 1e-9 * sim else f"; the simulated translator has {sim:.4g} kg"
    return setup, f"{m:.4g} kg from the motor description{differs}"

