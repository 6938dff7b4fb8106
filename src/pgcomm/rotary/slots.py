"""The slot count of a rotary motor from its drive's running logs, for users who do not know it.

Datasheets of industrial servo motors give the pole count but rarely the slots, and the cogging orders of
:mod:`pgcomm.rotary.model` need both: multiples of ``L = LCM(Q, 2p)``, of the slot number ``Q`` and of
``2p``, and the lowest orders.

**Which orders the logs show.** The identification of :mod:`pgcomm.rotary.identify` runs once with a cogging
basis of *every* order from 1 to ``H`` (the highest the logs can carry: at least
:data:`pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD` samples per period at the 90th percentile of the logs'
speed, at most
:data:`MAX_ORDER`) and the ripple's orders that do not depend on ``Q``. Each order's ``T² = δᵀ C⁻¹ δ``
(cosine and sine over their block-sandwich covariance) against its family-wise threshold (the screening's,
``α`` = :data:`pgcomm.rotary.regression.EXTRA_ORDER_ALPHA` over the ``H`` orders) says whether the logs show it.
The physics is in the fit: a dither or an acceleration is the inertia's, not an order of the angle, so a
constant-speed log's time-periodic content does not pose as cogging (an FFT of the logged current over the
angle reads a current at ``f`` Hz at a constant speed ``ω`` as order ``2πf/ω``, so a dither's lines would be
taken for the strongest orders and the fundamental read wrong).

**The choice.** Each three-phase slot count ``Q`` (a multiple of 3 up to :data:`MAX_SLOTS`) whose
fundamental ``L`` the logs show is scored by what its basis explains: ``Σ (T²/threshold − 1)`` over the
cogging orders it predicts up to ``H`` (:func:`pgcomm.rotary.model.cogging_orders`): an order seen adds, an
order predicted and not seen costs about one. The best score sets ``L``. The slot counts with that ``L``
differ only in their slot sidebands (multiples of ``Q``, from magnet tolerances): the one that explains the
most sidebands the logs show wins, then the score (9 slots beside 18 on a 16-pole motor, ``L`` = 144 both:
18 explains the sidebands at multiples of 18 with half the orders). ``L`` is what the logs determine; the
slot count is ambiguous when the sidebands are too weak to be seen (an 18N16P that shows only 144 and 288:
9 slots fit as well as 18), and then the identification's screening adds the sidebands the data do
resolve, whichever ``Q`` was taken.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from pgcomm.errors import ExcitationError
from pgcomm.rotary.model import cogging_orders, direction_orders, fundamental_cogging_order, ripple_orders
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.readings import apply_reading, detect_reading, lag_of
from pgcomm.rotary.regression import EXTRA_ORDER_ALPHA, FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, MIN_SPEED_SHARE, Orders, \
    _fit, _Layout, _log_arrays, _prepare, _significant_extra_orders
from pgcomm.rotary.time_lines import detect_time_lines
from pgcomm.settings import RotaryIdentifyOptions

__all__ = ["detect_slots", "count_slots", "MAX_SLOTS", "MAX_ORDER"]

#: Largest slot count considered (the motor TOML's plausibility bound).
MAX_SLOTS = 600
#: Highest cogging order examined (the fit has two columns per order).
MAX_ORDER = 1024
#: Time blocks of the detection's sandwich covariance (s). The identification's one-second blocks give a
#: log of a few seconds so few blocks that the significance threshold (Hotelling's F quantile) is 10^5-10^7
#: times the noise; the rows' residuals are nearly white (a small lag-1 correlation), so blocks a tenth as long still hold the correlation of overlapping filter windows (8 samples).
DETECTION_BLOCK_SECONDS = 0.1


def _highest_order(logs, sample_time: float) -> int:
    """The highest order with :data:`~pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD` samples per period at the
    90th percentile of the logs' speed at speed (the samples above the slow share of each log's 95th percentile),
    at most :data:`MAX_ORDER`: nine in ten samples pass the identification's alias guard."""
    steps = []  # rad per sample, at speed
    for i, log in enumerate(logs):
        _, th, _, _, _ = _log_arrays(log, i, sample_time)
        if th.size < 3:
            continue
        d = np.abs(np.gradient(th))
        steps.append(d[d > MIN_SPEED_SHARE * float(np.percentile(d, 95))])
    v = np.concatenate(steps) if steps else np.zeros(0)
    if not v.size:
        raise ExcitationError("no sample at speed in the logs: the slot count is read from running logs "
                              "(set slots in the motor TOML)")
    return int(min(MAX_ORDER, math.floor(2 * math.pi / (MIN_SAMPLES_PER_PERIOD * float(np.percentile(v, 90))))))


def detect_slots(logs, pole_pairs: int, sample_time: float, time_lines=(), current_lag=None) -> tuple[int, dict]:
    """The slot count whose cogging orders the logs show best (module docstring).

    Args:
        logs: running logs as for :func:`pgcomm.rotary.identify.identify` (``t``, ``theta`` rad multi-turn,
            ``iq_1`` A; each ``(N_i,)``), at speed in both directions ideally.
        pole_pairs: ``p``.
        sample_time: the drive's period (s), where a log has no ``t``.
        time_lines: frequencies (Hz) of time-periodic disturbances fitted beside the orders
            (:func:`pgcomm.rotary.time_lines.detect_time_lines`): a 50 Hz pickup at two speeds spreads over orders
            and, unfitted, can make the count a multiple of the true one.
        current_lag: the logged current read held between samples (``None``) or as the smooth curve through them, this
            many samples late (:func:`pgcomm.rotary.readings.lag_of` of the logs' reading): a drive that controls
            faster than it logs, read held, shows orders its motor does not have (a count of twice the slots).

    Returns:
        ``(slots, info)``: ``info`` has ``slots``, ``cogging_fundamental`` (``L``), ``slots_with_that_fundamental``
        (the three-phase slot counts with ``LCM(Q, 2p) = L``), ``orders_seen`` (strongest first, at most 12),
        ``highest_order_examined`` and ``runner_up`` (the next slot count with that ``L``, and how many of the
        slot sidebands seen it explains).

    Raises:
        ExcitationError: the logs show no slot count's fundamental (or are too slow or fast to say).
    """
    p = int(pole_pairs)
    top = _highest_order(logs, sample_time)
    if top < 2 * p:
        raise ExcitationError(f"the logs are too fast to show the cogging: order {2 * p} (2p) has fewer than "
                              f"{MIN_SAMPLES_PER_PERIOD:g} samples per period at their usual speed; set slots in the "
                              "motor TOML or log slower")
    ripple = ripple_orders(None, p)
    ripple = ripple[ripple <= top]
    every = Orders(np.arange(1, top + 1), ripple, direction_orders(p))
    motor = RotaryMotor(pole_pairs=p, slots=None, sample_time=sample_time)
    prepared, _, _, _ = _prepare(logs, motor, every, MIN_SAMPLES_PER_PERIOD, FILTER_TAPS, current_lag=current_lag)
    layout = _Layout.of(every, tuple(time_lines), len(prepared))
    screen = _significant_extra_orders(_fit(prepared, layout, FILTER_TAPS, None, DETECTION_BLOCK_SECONDS), layout,
                                       Orders(np.zeros(0, int), ripple, every.direction), EXTRA_ORDER_ALPHA)
    orders, t2, thr = screen["statistic"]["cogging"]
    ratio = np.zeros(top + 1)
    ratio[orders] = t2 / thr
    scores = []
    for q in range(3, MAX_SLOTS + 1, 3):
        lcm = fundamental_cogging_order(q, p)
        if lcm > top or ratio[lcm] <= 1.0:
            continue
        basis = cogging_orders(q, p)
        basis = basis[basis <= top]
        scores.append((float(np.sum(ratio[basis] - 1.0)), -q, q, lcm))
    if not scores:
        strongest = int(np.argmax(ratio))
        raise ExcitationError(
            f"slots not given, and the logs show no cogging fundamental LCM(Q, {2 * p}) up to order {top} (strongest "
            f"order {strongest} at {ratio[strongest]:.2g}x its threshold): set slots in the motor TOML")
    scores.sort(reverse=True)
    lcm = scores[0][3]
    # slot counts with that fundamental differ only in their slot sidebands (multiples of Q): the one that explains
    # the most sidebands the logs show (orders seen that are neither low, nor multiples of 2p or L), then the score
    seen = np.flatnonzero(ratio > 1.0)
    side = [int(h) for h in seen if h > 2 and h % (2 * p) and h % lcm]
    same = [(sum(1 for h in side if h % q == 0), score, -q, q) for score, _, q, L in scores if L == lcm]
    same.sort(reverse=True)
    best = same[0]
    info = {"slots": best[3], "cogging_fundamental": lcm,
            "slots_with_that_fundamental": sorted(q for *_, q in same),
            "orders_seen": [int(h) for h in seen[np.argsort(ratio[seen])[::-1]][:12]],
            "highest_order_examined": top}
    if len(same) > 1:
        info["runner_up"] = {"slots": same[1][3], "sidebands_explained": same[1][0], "of": len(side)}
    return best[3], info


def count_slots(logs, motor, *, current_delay="detect", angle_pll="detect", current_lag="detect",
                time_lines="detect") -> tuple[int, dict]:
    """The slot count of ``motor`` (a :class:`~pgcomm.rotary.motor.RotaryMotor` without ``slots``) as ``pgcomm
    identify`` reads it from ``logs``: counted on the logs as written (:func:`detect_slots`), then, with that count's
    basis, the logs read as :func:`~pgcomm.rotary.identify.identify` would read them (the angle's PLL, the current's
    delay and form, :func:`pgcomm.rotary.readings.detect_reading`) and counted again on the logs so read; then with the
    time-periodic disturbances fitted (:mod:`pgcomm.rotary.time_lines`). Each of these hides the cogging's orders
    when it is not read, and the count comes out a multiple of the true one: a late current or a PLL's angle, a
    snapshot current read as held, a 50 Hz pickup at two speeds.

    Args:
        logs: as for :func:`detect_slots`.
        motor: the description (pole pairs, sample time (s); ``slots`` is ignored).
        current_delay, angle_pll, current_lag, time_lines: each ``"detect"`` or as given, as for
            :func:`~pgcomm.rotary.identify.identify`.

    Returns:
        ``(slots, info)`` as :func:`detect_slots`, ``info`` also with ``counted_after_reading`` (``True``, where a
        reading other than the logs as written was taken), ``counted_with_time_lines`` (Hz, where lines were
        fitted) and ``read_with`` (``current_delay`` samples, ``current_lag`` samples or ``None`` for held,
        ``angle_pll_rad_s`` or ``None``).
    """
    p, ts = motor.pole_pairs, motor.sample_time
    q, info = detect_slots(logs, p, ts)
    est, timing = detect_reading(logs, replace(motor, slots=q), RotaryIdentifyOptions(
        current_delay=current_delay, angle_pll=angle_pll, current_lag=current_lag))
    pll = None if est["natural_frequency_rad_s"] is None else (est["natural_frequency_rad_s"], est["damping"])
    lag = lag_of(timing)
    read, counted = logs, False
    if pll is not None or timing["samples"] or lag is not None:
        read = [apply_reading(d, timing["samples"], pll, ts) for d in logs]
        q, info = detect_slots(read, p, ts, current_lag=lag)
        counted = True
    lines = (detect_time_lines(read, replace(motor, slots=q), current_lag=lag)["hz"] if time_lines == "detect"
             else list(time_lines))
    if lines:
        q, info = detect_slots(read, p, ts, time_lines=lines, current_lag=lag)
        info["counted_with_time_lines"] = lines
    if counted:
        info["counted_after_reading"] = True
    info["read_with"] = {"current_delay": int(timing["samples"]), "current_lag": lag,
                         "angle_pll_rad_s": None if pll is None else float(pll[0])}
    return q, info
