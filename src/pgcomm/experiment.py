"""Experiment settings (TOML -> frozen dataclasses) and the plant/motor set-up they describe.

An experiment config is a TOML file whose tables map onto :class:`ExperimentConfig`::

    sample_time = 0.001        # s
    current_limit = 10.0       # A
    [twin]                     # any TwinParams field (pgcomm.twin), e.g.
    harmonic_5 = 0.01
    [mechanics]                # mass (kg), viscous (N s/m), coulomb (N), coulomb_velocity (m/s), substeps
    [sensors]                  # encoder_resolution (m), force_noise = [N, N, N m]
    [controller]               # bandwidth_hz, mass (kg, for the tuning), ff_iterations
    [reference]                # stroke (m), velocities (m/s), a_max, j_max, dwell (s)
    [calibration]              # k0 (N/A), zeta0 (rad), delta (rad), iterations, tol, method, n_bins
    [identification]           # gain_widths, cog_widths, activation, regularisation, starts, ...
    [evaluation]               # lowpass_hz, cogging_table_entries, harmonics

Unknown keys are refused with the closest valid name. The plant is the twin unless
a force map (with its motor TOML) is given, which replaces the twin's
electromagnetics; mechanics and sensors stay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pgcomm.control import PID
from pgcomm.errors import ConfigError
from pgcomm.mechanics import Mechanics
from pgcomm.motor import Motor
from pgcomm.sensors import Sensors
from pgcomm.twin import TwinParams, true_fundamental


@dataclass(frozen=True)
class ControllerConfig:
    """Feedback tuning: bandwidth (Hz) for a mass (kg); feedforward identification passes."""

    bandwidth_hz: float = 6.0
    mass: float = 30.0
    ff_iterations: int = 3

    def pid(self) -> PID:
        """The tuned :class:`PID`."""
        return PID.tuned(self.mass, self.bandwidth_hz)


@dataclass(frozen=True)
class ReferenceConfig:
    """The paper's data-generation reference: moves between ``±stroke`` (m) at each ``v_max`` (m/s)."""

    stroke: float = 0.1
    velocities: tuple[float, ...] = (0.025, 0.075, 0.15)
    a_max: float = 1.0
    j_max: float = 1000.0
    dwell: float = 0.5


@dataclass(frozen=True)
class CalibrationConfig:
    """Algorithm 1 settings: initial ``k̂`` (N/A), ``ζ̂`` (rad), ``Δ`` (rad), passes, tolerance, estimator."""

    k0: float = 67.0
    zeta0: float = -0.52
    delta: float = math.pi / 4
    iterations: int = 1
    tol: float = 1e-4
    method: str = "offset"
    n_bins: int = 40

    def __post_init__(self):
        if self.method not in ("paper", "offset"):
            raise ValueError(f"method must be 'paper' or 'offset', got {self.method!r}")
        if not 0 < abs(self.delta) <= math.pi / 4 + 1e-12:
            raise ValueError(f"delta = {self.delta} rad: expected 0 < |delta| <= pi/4 (paper: for safety)")


@dataclass(frozen=True)
class IdentificationConfig:
    """Algorithm 2 settings (paper defaults: widths 2 and 16, tanh, Λ = 0.1 I)."""

    gain_widths: tuple[int, ...] = (2,)
    cog_widths: tuple[int, ...] = (16,)
    activation: str = "tanh"
    regularisation: float = 0.1
    starts: int = 8
    max_iterations: int = 100
    validation_fraction: float = 0.2
    ridge_output: float = 0.0
    tol: float = 1e-9


@dataclass(frozen=True)
class EvaluationConfig:
    """Evaluation: low-pass cut-off (Hz), anti-cogging table entries, harmonics of the harmonic fit."""

    lowpass_hz: float = 50.0
    cogging_table_entries: int = 2000
    harmonics: int = 10


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything an experiment needs besides the plant itself (SI units)."""

    sample_time: float = 1e-3
    current_limit: float = 10.0
    twin: TwinParams = field(default_factory=TwinParams)
    mechanics: Mechanics = field(default_factory=Mechanics)
    sensors: Sensors = field(default_factory=Sensors)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    calibration: CalibrationConfig = field(default_factory=CalibrationConfig)
    identification: IdentificationConfig = field(default_factory=IdentificationConfig)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)

    def __post_init__(self):
        if not 1e-6 <= self.sample_time <= 0.1:
            raise ValueError(f"sample_time = {self.sample_time} s is implausible (expected 1e-6 to 0.1 s)")


def load_experiment(path) -> ExperimentConfig:
    """Read an experiment TOML into :class:`ExperimentConfig` (unknown keys refused)."""
    from pgcomm.io.config import load_dataclass, load_toml

    return load_dataclass(ExperimentConfig, load_toml(path), str(path))


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


def build_setup(config: ExperimentConfig, forcemap_path=None, motor_path=None) -> Setup:
    """Resolve the plant and the nominal motor.

    Args:
        config: experiment settings.
        forcemap_path: force-map CSV replacing the twin's electromagnetics (needs ``motor_path``).
        motor_path: motor TOML (pole pitch, lever arms, nominal values, sample time, limit).

    Raises:
        ConfigError: a force map without a motor file, or inconsistent coil-set counts.
    """
    cal = config.calibration
    if forcemap_path is None:
        if motor_path is not None:
            raise ConfigError("--motor is only used with --plant FORCEMAP.csv (the twin has its own motor)")
        tw = config.twin
        motor = tw.motor(k_hat=cal.k0, zeta_hat=cal.zeta0, sample_time=config.sample_time,
                         current_limit=config.current_limit)
        k, zeta = true_fundamental(tw, (-config.reference.stroke, config.reference.stroke))
        return Setup(tw.plant(), motor, config, k, zeta, "twin")
    if motor_path is None:
        raise ConfigError(f"--plant {forcemap_path}: a force map needs --motor MOTOR.toml "
                          "(pole pitch, lever arms, nominal k and zeta)")
    from pgcomm.forcemap import load_forcemap
    from pgcomm.io.config import load_motor

    plant = load_forcemap(forcemap_path)
    motor = load_motor(motor_path)
    if plant.n_coil_sets != motor.n_coil_sets:
        raise ConfigError(f"{forcemap_path}: {plant.n_coil_sets} coil sets, but {motor_path} describes "
                          f"{motor.n_coil_sets}")
    lo, hi = plant.y_range
    s = config.reference.stroke
    if -s < lo or s > hi:
        raise ConfigError(f"{forcemap_path}: covers y in [{lo:.6g}, {hi:.6g}] m but the reference strokes over "
                          f"[{-s:.6g}, {s:.6g}] m; set [reference] stroke in --config")
    from dataclasses import replace

    config = replace(config, sample_time=motor.sample_time,
                     current_limit=motor.current_limit if motor.current_limit else config.current_limit)
    return Setup(plant, motor, config, None, None, str(forcemap_path))
