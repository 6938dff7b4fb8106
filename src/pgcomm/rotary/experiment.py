"""``pgcomm reproduce`` on a rotary motor: running logs -> identification -> laws in closed loop.

Rows (all on the same twin, same seeds, same feedback gains):

``classical``
    no compensation: ``i_q = u``, with the feedforward a drive user tunes (inertia, viscous and
    Coulomb friction fitted on the running logs, :func:`pgcomm.rotary.identify.fit_mechanics`).
``standstill_table``
    the drives' method: the table of a standstill sweep (:mod:`pgcomm.rotary.standstill`) added to
    ``u``, same feedforward as ``classical``.
``model``
    the law of the model identified from running logs without a torque sensor
    (:mod:`pgcomm.rotary.law`), with the feedforward of its own identification (``J/k0``, ``b``;
    the Coulomb term is its direction map).
``oracle``
    the law with the true map and the true feedforward: the floor.

Figures per row: tracking MSE of the position loop (rad²) and of the speed loop ((rad/s)²), the
commutation error (the torque disturbance the feedback must fight, as an equivalent current:
``(T_em − (T_c + D) s − b ω)/k0 − u_ff,true``, MSE in A²), and the reducible share
``(classical − row)/(classical − oracle)``. Identification: RMS error of cogging and ripple
against the truth over the revolution (relative to the truth's RMS), and the agreement of the
running-log table with the standstill table against the sweep's noise.

**How long to log.** After the first round of running logs, the identification's standard errors
(time-block sandwich, :func:`pgcomm.rotary.identify.identify`) say whether the cogging and the
ripple are resolved to 5 % of their RMS and how much longer the logs would have to be. By default the
rounds fill :attr:`~pgcomm.settings.RotarySettings.log_budget_share` of the sweep's time
(:attr:`~pgcomm.settings.RotarySettings.stop_when_resolved`
says why); with ``stop_when_resolved`` more rounds are recorded only while a map is unresolved and they
fit the budget, the need estimated again after every batch (the standard error of a short log is itself
uncertain). The
ripple needs current: a free rotor carries a large q-current only briefly (the speed swing of a
dither ``a`` at ``f`` is ``a k0/(J 2πf)``), so a high-pole-count motor with a light rotor may end
the budget with its ripple unresolved; the results say so (``identification.standard_error``).
Noise streams are named (:func:`pgcomm.seeds.stream_seed`: ``"rotary running log", round, i``,
``"rotary standstill sweep"``, ``"rotary evaluation", loop``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from pgcomm.seeds import stream_seed
from pgcomm.rotary.identify import fit_mechanics, identify, map_text, resolution_verdict
from pgcomm.settings import RotaryIdentifyOptions
from pgcomm.rotary.readings import delay_text, lag_of
from pgcomm.rotary.regression import Orders, max_speed
from pgcomm.rotary.model import RotaryModel
from pgcomm.rotary.standstill import run_standstill, sweep_reference
from pgcomm.rotary.twin import Gains, LawParams, Reference, RotaryTruth, Start, breakaway_current, default_gains, \
    simulate
from pgcomm.settings import RotarySettings, StandstillPlan
from pgcomm.progress import Progress

__all__ = ["running_references", "running_log", "record_running_logs", "RunningLogs", "slower_for_the_host_clock",
           "drive_log_mix", "tracking_references", "closed_loop", "run", "identification_errors", "ROWS",
           "quick_settings", "QUICK_OVERRIDES", "stall_log", "polled_by_host", "speed_loop_log"]

ROWS = ("classical", "standstill_table", "model", "oracle")
#: Running-log and standstill tables agree "within the noise of the sweep" when their RMS difference is at
#: most this factor times the sweep's own RMS error against the truth (sqrt(2) for two equally good tables).
AGREEMENT_FACTOR = 1.5
#: The evaluation runs at a share of the speed at which the highest cogging order still has this many
#: samples per period: a compensation held for a sample cannot follow a harmonic much faster (the
#: identification's alias guard, :data:`pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD`, is looser: it
#: only has to integrate the torque along the path, not cancel it).
EVAL_MIN_SAMPLES_PER_PERIOD = 8.0


#: The ``[rotary_experiment]`` keys :func:`quick_settings` sets (``reproduce --quick`` refuses them in ``--config``).
QUICK_OVERRIDES = ("rotary_experiment.revolutions", "rotary_experiment.eval_revolutions",
                   "rotary_experiment.standstill.points", "rotary_experiment.standstill.settle",
                   "rotary_experiment.standstill.average")


def quick_settings(settings: RotarySettings = RotarySettings()) -> RotarySettings:
    """A short run for a first look and for tests: ``settings`` with one revolution per running-log segment, half a
    revolution per evaluation run and a 720-angle standstill sweep (:data:`QUICK_OVERRIDES`)."""
    return replace(settings, revolutions=1.0, standstill=StandstillPlan(points=720, settle=30, average=20),
                   eval_revolutions=0.5)


def _ramp_profile(omega: float, n_cruise: int, n_ramp: int, ts: float):
    """Speed profile: smooth (raised-cosine) ramp up, cruise, ramp down. Returns ``(ω, α)``."""
    up = 0.5 * (1 - np.cos(np.pi * np.arange(n_ramp) / n_ramp))
    prof = np.concatenate([up, np.ones(n_cruise), up[::-1]]) * omega
    alpha = np.gradient(prof, ts)
    return prof, alpha


def running_references(truth_motor, inertia_ratio: float, settings: RotarySettings, orders: Orders) -> list:
    """The running logs' references: speed loop at two speeds in both directions with a q-current dither.

    Args:
        truth_motor: :class:`RotaryMotor` (sample time, current limit).
        inertia_ratio: nominal ``J/k0`` (A·s²/rad) the drive is tuned with (bounds the dither).
        settings: :class:`RotarySettings`; orders: the model's orders (the alias guard's limit).

    Returns:
        list of :class:`Reference` (speed mode).
    """
    ts = truth_motor.sample_time
    v_lim = max_speed(orders, ts)
    i_lim = truth_motor.current_limit or 10.0
    refs = []
    for share in settings.speed_shares:
        for sign in (+1.0, -1.0):
            w = share * v_lim
            n_cruise = int(math.ceil(settings.revolutions * 2 * math.pi / w / ts))
            n_ramp = int(0.2 / ts)
            om, al = _ramp_profile(sign * w, n_cruise, n_ramp, ts)
            t = ts * np.arange(om.size)
            # dither amplitude per frequency: the speed swing a/(J/k0 · 2πf) stays below swing · w
            amp = [min(settings.dither_share * i_lim / len(settings.dither_hz),
                       settings.swing * w * 2 * math.pi * f * inertia_ratio / len(settings.dither_hz))
                   for f in settings.dither_hz]
            dith = sum(a * np.sin(2 * math.pi * f * t + k) for k, (a, f) in enumerate(zip(amp, settings.dither_hz)))
            dith = dith * (np.abs(om) >= 0.999 * w)  # only while cruising
            th = np.cumsum(om) * ts
            refs.append(Reference(th, om, al, "speed", dith))
    return refs


def running_log(truth: RotaryTruth, ref: Reference, law: LawParams, gains, seed: int) -> dict:
    """One running log (:func:`pgcomm.rotary.twin.simulate`) that starts at an angle drawn from ``seed``.

    A rig never starts two logs at the same angle to a fraction of an encoder count; the twin, without process
    noise, would: every round of the same reference would then retrace the same path, with the same encoder
    quantisation error in every sample, and more rounds would not average it (on 16-bit encoders the screening
    took that repeated error for a dozen orders outside the basis).

    The log is the host's where the truth has a host's habits (``simulate(..., host=True)``: jittered rows), in
    power-up 0.

    Args:
        truth: the twin; ref: a speed-loop :class:`Reference`; law, gains: as for ``simulate``;
        seed: the log's noise seed (also draws the start angle, uniform over the revolution).
    """
    start = float(np.random.default_rng([int(seed), 0x57A7]).uniform(0.0, 2 * math.pi))
    shifted = Reference(np.asarray(ref.theta, float) + start, ref.omega, ref.alpha, ref.mode, ref.dither)
    return simulate(truth, shifted, law, gains, seed=seed, host=True)


def polled_by_host(truth: RotaryTruth, step: float) -> RotaryTruth:
    """``truth`` logged by a host that polls it about every ``step`` (s; its median step): the drive keeps its control
    rate (``control_per_log`` control cycles per ``step``, at least one)."""
    rate = truth.control_per_log / truth.motor.sample_time
    return replace(truth, motor=replace(truth.motor, sample_time=float(step)),
                   control_per_log=max(1, round(rate * step)))


def speed_loop_log(truth: RotaryTruth, speed: float, seconds: float, seed: int) -> dict:
    """What a robot joint's drive records in its own speed loop: a 0.5 s ramp from standstill to ``speed`` (rad/s, its
    sign the direction), then ``seconds`` at it, one direction, no dither, the drive's tuned classical law
    (:func:`running_log`, the host's log where the truth has a host's habits)."""
    ts = truth.motor.sample_time
    a = truth.inertia / truth.k0
    law = LawParams.classical(truth.motor.pole_pairs, a, truth.viscous / truth.k0, truth.coulomb / truth.k0)
    om = np.concatenate([np.linspace(0.0, speed, int(0.5 / ts)), np.full(int(seconds / ts), speed)])
    return running_log(truth, Reference(np.cumsum(om) * ts, om, np.gradient(om, ts), "speed"), law,
                       default_gains(a), seed)


def stall_log(truth: RotaryTruth, seed: int = 0, seconds: float = 10.0, direction: float = 1.0,
              power_up: int = 0) -> dict:
    """A low-speed run in a speed loop too soft for the cogging, which stalls about halfway: what two of three runs
    at 0.1 rev/s did on the ODrive of ``../real``.

    The loop is the drive's tuned proportional gain ``k_pv`` (:func:`pgcomm.rotary.twin.default_gains` at the true
    ``J/k0``) with its integrator off and no feedforward: at standstill its current is ``k_pv ω_r``. The reference
    falls linearly from 1.5 to 0.5 times the speed at which that current equals the break-away current
    (:func:`pgcomm.rotary.twin.breakaway_current`: the cogging, the drive's current errors and the friction), so the
    rotor turns in the first half and sticks on the first angle that holds it in the second (at these speeds the
    rotor's kinetic energy is small against a cogging period's). The log is the host's where the truth has a host's
    habits.

    Args:
        truth: the twin; seed: noise seed (also the start angle); seconds: the run's length (s);
        direction: ``+1`` or ``-1``; power_up: the power-up.

    Returns:
        the log (:func:`pgcomm.rotary.twin.simulate`), with ``stall_speed`` (rad/s, the speed at which the loop's
        standstill current is the break-away current) beside the columns.
    """
    ts = truth.motor.sample_time
    a = truth.inertia / truth.k0
    kpv = default_gains(a).kpv
    s = 1.0 if direction >= 0 else -1.0
    w_b = breakaway_current(truth, s) / kpv
    n = max(2, int(round(seconds / ts)))
    om = s * w_b * np.linspace(1.5, 0.5, n)
    start = float(np.random.default_rng([int(seed), 0x57A7]).uniform(0.0, 2 * math.pi))
    ref = Reference(start + ts * np.cumsum(om), om, np.gradient(om, ts), "speed")
    log = simulate(truth, ref, LawParams.classical(truth.motor.pole_pairs), Gains(0.0, 0.0, 0.0, kpv, 0.0),
                   seed=seed, host=True, start=Start(power_up=power_up))
    log["stall_speed"] = s * w_b
    return log


def drive_log_mix(truth: RotaryTruth, seed: int = 0) -> dict:
    """The logs a drive user already has, without a dither (constant speeds, accelerations, a slow sweep), in the drive's speed loop with
    the classical law and its tuned feedforward:

    * ``const``: four runs of 8 s at 0.3 and 0.6 of the alias guard's speed limit, both directions;
    * ``accel``: two runs (one per direction) of repeated speed ramps between 0.2 and 0.9 of the limit at half
      the current limit's acceleration (each ramp at least 50 ms);
    * ``sweep``: the drives' slow sweep, a revolution each way in 60 s (position loop).

    All as the host logs them where the truth has a host's habits, in one power-up.

    Args:
        truth: the twin; seed: noise seed (streams ``"drive log mix", k``; each run starts at its own angle).

    Returns:
        ``{"const": [log, ...], "accel": [...], "sweep": [log]}``, logs as :func:`pgcomm.rotary.twin.simulate`'s.
    """
    m = truth.motor
    ts = m.sample_time
    a = truth.inertia / truth.k0
    gains = default_gains(a)
    # the feedforward a drive user tunes (the twin's true values: these logs are for identification)
    law = LawParams.classical(m.pole_pairs, a, truth.viscous / truth.k0, truth.coulomb / truth.k0)
    v_lim = max_speed(Orders.for_motor(m), ts)
    logs = {"const": [], "accel": [], "sweep": []}
    k = 0
    for share in (0.3, 0.6):
        for sign in (1.0, -1.0):
            om, al = _ramp_profile(sign * share * v_lim, int(8 / ts), int(0.3 / ts), ts)
            k += 1
            logs["const"].append(running_log(truth, Reference(np.cumsum(om) * ts, om, al, "speed"), law, gains,
                                             stream_seed(seed, "drive log mix", k)))
    w = 0.9 * v_lim
    acc = min(0.5 * (m.current_limit or 10.0) / a, w / 0.05)
    for sign in (1.0, -1.0):
        up = np.linspace(0.2 * w, w, max(2, int(0.8 * w / acc / ts)))
        hold_hi, hold_lo = np.full(int(0.05 / ts), w), np.full(int(0.05 / ts), 0.2 * w)
        seg = np.concatenate([up, hold_hi, up[::-1], hold_lo])
        start = np.linspace(0.0, 0.2 * w, int(0.3 / ts))
        om = sign * np.concatenate([start, np.tile(seg, max(1, int(8.0 / (seg.size * ts)))), start[::-1]])
        k += 1
        logs["accel"].append(running_log(truth, Reference(np.cumsum(om) * ts, om, np.gradient(om, ts), "speed"),
                                         law, gains, stream_seed(seed, "drive log mix", k)))
    logs["sweep"].append(simulate(truth, sweep_reference(ts, 60.0), LawParams.classical(m.pole_pairs), gains,
                                  seed=stream_seed(seed, "drive log mix", "sweep"), host=True))
    return logs


def tracking_references(truth_motor, orders: Orders, settings: RotarySettings) -> dict:
    """Evaluation references: ``position`` (forward then back at the evaluation speed, position loop)
    and ``speed`` (the same profile in the speed loop)."""
    ts = truth_motor.sample_time
    w = settings.eval_share * max_speed(orders, ts, EVAL_MIN_SAMPLES_PER_PERIOD)
    n_cruise = int(math.ceil(settings.eval_revolutions * 2 * math.pi / w / ts))
    n_ramp = int(0.2 / ts)
    om_f, al_f = _ramp_profile(w, n_cruise, n_ramp, ts)
    pause = np.zeros(int(0.1 / ts))
    om = np.concatenate([pause, om_f, pause, -om_f, pause])
    al = np.concatenate([pause, al_f, pause, -al_f, pause])
    th = np.cumsum(om) * ts
    return {"position": Reference(th, om, al, "position"), "speed": Reference(th, om, al, "speed")}


def identification_errors(model: RotaryModel, truth: RotaryTruth, n: int = 4096) -> dict:
    """RMS errors over the revolution against the truth (relative to the truth's RMS, and absolute).

    Returns:
        ``{"cogging_rel", "cogging_rms_A", "ripple_rel", "ripple_rms", "direction_rel", "inertia_ratio_rel"}``.
    """
    tm = truth.model()
    th = 2 * math.pi * np.arange(n) / n

    def rel(a, b):
        e = float(np.sqrt(np.mean((a - b) ** 2)))
        r = float(np.sqrt(np.mean(b**2)))
        return e / r if r > 0 else float("nan"), e

    c_rel, c_abs = rel(model.cogging(th), tm.cogging(th))
    r_rel, r_abs = rel(model.ripple(th), tm.ripple(th))
    d_rel, _ = rel(model.direction(th), tm.direction(th))
    a_rel = abs(model.inertia_ratio / tm.inertia_ratio - 1) if model.inertia_ratio else float("nan")
    return {"cogging_rel": c_rel, "cogging_rms_A": c_abs, "ripple_rel": r_rel, "ripple_rms": r_abs,
            "direction_rel": d_rel, "inertia_ratio_rel": a_rel}


def _commutation_error(truth: RotaryTruth, log: dict, ref: Reference, gains_u_fb=None) -> np.ndarray:
    """Torque disturbance the feedback fights, as an equivalent current (A), per sample."""
    th, om, iq = log["theta_true"], log["omega_true"], log["iq_true"]
    k0 = truth.k0
    s = np.tanh(om / truth.friction_velocity)
    net = truth.air_gap_torque(th, iq) - (truth.coulomb + truth.drag(th)) * s - truth.viscous * om
    # what the feedback alone would have had to deliver on an ideal motor: u_fb = u - ff of the row; the
    # disturbance is the net torque beyond the feedback plus the ideal inertial feedforward
    return net / k0 - (log["u_fb"] + truth.inertia / k0 * ref.alpha)


def _tuned_drive(truth: RotaryTruth):
    """The drive the experiment runs: ``(orders, J/k0, gains, classical law)``; its gains come from the nominal
    ``J/k0`` (A·s²/rad), as a drive user tunes them."""
    a_nom = truth.inertia / truth.k0
    return (Orders.for_motor(truth.motor), a_nom, default_gains(a_nom),
            LawParams.classical(truth.motor.pole_pairs))


@dataclass
class RunningLogs:
    """What :func:`record_running_logs` recorded and identified.

    Attributes:
        logs: the running logs (dicts of :func:`running_log`), ``rounds`` times the references.
        identification: :class:`pgcomm.rotary.identify.RotaryIdentification` on all of them.
        rounds: rounds of the references recorded; round_seconds: rig time of one round (s).
        delay: the current's delay (logged samples) and lag: its lag within a sample (``None`` held), as read
            on the first round and kept for the longer logs.
        set_aside: rig time of a first round recorded and set aside (s; :func:`slower_for_the_host_clock`).
    """

    logs: list
    identification: object
    rounds: int
    round_seconds: float
    delay: int
    lag: object
    set_aside: float = 0.0

    @property
    def seconds(self) -> float:
        """Rig time of the running logs (s), a first round set aside included."""
        return self.rounds * self.round_seconds + self.set_aside


def slower_for_the_host_clock(host_clock: dict | None, settings: RotarySettings) -> RotarySettings | None:
    """The running logs' settings where a first round's angle carries a host's clock, else ``None``.

    The clock is there where the identification resolved a timing noise in the logged angle
    (``identification.host_clock.resolved``, :func:`pgcomm.rotary.host_clock.weigh`): logs stamped by the drive have
    none. The runs then go at :attr:`~pgcomm.settings.RotarySettings.host_clock_speed_shares` (the reason is there),
    each segment ``revolutions`` times the ratio of the mean speeds, so that a round takes about as long, and at least
    ``1 / len(shares)`` revolutions, so that the speeds together pass every angle in each direction.

    Args:
        host_clock: ``identification.host_clock`` of the first round (``None``: not read).
        settings: :class:`RotarySettings`.

    Returns:
        :class:`RotarySettings` with the slower ``speed_shares`` and ``revolutions``, or ``None`` where there is no
        clock, no ``host_clock_speed_shares``, or they are not slower.
    """
    slow = settings.host_clock_speed_shares
    if not host_clock or not host_clock.get("resolved") or not slow:
        return None
    ratio = float(np.mean(slow)) / float(np.mean(settings.speed_shares))
    if ratio >= 1.0:
        return None
    return replace(settings, speed_shares=slow, revolutions=max(settings.revolutions * ratio, 1.0 / len(slow)))


def record_running_logs(truth: RotaryTruth, settings: RotarySettings = RotarySettings(), seed: int = 0,
                        progress=None) -> RunningLogs:
    """Record rounds of running logs on ``truth`` and identify the map from them, without a torque sensor.

    One round of :func:`running_references` first (recorded again at slower speeds, the first set aside, where its
    angle carries a host's clock: :func:`slower_for_the_host_clock`); then, within ``settings.log_budget_share`` of
    the standstill sweep's rig time, either the whole budget (``settings.stop_when_resolved`` false) or rounds until the
    standard errors say both maps are resolved (module docstring, "How long to log"). The drive runs classical
    commutation with the gains of the nominal ``J/k0``. Noise streams: ``"rotary running log", round, i``.

    Args:
        truth: the twin (:class:`RotaryTruth`); settings: :class:`RotarySettings`; seed: noise seed.
        progress: :class:`pgcomm.progress.Progress` or ``None``.

    Returns:
        :class:`RunningLogs`; its identification has ``rounds``, ``first_round_standard_error``,
        ``log_budget_s`` (s) and the ``current_delay`` read on the first round.
    """
    progress = progress or Progress(enabled=False)
    motor = truth.motor
    ts = motor.sample_time
    orders, a_nom, gains, classical = _tuned_drive(truth)
    refs = running_references(motor, a_nom, settings, orders)
    round_seconds = sum(r.n for r in refs) * ts
    budget = settings.log_budget_share * settings.standstill.duration(ts)
    logs = []
    first_k = 0  # the first round's index in the noise streams (1 after a first round set aside)

    def record(rounds):
        for k in rounds:
            logs.extend(running_log(truth, r, classical, gains, stream_seed(seed, "rotary running log", first_k + k, i))
                        for i, r in enumerate(refs))

    with progress.stage("running logs (speed loop, two speeds, both directions, q-current dither)"):
        record([0])
    with progress.stage("identification from the running logs (no torque sensor)"):
        ident = identify(logs, motor, RotaryIdentifyOptions(orders=orders))
        set_aside, shares = 0.0, settings.speed_shares
        clock = slower_for_the_host_clock(ident.host_clock, settings)
        if clock is not None:
            # the first round is set aside: its timing readings were made through the clock at the faster speeds
            set_aside, shares = round_seconds, clock.speed_shares
            refs = running_references(motor, a_nom, clock, orders)
            round_seconds = sum(r.n for r in refs) * ts
            progress.info(f"the logged angle carries a host's clock ({ident.host_clock['sigma_t_us']:.3g} µs RMS): "
                          f"recording again at {', '.join(f'{s:g}' for s in shares)} of the alias guard's limit "
                          f"(timing errors cost in proportion to the speed); the first round's {set_aside:.0f} s set "
                          "aside")
            logs.clear()
            first_k = 1
            record([0])
            ident = identify(logs, motor, RotaryIdentifyOptions(orders=orders))
            budget_left = budget - set_aside
        else:
            budget_left = budget
        # the current's timing is the drive's: detected once, kept for the longer logs
        delay = ident.current_delay["samples"]
        lag = lag_of(ident.current_delay)
        rounds, max_rounds = 1, max(1, math.floor(budget_left / round_seconds))
        first = {k: dict(ident.standard_error[k]) for k in ("cogging", "ripple")}
        first_timing = dict(ident.current_delay)
        progress.info(delay_text(first_timing))
        if not settings.stop_when_resolved and max_rounds > 1:
            progress.info(f"recording the rest of the budget: {max_rounds - 1} more round(s) ({budget_left:.0f} s)")
            record(range(1, max_rounds))
            rounds = max_rounds
            ident = identify(logs, motor, RotaryIdentifyOptions(orders=orders, current_delay=delay, current_lag=lag))
        # log until both maps are resolved or the budget is spent; the standard error of a short log is itself
        # uncertain, so the need is re-estimated after every batch rather than trusted from the first round
        while rounds < max_rounds:
            se = ident.standard_error
            need = max(se["cogging"]["log_time_factor_to_resolve"], se["ripple"]["log_time_factor_to_resolve"])
            if need <= 1.0:
                break
            # an infinite need (the ridge or the encoder alone reach the share): the budget is all there is
            more = (int(min(math.ceil(rounds * need - 1e-9), max_rounds)) if math.isfinite(need) else max_rounds) - rounds
            if more < 1:
                break
            progress.info(f"standard errors: cogging {100 * se['cogging']['relative']:.1f} %, ripple "
                          f"{100 * se['ripple']['relative']:.1f} % of their RMS after {rounds * round_seconds:.0f} s "
                          f"of logs: recording {more} more round(s) (budget {budget:.0f} s)")
            record(range(rounds, rounds + more))
            rounds += more
            ident = identify(logs, motor, RotaryIdentifyOptions(orders=orders, current_delay=delay, current_lag=lag))
        ident = replace(ident, rounds=rounds, first_round_standard_error=first, log_budget_s=budget,
                        current_delay={**first_timing, "samples": delay}, speed_shares=list(shares),
                        set_aside_s=set_aside)
    return RunningLogs(logs, ident, rounds, round_seconds, delay, lag, set_aside)



def closed_loop(truth: RotaryTruth, laws: dict, gains, settings: RotarySettings, seed: int = 0) -> tuple[dict, dict]:
    """Each law in the position and the speed loop on :func:`tracking_references` (the same noise per loop).

    Args:
        truth: the twin; laws: ``{row: LawParams}``; gains: the drive's :class:`Gains`;
        settings: :class:`RotarySettings` (evaluation speed and length); seed: noise seed.

    Returns:
        ``(tracking, commutation)``: per row and loop, the tracking MSE (position rad², speed (rad/s)² over
        the cruise) and the commutation error's MSE (A², module docstring).
    """
    tracking, commutation = {}, {}
    evals = tracking_references(truth.motor, Orders.for_motor(truth.motor), settings)
    for row, law in laws.items():
        tracking[row], commutation[row] = {}, {}
        for loop, ref in evals.items():
            log = simulate(truth, ref, law, gains, seed=stream_seed(seed, "rotary evaluation", loop))
            ff = law.ff_a * ref.alpha + law.ff_b * ref.omega + law.ff_d * np.sign(ref.omega)
            log["u_fb"] = log["demand"] - ff
            if loop == "position":
                tracking[row][loop] = float(np.mean((ref.theta - log["theta_true"]) ** 2))
            else:
                cruise = np.abs(ref.omega) >= 0.999 * np.max(np.abs(ref.omega))
                tracking[row][loop] = float(np.mean((ref.omega - log["omega_true"])[cruise] ** 2))
            commutation[row][loop] = float(np.mean(_commutation_error(truth, log, ref) ** 2))
    return tracking, commutation


def run(truth: RotaryTruth, settings: RotarySettings = RotarySettings(), seed: int = 0, progress=None) -> dict:
    """The whole rotary experiment on ``truth`` (module docstring); returns the results dict.

    Args:
        truth: the twin (:class:`RotaryTruth`).
        settings: :class:`RotarySettings`.
        seed: noise seed (each run gets its own stream derived from it).
        progress: :class:`pgcomm.progress.Progress` or ``None``.

    Returns:
        dict with ``motor``, ``identification``, ``standstill``, ``tracking_mse``, ``commutation_mse``,
        ``reducible_share``, ``tracking_ratio_model_over_standstill``, ``timing`` and the models
        (``models``: the identified and true :class:`RotaryModel`, the standstill table).
    """
    progress = progress or Progress(enabled=False)
    t_start = time.perf_counter()
    motor = truth.motor
    orders, a_nom, gains, classical = _tuned_drive(truth)
    rec = record_running_logs(truth, settings, seed, progress)
    logs, ident, run_seconds = rec.logs, rec.identification, rec.seconds
    delay, lag = rec.delay, rec.lag
    with progress.stage("mechanics from the running logs (inertia ratio, friction)"):
        mech = fit_mechanics(logs, motor, RotaryIdentifyOptions(
            orders=orders, current_delay=delay, current_lag=lag, time_lines=ident.time_lines["hz"],
            current_filter=ident.current_filter["tau_s"]))
        errs = identification_errors(ident.model, truth)
        progress.info(f"cogging error {100 * errs['cogging_rel']:.1f} %, ripple error {100 * errs['ripple_rel']:.1f} "
                      f"% of the truth's RMS; ridge {ident.ridge:.0e}")
        for name in ("cogging", "ripple"):
            se = ident.standard_error[name]
            progress.info(map_text(name, se, run_seconds))
    with progress.stage(f"standstill sweep ({settings.standstill.points} angles, both directions)"):
        t0 = time.perf_counter()
        sweep = run_standstill(truth, gains, settings.standstill, seed=stream_seed(seed, "rotary standstill sweep"))
        sweep_sim = time.perf_counter() - t0
    n_pts = settings.standstill.points
    tab_model = ident.model.table(n_pts)
    tab_truth = truth.model().table(n_pts)
    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    agreement = {"rms_model_minus_sweep_A": rms(tab_model - sweep.table), "sweep_noise_A": sweep.noise,
                 "rms_sweep_minus_truth_A": rms(sweep.table - tab_truth),
                 "rms_model_minus_truth_A": rms(tab_model - tab_truth), "truth_rms_A": rms(tab_truth)}
    agreement["rms_forward_minus_reverse_A"] = rms(sweep.forward - sweep.reverse)
    # a model as good as the sweep differs from it by sqrt(2) x the sweep's own error, a perfect one by 1 x
    agreement["within_noise"] = bool(agreement["rms_model_minus_sweep_A"]
                                     <= AGREEMENT_FACTOR * agreement["rms_sweep_minus_truth_A"])
    laws = {
        "classical": LawParams.classical(motor.pole_pairs, mech["inertia_ratio"], mech["viscous"], mech["coulomb"]),
        "standstill_table": LawParams(classical.model, sweep.table, mech["inertia_ratio"], mech["viscous"],
                                      mech["coulomb"]),
        "model": LawParams(ident.model, None, ident.model.inertia_ratio, ident.model.viscous, 0.0),
        # the true maps: the floor of a commutation map (a drive's dead time, what its current loop leaves of it,
        # follows the current's history and stays in every row)
        "oracle": LawParams(truth.model(), None, a_nom, truth.viscous / truth.k0, 0.0),
    }
    with progress.stage("laws in closed loop (position and speed loops)"):
        tracking, commutation = closed_loop(truth, laws, gains, settings, seed)
    share = {}
    for row in ROWS:
        share[row] = {}
        for loop in ("position", "speed"):
            c, o = tracking["classical"][loop], tracking["oracle"][loop]
            share[row][loop] = (c - tracking[row][loop]) / (c - o) if c > o else None
    ratio = {loop: tracking["model"][loop] / tracking["standstill_table"][loop] for loop in ("position", "speed")}
    return {
        "motor": {**motor.to_dict(), "name": motor.name, "cogging_fundamental": motor.cogging_fundamental,
                  "k0_true": truth.k0, "inertia_ratio_true": truth.inertia / truth.k0,
                  "control_per_log": truth.control_per_log},
        "identification": {**ident.to_dict(), "errors": errs, "mechanics_fit": mech},
        "standstill": {"points": n_pts, "seconds": sweep.seconds, "noise_A": sweep.noise,
                       "simulation_seconds": sweep_sim, "agreement": agreement},
        "timing": {"running_logs_s": run_seconds, "standstill_s": sweep.seconds,
                   "running_over_standstill": run_seconds / sweep.seconds},
        "tracking_mse": tracking, "commutation_mse": commutation, "reducible_share": share,
        "tracking_ratio_model_over_standstill": ratio,
        "runtime_s": time.perf_counter() - t_start,
        "models": {"model": ident.model, "truth": truth.model(), "table": sweep.table},
    }
