"""A rotary PMSM twin on a field-oriented drive, in closed loop (``jax.lax.scan``).

**Truth.** The drive's electrical frame is ``p θ_enc + offset``; the motor's true frame is
offset from it by ``δ`` (rad, electrical), so a q-current ``i_q`` in the drive frame is
``i_q cos δ`` in the true q axis (the d-axis command is zero; the drive's ``i_d`` reads noise).
The air-gap torque and the mechanics are::

    T_em = k_t cos δ · (1 + ρ(θ)) i_q + T_cog(θ)                            (N·m)
    J θ̈  = T_em − (T_c + D(θ)) tanh(ω / ω_ε) − b ω

``ρ`` the relative torque-constant ripple (eccentricity at order 1, magnet tolerances at the
low orders and ``2p``, back-EMF harmonics at ``6p``, ``12p``, the slots at ``Q``, and a small
part outside any model's basis), ``T_cog`` the cogging torque at the multiples of
``LCM(Q, 2p)`` with the sidebands of magnet (``kQ``) and stator (``k·2p``) tolerances, ``T_c``
Coulomb friction, ``D`` the position-dependent part of the direction-dependent torque, ``b``
viscous friction. ``k0 = k_t cos δ`` is the mean effective torque constant the drive sees.

**Drive.** One step per controller sample ``T_s``: the encoder quantises the angle; the velocity
is the encoder difference through a first-order low-pass (the drive's estimator); a PID position
loop or a PI speed loop with feedforward gives the demand ``u`` (A, equivalent current at
``k0``); the commutation law (:mod:`pgcomm.rotary.law`) makes it a q-current, clipped to the
limit and held over the sample (ideal current loop). The law is evaluated at the angle the rotor
has in the middle of that hold, ``θ_enc + advance · ω̂ · T_s`` (:attr:`LawParams.advance`, default
½, :func:`pgcomm.rotary.law.hold_angle`): evaluated at the sample's start, a compensation held for a
sample lags half a sample, which at 16 samples per cogging period leaves ``2 sin(π/32) ≈ 20 %`` of
that harmonic uncompensated (the floor of every row, the oracle's included); the mechanics are integrated in
``n_sub`` sub-steps, each exact for a constant torque, with the torques taken at the sub-step's middle (second order:
taken at its start, each harmonic would lag half a sub-step, a torque odd in the direction that the identification
puts into the ripple at the largest cogging order, a sizeable share of a small ripple there). The log holds what the drive records: ``t``,
``theta`` (multi-turn, encoder), ``velocity``, ``iq_1``, ``id_1`` (measured, with noise), plus the truth
(``theta_true``, ``omega_true``, ``torque`` = air-gap torque, e.g. for a torque sensor).

**A drive faster than its log.** With :attr:`RotaryTruth.control_per_log` ``K > 1`` the drive runs all of the above
``K`` times per logged sample (``T_s/K``: encoder, velocity estimate, loops, law, held current) on references and
dither interpolated by a cubic spline, and logs a snapshot of every ``K``-th cycle: an ODrive at 8 kHz or a moteus at
15-40 kHz logged at 1 kHz. The logged current is then not the one that flowed until the next row
(:mod:`pgcomm.rotary.readings`, "Between logged samples").

**A real drive's habits** (each its own field of :class:`RotaryTruth`, all off by default; the zoo draws them with
``real_drive=True``, :func:`pgcomm.rotary.zoo.draw_rotary`):

* *current sensors* (``sensor_offset``, ``sensor_gain``): the drive measures two phase currents with an offset and a
  gain error each and regulates the *measured* current to its command in its frame; the phase currents that flow are
  the measured ones less those errors (the third phase closes the star). In the drive's frame the offsets make an
  error at the electrical order ``p``, the gain mismatch ``2p`` (and a mean gain). The torque the motor makes is that
  of the current that flows (:func:`drive_current_error`); the log holds the current the drive measures;
* *the inverter's dead time* (``deadtime_error``, ``deadtime_width``, ``current_bandwidth``, ``electrical_pole``):
  each phase's voltage falls short by the dead time's ``V_dt``, which alone would leave its current
  ``V_dt/R · tanh(i_ph/i_ε)`` short (``6p`` and its multiples in the q-current). The sensors measure the current
  that flows, so the current loop sees the dead time and takes it out but for what its finite gain leaves,
  :func:`deadtime_residual`: nothing at standstill, most where a phase current crosses zero fast. That residual
  moves the measured current (and the log) and the current that flows together, off the command;
* *a filtered current report* (``report_filter``, s): the logged q- and d-currents are the drive's first-order
  low-pass of the currents it measures, sensor noise included, updated every control cycle (ODrive's ``Iq_measured``,
  ``Id_measured``);
* *a PLL angle* (``pll_bandwidth``, rad/s): the drive's angle and velocity are ODrive's encoder PLL's (``k_p = 2 bw``,
  ``k_i = bw²``, run every control cycle on the encoder count), for its loops, its law and its log;
* *the host's clock* (``host_jitter``, ``host_gaps``, ``stamp_noise``): a PC polls the drive at jittered instants
  (:func:`host_instants`), and each row is the drive's state at its last control cycle before the instant, stamped
  with the instant plus a little noise (``simulate(..., host=True)``);
* *an index that moves between power-ups* (``power_up_offsets``, rad): recorded in power_up ``s``, the drive's angle is
  the encoder's plus ``power_up_offsets[s]`` (rounded to whole counts): its position loop, its law and its log work in
  that frame, its commutation is calibrated again (``simulate(..., start=Start(power_up=s))``);
* *stalls*: the plant's cogging, drive errors and friction hold a rotor a soft speed loop cannot move
  (:func:`breakaway_current`; :func:`pgcomm.rotary.experiment.stall_log`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from pgcomm.rotary.model import Fourier, RotaryModel
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.winding import BackEmf, Winding, d_voltage, logged_dq, q_voltage

__all__ = ["RotaryTruth", "Gains", "LawParams", "Reference", "simulate", "default_gains", "VELOCITY_CUTOFF_HZ",
           "SUBSTEPS", "Start", "HOLD_ADVANCE", "drive_current_error", "deadtime_residual", "breakaway_current",
           "host_instants", "power_up_offset",
           "HOST_STEP_RANGE", "HOST_GAP_STEPS", "STAMP_NOISE_CLIP"]

#: Cut-off of the drive's velocity estimate (Hz): first-order low-pass on the encoder difference.
VELOCITY_CUTOFF_HZ = 200.0
#: Plant sub-steps per controller sample (the cogging at 8+ samples per period needs ~10).
SUBSTEPS = 10
#: Where in the sample the drive evaluates the law (share of ``T_s`` past the encoder sample, at the
#: estimated velocity): the middle of the sample over which the current is held.
HOLD_ADVANCE = 0.5
#: The host's steps between logged rows, as multiples of the log's median step :attr:`RotaryMotor.sample_time`: the
#: jitter is clipped to this range (a PC's Python loop over USB: 0.6-2.6x on the ODrive logs of ``../real``).
HOST_STEP_RANGE = (0.6, 2.6)
#: A missed stretch of the host's log: this many median steps (uniform, inclusive).
HOST_GAP_STEPS = (5, 40)
#: The host's stamp noise is clipped to this share of the median step, so the stamps keep increasing.
STAMP_NOISE_CLIP = 0.2


@dataclass(frozen=True)
class RotaryTruth:
    """The twin's electromagnetic and mechanical truth (SI units, module docstring).

    Attributes:
        motor: the nominal description the user has (:class:`RotaryMotor`).
        k_t: true mean torque constant in the true frame (N·m/A).
        offset_error: ``δ`` (rad, electrical): true frame minus drive frame.
        ripple: ``ρ(θ)`` (-), relative, zero mean.
        cogging: ``T_cog(θ)`` (N·m).
        drag: ``D(θ)`` (N·m), zero mean: the position-dependent direction-dependent torque.
        coulomb: ``T_c`` (N·m); viscous: ``b`` (N·m·s/rad); inertia: ``J`` (kg·m²).
        friction_velocity: ``ω_ε`` (rad/s) of the smooth sign.
        current_noise: std of the logged ``i_q``, ``i_d`` (A); with ``report_filter``, of the sensed current per
            control cycle, before the filter.
        torque_noise: std of the logged torque (N·m).
        encoder_counts: counts per revolution.
        winding: the winding and inverter behind the logged q-voltage (:mod:`pgcomm.rotary.winding`), or
            ``None`` for a twin that logs no voltage.
        control_per_log: the drive's control samples per logged sample (``motor.sample_time`` is the log's
            period). 1: the drive controls at its log rate. ``K > 1``: it controls at ``K`` times the log rate (an
            ODrive at 8 kHz, a moteus at 15-40 kHz logged at 1 kHz), and the log holds a snapshot at every
            ``K``-th control sample, so the current between two logged samples is not the one logged.
        sensor_offset: ``(o_a, o_b)`` (A): the offsets of the drive's current sensors on phases a and b (module
            docstring, "A real drive's habits"); torque at the electrical order ``p``.
        sensor_gain: ``(g_a, g_b)`` (-): their relative gain errors; torque at ``2p`` and a mean gain.
        deadtime_error: ``V_dt / R`` (A): how far the inverter's dead time would leave each phase current short
            without a current loop; the loop takes it out but for :func:`deadtime_residual` (torque at ``6p``).
        deadtime_width: ``i_ε`` (A) of its ``tanh(i_ph / i_ε)``, positive when ``deadtime_error`` is.
        current_bandwidth: ``ω_c`` (rad/s) of the drive's current loop (ODrive's default 1000); with a dead time and
            none given, the winding's ``loop_gain / L``.
        electrical_pole: ``a = R / L`` (rad/s) of the winding; with a dead time and none given, the winding's.
        report_filter: ``τ`` (s) of the first-order low-pass the logged q- and d-currents go through, run every
            control cycle on the measured current with its sensors' noise (``current_noise`` per control cycle); 0:
            none.
        pll_bandwidth: ``bw`` (rad/s) of the drive's encoder PLL (``k_p = 2 bw``, ``k_i = bw²``); 0: the encoder's
            count and the low-passed difference (:data:`VELOCITY_CUTOFF_HZ`).
        host_jitter: ``σ`` of the log of the host's steps between rows (log-normal around the median step, clipped
            to :data:`HOST_STEP_RANGE`); 0 with ``host_gaps`` and ``stamp_noise``: rows at ``j T_s``.
        host_gaps: the chance per row that the host misses :data:`HOST_GAP_STEPS` median steps after it.
        stamp_noise: std (s) of a stamp about its row's instant (clipped at :data:`STAMP_NOISE_CLIP` of the step).
        power_up_offsets: the drive's angle zero in power-ups ``0, 1, ...`` (rad, ``power_up s`` uses entry
            ``s mod len``); empty: the index never moves.
    """

    motor: RotaryMotor
    k_t: float
    offset_error: float
    ripple: Fourier
    cogging: Fourier
    drag: Fourier
    coulomb: float
    viscous: float
    inertia: float
    friction_velocity: float
    current_noise: float
    torque_noise: float
    encoder_counts: int
    winding: Winding | None = None
    control_per_log: int = 1
    sensor_offset: tuple = (0.0, 0.0)
    sensor_gain: tuple = (0.0, 0.0)
    deadtime_error: float = 0.0
    deadtime_width: float = 0.0
    current_bandwidth: float = 0.0
    electrical_pole: float = 0.0
    report_filter: float = 0.0
    pll_bandwidth: float = 0.0
    host_jitter: float = 0.0
    host_gaps: float = 0.0
    stamp_noise: float = 0.0
    power_up_offsets: tuple = ()

    def __post_init__(self):
        k = self.control_per_log
        if isinstance(k, bool) or int(k) != k or k < 1:
            raise ValueError(f"control_per_log = {k!r} must be a positive integer")
        object.__setattr__(self, "control_per_log", int(k))
        for name in ("sensor_offset", "sensor_gain"):
            v = tuple(float(x) for x in getattr(self, name))
            if len(v) != 2 or not all(math.isfinite(x) for x in v):
                raise ValueError(f"{name} = {getattr(self, name)!r} must be two finite numbers (phases a and b)")
            object.__setattr__(self, name, v)
        if min(self.sensor_gain) <= -1.0:
            raise ValueError(f"sensor_gain = {self.sensor_gain!r}: a gain error of -100 % or less reads no current")
        for name in _HABITS_NONNEGATIVE:
            v = float(getattr(self, name))
            if not (v >= 0.0 and math.isfinite(v)):
                raise ValueError(f"{name} = {getattr(self, name)!r} must be a non-negative number")
            object.__setattr__(self, name, v)
        if self.host_gaps > 1.0:
            raise ValueError(f"host_gaps = {self.host_gaps!r} is a chance per row, at most 1")
        if self.deadtime_error > 0 and self.deadtime_width <= 0:
            raise ValueError(f"deadtime_width = {self.deadtime_width!r} must be positive with a deadtime_error")
        if self.deadtime_error > 0:
            w = self.winding
            if self.current_bandwidth <= 0 and w is not None:
                object.__setattr__(self, "current_bandwidth", float(w.loop_gain / w.inductance))
            if self.electrical_pole <= 0 and w is not None:
                object.__setattr__(self, "electrical_pole", float(w.resistance / w.inductance))
            if self.current_bandwidth <= 0 or self.electrical_pole <= 0:
                raise ValueError("a deadtime_error needs the current loop's current_bandwidth and the winding's "
                                 "electrical_pole (rad/s), or a winding to take them from")
        offs = tuple(float(x) for x in self.power_up_offsets)
        if not all(math.isfinite(x) for x in offs):
            raise ValueError(f"power_up_offsets = {self.power_up_offsets!r} must be finite angles (rad)")
        object.__setattr__(self, "power_up_offsets", offs)

    @property
    def drive_errors(self) -> bool:
        """Whether the current that flows differs from the command (sensor offset, gain, dead time's residual)."""
        return any(self.sensor_offset) or any(self.sensor_gain) or self.deadtime_error > 0

    @property
    def host_logger(self) -> bool:
        """Whether a host's clock stamps the logs (:func:`host_instants`) rather than the drive's uniform samples."""
        return self.host_jitter > 0 or self.host_gaps > 0 or self.stamp_noise > 0

    @property
    def k0(self) -> float:
        """Mean effective torque constant seen from the drive frame: ``k_t cos δ`` (N·m/A)."""
        return self.k_t * math.cos(self.offset_error)

    @property
    def back_emf(self) -> BackEmf:
        """The magnets' field as the winding meets it in the drive's frame (:class:`pgcomm.rotary.winding.BackEmf`)."""
        return BackEmf(self.k_t, self.offset_error, self.ripple, self.motor.pole_pairs, self.motor.commutation_offset)

    def model(self, drive: bool = True) -> RotaryModel:
        """The truth in current units (:class:`RotaryModel`): what an ideal identification returns.

        With the drive's current errors (:attr:`drive_errors`) and ``drive`` true, the maps are those of the motor
        *seen through the drive's current*: the torque is ``k0 (1 + ρ)(1 + G) i_q + k0 (1 + ρ) E + T_cog`` with the
        sensors' error ``E`` (A, order ``p``) and gain ``G`` (orders 0 and ``2p``) of :meth:`drive_maps`, so the
        torque constant is ``k0`` times the mean of ``(1 + ρ)(1 + G)``, the ripple the rest of it, and the cogging
        takes ``k0 (1 + ρ) E``: the maps a compensation has to hold. The dead time's error depends on the current's
        sign and stays outside (it is not a map). ``drive=False``: the motor alone.
        """
        k0 = self.k0
        cog, rip = self.cogging, self.ripple
        if drive and (any(self.sensor_offset) or any(self.sensor_gain)):
            e, g = self.drive_maps()
            one = Fourier(np.array([0]), np.array([[1.0, 0.0]]))
            both = _product(_sum(one, rip), _sum(one, g))
            mean = both.mean()
            rip = _sum(both.scaled(1.0 / mean), one.scaled(-1.0), drop_zero_order=True)
            cog = _sum(cog, _product(_sum(one, self.ripple), e).scaled(k0))
            k0 = k0 * mean
        direction = Fourier(np.concatenate([[0], self.drag.orders]),
                            np.concatenate([[[self.coulomb, 0.0]], self.drag.coef]) / k0)
        return RotaryModel(self.motor.pole_pairs, cog.scaled(1.0 / k0), rip, direction,
                           viscous=self.viscous / k0, inertia_ratio=self.inertia / k0, k_t=k0,
                           info={"source": "twin truth" if drive else "twin truth, the motor alone"})

    def drive_maps(self) -> tuple[Fourier, Fourier]:
        """The current sensors' errors as maps over the revolution (:func:`drive_current_error` without the dead
        time, at the true angle): ``(E, G)`` with the current that flows ``(1 + G(θ)) i_q + E(θ)`` (in the drive's
        ``k0`` units): ``E`` (A) at order ``p`` (the offsets), ``G`` (-) at orders 0 and ``2p`` (the gains). Exact
        (the error is linear in ``i_q`` and band-limited): read off the FFT of the error at ``i_q`` = 0 and 1 A."""
        p = self.motor.pole_pairs
        n = 16 * p
        th = 2 * math.pi * np.arange(n) / n
        e0, e1 = (drive_current_error(self, th, np.full(n, float(i))) for i in (0.0, 1.0))
        return _fit_orders(e0, [p]), _fit_orders(e1 - e0, [0, 2 * p])

    def air_gap_torque(self, theta, iq) -> np.ndarray:
        """``T_em`` (N·m) at angles ``theta`` (rad) and drive-frame q-currents ``iq`` (A), broadcast."""
        th = np.asarray(theta, float)
        return self.k0 * (1.0 + self.ripple(th)) * np.asarray(iq, float) + self.cogging(th)

    def rated_current(self) -> float:
        """A nominal scale for currents (A): the current limit, else 1 A."""
        return float(self.motor.current_limit) if self.motor.current_limit else 1.0

    def habits(self) -> dict:
        """The drive's and host's habits that differ from their defaults (all off): ``{field: value}``."""
        out = {}
        for name, default in _HABIT_DEFAULTS.items():
            v = getattr(self, name)
            if v != default:
                out[name] = list(v) if isinstance(v, tuple) else v
        return out

    def to_dict(self) -> dict:
        return {"motor": self.motor.to_dict(), "k_t": self.k_t, "offset_error": self.offset_error,
                "ripple": self.ripple.to_dict(), "cogging": self.cogging.to_dict(), "drag": self.drag.to_dict(),
                "coulomb": self.coulomb, "viscous": self.viscous, "inertia": self.inertia,
                "friction_velocity": self.friction_velocity, "current_noise": self.current_noise,
                "torque_noise": self.torque_noise, "encoder_counts": self.encoder_counts,
                **({"winding": self.winding.to_dict()} if self.winding is not None else {}),
                **({"control_per_log": self.control_per_log} if self.control_per_log != 1 else {}), **self.habits()}

    @classmethod
    def from_dict(cls, d: dict) -> "RotaryTruth":
        m = dict(d["motor"])
        m.pop("kind", None)
        return cls(RotaryMotor(**m), float(d["k_t"]), float(d["offset_error"]), Fourier.from_dict(d["ripple"]),
                   Fourier.from_dict(d["cogging"]), Fourier.from_dict(d["drag"]), float(d["coulomb"]),
                   float(d["viscous"]), float(d["inertia"]), float(d["friction_velocity"]),
                   float(d["current_noise"]), float(d["torque_noise"]), int(d["encoder_counts"]),
                   Winding.from_dict(d["winding"]) if "winding" in d else None, d.get("control_per_log", 1),
                   **{k: (tuple(d[k]) if isinstance(v, tuple) else d[k]) for k, v in _HABIT_DEFAULTS.items() if k in d})


#: The habits' fields and their defaults (off): truth files without them are twins without them.
_HABIT_DEFAULTS = {"sensor_offset": (0.0, 0.0), "sensor_gain": (0.0, 0.0), "deadtime_error": 0.0,
                   "deadtime_width": 0.0, "current_bandwidth": 0.0, "electrical_pole": 0.0, "report_filter": 0.0,
                   "pll_bandwidth": 0.0, "host_jitter": 0.0, "host_gaps": 0.0, "stamp_noise": 0.0,
                   "power_up_offsets": ()}
_HABITS_NONNEGATIVE = ("deadtime_error", "deadtime_width", "current_bandwidth", "electrical_pole", "report_filter",
                       "pll_bandwidth", "host_jitter", "host_gaps", "stamp_noise")
_SQRT3 = math.sqrt(3.0)


def _flow_dq(xp, theta_e, id_m, iq_m, o_a, o_b, g_a, g_b):
    """The ``(i_d, i_q)`` that flow in the drive's frame (A) where the drive measures ``(id_m, iq_m)``
    (module docstring, "A real drive's habits"), for array module ``xp`` (NumPy or JAX): amplitude-invariant Park at
    the drive's electrical angle ``theta_e``; the sensors of phases a and b read ``(1 + g) i + o``, phase c closes
    the star."""
    s, c = xp.sin(theta_e), xp.cos(theta_e)
    m_al, m_be = id_m * c - iq_m * s, id_m * s + iq_m * c
    i_a = (m_al - o_a) / (1.0 + g_a)
    i_b = (-0.5 * m_al + 0.5 * _SQRT3 * m_be - o_b) / (1.0 + g_b)
    al, be = i_a, (i_a + 2.0 * i_b) / _SQRT3
    return al * c + be * s, -al * s + be * c


def _deadtime_dq(xp, theta_e, iq, dt_error, dt_width):
    """The ``(d, q)`` error (A) the inverter's dead time would leave in a current ``iq`` (drive frame, ``i_d = 0``)
    with no current loop: each phase short by ``dt_error tanh(i_ph/dt_width)`` (``dt_error = V_dt / R``), three
    phases into the frame's two by the amplitude-invariant Park transform."""
    e_d = 0.0 * iq
    e_q = 0.0 * iq
    for k in range(3):
        ph = theta_e - 2.0 * math.pi * k / 3.0
        pk = -xp.sin(ph)
        short = (2.0 / 3.0) * dt_error * xp.tanh(iq * pk / dt_width)
        e_d = e_d - xp.cos(ph) * short
        e_q = e_q - pk * short
    return e_d, e_q


def _current_error(xp, theta_e, iq, o_a, o_b, g_a, g_b, tan_delta, id_m=0.0):
    """The true-frame q-current that flows less the measured ``iq`` (A, the drive's ``k0`` units) for the sensors'
    offsets and gains (:func:`_flow_dq`): the true-frame q-current of the drive-frame ``(i_d, i_q)`` is
    ``(i_q cos δ − i_d sin δ)``, over ``cos δ`` for ``k0``."""
    i_d, i_q = _flow_dq(xp, theta_e, id_m, iq, o_a, o_b, g_a, g_b)
    return i_q - i_d * tan_delta - iq


def deadtime_residual(truth: "RotaryTruth", frequency) -> np.ndarray:
    """The share of the dead time's voltage error that the drive's current loop lets into the current at
    ``frequency`` (rad/s, electrical, in the drive's frame): ``|H(jω)|`` with ``H(s) = a s / ((s + a)(s + ω_c))``,
    ``a = R/L`` the winding's pole (:attr:`RotaryTruth.electrical_pole`) and ``ω_c`` the loop's bandwidth
    (:attr:`RotaryTruth.current_bandwidth`): a PI loop with its zero on the winding's pole, so its open loop is
    ``ω_c / s`` and a voltage ``v`` enters the current as ``v/(L s + R) · s/(s + ω_c)``; in units of ``v/R``
    (:attr:`RotaryTruth.deadtime_error`). Zero at standstill (the integrator holds the current), at most
    ``a / (a + ω_c)`` near ``√(a ω_c)``.

    Args:
        truth: the twin; frequency: ``(N,)`` or scalar, rad/s.

    Returns:
        the gain (-), the shape of ``frequency``.
    """
    w = np.asarray(frequency, float)
    a, wc = truth.electrical_pole, truth.current_bandwidth
    return a * np.abs(w) / np.sqrt((w * w + a * a) * (w * w + wc * wc))


def _deadtime_loop(truth: "RotaryTruth", tc: float) -> tuple[float, ...]:
    """The twin step's constants for :func:`deadtime_residual`'s ``H(s) = k (ω_c/(s + ω_c) - a/(s + a))``,
    ``k = a/(ω_c - a)``, on an error held over the control cycle ``T_c`` (s): ``(α_a, α_c, k, m_a, m_c)`` with
    ``α = 1 - e^{-x}`` a low-pass's step per cycle and ``m = 1 - (1 - e^{-x})/x`` the share of the step its mean over
    the cycle takes, ``x = a T_c`` or ``ω_c T_c``; zeros without a dead time. Where ``ω_c`` is within 0.1 % of ``a``
    it is taken 0.1 % above (``k`` stays finite; the residual moves by less than that)."""
    if truth.deadtime_error <= 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    a, wc = truth.electrical_pole, truth.current_bandwidth
    if abs(wc - a) < 1e-3 * a:
        wc = a * 1.001
    xa, xc = a * tc, wc * tc
    return (-math.expm1(-xa), -math.expm1(-xc), a / (wc - a), 1.0 + math.expm1(-xa) / xa,
            1.0 + math.expm1(-xc) / xc)


def drive_current_error(truth: "RotaryTruth", theta, iq) -> np.ndarray:
    """How far the q-current that flows is from the one the drive measures and logs (A, in its ``k0`` units): the
    current sensors' offsets and gains of ``truth`` (module docstring, "A real drive's habits"), linear in ``iq``.
    The dead time is not among them: the sensors measure the current it leaves, and the current loop takes it out
    of the command's current but for :func:`deadtime_residual`.

    Args:
        truth: the twin; theta: ``(N,)`` the rotor's angle in the drive's commutation (rad, mechanical: its
            electrical angle is ``p θ + commutation_offset``); iq: ``(N,)`` the q-current the drive measures (A).

    Returns:
        ``(N,)`` A; zero without current-sensor errors.
    """
    th, i = np.broadcast_arrays(np.asarray(theta, float), np.asarray(iq, float))
    return _current_error(np, truth.motor.pole_pairs * th + truth.motor.commutation_offset, i, *truth.sensor_offset,
                          *truth.sensor_gain, math.tan(truth.offset_error))


def _fit_orders(values: np.ndarray, orders) -> Fourier:
    """The Fourier coefficients at ``orders`` of ``values`` sampled at ``2π j / N`` (FFT; exact for band-limited
    values below ``N/2``)."""
    n = values.size
    x = np.fft.rfft(values) / n
    coef = [[x[h].real, 0.0] if h == 0 else [2 * x[h].real, -2 * x[h].imag] for h in orders]
    return Fourier(np.asarray(orders, int), np.asarray(coef, float))


def _sum(*parts: Fourier, drop_zero_order: bool = False) -> Fourier:
    """The sum of Fourier maps, one coefficient pair per order (sorted); ``drop_zero_order``: without the mean."""
    acc: dict[int, np.ndarray] = {}
    for f in parts:
        for h, c in zip(f.orders.tolist(), f.coef):
            acc[h] = acc.get(h, np.zeros(2)) + (c * [1.0, 0.0] if h == 0 else c)
    hs = sorted(h for h in acc if not (drop_zero_order and h == 0))
    return Fourier(np.asarray(hs, int), np.asarray([acc[h] for h in hs], float).reshape(-1, 2))


def _product(f: Fourier, g: Fourier) -> Fourier:
    """The product of two Fourier maps (orders ``|h1 − h2|`` and ``h1 + h2``), by the product-to-sum identities."""
    parts = []
    for h1, (a1, b1) in zip(f.orders.tolist(), f.coef):
        b1 = 0.0 if h1 == 0 else b1
        for h2, (a2, b2) in zip(g.orders.tolist(), g.coef):
            b2 = 0.0 if h2 == 0 else b2
            d, sgn = abs(h1 - h2), (1.0 if h1 >= h2 else -1.0)
            parts.append(Fourier(np.array([d, h1 + h2]),
                                 0.5 * np.array([[a1 * a2 + b1 * b2, sgn * (b1 * a2 - a1 * b2)],
                                                 [a1 * a2 - b1 * b2, a1 * b2 + b1 * a2]])))
    return _sum(*parts)


def power_up_offset(truth: "RotaryTruth", power_up: int) -> float:
    """The drive's angle zero in power-up ``power_up`` (rad): ``truth.power_up_offsets[power_up mod len]``
    rounded to whole encoder counts (0 without offsets)."""
    if not truth.power_up_offsets:
        return 0.0
    q = 2 * math.pi / truth.encoder_counts
    return float(np.round(truth.power_up_offsets[int(power_up) % len(truth.power_up_offsets)] / q) * q)


def host_instants(truth: "RotaryTruth", duration: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """The instants a host polls the drive at and the stamps it writes, over ``[0, duration)`` (s).

    The steps are the log's median step ``T_s`` (:attr:`RotaryMotor.sample_time`) times ``exp(σ z)``, ``z`` standard
    normal, ``σ = host_jitter``, clipped to :data:`HOST_STEP_RANGE`; after a row, with chance ``host_gaps``, the host
    misses :data:`HOST_GAP_STEPS` median steps (drawn uniform); the first row comes within the first step. Each stamp
    is its instant plus normal noise of std ``stamp_noise`` clipped at :data:`STAMP_NOISE_CLIP` of ``T_s``, so the
    stamps keep increasing.

    Args:
        truth: the twin (its host's habits); duration: s; rng: :class:`numpy.random.Generator`.

    Returns:
        ``(instants, stamps)``, ``(M,)`` each, s.
    """
    ts = truth.motor.sample_time
    lo, hi = HOST_STEP_RANGE
    m = int(math.ceil(duration / (lo * ts))) + 2
    steps = ts * np.clip(np.exp(truth.host_jitter * rng.standard_normal(m)), lo, hi)
    gap = rng.random(m) < truth.host_gaps
    steps = steps + gap * ts * rng.integers(HOST_GAP_STEPS[0], HOST_GAP_STEPS[1] + 1, m)
    inst = ts * rng.random() + np.concatenate([[0.0], np.cumsum(steps[:-1])])
    inst = inst[inst < duration]
    clip = STAMP_NOISE_CLIP * ts
    stamps = inst + np.clip(truth.stamp_noise * rng.standard_normal(inst.size), -clip, clip)
    return inst, stamps


def breakaway_current(truth: "RotaryTruth", direction: float = 1.0, n: int | None = None) -> float:
    """The least demand (A, in the drive's ``k0`` units) at which a rotor at rest turns in ``direction`` from every
    angle: where the static torque ``k0 (1 + ρ)(u + e(θ, u)) + T_cog`` (the drive's current errors ``e``,
    :func:`drive_current_error`) exceeds the friction ``T_c + D(θ)`` that creeping meets, everywhere. Below it, a speed
    loop whose current at standstill is less stalls on the first angle that holds it (a cogging or drive-error peak).

    Args:
        truth: the twin; direction: ``+1`` or ``-1``; n: angles on the revolution (default 16 per highest order).

    Returns:
        A, at most the current limit (a rotor the limit cannot turn everywhere).
    """
    s = 1.0 if direction >= 0 else -1.0
    orders = np.concatenate([truth.cogging.orders, truth.ripple.orders, truth.drag.orders,
                             [6 * truth.motor.pole_pairs]])
    n = int(n or 16 * max(1, int(orders.max())))
    th = 2 * math.pi * np.arange(n) / n

    def excess(x, u):
        iq = np.full(x.shape, s * u)
        t = truth.k0 * (1.0 + truth.ripple(x)) * (iq + drive_current_error(truth, x, iq)) + truth.cogging(x)
        return s * t - truth.coulomb - truth.drag(x)

    def margin(u):
        # the least excess on the grid, refined between the grid's neighbours of its smallest
        v = excess(th, u)
        j = int(np.argmin(v))
        step = 2 * math.pi / n
        res = minimize_scalar(lambda x: float(excess(np.array([x]), u)[0]), bounds=(th[j] - step, th[j] + step),
                              method="bounded", options={"xatol": 1e-12})
        return min(float(v[j]), float(res.fun))

    lo, hi = 0.0, truth.rated_current()
    if margin(hi) <= 0:
        return hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if margin(mid) > 0 else (mid, hi)
    return hi


@dataclass(frozen=True)
class Gains:
    """Feedback gains of the drive, in current units (A per rad, per rad/s, ...).

    Position loop (PID): ``u = kp e + ki ∫e + kd ė``; speed loop (PI): ``u = kpv e_v + kiv ∫e_v``.
    """

    kp: float
    ki: float
    kd: float
    kpv: float
    kiv: float


def default_gains(inertia_ratio: float, position_hz: float = 15.0, speed_hz: float = 30.0) -> Gains:
    """Pole-placement gains for the plant ``(J/k0) θ̈ = u``.

    Position: a triple pole at ``2π position_hz``; speed: a double pole at ``2π speed_hz``.

    Args:
        inertia_ratio: ``J/k0`` (A·s²/rad), nominal or identified.
    """
    a = float(inertia_ratio)
    wp, wv = 2 * math.pi * position_hz, 2 * math.pi * speed_hz
    return Gains(kp=3 * a * wp**2, ki=a * wp**3, kd=3 * a * wp, kpv=2 * a * wv, kiv=a * wv**2)


@dataclass(frozen=True)
class LawParams:
    """A commutation law plus its feedforward, as the simulator runs it (current units).

    ``i_q = (u − c(θ) + d(θ) s) / (1 + r(θ)) + table(θ)``, ``u = fb + ff_a α_r + ff_b ω_r + ff_d s + dither``
    with ``s = sign(ω_r)``; ``table`` (``(n,)`` A, linear interpolation on ``θ_j = 2π j/n``) is the
    drives' standstill table. The maps and the table are read at ``θ = θ_enc + advance · ω̂ T_s``
    (``advance`` in samples, ω̂ the drive's velocity estimate): ½ is the middle of the sample over
    which the current is held (module docstring), 0 the encoder angle as sampled.

    A drive with a table per direction (``table_reverse``, same size) uses ``table`` until its speed
    estimate ω̂ falls below ``−hysteresis/2`` and ``table_reverse`` until it rises above ``+hysteresis/2``
    (rad/s; inside the band the table in use stays); a drive that fades its table out with speed
    (``fade = (start, end)``, rad/s) scales it by 1 up to ``|ω̂| = start``, linearly to 0 at ``end``.

    """

    model: RotaryModel
    table: np.ndarray | None = None
    ff_a: float = 0.0
    ff_b: float = 0.0
    ff_d: float = 0.0
    advance: float = HOLD_ADVANCE
    table_reverse: np.ndarray | None = None
    hysteresis: float = 0.0
    fade: tuple | None = None

    @classmethod
    def classical(cls, pole_pairs: int, ff_a=0.0, ff_b=0.0, ff_d=0.0) -> "LawParams":
        return cls(RotaryModel.zero(pole_pairs), None, ff_a, ff_b, ff_d)


@dataclass(frozen=True)
class Reference:
    """Reference samples for one run: ``(N,)`` each. ``mode`` ``"position"`` or ``"speed"``.

    Attributes:
        theta: rad; omega: rad/s; alpha: rad/s²; dither: current added to the demand (A).
    """

    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    mode: str = "position"
    dither: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(np.asarray(self.theta).shape[0])


def _pad(n: int) -> int:
    """Array length padded to a multiple of 16 (fewer distinct shapes, fewer compilations)."""
    return max(16, -(-n // 16) * 16)


def _pack_fourier(parts, n_pad):
    """Concatenate Fourier maps into one order vector and one coefficient block per map (zero-padded)."""
    orders = np.concatenate([p.orders for p in parts]).astype(float)
    total = orders.size
    pad = n_pad - total
    h = np.concatenate([orders, np.zeros(pad)])
    blocks = []
    pos = 0
    for p in parts:
        a = np.zeros(n_pad)
        b = np.zeros(n_pad)
        a[pos:pos + p.orders.size] = p.coef[:, 0]
        b[pos:pos + p.orders.size] = p.coef[:, 1]
        blocks.append((a, b))
        pos += p.orders.size
    return h, blocks


def _order_bits(orders: np.ndarray) -> np.ndarray:
    """``(n, B)`` the binary digits (0/1, least significant first) of non-negative integer orders, ``B`` the bit
    length of the highest (at least 1): what :func:`_harmonics` multiplies by."""
    h = np.asarray(orders, float)
    if np.any(h < 0) or not np.array_equal(h, np.round(h)):
        raise ValueError(f"the twin's orders must be non-negative integers, got {h[(h < 0) | (h != np.round(h))][:3]}")
    hi = h.astype(np.int64)
    nbits = max(1, int(hi.max(initial=0)).bit_length())
    return ((hi[:, None] >> np.arange(nbits)[None, :]) & 1).astype(float)


def _harmonics(bits, theta):
    """``(cos(h θ), sin(h θ))`` ``(n,)`` each, for the orders whose binary digits are ``bits`` (:func:`_order_bits`).

    ``e^{i h θ}`` is the product of ``e^{i 2^b θ}`` over the set bits ``b``, each the square of the one before: two
    trigonometric calls per step for any number of orders, where ``cos(h θ)`` took two per order and per plant
    evaluation and was most of the twin's time (XLA's float64 sine costs ~30 ns). The phase's error grows with
    the order as the rounding of ``h θ`` does in the closed form.
    """
    th = jnp.mod(theta, 2 * jnp.pi)
    zr, zi = jnp.cos(th), jnp.sin(th)
    cr = jnp.ones(bits.shape[0])
    ci = jnp.zeros(bits.shape[0])
    for b in range(bits.shape[1]):
        sel = bits[:, b]
        nr, ni = cr * zr - ci * zi, cr * zi + ci * zr
        cr, ci = cr + sel * (nr - cr), ci + sel * (ni - ci)
        zr, zi = zr * zr - zi * zi, 2.0 * zr * zi
    return cr, ci


@partial(jax.jit, static_argnames=("n_sub",))
def _run(params, xs, n_sub: int):
    (h_p, rho_a, rho_b, cog_a, cog_b, drag_a, drag_b, k0, coul, visc, inertia, w_eps, ts, q,
     h_l, lc_a, lc_b, lr_a, lr_b, ld_a, ld_b, table, n_table, ff_a, ff_b, ff_d,
     kp, ki, kd, kpv, kiv, beta, i_lim, mode_pos, theta0, advance,
     use_pll, pll_kp, pll_ki, errors_on, sensors, index0, pole_pairs, comm_offset, table_rev, band, fade_s,
     fade_e, dt_a, dt_c, dt_k, ma, mc) = params
    dt = ts / n_sub
    o_a, o_b, g_a, g_b, dt_e, dt_w, tan_d = sensors

    def plant_torque(theta, omega, iq):
        c, s = _harmonics(h_p, theta)
        # sums of products rather than dot products: XLA fuses them into one loop, where each small dot was a
        # library call of its own (the dots were half the twin's time)
        rho = jnp.sum(c * rho_a + s * rho_b)
        cog = jnp.sum(c * cog_a + s * cog_b)
        drag = jnp.sum(c * drag_a + s * drag_b)
        t_em = k0 * (1.0 + rho) * iq + cog
        return t_em, t_em - (coul + drag) * jnp.tanh(omega / w_eps) - visc * omega

    def step(carry, x):
        theta, omega, th_prev, w_f, integ, acc, pe, ve, dstate, zcd, zcq, zad, zaq = carry
        th_r, w_r, a_r, dith = x
        # the encoder's count; the estimates are made from it as in power_up 0 (they are translation-invariant), and
        # the power-up's offset (index0, whole counts) is added where the drive uses its angle as such
        th_m = jnp.round(theta / q) * q
        w_f = w_f + beta * ((th_m - th_prev) / ts - w_f)
        # ODrive's encoder PLL: predict, then correct with the count
        pe = pe + ts * ve
        e_pll = th_m - pe
        pe = pe + ts * pll_kp * e_pll
        ve = ve + ts * pll_ki * e_pll
        th_0 = jnp.where(use_pll > 0, pe, th_m)
        th_d = th_0 + index0
        w_d = jnp.where(use_pll > 0, ve, w_f)
        e_p, e_v = th_r - th_d, w_r - w_d
        integ = integ + ts * (mode_pos * e_p + (1.0 - mode_pos) * e_v)
        u_fb = mode_pos * (kp * e_p + ki * integ + kd * e_v) + (1.0 - mode_pos) * (kpv * e_v + kiv * integ)
        sgn = jnp.sign(w_r)
        u = u_fb + ff_a * a_r + ff_b * w_r + ff_d * sgn + dith
        # the commutation law at the angle of the middle of the hold (LawParams.advance)
        th_l = th_d + advance * ts * w_d
        c, s = _harmonics(h_l, th_l)
        x_t = jnp.mod(th_l, 2 * jnp.pi) / (2 * jnp.pi) * n_table
        j0 = jnp.floor(x_t)
        fr = x_t - j0
        n_int = jnp.maximum(n_table, 1.0).astype(jnp.int32)
        j0 = j0.astype(jnp.int32) % n_int
        j1 = (j0 + 1) % n_int
        # a table per direction kept through a hysteresis band, and a fade-out with speed (LawParams), on the drive's
        # own speed estimate
        dstate = jnp.where(w_d > 0.5 * band, 1.0, jnp.where(w_d < -0.5 * band, -1.0, dstate))
        tab = jnp.where(dstate < 0, (1.0 - fr) * table_rev[j0] + fr * table_rev[j1],
                        (1.0 - fr) * table[j0] + fr * table[j1])
        tab = tab * jnp.where(fade_e > fade_s, jnp.clip((fade_e - jnp.abs(w_d)) / (fade_e - fade_s), 0.0, 1.0), 1.0)
        law_cog, law_dir = jnp.sum(c * lc_a + s * lc_b), jnp.sum(c * ld_a + s * ld_b)
        iq = (u - law_cog + law_dir * sgn) / (1.0 + jnp.sum(c * lr_a + s * lr_b)) + tab
        theta_e = pole_pairs * th_0 + comm_offset
        # the dead time's error (d, q) with no current loop at the command, through the loop's H(s) =
        # a s/((s + a)(s + ω_c)) = k (ω_c/(s + ω_c) - a/(s + a)), k = a/(ω_c - a) (deadtime_residual): the two
        # low-passes zc, za of the error held over the control cycle, each exact, and the residual k (zc - za) is
        # H's mean over the cycle (the current the plant holds; the cycle's end would lead it by half a cycle)
        def residual(i):
            e_d, e_q = _deadtime_dq(jnp, theta_e, i, dt_e, dt_w)
            new = (zcd + dt_c * (e_d - zcd), zcq + dt_c * (e_q - zcq), zad + dt_a * (e_d - zad),
                   zaq + dt_a * (e_q - zaq))
            mean_d = dt_k * (zcd + mc * (e_d - zcd) - zad - ma * (e_d - zad))
            mean_q = dt_k * (zcq + mc * (e_q - zcq) - zaq - ma * (e_q - zaq))
            return new, mean_d, mean_q

        iq = jnp.where(jnp.isfinite(iq), iq, 0.0)  # a NaN demand gives zero current, never NaN torque
        iq = jnp.clip(iq, -i_lim, i_lim)
        # what the drive measures: the command and the dead time's residual; what flows: the measured current less
        # the sensors' errors, at the electrical angle the drive commutates with (calibrated again at every power-up:
        # the true frame's)
        (zcd, zcq, zad, zaq), meas_d, meas_q = residual(iq)
        meas_q = iq + meas_q
        i_flow = jnp.where(errors_on > 0,
                           meas_q + _current_error(jnp, theta_e, meas_q, o_a, o_b, g_a, g_b, tan_d, id_m=meas_d), iq)
        out = (th_d, w_d, theta, omega, 0.0, u, meas_q, i_flow, meas_d)
        t_em0, _ = plant_torque(theta, omega, i_flow)
        out = (*out[:4], t_em0, *out[5:])

        def sub(_, st):
            th, om, acc = st
            # exact for a torque constant over the sub-step (the held current's part is): semi-implicit
            # Euler's dt²/2 error per sub-step would bias the identified friction by tens of per cent under a 100 Hz
            # dither.
            # The torques are taken at the sub-step's middle, the angle and speed predicted from the last sub-step's
            # acceleration (second order, at one evaluation per sub-step): taken at its start, the angle's lag half a
            # sub-step, a turn of h ω dt / 2 of each harmonic that is odd in the direction, and the fit can hold an
            # odd torque at the largest cogging order only in the ripple's column there (through the friction's
            # current), where the cogging is thousands of times the ripple's torque, so a small turn is a large share
            # of the ripple there (bench/rotary_ripple_bias.py)
            _, t_net = plant_torque(th + 0.5 * dt * om + 0.125 * dt * dt * acc, om + 0.5 * dt * acc, i_flow)
            acc = t_net / inertia
            return th + dt * om + 0.5 * dt * dt * acc, om + dt * acc, acc

        theta_n, omega_n, acc_n = jax.lax.fori_loop(0, n_sub, sub, (theta, omega, acc), unroll=n_sub <= 4)
        return (theta_n, omega_n, th_m, w_f, integ, acc_n, pe, ve, dstate, zcd, zcq, zad, zaq), out

    q0 = jnp.round(theta0 / q) * q
    # the acceleration the first sub-step predicts its middle from: the rotor starts at rest, with none; the PLL
    # starts on the count, at rest
    carry0 = (theta0, 0.0 * theta0, q0, 0.0 * theta0, 0.0 * theta0, 0.0 * theta0, q0, 0.0 * theta0,
              1.0 + 0.0 * theta0, *(0.0 * theta0 for _ in range(4)))
    _, outs = jax.lax.scan(step, carry0, xs)
    return outs


@dataclass(frozen=True)
class Start:
    """How a run of :func:`simulate` starts, the rotor at rest.

    Attributes:
        power_up: the power-up (the drive's angle zero, :func:`power_up_offset`).
        theta: the rotor's true angle (rad); ``None``: the reference's first angle less the power-up's offset.
    """

    power_up: int = 0
    theta: float | None = None


def simulate(truth: RotaryTruth, ref: Reference, law: LawParams, gains: Gains, seed: int = 0, *,
             n_sub: int = SUBSTEPS, host: bool = False, start: Start = Start()) -> dict[str, np.ndarray]:
    """Closed-loop run of the twin on a drive with ``law``.

    Args:
        truth: the motor (:class:`RotaryTruth`).
        ref: reference samples (:class:`Reference`, in the drive's frame); the run has ``ref.n`` samples of ``T_s``.
        law: commutation law and feedforward (:class:`LawParams`).
        gains: feedback gains (:class:`Gains`).
        seed: current-noise seed (same seed, same numbers).
        n_sub: plant sub-steps per logged sample (per control sample ``ceil(n_sub / K)``, at least 2, where the drive
            controls at ``K = truth.control_per_log`` times the log rate).
        host: the log as the truth's host records it (:attr:`RotaryTruth.host_logger`: rows at jittered instants,
            :func:`host_instants`); the same as ``False`` for a truth without a host's habits. ``False``: the drive's
            own samples ``j T_s`` (for evaluations against the reference).
        start: the power-up and the rotor's initial angle (:class:`Start`).

    Returns:
        dict of ``(N,)`` arrays at the logged instants ``j T_s``: ``t`` (s), ``theta`` (the drive's angle: encoder or
        PLL, rad), ``velocity`` (rad/s, the drive's estimate), ``iq_1`` (A, the drive's report of the current it
        measures, with noise), ``id_1`` (A, noise), ``theta_true``, ``omega_true``, ``torque`` (air-gap N·m, with
        ``torque_noise``), ``iq_true`` (A, the current that flows from that instant, in the drive's ``k0`` units:
        ``torque`` is :meth:`RotaryTruth.air_gap_torque` of it), ``iq_drive`` (A, the current the drive measures and
        holds, before its report's filter), ``demand`` (A), ``theta_ref``, ``omega_ref``; and ``vq_1``, ``vd_1`` (V,
        the drive's q- and d-voltage commands, :mod:`pgcomm.rotary.winding`) when ``truth.winding`` is set. Where the
        drive controls faster than it logs (``control_per_log = K > 1``) the references are interpolated to the
        control samples by a cubic spline and every column is the snapshot of every ``K``-th control sample; the
        measurement noises are drawn per logged sample, so they are the same numbers for every ``K``. With ``host``
        and a host's habits, ``N`` rows at the host's instants (``t_instant``, s): the drive's columns those of its
        last control cycle before the instant, the rotor's (``theta_true``, ``omega_true``, ``torque``) at the
        instant (cubic Hermite between control cycles), ``t`` the host's stamp.
    """
    m = truth.motor
    ts = float(m.sample_time)
    k_ctl = truth.control_per_log
    tc = ts / k_ctl
    n = ref.n
    n_f = n * k_ctl
    n_pad = _pad(truth.ripple.orders.size + truth.cogging.orders.size + truth.drag.orders.size)
    h_p, ((ra, rb), (ca, cb), (da, db)) = _pack_fourier([truth.ripple, truth.cogging, truth.drag], n_pad)
    lm = law.model
    n_lpad = _pad(lm.cogging.orders.size + lm.ripple.orders.size + lm.direction.orders.size)
    h_l, ((lca, lcb), (lra, lrb), (lda, ldb)) = _pack_fourier([lm.cogging, lm.ripple, lm.direction], n_lpad)
    if law.table is None:
        table, n_table = np.zeros(16), 0
    else:
        t = np.asarray(law.table, float)
        table, n_table = np.concatenate([t, np.zeros(_pad(t.size) - t.size)]), t.size
    table_rev = table
    if law.table_reverse is not None:
        t = np.asarray(law.table_reverse, float)
        if t.size != n_table:
            raise ValueError(f"table_reverse has {t.size} entries, table {n_table}")
        table_rev = np.concatenate([t, np.zeros(_pad(t.size) - t.size)])
    fade_s, fade_e = (0.0, 0.0) if law.fade is None else (float(law.fade[0]), float(law.fade[1]))
    i_lim = float(m.current_limit) if m.current_limit else np.inf
    beta = 1.0 - math.exp(-2 * math.pi * VELOCITY_CUTOFF_HZ * tc)
    q = 2 * math.pi / truth.encoder_counts
    mode_pos = {"position": 1.0, "speed": 0.0}[ref.mode]
    index0 = power_up_offset(truth, start.power_up)
    th0 = float(ref.theta[0]) - index0 if start.theta is None else float(start.theta)
    f = float
    bw = f(truth.pll_bandwidth)
    dte = f(truth.deadtime_error)
    sensors = (*truth.sensor_offset, *truth.sensor_gain, dte, f(truth.deadtime_width) if dte > 0 else 1.0,
               math.tan(truth.offset_error))
    params = (jnp.asarray(_order_bits(h_p)), *(jnp.asarray(v) for v in (ra, rb, ca, cb, da, db)), f(truth.k0),
              f(truth.coulomb),
              f(truth.viscous), f(truth.inertia), f(truth.friction_velocity), tc, q,
              jnp.asarray(_order_bits(h_l)), *(jnp.asarray(v) for v in (lca, lcb, lra, lrb, lda, ldb)),
              jnp.asarray(table),
              float(n_table), f(law.ff_a), f(law.ff_b), f(law.ff_d),
              f(gains.kp), f(gains.ki), f(gains.kd), f(gains.kpv), f(gains.kiv), beta, i_lim, mode_pos, th0,
              f(law.advance), 1.0 if bw > 0 else 0.0, 2.0 * bw, bw * bw, 1.0 if truth.drive_errors else 0.0,
              tuple(f(x) for x in sensors), index0, f(m.pole_pairs), f(m.commutation_offset), jnp.asarray(table_rev),
              f(law.hysteresis), fade_s, fade_e,
              *_deadtime_loop(truth, tc))
    rng = np.random.default_rng(seed)
    dither = np.zeros(n) if ref.dither is None else np.asarray(ref.dither, float)
    refs = [np.asarray(v, float) for v in (ref.theta, ref.omega, ref.alpha, dither)]
    if k_ctl > 1:
        # a drive generates its references and dither at its own rate: smooth between the logged samples (a linear
        # interpolation's kinks put 3 % of a 100 Hz dither's amplitude into every logged interval's mean)
        t_f = np.minimum(tc * np.arange(n_f), ts * (n - 1))
        refs = [CubicSpline(ts * np.arange(n), v)(t_f) if n > 1 else np.repeat(v, k_ctl) for v in refs]
        n_sub = max(2, -(-int(n_sub) // k_ctl))
    outs = [np.asarray(o) for o in _run(params, tuple(jnp.asarray(v) for v in refs), n_sub)]
    filtered = truth.report_filter > 0
    if filtered:
        # the drive's report: y_k = y_{k-1} + (1 - a)(i_k - y_{k-1}) every control cycle, from zero (no current
        # before the run), of the current it measures: its sensors' noise, drawn per control cycle, goes through the
        # filter too (read back, it is white again: ODrive's filtered Iq_measured reads back as smoothly as it does)
        a = math.exp(-tc / truth.report_filter)
        sensed = truth.current_noise * np.random.default_rng([int(seed), 0x5E45]).standard_normal((2, n_f))
        report = lfilter([1.0 - a], [1.0, -a], outs[6] + sensed[0])
        report_d = lfilter([1.0 - a], [1.0, -a], outs[8] + sensed[1])
    else:
        report = outs[6]
    on_host = host and truth.host_logger and n_f > 1
    if on_host:
        # the host's own stream: a twin without one draws the noises it always drew
        inst, stamps = host_instants(truth, (n_f - 1) * tc, np.random.default_rng([int(seed), 0x4057]))
        idx = np.minimum(np.floor(inst / tc).astype(np.int64), n_f - 2)
    else:
        idx = np.arange(n) * k_ctl
    rows = idx.size
    noise = rng.standard_normal((3, rows))
    th_m, w_f, th_f, om_f, tq, u, iq_act, i_flow, id_act = (o[idx] for o in outs)
    rep = report[idx]
    if on_host:
        # the rotor between control cycles: the cubic through the angles and speeds at their ends
        x = (inst - idx * tc) / tc
        th0_, th1_ = outs[2][idx], outs[2][idx + 1]
        om0_, om1_ = outs[3][idx], outs[3][idx + 1]
        h00, h10, h01, h11 = 2 * x**3 - 3 * x**2 + 1, x**3 - 2 * x**2 + x, -2 * x**3 + 3 * x**2, x**3 - x**2
        th_f = h00 * th0_ + h10 * tc * om0_ + h01 * th1_ + h11 * tc * om1_
        om_f = ((6 * x**2 - 6 * x) * (th0_ - th1_) / tc + (3 * x**2 - 4 * x + 1) * om0_ + (3 * x**2 - 2 * x) * om1_)
        tq = truth.air_gap_torque(th_f, i_flow)
        t_log = stamps
        th_ref, om_ref = refs[0][idx], refs[1][idx]
    else:
        t_log = ts * np.arange(n)
        th_ref, om_ref = np.asarray(ref.theta, float), np.asarray(ref.omega, float)
    if filtered:
        iq, idd = rep, report_d[idx]
    else:
        iq = rep + truth.current_noise * noise[0]
        idd = id_act + truth.current_noise * noise[1]
    log = {"t": t_log, "theta": th_m, "velocity": w_f, "iq_1": iq, "id_1": idd, "theta_true": th_f,
           "omega_true": om_f, "iq_true": i_flow, "iq_drive": iq_act, "torque": tq + truth.torque_noise * noise[2],
           "demand": u, "theta_ref": th_ref, "omega_ref": om_ref}
    if on_host:
        log["t_instant"] = inst
    if truth.winding is not None:
        w = truth.winding
        # the voltages the loop commands between logged samples follow the current at the control rate (its slope
        # L di/dt); the logged noises are per logged sample, added to the snapshots
        # only the slope needs the control rate's samples; the rest is read at the logged instants; the winding
        # carries the current that flows
        di = np.gradient(outs[7], tc)[idx] if outs[7].size > 1 else np.zeros(rows)
        # drawn after the currents' noise, so a twin with a winding logs the same currents as one without
        v_noise = rng.standard_normal(rows)
        emf = truth.back_emf
        log["vq_1"] = (q_voltage(w, emf, th_f, om_f, i_flow, tc, slope=di) - w.loop_gain * (iq - rep)
                       + w.voltage_noise * v_noise)
        # drawn after the q-voltage's, which is then the same as a twin's that logs no d-voltage
        v_noise = rng.standard_normal(rows)
        log["vd_1"] = d_voltage(w, emf, th_f, om_f, i_flow) - w.loop_gain * (idd - id_act) + w.voltage_noise * v_noise
        if w.voltage_lag:
            log["vd_1"], log["vq_1"] = logged_dq(log["vd_1"], log["vq_1"], m.pole_pairs, om_f, w.voltage_lag)
    return log


def with_motor(truth: RotaryTruth, **changes) -> RotaryTruth:
    """``truth`` with fields of its motor replaced (e.g. ``sample_time``)."""
    return replace(truth, motor=replace(truth.motor, **changes))
