"""A resolved experiment (:class:`Setup`): the plant, the nominal motor and what is known of the truth,
with the checks and ranges that depend on the plant.

Pure functions of settings and a plant: the span a default reference may cover on a force map
(:func:`reference_span`, :func:`resolve_reference`), the check that a reference stays on the plant
(:func:`check_reference`), and the moving mass of identification without a force sensor
(:func:`sensorless_mass`, :func:`simulated_mass`). Reading a set-up from files (the twin or a force map with its
motor TOML, and the plant's known fundamental, ``truth.json``, written by :mod:`pgcomm.zoo`) is :func:`build_setup`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pgcomm.control import PID
from pgcomm.errors import ConfigError
from pgcomm.io.config import load_motor
from pgcomm.io.forcemap import load_forcemap
from pgcomm.motor import Motor
from pgcomm.settings import ExperimentConfig, ReferenceConfig
from pgcomm.simulate import ClosedLoop
from pgcomm.twin import true_fundamental

__all__ = ["Setup", "build_setup", "load_truth", "reference_span", "resolve_reference", "check_reference",
           "sensorless_mass", "simulated_mass"]


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

    @property
    def loop(self) -> ClosedLoop:
        """The closed loop around the law: this experiment's feedback, translator and sensors."""
        return ClosedLoop(self.pid, self.config.mechanics, self.config.sensors)



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


def build_setup(config: ExperimentConfig, forcemap_path=None, motor_path=None, truth_path=None) -> Setup:
    """Resolve the plant, the nominal motor and the reference's range.

    Args:
        config: experiment settings.
        forcemap_path: force-map CSV replacing the twin's electromagnetics (needs ``motor_path``).
        motor_path: motor TOML (pole pitch, lever arms, nominal values, sample time, limit).
        truth_path: the plant's known fundamental (:func:`load_truth`); default ``truth.json``
            beside the force map when it exists (the motor zoo writes one).

    Raises:
        ConfigError: a force map without a motor file, or inconsistent coil-set counts.
    """
    cal = config.calibration
    if forcemap_path is None:
        if motor_path is not None:
            raise ConfigError("--motor is only used with --plant FORCEMAP.csv (the twin has its own motor)")
        tw = config.twin
        motor = tw.motor(k_hat=cal.k0, zeta_hat=cal.zeta0, sample_time=config.sample_time,
                         current_limit=config.current_limit, mass=config.mechanics.mass)
        rc = config.reference
        rc = replace(rc, stroke=0.1 if rc.stroke is None else rc.stroke, center=rc.center or 0.0)
        plant = tw.plant()
        config = replace(config, reference=resolve_reference(rc, *plant.y_range, "the twin"))
        k, zeta = true_fundamental(tw, config.reference.span)
        return Setup(plant, motor, config, k, zeta, "twin")
    if motor_path is None:
        raise ConfigError(f"--plant {forcemap_path}: a force map needs --motor MOTOR.toml "
                          "(pole pitch, lever arms, nominal k and zeta)")
    plant = load_forcemap(forcemap_path)
    motor = load_motor(motor_path)
    if plant.n_coil_sets != motor.n_coil_sets:
        raise ConfigError(f"{forcemap_path}: {plant.n_coil_sets} coil sets, but {motor_path} describes "
                          f"{motor.n_coil_sets}")
    try:
        config = replace(config, sample_time=motor.sample_time,
                         current_limit=motor.current_limit if motor.current_limit else config.current_limit)
    except ValueError as e:
        raise ConfigError(f"{motor_path} with the experiment settings: {' '.join(str(e).split())}") from None
    config = replace(config, reference=resolve_reference(config.reference, *plant.y_range, str(forcemap_path)))
    if truth_path is None and (Path(forcemap_path).parent / "truth.json").is_file():
        truth_path = Path(forcemap_path).parent / "truth.json"
    if truth_path is None:
        return Setup(plant, motor, config, None, None, str(forcemap_path))
    truth = load_truth(truth_path, plant.n_coil_sets)
    if truth["y_range"] is not None and not np.allclose(truth["y_range"], config.reference.span,
                                                        rtol=0, atol=1e-9 * (abs(plant.y_range[1]) + 1e-3)):
        # the fundamental depends on the range it is fitted over: the truth must be of this reference
        raise ConfigError(f"{truth_path}: fitted over y in {list(truth['y_range'])} m, but the reference spans "
                          f"{list(config.reference.span)} m; leave [reference] stroke/center at the map's default")
    return Setup(plant, motor, config, truth["k"], truth["zeta"], str(forcemap_path))


def load_truth(path, n_coil_sets: int) -> dict:
    """A plant's known fundamental, ``truth.json`` as :mod:`pgcomm.zoo` writes it.

    Returns:
        ``{"k": (L,) N/A, "zeta": (L,) rad, "y_range": (lo, hi) m or None}``.

    Raises:
        ConfigError: unreadable file, missing keys, or a coil-set count other than ``n_coil_sets``.
    """
    try:
        data = json.loads(Path(path).read_text())
        k = np.asarray(data["k"], dtype=float)
        zeta = np.asarray(data["zeta"], dtype=float)
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ConfigError(f"{path}: not a truth file with lists 'k' (N/A) and 'zeta' (rad): {err}") from None
    if k.shape != (n_coil_sets,) or zeta.shape != (n_coil_sets,) or not np.isfinite([*k, *zeta]).all():
        raise ConfigError(f"{path}: 'k' and 'zeta' need {n_coil_sets} finite values (one per coil set), "
                          f"got {k.tolist()} and {zeta.tolist()}")
    y_range = data.get("y_range")
    return {"k": k, "zeta": zeta, "y_range": tuple(float(v) for v in y_range) if y_range else None}

