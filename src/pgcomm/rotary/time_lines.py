"""Time-periodic disturbances in a drive's running logs, searched for and fitted beside the maps of
:func:`pgcomm.rotary.identify.identify` (columns of :mod:`pgcomm.rotary.regression`).

**Time-periodic disturbances.** A rig adds torque at fixed frequencies whatever the rotor's speed: a current
sensor's mains pickup (the current loop turns it into torque), a fan or a pump on the frame, a resonance the drive
keeps exciting. At one speed such a line is an order of the revolution; in logs at several speeds it spreads over
orders the basis does not have, and a pickup of 1 % of the current limit puts the maps far beyond their standard
errors (figures: ``bench/rotary_time_lines.py``). The residuals of the basis fit are searched for lines at one frequency in the logs of
two different speeds (:func:`_time_lines`); a line the logged current carries twice as strongly is its own (a
dither's), and one an order of the revolution explains as well is that order. Each line found is fitted beside
the maps, a cosine and a sine per log (a log's phase is its own), and the results report it.

**What it cannot tell apart.** A disturbance ``d`` is ``d`` in the fit and ``T d`` in the current (``T`` the speed
loop's complementary sensitivity); a dither's misfit is a small share of the dither. So a line the drive's loop
amplifies more than ``1 /`` :data:`LINE_CURRENT_SHARE`-fold (near the speed loop's peak), or one within about a
natural bin of a dither (a 60 Hz pickup beside a 61 Hz dither in 1 s logs, where the current's line there cannot be
separated from the dither's), is taken for the current's own: give it with ``time_lines=`` (``--time-lines``). Logs
at one speed only cannot tell a line from an order.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import median_filter
from scipy.optimize import minimize_scalar
from scipy.stats import chi2, gamma

from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.regression import EXTRA_ORDER_ALPHA, FILTER_TAPS, MIN_SAMPLES_PER_PERIOD, Orders, _Layout, \
    _basis_cost, _basis_fit, _chunks, _evidence, _prepare, _residuals, resolved_orders

#: Time-periodic disturbances (:func:`_time_lines`): at most this many lines, from at most this many peaks examined
MAX_LINES = 4
MAX_LINE_CANDIDATES = 8
#: ... above this frequency (Hz): slower content of a few-second log is the speed's own drift
LINE_MIN_HZ = 2.0
#: ... the spectra zero-padded to this many times the longest log, their noise floors the running median over this
#: many bins of each log's own periodogram
LINE_PADDING = 4
LINE_FLOOR_BINS = 65
#: ... a log counts as at constant speed (a line there could be an order of the revolution) when the interquartile
#: range of its mean speeds over stretches of this many seconds is within this share of their median
LINE_SPEED_SECONDS = 0.25
LINE_CONSTANT_SPEED = 0.1
#: ... and as showing a line where its normalised periodogram exceeds this (chance e⁻⁶ for noise alone)
LINE_LOG_SUPPORT = 6.0
#: ... a line is a disturbance only where its amplitude fitted beside the maps is at least this share of the logged
#: current's own line at that frequency (median over the logs that show it). A torque disturbance ``d`` (or a current
#: sensor's pickup, which the current loop turns into one) is ``d`` in the fit and ``T d`` in the current (``T`` the
#: speed loop's complementary sensitivity), a share of ``1/|T|``: at least 0.5 for up to 6 dB of peaking (about 1
#: where the pickup is only in the log). Where the current carries a line twice the fitted one it is its cause (the
#: user's dither) and the residual the model's misfit of it, a small share where the logs are read right
#: (``bench/rotary_time_lines.py --several`` prints the shares)
LINE_CURRENT_SHARE = 0.5
#: ... the logged current's line at a candidate's frequency is fitted jointly with at most this many of the current's
#: other strong lines nearby (:func:`_current_lines`), none closer than this many natural bins to another
MAX_CURRENT_NEIGHBOURS = 4
CURRENT_NEIGHBOUR_BINS = 1.0
#: ... the orders tried as the line's other explanation, and the χ² level a line must pass against the best of them
MAX_LINE_ORDERS = 4
LINE_EVIDENCE_LEVEL = 1e-3
#: ... fits spent refining a line's frequency
LINE_REFINE_FITS = 10


def _peak(f: np.ndarray, power: np.ndarray, j: int) -> float:
    """The frequency (Hz) of the spectral peak at bin ``j`` of ``power`` on the grid ``f``: the vertex of the parabola
    through the log-power of ``j`` and its two neighbours (a Gaussian-shaped peak exactly), ``f[j]`` at an edge or
    where the three do not bend down."""
    hz = float(f[j])
    if 0 < j < f.size - 1 and min(power[j - 1], power[j + 1]) > 0:
        y0, y1, y2 = np.log(power[j - 1:j + 2])
        den = y0 - 2 * y1 + y2
        if den < 0:
            hz += float(0.5 * (y0 - y2) / den * (f[1] - f[0]))
    return hz


def _current_lines(prepared, hz: float, taps: int) -> np.ndarray:
    """``(L,)`` per log, the amplitude (A) of the logged current's line at ``hz``: its filtered current fitted on a
    cosine and a sine through the same kernel and filter as a disturbance's line (:func:`_chunks`), jointly with the
    current's other strong lines within the noise floor's window of ``hz``.

    Those are taken one at a time, the strongest first, from the sum over the logs of the periodograms of what the
    lines so far leave of the current (:func:`_line_spectrum`), while it exceeds the ``1 − α/M`` quantile of noise
    alone; at most :data:`MAX_CURRENT_NEIGHBOURS`, none within :data:`CURRENT_NEIGHBOUR_BINS` natural bins (of the
    shortest log) of a line already taken. Fitted alone, the cosine and sine at ``hz`` take in part of a dither line
    a few bins off (a pickup's 100 Hz harmonic 7 Hz from the running logs' 107 Hz dither would be refused and left in
    the maps); fitted jointly with the dither's line, its share is the pickup's own.
    A dither one natural bin off is not separated (a 60 Hz line beside a 61 Hz dither in 1 s logs, module docstring).
    """
    none = Orders(np.zeros(0, int), np.zeros(0, int), np.zeros(0, int))
    stride = max(1, taps // 2)
    ts = float(np.median([p.ts for p in prepared]))
    freqs = [float(hz)]
    while True:
        k2 = 2 * len(freqs)
        G, g = np.zeros((len(prepared), k2, k2)), np.zeros((len(prepared), k2))
        parts = [([], [], []) for _ in prepared]
        for ch in _chunks(prepared, none, taps, lines=tuple(freqs)):
            k = ch["log"][0]
            G[k] += ch["line"].T @ ch["line"]
            g[k] += ch["line"].T @ ch["y"]
            for part, x in zip(parts[k], (ch["row"], ch["y"], ch["line"])):
                part.append(x)
        coef = [np.linalg.lstsq(a, b, rcond=None)[0] for a, b in zip(G, g)]
        if len(freqs) > MAX_CURRENT_NEIGHBOURS:
            break
        left = [(np.concatenate(r), np.concatenate(y) - np.concatenate(c) @ b) for (r, y, c), b in zip(parts, coef)]
        f, _, total, independent, edge = _line_spectrum(left, stride, ts)
        threshold = float(gamma.isf(EXTRA_ORDER_ALPHA / (2.0 * max(independent, 1)), len(left)))
        natural = max(1.0 / ((int(r.max()) // stride + 1) * stride * ts) for r, _ in left)
        near = (np.abs(f - hz) <= (LINE_FLOOR_BINS // 2) * natural) & (f >= LINE_MIN_HZ) & (f <= edge)
        for f0 in freqs:
            near &= np.abs(f - f0) > CURRENT_NEIGHBOUR_BINS * natural
        if not np.any(near):
            break
        j = int(np.flatnonzero(near)[np.argmax(total[near])])
        if total[j] <= threshold:
            break
        freqs.append(_peak(f, total, j))
    n = len(freqs)
    return np.array([float(np.hypot(c[0], c[n])) for c in coef])


def _line_spectrum(residuals, stride: int, ts: float):
    """The residuals' periodograms on one frequency grid, each over its own noise floor, and their sum.

    Each log's residual sits on its windows' grid (``stride`` samples; zero where a window was refused), zero-padded
    to :data:`LINE_PADDING` times the longest log so that every log's spectrum is read at the same frequencies. Its
    noise floor is the running median of its unpadded periodogram over :data:`LINE_FLOOR_BINS` bins (over ``ln 2``:
    the median of an exponential), so a noise-only bin is exponential with mean 1 whatever the filter's shape.

    Returns:
        ``(f, per_log, total, independent, edge)``: ``(F,)`` Hz, ``(L, F)``, ``(F,)``, the number of independent
        frequencies in the longest log, and the highest frequency (Hz) at which every log's noise floor has its whole
        window (half of it short of the Nyquist frequency of the shortest log's bins).
    """
    lengths = [int(r.max()) // stride + 1 for r, _ in residuals]
    n = 1 << int(math.ceil(math.log2(LINE_PADDING * max(lengths))))
    dt = stride * ts
    f = np.fft.rfftfreq(n, dt)
    per_log = np.empty((len(residuals), f.size))
    for k, ((rows, e), m) in enumerate(zip(residuals, lengths)):
        x = np.zeros(m)
        x[rows // stride] = e
        raw = np.abs(np.fft.rfft(x)) ** 2
        floor = median_filter(raw, size=min(LINE_FLOOR_BINS, raw.size), mode="nearest") / math.log(2.0)
        floor = np.interp(f, np.fft.rfftfreq(m, dt), np.maximum(floor, 1e-300))
        per_log[k] = np.abs(np.fft.rfft(x, n)) ** 2 / floor
    edge = f[-1] - (LINE_FLOOR_BINS // 2) / (min(lengths) * dt)
    return f, per_log, per_log.sum(axis=0), max(lengths) // 2, edge


def _time_lines(prepared, orders: Orders, taps: int) -> dict:
    """Time-periodic disturbances in the logs (module docstring, "Time-periodic disturbances"): lines at one
    frequency (Hz) in the residuals of logs at different speeds.

    Repeatedly: the basis fit with the lines found so far; the sum over the logs of the residuals' normalised
    periodograms (:func:`_line_spectrum`), a ``Gamma(L)`` variable per frequency where there is only noise; its
    peaks above :data:`LINE_MIN_HZ`, largest first, while they exceed that distribution's ``1 − α/M`` quantile
    (``α`` = :data:`EXTRA_ORDER_ALPHA`, ``M`` twice the independent frequencies: the padded grid's maximum), each
    frequency refined on a parabola. A peak is a candidate only where logs at two different speeds show it (a
    log whose speed varies counts as a speed of its own): what is locked to the speed (an order of the revolution,
    the encoder's rounding beating with the sample rate at a constant speed) shows at one speed's frequency only. A
    line an order of the revolution could make (at a constant speed ``ω``, order ``h`` is ``h ω / 2π`` Hz) is taken
    only where a cosine and a sine per log at that frequency fit better than the best such order by the χ² quantile
    of :data:`LINE_EVIDENCE_LEVEL` for the ``2L − 2`` extra parameters; otherwise the order joins the fit (it is the
    screening's to keep or not) and the spectrum is taken again.

    The windows' grid is ``1 / (stride T_s)``: a line above half of it shows at its alias (``aliases``), which fits the
    same (its amplitude is then the alias's through the filter).

    Returns:
        ``{"hz": [...], "aliases": [[...]], "statistic": [...], "threshold": float, "evidence": [...],
        "speeds_seen": [...], "read_as_orders": [{"hz", "order"}...], "locked_to_one_speed": [Hz...],
        "in_the_current": [Hz...], "current_share": [{"hz", "share"}...], "searched": True}``: the lines taken, the
        peaks set aside, and each peak's amplitude fitted beside the maps over the logged current's own line there
        (median over the logs that show it; under :data:`LINE_CURRENT_SHARE` it is the current's own).
    """
    stride = max(1, taps // 2)
    ts = float(np.median([p.ts for p in prepared]))
    rate = 1.0 / (stride * ts)
    logs = len(prepared)
    span = taps + 2
    speeds = []
    for p in prepared:
        # the mean speeds over stretches of LINE_SPEED_SECONDS (the cogging's speed ripple is not the log's speed),
        # their median and interquartile range (nor are a constant-speed log's ramps)
        m = max(2, int(round(LINE_SPEED_SECONDS / p.ts)))
        mid = p.starts + span // 2
        blocks = np.abs(p.theta[mid[m:]] - p.theta[mid[:-m]]) / ((mid[m:] - mid[:-m]) * p.ts) if mid.size > m else \
            np.abs(p.w[mid])
        q1, med, q3 = np.percentile(blocks, [25, 50, 75])
        speeds.append(float(med) if q3 - q1 <= LINE_CONSTANT_SPEED * med else None)
    out = {"hz": [], "aliases": [], "statistic": [], "evidence": [], "speeds_seen": [], "read_as_orders": [],
           "locked_to_one_speed": [], "in_the_current": [], "current_share": [], "threshold": None,
           "searched": True}
    found, extra, locked, wide = [], np.zeros(0, int), [], []
    refit = True
    for _ in range(MAX_LINE_CANDIDATES):
        if refit:
            cur = Orders(np.union1d(orders.cogging, extra), orders.ripple, orders.direction)
            lay = _Layout.of(cur, tuple(found), logs)
            beta, cost, rows = _basis_fit(prepared, lay, taps)
            f, per_log, total, independent, edge = _line_spectrum(_residuals(prepared, lay, taps, beta), stride, ts)
            out["threshold"] = float(gamma.isf(EXTRA_ORDER_ALPHA / (2.0 * max(independent, 1)), logs))
            refit = False
        # the noise floor is a running median: within half its window of the windows' Nyquist frequency it is not (a
        # peak just below that frequency would be taken as a line, read as two orders, and slow identify down)
        band = (f >= LINE_MIN_HZ) & (f <= edge)
        for hz0 in locked:  # peaks already set aside: two natural bins either side
            band &= np.abs(f - hz0) > 2.0 * LINE_PADDING * (f[1] - f[0])
        for hz0 in wide:
            band &= np.abs(f - hz0) > (LINE_FLOOR_BINS // 2) * LINE_PADDING * (f[1] - f[0])
        if not np.any(band):
            break
        j = int(np.flatnonzero(band)[np.argmax(total[band])])
        if total[j] <= out["threshold"]:
            break
        hz = _peak(f, total, j)
        seen = [k for k in range(logs) if per_log[k, j] >= LINE_LOG_SUPPORT]
        groups = []
        for k in seen:
            w = speeds[k]
            if w is None or not any(g is not None and abs(w - g) <= LINE_CONSTANT_SPEED * g for g in groups):
                groups.append(w)
        if len(groups) < 2:
            locked.append(hz)
            out["locked_to_one_speed"].append(hz)
            continue
        # the line fitted beside the maps against the logged current's own line at that frequency, per log (median
        # over the logs that show it): a residual's periodogram would read a line the maps absorb part of in a log
        # where the frequency falls on a basis order as smaller than it is
        lay_line = _Layout.of(cur, tuple(found) + (hz,), logs)
        beta_line, cost_line, _ = _basis_fit(prepared, lay_line, taps)
        full = np.zeros(lay_line.keep.size)
        full[lay_line.keep] = beta_line
        cs = full[lay_line.o_t].reshape(logs, 2, len(found) + 1)[:, :, -1]
        in_current = np.maximum(_current_lines(prepared, hz, taps)[seen], 1e-300)
        shares = np.hypot(cs[seen, 0], cs[seen, 1]) / in_current
        share = float(np.median(shares))
        out["current_share"].append({"hz": hz, "share": share})
        if share < LINE_CURRENT_SHARE:
            # the current's own line (a dither): its sidebands of the misfit too, over the noise floor's window
            wide.append(hz)
            out["in_the_current"].append(hz)
            continue
        aliases = [hz] + [a for m in range(1, int(0.5 / ts / rate) + 2) for a in (m * rate - hz, m * rate + hz)]
        aliases = [float(a) for a in aliases if 0 < a <= 0.5 / ts]
        # the orders that could make this line in a constant-speed log that shows it (at the line or an alias)
        support = {}
        for k in seen:
            if speeds[k] is None or speeds[k] <= 0:
                continue
            for a in aliases:
                h = int(round(2 * math.pi * a / speeds[k]))
                if 1 <= h <= 2 * max(orders.highest, 1) and h not in cur.cogging:
                    support[h] = support.get(h, 0.0) + float(per_log[k, j])
        best_order, cost_alt, dof = None, cost, 2 * logs
        for h in sorted(support, key=support.get, reverse=True)[:MAX_LINE_ORDERS]:
            c = _basis_cost(prepared, _Layout.of(Orders(np.union1d(cur.cogging, [h]), cur.ripple, cur.direction),
                                                 tuple(found), logs), taps)[0]
            if c < cost_alt:
                best_order, cost_alt, dof = h, c, 2 * logs - 2
        e = _evidence(cost_alt, cost_line, rows, taps)
        if e > float(chi2.isf(LINE_EVIDENCE_LEVEL, max(dof, 1))):
            # the spectrum's peak is good to a few hundredths of a bin; over a log of many periods the phase needs
            # better: the frequency whose fit leaves the least, within a natural bin of the peak

            step = rate / (2 * independent)
            best = minimize_scalar(lambda x: _basis_cost(prepared, _Layout.of(cur, tuple(found) + (x,), logs), taps)[0],
                                   bounds=(hz - step, hz + step), method="bounded",
                                   options={"xatol": step / 100, "maxiter": LINE_REFINE_FITS})
            if best.fun < cost_line:
                hz = float(best.x)
            found.append(hz)
            out["hz"].append(hz)
            out["aliases"].append(aliases[1:])
            out["statistic"].append(float(total[j]))
            out["evidence"].append(float(e))
            out["speeds_seen"].append(len(groups))
            if len(found) >= MAX_LINES:
                break
        elif best_order is not None:
            extra = np.union1d(extra, [best_order])
            out["read_as_orders"].append({"hz": hz, "order": int(best_order)})
        else:
            locked.append(hz)
            continue
        refit = True
    return out


def detect_time_lines(logs, motor: RotaryMotor, orders: Orders | None = None, *,
                      min_samples_per_period: float = MIN_SAMPLES_PER_PERIOD, taps: int = FILTER_TAPS,
                      current_lag=None) -> dict:
    """The time-periodic disturbances :func:`identify` would fit beside the maps of ``logs`` (read as they are: apply
    :func:`apply_reading` first, and give the current's form, ``current_lag``, as
    :func:`pgcomm.rotary.readings.lag_of` says), without the identification: e.g. to count the slots with them fitted
    (a pickup at two speeds spreads over orders the basis does not have).

    Returns:
        the entry :func:`identify` reports as ``time_lines`` (without the amplitudes).
    """
    if orders is None:
        # the basis identify fits: cut to the orders the logs resolve in time (a joint's speed loop)
        orders, _ = resolved_orders(logs, motor, Orders.for_motor(motor), min_samples_per_period)
    prepared, _, _, _ = _prepare(logs, motor, orders, min_samples_per_period, taps, current_lag=current_lag)
    return _time_lines(prepared, orders, taps)


def lines_text(lines: dict) -> str | None:
    """One sentence on the time-periodic disturbances (``time_lines`` of :func:`identify`), or ``None`` when
    none was searched or given."""
    if not lines or not (lines.get("searched") or lines.get("hz")):
        return None
    hz = lines.get("hz") or []
    if not hz:
        return "no time-periodic disturbance in the logs (no line at one frequency in the logs of two speeds)"
    amps = lines.get("amplitude_A") or [float("nan")] * len(hz)
    aliases = lines.get("aliases") or [[] for _ in hz]
    each = []
    for f, a, al in zip(hz, amps, aliases):
        also = f" (or its alias at {' or '.join(f'{x:.1f}' for x in al[:2])} Hz)" if al else ""
        each.append(f"{a:.3g} A of q-current at {f:.2f} Hz{also}")
    how = "found in the logs of different speeds" if lines.get("searched") else "as given"
    return (f"a time-periodic disturbance, {'; '.join(each)}, {how}; fitted beside the maps with its own phase in "
            "each log (a current sensor's pickup, a fan or a pump on the rig, a resonance)")
