"""Experiment settings: the schema of an experiment config TOML (frozen dataclasses).

An experiment config is a TOML file (read by :func:`load_experiment`) whose tables map onto
:class:`ExperimentConfig`::

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

Unknown keys are refused with the closest valid name. Every field carries its range, unit and
a hint in its metadata (:func:`pgcomm.io.config.load_dataclass` reads them for the messages).
Resolving the settings against a plant, and reading a set-up from files, is :mod:`pgcomm.setup`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pgcomm.control import PID
from pgcomm.mechanics import Mechanics
from pgcomm.sensors import Sensors
from pgcomm.twin import TwinParams

__all__ = ["ControllerConfig", "ReferenceConfig", "CalibrationConfig", "IdentificationConfig", "EvaluationConfig",
           "ExperimentConfig", "load_experiment"]


@dataclass(frozen=True)
class ControllerConfig:
    """Feedback tuning: bandwidth (Hz) for a mass (kg); feedforward identification passes."""

    bandwidth_hz: float = field(default=6.0, metadata={"range": (0.01, 1e4), "unit": "Hz", "hint": "a closed-loop bandwidth above 0"})
    mass: float = field(default=30.0, metadata={"range": (1e-3, 1e5), "unit": "kg", "hint": "the moving mass the feedback is tuned for"})
    ff_iterations: int = field(default=3, metadata={"range": (0, 100)})

    def pid(self) -> PID:
        """The tuned :class:`PID`."""
        return PID.tuned(self.mass, self.bandwidth_hz)


@dataclass(frozen=True)
class ReferenceConfig:
    """The paper's data-generation reference: moves between ``center ± stroke`` (m) at each ``v_max`` (m/s).

    ``stroke`` and ``center`` default (``None``) to the plant's: ``0.1`` m about ``0`` on the twin,
    and on a force map its range less a margin for the following error (:func:`reference_span`).
    :func:`build_setup` resolves them, so a :class:`Setup`'s config always holds numbers.
    """

    stroke: float | None = field(default=None, metadata={"range": (1e-4, 10.0), "unit": "m",
                                                         "hint": "did you give mm?"})
    center: float | None = field(default=None, metadata={"range": (-100.0, 100.0), "unit": "m",
                                                         "hint": "did you give mm?"})
    velocities: tuple[float, ...] = field(default=(0.025, 0.075, 0.15), metadata={"range": (1e-5, 100.0), "unit": "m/s"})
    a_max: float = field(default=1.0, metadata={"range": (1e-4, 1e4), "unit": "m/s^2"})
    j_max: float = field(default=1000.0, metadata={"range": (1e-3, 1e7), "unit": "m/s^3"})
    dwell: float = field(default=0.5, metadata={"range": (0.0, 100.0), "unit": "s"})

    @property
    def span(self) -> tuple[float, float]:
        """``(center - stroke, center + stroke)`` (m): the positions the reference covers (resolved configs)."""
        return (self.center - self.stroke, self.center + self.stroke)


@dataclass(frozen=True)
class CalibrationConfig:
    """Algorithm 1 settings: initial ``k̂`` (N/A), ``ζ̂`` (rad), ``Δ`` (rad), passes, tolerance, estimator."""

    k0: float = 67.0
    zeta0: float = -0.52
    delta: float = math.pi / 4
    iterations: int = field(default=1, metadata={"range": (1, 100), "hint": "Algorithm 1 needs at least one pass"})
    tol: float = field(default=1e-4, metadata={"range": (0.0, 1.0)})
    method: str = "offset"
    n_bins: int = field(default=40, metadata={"range": (1, 1000), "hint": "offset bins of the cable-slab/cogging tables; default 40"})

    def __post_init__(self):
        if self.method not in ("paper", "offset"):
            raise ValueError(f"method must be 'paper' or 'offset', got {self.method!r}")
        if self.iterations < 1:
            raise ValueError(f"iterations = {self.iterations}: Algorithm 1 needs at least 1 pass")
        if self.n_bins < 1:
            raise ValueError(f"n_bins = {self.n_bins}: need at least 1 offset bin (default 40)")
        if not 0 < abs(self.delta) <= math.pi / 4 + 1e-12:
            raise ValueError(f"delta = {self.delta} rad: expected 0 < |delta| <= pi/4 (paper: for safety)")


@dataclass(frozen=True)
class IdentificationConfig:
    """Algorithm 2 settings (paper defaults: widths 2 and 16, tanh, Λ = 0.1 I)."""

    gain_widths: tuple[int, ...] = field(default=(2,), metadata={"range": (1, 256), "hint": "neurons per hidden layer"})
    cog_widths: tuple[int, ...] = field(default=(16,), metadata={"range": (1, 256), "hint": "neurons per hidden layer"})
    #: single-layer gain widths to choose from per coil set by validation cost; empty (default) =
    #: ``gain_widths``. Off by default, measured: on the twin the validation split of the
    #: data-generation runs picks widths 4-8, which absorb the direction-dependent force as a gain
    #: change and do worse in closed loop (PGNN y 8.7 N² against 2.8 N² with the paper's width 2).
    gain_width_candidates: tuple[int, ...] = field(default=(), metadata={"range": (1, 256),
                                                                         "hint": "neurons per hidden layer"})
    activation: str = "tanh"
    regularisation: float = field(default=0.1, metadata={"range": (0.0, 1e6), "hint": "Lambda = regularisation * I must be >= 0"})
    starts: int = field(default=8, metadata={"range": (1, 256), "hint": "random starts, run batched (memory grows with starts): 1 to 256"})
    max_iterations: int = field(default=100, metadata={"range": (1, 100000), "hint": "LM iterations per start"})
    validation_fraction: float = field(default=0.2, metadata={"range": (0.0, 0.5), "hint": "0 trains on everything"})
    ridge_output: float = field(default=0.0, metadata={"range": (0.0, 1e6)})
    tol: float = field(default=1e-9, metadata={"range": (0.0, 1.0)})
    #: the direction term (extensions beyond the paper): ``v_ε`` (m/s) of the direction term's smooth sign; whether the ``pgnn_direction`` row
    #: also gets the 5th/7th harmonic columns; which velocity the direction law is given
    #: (``"reference"`` or ``"encoder"``, see :class:`pgcomm.commutation.ModelLaw`).
    direction_velocity: float = 1e-3
    direction_harmonics: bool = False
    law_velocity: str = "reference"

    def __post_init__(self):
        if len(self.gain_widths) == 0 or len(self.cog_widths) == 0:
            which = "gain_widths" if len(self.gain_widths) == 0 else "cog_widths"
            raise ValueError(f"{which} = []: give at least one hidden layer width, e.g. [2] (gain) or [16] (cogging)")
        if self.starts < 1 or self.max_iterations < 1:
            raise ValueError(f"starts = {self.starts}, max_iterations = {self.max_iterations}: both must be >= 1")
        if not self.regularisation >= 0:
            raise ValueError(f"regularisation = {self.regularisation}: must be >= 0 (Lambda = regularisation * I)")
        if not 0.0 <= self.validation_fraction <= 0.5:
            raise ValueError(f"validation_fraction = {self.validation_fraction}: expected 0 to 0.5 "
                             "(0 trains on everything)")
        if self.law_velocity not in ("reference", "encoder"):
            raise ValueError(f"law_velocity must be 'reference' or 'encoder', got {self.law_velocity!r}")
        if not 0 < self.direction_velocity < 1:
            raise ValueError(f"direction_velocity = {self.direction_velocity} m/s: expected 0 < v_eps < 1 m/s")

    def options(self, **changes):
        """These settings as the :class:`~pgcomm.identify.options.IdentifyOptions` of Algorithm 2.

        Args:
            changes: fields of :class:`~pgcomm.identify.options.IdentifyOptions` that differ from the
                settings for one call (e.g. ``direction=True`` for the direction row).
        """
        from pgcomm.identify.options import IdentifyOptions

        fields = dict(gain_widths=self.gain_widths, cog_widths=self.cog_widths,
                      gain_width_candidates=self.gain_width_candidates, activation=self.activation,
                      regularisation=self.regularisation, ridge_output=self.ridge_output, starts=self.starts,
                      max_iterations=self.max_iterations, tol=self.tol, validation_fraction=self.validation_fraction,
                      direction_velocity=self.direction_velocity)
        fields.update(changes)
        return IdentifyOptions(**fields)


@dataclass(frozen=True)
class EvaluationConfig:
    """Evaluation: low-pass cut-off (Hz), anti-cogging table entries, harmonics of the harmonic fit."""

    lowpass_hz: float = field(default=50.0, metadata={"range": (1e-3, 1e6), "unit": "Hz", "hint": "a cut-off above 0 and below the Nyquist frequency"})
    cogging_table_entries: int = field(default=2000, metadata={"range": (2, 1000000)})
    harmonics: int = field(default=10, metadata={"range": (0, 1000)})


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything an experiment needs besides the plant itself (SI units)."""

    sample_time: float = field(default=1e-3, metadata={"range": (1e-6, 0.1), "unit": "s", "hint": "did you give ms?"})
    current_limit: float = field(default=10.0, metadata={"range": (1e-3, 1e4), "unit": "A", "hint": "a positive peak phase current in A"})
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
        if not self.current_limit > 0:
            raise ValueError(f"current_limit = {self.current_limit} A: expected a positive peak phase current")
        nyquist = 0.5 / self.sample_time
        lp = self.evaluation.lowpass_hz
        if not 0 < lp < nyquist:
            raise ValueError(f"[evaluation] lowpass_hz = {lp:g} Hz: expected above 0 and below the Nyquist "
                             f"frequency {nyquist:g} Hz of sample_time = {self.sample_time:g} s")
        bw = self.controller.bandwidth_hz
        if not 0 < bw <= nyquist / 10:
            raise ValueError(f"[controller] bandwidth_hz = {bw:g} Hz: expected above 0 and at most a tenth of the "
                             f"Nyquist frequency ({nyquist / 10:g} Hz at sample_time = {self.sample_time:g} s); "
                             "a faster loop is unstable")


def load_experiment(path) -> ExperimentConfig:
    """Read an experiment TOML into :class:`ExperimentConfig` (unknown keys refused, by
    :func:`pgcomm.io.config.load_dataclass`)."""
    from pgcomm.io.config import load_dataclass, load_toml

    return load_dataclass(ExperimentConfig, load_toml(path), str(path))

