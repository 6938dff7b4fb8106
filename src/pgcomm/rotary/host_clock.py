"""The host's clock in a logged angle: a noise that grows with the speed, and the rows' weights it sets.

**The noise.** A PC that polls a drive stamps each row when it reads it; the drive's values are those of its last
control cycle before. The angle is therefore the rotor's at an instant a little before its stamp, by an amount that
varies from row to row (uniform over a control cycle, plus the host's own stamping noise). At speed ``ω`` an error
``δt`` in the instant is an error ``ω δt`` in the angle, so the logged angle carries a white noise of variance::

    var_θ(ω) = a + b ω²            (a: the encoder's rounding and other white noise, rad²; b = σ_t², s²)

In the filtered acceleration (:mod:`pgcomm.rotary.quantisation`) this becomes a current-equivalent noise
``(J/k0)² W(ω)`` in the regression's rows: at the speeds of a running log, thousands of times the encoder's, so the
fast rows are far noisier than the slow ones. It is a variance, not a bias: inflating the errors-in-variables
correction does nothing to it.

**Reading it from the angle alone** (:func:`angle_noise_bins`, :func:`speed_noise_fit`). In every run of
``k + 1`` consecutive samples the ``k``-th divided difference over the real stamps annihilates any polynomial of
degree ``k − 1`` in time; normalised to unit coefficient norm it is, for a white angle noise of locally constant
variance, a variable of that variance. The motion's part falls as ``(2 sin(π f T_s))^k`` (a dither at a tenth of the
log rate: ``0.6^k``), so at ``k = 6`` (:data:`DIFFERENCE_ORDER`) a multi-ampere dither leaves less than a per cent of
the noise. The squared differences are binned by speed; a bin's variance is their mean after the values beyond
``χ²₁``'s :data:`TRIM_QUANTILE` quantile of the bin's median-based scale are set aside (glitches, a stall's jerk),
with the truncated mean's closed-form factor put back. ``a`` and ``b`` are the non-negative weighted least squares
of those bins on ``[1, ω²]``, from one log's bins or from several logs' together (one host, one encoder).

**The rows' weights** (:func:`row_weights`). Each row's acceleration noise ``A_j`` is predicted from ``var_θ`` at its
speed (:func:`pgcomm.rotary.quantisation.acceleration_noise`); the squared residuals of a first fit of the basis,
binned by ``A_j`` the same way, give ``e² ≈ c0 + c1 A_j`` (``c1`` near ``(J/k0)²``; ``c0`` the current's noise and
what the model leaves). The rows then enter the regression with weights ``w_j = 1 / (c0 + c1 A_j)`` (normalised to
a mean of 1), a feasible generalised least squares. Only where the speed-dependent part matters: ``b`` resolved
(:data:`RESOLVED_SIGMAS` standard errors), the timing noise at the fast rows at least the angle's other noise
(``b ω_95² ≥ a``) and a clock's (``σ_t`` at least :data:`MIN_TIMING_SHARE` of the median step), and the predicted residual variance at the fastest rows at least :data:`WEIGHT_SPREAD` times that
at the slowest (below it generalised least squares gains little over ordinary); otherwise every weight is 1 and
the fit is unchanged. The squared residuals must also grow with ``A_j`` at least as ``J/k0`` says they should, within
:data:`C1_FACTOR`.

**The acceleration's bias** (:func:`timing_noise`). The same noise sits in the regressor: least squares pulls ``J/k0``
towards zero by the share of the filtered acceleration's variance it makes up (2.4-fold at 40 µs on a 30 rad/s log),
and the maps absorb what ``J/k0`` misses, whether or not the rows are weighted. Its variance per row, ``σ_t² ω²`` at
each sample through the squared weights of the row's filtered divided differences over the real stamps
(:func:`_row_noise`; ``σ_t² ω² Σ k_m² / T_s⁴`` on uniform stamps), is known from the angle, so it is taken out of the
normal equations with the encoder's (:mod:`pgcomm.rotary.quantisation`). The host's clock is white and the drive does not react to it, so the correction
holds as the model says. Only where the growth is a clock's: at slow speeds an encoder's rounding also grows with the
speed (the steps of a rotor that moves less than a count per sample are correlated, and whiten as it speeds up), so
the rows must move at least :data:`MIN_COUNTS_PER_SAMPLE` encoder steps per sample at their median speed, and the
timing part must reach the angle's other noise there (``b ω_50² ≥ a``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.optimize import nnls
from scipy.stats import chi2

from pgcomm.rotary import quantisation
from pgcomm.rotary.regression import _basis_fit, _hann, _Layout, _residuals

__all__ = ["angle_noise_bins", "speed_noise_fit", "row_weights", "timing_noise", "weigh", "host_clock_text", "DIFFERENCE_ORDER", "SPEED_BINS", "TRIM_QUANTILE",
           "RESOLVED_SIGMAS", "WEIGHT_SPREAD"]

#: Order ``k`` of the divided difference that reads the angle's noise (module docstring).
DIFFERENCE_ORDER = 6
#: Speed (and predicted-noise) bins of the variance function's fit.
SPEED_BINS = 8
#: A run of samples spanning more than this many median steps per difference order holds a gap: left out.
MAX_SPAN_STEPS = 2.0
#: Squared differences beyond this ``χ²₁`` quantile of their bin's median-based scale are set aside (glitches).
TRIM_QUANTILE = 0.999
#: The timing noise ``b`` counts as found when it is at least this many of its standard errors.
RESOLVED_SIGMAS = 3.0
#: Rows are weighted only when the predicted residual variance at the fastest rows (95th percentile of ``A_j``) is at
#: least this many times that at the slowest (5th): below it generalised least squares gains little over ordinary.
WEIGHT_SPREAD = 2.0
#: The residuals' growth with the predicted acceleration noise, ``c1``, must be at least ``(J/k0)²`` over this factor
#: (the angle's noise reaches the rows through ``J/k0``): a growth far below it is not the angle's noise (logs without
#: noise, whose residuals are the kernel's error). Only a lower bound: the same noise in the acceleration regressor
#: pulls the first fit's ``J/k0`` towards zero (2.4-fold at 40 µs on a 30 rad/s log).
C1_FACTOR = 4.0
#: A timing noise below this share of the log's median step is not a clock's (a host stamps to a microsecond or
#: better, a drive's own clock exactly): what the differences then read is the motion's own, and no row is weighted.
MIN_TIMING_SHARE = 1e-3
#: The timing noise's bias is taken out only where the rows' median speed moves the angle at least this many
#: encoder steps per sample (below it the rounding's own growth with the speed reads as a clock's).
MIN_COUNTS_PER_SAMPLE = 4.0
#: Fewest values in a bin.
MIN_BIN = 10
#: A bin's standard error counts as at least this share of the bins' median (:func:`speed_noise_fit`).
SE_FLOOR = 0.1

_CHI2_MEDIAN = 0.454936423119572  # median of χ²₁


def _trimmed_mean(x: np.ndarray, inflation: float) -> tuple[float, float]:
    """``(variance, its standard error)`` from squared values ``x`` of a zero-mean variable: their mean after those
    beyond :data:`TRIM_QUANTILE` of ``χ²₁`` times the median-based scale are set aside, divided by the truncated
    mean's factor ``P(χ²₃ ≤ q) / P(χ²₁ ≤ q)`` (exact for a normal variable); ``inflation`` the variance factor of the
    values' correlation (overlapping windows)."""
    q = float(chi2.ppf(TRIM_QUANTILE, 1))
    scale = float(np.median(x)) / _CHI2_MEDIAN
    kept = x[x <= q * scale] if scale > 0 else x
    factor = float(chi2.cdf(q, 3) / chi2.cdf(q, 1))
    v = float(np.mean(kept)) / factor
    se = float(np.std(kept)) / factor * math.sqrt(inflation / max(kept.size, 1))
    return v, se


def _overlap_inflation(order: int) -> float:
    """``Σ_lag ρ²`` of the ``order``-th difference of white noise (overlapping windows): the factor by which their
    squares' mean is noisier than that of as many independent values, ``C(4k, 2k) / C(2k, k)²``."""
    return math.comb(4 * order, 2 * order) / math.comb(2 * order, order) ** 2


def angle_noise_bins(t, theta, order: int = DIFFERENCE_ORDER, bins: int = SPEED_BINS) -> dict:
    """The logged angle's noise variance in bins of speed, from the angle alone (module docstring).

    Args:
        t: ``(N,)`` time stamps (s), increasing (uniform or not).
        theta: ``(N,)`` logged angle (rad, multi-turn).
        order: the divided difference's order ``k``; bins: speed bins (quantiles of the speed).

    Returns:
        dict: ``variance`` ``(m,)`` rad², ``se`` ``(m,)`` rad², ``speed2`` ``(m,)`` mean ω² (rad²/s²), ``count``
        ``(m,)`` int and ``windows`` int; ``m ≤ bins`` (bins with fewer than :data:`MIN_BIN` runs left out; all empty
        arrays when the log is too short).
    """
    t, th = np.asarray(t, float), np.asarray(theta, float)
    empty = {"variance": np.zeros(0), "se": np.zeros(0), "speed2": np.zeros(0), "count": np.zeros(0, int),
             "windows": 0}
    n = th.size - order
    if n < MIN_BIN:
        return empty
    h = float(np.median(np.diff(t)))
    idx = np.arange(n)[:, None] + np.arange(order + 1)
    x = (t[idx] - t[idx[:, :1]]) / h  # in median steps: the products stay O(1)
    diff = x[:, :, None] - x[:, None, :]
    diff[:, np.arange(order + 1), np.arange(order + 1)] = 1.0
    c = 1.0 / np.prod(diff, axis=2)  # the divided difference's coefficients
    c /= np.sqrt(np.sum(c * c, axis=1, keepdims=True))
    r2 = np.sum(c * th[idx], axis=1) ** 2
    span = x[:, -1]
    speed = (th[idx[:, -1]] - th[idx[:, 0]]) / (span * h)
    ok = span <= MAX_SPAN_STEPS * order
    r2, speed = r2[ok], np.abs(speed[ok])
    if r2.size < MIN_BIN:
        return empty
    nb = int(max(1, min(bins, r2.size // MIN_BIN)))
    edges = np.quantile(speed, np.linspace(0.0, 1.0, nb + 1))
    which = np.clip(np.searchsorted(edges, speed, side="right") - 1, 0, nb - 1)
    infl = _overlap_inflation(order)
    out = {k: [] for k in ("variance", "se", "speed2", "count")}
    for i in range(nb):
        m = which == i
        if m.sum() < MIN_BIN:
            continue
        v, se = _trimmed_mean(r2[m], infl)
        out["variance"].append(v)
        out["se"].append(se)
        out["speed2"].append(float(np.mean(speed[m] ** 2)))
        out["count"].append(int(m.sum()))
    return {**{k: np.asarray(v, int if k == "count" else float) for k, v in out.items()}, "windows": int(r2.size)}


def speed_noise_fit(bins) -> dict:
    """``var_θ(ω) = a + b ω²`` from the bins of one log or of several (:func:`angle_noise_bins`): non-negative least
    squares weighted by the bins' standard errors.

    Args:
        bins: one :func:`angle_noise_bins` dict, or a sequence of them (one host, one encoder).

    Returns:
        dict: ``floor_rad2`` (a), ``timing_s2`` (b), ``timing_se_s2`` (its standard error), ``sigma_t_s`` (√b),
        ``resolved`` (b at least :data:`RESOLVED_SIGMAS` standard errors), ``speed95_rad_s`` (the bins' fastest RMS
        speed); ``None`` when no bin was filled.
    """
    bins = [bins] if isinstance(bins, dict) else list(bins)
    v = np.concatenate([b["variance"] for b in bins])
    se = np.concatenate([b["se"] for b in bins])
    w2 = np.concatenate([b["speed2"] for b in bins])
    if v.size == 0:
        return None
    # a bin at standstill holds no noise at all (the angle sits still): its zero standard error would pin the fit
    se = np.maximum(se, max(SE_FLOOR * float(np.median(se)), 1e-300))
    X = np.column_stack([np.ones_like(v), w2])
    col = np.maximum(np.max(np.abs(X), axis=0), 1e-300)  # columns to unit scale: ω² is thousands of rad²/s²
    Xs = X / col / se[:, None]
    coef, _ = nnls(Xs, v / se)
    a, b = coef / col
    if v.size >= 2 and np.ptp(w2) > 0:
        cov = np.linalg.pinv(Xs.T @ Xs) / np.outer(col, col)
        b_se = math.sqrt(max(float(cov[1, 1]), 0.0))
    else:
        b_se = math.inf  # one speed: a and b cannot be told apart
    return {"floor_rad2": float(a), "timing_s2": float(b), "timing_se_s2": float(b_se), "sigma_t_s": math.sqrt(b),
            "resolved": bool(b > 0 and b >= RESOLVED_SIGMAS * b_se), "speed95_rad_s": float(math.sqrt(np.max(w2)))}


def _centre(taps: int) -> int:
    """The sample at a row's centre, from its window's first (the filter's span ``taps + 2``)."""
    return (taps + 2) // 2


def row_weights(prepared, rows, residuals, fit: dict, taps: int, inertia_ratio: float | None = None) -> dict:
    """The rows' weights ``w_j = 1 / (c0 + c1 A_j)`` (module docstring), per log and sample.

    Args:
        prepared: the logs (:class:`pgcomm.rotary.regression._Prepared`): ``w`` the speed per sample (rad/s), ``ts``.
        rows, residuals: per log, each used window's first sample ``(J_i,)`` and a first fit's residual there
            ``(J_i,)`` (A), :func:`pgcomm.rotary.regression._residuals`.
        fit: :func:`speed_noise_fit` of the logs' angle.
        taps: the acceleration filter's taps.
        inertia_ratio: ``J/k0`` of the first fit (A·s²/rad): ``c1`` must reach its square over :data:`C1_FACTOR`.

    Returns:
        ``{"weights": [ (N_i,) per-sample weights or None ], "weighted": bool, "c0_A2", "c1", "spread", "reason"}``:
        ``weights`` ``None`` (every weight 1) unless ``weighted``; ``spread`` the predicted residual variance at the
        95th percentile of the rows over that at the 5th.
    """
    out = {"weights": [None] * len(prepared), "weighted": False, "c0_A2": None, "c1": None, "spread": 1.0}
    if fit is None or not fit["resolved"] or fit["sigma_t_s"] < MIN_TIMING_SHARE * float(np.median([p.ts for p in
                                                                                                     prepared])):
        return {**out, "reason": "no timing noise resolved in the angle"}
    if fit["timing_s2"] * fit["speed95_rad_s"] ** 2 < fit["floor_rad2"]:
        return {**out, "reason": "the timing noise stays below the angle's other noise at these speeds"}
    g = _hann(taps)
    per_sample = [quantisation.acceleration_noise(1.0, g, p.ts) * (fit["floor_rad2"] + fit["timing_s2"] * p.w ** 2)
                  for p in prepared]
    a_rows = np.concatenate([a[r + _centre(taps)] for a, r in zip(per_sample, rows)])
    e2 = np.concatenate(residuals) ** 2
    nb = int(max(1, min(SPEED_BINS, e2.size // MIN_BIN)))
    edges = np.quantile(a_rows, np.linspace(0.0, 1.0, nb + 1))
    which = np.clip(np.searchsorted(edges, a_rows, side="right") - 1, 0, nb - 1)
    # the filter windows overlap (stride taps // 2 of span taps + 2): their squared residuals are that much less news
    infl = (taps + 2) / max(1, taps // 2)
    v, se, a_mean = [], [], []
    for i in range(nb):
        m = which == i
        if m.sum() < MIN_BIN:
            continue
        vi, si = _trimmed_mean(e2[m], infl)
        v.append(vi)
        se.append(si)
        a_mean.append(float(np.mean(a_rows[m])))
    c = speed_noise_fit({"variance": np.array(v), "se": np.array(se), "speed2": np.array(a_mean)})
    if c is None:
        return {**out, "reason": "too few rows"}
    c0, c1 = c["floor_rad2"], c["timing_s2"]
    lo, hi = np.percentile(a_rows, [5, 95])
    spread = (c0 + c1 * hi) / max(c0 + c1 * lo, 1e-300) if c0 + c1 * lo > 0 else math.inf
    out.update(c0_A2=float(c0), c1=float(c1), spread=float(spread))
    if not c["resolved"]:
        return {**out, "reason": "the residuals do not grow with the predicted noise"}
    if inertia_ratio is not None and c1 < inertia_ratio**2 / C1_FACTOR:
        return {**out, "reason": f"the residuals grow with the predicted noise {c1 / max(inertia_ratio**2, 1e-300):.3g} "
                                 "times as (J/k0)² says: not the angle's noise"}
    if spread < WEIGHT_SPREAD:
        return {**out, "reason": f"the residuals' variance varies less than {WEIGHT_SPREAD:g}-fold over the rows"}
    # the floor: the slowest rows' variance (c0 = 0 would weigh a row by its angle's rounding alone)
    floor = max(c0, 0.5 * float(np.min(v)))
    raw = [1.0 / (floor + c1 * a) for a in per_sample]
    mean = float(np.mean(1.0 / (floor + c1 * a_rows)))
    return {**out, "weights": [r / mean for r in raw], "weighted": True, "reason": "the timing noise"}


def unresolved_timing_noise(prepared, taps: int) -> list | None:
    """:func:`timing_noise` at the clock's noise the angle reads where that noise is not resolved from the floor:
    ``None`` where it is resolved (then taken out), or the angle reads none a clock could have.

    At one speed (a joint's speed loop) the angle's noise is read at a single speed, so the encoder's floor and a
    clock's noise that grows with the speed are hardly told apart, and the clock's is not taken out. It still pulls
    ``J/k0`` down, and at one speed the maps with it along the speed ripple: the verdict weighs the fit with it taken
    out (:func:`pgcomm.rotary.identify.identify`)."""
    fit = speed_noise_fit([angle_noise_bins(np.arange(p.theta.size) * p.ts if p.t is None else p.t, p.theta)
                           for p in prepared])
    if fit is None or fit["resolved"] or not fit["timing_s2"] > 0.0:
        return None
    return timing_noise(prepared, {**fit, "resolved": True}, taps)[0]


def timing_noise(prepared, fit: dict | None, taps: int) -> tuple[list | None, str]:
    """The host's clock's noise variance in each row's filtered acceleration (module docstring, "The acceleration's
    bias"), where the angle's speed-dependent noise is a clock's.

    Args:
        prepared: the logs (:class:`pgcomm.rotary.regression._Prepared`): ``w`` (rad/s), ``ts`` (s), ``step`` (the
            encoder's step, rad, or ``None``), ``starts`` (the rows' first samples).
        fit: :func:`speed_noise_fit` of the logs' angle (or ``None``); taps: the acceleration filter's taps.

    Returns:
        ``(noise, reason)``: ``noise`` per log an ``(N_i,)`` variance ((rad/s²)²) of the row centred on each sample,
        or ``None`` where none is taken out; ``reason`` says why or why not.
    """
    step = float(np.median([p.ts for p in prepared]))
    if fit is None or not fit["resolved"] or fit["sigma_t_s"] < MIN_TIMING_SHARE * step:
        return None, "no timing noise resolved in the angle"
    centre = _centre(taps)
    speed = np.concatenate([np.abs(p.w[p.starts + centre]) for p in prepared if p.starts.size])
    w50 = float(np.median(speed)) if speed.size else 0.0
    if fit["timing_s2"] * w50 ** 2 < fit["floor_rad2"]:
        return None, "the timing noise stays below the angle's other noise at the rows' median speed"
    counts = [w50 * p.ts / p.step for p in prepared if p.step]
    if counts and min(counts) < MIN_COUNTS_PER_SAMPLE:
        return None, (f"the rows move {min(counts):.3g} encoder steps per sample at their median speed (under "
                      f"{MIN_COUNTS_PER_SAMPLE:g}): the rounding's growth with the speed is not told from a clock's")
    g = _hann(taps)
    return ([_row_noise(p, g, fit["timing_s2"] * p.w ** 2) for p in prepared],
            "the timing noise's share of the acceleration")


def _row_noise(p, g: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """``(N,)``: at ``start + span // 2`` of each of the log's rows, the variance ((rad/s²)²) that independent angle
    errors of variance ``variance`` ``(N,)`` (rad²) put in its filtered acceleration (a zero elsewhere).

    The row is ``Σ_m g_m d_{s+1+m}`` of the divided differences ``d_i = a_i θ_{i−1} + b_i θ_i + c_i θ_{i+1}`` over the
    real stamps (``a_i = 2 / (h_{i−1}(h_{i−1} + h_i))``, ``c_i = 2 / (h_i(h_{i−1} + h_i))``, ``b_i = −a_i − c_i``;
    ``1, −2, 1`` over ``T_s²`` on a uniform log), so its weight on ``θ_{s+k}`` is
    ``g_k a_{s+k+1} + g_{k−1} b_{s+k} + g_{k−2} c_{s+k−1}`` and its variance the sum of the squared weights times
    ``variance``. On jittered stamps that is more than the uniform formula's (steps uniform over ``±50 %`` of ``T_s``:
    about 2.6-fold), as a divided difference over a short step amplifies its samples' errors."""
    n = p.theta.size
    if p.t is None:
        h = np.full(n + 1, p.ts)
    else:
        d = np.diff(p.t)
        h = np.concatenate([[d[0]], d, [d[-1]]])  # h[i] the step after sample i - 1 (end steps repeated)
    h_before, h_after = h[:-1], h[1:]  # the steps before and after each sample
    a = 2.0 / (h_before * (h_before + h_after))
    c = 2.0 / (h_after * (h_before + h_after))
    b = -a - c
    s = p.starts  # every row's span s .. s + taps + 1 lies inside the log (regression._prepare)
    taps = g.size
    total = np.zeros(s.size)
    for k in range(taps + 2):
        wk = np.zeros(s.size)
        if k < taps:
            wk += g[k] * a[s + k + 1]
        if 1 <= k <= taps:
            wk += g[k - 1] * b[s + k]
        if k >= 2:
            wk += g[k - 2] * c[s + k - 1]
        total += wk * wk * variance[s + k]
    out = np.zeros(n)
    out[s + (taps + 2) // 2] = total
    return out


def weigh(prepared, orders, taps: int) -> tuple[list, dict]:
    """The logs with their rows weighted for the angle's speed-dependent noise, where it matters (module docstring).

    Args:
        prepared: the logs (:func:`pgcomm.rotary.regression._prepare`), as read so far; orders: the basis
            (:class:`pgcomm.rotary.regression.Orders`) of the first fit; taps: the acceleration filter's taps.

    Returns:
        ``(prepared, info)``: the logs with :attr:`~pgcomm.rotary.regression._Prepared.weight` set (or as given), and
        ``{"sigma_t_us", "sigma_t_se_us", "floor_rad2", "resolved", "weighted", "c0_A2", "c1", "spread", "reason",
        "per_log_sigma_t_us", "bias_corrected", "bias_reason"}`` for the results (``results.json``'s
        ``identification.host_clock``); ``bias_corrected``: the timing noise's variance taken out of the acceleration
        (:func:`timing_noise`).
    """
    bins = [angle_noise_bins(np.arange(p.theta.size) * p.ts if p.t is None else p.t, p.theta) for p in prepared]
    fit = speed_noise_fit(bins)
    step = float(np.median([p.ts for p in prepared]))
    per_log = [speed_noise_fit(b) for b in bins]
    info = {"sigma_t_us": None if fit is None else 1e6 * fit["sigma_t_s"],
            "sigma_t_se_us": None if fit is None or not math.isfinite(fit["timing_se_s2"]) or fit["timing_s2"] <= 0
            else 1e6 * fit["timing_se_s2"] / (2.0 * fit["sigma_t_s"]),
            "floor_rad2": None if fit is None else fit["floor_rad2"],
            "resolved": bool(fit and fit["resolved"] and fit["sigma_t_s"] >= MIN_TIMING_SHARE * step),
            "per_log_sigma_t_us": [None if f is None else 1e6 * f["sigma_t_s"] for f in per_log]}
    if not info["resolved"] or fit["timing_s2"] * fit["speed95_rad_s"] ** 2 < fit["floor_rad2"]:
        found = row_weights(prepared, [], [], fit, taps)
    else:
        layout = _Layout.of(orders)
        beta = _basis_fit(prepared, layout, taps)[0]
        res = _residuals(prepared, layout, taps, beta)
        found = row_weights(prepared, [r for r, _ in res], [e for _, e in res], fit, taps, float(beta[0]))
    weights = found.pop("weights")
    info.update(found)
    if info["weighted"]:
        prepared = [replace(p, weight=w) for p, w in zip(prepared, weights)]
    noise, why = timing_noise(prepared, fit, taps)
    info.update(bias_corrected=noise is not None, bias_reason=why)
    if noise is not None:
        prepared = [replace(p, timing_noise=n) for p, n in zip(prepared, noise)]
    return prepared, info


def host_clock_text(info: dict | None) -> str | None:
    """One line on the angle's timing noise where the rows were weighted or the acceleration corrected for it
    (``host_clock`` of :func:`pgcomm.rotary.identify.identify`), else ``None``.

    An angle noise that grows with the speed is a timing noise only where the fit's residuals grow with it too (the
    weighting's test): on slow logs the encoder's rounding turns white as the rotor passes a count per sample and
    grows with the speed as well, so the figure alone is not said."""
    if not info or not info.get("resolved") or not (info.get("weighted") or info.get("bias_corrected")):
        return None
    sigma = f"{info['sigma_t_us']:.3g} µs" + (f" (± {info['sigma_t_se_us']:.2g})" if info.get("sigma_t_se_us") else "")
    done = []
    if info.get("bias_corrected"):
        done.append("its share of the acceleration is taken out of the fit (it would pull J/k0 towards zero)")
    if info.get("weighted"):
        done.append(f"the rows are weighted by their predicted noise (the fastest {info['spread']:.3g} times the "
                    "slowest's variance)")
    return (f"the logged angle carries a timing noise of {sigma} (the host's clock: each row is the drive's state "
            f"at an instant a little before its stamp), an angle noise that grows with the speed: " + "; ".join(done)
            + " (slower running logs, or the drive's own time stamps, carry less of it)")
