"""A zoo of random, physically plausible rotary PMSM/BLDC motors with their truth.

Every claim about the rotary pipeline is checked over the zoo, never on one motor. A motor is
drawn from a seed and an index (the same pair always gives the same motor):

* slot/pole combination from common fractional-slot designs (:data:`COMBINATIONS`: the first
  eight motors take one each, in order, so any zoo of >= 8 motors covers them all);
* torque constant 0.02–2 N·m/A (log-uniform), current limit 5–40 A, inertia of rotor plus load
  with ``J/k_t`` 2e-3–2e-2 A·s²/rad;
* cogging RMS 0.5–5 % of the rated torque (``k_t`` times half the current limit): the
  multiples of ``LCM(Q, 2p)`` (falling with the multiple), magnet-tolerance sidebands at the
  multiples of ``Q``, stator-tolerance sidebands at the multiples of ``2p``, order 1 and 2 from
  eccentricity, and 2 % of it at an order outside the model's basis;
* torque-constant ripple RMS 0.5–3 %: eccentricity (1), magnet tolerances (2, 3, ``2p``), back-EMF
  harmonics (``6p``, ``12p``), slotting (``Q``), and 3 % of it outside the basis;
* the drive's commutation offset off by up to ±0.3 rad (electrical);
* Coulomb friction 0.5–3 % of rated torque with a position-dependent part of 10–40 % of it
  (orders 1, 2, ``2p``), viscous friction, encoder of 2^16–2^20 counts, current noise
  0.2–0.5 % of the limit;
* a winding behind the logged q-voltage (:func:`pgcomm.rotary.winding.draw_winding`: resistance, inductance, the
  inverter's dead time, the current loop's noise), drawn from a stream of its own;
* a drive that controls at 4-16 kHz (log-uniform, :data:`CONTROL_RATE_HZ`) and logs a snapshot every millisecond
  (:attr:`RotaryTruth.control_per_log`, the rate rounded to whole control cycles per logged sample), also from a
  stream of its own: real field-oriented drives run their loops many times per logged sample (ODrive 8 kHz,
  industrial servo drives 8-32 kHz), and a drive that controls only at its 1 kHz log rate cannot cancel the
  cogging orders a law must follow at speed.

With ``real_drive=True`` (``pgcomm zoo --kind rotary --real-drive``) every motor also gets a real drive's and host's
habits (:mod:`pgcomm.rotary.twin`, "A real drive's habits"), drawn from a stream of their own
(:func:`draw_drive_habits`, ranges in :data:`REAL_DRIVE_RANGES`): current-sensor offsets and gain mismatches of a few
per cent of the sensor's range, the inverter's dead time (its current loop leaves a residual), a filtered current report (none to 120 ms), ODrive's
encoder PLL (on two drives in three, 500-3000 rad/s), a host's jittered clock with gaps and stamp noise, and an index
that moves between power-ups (by half a revolution or an electrical period, or not at all).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from pgcomm.rotary.model import Fourier, RotaryModel, cogging_orders, direction_orders, fundamental_cogging_order, \
    ripple_orders
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.experiment import running_references, stall_log
from pgcomm.settings import RotarySettings
from pgcomm.rotary.regression import Orders
from pgcomm.rotary.standstill import sweep_reference
from pgcomm.rotary.twin import LawParams, RotaryTruth, Start, default_gains, simulate
from pgcomm.rotary.winding import draw_winding
from pgcomm.errors import ConfigError

__all__ = ["COMBINATIONS", "CONTROL_RATE_HZ", "draw_control_per_log", "draw_rotary", "default_truth", "truth_from_model",
           "truth_from_identification", "running_logs", "sweep_log", "MAX_MOTORS", "draw_drive_habits",
           "REAL_DRIVE_RANGES"]

#: (slots, pole pairs) of common concentrated-winding motors: 9N6P, 12N8P, 12N10P, 12N14P, 18N16P,
#: 24N20P, 24N22P, 36N42P.
COMBINATIONS = [(9, 3), (12, 4), (12, 5), (12, 7), (18, 8), (24, 10), (24, 11), (36, 21)]
MAX_MOTORS = 999
#: The range (Hz) the zoo's drives run their loops at, drawn log-uniform. Faster drives (a moteus at 40 kHz) read like
#: the top of the range (their current is a snapshot of one that moves between logged samples, nearly without lag)
#: and cost the twin time in proportion to their rate.
CONTROL_RATE_HZ = (4000.0, 16000.0)
#: What :func:`draw_drive_habits` draws (log-uniform ranges unless said otherwise). ``sensor_range``: the current
#: sensors' full scale as a multiple of the current limit; ``sensor_offset`` (std per phase) and ``sensor_gain``
#: (std per phase, relative) as shares of it: a few per cent (the ODrive map of ``../real``: order ``p`` 0.87 A, 7x
#: its cogging fundamental); the dead time is the winding's inverter's (:func:`pgcomm.rotary.winding.draw_winding`:
#: ``V_dt / R``, its zero crossing's width, its current loop and ``R/L``); ``report_filter`` (s), none on ``report_filter_none`` of the drives (the ODrive logs: 80-100 ms);
#: ``pll_bandwidth`` (rad/s, ODrive's default 1000), on ``1 - pll_none`` of the drives, at least 2.5 times the
#: zoo's 30 Hz speed-loop pole (a drive tunes its velocity loop under its PLL: at 300 rad/s the zoo's speed loop
#: oscillated) and at most ``pll_max_kp_dt / 2`` over the control period (ODrive's discrete loop stays close to its
#: continuous one; a drive too slow for both runs none);
#: ``host_jitter`` (σ of the log-steps), ``host_gaps`` (per row), ``stamp_noise`` (share of the median step);
#: ``index_moves``: the index moves by half a revolution, an electrical period or not at all with these chances, in
#: ``power_ups`` power-ups (the first one's zero is the truth's).
REAL_DRIVE_RANGES = {"sensor_range": 2.0, "sensor_offset": (0.003, 0.03), "sensor_gain": (0.003, 0.03),
                     "report_filter": (5e-4, 0.12), "report_filter_none": 0.2,
                     "pll_bandwidth": (500.0, 3000.0), "pll_none": 1.0 / 3.0, "pll_max_kp_dt": 0.5,
                     "host_jitter": (0.03, 0.3), "host_gaps": (3e-4, 3e-3), "stamp_noise": (0.005, 0.03),
                     "index_moves": {"half": 0.5, "electrical": 0.25, "none": 0.25}, "power_ups": 4}


def _random_fourier(rng, orders, rms: float, weights=None) -> Fourier:
    """Random phases, amplitudes ∝ ``weights`` (default equal), scaled to ``rms`` over the revolution."""
    orders = np.asarray(orders, int)
    w = np.ones(orders.size) if weights is None else np.asarray(weights, float)
    amp = w * rng.uniform(0.5, 1.0, orders.size)
    ph = rng.uniform(0, 2 * math.pi, orders.size)
    coef = np.stack([amp * np.cos(ph), amp * np.sin(ph)], axis=1)
    f = Fourier(orders, coef)
    r = f.rms()
    return f.scaled(rms / r) if r > 0 else f


def _outside(basis, start: int) -> int:
    """The smallest order >= ``start`` that is not in ``basis`` (for the part of the truth no model holds)."""
    b = set(int(x) for x in basis)
    h = start
    while h in b:
        h += 1
    return h


def _merge(*parts: Fourier) -> Fourier:
    return Fourier(np.concatenate([p.orders for p in parts]), np.concatenate([p.coef for p in parts]))


#: A torque sensor's noise as a share of the rated torque (half the current limit's).
TORQUE_NOISE = 0.005


def _friction_velocity(sample_time: float, coulomb: float, inertia: float) -> float:
    """``ω_ε`` (rad/s) of the twin's smooth friction sign: wide enough that it stays stable in the plant's sub-steps."""
    dt = sample_time / 10
    return max(0.01, 2.0 * dt * abs(coulomb) * 1.5 / inertia)


def draw_truth(rng, slots: int, pole_pairs: int, *, k_t=None, current_limit=None, inertia=None,
               sample_time: float = 1e-3) -> RotaryTruth:
    """One random motor of a given slot/pole combination (ranges in the module docstring).

    Args:
        rng: :class:`numpy.random.Generator`.
        slots, pole_pairs: ``Q``, ``p``.
        k_t, current_limit, inertia: fix these (N·m/A, A, kg·m²) instead of drawing them.
        sample_time: the period of the drive's logs (s).
    """
    p, q = int(pole_pairs), int(slots)
    k_t = float(k_t) if k_t is not None else float(np.exp(rng.uniform(np.log(0.02), np.log(2.0))))
    i_lim = float(current_limit) if current_limit is not None else float(np.exp(rng.uniform(np.log(5), np.log(40))))
    inertia = float(inertia) if inertia is not None else k_t * float(np.exp(rng.uniform(np.log(2e-3), np.log(2e-2))))
    t_rated = k_t * 0.5 * i_lim
    lcm = fundamental_cogging_order(q, p)
    c_basis = cogging_orders(q, p)
    # cogging: main multiples of L, falling; sidebands at kQ and k·2p; eccentricity orders; outside part
    main = Fourier(np.array([lcm, 2 * lcm, 3 * lcm]), np.zeros((3, 2)))
    w_main = np.array([1.0, rng.uniform(0.1, 0.3), rng.uniform(0.02, 0.1)])
    main = _random_fourier(rng, main.orders, 1.0, w_main)
    side_q = [h for h in range(q, 3 * lcm + 1, q) if h % lcm]
    side_p = [h for h in range(2 * p, 3 * lcm + 1, 2 * p) if h % lcm and h % q]
    side_q = _random_fourier(rng, side_q, rng.uniform(0.05, 0.15), np.exp(-np.asarray(side_q) / lcm)) if side_q \
        else Fourier.zeros([])
    side_p = _random_fourier(rng, side_p, rng.uniform(0.03, 0.1), np.exp(-np.asarray(side_p) / lcm)) if side_p \
        else Fourier.zeros([])
    ecc = _random_fourier(rng, [1, 2], rng.uniform(0.01, 0.04))
    out = _random_fourier(rng, [_outside(c_basis, lcm // 2 + 1)], 0.02)
    cog = _merge(main, side_q, side_p, ecc, out)
    cog = cog.scaled(rng.uniform(0.005, 0.05) * t_rated / cog.rms())
    # torque-constant ripple (relative)
    r_basis = ripple_orders(q, p)
    r_orders = [1, 2, 3, 2 * p, 6 * p, 12 * p, q]
    r_weights = [1.0, 0.4, 0.3, 0.5, 1.0, 0.3, 0.3]
    rip = _random_fourier(rng, r_orders, 1.0, r_weights)
    rip = _merge(rip, _random_fourier(rng, [_outside(r_basis, 4)], 0.03))
    rip = rip.scaled(rng.uniform(0.005, 0.03) / rip.rms())
    # friction and the direction-dependent drag
    coulomb = rng.uniform(0.005, 0.03) * t_rated
    d_orders = [h for h in direction_orders(p) if h > 0]
    drag = _random_fourier(rng, d_orders, rng.uniform(0.1, 0.4) * coulomb)
    viscous = rng.uniform(0.002, 0.01) * t_rated / 10.0  # 0.2-1 % of rated torque at 10 rad/s
    bits = int(rng.integers(16, 21))
    motor = RotaryMotor(pole_pairs=p, slots=q, sample_time=sample_time, k_t=round(k_t, 4), inertia=None,
                        current_limit=round(i_lim, 2), commutation_offset=0.0, encoder_counts=2**bits)
    w_eps = _friction_velocity(sample_time, coulomb, inertia)
    return RotaryTruth(motor=motor, k_t=k_t, offset_error=float(rng.uniform(-0.3, 0.3)), ripple=rip, cogging=cog,
                       drag=drag, coulomb=coulomb, viscous=viscous, inertia=inertia, friction_velocity=w_eps,
                       current_noise=float(rng.uniform(0.002, 0.005) * i_lim), torque_noise=TORQUE_NOISE * t_rated,
                       encoder_counts=2**bits)


def draw_control_per_log(rng, sample_time: float) -> int:
    """The drive's control cycles per logged sample: a control rate drawn log-uniform over :data:`CONTROL_RATE_HZ`,
    times the log's period ``sample_time`` (s), rounded (at least 1: a drive that logs at its own rate)."""
    lo, hi = CONTROL_RATE_HZ
    rate = float(np.exp(rng.uniform(math.log(lo), math.log(hi))))
    return max(1, round(rate * float(sample_time)))


def _log_uniform(rng, lo_hi) -> float:
    lo, hi = lo_hi
    return float(np.exp(rng.uniform(math.log(lo), math.log(hi))))


def draw_drive_habits(rng, truth: RotaryTruth) -> dict:
    """A real drive's and host's habits for ``truth`` (:data:`REAL_DRIVE_RANGES`; :mod:`pgcomm.rotary.twin`, "A real
    drive's habits"): ``{field: value}`` for :func:`dataclasses.replace` on the truth. The PLL's bandwidth is bounded
    by the truth's control period (draw the control rate first); the dead time is the truth's winding's (none
    without one).

    Args:
        rng: :class:`numpy.random.Generator`; truth: the motor and its drive (current limit, noise, control rate).
    """
    r = REAL_DRIVE_RANGES
    i_lim = truth.rated_current()
    full = r["sensor_range"] * i_lim
    offsets = rng.normal(0.0, _log_uniform(rng, r["sensor_offset"]) * full, 2)
    gains = rng.normal(0.0, _log_uniform(rng, r["sensor_gain"]), 2)
    habits = {"sensor_offset": tuple(float(x) for x in offsets), "sensor_gain": tuple(float(x) for x in gains)}
    # two places of the stream held for a dead time of the drive's own, so a seed's other habits stay where they are
    rng.uniform(size=2)
    w = truth.winding
    if w is not None:
        # the inverter the winding's voltages already carry: one dead time for the currents and the voltages
        habits.update(deadtime_error=w.deadtime_voltage / w.resistance, deadtime_width=w.deadtime_current,
                      current_bandwidth=w.loop_gain / w.inductance, electrical_pole=w.resistance / w.inductance)
    filtered = rng.random() >= r["report_filter_none"]
    tau = _log_uniform(rng, r["report_filter"])
    habits["report_filter"] = tau if filtered else 0.0
    pll = rng.random() >= r["pll_none"]
    tc = truth.motor.sample_time / truth.control_per_log
    bw = min(_log_uniform(rng, r["pll_bandwidth"]), 0.5 * r["pll_max_kp_dt"] / tc)
    habits["pll_bandwidth"] = bw if pll and bw >= r["pll_bandwidth"][0] else 0.0
    habits["host_jitter"] = _log_uniform(rng, r["host_jitter"])
    habits["host_gaps"] = _log_uniform(rng, r["host_gaps"])
    habits["stamp_noise"] = _log_uniform(rng, r["stamp_noise"]) * truth.motor.sample_time
    kinds = list(r["index_moves"])
    kind = kinds[int(rng.choice(len(kinds), p=[r["index_moves"][k] for k in kinds]))]
    steps = {"half": 2, "electrical": truth.motor.pole_pairs, "none": 1}[kind]
    moves = rng.integers(0, steps, r["power_ups"] - 1)
    habits["power_up_offsets"] = (0.0, *(2 * math.pi * float(k) / steps for k in moves)) if steps > 1 else ()
    return habits


def draw_rotary(seed: int, index: int, control_per_log: int | None = None, real_drive: bool = False) -> RotaryTruth:
    """Zoo motor ``index`` (0-based) of zoo ``seed``: combination ``COMBINATIONS[index]`` for the first
    eight, a random one after that; everything else drawn (module docstring). The winding and the drive's control
    rate come from streams of their own, so the motor's mechanical and magnetic draws stay those of a zoo without
    them; ``control_per_log`` gives the drive's control cycles per logged sample instead of drawing them (1: a drive
    that controls at its log rate). ``real_drive``: with a real drive's and host's habits
    (:func:`draw_drive_habits`), from a stream of their own too: the same motor and drive as without them."""
    rng = np.random.default_rng([int(seed), int(index), 0x70])
    if index < len(COMBINATIONS):
        q, p = COMBINATIONS[index]
    else:
        q, p = COMBINATIONS[int(rng.integers(len(COMBINATIONS)))]
    t = _with_winding(draw_truth(rng, q, p), np.random.default_rng([int(seed), int(index), 0x72]))
    k = control_per_log or draw_control_per_log(np.random.default_rng([int(seed), int(index), 0x74]),
                                                t.motor.sample_time)
    t = replace(t, control_per_log=k)
    if real_drive:
        t = replace(t, **draw_drive_habits(np.random.default_rng([int(seed), int(index), 0x76]), t))
    return t


def _with_winding(truth: RotaryTruth, rng) -> RotaryTruth:
    """``truth`` with a winding drawn from its own stream (:func:`pgcomm.rotary.winding.draw_winding`), so the
    mechanical and magnetic draws stay those of a zoo without voltages."""
    return replace(truth, winding=draw_winding(rng, truth.k_t, truth.current_noise))


def default_truth(motor: RotaryMotor, seed: int = 0) -> RotaryTruth:
    """A twin for a user's rotary motor description: its ``k_t``, limit, inertia and drive's control rate where given,
    parasitic effects (and the rate where not given) drawn (seeded) from the zoo's ranges."""
    rng = np.random.default_rng([int(seed), 0x71])
    t = draw_truth(rng, motor.slots, motor.pole_pairs, k_t=motor.k_t, current_limit=motor.current_limit,
                   inertia=motor.inertia, sample_time=motor.sample_time)
    counts = motor.encoder_counts or t.encoder_counts
    k = motor.control_per_log or draw_control_per_log(np.random.default_rng([int(seed), 0x75]), motor.sample_time)
    return replace(_with_winding(replace(t, motor=motor, encoder_counts=int(counts)),
                                 np.random.default_rng([int(seed), 0x73])), control_per_log=k)


def truth_from_model(model: RotaryModel, motor: RotaryMotor, *, current_noise: float, encoder_counts: int | None = None,
                     offset_error: float = 0.0, resistance: float | None = None, inductance: float | None = None,
                     seed: int = 0) -> RotaryTruth:
    """A twin of a user's motor as identified from its logs: the inverse of :meth:`RotaryTruth.model`.

    ``pgcomm reproduce --truth model.json`` runs the experiment on it: the model's law against the drives' standstill
    table and the oracle on this motor's maps, inertia, friction, encoder and current noise, before the law goes on
    the drive. The twin has the model's orders and nothing outside them (what the logs did not show, it does not
    have), so it previews the tracking, not the identification's own error.

    Args:
        model: the identified :class:`RotaryModel` (current units), with ``k_t`` (``k0``, N·m/A: from the back-EMF, a
            torque sensor or the motor description) and ``inertia_ratio`` (A·s²/rad).
        motor: the description (pole pairs, slots, sample time, limit).
        current_noise: the logged current's white noise (A, ``identify``'s ``current_noise_A``).
        encoder_counts: counts per revolution (default: the motor's, else 2^17).
        offset_error: the drive's offset error ``δ`` (rad, electrical) where the d-voltage gave it.
        resistance, inductance: the winding's (Ω, H) where the q-voltage gave them; the rest of the winding is drawn.
        seed: for the winding's undetermined parts.

    Raises:
        ConfigError: the model has no ``k_t`` or no ``inertia_ratio``.
    """
    if not model.k_t or not model.inertia_ratio or model.inertia_ratio <= 0:
        raise ConfigError("the model has no " + ("torque constant k0 (log vq_1, or give k_t in the motor TOML)"
                                                 if not model.k_t else "positive J/k0 (identify it from running logs)"))
    k0 = float(model.k_t)
    cog = model.cogging
    cog = Fourier(cog.orders[cog.orders > 0], cog.coef[cog.orders > 0] * k0)
    d = model.direction
    coulomb = float(k0 * d.coef[d.orders == 0, 0].sum())
    drag = Fourier(d.orders[d.orders > 0], d.coef[d.orders > 0] * k0)
    inertia = float(model.inertia_ratio) * k0
    counts = int(encoder_counts or motor.encoder_counts or 2**17)
    i_lim = float(motor.current_limit) if motor.current_limit else 1.0
    truth = RotaryTruth(motor=motor, k_t=k0 / math.cos(offset_error), offset_error=float(offset_error),
                        ripple=model.ripple, cogging=cog, drag=drag, coulomb=abs(coulomb),
                        viscous=float(model.viscous) * k0, inertia=inertia,
                        friction_velocity=_friction_velocity(motor.sample_time, coulomb, inertia),
                        current_noise=float(current_noise), torque_noise=TORQUE_NOISE * k0 * 0.5 * i_lim,
                        encoder_counts=counts)
    w = draw_winding(np.random.default_rng([int(seed), 0x74]), truth.k_t, truth.current_noise)
    if resistance is not None and inductance is not None and resistance > 0 and inductance > 0:
        w = replace(w, resistance=float(resistance), inductance=float(inductance))
    return replace(truth, winding=w)


#: The most control cycles per logged sample a preview's drive runs (:func:`truth_from_identification`): a drive read
#: as faster is previewed at this rate, whose held cycles are already within an eighth of a logged sample.
PREVIEW_MAX_CONTROL_PER_LOG = 8


def truth_from_identification(model: RotaryModel, identification: dict, motor: RotaryMotor,
                              seed: int = 0) -> RotaryTruth:
    """:func:`truth_from_model` with what ``identify`` measured beside the model (its ``info``, results key
    ``identification``): the back-EMF's ``k0``, offset error, R and L where the voltage was read and agrees with the
    currents (else the model's or the description's ``k_t``, no offset, a drawn winding), the encoder's counts as the
    logs showed them, the logged current's noise, and a drive that controls ``K ≈ 1/(2 lag)`` times per logged sample
    where the current read smooth, or as the description's ``control_rate`` says where it has one (at most
    :data:`PREVIEW_MAX_CONTROL_PER_LOG`: the twin's time grows with ``K``).

    Raises:
        ConfigError: no ``current_noise_A`` (an identification by an older pgcomm), or what :func:`truth_from_model`
            refuses.
    """
    if identification.get("current_noise_A") is None:
        raise ConfigError("the identification has no current_noise_A (identified by an older pgcomm: identify again)")
    back_emf = identification.get("back_emf") or {}
    voltage = back_emf if back_emf.get("consistent") else {}
    k0 = voltage.get("k0_amplitude_invariant") or model.k_t or motor.k_t
    counts = ((identification.get("quantisation") or {}).get("counts_per_revolution") or [None])[0]
    truth = truth_from_model(replace(model, k_t=k0), motor, current_noise=identification["current_noise_A"],
                             encoder_counts=counts, offset_error=(voltage.get("offset_error") or {}).get("delta", 0.0),
                             resistance=voltage.get("resistance"), inductance=voltage.get("inductance"), seed=seed)
    if motor.control_per_log:  # the description's rate, where given, over the logs' reading of it
        return replace(truth, control_per_log=min(motor.control_per_log, PREVIEW_MAX_CONTROL_PER_LOG))
    timing = identification.get("current_delay") or {}
    if timing.get("held", True):
        return truth
    lag = float(timing.get("lag", 0.0))
    k = PREVIEW_MAX_CONTROL_PER_LOG if lag <= 0.5 / PREVIEW_MAX_CONTROL_PER_LOG else max(1, round(0.5 / lag))
    return replace(truth, control_per_log=int(k))


#: The power-up of the zoo's standstill sweep (:func:`sweep_log`): another day than the running logs'
#: (power_up 0), so on a truth whose index moves (:attr:`RotaryTruth.power_up_offsets`) its angle zero may differ.
SWEEP_POWER_UP = 1


def running_logs(truth: RotaryTruth, seed: int = 0, stall: bool = False) -> list[tuple[str, dict]]:
    """Simulate the running logs of :func:`pgcomm.rotary.experiment.running_references` in power-up 0: what a drive
    records (``t, theta, velocity, iq_1, id_1, vq_1, vd_1``, with the host's stamps as they come where the truth has a
    host's habits), each ``(N,)``. ``stall``: also a low-speed run in a speed loop too soft for the cogging, which
    stalls about halfway (:func:`pgcomm.rotary.experiment.stall_log`).

    Returns:
        ``[(name, log), ...]``: ``run1``, ``run2``, ... (and ``stall``), each log a dict of columns.
    """
    a = truth.inertia / truth.k0
    refs = running_references(truth.motor, a, RotarySettings(), Orders.for_motor(truth.motor))
    logs = [(f"run{k}", simulate(truth, ref, LawParams.classical(truth.motor.pole_pairs), default_gains(a),
                                 seed=seed * 1000 + k, host=True))
            for k, ref in enumerate(refs, start=1)]
    if stall:
        logs.append(("stall", stall_log(truth, seed=seed * 1000 + 998)))
    return logs


def sweep_log(truth: RotaryTruth, seed: int = 0, revolution_seconds: float = 60.0) -> dict:
    """Simulate a slow position sweep in both directions (:func:`pgcomm.rotary.standstill.sweep_reference`,
    classical law, the drive's tuned gains): the drives' calibration run, for ``pgcomm identify --sweep``; columns as
    :func:`running_logs`'. Recorded in power_up :data:`SWEEP_POWER_UP`: where the truth's index moves, its angle zero
    is :func:`pgcomm.rotary.twin.power_up_offset` of it, not the running logs'."""
    ref = sweep_reference(truth.motor.sample_time, revolution_seconds)
    return simulate(truth, ref, LawParams.classical(truth.motor.pole_pairs), default_gains(truth.inertia / truth.k0),
                    seed=seed * 1000 + 999, host=True, start=Start(power_up=SWEEP_POWER_UP))
