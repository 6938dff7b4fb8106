"""The slot count of a rotary motor from its drive's running logs, for users who do not know it.

Datasheets of industrial servo motors give the pole count but rarely the slots, and the cogging orders of
:mod:`pgcomm.rotary.model` need both: multiples of ``L = LCM(Q, 2p)``, of the slot number ``Q`` and of
``2p``, and the lowest orders.

**Which orders the logs show.** The identification of :mod:`pgcomm.rotary.identify` runs once with a cogging
basis of *every* order from 1 to ``H`` (the highest the logs can carry: at least
:data:`pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD` samples per period at the 90th percentile of the logs'
speed, at most
:data:`MAX_ORDER`, and no higher than the logs' windows determine: :data:`COUNT_WINDOWS_PER_UNKNOWN`,
:func:`_determined_order`) and the ripple's orders that do not depend on ``Q``. Each order's ``T² = δᵀ C⁻¹ δ``
(cosine and sine over their block-sandwich covariance) against its family-wise threshold (the screening's,
``α`` = :data:`pgcomm.rotary.regression.EXTRA_ORDER_ALPHA` over the ``H`` orders) says whether the logs show it.
The physics is in the fit: a dither or an acceleration is the inertia's, not an order of the angle, so a
constant-speed log's time-periodic content does not pose as cogging (an FFT of the logged current over the
angle reads a current at ``f`` Hz at a constant speed ``ω`` as order ``2πf/ω``, so a dither's lines would be
taken for the strongest orders and the fundamental read wrong).

**The choice.** Each slot count ``Q`` a three-phase motor with ``2p`` poles can have (:func:`winding_exists`: a
balanced winding, at least a quarter slot per pole and phase; up to :data:`MAX_SLOTS`) whose fundamental ``L`` the
logs show is scored by what its basis explains: ``Σ (T²/threshold − 1)`` over the
cogging orders it predicts up to ``H`` (:func:`pgcomm.rotary.model.cogging_orders`): an order seen adds, an
order predicted and not seen costs about one. The best score sets ``L``. The slot counts with that ``L``
differ only in their slot sidebands (multiples of ``Q``, from magnet tolerances): the one that explains the
most sidebands the logs show wins, then the score (12 slots beside 84 on a 14-pole motor, ``L`` = 84 both: 12
explains the sidebands at 12, 24, 36). ``L`` is what the logs determine; the slot count is ambiguous when the
sidebands are too weak to be seen (an 18N16P that shows only 144 and 288: 144 slots fit as well as 18), and then
the identification's screening adds the sidebands the data do resolve, whichever ``Q`` was taken.

**What the logs predict.** The orders seen are a significance test, and on a real drive's logs it lets in tens to
hundreds of orders that no motor has (a host's clock, the encoder's and the current sensor's errors: 60-480 of the
orders to 500-1000 on a real ODrive's logs of a 12N14P outrunner), while a real motor's slot sidebands (orders 12 and
36 of a 12N14P) can outweigh its fundamental (84), which then may not pass. So each count's basis is also judged on
what it predicts: fitted on the training rows and scored on the held-out time blocks
(:func:`pgcomm.rotary.regression._validated_ridge`, every fourth block), from the every-order fit's own normal
equations (:func:`_held_out`). Where another count leaves less than :data:`HELD_OUT_OVERRULE` of the held-out mean
square of the count the orders seen give, the logs contradict that count and the other is taken; where the orders
seen give no count, the count that predicts best is taken if it beats the poles' orders alone and the logs show one
of its own orders (a real ODrive's log at 0.1 rev/s, to order 216: no fundamental passes, and 12 slots leave 0.7 % of
the current's held-out mean square unexplained, the next count 3.9 %, the poles' orders alone 4.6 %).

**Over the angle.** Where neither gives a count (the count that predicts best has its fundamental beyond ``H``, or
none beats the poles' orders alone), the fundamental may turn too fast for the logs' sampling: a joint's speed loop
polled by a host every few milliseconds. Over a stretch of steady speed, every order is read over the angle whatever
the sample rate (:mod:`pgcomm.rotary.over_the_angle`), and the strongest fundamental of the counts a motor can be
wound with, over its family-wise threshold, is taken (:func:`_count_over_the_angle`). Where none passes, the count is
refused.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.stats import chi2

from pgcomm.errors import ExcitationError
from pgcomm.rotary.model import cogging_orders, direction_orders, drive_orders, fundamental_cogging_order, \
    ripple_orders
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.over_the_angle import order_evidence
from pgcomm.rotary.readings import apply_reading, detect_reading, lag_of
from pgcomm.rotary.regression import EXTRA_ORDER_ALPHA, FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, MIN_SPEED_SHARE, Orders, \
    _fit, _Layout, _log_arrays, _prepare, _significant_extra_orders, _validated_ridge, steps_at_speed
from pgcomm.rotary.time_lines import detect_time_lines
from pgcomm.settings import RotaryIdentifyOptions

__all__ = ["detect_slots", "count_slots", "winding_exists", "held_out_text", "MAX_SLOTS", "MAX_ORDER",
           "MIN_SLOTS_PER_POLE_PHASE", "HELD_OUT_OVERRULE"]

#: Largest slot count considered (the motor TOML's plausibility bound).
MAX_SLOTS = 600
#: Highest cogging order examined (the fit has two columns per order).
MAX_ORDER = 1024
#: Time blocks of the detection's sandwich covariance (s). The identification's one-second blocks give a
#: log of a few seconds so few blocks that the significance threshold (Hotelling's F quantile) is 10^5-10^7
#: times the noise; the rows' residuals are nearly white (a small lag-1 correlation), so blocks a tenth as long
#: still hold the correlation of overlapping filter windows (8 samples).
DETECTION_BLOCK_SECONDS = 0.1
#: The fewest slots per pole and phase, ``Q / (3 · 2p)``, of a motor that is built: the concentrated (tooth) windings
#: of fractional-slot motors span 1/4 to 1/2 (9N12P, 12N14P, 36N42P at 1/4-2/7; 9N6P, 12N8P at 1/2), distributed
#: windings one and more. Below a quarter a tooth faces more than one pole pair's magnets, whose flux cancels in it
#: (A. M. El-Refaie, "Fractional-slot concentrated-windings synchronous permanent magnet machines: opportunities and
#: challenges", IEEE Trans. Ind. Electron. 57(1), 2010, which surveys the range).
MIN_SLOTS_PER_POLE_PHASE = 0.25
#: The fewest filter windows per unknown of the every-order fit, the bar below which the identification refuses
#: a fit (:func:`pgcomm.rotary.identify.identify`). A slow or short log resolves orders in time that its windows
#: cannot all determine at once (a real ODrive's 10 s at 0.1 rev/s: 714 windows for 1273 unknowns to order 626). Such
#: a fit interpolates its rows, its validated ridge lies on a flat bottom (the grid's smallest weights within 1e-5 of
#: each other), and which one wins, with the screening's statistics, changed with the BLAS's thread count: order 60 at
#: 2.5 times its threshold with one thread, 0.006 with two, and the count refused.
COUNT_WINDOWS_PER_UNKNOWN = 2.0
#: The held-out blocks overrule the count the orders seen give where another count's basis leaves less than this
#: share of its held-out mean square: the logs predicted twice as well by another count contradict it.
HELD_OUT_OVERRULE = 0.5


def winding_exists(slots: int, pole_pairs: int) -> bool:
    """Whether a three-phase motor of ``slots`` slots and ``2 pole_pairs`` poles can be wound and is built.

    Balanced: the ``Q / t`` slots of the winding's repeating unit (``t = gcd(Q, p)`` units around the stator) share out
    over the three phases, ``Q / (3 t)`` an integer; otherwise no connection of the coils gives three phases 120°
    apart (12N6P, 6N6P). Built: at least :data:`MIN_SLOTS_PER_POLE_PHASE` slots per pole and phase (3N14P is balanced
    but its single tooth per phase spans more than two of its magnets). A count of the logs that fails either is a
    divisor of the true count whose multiples the logs also show (a 9N6P read as 3 slots, ``L`` = 6).

    Args:
        slots: ``Q``; pole_pairs: ``p``.
    """
    q, p = int(slots), int(pole_pairs)
    return q > 0 and p > 0 and (q // math.gcd(q, p)) % 3 == 0 and q >= MIN_SLOTS_PER_POLE_PHASE * 6 * p


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


def _every_order(top: int, p: int) -> Orders:
    """The basis of the count's fit to order ``top``: every cogging order, the ripple's orders that do not depend on
    the slots, the direction map's."""
    ripple = ripple_orders(None, p)
    return Orders(np.arange(1, top + 1), ripple[ripple <= top], direction_orders(p))


def _determined_order(logs, p: int, sample_time: float, top: int, lines: int) -> int:
    """The highest order, at most ``top``, whose every-order fit (:func:`_every_order`, ``lines`` time lines) the
    logs' windows determine: the alias guard's windows at least :data:`COUNT_WINDOWS_PER_UNKNOWN` times its
    unknowns. Fewer orders keep more windows and need fewer unknowns, so the largest such order is found by
    bisection; ``top`` where the logs determine it, 0 where they determine no order."""
    steps = steps_at_speed(logs, sample_time, FILTER_TAPS)

    def determined(h: int) -> bool:
        kept = int(np.sum(steps <= 2 * math.pi / (MIN_SAMPLES_PER_PERIOD * h)))
        return kept >= COUNT_WINDOWS_PER_UNKNOWN * int(_Layout.of(_every_order(h, p), (0.0,) * lines,
                                                                   len(logs)).keep.sum())

    if top < 1 or determined(top):
        return top
    lo, hi = 0, top  # determined(lo) (or lo = 0), not determined(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if determined(mid) else (lo, mid)
    return lo


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
        (the slot counts a motor can have, :func:`winding_exists`, with ``LCM(Q, 2p) = L``), ``orders_seen``
        (strongest first, at most 12), ``highest_order_examined``, ``chosen_by`` (``"orders seen"`` or ``"held-out
        blocks"``, module docstring), ``held_out`` (``unexplained``: the share of the current's held-out mean square
        the count's basis leaves; ``poles_alone``: that of the orders every count shares; ``next``: the next other
        basis's ``slots`` and ``unexplained``) and, chosen by the orders seen, ``runner_up`` (the next slot count
        with that ``L``, and how many of the slot sidebands seen it explains).

    Raises:
        ExcitationError: the logs show no slot count's fundamental and no count's basis predicts their held-out
            blocks better than the poles' orders alone; the count that predicts them best has its fundamental beyond
            the orders they resolve; or they are too slow, fast or short to say.
    """
    p = int(pole_pairs)
    resolved = _highest_order(logs, sample_time)
    if resolved < 2 * p:
        raise ExcitationError(f"the logs are too fast to show the cogging: order {2 * p} (2p) has fewer than "
                              f"{MIN_SAMPLES_PER_PERIOD:g} samples per period at their usual speed; set slots in the "
                              "motor TOML or log slower")
    top = _determined_order(logs, p, sample_time, resolved, len(time_lines))
    if top < 2 * p:
        raise ExcitationError(f"the logs are too short to show the cogging: their filter windows determine the orders "
                              f"to {top} at once, fewer than order {2 * p} (2p) ({COUNT_WINDOWS_PER_UNKNOWN:g} windows "
                              "per unknown); set slots in the motor TOML or log longer")
    every = _every_order(top, p)
    ripple = every.ripple
    motor = RotaryMotor(pole_pairs=p, slots=None, sample_time=sample_time)
    prepared, _, _, _ = _prepare(logs, motor, every, MIN_SAMPLES_PER_PERIOD, FILTER_TAPS, current_lag=current_lag)
    layout = _Layout.of(every, tuple(time_lines), len(prepared))
    fit = _fit(prepared, layout, FILTER_TAPS, None, DETECTION_BLOCK_SECONDS)
    screen = _significant_extra_orders(fit, layout, Orders(np.zeros(0, int), ripple, every.direction),
                                       EXTRA_ORDER_ALPHA)
    orders, t2, thr = screen["statistic"]["cogging"]
    ratio = np.zeros(top + 1)
    ratio[orders] = t2 / thr
    held_out = _held_out(fit["equations"], layout, p, top)
    scores = []
    for q in held_out["bases"]:
        lcm = fundamental_cogging_order(q, p)
        if lcm > top or ratio[lcm] <= 1.0:
            continue
        basis = cogging_orders(q, p)
        basis = basis[basis <= top]
        scores.append((float(np.sum(ratio[basis] - 1.0)), -q, q, lcm))
    seen = np.flatnonzero(ratio > 1.0)
    info = {"orders_seen": [int(h) for h in seen[np.argsort(ratio[seen])[::-1]][:12]], "highest_order_examined": top}
    # a count is judged on the held-out blocks only where the logs show one of its own orders (its multiples of Q or
    # L that the poles and the drive do not share): of a hundred counts' noise, the best would beat the poles' alone
    own_seen = {q for q, own in held_out["own"].items() if np.any(ratio[own] > 1.0)}
    best_q = min(own_seen, key=lambda x: (held_out["mse"][x], x), default=None)
    best_mse = held_out["mse"][best_q] if best_q is not None else math.inf
    if scores:
        scores.sort(reverse=True)
        lcm = scores[0][3]
        # slot counts with that fundamental differ only in their slot sidebands (multiples of Q): the one that
        # explains the most sidebands the logs show (orders seen that are neither low, nor multiples of 2p or L)
        side = [int(h) for h in seen if h > 2 and h % (2 * p) and h % lcm]
        same = [(sum(1 for h in side if h % q == 0), score, -q, q) for score, _, q, L in scores if L == lcm]
        same.sort(reverse=True)
        q = same[0][3]
        if best_q is None or best_mse >= HELD_OUT_OVERRULE * _mse_of(held_out, q):
            info.update({"slots": q, "cogging_fundamental": lcm, "chosen_by": "orders seen",
                         "slots_with_that_fundamental": sorted(x for *_, x in same)})
            if len(same) > 1:
                info["runner_up"] = {"slots": same[1][3], "sidebands_explained": same[1][0], "of": len(side)}
            return q, _with_held_out(info, held_out)
    refusal = None
    if not scores and best_mse >= held_out["base"]:
        strongest = int(np.argmax(ratio))
        refusal = (
            f"slots not given, and the logs show no cogging fundamental LCM(Q, {2 * p}) up to order {top} (strongest "
            f"order {strongest} at {ratio[strongest]:.2g}x its threshold), nor does any slot count's basis predict "
            "the logs' held-out time blocks better than the orders of the poles alone: set slots in the motor TOML")
    else:
        lcm = fundamental_cogging_order(best_q, p)
        if lcm > top:
            # the count's own orders below top are one or two multiples of Q: too few to tell it from its neighbours,
            # and the cogging's fundamental, which would, is beyond what the logs resolve in time
            refusal = (
                f"slots not given, and the logs do not determine them: their held-out time blocks are predicted best "
                f"by {best_q} slots, whose cogging fundamental LCM({best_q}, {2 * p}) = {lcm} is beyond order {top}, "
                f"the highest the logs resolve at their speed: set slots in the motor TOML, or log at most "
                f"{top / lcm:.2g} times as fast")
    if refusal is not None:
        # neither gives a count: the fundamental may turn too fast for the logs' sampling, read over the angle
        found = _count_over_the_angle(logs, p, sample_time, top, seen)
        if found is None:
            raise ExcitationError(refusal)
        info.update(found)
        return found["slots"], _with_held_out(info, held_out)
    info.update({"slots": best_q, "cogging_fundamental": lcm, "chosen_by": "held-out blocks",
                 "slots_with_that_fundamental": sorted(x for x in held_out["bases"]
                                                       if fundamental_cogging_order(x, p) == lcm)})
    return best_q, _with_held_out(info, held_out)


def _count_over_the_angle(logs, p: int, sample_time: float, top: int, seen) -> dict | None:
    """The slot count whose fundamental the logs' steady stretches show most strongly over the angle
    (:func:`pgcomm.rotary.over_the_angle.order_evidence`), or ``None``: where the orders the logs resolve in time (up
    to ``top``) do not give one, the fundamental may be beyond them, or hidden in time by a speed loop's ripple.

    Candidates are the fundamentals ``L = LCM(Q, 2p)`` up to :data:`MAX_ORDER` of the counts a motor can be wound
    with, but for the drive's own orders (:func:`pgcomm.rotary.model.drive_orders`); each order's ``T²`` over its
    family-wise threshold (``α`` = :data:`EXTRA_ORDER_ALPHA` over the candidates).
    The strongest one that passes is the fundamental: a motor's cogging fundamental outweighs the drive's and the
    ripple's orders it may share a multiple of ``2p`` with. Of the counts with that ``L``, the one that explains the
    most slot sidebands seen in time (``seen``: orders up to ``top`` that are not multiples of ``2p``), then the
    fewest slots. ``{"slots", "cogging_fundamental", "chosen_by": "over the angle", "slots_with_that_fundamental",
    "over_the_angle": {"t2_over_threshold", "segments"}}``."""
    by_l: dict[int, list[int]] = {}
    # a drive's own orders (p, 2p, 3p, 4p, 6p: its current sensors, its dead time) are on every drive's logs, whatever
    # the motor: a count whose fundamental is one of them cannot be told from the drive
    drive = set(drive_orders(p).tolist())
    for q in range(3, MAX_SLOTS + 1):
        lcm = fundamental_cogging_order(q, p)
        if winding_exists(q, p) and lcm <= MAX_ORDER and lcm not in drive:
            by_l.setdefault(lcm, []).append(q)
    if not by_l:
        return None
    cands = np.array(sorted(by_l))
    orders = np.union1d(np.arange(1, top + 1), cands)
    t2, segs = order_evidence(logs, orders, sample_time)
    if not segs:
        return None
    thr = chi2.isf(EXTRA_ORDER_ALPHA / cands.size, 4 * segs)
    ratio = t2[np.searchsorted(orders, cands)] / thr
    best = int(np.argmax(ratio))
    if ratio[best] <= 1.0:
        return None
    lcm = int(cands[best])
    side = [int(h) for h in seen if h > 2 and h % (2 * p)]
    q = min(by_l[lcm], key=lambda x: (-sum(1 for h in side if h % x == 0), x))
    return {"slots": q, "cogging_fundamental": lcm, "chosen_by": "over the angle",
            "slots_with_that_fundamental": by_l[lcm],
            "over_the_angle": {"t2_over_threshold": float(ratio[best]), "segments": int(segs)}}


def over_the_angle_count_text(info: dict) -> str:
    """A clause on a fundamental read over the angle (``info`` of :func:`detect_slots` chosen so), or ``""``."""
    found = info.get("over_the_angle")
    if info.get("chosen_by") != "over the angle" or not found:
        return ""
    return (f"the fundamental is beyond the orders the logs resolve in time, and read over the angle of "
            f"{found['segments']} steady stretch(es) it stands at {found['t2_over_threshold']:.3g} times its threshold, "
            "the strongest of the counts' fundamentals there")


def held_out_text(info: dict) -> str:
    """What the held-out blocks said of a count (``info`` of :func:`detect_slots`), as a clause: the share of the
    current's held-out mean square the count leaves, beside the next other count's and the poles' alone."""
    h = info.get("held_out")
    if not h:
        return ""
    nxt = h.get("next")
    how = "taken by the held-out blocks" if info.get("chosen_by") == "held-out blocks" else "held-out blocks"
    return (f"{how}: {100 * h['unexplained']:.3g} % of the current unexplained with {info['slots']} slots"
            + (f", {100 * nxt['unexplained']:.3g} % with {nxt['slots']}" if nxt else "")
            + f", {100 * h['poles_alone']:.3g} % with the poles' orders alone")


def _mse_of(held_out: dict, q: int) -> float:
    """The held-out mean square of slot count ``q``'s basis (that of the count with the same basis below ``top``)."""
    return held_out["mse"][held_out["same_as"][q]]


def _with_held_out(info: dict, held_out: dict) -> dict:
    """``info`` with the held-out blocks' verdict: the chosen count's mean square, the next other basis's, and the
    poles' alone, each as a share of the current's held-out mean square (``1 − R²``)."""
    q = info["slots"]
    mine = _mse_of(held_out, q)
    others = sorted((v, x) for x, v in held_out["mse"].items() if x != held_out["same_as"][q])
    scale = max(held_out["mean_square"], 1e-300)
    info["held_out"] = {"unexplained": mine / scale, "poles_alone": held_out["base"] / scale}
    if others:
        info["held_out"]["next"] = {"slots": others[0][1], "unexplained": others[0][0] / scale}
    return info


def _held_out(equations, layout: _Layout, pole_pairs: int, top: int) -> dict:
    """Each slot count's basis judged on the logs' held-out time blocks (module docstring, "What the logs predict").

    ``equations`` are the normal equations of every cogging order to ``top`` (:func:`_fit`'s, training and held-out
    rows apart): a count's basis is a subset of their columns, so each count's ridge-validated fit and its held-out
    mean square (:func:`pgcomm.rotary.regression._validated_ridge`) cost a solve of its own columns, not a pass over
    the logs. Counts whose bases agree up to ``top`` are one candidate (the smallest count stands for them).

    Returns:
        dict: ``mse`` (count → held-out mean square, A², one count per distinct basis), ``own`` (count → the orders
        of its basis the poles and the drive do not share, ``(k,)`` int), ``same_as`` (every count
        that can be wound with ``p`` → the count standing for its basis), ``bases`` (the counts that can be wound),
        ``base`` (the held-out mean square of the orders every count shares: 1, 2, the multiples of ``2p`` and the
        drive's orders), ``mean_square`` (the current's held-out mean square, A²).
    """
    G, b, yy, n = equations
    p = int(pole_pairs)
    kept = np.flatnonzero(layout.keep)
    at = np.full(layout.keep.size, -1)
    at[kept] = np.arange(kept.size)
    cog = np.zeros(layout.keep.size, bool)
    cog[layout.o_c] = True
    common = at[kept[~cog[kept]]]
    pen = layout.pen[kept].astype(float)
    shared = {1, 2} | set(range(2 * p, top + 1, 2 * p)) | {int(h) for h in drive_orders(p) if h <= top}

    def mse(orders) -> float:
        o = np.array(sorted(orders), int)
        cols = at[np.concatenate([layout.o_c[o - 1], layout.o_c[top + o - 1]])]
        idx = np.sort(np.concatenate([common, cols[cols >= 0]]))
        return min(_validated_ridge(G[:, idx][:, :, idx], b[:, idx], yy, n, pen[idx])[1])

    out = {"mse": {}, "own": {}, "same_as": {}, "bases": [], "base": mse(shared),
           "mean_square": float(yy[1]) / max(float(n[1]), 1.0)}
    by_basis = {}
    for q in range(3, MAX_SLOTS + 1, 3):
        if not winding_exists(q, p):
            continue
        out["bases"].append(q)
        basis = frozenset(int(h) for h in cogging_orders(q, p) if 1 <= h <= top) | shared
        if basis not in by_basis:
            by_basis[basis] = q
            out["mse"][q] = mse(basis)
            out["own"][q] = np.array(sorted(basis - shared), int)
        out["same_as"][q] = by_basis[basis]
    return out


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
