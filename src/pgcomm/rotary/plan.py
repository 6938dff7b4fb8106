"""The rotary experiment plan: the speed-loop runs a drive records so that its logs determine the maps.

What :func:`pgcomm.rotary.identify.identify` reads from running logs, and what each part of the plan is for:

* the **cogging** ``c(θ)``: every angle passed at a steady speed;
* the **direction map** ``d(θ)`` (Coulomb friction and its angle dependence): both directions; from one direction it
  folds into the cogging;
* the **viscous friction** ``b`` beside the Coulomb term: several speeds per direction; they also spread the effects
  that grow with speed (the logged current's delay, a drive PLL's lag) so that the reading can tell them apart;
* ``J/k0`` and the **torque-constant ripple** ``r(θ)``: a q-current that varies at each angle independently of the
  angle. At a constant speed the current is a function of the angle alone and the ripple, which multiplies it, cannot
  be told from the cogging; so each run carries a q-current **dither** added to the drive's speed loop.

**Speeds** (:func:`segment_speeds`). The alias guard (:func:`pgcomm.rotary.regression.max_speed`) keeps only windows
whose highest modelled order (:meth:`~pgcomm.rotary.regression.Orders.for_motor`: ``3 LCM(Q, 2p)`` on most motors)
has at least :data:`~pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD` samples per period at the log's period ``T_s``:
``ω_max = 2π / (T_s · 3 · h_max)``. The fastest run cruises at ``guard_margin · ω_max / (1 + swing)``, so that with
the dither's largest swing it stays within the guard with a margin for the cogging's own speed ripple, and at most at
``top_share · ω_max`` (0.2): the rows are stamped by the host, whose clock blurs the logs' timing, and a timing error
costs a phase in proportion to the speed (:class:`RotaryPlanSettings`); the others
sit geometrically below it down to ``lowest_share`` of it, each in both directions. Without the slot count the
highest order is unknown: the plan then takes :data:`pgcomm.rotary.slots.MAX_ORDER`, the highest order the slot
count's detection examines.

**The dither** (:func:`dither_amplitudes`). ``Σ_k a_k cos(2π f_k τ)`` added to the q-current while the run cruises
(``τ`` from the cruise's start). On a free rotor (a speed loop that answers the dither only shrinks what follows) it
changes the speed by::

    Δω(τ) = Σ_k a_k sin(2π f_k τ) / ((J/k0) 2π f_k),      |Δω| ≤ Σ_k a_k / ((J/k0) 2π f_k)

zero at the start (the cosine's integral is a sine: no mean offset). Each ``a_k`` is at most
``swing · |ω| · (J/k0) · 2π f_k / n``, so the speed stays within ``(1 ± swing) ω``: it keeps its sign. Each is also at
most ``dither_share · current_limit / n``. ``J/k0`` (A·s²/rad) is the motor TOML's ``inertia / k_t`` or, where it has
none, a first round's identified one; without either the first round runs without a dither and its logs give ``J/k0``.
The frequencies (:func:`dither_frequencies`) sit in an octave below ``1/(8 T_s)`` (at most
:data:`DITHER_MAX_HZ`) and at least ``mains_margin_hz`` from every harmonic of 50 and 60 Hz: a mains pickup within a
natural bin of a dither cannot be told from it (:mod:`pgcomm.rotary.time_lines`).

**Durations.** A first round (no logs yet) runs every speed for the same cruise time (:func:`first_round_cruise`):
:attr:`RotaryPlanSettings.first_round_seconds`, longer where the fastest run would not pass
:attr:`RotaryPlanSettings.first_round_revolutions` in it: a documented default, not a standard error. Equal times,
not equal revolutions: the slow runs are there for the friction and the readings that grow with speed, and a
revolution at each would spend most of the round where the dither, bounded by the speed's swing, is smallest (the
ripple's information grows as the dither's power, the square of the speed).
Its logs give each map's standard error and the log time that would resolve it
(``identification.standard_error[map].log_time_factor_to_resolve``, which assumes the noise part falls as the square
root of the log time at the same excitation); :func:`refined_plan` plans the rest: ``(F − 1)`` times the first
round's log time, ``F`` the largest finite factor over the cogging, the ripple and the direction map, the runs in the
first round's proportions. A map whose factor is infinite (the ridge, the encoder's rounding or a reading sets it) is
not resolved by more of the same logs; the plan names it and why.

:func:`first_plan` and :func:`refined_plan` build a :class:`RotaryPlan`; :mod:`pgcomm.io.rotary_plan` writes it as
reference files, ``plan.md``, a column map and a script for the drive.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.regression import MIN_SAMPLES_PER_PERIOD, Orders, max_speed
from pgcomm.rotary.slots import count_slots, MAX_ORDER
from pgcomm.rotary.identify import identify, resolution_verdict

__all__ = ["RotaryPlanSettings", "Run", "RotaryPlan", "FirstRound", "DRIVES", "DRIVE_COLUMNS", "DITHER_MAX_HZ",
           "highest_order", "segment_speeds", "first_round_cruise", "dither_frequencies", "dither_amplitudes",
           "swing_bound",
           "first_plan", "refined_plan", "read_first_round", "logs_as_data", "MAPS"]

#: Drives a plan can be written for: a script using the drive's own Python package, or CSV references only.
DRIVES = ("moteus", "odrive", "generic")

#: The log-format columns each drive's script writes, under the drive's own names and units:
#: ``{drive: {log-format name: (column in the script's CSV, unit in the column map or None for SI)}}``. The scripts
#: (:mod:`pgcomm.rotary.drive_scripts`) write exactly these names; ``columns.toml`` maps them back.
DRIVE_COLUMNS = {
    "moteus": {"t": ("time_s", None), "theta": ("position", "rev"), "velocity": ("velocity", "rev/s"),
               "iq_1": ("q_current", None), "id_1": ("d_current", None)},
    "odrive": {"t": ("time_s", None), "theta": ("pos_estimate", "rev"), "iq_1": ("Iq_measured", None),
               "id_1": ("Id_measured", None)},
    "generic": {"t": ("t", None), "theta": ("theta", "rad"), "velocity": ("velocity", "rad/s"),
                "iq_1": ("iq_1", None), "id_1": ("id_1", None)},
}

#: The maps whose standard errors set the durations (``identification.standard_error`` keys).
MAPS = ("cogging", "ripple", "direction")

#: Highest dither frequency (Hz): above the speed loops of common drives (the twin's peaks near 150-180 Hz,
#: :mod:`pgcomm.rotary.time_lines`) the loop hardly answers, below the current loop's bandwidth.
DITHER_MAX_HZ = 110.0
#: Fewest log samples per period of the fastest dither component.
DITHER_MIN_SAMPLES = 8.0
#: Mains frequencies (Hz) whose harmonics the dither avoids.
MAINS_HZ = (50.0, 60.0)


@dataclass(frozen=True)
class RotaryPlanSettings:
    """Sizes of a rotary plan (defaults in brackets).

    Attributes:
        speeds: cruise speeds per direction [4], geometric from ``lowest_share`` of the fastest to the fastest.
        lowest_share: slowest speed as a share of the fastest [0.25]; 0 < share ≤ 1.
        guard_margin: the fastest run's speed with the dither's swing, as a share of the alias guard's limit [0.9]: the
            rest is room for the cogging's own speed ripple.
        top_share: the fastest run's cruise speed as a share of the alias guard's limit, at most [0.2, as ``pgcomm
            reproduce``'s ``host_clock_speed_shares``]. The plan's script stamps each row on the host when it reads the
            drive, and a host's clock blurs what the identification reads of the logs' timing (the current's delay, a
            report filter, a PLL's lag): a timing error ``δτ`` costs order ``h`` the phase ``h ω δτ``, less at lower
            speeds (:attr:`pgcomm.settings.RotarySettings.host_clock_speed_shares`).
        swing: the dither's largest speed swing as a share of the run's speed [0.8, as ``pgcomm reproduce``'s running
            logs]; 0 < swing < 1 keeps the sign. The dither's current at the fastest run grows as
            ``swing / (1 + swing)``, the ripple's information as its square (``python bench/rotary_plan.py`` compares
            swings on the twin).
        dither_share: the dither's amplitudes summed, as a share of the motor's ``current_limit`` at most [0.5].
        dither_count: frequencies in the dither [3].
        mains_margin_hz: least distance of a dither frequency from every harmonic of 50 and 60 Hz [3 Hz].
        ramp_seconds: the speed's raised-cosine ramp at each end of a run, at least [0.5 s]; longer where the ramp's
            current ``(J/k0) α`` would exceed a quarter of the current limit.
        first_round_revolutions: a first round's fastest run passes at least this many revolutions [1].
        first_round_seconds: a first round's cruise per run, at least [4 s] (the identification's sandwich covariance
            takes one-second time blocks).
        min_cruise_seconds: a refined run's cruise at least [2 s].
        max_revolutions: revolutions per run at most [200]; a longer cruise is split into repeats that alternate the
            direction, so that the multi-turn position stays small (an ODrive's ``pos_estimate`` is float32: at 200
            turns its step is 1.5e-5 turn, an eighth of an 8192-count encoder's).
        max_seconds: the logs' total (first round included) at most [3600 s]; beyond it the plan says what the maps'
            standard errors will be.
    """

    speeds: int = 4
    lowest_share: float = 0.25
    guard_margin: float = 0.9
    top_share: float = 0.2
    swing: float = 0.8
    dither_share: float = 0.5
    dither_count: int = 3
    mains_margin_hz: float = 3.0
    ramp_seconds: float = 0.5
    first_round_revolutions: float = 1.0
    first_round_seconds: float = 4.0
    min_cruise_seconds: float = 2.0
    max_revolutions: float = 200.0
    max_seconds: float = 3600.0

    def __post_init__(self):
        checks = (("speeds", self.speeds >= 1 and int(self.speeds) == self.speeds, "an integer >= 1"),
                  ("lowest_share", 0.0 < self.lowest_share <= 1.0, "in (0, 1]"),
                  ("guard_margin", 0.0 < self.guard_margin <= 1.0, "in (0, 1]"),
                  ("top_share", 0.0 < self.top_share <= 1.0, "in (0, 1]"),
                  ("swing", 0.0 < self.swing < 1.0, "in (0, 1): a swing of 1 would stop the rotor"),
                  ("dither_share", 0.0 <= self.dither_share <= 1.0, "in [0, 1]"),
                  ("dither_count", self.dither_count >= 1 and int(self.dither_count) == self.dither_count,
                   "an integer >= 1"),
                  ("mains_margin_hz", self.mains_margin_hz >= 0.0, ">= 0"),
                  ("ramp_seconds", self.ramp_seconds > 0.0, "> 0"),
                  ("first_round_revolutions", self.first_round_revolutions > 0.0, "> 0"),
                  ("first_round_seconds", self.first_round_seconds > 0.0, "> 0"),
                  ("min_cruise_seconds", self.min_cruise_seconds > 0.0, "> 0"),
                  ("max_revolutions", self.max_revolutions >= 1.0, ">= 1"),
                  ("max_seconds", self.max_seconds > 0.0, "> 0"))
        for name, ok, expected in checks:
            if not (ok and math.isfinite(float(getattr(self, name)))):
                raise ConfigError(f"rotary plan setting {name} = {getattr(self, name)!r}: expected {expected}")


@dataclass(frozen=True)
class Run:
    """One speed-loop run of the plan.

    Attributes:
        name: file stem, ``"s{k}_{fwd|rev}"`` (``k`` = 1 the slowest), ``"_r{j}"`` appended for repeats.
        speed: cruise speed (rad/s, signed: negative is reverse).
        cruise: time at the cruise speed (s), where the dither runs.
        ramp: time of each raised-cosine ramp, from rest and back (s).
        dither_hz: ``(n,)`` frequencies (Hz); dither_amplitude: ``(n,)`` amplitudes (A, zero without a dither).
    """

    name: str
    speed: float
    cruise: float
    ramp: float
    dither_hz: tuple
    dither_amplitude: tuple

    @property
    def duration(self) -> float:
        """Length of the run (s): ramp, cruise, ramp."""
        return self.cruise + 2.0 * self.ramp

    @property
    def revolutions(self) -> float:
        """Revolutions while cruising."""
        return abs(self.speed) * self.cruise / (2.0 * math.pi)

    def reference(self, sample_time: float) -> dict:
        """The run as the drive plays it back, one row per log period ``sample_time`` (s).

        Returns:
            ``{"t": (N,) s, "speed": (N,) rad/s, "dither": (N,) A}``: the speed setpoint (raised-cosine ramps, the
            cruise) and the q-current added to the speed loop's (``Σ a_k cos(2π f_k τ)`` while cruising, ``τ`` from the
            cruise's start; zero on the ramps).
        """
        n = int(math.ceil(self.duration / sample_time - 1e-9)) + 1
        t = sample_time * np.arange(n)
        share = np.clip(np.minimum(t, self.duration - t) / self.ramp, 0.0, 1.0)
        speed = self.speed * 0.5 * (1.0 - np.cos(np.pi * share))
        tau = t - self.ramp
        on = (tau >= 0.0) & (tau < self.cruise)
        dither = np.zeros(n)
        for a, f in zip(self.dither_amplitude, self.dither_hz):
            dither += a * np.cos(2.0 * np.pi * f * tau)
        return {"t": t, "speed": speed, "dither": np.where(on, dither, 0.0)}


@dataclass(frozen=True)
class FirstRound:
    """What a first round's logs say for the next plan (:func:`read_first_round`).

    Attributes:
        seconds: the logs' total length (s).
        sample_time: the median step of their time stamps (s): the rate the host reached.
        inertia_ratio: ``|J/k0|`` identified (A·s²/rad).
        slots: the slot count read from the logs where the motor TOML lacked it, else ``None``.
        standard_error: the identification's ``standard_error`` (per map: ``relative``, ``resolved``,
            ``log_time_factor_to_resolve``, ...).
        verdicts: per map of :data:`MAPS`, :func:`pgcomm.rotary.identify.resolution_verdict`'s phrase.
    """

    seconds: float
    sample_time: float
    inertia_ratio: float
    slots: int | None
    standard_error: dict
    verdicts: dict


@dataclass(frozen=True)
class RotaryPlan:
    """A rotary plan: the runs, and what they were sized from.

    Attributes:
        motor: the motor description the plan is for (slots as read from a first round where the TOML lacked them,
            ``sample_time`` the log period the plan assumes).
        settings: :class:`RotaryPlanSettings`.
        highest_order: the highest modelled order per revolution the alias guard protects.
        speed_limit: the alias guard's speed limit (rad/s).
        inertia_ratio: ``J/k0`` the dither is sized from (A·s²/rad), or ``None`` (no dither).
        inertia_source: where ``inertia_ratio`` came from (a phrase for plan.md).
        runs: the runs, in the order to record them (empty when a first round resolved every map).
        first_round: :class:`FirstRound` for a refined plan, ``None`` for a first round.
        need: for a refined plan: ``factor`` (the largest finite log-time factor), ``driver`` (its map),
            ``seconds`` (the rest to log, s), ``capped`` (bool), ``factors`` (per map), ``not_by_time`` (maps more of
            the same logs do not resolve), ``undetermined`` (maps the first round's logs did not determine: pinned by
            the identification).
        notes: sentences for plan.md (what was assumed, what is missing).
    """

    motor: RotaryMotor
    settings: RotaryPlanSettings
    highest_order: int
    speed_limit: float
    inertia_ratio: float | None
    inertia_source: str
    runs: tuple
    first_round: FirstRound | None = None
    need: dict | None = None
    notes: tuple = field(default=())

    @property
    def sample_time(self) -> float:
        """The log period the plan assumes (s)."""
        return float(self.motor.sample_time)

    @property
    def duration(self) -> float:
        """Total length of the runs (s), pauses between them not counted."""
        return float(sum(r.duration for r in self.runs))

    @property
    def plan_id(self) -> str:
        """12 hex digits of the SHA-256 of the plan's content (motor, sample time, runs): the logs' scripts record
        it, so that a log names the plan it ran."""
        doc = {"motor": self.motor.to_dict(), "runs": [[r.name, r.speed, r.cruise, r.ramp, list(r.dither_hz),
                                                        list(r.dither_amplitude)] for r in self.runs]}
        return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()[:12]


def highest_order(motor: RotaryMotor) -> int:
    """The highest order per revolution the identification models (:meth:`Orders.for_motor`), or, without the slot
    count, :data:`pgcomm.rotary.slots.MAX_ORDER` (the highest the slot count's detection examines)."""
    if motor.slots is None:
        return int(MAX_ORDER)
    return Orders.for_motor(motor).highest


def segment_speeds(speed_limit: float, settings: RotaryPlanSettings) -> np.ndarray:
    """The cruise speeds per direction (rad/s, positive, slowest first).

    The fastest is ``min(guard_margin / (1 + swing), top_share) · speed_limit``: with the dither's largest swing it
    stays within the guard's margin, and at most ``top_share`` of the limit (a host's clock,
    :class:`RotaryPlanSettings`); the others are geometric down to ``lowest_share`` of it.

    Args:
        speed_limit: the alias guard's limit (rad/s, :func:`pgcomm.rotary.regression.max_speed`).
        settings: :class:`RotaryPlanSettings`.

    Returns:
        ``(speeds,)`` rad/s.
    """
    top = min(settings.guard_margin / (1.0 + settings.swing), settings.top_share) * speed_limit
    if settings.speeds == 1:
        return np.array([top])
    return top * settings.lowest_share ** (1.0 - np.arange(settings.speeds) / (settings.speeds - 1))


def first_round_cruise(speeds, settings: RotaryPlanSettings) -> np.ndarray:
    """A first round's cruise per speed (s): the same for every speed, ``first_round_seconds`` or the time the fastest
    takes for ``first_round_revolutions``, whichever is longer (module docstring, "Durations").

    Args:
        speeds: ``(n,)`` cruise speeds (rad/s, positive); settings: :class:`RotaryPlanSettings`.

    Returns:
        ``(n,)`` seconds.
    """
    w = np.asarray(speeds, float)
    cruise = max(settings.first_round_seconds, settings.first_round_revolutions * 2.0 * math.pi / w.max())
    return np.full(w.shape, cruise)


def dither_frequencies(sample_time: float, settings: RotaryPlanSettings) -> tuple:
    """The dither's frequencies (Hz): whole hertz in the octave ``[0.55 f_hi, f_hi]``, ``f_hi = min(DITHER_MAX_HZ,
    1/(DITHER_MIN_SAMPLES T_s))``, at least ``mains_margin_hz`` from every harmonic of 50 and 60 Hz, spread evenly
    over the candidates (within an octave no frequency is a harmonic of another).

    Args:
        sample_time: the log period (s).
        settings: :class:`RotaryPlanSettings`.

    Returns:
        up to ``dither_count`` frequencies (Hz), ascending.

    Raises:
        ConfigError: no whole-hertz frequency in the band keeps the margin.
    """
    f_hi = min(DITHER_MAX_HZ, 1.0 / (DITHER_MIN_SAMPLES * sample_time))
    cand = np.arange(math.ceil(0.55 * f_hi), math.floor(f_hi) + 1, dtype=float)
    for mains in MAINS_HZ:
        k = np.maximum(np.round(cand / mains), 1.0)
        cand = cand[np.abs(cand - k * mains) >= settings.mains_margin_hz]
    if cand.size == 0:
        raise ConfigError(f"no dither frequency in {0.55 * f_hi:.3g}-{f_hi:.3g} Hz keeps {settings.mains_margin_hz:g} "
                          f"Hz from the mains harmonics at a log period of {sample_time:g} s")
    pick = np.unique(np.round(np.linspace(0, cand.size - 1, min(settings.dither_count, cand.size))).astype(int))
    return tuple(float(f) for f in cand[pick])


def dither_amplitudes(speed: float, frequencies, inertia_ratio: float | None, current_limit: float | None,
                      settings: RotaryPlanSettings) -> tuple:
    """The dither's amplitudes (A) for a run at ``speed`` (module docstring, "The dither").

    ``a_k = min(swing |ω| (J/k0) 2π f_k / n, dither_share · current_limit / n)``: the speed swing
    ``Σ a_k / ((J/k0) 2π f_k)`` stays within ``swing |ω|``.

    Args:
        speed: the run's cruise speed (rad/s); frequencies: ``(n,)`` Hz.
        inertia_ratio: ``J/k0`` (A·s²/rad), or ``None``: no dither (zeros).
        current_limit: the drive's q-current limit (A), or ``None`` (the swing alone bounds the dither).
        settings: :class:`RotaryPlanSettings`.

    Returns:
        ``(n,)`` amplitudes (A).
    """
    n = len(frequencies)
    if inertia_ratio is None or n == 0:
        return tuple(0.0 for _ in frequencies)
    cap = math.inf if current_limit is None else settings.dither_share * float(current_limit) / n
    return tuple(float(min(settings.swing * abs(speed) * abs(inertia_ratio) * 2.0 * math.pi * f / n, cap))
                 for f in frequencies)


def swing_bound(run: Run, inertia_ratio: float | None) -> float:
    """The dither's largest speed swing on a free rotor, ``Σ a_k / ((J/k0) 2π f_k)`` (rad/s); 0 without a dither."""
    if inertia_ratio is None:
        return 0.0
    return float(sum(a / (abs(inertia_ratio) * 2.0 * math.pi * f) for a, f in zip(run.dither_amplitude, run.dither_hz)))


def _ramp(speed: float, inertia_ratio: float | None, current_limit: float | None, settings: RotaryPlanSettings):
    """The ramp's length (s): ``ramp_seconds``, longer where its peak current ``(J/k0) π|ω|/(2 T)`` would exceed a
    quarter of the current limit."""
    if inertia_ratio is None or current_limit is None:
        return settings.ramp_seconds
    return max(settings.ramp_seconds, math.pi * abs(speed) * abs(inertia_ratio) / (2.0 * 0.25 * float(current_limit)))


def _runs(motor: RotaryMotor, speeds, cruises, inertia_ratio, settings: RotaryPlanSettings) -> tuple:
    """The runs at ``speeds`` (rad/s, positive) with cruises ``cruises`` (s) per direction, split into repeats of at
    most ``max_revolutions`` each that alternate the direction."""
    freqs = dither_frequencies(motor.sample_time, settings)
    runs = []
    for k, (w, cruise) in enumerate(zip(speeds, cruises), start=1):
        parts = max(1, math.ceil(w * cruise / (2.0 * math.pi * settings.max_revolutions) - 1e-9))
        ramp = _ramp(w, inertia_ratio, motor.current_limit, settings)
        for j in range(parts):
            for sign, tag in ((1.0, "fwd"), (-1.0, "rev")):
                name = f"s{k}_{tag}" + (f"_r{j + 1}" if parts > 1 else "")
                runs.append(Run(name, sign * float(w), float(cruise) / parts, ramp, freqs,
                                dither_amplitudes(w, freqs, inertia_ratio, motor.current_limit, settings)))
    return tuple(runs)


def _inertia(motor: RotaryMotor) -> tuple:
    """``(J/k0, source phrase)`` from the motor TOML, or ``(None, why not)``."""
    if motor.inertia is not None and motor.k_t is not None:
        return motor.inertia / motor.k_t, "the motor TOML's inertia / k_t"
    missing = " and ".join(k for k in ("inertia", "k_t") if getattr(motor, k) is None)
    return None, f"not known (no {missing} in the motor TOML)"


def first_plan(motor: RotaryMotor, settings: RotaryPlanSettings = RotaryPlanSettings()) -> RotaryPlan:
    """A first round: :func:`segment_speeds` in both directions, each for :func:`first_round_cruise` (a documented
    default: no standard error yet), with the dither sized from the
    motor TOML's ``inertia / k_t`` (none without them: the first round's logs then give ``J/k0``).

    Args:
        motor: the motor description (``sample_time`` is the log period the host will reach).
        settings: :class:`RotaryPlanSettings`.

    Returns:
        :class:`RotaryPlan`.
    """
    h = highest_order(motor)
    v_lim = max_speed(_orders_up_to(h), motor.sample_time)
    speeds = segment_speeds(v_lim, settings)
    ratio, source = _inertia(motor)
    cruises = first_round_cruise(speeds, settings)
    return RotaryPlan(motor, settings, h, v_lim, ratio, source, _runs(motor, speeds, cruises, ratio, settings),
                      notes=tuple(_motor_notes(motor, ratio)))


def refined_plan(motor: RotaryMotor, first: FirstRound,
                 settings: RotaryPlanSettings = RotaryPlanSettings()) -> RotaryPlan:
    """The runs a first round's standard errors ask for (module docstring, "Durations").

    The speeds and frequencies follow the log period the first round reached (``first.sample_time``) and the slot
    count it read; the dither follows the motor TOML's ``inertia / k_t``, or the first round's identified ``J/k0``
    where the TOML has none (a note where the two differ by more than 1.5 times). The rest to log is
    ``(F − 1) · first.seconds``
    (capped at ``max_seconds`` in all), ``F`` the largest finite ``log_time_factor_to_resolve`` over :data:`MAPS`,
    shared by the runs in a first round's proportions (each cruise at least ``min_cruise_seconds``). ``F ≤ 1``: no
    runs (every map resolved). A map the first round did not determine (pinned by the identification: no dither, one
    direction) or a ripple a first round without a dither could not excite gets a round of at least a first round's
    size, with the plan's dither and both directions.

    Args:
        motor: the motor description; first: :class:`FirstRound`; settings: :class:`RotaryPlanSettings`.

    Returns:
        :class:`RotaryPlan` with ``first_round`` and ``need``.
    """
    motor = replace(motor, sample_time=float(first.sample_time),
                    slots=motor.slots if first.slots is None else int(first.slots))
    h = highest_order(motor)
    v_lim = max_speed(_orders_up_to(h), motor.sample_time)
    speeds = segment_speeds(v_lim, settings)
    # the motor TOML's J/k0 where it gives one (the user's statement; a first round's slow, steady runs may carry too
    # little acceleration to pin it), else the identified
    ratio, source = _inertia(motor)
    identified = float(first.inertia_ratio)
    if ratio is None:
        ratio, source = identified, "the first round's identification"
    entries = {m: first.standard_error[m] for m in MAPS if m in first.standard_error}
    # a map the logs did not determine was pinned by the identification (no time factor): its experiment is the
    # plan's own (both directions, a dither), so a round of a first round's size comes next
    undetermined = {m: first.verdicts.get(m, "") for m, e in entries.items() if e.get("determined") is False}
    factors = {m: float(e["log_time_factor_to_resolve"]) for m, e in entries.items() if m not in undetermined}
    finite = {m: f for m, f in factors.items() if math.isfinite(f)}
    not_by_time = {m: first.verdicts.get(m, "") for m, f in factors.items() if not math.isfinite(f)}
    driver = max(finite, key=finite.get) if finite else None
    factor = finite[driver] if driver else 1.0
    total = factor * first.seconds
    capped = total > settings.max_seconds
    rest = max(0.0, min(total, settings.max_seconds) - first.seconds)
    notes = []
    runs = ()
    base = first_round_cruise(speeds, settings)
    # a first round planned without J/k0 had no dither: its ripple was not excited, and a round of the same size with
    # the dither sized from the identified J/k0 is what comes next (then plan again from all the logs)
    undithered = "ripple" in not_by_time and _inertia(motor)[0] is None
    fresh = undithered or bool(undetermined)
    if (factor > 1.0 and rest > 0.0) or fresh:
        ramps = np.array([_ramp(w, ratio, motor.current_limit, settings) for w in speeds])
        scale = max(0.0, rest / 2.0 - float(np.sum(2.0 * ramps))) / float(np.sum(base))
        cruises = np.maximum(base * scale, base if fresh else settings.min_cruise_seconds)
        runs = _runs(motor, speeds, cruises, ratio, settings)
    if undetermined:
        notes.append("Not determined by the first round's logs: " + "; ".join(f"the {m}: {v}" for m, v in
                                                                             undetermined.items())
                     + ". These runs have what determines it (each speed in both directions, each with a dither): run "
                     "them, then plan again from all the logs so far.")
    if undithered:
        notes.append("The first round had no dither (J/k0 was not known), so its logs could not determine the ripple. "
                     "This round carries a dither sized from the identified J/k0: run it, then plan again from all the "
                     "logs so far.")
    if capped:
        worst = first.standard_error[driver]
        at_cap = worst["relative"] * math.sqrt(first.seconds / settings.max_seconds)
        notes.append(f"The {driver} asks for {total:.0f} s of logs in all; the plan stops at "
                     f"{settings.max_seconds:.0f} s, where its noise part is expected near {100 * at_cap:.1f} % of its "
                     "RMS (it falls as the square root of the log time).")
    if not_by_time:
        notes.append("Not resolved by more of the same logs: " + "; ".join(f"the {m}: {v}" for m, v in
                                                                           not_by_time.items()) + ".")
    notes += _motor_notes(motor, ratio)
    need = {"factor": factor, "driver": driver, "seconds": rest, "capped": bool(capped),
            "factors": factors, "not_by_time": sorted(not_by_time), "undetermined": sorted(undetermined)}
    if ratio != identified and not 1 / 1.5 <= identified / ratio <= 1.5:
        notes.append(f"The first round's logs give J/k0 = {identified:.4g} A·s²/rad, the motor TOML's inertia / k_t "
                     f"{ratio:.4g}: the dither is sized from the TOML's. Check inertia and k_t; if the logged speed "
                     "swings more than the runs' table says, lower --swing.")
    return RotaryPlan(motor, settings, h, v_lim, ratio, source, runs, first, need,
                      tuple(notes))


def _orders_up_to(h: int) -> Orders:
    """Orders whose highest is ``h`` (only :attr:`Orders.highest` matters to the guard)."""
    z = np.zeros(0, int)
    return Orders(np.array([int(h)]), z, z)


def _motor_notes(motor: RotaryMotor, inertia_ratio) -> list:
    notes = []
    if motor.slots is None:
        notes.append("The motor TOML has no slot count: the speeds keep every order up to "
                     f"{highest_order(motor)} per revolution within the alias guard (what the slot count's detection "
                     "examines). With `slots` set they would be faster.")
    if inertia_ratio is None:
        notes.append("No dither: J/k0 is not known (add inertia and k_t to the motor TOML). The first round's logs "
                     "determine the cogging, the direction map and J/k0; `pgcomm plan --data` then sizes a dither "
                     "for the ripple from the identified J/k0.")
    elif motor.current_limit is None:
        notes.append("No current_limit in the motor TOML: only the speed swing bounds the dither.")
    return notes


def check_rotary_logs(logs, motor: str = "") -> None:
    """Refuse logs the rotary identification cannot read: a linear motor's (``y`` in place of ``theta``) or one without
    the q-current ``iq_1``; ``motor`` names the rotary motor they were given with (e.g. ``"--motor m.toml"``).

    Raises:
        DataError: one line naming the log.
    """
    given = f", but {motor} is rotary" if motor else ""
    for lg in logs:
        if not lg.is_rotary:
            raise DataError(f"{lg.source}: a linear motor's log (it has 'y'){given}; a rotary log has the mechanical "
                            "angle 'theta' in place of 'y'")
        if "iq_1" not in lg.columns:
            raise DataError(f"{lg.source}: no q-axis current 'iq_1' (map the drive's q-current column to iq_1 in "
                            "--columns); rotary identification reads the current in the drive's frame")


def logs_as_data(logs) -> list:
    """Logs read by :func:`pgcomm.io.logs.read_logs` (``stamps=True``: a host's time stamps as recorded) as the rotary
    identification takes them: one dict per stretch between gaps, with ``name``, ``t``, ``theta``, ``iq_1`` and, where
    every log has it, ``id_1``.

    Raises:
        DataError: a log without ``iq_1``.
    """
    check_rotary_logs(logs)
    extra = ("id_1",) if all("id_1" in lg.columns for lg in logs) else ()
    return [{"name": lg.source if len(lg.gaps) == 0 else f"{lg.source} rows {a + 1}-{b}",
             **{k: lg.columns[k][a:b] for k in ("t", "theta", "iq_1", *extra)}}
            for lg in logs for a, b in lg.segments()]


def read_first_round(data, motor: RotaryMotor) -> FirstRound:
    """Identify a first round's logs (:func:`pgcomm.rotary.identify.identify`, every reading detected) and keep what
    the next plan needs.

    Args:
        data: logs as :func:`logs_as_data` gives them (``t`` s, ``theta`` rad, ``iq_1`` A; each ``(N_i,)``).
        motor: the motor description; without ``slots`` they are read from the logs
            (:func:`pgcomm.rotary.slots.count_slots`).

    Returns:
        :class:`FirstRound`.

    Raises:
        DataError, ExcitationError: as the identification (logs that never move, no usable window, ...).
    """
    slots = None
    if motor.slots is None:
        slots, _ = count_slots(data, motor)
        motor = replace(motor, slots=int(slots))
    res = identify(data, motor)
    seconds = 0.0
    steps = []
    for d in data:
        t = np.asarray(d["t"], float)
        step = np.diff(t)
        steps.append(step)
        seconds += float(t[-1] - t[0]) + float(np.median(step))
    se = res.standard_error
    return FirstRound(seconds, float(np.median(np.concatenate(steps))), abs(float(res.model.inertia_ratio)),
                      None if slots is None else int(slots), se,
                      {m: resolution_verdict(se[m], seconds) for m in MAPS if m in se})
