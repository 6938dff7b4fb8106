"""The paper's experiment: settings (frozen dataclasses), the resolved :class:`Setup`, and its steps.

Settings: an experiment config is a TOML file (read by :func:`load_experiment`)
whose tables map onto :class:`ExperimentConfig`::

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
electromagnetics; mechanics and sensors stay (:func:`build_setup`).

Steps, each taking a :class:`Setup` and returning plain results (nothing here prints
except through an optional :class:`pgcomm.progress.Progress`): the paper's references
(:func:`data_generation_reference`, :func:`single_velocity_reference`), data sets ``Z_i^l``
(:func:`generate`), Algorithm 1 (:func:`run_calibration`, :func:`calibration_results`),
Algorithm 2 for every coil set (:func:`identify_models`, :func:`identification_results`),
feedforward per law (:func:`tune_feedforward`), closed-loop runs (:func:`run_laws`) and
their metrics (:func:`run_metrics`), and the drives' sensorless anti-cogging table
(:func:`sensorless_cogging_table`). The CLI commands and :mod:`pgcomm.reproduce` use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pgcomm import trajectory
from pgcomm.calibration import CalibrationResult, calibrate
from pgcomm.control import PID, Feedforward, identify_feedforward
from pgcomm.data import CoilSetData, generate_datasets
from pgcomm.errors import ConfigError
from pgcomm.identify import identify_all
from pgcomm.mechanics import Mechanics
from pgcomm.metrics import commutation_mse, tracking_mse
from pgcomm.models import CombinedModel
from pgcomm.motor import Motor
from pgcomm.sensors import Sensors
from pgcomm.simulate import SimResult, simulate_many
from pgcomm.twin import TwinParams, true_fundamental


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
    #: issue 10: ``v_ε`` (m/s) of the direction term's smooth sign; whether the ``pgnn_direction`` row
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
        config = replace(config, reference=_resolve_reference(rc, *plant.y_range, "the twin"))
        k, zeta = true_fundamental(tw, config.reference.span)
        return Setup(plant, motor, config, k, zeta, "twin")
    if motor_path is None:
        raise ConfigError(f"--plant {forcemap_path}: a force map needs --motor MOTOR.toml "
                          "(pole pitch, lever arms, nominal k and zeta)")
    from pgcomm.io.config import load_motor
    from pgcomm.io.forcemap import load_forcemap

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
    config = replace(config, reference=_resolve_reference(config.reference, *plant.y_range, str(forcemap_path)))
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


def _resolve_reference(rc: ReferenceConfig, y_lo: float, y_hi: float, where: str) -> ReferenceConfig:
    """``rc`` with ``stroke``/``center`` filled in for a plant defined on ``[y_lo, y_hi]`` (m), checked to fit."""
    lo, hi = reference_span(y_lo, y_hi)
    center = rc.center if rc.center is not None else (0.0 if rc.stroke is not None else 0.5 * (lo + hi))
    stroke = rc.stroke if rc.stroke is not None else 0.5 * (hi - lo)
    if center - stroke < y_lo or center + stroke > y_hi:
        raise ConfigError(f"{where}: covers y in [{y_lo:.6g}, {y_hi:.6g}] m but the reference spans "
                          f"[{center - stroke:.6g}, {center + stroke:.6g}] m; set [reference] stroke (and center) "
                          "in --config, or leave them out to span the plant's range")
    return replace(rc, stroke=float(stroke), center=float(center))


def load_truth(path, n_coil_sets: int) -> dict:
    """A plant's known fundamental, ``truth.json`` as :mod:`pgcomm.zoo` writes it.

    Returns:
        ``{"k": (L,) N/A, "zeta": (L,) rad, "y_range": (lo, hi) m or None}``.

    Raises:
        ConfigError: unreadable file, missing keys, or a coil-set count other than ``n_coil_sets``.
    """
    import json

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


# --------------------------------------------------------------------------------------------
# steps of the experiment
# --------------------------------------------------------------------------------------------


def data_generation_reference(setup: Setup) -> trajectory.Reference:
    """The paper's data-generation reference (Fig. Data_Generation) for this set-up."""
    rc = setup.config.reference
    ref = trajectory.data_generation_reference(setup.motor.sample_time, rc.stroke, rc.velocities, rc.a_max,
                                               rc.j_max, rc.dwell)
    return replace(ref, r=ref.r + rc.center) if rc.center else ref


def single_velocity_reference(setup: Setup, v_max: float) -> trajectory.Reference:
    """One back-and-forth over the stroke at ``v_max`` (m/s): the paper's slow/fast references."""
    rc = setup.config.reference
    ref = trajectory.single_velocity_reference(v_max, setup.motor.sample_time, rc.stroke, rc.a_max, rc.j_max,
                                               rc.dwell)
    return replace(ref, r=ref.r + rc.center) if rc.center else ref


def generate(setup: Setup, reference, k_hat, zeta_hat, seed: int = 0, coil_sets=None):
    """Data sets ``Z_{1,2}^l`` with the drive at ``k̂`` (L,) N/A and ``ζ̂`` (L,) rad (no feedforward)."""
    drive = setup.motor.with_nominal(k=tuple(np.asarray(k_hat, float)), zeta=tuple(np.asarray(zeta_hat, float)))
    return generate_datasets(setup.plant, drive, reference, delta=setup.config.calibration.delta, pid=setup.pid,
                             mechanics=setup.config.mechanics, sensors=setup.config.sensors, seed=seed,
                             coil_sets=coil_sets)


def run_calibration(setup: Setup, reference, seed: int = 0, progress=None, first=None,
                    sensorless: bool = False) -> tuple[CalibrationResult, list]:
    """Algorithm 1 from the set-up's initial ``k0``, ``ζ0``; returns the result and the last data sets.

    ``first``: data sets already generated at ``k0``, ``ζ0`` (used for the first pass).
    ``sensorless``: no force data (:func:`pgcomm.calibration.fit_coefficients` method
    ``"sensorless"`` with the moving mass :func:`sensorless_mass`).
    """
    cc = setup.config.calibration
    last = {"calls": 0}

    def gen(k, zeta):
        if last["calls"] == 0 and first is not None:
            last["data"] = first
        else:
            last["data"] = generate(setup, reference, k, zeta, seed=seed + 1000 * last["calls"])
        last["calls"] += 1
        return last["data"]

    def report(it, k, zeta):
        if progress:
            progress.info(f"pass {it}: k = {np.array2string(k, precision=3)} N/A, "
                          f"zeta = {np.array2string(zeta, precision=4)} rad")

    cal = calibrate(gen, np.asarray(setup.motor.k), np.asarray(setup.motor.zeta), delta=cc.delta,
                    iterations=cc.iterations, tol=cc.tol, method="sensorless" if sensorless else cc.method,
                    n_bins=cc.n_bins, progress=report, pole_pitch=setup.motor.pole_pitch,
                    mass=sensorless_mass(setup) if sensorless else None)
    return cal, last["data"]


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


def tune_feedforward(setup: Setup, laws: list, reference, seed: int = 0) -> list[Feedforward]:
    """Feedforward ``m, f_v, f_c`` per law, identified from closed-loop data with that law.

    Iterated ``controller.ff_iterations`` times: each pass runs the loop with the previous
    estimate (the first with none) and refits :func:`pgcomm.control.identify_feedforward`
    on the demanded force; with the feedforward in the loop the feedback lag no longer
    biases the mass estimate. Laws of the same type are simulated batched.
    """
    ffs = [Feedforward()] * len(laws)
    for it in range(setup.config.controller.ff_iterations):
        runs = run_laws(setup, laws, reference, ffs, seeds=[seed + 7919 * it + j for j in range(len(laws))])
        ffs = [identify_feedforward(reference.v, reference.a, r.f_star[:, 0]) for r in runs]
    return ffs


def run_laws(setup: Setup, laws: list, reference, feedforwards: list, seeds) -> list[SimResult]:
    """Simulate each law with its feedforward; laws sharing a pytree structure run batched.

    ``reference`` is one reference for all laws or a list with one per law.
    """
    import jax

    refs = list(reference) if isinstance(reference, (list, tuple)) else [reference] * len(laws)
    groups: dict = {}
    for j, law in enumerate(laws):
        groups.setdefault(jax.tree_util.tree_structure(law), []).append(j)
    out: list = [None] * len(laws)
    kw = dict(drive=setup.motor, pid=setup.pid, mechanics=setup.config.mechanics, sensors=setup.config.sensors)
    for idx in groups.values():
        res = simulate_many(setup.plant, [laws[j] for j in idx], [refs[j] for j in idx],
                            feedforwards=[feedforwards[j] for j in idx], seeds=[seeds[j] for j in idx], **kw)
        for j, r in zip(idx, res):
            out[j] = r
    return out


def run_metrics(result: SimResult, lowpass_hz: float = 50.0) -> dict:
    """``{"commutation_mse": {dir: {filtered, unfiltered}}, "tracking_mse": m²}`` of one run."""
    return {"commutation_mse": commutation_mse(result.f_meas, result.f_star, result.sample_time, lowpass_hz),
            "tracking_mse": tracking_mse(result.e)}


def calibration_results(setup: Setup, cal: CalibrationResult) -> dict:
    """The ``calibration.*`` keys of results.json: initial, calibrated and (twin only) true ``k`` (N/A), ``ζ`` (rad)."""
    true = setup.true_k is not None
    return {"initial": {"k": cal.k_initial, "zeta": cal.zeta_initial},
            "calibrated": {"k": cal.k, "zeta": cal.zeta},
            "true": {"k": setup.true_k if true else None, "zeta": setup.true_zeta if true else None},
            "error": ({"k_relative": cal.k / setup.true_k - 1.0, "zeta_rad": cal.zeta - setup.true_zeta}
                      if true else None),
            "iterations": cal.iterations, "method": setup.config.calibration.method,
            "delta": setup.config.calibration.delta}


def identify_models(setup: Setup, data: list[CoilSetData], seed: int, progress=None, check_data: bool = True):
    """Algorithm 2 for every coil set; returns ``(pgnn, physics, [IdentifyResult])``.

    ``check_data=False`` skips the excitation check (the caller ran it and chose to go on).
    """
    ic = setup.config.identification
    pgnn, res = identify_all(data, setup.motor.pole_pitch, seed=seed, progress=_lm_progress(progress),
                             gain_widths=tuple(ic.gain_widths), cog_widths=tuple(ic.cog_widths),
                             gain_width_candidates=tuple(ic.gain_width_candidates),
                             activation=ic.activation, Lambda=ic.regularisation, ridge_output=ic.ridge_output,
                             n_starts=ic.starts, max_iter=ic.max_iterations, tol=ic.tol,
                             validation_fraction=ic.validation_fraction, check_data=check_data)
    physics = CombinedModel.from_coil_sets([r.physics_model for r in res])
    return pgnn, physics, res


def identify_sensorless_models(setup: Setup, data: list[CoilSetData], k, zeta, seed: int, progress=None,
                               check_data: bool = True):
    """Algorithm 2 without a force sensor for every coil set (:mod:`pgcomm.sensorless`); force columns unused.

    The y row of each coil set's PGNN is identified jointly with its Coulomb and viscous
    friction from the motion (moving mass :func:`sensorless_mass`); the x and z rows are the
    classical model with ``k`` (L,) N/A and ``ζ`` (L,) rad (e.g. a sensorless calibration).

    Returns:
        ``(CombinedModel, [IdentifyResult])``; each result's ``mechanics`` holds the friction.
    """
    from pgcomm.sensorless import sensorless_data, with_classical_rows

    ic = setup.config.identification
    motor = setup.motor
    mass = sensorless_mass(setup)
    sdata = [sensorless_data(d, motor.sample_time, motor.pole_pitch, mass, current_limit=motor.current_limit,
                             friction_velocity=ic.direction_velocity) for d in data]
    _, res = identify_all(sdata, motor.pole_pitch, seed=seed, progress=_lm_progress(progress),
                          gain_widths=tuple(ic.gain_widths), cog_widths=tuple(ic.cog_widths),
                          gain_width_candidates=tuple(ic.gain_width_candidates), activation=ic.activation,
                          Lambda=ic.regularisation, ridge_output=ic.ridge_output, n_starts=ic.starts,
                          max_iter=ic.max_iterations, tol=ic.tol, validation_fraction=ic.validation_fraction,
                          check_data=check_data)
    models = [with_classical_rows(r.model, float(k[l]), float(zeta[l]), motor.mu, motor.lever_arms[l])
              for l, r in enumerate(res)]
    return CombinedModel.from_coil_sets(models), res


def _lm_progress(progress):
    """Per-iteration callback of :func:`pgcomm.identify.identify` printing to ``progress`` every 10 iterations."""
    if progress is None:
        return None

    def show(info):
        progress.checkpoint()
        if progress.enabled and info["iteration"] % 10 == 0:
            progress.info(f"iteration {info['iteration']:3d}: best V = {info['best_cost']:.5g}, "
                          f"{info['active']}/{info['starts']} starts active")
    return show


def identify_spline_models(setup: Setup, data: list[CoilSetData], progress=None):
    """The physics-guided spline model of all coil sets and the mechanics from the same data (issue 15).

    Returns:
        ``(SplineFit, MechanicsFit)``: :func:`pgcomm.identify.spline.identify_spline` with the direction
        table's ``v_ε`` of ``[identification] direction_velocity``, and
        :func:`pgcomm.identify.mechanics.identify_mechanics` on the model's force.
    """
    from pgcomm.identify.mechanics import identify_mechanics
    from pgcomm.identify.spline import SplineOptions, identify_spline

    ic, motor = setup.config.identification, setup.motor
    fit = identify_spline(data, motor.pole_pitch, SplineOptions(direction_velocity=ic.direction_velocity), progress)
    mech = identify_mechanics(data, fit.model, motor.sample_time, motor.pole_pitch, ic.direction_velocity)
    return fit, mech


def identify_direction_models(setup: Setup, data: list[CoilSetData], start_models, seed: int, progress=None):
    """The PGNN with the direction term ``C^l s(ẏ)`` (and the harmonics if configured) per coil set.

    Warm-started from ``start_models`` (the paper's PGNN per coil set, same widths): the
    extension adds only linear columns, which Proposition 1 sets for any hidden weights, so
    one start refined from the trained hidden layers replaces the random restarts.

    Returns:
        ``(CombinedModel, [IdentifyResult])``.
    """
    from pgcomm.identify import identify

    ic = setup.config.identification
    res = []
    for l, (d, m0) in enumerate(zip(data, start_models)):
        # the widths of the start model (chosen by validation per coil set)
        gw = None if m0.gain_nets is None else m0.gain_nets[0].widths
        cw = None if m0.cog_net is None else m0.cog_net.widths
        res.append(identify(d, setup.motor.pole_pitch, seed=seed + l, gain_widths=gw,
                            cog_widths=cw, activation=ic.activation, Lambda=ic.regularisation,
                            ridge_output=ic.ridge_output, n_starts=1, max_iter=ic.max_iterations, tol=ic.tol,
                            validation_fraction=ic.validation_fraction, check_data=False,
                            harmonics=ic.direction_harmonics, direction=True,
                            direction_velocity=ic.direction_velocity, start_from=m0))
    return CombinedModel.from_coil_sets([r.model for r in res]), res


def identification_results(res, seconds_total: float, res_direction=None) -> dict:
    """The ``identification.*`` keys of results.json from ``[IdentifyResult]`` and the total time (s).

    Per coil set also ``cost_y_pgnn`` (the paper's PGNN) and, with ``res_direction``,
    ``cost_y_pgnn_direction`` and ``direction_term`` (``C^l``, N, N, N·m): the y cost
    ``mean (Fy - F̂y)²`` (N²) of the paper's Remark on training data.
    """
    sets = []
    for l, r in enumerate(res):
        d = r.to_dict()
        d["cost_y_pgnn"] = d.get("cost_y")
        if res_direction is not None:
            rd = res_direction[l]
            d["cost_y_pgnn_direction"] = rd.cost_y
            d["direction_term"] = [float(c) for c in np.asarray(rd.model.C)]
            d["cost_pgnn_direction"] = rd.cost_pgnn
            d["cost_pgnn_direction_validation"] = rd.cost_pgnn_validation
            d["seconds_direction"] = rd.seconds
        sets.append(d)
    return {"coil_sets": sets, "seconds_total": seconds_total}


#: Cruise speed of :func:`sensorless_cogging_table` as a fraction ``c`` of ``d_m · f_bw``: the
#: pole-pitch period ``d_m / v`` is then seen at ``f = c · f_bw``. For the loop-shaping tuning of
#: :meth:`pgcomm.control.PID.tuned` (normalised by the crossover, mass matched) the complementary
#: sensitivity is ``|T(j 0.1 ω_b)| = 1.020`` with 0.015 rad lag (``|T - 1| = 0.025``), against
#: ``|T - 1| = 0.07`` at 0.15 and 0.14 at 0.2 (resonance peak 1.31 near 0.5): at ``c = 0.1`` the
#: effort reproduces a disturbance at the pole-pitch period within 2.5 %.
EFFORT_SPEED_FRACTION = 0.1


def loop_settling_time(setup: Setup, decay: float = 0.01) -> float:
    """Time (s) for the slowest closed-loop mode of the position loop to decay to ``decay``.

    Continuous-time loop of the tuned PID (``kp``, ``ki``, ``kd``, output low-pass ``ω_lp``)
    around the mass the feedback is tuned for (``[controller] mass``, what a drive knows):
    roots of ``m s³ (1 + s/ω_lp) + kd s² + kp s + ki``; ``ln(1/decay) / min |Re p|``. With
    :meth:`~pgcomm.control.PID.tuned` the slowest pole is the integrator's, ``≈ -0.18 ω_b``
    (0.67 s to 1 % at 6 Hz).
    """
    pid, m = setup.pid, setup.config.controller.mass
    w_lp = 2 * np.pi * pid.lowpass_hz
    poles = np.roots([m / w_lp, m, pid.kd, pid.kp, pid.ki])
    return float(math.log(1.0 / decay) / np.min(np.abs(poles.real)))


def sensorless_cogging_table(setup: Setup, classical_law, feedforward: Feedforward, seed: int = 0,
                             speed: float | None = None):
    """The drives' anti-cogging table without a force sensor: the position controller's effort at
    slow constant velocity, both directions averaged (:func:`pgcomm.compensation.fit_effort_table`).

    The reference rests at the low end of the set-up's span, moves to the high end at ``speed``,
    rests and moves back (third-order moves with the configured ``a_max``, ``j_max``, rests of the
    configured dwell). Of the closed-loop run with ``classical_law`` and ``feedforward`` only
    settled constant-velocity samples are kept: reference acceleration 0 at the sample and the next
    (the feedforward looks one sample ahead), ``|v_ref|`` at the cruise speed, and at least
    :func:`loop_settling_time` after the cruise began (the loop's transient from the start of the
    move has decayed to 1 %). They are split by direction and indexed by the encoder position.

    Default ``speed``: ``min(slowest configured reference velocity, c · d_m · f_bw)`` with
    ``c =`` :data:`EFFORT_SPEED_FRACTION` (0.1): a disturbance with the pole pitch's period
    ``d_m / v`` then lies at a tenth of the loop's bandwidth, where the effort follows it within
    2.5 %; shorter periods are followed less well. The distance lost to settling at the start of
    each pass is ``v · t_settle ≈ 0.4 d_m`` for the default speed and tuning.

    Args:
        setup: the resolved experiment.
        classical_law: the (calibrated) classical commutation law the drive runs.
        feedforward: its feedforward (:func:`tune_feedforward`).
        seed: sensor-noise seed of the run.
        speed: cruise speed (m/s), > 0; default as above.

    Returns:
        ``(CoggingTable, info)`` with ``info``: ``speed`` (m/s), ``samples`` (``{"positive": n,
        "negative": n}`` samples used), ``duration`` (s of machine time, the reference's),
        ``settling_time`` (s), ``y_range`` (m, the table's grid ends: the span) and ``seconds``
        (wall time of the run and fit).

    Raises:
        ConfigError: a speed that is not > 0, a reference outside the plant, or a stroke too short
            to leave settled samples in both directions at the same positions.
    """
    import time

    from pgcomm.compensation import fit_effort_table

    t0 = time.perf_counter()
    ref, speed, pos, neg, settle = effort_reference(setup, speed)
    lo, hi = setup.config.reference.span
    res = run_laws(setup, [classical_law], ref, [feedforward], seeds=[seed])[0]
    fy = res.f_star[:, 0]
    try:
        table = fit_effort_table(res.y_meas[pos], fy[pos], res.y_meas[neg], fy[neg],
                                 setup.config.evaluation.cogging_table_entries, (lo, hi))
    except ValueError as err:
        raise ConfigError(f"sensorless cogging table at {speed:.4g} m/s: {err}") from None
    info = {"speed": speed, "samples": {"positive": int(pos.sum()), "negative": int(neg.sum())},
            "duration": ref.duration, "settling_time": settle, "y_range": (lo, hi),
            "seconds": time.perf_counter() - t0}
    return table, info


def effort_reference(setup: Setup, speed: float | None = None):
    """The reference of :func:`sensorless_cogging_table` and the samples it keeps, checked without simulating.

    Args:
        setup: the resolved experiment; speed: cruise speed (m/s) or ``None`` for the default
            (:func:`sensorless_cogging_table`).

    Returns:
        ``(reference, speed (m/s), positive (N,) bool, negative (N,) bool, settling time (s))``: the
        settled constant-velocity samples of each direction.

    Raises:
        ConfigError: a speed that is not > 0, a reference outside the plant, or a stroke too short to
            leave settled samples in both directions at the same positions.
    """
    rc = setup.config.reference
    lo, hi = rc.span
    if speed is None:
        speed = min(min(rc.velocities),
                    EFFORT_SPEED_FRACTION * setup.motor.pole_pitch * setup.config.controller.bandwidth_hz)
    speed = float(speed)
    if not (math.isfinite(speed) and speed > 0):
        raise ConfigError(f"sensorless cogging table: speed = {speed} m/s, expected > 0")
    ts = setup.motor.sample_time
    ref = trajectory.sequence([(hi, speed, rc.a_max, rc.j_max), (lo, speed, rc.a_max, rc.j_max)], ts,
                              dwell=rc.dwell, start=lo, initial_dwell=rc.dwell)
    check_reference(setup, ref, "the sensorless cogging-table reference")

    settle = loop_settling_time(setup)
    a_next = np.concatenate([ref.a[1:], ref.a[-1:]])
    cruise = (ref.a == 0) & (a_next == 0) & np.isclose(np.abs(ref.v), speed, rtol=1e-9, atol=0.0)
    # time since the current cruise began: samples in a run of cruise samples, times ts
    run_start = np.maximum.accumulate(np.where(~cruise, np.arange(len(ref)), -1))
    since = (np.arange(len(ref)) - run_start) * ts
    keep = cruise & (since >= settle)
    pos, neg = keep & (ref.v > 0), keep & (ref.v < 0)
    if (pos.sum() < 2 or neg.sum() < 2
            or not min(ref.r[pos].max(), ref.r[neg].max()) > max(ref.r[pos].min(), ref.r[neg].min())):
        raise ConfigError(f"sensorless cogging table: the stroke [{lo:.6g}, {hi:.6g}] m at {speed:.4g} m/s leaves "
                          "no positions passed in both directions at settled constant velocity "
                          f"({int(pos.sum())} positive, {int(neg.sum())} negative samples after the loop's "
                          f"settling time {settle:.3g} s); lower the speed or lengthen the stroke")
    return ref, speed, pos, neg, settle
