"""Experiment settings: the schema of an experiment config TOML (frozen dataclasses).

An experiment config is a TOML file (read by :func:`pgcomm.io.config.load_experiment`) whose tables map onto
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
    [rotary]                   # a rotary motor's identification: RotaryIdentifyOptions, e.g. current_filter = 0.08
    [rotary_experiment]        # pgcomm reproduce on a rotary motor: RotarySettings, [rotary_experiment.standstill]

Unknown keys are refused with the closest valid name. Every field carries its range, unit and
a hint in its metadata (:func:`pgcomm.io.config.load_dataclass` reads them for the messages).
Resolving the settings against a plant, and reading a set-up from files, is :mod:`pgcomm.setup`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from pgcomm.control import PID
from pgcomm.mechanics import Mechanics
from pgcomm.sensors import Sensors
from pgcomm.twin import TwinParams
from pgcomm.identify.options import IdentifyOptions

__all__ = ["ControllerConfig", "ReferenceConfig", "CalibrationOptions", "CalibrationConfig", "IdentificationConfig",
           "EvaluationConfig", "StandstillPlan", "RotarySettings", "RotaryIdentifyOptions", "ExperimentConfig"]


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


#: The estimators of ``ĉ_1, ĉ_2`` (:mod:`pgcomm.calibration`).
CALIBRATION_METHODS = ("paper", "offset", "sensorless")


@dataclass(frozen=True)
class CalibrationOptions:
    """The settings of Algorithm 1 (:func:`pgcomm.calibration.calibrate`) as one object (``[calibration]`` of an
    experiment TOML gives them, :meth:`CalibrationConfig.options`).

    Attributes:
        method: the estimator of ``ĉ_1, ĉ_2``: ``"paper"`` (eq. Ci per data set), ``"offset"`` or ``"sensorless"``
            (:mod:`pgcomm.calibration`).
        n_bins: offset bins per direction over the stroke (``"offset"``, ``"sensorless"``).
        gain_bins: bins of the gain ``c_i(y)`` along the stroke.
        y_range: ``(lo, hi)`` (m) the bins span; ``None``: the data's range.
        min_speed: samples with ``|v| <= min_speed`` (m/s) are left out (standstill, reversals).
        delta: ``Δ`` (rad), the drive's phase offset of the two data sets, ``0 < |Δ| <= π/4``.
        iterations: at most this many passes of :func:`~pgcomm.calibration.calibrate`.
        tol: :func:`~pgcomm.calibration.calibrate` stops when ``max |Δk̂/k̂|`` and ``max |Δζ̂|`` (rad) are both below it.
    """

    method: str = "offset"
    n_bins: int = 40
    gain_bins: int = 8
    y_range: tuple[float, float] | None = None
    min_speed: float = 0.01
    delta: float = math.pi / 4
    iterations: int = 1
    tol: float = 1e-4

    def __post_init__(self):
        if self.method not in CALIBRATION_METHODS:
            raise ValueError(f"method must be 'paper', 'offset' or 'sensorless', got {self.method!r}")


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

    def options(self, **changes) -> CalibrationOptions:
        """These settings as the :class:`CalibrationOptions` of Algorithm 1.

        Args:
            changes: fields of :class:`CalibrationOptions` that differ from the settings for one
                call (e.g. ``method="sensorless"`` without a force sensor).
        """
        fields = dict(method=self.method, n_bins=self.n_bins, delta=self.delta, iterations=self.iterations,
                      tol=self.tol)
        fields.update(changes)
        return CalibrationOptions(**fields)


@dataclass(frozen=True)
class IdentificationConfig:
    """Algorithm 2 settings (paper defaults: widths 2 and 16, tanh, Λ = 0.1 I)."""

    gain_widths: tuple[int, ...] = field(default=(2,), metadata={"range": (1, 256), "hint": "neurons per hidden layer"})
    cog_widths: tuple[int, ...] = field(default=(16,), metadata={"range": (1, 256), "hint": "neurons per hidden layer"})
    #: single-layer gain widths to choose from per coil set by validation cost; empty (default) =
    #: ``gain_widths``, the paper's. On the twin the validation split picks width 8: y 2.3 against 3.7 N²
    #: with width 2, tracking better on the long and fast references and worse on the slow one.
    gain_width_candidates: tuple[int, ...] = field(default=(), metadata={"range": (1, 256),
                                                                         "hint": "neurons per hidden layer"})
    activation: str = "tanh"
    regularisation: float = field(default=0.1, metadata={"range": (0.0, 1e6), "hint": "Lambda = regularisation * I must be >= 0"})
    starts: int = field(default=8, metadata={"range": (1, 256), "hint": "random starts, run batched (memory grows with starts): 1 to 256"})
    #: the cap of each phase of Algorithm 2 (the final phase runs until it converges: a safety net there)
    max_iterations: int = field(default=400, metadata={"range": (1, 100000), "hint": "LM iterations per start"})
    #: the first phase's budget: the random starts screened on a subsample, at most max_iterations
    screen_iterations: int = field(default=300, metadata={"range": (1, 100000), "hint": "LM iterations per start"})
    validation_fraction: float = field(default=0.2, metadata={"range": (0.0, 0.5), "hint": "0 trains on everything"})
    ridge_output: float = field(default=0.0, metadata={"range": (0.0, 1e6)})
    tol: float = field(default=1e-9, metadata={"range": (0.0, 1.0)})
    #: a coil set's PGNN has converged when the Gauss–Newton step from where it stands would lower its cost by at
    #: most this share (:class:`~pgcomm.identify.options.IdentifyOptions`)
    decrease_tol: float = field(default=1e-4, metadata={"range": (0.0, 0.5), "hint": "a share of the cost"})
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
        if self.starts < 1 or self.max_iterations < 1 or self.screen_iterations < 1:
            raise ValueError(f"starts = {self.starts}, max_iterations = {self.max_iterations}, screen_iterations = "
                             f"{self.screen_iterations}: all must be >= 1")
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
        fields = dict(gain_widths=self.gain_widths, cog_widths=self.cog_widths,
                      gain_width_candidates=self.gain_width_candidates, activation=self.activation,
                      regularisation=self.regularisation, ridge_output=self.ridge_output, starts=self.starts,
                      max_iterations=self.max_iterations, screen_iterations=self.screen_iterations, tol=self.tol,
                      decrease_tol=self.decrease_tol,
                      validation_fraction=self.validation_fraction,
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
class StandstillPlan:
    """A standstill sweep: ``points`` angles per revolution, ``settle`` and ``average`` samples per angle."""

    points: int = field(default=3600, metadata={"range": (16, 10_000_000), "hint": "angles per revolution"})
    settle: int = field(default=30, metadata={"range": (0, 1_000_000), "hint": "samples to settle at each angle"})
    average: int = field(default=20, metadata={"range": (1, 1_000_000), "hint": "samples averaged at each angle"})

    def duration(self, sample_time: float) -> float:
        """Seconds the sweep takes on the rig (both directions)."""
        return 2 * self.points * (self.settle + self.average) * sample_time


@dataclass(frozen=True)
class RotarySettings:
    """Sizes of the rotary experiment.

    Attributes:
        revolutions: revolutions per running-log segment (two speeds, both directions).
        speed_shares: mean speeds of the segments as shares of the alias guard's speed limit.
        dither_hz: frequencies of the q-current dither the drive injects in the running logs (Hz). The twin has no
            mains pickup; on a rig keep them a few hertz off the mains' harmonics, where a pickup within a natural bin
            of a dither cannot be told from it (:mod:`pgcomm.rotary.time_lines`).
        dither_share: dither amplitude as a share of the current limit (at most; less where the
            speed swing would exceed ``swing`` of the mean speed).
        swing: largest speed swing the dither may cause (share of the mean speed).
        standstill: the sweep (points, settle, average).
        eval_share: evaluation speed as a share of the speed limit.
        eval_revolutions: revolutions per direction of each evaluation run.
        log_budget_share: the running logs may take at most this share of the standstill sweep's rig
            time: while the identification's standard error says the cogging or the ripple is not
            resolved (within :data:`pgcomm.rotary.identify.RESOLVED_SHARE` of its RMS with probability
            :data:`~pgcomm.rotary.identify.RESOLVED_CONFIDENCE`), more rounds of the
            same references are recorded, as many as the standard error asks for and the budget allows
            (what an engineer at the rig does: log until the map is resolved, then stop).
        host_clock_speed_shares: the speeds of the running logs where the first round's angle carries a host's clock
            (:mod:`pgcomm.rotary.host_clock`: each row stamped when a PC read it, the values from the drive's last
            cycle before), as shares of the alias guard's limit; the rounds identified then run at these, the first
            round set aside (empty: keep ``speed_shares``). Slower, because what the identification reads of the
            logs' timing (the current's delay, a report filter, a PLL's lag) is blurred by the clock's noise, and a
            timing error ``δτ`` at speed ``ω`` shifts order ``h`` by the phase ``h ω δτ``; the clock's own angle noise
            ``ω σ_t`` falls with the speed too. Logs stamped by the drive keep the faster ``speed_shares``: they
            excite the dither and the back-EMF more, and their timing reads sharply.
        stop_when_resolved: stop logging as soon as both maps are resolved (``True``), or record the whole
            budget (``False``, the default): a map resolved to 5 % RMS can still miss an order outside the
            basis that the screening would find in a longer log, and a low one costs the speed loop more than
            its share of the RMS (a low outside order left unseen can cost the law most of its gain over the
            standstill table in the speed loop).
    """

    revolutions: float = field(default=2.0, metadata={"range": (0.01, 1e4), "unit": "rev"})
    speed_shares: tuple[float, ...] = field(default=(0.3, 0.5), metadata={"range": (1e-3, 1.0),
                                                                         "hint": "shares of the speed limit"})
    host_clock_speed_shares: tuple[float, ...] = field(default=(0.1, 0.2), metadata={
        "range": (1e-3, 1.0), "hint": "shares of the speed limit, used where the logs carry a host's clock"})
    dither_hz: tuple[float, ...] = field(default=(61.0, 83.0, 107.0), metadata={"range": (0.0, 1e5), "unit": "Hz"})
    dither_share: float = field(default=0.5, metadata={"range": (0.0, 1.0), "hint": "a share of the current limit"})
    swing: float = field(default=0.8, metadata={"range": (0.0, 1.0), "hint": "a share of the mean speed"})
    standstill: StandstillPlan = field(default_factory=StandstillPlan)
    eval_share: float = field(default=0.5, metadata={"range": (1e-3, 1.0), "hint": "a share of the speed limit"})
    eval_revolutions: float = field(default=1.0, metadata={"range": (0.01, 1e4), "unit": "rev"})
    log_budget_share: float = field(default=0.5, metadata={"range": (0.0, 100.0),
                                                           "hint": "a share of the standstill sweep's rig time"})
    stop_when_resolved: bool = False

    def __post_init__(self):
        for name in ("speed_shares", "host_clock_speed_shares", "dither_hz"):
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
        if not self.speed_shares:
            raise ValueError("speed_shares = []: give at least one running speed, e.g. [0.3, 0.5]")


#: What :class:`RotaryIdentifyOptions` reads from the logs when told ``"detect"``.
DETECT = "detect"


@dataclass(frozen=True)
class RotaryIdentifyOptions:
    """How :func:`pgcomm.rotary.identify.identify` reads a rotary motor's running logs: the ``[rotary]`` table of an
    experiment TOML, or built in Python and passed whole.

    Every reading of the logs is ``"detect"`` by default (found from the logs, each a search over tens of fits); a
    value fixes it, as :meth:`pgcomm.rotary.identify.RotaryIdentification.reading` reports it, to read more logs
    of the same drive the same way without searching again. TOML has no null: where ``None`` is a value, write
    ``"none"`` (``current_lag``: ``"held"``).

    Attributes:
        orders: harmonics per revolution of the cogging, ripple and direction maps, three arrays of integers
            (default ``None``: from the motor's slots and poles, :meth:`pgcomm.rotary.regression.Orders.for_motor`).
            An :class:`~pgcomm.rotary.regression.Orders` is taken as it is.
        torque_sensor: identify from a ``torque`` column (N·m) instead of the motion.
        min_samples_per_period: the alias guard: samples per period of the highest modelled order (``None``:
            :data:`pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD`).
        taps: the acceleration filter's Hann window length, samples (``None``:
            :data:`pgcomm.rotary.regression.FILTER_TAPS`).
        ridge: a fixed relative ridge weight instead of the one validated on held-out time blocks (``None``).
        extra_orders: let the logs add cogging and ripple orders outside ``orders``.
        encoder_step: the encoder's step (rad) for the quantisation correction of the acceleration, ``"detect"``
            (from each log's angle) or ``None`` (no correction).
        current_delay: samples (an integer) by which the logged q-current lags the current that acted, or
            ``"detect"``.
        angle_pll: ``(ω_n rad/s, ζ)`` (``ζ`` 1 when left out) of the drive's PLL whose estimate the logged angle is,
            ``None`` for the encoder's own angle, or ``"detect"``.
        time_lines: frequencies (Hz) of time-periodic disturbances to fit beside the maps, ``()`` for none, or
            ``"detect"``.
        back_emf: read the logged q-voltage (``vq_1``) where every log has it (ripple check, back-EMF constant).
        current_lag: the logged current between samples: ``None`` held, a lag in samples (``|L| ≤ 0.5``) of the
            smooth curve through the samples, or ``"detect"``.
        current_noise: the logged current's white noise (A) the fit corrects for, ``None`` for no correction, or
            ``"detect"``.
        current_filter: the time constant (s, 0 to 10; ``0`` for none) of the drive's first-order report filter, or
            ``"detect"``.
        pin: maps to pin whatever the logs' information on them: ``"ripple"``, ``"direction"``.

    Raises:
        ValueError: one line naming the option and the value expected (the TOML loader prefixes the file and table).
    """

    orders: tuple[tuple[int, ...], ...] | None = None
    torque_sensor: bool = False
    min_samples_per_period: float | None = field(default=None, metadata={"range": (1.0, 1e3),
                                                                         "hint": "samples per period"})
    taps: int | None = field(default=None, metadata={"range": (2, 10_000), "hint": "samples"})
    ridge: float | None = field(default=None, metadata={"range": (0.0, 1e6)})
    extra_orders: bool = True
    encoder_step: float | str | None = DETECT
    current_delay: int | str = DETECT
    angle_pll: tuple[float, ...] | str | None = DETECT
    time_lines: tuple[float, ...] | str = DETECT
    back_emf: bool = True
    current_lag: float | str | None = DETECT
    current_noise: float | str | None = DETECT
    current_filter: float | str = DETECT
    pin: tuple[str, ...] = ()

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        def word(name, value, kind, *words):
            # the words a TOML file writes for None or for "detect"
            if isinstance(value, str):
                w = value.strip().lower()
                if w not in words:
                    raise ValueError(f"{name} = {value!r}: expected {' or '.join(map(repr, words))}, or {kind}")
                return w
            return value

        if self.orders is not None:
            o = self.orders
            maps = (o.cogging, o.ripple, o.direction) if hasattr(o, "cogging") else tuple(o)
            if len(maps) != 3:
                raise ValueError(f"orders: {len(maps)} arrays, expected 3 (cogging, ripple, direction)")
            put("orders", tuple(tuple(int(h) for h in m) for m in maps))
            if any(h < 0 for m in self.orders for h in m):
                raise ValueError("orders: harmonics per revolution are integers >= 0")
        if self.min_samples_per_period is not None and not 1.0 <= self.min_samples_per_period <= 1e3:
            raise ValueError(f"min_samples_per_period = {self.min_samples_per_period}: expected 1 to 1000 samples")
        if self.taps is not None and not 2 <= self.taps <= 10_000:
            raise ValueError(f"taps = {self.taps}: expected 2 to 10000 samples")
        step = word("encoder_step", self.encoder_step, "a step in rad", DETECT, "none")
        put("encoder_step", None if step == "none" else step)
        if not (self.encoder_step in (None, DETECT) or (isinstance(self.encoder_step, (int, float))
                                                        and 0 < self.encoder_step < math.pi)):
            raise ValueError(f"encoder_step = {self.encoder_step}: the encoder's step in rad (above 0), "
                             "\"detect\" or \"none\"")
        delay = word("current_delay", self.current_delay, "an integer number of samples", DETECT)
        if delay != DETECT and (isinstance(delay, bool) or not isinstance(delay, int)):
            raise ValueError(f"current_delay = {delay!r}: an integer number of samples, e.g. 1, or \"detect\"")
        put("current_delay", delay)
        pll = word("angle_pll", self.angle_pll, "[rad/s, damping]", DETECT, "none")
        if pll == "none":
            pll = None
        elif pll != DETECT and pll is not None:
            pll = tuple(float(v) for v in (pll if isinstance(pll, (tuple, list)) else (pll,)))
            pll = pll + (1.0,) if len(pll) == 1 else pll
            if len(pll) != 2 or not all(math.isfinite(v) and v > 0 for v in pll):
                raise ValueError(f"angle_pll = {list(pll)}: a natural frequency in rad/s and optionally a damping, "
                                 "both positive (e.g. [1000.0, 0.707]), \"detect\" or \"none\"")
        put("angle_pll", pll)
        lines = word("time_lines", self.time_lines, "frequencies in Hz", DETECT, "none")
        if lines == "none":
            lines = ()
        elif lines != DETECT:
            lines = tuple(float(f) for f in lines)
            if not all(math.isfinite(f) and f > 0 for f in lines):
                raise ValueError(f"time_lines = {list(lines)}: frequencies in Hz, positive, \"detect\" or \"none\"")
        put("time_lines", lines)
        lag = word("current_lag", self.current_lag, "a lag in samples", DETECT, "held")
        lag = None if lag == "held" else lag
        if lag not in (None, DETECT) and not (math.isfinite(lag) and abs(lag) <= 0.5):
            raise ValueError(f"current_lag = {lag}: \"held\", or a lag in samples between -0.5 and 0.5 (1/(2K) for K "
                             "control cycles per logged sample), or \"detect\"")
        put("current_lag", None if lag is None else lag if lag == DETECT else float(lag))
        noise = word("current_noise", self.current_noise, "a noise in A", DETECT, "none")
        noise = None if noise == "none" else noise
        if noise not in (None, DETECT) and not (math.isfinite(noise) and noise >= 0):
            raise ValueError(f"current_noise = {noise}: the logged current's noise in A (a standard deviation, "
                             ">= 0), \"detect\" or \"none\"")
        put("current_noise", noise if noise in (None, DETECT) else float(noise))
        tau = word("current_filter", self.current_filter, "a time constant in s", DETECT, "none")
        tau = 0.0 if tau == "none" else tau
        if tau != DETECT and not (math.isfinite(tau) and 0 <= tau <= 10):
            raise ValueError(f"current_filter = {tau}: the report filter's time constant in s (0 to 10), "
                             "\"detect\" or \"none\"")
        put("current_filter", tau if tau == DETECT else float(tau))
        put("pin", tuple(self.pin))
        unknown = [m for m in self.pin if m not in ("ripple", "direction")]
        if unknown:
            raise ValueError(f"pin = {list(self.pin)}: maps to pin are \"ripple\" and \"direction\"")

    def with_reading(self, reading) -> "RotaryIdentifyOptions":
        """These options with the logs' reading fixed as an identification found it
        (:meth:`pgcomm.rotary.identify.RotaryIdentification.reading`): the current's delay and lag, the angle's PLL,
        the time-periodic disturbances and the report filter. The current's noise stays as it is (it is read from
        the logs at hand)."""
        return replace(self, current_delay=reading.current_delay, current_lag=reading.current_lag,
                       angle_pll=reading.angle_pll, time_lines=reading.time_lines,
                       current_filter=reading.current_filter)


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
    rotary: RotaryIdentifyOptions = field(default_factory=RotaryIdentifyOptions)
    rotary_experiment: RotarySettings = field(default_factory=RotarySettings)

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
