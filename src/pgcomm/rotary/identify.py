"""Identification of a rotary motor from running logs, with or without a torque sensor.

**Without a torque sensor** (the drive's own logs: ``t``, ``theta``, ``iq``). The model of
:mod:`pgcomm.rotary.model` divided by ``k0``::

    (J/k0) θ̈ = (1 + r(θ)) i_q + c(θ) − d(θ) s(ω) − b ω

is linear in ``J/k0``, the Fourier coefficients of ``r``, ``c``, ``d`` and ``b``; the ``1`` in
front of ``i_q`` fixes the scale (only ratios are observable). Least squares on::

    i_q,f = (J/k0) θ̈_f − Σ r_h (i_q φ_h)_f − Σ c_h φ_h,f + Σ d_h (s φ_h)_f + b ω_f

**The filter** is :mod:`pgcomm.sensorless`'s idea: a short zero-phase Hann window ``g`` on the
second difference of the encoder angle, and the *same* window on every regressor.

**The kernel.** The second difference is exact: ``Δ²θ[j] = T_s²/J (∫₀¹ x T(t_{j−1} + x T_s) dx +
∫₀¹ (1 − x) T(t_j + x T_s) dx)``, the torque weighted by a triangle over the two sample intervals
around ``t_j``. A current held over a sample (ZOH) gives weights ``½, ½`` on ``i_q[j−1], i_q[j]``. A
torque that is a function of the angle (cogging, the ripple's ``r(θ) i_q``, the drag) is integrated
along the rotor's path: per interval, four-point Gauss–Legendre on the cubic through the four encoder
samples around it (:func:`_interval_weights`). This stays exact when a harmonic turns by a large
phase within a sample: at 3 samples per period of the highest cogging order, with the noise off, the
cogging comes out within 0.15 % of the truth on the zoo. (The earlier kernel took the torque as a
quadratic in time, ``[1/12, 5/6, 1/12]`` on the samples, which needs about 8 samples per period; the
speed of the running logs, and so the dither current they can carry, is bounded by this number.)

**Alias guard.** A window is used only where the highest modelled harmonic has at least
``MIN_SAMPLES_PER_PERIOD`` samples per period at the window's fastest speed (DESIGN: "refuse
windows whose cogging period is below a few samples, and say so"); the result reports how many
windows were refused and the speed limit. Windows near standstill (stiction, reversals) and
windows whose direction changes are left out too.

**Encoder quantisation.** The logged angle's rounding to the encoder's step is noise in the acceleration
*regressor*, which pulls ``J/k0`` towards zero and the maps with it (errors in variables; 13–56 % low at
constant speed with 16–17-bit encoders on the zoo). Where the logged angle sits on an encoder's lattice, the
step is read from it and the noise's known variance taken out of the normal equations
(:mod:`pgcomm.rotary.quantisation`, :func:`_quantisation_correction`).

**The current's timing.** The kernel takes ``i_q[j]`` as the current held over ``[t_j, t_{j+1}]``. A drive that
samples its current at another point of its cycle than the encoder, or a logger that writes the column a cycle
late, shifts it by whole samples, and one sample turns each harmonic by ``h ω T_s``: on the zoo, cogging 21-29 %
and ripple 66-294 % off, and one such fit still called its cogging resolved. The fit of the slot/pole basis is
repeated with the current shifted by :data:`CURRENT_DELAYS` samples and the delay whose residual is smallest is
taken when it fits clearly better than the log as written (:func:`_current_delay`); the results report it.

**The angle's estimate.** Open drives log the angle their PLL estimates from the encoder (ODrive's ``pos_estimate``,
a type-2 loop of 1000 rad/s by default), not the encoder's count: its acceleration is the rotor's through
``(k_p s + k_i)/(s² + k_p s + k_i)``, which at 1000 rad/s halves a cogging harmonic at 3 samples per period. Read
as the rotor's, such a log gave the cogging 8-12 % off, still called resolved, and the ripple 34-124 % (zoo 9N6P
and 12N14P). A raw encoder angle sits on the encoder's lattice; where no logged angle does, the basis fit is
repeated with the angle corrected for a PLL (:func:`pll_corrected`) of each natural frequency in
:data:`PLL_FREQUENCIES` and dampings :data:`PLL_DAMPINGS`, and the best is taken when it fits clearly better
than the angle as logged by a likelihood ratio (:func:`_angle_pll`); the results report it, and :data:`PLL_UNCERTAINTY` of the maps' move from the angle as logged counts against "resolved"
(``pll_bias``).

**Time-periodic disturbances.** A rig adds torque at fixed frequencies whatever the rotor's speed: a current
sensor's mains pickup (the current loop turns it into torque), a fan or a pump on the frame, a resonance the drive
keeps exciting. At one speed such a line is an order of the revolution; in logs at several speeds it spreads over
orders the basis does not have. A 50 Hz pickup of 1 % of the current limit put the cogging 10-21 % off and the ripple
119-240 % (zoo 9N6P and 12N14P). The residuals of the basis fit are searched for lines at one frequency in the logs of
two different speeds (:func:`_time_lines`); a line the logged current carries twice as strongly is its own (a
dither's), and one an order of the revolution explains as well is that order. Each line found is fitted beside
the maps, a cosine and a sine per log (a log's phase is its own), and the results report it.

**Regularisation.** A ridge on the Fourier coefficients (columns scaled to unit RMS; the
mechanical columns ``J/k0``, ``b`` and the Coulomb term are not penalised), its weight chosen
by validation on held-out **time blocks** (every ``VALIDATION_EVERY``-th block of about one
second of each log, never samples of the same stretch of trajectory), then refitted on all data;
the choice and the validation curve are reported.

**Orders the basis does not have.** The slot/pole combination sets the orders a healthy motor shows
(:mod:`pgcomm.rotary.model`); a real one adds others (a chipped magnet, a wound-in tolerance: the
standstill table, which has every order, would then beat a model that cannot hold them). So the
identification first fits *every* order up to the basis's highest, cogging and ripple, and keeps an
order outside the basis only when the data resolve it: ``δᵀ C⁻¹ δ`` (its cosine and sine over their
2×2 sandwich covariance) above ``2 ln(n/α)``, the χ²₂ quantile that lets a noise-only order in with
chance at most ``α`` = :data:`EXTRA_ORDER_ALPHA` over the ``n`` candidates of a map. The final fit
has the basis plus those orders (``info["orders_added"]``), so its variance stays that of a
structured model. The rows are built a chunk of windows at a time and reduced to normal equations
(training and validation blocks apart), so the screening's hundreds of orders cost tens of MB.

**With a torque sensor** (column ``torque``, N·m: the air-gap torque): ``T = k0 (1 + r) i_q +
T_cog(θ)`` sample by sample, no filter; gives ``k0`` (N·m/A), the ripple and the cogging in N·m
(returned in current units with ``k_t = k0``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from pgcomm.errors import DataError, ExcitationError
from pgcomm.rotary.model import Fourier, RotaryModel, cogging_orders, direction_orders, harmonic_columns, \
    ripple_orders
from pgcomm.rotary import quantisation
from pgcomm.rotary.motor import RotaryMotor

__all__ = ["identify", "fit_mechanics", "check_plausible", "resolution_verdict", "RESOLVED_SHARE",
           "RESOLVED_CONFIDENCE", "Orders", "MIN_SAMPLES_PER_PERIOD", "FILTER_TAPS", "max_speed",
           "RotaryIdentification", "delay_text", "pll_text", "pll_corrected", "detect_reading", "apply_reading",
           "CURRENT_DELAYS", "PLL_FREQUENCIES", "lines_text",
           "detect_time_lines"]

#: Fewest samples per period of the highest modelled harmonic for a window to be used. The kernel is
#: exact along the path (module docstring); below ~3 the cubic between encoder samples no longer follows a
#: cogging-driven speed ripple and the interpolation's error grows (0.3 % at 2.2 on the zoo, noise off).
MIN_SAMPLES_PER_PERIOD = 3.0
#: Hann window length (samples) of the acceleration filter; stride half of it.
FILTER_TAPS = 6
#: Windows slower than this share of the log's 95th-percentile speed anywhere are left out.
MIN_SPEED_SHARE = 0.1
#: Validation: every ``VALIDATION_EVERY``-th time block of ``BLOCK_SECONDS`` is held out.
VALIDATION_EVERY = 4
BLOCK_SECONDS = 1.0
#: Ridge weights tried (relative to the mean diagonal of the scaled normal matrix).
RIDGE_GRID = tuple(10.0 ** np.arange(-10, 0.5, 1.0))
#: Orders outside the slot/pole basis enter the model when their amplitude is significant at this
#: family-wise level (chance that a noise-only order gets in, per map).
EXTRA_ORDER_ALPHA = 0.01
#: Filter windows per block of rows built at once (memory: rows x columns x 8 bytes).
CHUNK_WINDOWS = 512
#: The encoder-noise correction of the acceleration (:func:`_quantisation_correction`) removes at most this
#: share of the acceleration's part that the maps and friction do not explain: beyond it the logs do not carry
#: the rotor's acceleration above the encoder's noise, and ``J/k0`` would be noise over almost nothing.
MAX_NOISE_SHARE = 0.75
#: Delays (samples) of the logged q-current behind the current that acted over each sample that
#: :func:`identify` tries (:func:`_current_delay`): drives sample the current and the encoder at different
#: points of their cycle, and loggers write a column a cycle late.
CURRENT_DELAYS = (-2, -1, 0, 1, 2)
#: How much better (``n_eff ln(cost_as_logged / cost)``, a likelihood ratio, :func:`_evidence`) another reading of
#: the logs (a shifted current, a PLL's angle) must fit than the logs as written to be taken: the χ²₁ quantile at
#: 0.1 %.
READING_EVIDENCE = 10.83
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
#: speed loop's complementary sensitivity), a share of ``1/|T|``: at least 0.5 for up to 6 dB of peaking (0.6-0.8
#: measured for a 50 Hz pickup on zoo 9N6P, 0.98 where the pickup is only in the log). Where the current carries a
#: line twice the fitted one it is its cause (the user's dither) and the residual the model's misfit of it
#: (0.008-0.22 measured at the running logs' dither frequencies, with the angle read through a PLL or not)
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
#: Natural frequencies (rad/s) of a drive's angle-estimating PLL tried when no logged angle sits on an encoder's
#: lattice (:func:`_angle_pll`): ODrive's encoder bandwidth defaults to 1000 rad/s.
PLL_FREQUENCIES = tuple(float(x) for x in np.geomspace(50.0, 5000.0, 13))
#: Dampings tried at the best natural frequency (1: ODrive's ``k_i = k_p² / 4``).
PLL_DAMPINGS = (1.0, 0.707)
#: The share of a PLL reading's move of the maps (from the angle as logged) taken as uncertain in the verdict: on the
#: sixteen motors of zoo seeds 0 and 1 through ODrive's discrete PLL, the reading left 10-40 % of the as-logged
#: cogging error (ODrive's loop differs from the continuous model by about ``k_p dt``).
PLL_UNCERTAINTY = 0.4
#: The share of the encoder-noise correction taken as uncertain in the verdict: on the twin, the noise the
#: acceleration actually carries (with the drive's loop reacting to it) was 0.83-1.44 times the white model's
#: (zoo seed 1, 12N14P and 18N16P, per constant-speed log).
QUANTISATION_UNCERTAINTY = 0.5


@dataclass(frozen=True)
class Orders:
    """Harmonics per revolution of the three maps (int arrays)."""

    cogging: np.ndarray
    ripple: np.ndarray
    direction: np.ndarray

    @classmethod
    def for_motor(cls, motor: RotaryMotor) -> "Orders":
        """The orders the slot/pole combination sets (:mod:`pgcomm.rotary.model`), and order 0 in the cogging
        map: a constant torque (a load, the current sensor's offset) that the law compensates with the cogging.
        Without it, an offset of 1 % of the current limit went into the ripple (153 % of its RMS off, zoo
        9N6P) and the cogging (0.7 → 6.2 %, still called resolved)."""
        return cls(np.union1d([0], cogging_orders(motor.slots, motor.pole_pairs)),
                   ripple_orders(motor.slots, motor.pole_pairs), direction_orders(motor.pole_pairs))

    @property
    def highest(self) -> int:
        return int(max(self.cogging.max(initial=0), self.ripple.max(initial=0), self.direction.max(initial=0)))


def max_speed(orders: Orders, sample_time: float, min_samples: float = MIN_SAMPLES_PER_PERIOD) -> float:
    """The fastest speed (rad/s) at which the alias guard keeps a window:
    ``2π / (T_s · min_samples · h_max)``."""
    return 2.0 * math.pi / (sample_time * min_samples * max(orders.highest, 1))


@dataclass
class RotaryIdentification:
    """Result of :func:`identify`: the model plus what was used and chosen.

    Attributes:
        model: :class:`RotaryModel` (current units).
        info: windows used/refused (alias guard, slow), ridge choice, validation curve, costs, seconds.
    """

    model: RotaryModel
    info: dict = field(default_factory=dict)


_ZOH = np.array([0.5, 0.5])
_TRI = np.array([1.0 / 12.0, 5.0 / 6.0, 1.0 / 12.0])
#: Gauss–Legendre nodes and weights on [0, 1] for the per-interval integrals (exact for degree 7; at three
#: samples per period of the highest order the phase turns 2.1 rad per interval: error ~1e-6 of a column).
_GL_NODES = 0.5 * (1.0 + np.polynomial.legendre.leggauss(4)[0])
_GL_WEIGHTS = 0.5 * np.polynomial.legendre.leggauss(4)[1]
#: ``(4, nodes)``: the cubic Lagrange weights of the samples at ``-1, 0, 1, 2`` (sample intervals) at each node.
_GL_LAGRANGE = np.array([[-x * (x - 1) * (x - 2) / 6, (x + 1) * (x - 1) * (x - 2) / 2,
                          -(x + 1) * x * (x - 2) / 2, (x + 1) * x * (x - 1) / 6] for x in _GL_NODES]).T


def _hann(n: int) -> np.ndarray:
    g = np.hanning(n + 2)[1:-1]
    return g / g.sum()


def _log_arrays(log, i: int, sample_time):
    """``(theta, iq, torque-or-None, T_s)`` of one log, checked."""
    name = log.get("name", f"log {i + 1}") if isinstance(log, dict) else f"log {i + 1}"
    cols = {}
    for key, alts in (("theta", ("theta",)), ("iq", ("iq_1", "iq"))):
        for a in alts:
            if a in log:
                cols[key] = np.asarray(log[a], float)
                break
        else:
            raise DataError(f"{name}: column '{alts[0]}' missing (rotary logs need t, theta, iq_1)")
    th, iq = cols["theta"], cols["iq"]
    if th.ndim != 1 or th.shape != iq.shape:
        raise DataError(f"{name}: theta and iq must be 1-D columns of equal length")
    for key, v in (("theta", th), ("iq_1", iq)):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise DataError(f"{name}: column '{key}' has a non-finite value at row {bad[0] + 1}")
    ts = sample_time
    if "t" in log:
        t = np.asarray(log["t"], float)
        d = np.diff(t)
        if d.size and (np.any(~np.isfinite(d)) or np.any(d <= 0)):
            raise DataError(f"{name}: column 't' must increase strictly")
        if d.size:
            ts_log = float(np.median(d))
            if np.max(np.abs(d - ts_log)) > 1e-3 * ts_log:
                raise DataError(f"{name}: column 't' is not uniformly sampled (steps {d.min():g} to {d.max():g} s)")
            ts = ts_log
    if ts is None:
        raise DataError(f"{name}: no 't' column and no sample time given")
    torque = np.asarray(log["torque"], float) if "torque" in log else None
    return name, th, iq, torque, float(ts)


def _filt(x, starts, taps):
    """``Σ_m taps_m x[s_j + m]`` for ``x`` ``(N,)`` or ``(N, k)``, one tap at a time (no ``(J, m, k)`` gather)."""
    st = np.asarray(starts)
    out = taps[0] * x[st]
    for m in range(1, taps.size):
        out = out + taps[m] * x[st + m]
    return out


@dataclass
class _Prepared:
    """One log's arrays and its usable windows (starts, samples)."""

    index: int
    theta: np.ndarray
    iq: np.ndarray
    sgn: np.ndarray
    w: np.ndarray
    starts: np.ndarray
    ts: float
    step: float | None = None
    acc_noise: float = 0.0


def _prepare(logs, motor: RotaryMotor, orders: Orders, min_samples: float, taps: int, encoder_step="detect"):
    """The usable windows of every log: the alias guard, and no window near standstill or reversing; and the
    encoder's quantisation noise in each log's acceleration (:mod:`pgcomm.rotary.quantisation`): ``encoder_step``
    ``"detect"`` reads the step from each logged angle, a number (rad) gives it, ``None`` leaves it out.

    Returns:
        ``(prepared, counts, v_limit, ts)``: a :class:`_Prepared` per log with windows, the window counts
        (``windows``, ``alias``, ``slow``), the alias guard's speed limit (rad/s), the median sample time (s).
    """
    span = taps + 2  # samples of θ one output needs: s .. s+T+1
    stride = max(1, taps // 2)
    counts = {"windows": 0, "alias": 0, "slow": 0}
    prepared, ts_all = [], []
    v_limit = None
    for i, log in enumerate(logs):
        name, th, iq, _, ts = _log_arrays(log, i, motor.sample_time)
        ts_all.append(ts)
        n = th.size
        if n < span + 2:
            continue
        w = np.empty(n)
        w[1:-1] = (th[2:] - th[:-2]) / (2 * ts)
        w[0], w[-1] = w[1], w[-2]
        speed = np.abs(w)
        v95 = float(np.percentile(speed, 95))
        v_limit = max_speed(orders, ts, min_samples)
        s_all = np.arange(0, n - span + 1, stride)
        idx = s_all[:, None] + np.arange(span)
        wmin = speed[idx].min(axis=1)
        wmax = speed[idx].max(axis=1)
        one_dir = np.all(np.sign(w[idx]) == np.sign(w[idx[:, :1]]), axis=1)
        slow = (wmin <= MIN_SPEED_SHARE * v95) | ~one_dir
        alias = ~slow & (wmax > v_limit)
        ok = ~slow & ~alias
        counts["windows"] += int(s_all.size)
        counts["slow"] += int(slow.sum())
        counts["alias"] += int(alias.sum())
        if np.any(ok):
            q = quantisation.encoder_step(th) if isinstance(encoder_step, str) else encoder_step
            noise = 0.0 if q is None else quantisation.acceleration_noise(quantisation.angle_noise(th, q), _hann(taps),
                                                                          ts)
            prepared.append(_Prepared(i, th, iq, np.sign(w), w, s_all[ok], ts, q, noise))
    if not prepared:
        lim = f"{v_limit:.3g} rad/s" if v_limit is not None else "?"
        raise ExcitationError(
            f"no usable window in {len(logs)} log(s): {counts['alias']} of {counts['windows']} windows too fast for "
            f"the encoder-sampled cogging (highest order {orders.highest} per revolution needs <= {lim} for "
            f"{min_samples:g} samples per period), {counts['slow']} near standstill or reversing")
    return prepared, counts, v_limit, float(np.median(ts_all))


def _extended(theta: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """``theta[lo − 1 : hi + 1]``, extended linearly past either end of the log (the interpolation's outer
    points)."""
    n = theta.size
    idx = np.arange(lo - 1, hi + 1)
    out = theta[np.clip(idx, 0, n - 1)].astype(float)
    if lo == 0:
        out[0] = 2.0 * theta[0] - theta[min(1, n - 1)]
    if hi >= n:
        out[-1] = 2.0 * theta[n - 1] - theta[max(n - 2, 0)]
    return out


def _path_angles(theta_ext: np.ndarray, n_int: int) -> np.ndarray:
    """The rotor's angle at the Gauss–Legendre nodes of each sample interval, on the cubic through the four
    encoder samples around it.

    Args:
        theta_ext: ``(n_int + 3,)`` angles (rad, multi-turn), ``theta_ext[k + 1]`` the sample at ``t_k``.

    Returns:
        ``(n_int, nodes)`` angles (rad).
    """
    pts = np.stack([theta_ext[j:j + n_int] for j in range(4)], axis=1)  # θ_{k-1}, θ_k, θ_{k+1}, θ_{k+2}
    return pts @ _GL_LAGRANGE


def _interval_weights(path: np.ndarray, orders):
    """The exact second-difference weights of a Fourier map over each sample interval (module docstring,
    "The kernel"): ``A_k = ∫₀¹ x φ(θ(t_k + x T_s)) dx`` and ``B_k = ∫₀¹ (1 − x) φ(θ(t_k + x T_s)) dx``,
    by Gauss–Legendre quadrature.

    Args:
        path: ``(n_int, nodes)`` angles at the nodes (:func:`_path_angles`).
        orders: ``(n,)`` harmonics per revolution.

    Returns:
        ``(A, B)``, each ``(n_int, 2n)`` (cosines, then sines).
    """
    ncol = 2 * np.asarray(orders).size
    A = np.zeros((path.shape[0], ncol))
    B = np.zeros((path.shape[0], ncol))
    for m, (x, w) in enumerate(zip(_GL_NODES, _GL_WEIGHTS)):
        phi = harmonic_columns(path[:, m], orders)
        A += (w * x) * phi
        B += (w * (1.0 - x)) * phi
    return A, B


def _chunks(prepared, orders: Orders, taps: int, chunk: int = CHUNK_WINDOWS, block_seconds: float = BLOCK_SECONDS,
            lines=()):
    """Filtered target and regressor blocks (module docstring), ``chunk`` windows at a time: the Fourier
    columns are built only over the samples a chunk needs, so a basis of hundreds of orders on minutes of
    1 kHz logs stays within a few tens of MB.

    Yields:
        dict of ``(J,)`` / ``(J, k)`` arrays: ``y``, ``acc``, ``rip``, ``cog``, ``dir``, ``visc``, ``sgn``,
        ``block`` (time block of ``block_seconds``, unique over the logs), ``acc_noise`` (the encoder's noise
        variance in ``acc``, (rad/s²)²), ``row`` (each window's first sample in its log), ``log`` (the log's
        position in ``prepared``) and, with ``lines``, ``line`` (``(J, 2 len(lines))``: a cosine and a sine of each time
        frequency of ``lines`` (Hz) over the log's own time, through the current's kernel and filter: a
        time-periodic disturbance, module docstring).
    """
    g = _hann(taps)
    g_zoh = np.convolve(g, _ZOH)  # (T+1,) on samples s .. s+T
    g_tri = np.convolve(g, _TRI)  # (T+2,) on samples s .. s+T+1
    span = taps + 2
    freqs = 2.0 * np.pi * np.asarray(lines, float)
    for pos, p in enumerate(prepared):
        for k in range(0, p.starts.size, chunk):
            st = p.starts[k:k + chunk]
            lo, hi = int(st[0]), int(st[-1]) + span
            loc = st - lo
            th, iq, sgn = p.theta[lo:hi], p.iq[lo:hi], p.sgn[lo:hi]
            d2 = th[2:] - 2 * th[1:-1] + th[:-2]  # d2[i-1] is Δ²θ at sample i
            # Δ²θ at sample j weighs interval j-1 (held iq[j-1]) rising and interval j (iq[j]) falling
            n_int = hi - lo - 1
            path = _path_angles(_extended(p.theta, lo, hi), n_int)
            a_r, b_r = _interval_weights(path, orders.ripple)
            a_c, b_c = _interval_weights(path, orders.cogging)
            a_d, b_d = _interval_weights(path, orders.direction)
            iq_i, sg_i = iq[:n_int, None], sgn[:n_int, None]
            out = {"row": st, "log": np.full(st.size, pos)}
            if lines:
                phase = np.arange(lo, hi)[:, None] * p.ts * freqs
                out["line"] = _filt(np.concatenate([np.cos(phase), np.sin(phase)], axis=1), loc, g_zoh)
            yield {**out, "y": _filt(iq, loc, g_zoh), "acc": _filt(d2, loc, g) / p.ts**2,
                   "rip": _filt(iq_i * a_r, loc, g) + _filt(iq_i * b_r, loc + 1, g),
                   "cog": _filt(a_c, loc, g) + _filt(b_c, loc + 1, g),
                   "dir": _filt(sg_i * a_d, loc, g) + _filt(sg_i * b_d, loc + 1, g),
                   "visc": _filt(p.w[lo:hi], loc, g_tri),
                   "sgn": sgn[loc + span // 2],
                   "block": np.floor(st * p.ts / block_seconds).astype(np.int64) + 100003 * p.index,
                   "acc_noise": np.full(st.size, p.acc_noise)}


def _design(logs, motor: RotaryMotor, orders: Orders, min_samples: float, taps: int, encoder_step="detect",
            current_delay: int = 0, angle_pll=None, lines=()):
    """All filtered rows of all logs at once (for the few columns of :func:`fit_mechanics`)."""
    prepared, counts, v_limit, ts = _prepare(logs, motor, orders, min_samples, taps, encoder_step)
    parts = list(_chunks(_with_delay(_with_pll(prepared, angle_pll), current_delay), orders, taps, lines=lines))
    return {k: np.concatenate([c[k] for c in parts]) for k in parts[0]}, counts, v_limit, ts


@dataclass
class _Layout:
    """Columns of the regression ``[J/k0, -ripple, -cogging, direction, lines, b]`` for one set of orders: which
    are kept (the sine of order 0 is zero, and a constant in ``r`` is the ``1`` that fixes the scale; a constant
    in ``c`` is a constant torque, :meth:`Orders.for_motor`) and penalised. ``lines`` are time frequencies (Hz) of
    a disturbance (module docstring, "Time-periodic disturbances"): a cosine and a sine per frequency and per log
    (``logs`` of them, each its own amplitude and phase), not penalised."""

    orders: Orders
    keep: np.ndarray
    pen: np.ndarray
    o_r: np.ndarray
    o_c: np.ndarray
    o_d: np.ndarray
    lines: tuple = ()
    logs: int = 0

    @classmethod
    def of(cls, orders: Orders, lines=(), logs: int = 0) -> "_Layout":
        nr, nc, nd = 2 * orders.ripple.size, 2 * orders.cogging.size, 2 * orders.direction.size
        lines = tuple(float(f) for f in lines)
        nt = 2 * len(lines) * logs
        n = 2 + nr + nc + nd + nt
        keep = np.ones(n, bool)
        pen = np.ones(n, bool)
        pen[0] = pen[-1] = False  # J/k0 and b are not penalised
        pen[1 + nr + nc + nd:n - 1] = False  # nor the disturbance's lines
        o_r = 1 + np.arange(nr)
        o_c = 1 + nr + np.arange(nc)
        o_d = 1 + nr + nc + np.arange(nd)
        for j in np.flatnonzero(orders.direction == 0):
            pen[o_d[j]] = False  # Coulomb friction: cos(0·θ)·s
            keep[o_d[orders.direction.size + j]] = False
        for j in np.flatnonzero(orders.ripple == 0):
            keep[o_r[j]] = keep[o_r[orders.ripple.size + j]] = False
        for j in np.flatnonzero(orders.cogging == 0):
            keep[o_c[orders.cogging.size + j]] = False
        return cls(orders, keep, pen, o_r, o_c, o_d, lines, int(logs) if lines else 0)

    @property
    def o_t(self) -> np.ndarray:
        """Columns of the lines: log ``k``'s cosines then sines at ``2 len(lines) k`` on."""
        start = 1 + 2 * (self.orders.ripple.size + self.orders.cogging.size + self.orders.direction.size)
        return start + np.arange(2 * len(self.lines) * self.logs)

    def rows(self, ch) -> np.ndarray:
        cols = [ch["acc"], -ch["rip"], -ch["cog"], ch["dir"]]
        if self.lines:
            cols.append(_line_columns(ch, self.logs))
        return np.column_stack(cols + [ch["visc"]])[:, self.keep]


def _line_columns(ch, logs: int) -> np.ndarray:
    """``(J, 2 F logs)``: each row's cosines and sines of the ``F`` lines (``ch["line"]``, :func:`_chunks`) in its own
    log's columns, zero in the others' (each log its own amplitude and phase)."""
    k = ch["line"].shape[1]
    t = np.zeros((ch["line"].shape[0], k * logs))
    t[np.arange(t.shape[0])[:, None], k * ch["log"][:, None] + np.arange(k)] = ch["line"]
    return t


def _is_validation(block) -> np.ndarray:
    return (block % VALIDATION_EVERY) == (VALIDATION_EVERY - 1)


def _normal_equations(prepared, layout: _Layout, taps: int, block_seconds: float = BLOCK_SECONDS):
    """Normal equations of the training and the validation rows: ``G (2, p, p)``, ``b (2, p)``,
    ``yy (2,)``, ``n (2,)``, and ``noise (2,)``, the encoder's noise in the acceleration summed over the rows
    (index 0 training, 1 validation)."""
    p = int(layout.keep.sum())
    G, b, yy, n, noise = np.zeros((2, p, p)), np.zeros((2, p)), np.zeros(2), np.zeros(2), np.zeros(2)
    for ch in _chunks(prepared, layout.orders, taps, block_seconds=block_seconds, lines=layout.lines):
        X, y = layout.rows(ch), ch["y"]
        val = _is_validation(ch["block"])
        for k, m in ((0, ~val), (1, val)):
            Xm, ym = X[m], y[m]
            G[k] += Xm.T @ Xm
            b[k] += Xm.T @ ym
            yy[k] += ym @ ym
            n[k] += ym.size
            noise[k] += float(ch["acc_noise"][m].sum())
    return G, b, yy, n, noise


def _quantisation_correction(G: np.ndarray, noise: np.ndarray):
    """Subtract the encoder's noise from the acceleration's diagonal (column 0) of the normal matrices
    (:mod:`pgcomm.rotary.quantisation`), at most :data:`MAX_NOISE_SHARE` of the acceleration's part that the
    other columns do not explain (its Schur complement ``1 / (G⁻¹)₀₀`` over training and validation rows).

    Args:
        G: ``(k, p, p)`` normal matrices (training, validation); noise: ``(k,)`` the noise variance summed
            over their rows.

    Returns:
        ``(G_corrected, factor, share)``: the share of the correction applied (1 unless capped), and the
        noise over the Schur complement.
    """
    total = float(np.sum(noise))
    if total <= 0.0:
        return G, 1.0, 0.0
    Gt = G.sum(axis=0)
    d = np.sqrt(np.diag(Gt))
    d[d == 0] = 1.0
    A = Gt / np.outer(d, d)
    # the grid's smallest ridge: where the other columns are collinear (one direction only) the ridge picks the fit
    A[np.diag_indices_from(A)] += RIDGE_GRID[0] * np.trace(A) / A.shape[0]
    unit = np.zeros(A.shape[0])
    unit[0] = 1.0
    schur = d[0] ** 2 / float(np.linalg.solve(A, unit)[0])
    share = total / schur
    factor = min(1.0, MAX_NOISE_SHARE / share)
    out = G.copy()
    out[:, 0, 0] -= factor * noise
    return out, float(factor), float(share)


def _ridge(G, b, n, penalty, lam_rel):
    """Ridge solution from normal equations, columns scaled to unit RMS first; the weight is ``lam_rel``
    times the mean diagonal of the scaled matrix. Returns ``(beta, A, scale)`` (``A`` the scaled, regularised
    normal matrix)."""
    scale = np.sqrt(np.diag(G) / max(n, 1.0))
    scale[scale == 0] = 1.0
    A = G / np.outer(scale, scale)
    lam = lam_rel * np.trace(A) / A.shape[0]
    A = A + np.diag(lam * penalty)
    bs = b / scale
    try:
        beta = np.linalg.solve(A, bs)
    except np.linalg.LinAlgError:
        beta = np.linalg.lstsq(A, bs, rcond=None)[0]
    return beta / scale, A, scale


def _validated_ridge(G, b, yy, n, pen) -> tuple[float, list]:
    """The ridge weight of :data:`RIDGE_GRID` with the smallest mean squared residual on the validation rows (index 1
    of the normal equations), fitted on the training rows (index 0); ``(weight, curve)``."""
    curve = []
    for lam in RIDGE_GRID:
        beta, _, _ = _ridge(G[0], b[0], n[0], pen, lam)
        curve.append(float((yy[1] - 2 * beta @ b[1] + beta @ G[1] @ beta) / max(n[1], 1.0)))
    return RIDGE_GRID[int(np.argmin(curve))], curve


def _fit(prepared, layout: _Layout, taps: int, ridge: float | None, block_seconds: float = BLOCK_SECONDS):
    """Ridge fit of one layout: the weight validated on held-out time blocks (or ``ridge``), the refit on all
    rows, and the estimate's covariance ``A⁻¹ (Σ_b X_bᵀ e_b e_bᵀ X_b) A⁻¹`` (``A`` the regularised normal
    matrix, ``e`` the residuals, ``b`` the one-second blocks): the sandwich that holds when the rows are
    correlated within a block (the overlapping filter windows) and the noise is not white (encoder
    quantisation, friction), as long as the blocks are roughly independent. The normal matrices are
    corrected for the encoder's noise in the acceleration (:func:`_quantisation_correction`), and the
    sandwich's block scores are those of the corrected estimating equation.

    Returns:
        dict: ``beta`` (kept columns, unscaled), ``cov``, ``ridge``, ``curve`` (validation MSE per grid
        weight, A²), ``cost`` (mean squared residual, A²), ``rows``, ``blocks``.
    """
    G, b, yy, n, noise = _normal_equations(prepared, layout, taps, block_seconds)
    G, factor, share = _quantisation_correction(G, noise)
    pen = layout.pen[layout.keep].astype(float)
    curve = []
    if ridge is None:
        lam, curve = _validated_ridge(G, b, yy, n, pen)
    else:
        lam = float(ridge)
    beta, A, scale = _ridge(G[0] + G[1], b[0] + b[1], n[0] + n[1], pen, lam)
    # what the correction leaves (the drive's loop reacting to the rounding; at a constant speed the rounding cycles
    # with the fraction of counts per sample and is not white): the fit's shift were the correction
    # QUANTISATION_UNCERTAINTY smaller (smaller keeps the matrix positive definite)
    shift = np.zeros_like(beta)
    if factor * float(np.sum(noise)) > 0.0:
        A2 = A.copy()
        A2[0, 0] += QUANTISATION_UNCERTAINTY * factor * float(np.sum(noise)) / scale[0] ** 2
        shift = np.linalg.solve(A2, (b[0] + b[1]) / scale) / scale - beta
    scores, sse = {}, 0.0
    for ch in _chunks(prepared, layout.orders, taps, block_seconds=block_seconds, lines=layout.lines):
        X = layout.rows(ch)
        e = ch["y"] - X @ beta
        sse += float(e @ e)
        lab, inv = np.unique(ch["block"], return_inverse=True)
        part = np.zeros((lab.size, X.shape[1]))
        np.add.at(part, inv, (X / scale) * e[:, None])
        # the corrected estimating equation X'(y - Xβ) + n W β₀ = 0, block by block
        np.add.at(part[:, 0], inv, factor * ch["acc_noise"] * beta[0] / scale[0])
        for j, c in enumerate(lab):
            scores[c] = scores[c] + part[j] if c in scores else part[j]
    S = np.array(list(scores.values()))
    a_inv = np.linalg.pinv(A)
    cov = (a_inv @ (S.T @ S) @ a_inv) / np.outer(scale, scale)
    rows = float(n[0] + n[1])
    # per-block influence on the estimate, A⁻¹ s_b (unscaled): the screening's effective number of blocks
    influence = (S @ a_inv) / scale
    # the ridge's pull towards zero: E[β̂] = A⁻¹ N β (N the unregularised scaled normal matrix), so the bias is
    # (A⁻¹ N − I) β, estimated at β̂ (an underestimate by the same shrinkage; unscaled like beta)
    bs = beta * scale
    bias = (a_inv @ ((G[0] + G[1]) / np.outer(scale, scale) @ bs) - bs) / scale
    return {"beta": beta, "cov": cov, "ridge": float(lam), "curve": curve, "cost": sse / rows, "rows": int(rows),
            "blocks": len(scores), "influence": influence, "bias": bias, "noise_share": share,
            "noise_factor": factor, "quantisation_shift": shift}


def _full(structured: np.ndarray) -> np.ndarray:
    """Every order from 1 to the basis's highest, and the basis's own (order 0 where it has it)."""
    top = int(np.max(structured, initial=0))
    return np.union1d(np.asarray(structured, int), np.arange(1, top + 1))


def _significant_extra_orders(fit: dict, layout: _Layout, structured: Orders, alpha: float) -> dict:
    """Orders outside the slot/pole basis whose amplitude the data resolve: ``T² = δᵀ C⁻¹ δ`` (``δ`` the
    order's cosine and sine, ``C`` their 2×2 sandwich covariance) above the ``1 − α/n`` quantile of its
    null distribution (``n`` the candidate orders of the map: at most ``α`` chance over the map that a
    noise-only order gets in). ``C`` is estimated from ``B`` time blocks, so ``T²`` follows Hotelling's
    ``2(B−1)/(B−2) F(2, B−2)``, not χ²₂: with the 8 blocks of a short log the χ²₂ quantile let in about
    five noise orders per map; the F quantile lets in none, and tends to χ²₂ (``2 ln(n/α)``) for long logs.

    Returns:
        ``{"cogging": int array, "ripple": int array, "threshold": {...}, "blind_rms": {map: (n,) array},
        "statistic": {map: (orders, T², threshold) arrays}}``: the orders added per map, per candidate order
        the RMS over θ of the largest amplitude it could have without passing, at the many-block threshold
        ``2 ln(n/α)`` (the map's units), and each candidate's ``T²`` with the threshold it had to pass.
    """
    beta = np.zeros(layout.keep.size)
    beta[layout.keep] = fit["beta"]
    cov = np.zeros((layout.keep.size, layout.keep.size))
    cov[np.ix_(layout.keep, layout.keep)] = fit["cov"]
    from scipy.stats import f as f_dist

    infl = np.zeros((fit["influence"].shape[0], layout.keep.size))
    infl[:, layout.keep] = fit["influence"]
    out = {"threshold": {}}
    for name, cols, full, basis in (("cogging", layout.o_c, layout.orders.cogging, structured.cogging),
                                    ("ripple", layout.o_r, layout.orders.ripple, structured.ripple)):
        cand = np.flatnonzero(~np.isin(full, basis) & (full > 0))
        chosen, q, blind, stat = [], alpha / max(cand.size, 1), [], []
        for j in cand:
            ij = [cols[j], cols[full.size + j]]
            d = beta[ij]
            c_inv = np.linalg.pinv(cov[np.ix_(ij, ij)])
            z2 = float(d @ c_inv @ d)
            u = infl[:, ij]
            share = np.einsum("bi,ij,bj->b", u, c_inv, u)  # each block's part of the variance (sums to 2)
            b_eff = float(np.sum(share) ** 2 / max(np.sum(share**2), 1e-300))
            thr = 2.0 * (b_eff - 1) / (b_eff - 2) * float(f_dist.isf(q, 2, b_eff - 2)) if b_eff > 3 else np.inf
            stat.append((int(full[j]), z2, thr))
            if z2 > thr:
                chosen.append(int(full[j]))
            # the RMS over θ (|δ|/√2) of the largest order this candidate could have and still not pass (δ on the
            # 2x2 covariance's long axis), at the many-block threshold 2 ln(n/α): so that it falls as the noise
            # does, as the square root of the log time (the F quantile of a few blocks would add a penalty for a
            # short log's uncertain covariance that more of the same log removes faster than that)
            blind.append(math.sqrt(2.0 * math.log(1.0 / q) * max(float(np.linalg.eigvalsh(cov[np.ix_(ij, ij)])[-1]),
                                                                  0.0) / 2.0))
        out["threshold"][name] = {"alpha": alpha, "candidates": int(cand.size)}
        out.setdefault("blind_rms", {})[name] = np.asarray(blind)
        st = np.array(stat, float).reshape(-1, 3)
        out.setdefault("statistic", {})[name] = (st[:, 0].astype(int), st[:, 1], st[:, 2])
        out[name] = np.array(chosen, int)
    return out


def _map_gram(map_orders) -> np.ndarray:
    """``M = mean_θ φ(θ) φ(θ)ᵀ``, the Gram matrix of a Fourier map's columns over the revolution (½ for a
    cosine or sine, 1 for the constant): the mean square over θ of the map ``φ(θ)ᵀ δ`` is ``δᵀ M δ``."""
    h = int(max(np.max(map_orders, initial=0), 1))
    th = 2 * math.pi * np.arange(4 * h + 4) / (4 * h + 4)  # exact for products of orders up to h
    phi = harmonic_columns(th, map_orders)
    return phi.T @ phi / th.size


def _map_error_quantile(cov_block, gram, level: float) -> float:
    """The ``level`` quantile of a Fourier map's RMS error over the revolution, for an error ``δ ~ N(0, Cov)``.

    The mean square ``δᵀ M δ`` (``gram`` = ``M``, :func:`_map_gram`) is a weighted sum of χ²₁ variables with weights ``λ``, the
    eigenvalues of ``Lᵀ Cov L`` (``M = L Lᵀ``); Satterthwaite's approximation takes it as ``(Σλ) χ²_ν / ν`` with
    ``ν = (Σλ)² / Σλ²`` degrees of freedom (exact when the weights are equal). Returns the RMS error (the map's
    units) that the noise part stays below with probability ``level``.
    """
    from scipy.stats import chi2

    d, v = np.linalg.eigh(gram)
    L = v * np.sqrt(np.clip(d, 0.0, None))  # M = L Lᵀ; M is singular where a column is zero (the sine of order 0)
    lam = np.clip(np.linalg.eigvalsh(L.T @ cov_block @ L), 0.0, None)
    total = float(np.sum(lam))
    if total <= 0.0:
        return 0.0
    nu = total**2 / float(np.sum(lam**2))
    return float(np.sqrt(total * chi2.ppf(level, nu) / nu))


def _map_standard_error(cov_block, gram) -> float:
    """Expected RMS over the revolution of a Fourier map's estimation error: ``sqrt(tr(Cov M))``
    (``gram`` = ``M``, :func:`_map_gram`) for an error ``δ`` of covariance ``Cov``."""
    return float(np.sqrt(max(float(np.sum(cov_block * gram)), 0.0)))


def _shifted(x: np.ndarray, delay: int) -> np.ndarray:
    """``x[j + delay]`` (the edges repeat the first or last sample): the current that acted over sample ``j`` when
    the log writes it ``delay`` samples late."""
    d = int(delay)
    if d == 0 or x.size == 0:
        return x
    out = np.empty_like(x)
    if d > 0:
        out[:-d] = x[d:]
        out[-d:] = x[-1]
    else:
        out[-d:] = x[:d]
        out[:-d] = x[0]
    return out


def _with_delay(prepared, delay: int) -> list:
    return [replace(p, iq=_shifted(p.iq, delay)) for p in prepared]


def _basis_fit(prepared, layout: "_Layout", taps: int) -> tuple[np.ndarray, float, float]:
    """The ridge-validated fit of ``layout`` (encoder-noise corrected): its coefficients (kept columns), mean squared
    residual (A², from the normal equations) and the rows, ``(beta, cost, rows)``."""
    G, b, yy, n, noise = _normal_equations(prepared, layout, taps)
    G, _, _ = _quantisation_correction(G, noise)
    pen = layout.pen[layout.keep].astype(float)
    beta, _, _ = _ridge(G[0] + G[1], b[0] + b[1], n[0] + n[1], pen, _validated_ridge(G, b, yy, n, pen)[0])
    gt, bt, yt = G[0] + G[1], b[0] + b[1], yy[0] + yy[1]
    rows = float(n[0] + n[1])
    return beta, max(float(yt - 2 * beta @ bt + beta @ gt @ beta), 1e-300) / max(rows, 1.0), rows


def _basis_cost(prepared, layout: "_Layout", taps: int) -> tuple[float, float]:
    """:func:`_basis_fit`'s ``(cost, rows)``."""
    return _basis_fit(prepared, layout, taps)[1:]


def _evidence(cost_plain: float, cost_best: float, rows: float, taps: int) -> float:
    """``n_eff ln(cost_plain / cost_best)``, ``n_eff`` the rows times ``stride / span`` (the filter windows overlap):
    the likelihood ratio of a better-fitting reading of the logs over the logs as written."""
    n_eff = rows * max(1, taps // 2) / (taps + 2)
    return n_eff * math.log(cost_plain / cost_best) if cost_plain > 0 else 0.0


def _current_delay(prepared, layout: "_Layout", taps: int) -> dict:
    """The delay (samples) of the logged q-current behind the current that acted (module docstring, "The current's
    timing"): the ridge-validated fit of ``layout`` with the current shifted by each of :data:`CURRENT_DELAYS`,
    its mean squared residual from the normal equations; a delay other than 0 only where its likelihood ratio
    (:func:`_evidence`) exceeds :data:`READING_EVIDENCE`.

    Returns:
        ``{"samples": int, "cost_by_delay": {delay: A²}, "evidence": float}``.
    """
    costs, rows = {}, 0.0
    for d in CURRENT_DELAYS:
        costs[d], rows = _basis_cost(_with_delay(prepared, d), layout, taps)
    best = min(costs, key=costs.get)
    evidence = _evidence(costs[0], costs[best], rows, taps)
    chosen = best if evidence > READING_EVIDENCE else 0
    return {"samples": int(chosen), "cost_by_delay": {int(k): v for k, v in costs.items()}, "evidence": float(evidence)}


def pll_corrected(theta: np.ndarray, sample_time: float, natural_frequency: float, damping: float) -> np.ndarray:
    """The rotor's angle from a drive's estimate of it: the output of a type-2 phase-locked loop,
    ``θ̂ = (k_p s + k_i) / (s² + k_p s + k_i) θ`` with ``k_p = 2 ζ ω_n``, ``k_i = ω_n²`` (ODrive's encoder PLL:
    ``ζ = 1``, ``ω_n`` its bandwidth). Solved for ``θ``: ``θ = θ̂ + s² / (k_p s + k_i) θ̂``, applied in the
    frequency domain up to the log's Nyquist frequency (a second difference and a bilinear low-pass at the log's
    rate would take 0.4x of the correction at 3 samples per period, where the cogging's highest order sits): to
    ``θ̂`` less the line through its ends, extended oddly (continuous with its slope, so only a few samples at each
    end feel the extension).

    Args:
        theta: ``(N,)`` the logged estimate (rad); sample_time: s; natural_frequency: ``ω_n`` (rad/s);
        damping: ``ζ``.

    Returns:
        ``(N,)`` rad.
    """
    th = np.asarray(theta, float)
    n = th.size
    if n < 3:
        return th.copy()
    kp, ki = 2.0 * damping * natural_frequency, natural_frequency**2
    x = th - np.linspace(th[0], th[-1], n)
    ext = np.concatenate([x, -x[-2:0:-1]])
    s = 2j * np.pi * np.fft.rfftfreq(ext.size, float(sample_time))
    # the line's correction is zero: s² kills it
    return th + np.fft.irfft(np.fft.rfft(ext) * (s * s / (kp * s + ki)), ext.size)[:n]


def _with_pll(prepared, pll) -> list:
    if pll is None:
        return prepared
    return [replace(p, theta=pll_corrected(p.theta, p.ts, *pll)) for p in prepared]


def _angle_pll(prepared, layout: "_Layout", taps: int) -> dict:
    """Whether the logged angle reads as a drive's PLL estimate (module docstring, "The angle's estimate"): the
    basis fit with the angle corrected for each natural frequency of :data:`PLL_FREQUENCIES` at ``ζ = 1``, then
    each :data:`PLL_DAMPINGS` at the best frequency and its neighbours, against the angle as logged; a PLL only
    where its likelihood ratio (:func:`_evidence`) exceeds :data:`READING_EVIDENCE`.

    Returns:
        ``{"natural_frequency_rad_s": float | None, "damping": float | None, "cost_as_logged": A², "cost": A²,
        "evidence": float, "cost_by_frequency": {"ω_n": A²}}`` (``None``: read as logged; the frequencies as
        strings of 4 digits, the results' keys).
    """
    plain, rows = _basis_cost(prepared, layout, taps)
    grid = np.asarray(PLL_FREQUENCIES, float)
    costs = np.array([_basis_cost(_with_pll(prepared, (w, 1.0)), layout, taps)[0] for w in grid])
    by_freq = {f"{w:.4g}": float(c) for w, c in zip(grid, costs)}  # results keys are strings
    j = int(np.argmin(costs))
    best, best_cost = (float(grid[j]), 1.0), float(costs[j])
    if 0 < j < grid.size - 1:
        # the grid is 1.47x per step: the minimum of a parabola in ln ω_n through the best point and its neighbours
        x, y = np.log(grid[j - 1:j + 2]), np.log(costs[j - 1:j + 2])
        den = y[0] - 2 * y[1] + y[2]
        if den > 0:
            w = float(np.exp(x[1] + 0.5 * (y[0] - y[2]) / den * (x[1] - x[0])))
            c = _basis_cost(_with_pll(prepared, (w, 1.0)), layout, taps)[0]
            by_freq[f"{w:.4g}"] = c
            if c < best_cost:
                best, best_cost = (w, 1.0), c
    for z in PLL_DAMPINGS:
        if z == 1.0:
            continue
        for w in grid[max(0, j - 1):j + 2]:
            c = _basis_cost(_with_pll(prepared, (float(w), z)), layout, taps)[0]
            if c < best_cost:
                best, best_cost = (float(w), float(z)), c
    evidence = _evidence(plain, best_cost, rows, taps)
    # no gate on the residual's drop: ODrive's PLL lowered it only 1.16x on zoo 12N10P and 1.31x on seed 1's
    # 36N42P, as much as an angle with noise of its own lowers it by a fast PLL (1.16-1.26x, 1.6-2.3 kHz: a 15-bit
    # angle with 0.2-0.5 counts of noise); a gate at 1.5 left those two cogging maps 6-8 % off and called resolved,
    # where a false reading's move is counted in the verdict (pll_bias)
    taken = evidence > READING_EVIDENCE
    return {"natural_frequency_rad_s": best[0] if taken else None, "damping": best[1] if taken else None,
            "cost_as_logged": plain, "cost": best_cost if taken else plain, "evidence": float(evidence),
            "cost_by_frequency": by_freq}


def _residuals(prepared, layout: "_Layout", taps: int, beta: np.ndarray) -> list:
    """Per log, ``(rows, e)``: each used window's first sample and the fit's residual there (A)."""
    out = [([], []) for _ in prepared]
    for ch in _chunks(prepared, layout.orders, taps, lines=layout.lines):
        out[ch["log"][0]][0].append(ch["row"])
        out[ch["log"][0]][1].append(ch["y"] - layout.rows(ch) @ beta)
    return [(np.concatenate(r), np.concatenate(e)) for r, e in out]


def _current_lines(prepared, hz: float, taps: int) -> np.ndarray:
    """``(L,)`` per log, the amplitude (A) of the logged current's line at ``hz``: its filtered current fitted on a
    cosine and a sine through the same kernel and filter as a disturbance's line (:func:`_chunks`), jointly with the
    current's other strong lines within the noise floor's window of ``hz``.

    Those are taken one at a time, the strongest first, from the sum over the logs of the periodograms of what the
    lines so far leave of the current (:func:`_line_spectrum`), while it exceeds the ``1 − α/M`` quantile of noise
    alone; at most :data:`MAX_CURRENT_NEIGHBOURS`, none within :data:`CURRENT_NEIGHBOUR_BINS` natural bins (of the
    shortest log) of a line already taken. Fitted alone, the cosine and sine at ``hz`` take in part of a dither line
    a few bins off: on zoo seed 0 that read the current's line at 100 Hz (a pickup's harmonic, 7 Hz from the running
    logs' 107 Hz dither) up to twice as large and refused the line; jointly, its share rose from under 0.5 to 0.84.
    A dither one natural bin off is not separated (9N6P's 60 Hz beside 61 Hz in 1 s logs, module docstring).
    """
    from scipy.stats import gamma

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
        new = float(f[j])
        if 0 < j < f.size - 1 and min(total[j - 1], total[j + 1]) > 0:
            y0, y1, y2 = np.log(total[j - 1:j + 2])
            if y0 - 2 * y1 + y2 < 0:
                new += 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2) * (f[1] - f[0])
        freqs.append(new)
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
    from scipy.ndimage import median_filter

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
    from scipy.stats import chi2, gamma

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
        # sweep's long log beside 34 s of constant speeds: 166.3 Hz of 166.7 taken as a line, read as two orders, and
        # identify 2.2x slower)
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
        hz = float(f[j])
        if 0 < j < f.size - 1 and total[j - 1] > 0 and total[j + 1] > 0:
            y0, y1, y2 = np.log(total[j - 1:j + 2])
            den = y0 - 2 * y1 + y2
            if den < 0:
                hz = float(hz + 0.5 * (y0 - y2) / den * (f[1] - f[0]))
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
            from scipy.optimize import minimize_scalar

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


def _reading(prepared, orders: Orders, taps: int, encoder_step, current_delay, angle_pll) -> tuple[dict, dict]:
    """How to read the logs: the angle (a drive's PLL estimate or the rotor's, :func:`_angle_pll`) and the current's
    delay (:func:`_current_delay`), each detected or as given. Each masks the other (a current a sample late hid
    ODrive's PLL: the PLL's reading fitted worse than the angle as logged), so where both are detected and the delay
    is not 0 the angle is read again with the delay taken out, and the delay again with that reading.

    Returns:
        ``(angle_pll, current_delay)``: the results' entries.
    """
    layout = _Layout.of(orders)
    search_pll = False
    if isinstance(angle_pll, str):
        # a raw encoder angle sits on its lattice (read here even when the correction is turned off: the
        # rounding's noise in the acceleration, uncorrected, reads as a PLL's high-frequency gain)
        steps = [p.step if isinstance(encoder_step, str) else quantisation.encoder_step(p.theta) for p in prepared]
        search_pll = all(q is None for q in steps)
        pll = None
    else:
        pll = None if angle_pll is None else (float(angle_pll[0]), float(angle_pll[1]))
    estimate = {"natural_frequency_rad_s": None if pll is None else pll[0], "damping": None if pll is None else pll[1],
                "searched": False}
    timing = {"samples": 0 if isinstance(current_delay, str) else int(current_delay), "cost_by_delay": None,
              "evidence": None}

    def read_angle():
        found = {**_angle_pll(_with_delay(prepared, timing["samples"]), layout, taps), "searched": True}
        w = found["natural_frequency_rad_s"]
        return found, (None if w is None else (w, found["damping"]))

    if search_pll:
        estimate, pll = read_angle()
    for _ in range(2):
        if isinstance(current_delay, str):
            timing = _current_delay(_with_pll(prepared, pll), layout, taps)
        if not (search_pll and timing["samples"] != 0):
            break
        before = pll
        estimate, pll = read_angle()
        if pll == before:
            break
    timing["detected"] = isinstance(current_delay, str)
    return estimate, timing


def detect_reading(logs, motor: RotaryMotor, orders: Orders | None = None, *, current_delay="detect",
                   angle_pll="detect", encoder_step="detect", min_samples_per_period: float = MIN_SAMPLES_PER_PERIOD,
                   taps: int = FILTER_TAPS) -> tuple[dict, dict]:
    """How :func:`identify` would read ``logs`` (the angle's PLL and the current's delay, module docstring), without
    the identification: e.g. to read the logs before counting the slots from them (a late current or a PLL's angle
    hides the cogging's orders).

    Returns:
        ``(angle_pll, current_delay)``: the entries :func:`identify` reports in its ``info``.
    """
    orders = orders or Orders.for_motor(motor)
    prepared, _, _, _ = _prepare(logs, motor, orders, min_samples_per_period, taps, encoder_step)
    return _reading(prepared, orders, taps, encoder_step, current_delay, angle_pll)


def detect_time_lines(logs, motor: RotaryMotor, orders: Orders | None = None, *,
                      min_samples_per_period: float = MIN_SAMPLES_PER_PERIOD, taps: int = FILTER_TAPS) -> dict:
    """The time-periodic disturbances :func:`identify` would fit beside the maps of ``logs`` (read as they are: apply
    :func:`apply_reading` first), without the identification: e.g. to count the slots with them fitted (a pickup at
    two speeds spreads over orders the basis does not have).

    Returns:
        the entry :func:`identify` reports as ``info["time_lines"]`` (without the amplitudes).
    """
    orders = orders or Orders.for_motor(motor)
    prepared, _, _, _ = _prepare(logs, motor, orders, min_samples_per_period, taps)
    return _time_lines(prepared, orders, taps)


def apply_reading(log: dict, current_delay: int, angle_pll, sample_time: float) -> dict:
    """``log`` (a dict with ``theta`` and ``iq_1``) as :func:`identify` reads it: the current shifted by
    ``current_delay`` samples (edges repeated), the angle corrected for ``angle_pll`` (``(ω_n, ζ)`` or ``None``,
    :func:`pll_corrected`; ``sample_time`` in s where the log has no ``t``). A new dict; the other columns as they
    are."""
    out = dict(log)
    key = "iq_1" if "iq_1" in log else "iq"
    out[key] = _shifted(np.asarray(log[key], float), int(current_delay))
    if angle_pll is not None:
        t = np.asarray(log["t"], float) if "t" in log else None
        ts = float(np.median(np.diff(t))) if t is not None and t.size > 1 else float(sample_time)
        out["theta"] = pll_corrected(np.asarray(log["theta"], float), ts, *angle_pll)
    return out


def identify(logs, motor: RotaryMotor, orders: Orders | None = None, *, torque_sensor: bool = False,
             min_samples_per_period: float = MIN_SAMPLES_PER_PERIOD, taps: int = FILTER_TAPS,
             ridge: float | None = None, extra_orders: bool = True, encoder_step="detect",
             current_delay="detect", angle_pll="detect", time_lines="detect") -> RotaryIdentification:
    """Identify cogging, torque-constant ripple, the direction-dependent torque and friction.

    Args:
        logs: sequence of dict-like logs with columns ``t`` (s), ``theta`` (rad, multi-turn),
            ``iq_1`` (or ``iq``, A), and ``torque`` (N·m) for ``torque_sensor``; each ``(N_i,)``.
        motor: :class:`RotaryMotor` (pole pairs and slots set the orders; ``sample_time`` is used
            when a log has no ``t``).
        orders: harmonics of the maps (default :meth:`Orders.for_motor`).
        torque_sensor: identify from the ``torque`` column instead of the motion.
        min_samples_per_period: the alias guard (module docstring).
        taps: Hann window length (samples).
        ridge: fixed relative ridge weight instead of the validated choice.
        extra_orders: let the data add cogging and ripple orders outside ``orders`` (module docstring,
            "Orders the basis does not have").
        encoder_step: the encoder's step (rad) for the quantisation correction of the acceleration
            (:mod:`pgcomm.rotary.quantisation`); ``"detect"`` reads it from each log's angle, ``None`` turns
            the correction off.
        current_delay: samples by which the logged q-current lags the current that acted over each sample (an
            int), or ``"detect"`` (module docstring, "The current's timing").
        angle_pll: ``(ω_n rad/s, ζ)`` of the PLL whose estimate the logged angle is, ``None`` for the encoder's own
            angle, or ``"detect"``: tried when no logged angle sits on an encoder's lattice (module docstring, "The
            angle's estimate").
        time_lines: frequencies (Hz) of time-periodic disturbances to fit beside the maps (a cosine and a sine per
            log each), ``()`` for none, or ``"detect"`` (module docstring, "Time-periodic disturbances").

    Returns:
        :class:`RotaryIdentification`; ``model.k_t`` is ``k0`` with a torque sensor, else the
        motor's ``k_t`` (or ``None``).

    Raises:
        DataError: missing/non-finite columns, non-uniform ``t``.
        ExcitationError: no usable window (all too fast for the alias guard or at standstill).
    """
    t0 = time.perf_counter()
    orders = orders or Orders.for_motor(motor)
    if torque_sensor:
        return check_plausible(_identify_torque(logs, motor, orders, t0))
    prepared, counts, v_limit, ts = _prepare(logs, motor, orders, min_samples_per_period, taps, encoder_step)
    n_windows = sum(p.starts.size for p in prepared)
    estimate, timing = _reading(prepared, orders, taps, encoder_step, current_delay, angle_pll)
    pll = None if estimate["natural_frequency_rad_s"] is None else (estimate["natural_frequency_rad_s"],
                                                                     estimate["damping"])
    as_logged = _with_delay(prepared, timing["samples"])
    prepared = _with_delay(_with_pll(prepared, pll), timing["samples"])
    if isinstance(time_lines, str):
        lines_info = _time_lines(prepared, orders, taps)
    else:
        lines_info = {"hz": [float(f) for f in time_lines or ()], "searched": False}
    lines = tuple(lines_info["hz"])
    added = {"cogging": np.zeros(0, int), "ripple": np.zeros(0, int)}
    screen = None
    if extra_orders:
        full = Orders(_full(orders.cogging), _full(orders.ripple), orders.direction)
        n_extra = full.cogging.size + full.ripple.size - orders.cogging.size - orders.ripple.size
        lay_full = _Layout.of(full, lines, len(prepared))
        if n_extra and n_windows >= 2 * int(lay_full.keep.sum()):
            screen = _significant_extra_orders(_fit(prepared, lay_full, taps, ridge), lay_full, orders,
                                               EXTRA_ORDER_ALPHA)
            added = {k: screen[k] for k in ("cogging", "ripple")}
    final = Orders(np.union1d(orders.cogging, added["cogging"]), np.union1d(orders.ripple, added["ripple"]),
                   orders.direction)
    layout = _Layout.of(final, lines, len(prepared))
    n_unknowns = int(layout.keep.sum())
    if n_windows < 2 * n_unknowns:
        raise ExcitationError(f"{n_windows} usable windows for {n_unknowns} unknowns: record longer running logs "
                              f"(speeds up to {v_limit:.3g} rad/s, both directions)")
    fit = _fit(prepared, layout, taps, ridge)
    beta = np.zeros(layout.keep.size)
    beta[layout.keep] = fit["beta"]
    cov = np.zeros((layout.keep.size, layout.keep.size))
    cov[np.ix_(layout.keep, layout.keep)] = fit["cov"]
    bias = np.zeros(layout.keep.size)
    bias[layout.keep] = fit["bias"]
    shift = np.zeros(layout.keep.size)
    shift[layout.keep] = fit["quantisation_shift"]
    reading = np.zeros(layout.keep.size)
    if pll is not None:
        # what a PLL's reading may leave: a share of the maps' move from the angle as logged (module docstring)
        reading[layout.keep] = PLL_UNCERTAINTY * (_fit(as_logged, layout, taps, fit["ridge"])["beta"] - fit["beta"])
    o_r, o_c, o_d = layout.o_r, layout.o_c, layout.o_d
    if lines:
        # per log a cosine and a sine of each line (A): the amplitude of each line in each log
        cs = beta[layout.o_t].reshape(len(prepared), 2, len(lines))
        lines_info["amplitude_A"] = [float(a) for a in np.median(np.hypot(cs[:, 0], cs[:, 1]), axis=0)]
    model = RotaryModel(
        motor.pole_pairs,
        cogging=Fourier.from_vector(final.cogging, beta[o_c]),
        ripple=Fourier.from_vector(final.ripple, beta[o_r]),
        direction=Fourier.from_vector(final.direction, beta[o_d]),
        viscous=float(beta[-1]), inertia_ratio=float(beta[0]), k_t=motor.k_t,
        info={"method": "running logs, no torque sensor"})
    blind = None
    if screen is not None:
        blind = {k: float(np.median(v)) for k, v in screen["blind_rms"].items() if np.size(v)}
    standard_error = _standard_errors(model, cov, bias, o_r, o_c, o_d, final, fit["blocks"], blind, shift, reading)
    info = {"windows": counts["windows"], "windows_used": int(n_windows), "windows_refused_alias": counts["alias"],
            "windows_refused_slow": counts["slow"], "speed_limit_rad_s": v_limit,
            "min_samples_per_period": float(min_samples_per_period), "highest_order": orders.highest,
            "filter_taps": int(taps), "unknowns": n_unknowns, "ridge": fit["ridge"],
            "ridge_chosen_by": "validation on held-out time blocks" if ridge is None else "given",
            "validation_curve": {f"{l:.0e}": c for l, c in zip(RIDGE_GRID, fit["curve"])},
            "orders_added": {k: v.tolist() for k, v in added.items()},
            "orders_screened": screen is not None,
            "cost_A2": fit["cost"], "inertia_ratio": float(beta[0]), "standard_error": standard_error,
            "quantisation": _quantisation_info(prepared, fit), "current_delay": timing, "angle_pll": estimate,
            "time_lines": lines_info,
            "seconds": time.perf_counter() - t0}
    if counts["alias"]:
        info["note"] = (f"{counts['alias']} of {counts['windows']} windows refused: faster than "
                        f"{v_limit:.3g} rad/s, where order {orders.highest} has fewer than "
                        f"{min_samples_per_period:g} samples per period")
    return check_plausible(RotaryIdentification(model, info))


def _quantisation_info(prepared, fit: dict) -> dict:
    """What the results say about the encoder's quantisation correction."""
    steps = [p.step for p in prepared if p.step is not None]
    return {"encoder_step_rad": float(np.median(steps)) if steps else None,
            "counts_per_revolution": sorted({round(2 * math.pi / q) for q in steps}),
            "logs_on_lattice": sum(p.step is not None for p in prepared), "logs": len(prepared),
            "noise_share": fit["noise_share"], "correction_capped": fit["noise_factor"] < 1.0,
            "inertia_ratio_shift": float(fit["quantisation_shift"][0])}


def check_plausible(result: RotaryIdentification) -> RotaryIdentification:
    """Refuse a model that is not a motor: a torque constant that falls below :data:`pgcomm.rotary.law.MIN_GAIN`
    of its mean somewhere on the revolution (``|r(θ)| > 1 − MIN_GAIN``; a real ripple is a few per cent). Such a
    fit comes from logs that do not determine the maps (e.g. a dither that reverses the speed, so that the few
    windows left carry nearly the same current at every angle), and its law would fight the feedback where the
    law clamps the gain.

    Returns:
        ``result`` unchanged.

    Raises:
        ExcitationError: the ripple's peak, where, and how many windows the fit had.
    """
    from pgcomm.rotary.law import MIN_GAIN

    th = 2 * math.pi * np.arange(4096) / 4096
    r = result.model.ripple(th)
    j = int(np.argmax(np.abs(r)))
    if not np.isfinite(r[j]) or abs(r[j]) > 1.0 - MIN_GAIN:
        used = result.info.get("windows_used")
        raise ExcitationError(
            f"the identified torque constant varies by {100 * r[j]:+.0f} % of its mean at {th[j]:.3f} rad (a motor's "
            f"ripple is a few per cent; the law refuses below {100 * MIN_GAIN:.0f} %): the logs do not determine the "
            "model" + (f" ({used} of {result.info.get('windows')} filter windows used)" if used is not None else "")
            + "; log at steady speeds in both directions with a q-current dither that keeps the speed's sign")
    return result


#: Relative standard error (of a map's RMS) at which :func:`identify` calls a map resolved.
RESOLVED_SHARE = 0.05
#: ... with this probability: a map is called resolved when the noise part of its error stays within
#: :data:`RESOLVED_SHARE` with this probability (its expected size within the target would be missed half the time).
RESOLVED_CONFIDENCE = 0.9


def _standard_errors(model: RotaryModel, cov, bias, o_r, o_c, o_d, orders: Orders, blocks: int,
                     blind: dict | None = None, shift=None, reading=None) -> dict:
    """How well the logs determine each map: expected RMS error over the revolution, relative to the
    map's identified RMS, and the running-log time that would bring it to :data:`RESOLVED_SHARE`.

    ``relative`` is the noise part (its expected RMS), ``relative_at_confidence`` the size it stays below with
    probability :data:`RESOLVED_CONFIDENCE` (:func:`_map_error_quantile`); both fall as the square root of the
    log time at the same excitation, which gives the time needed. ``ridge_bias`` is the RMS over the revolution
    of the ridge's pull towards zero (``(A⁻¹N − I) β̂``), relative too: small when the data set the map, large
    when logs that do not excite it leave the map to the ridge (then longer logs of the same kind do not help,
    and the noise part alone would call a map resolved that the data never determined).

    ``outside_order_limit`` (``blind``: per map, the RMS in the map's units, from the screening) is the RMS over
    the revolution of the largest order outside the slot/pole basis that the screening would not have added (the
    median over the candidate orders, :func:`_significant_extra_orders`), relative too: the part of a real map
    the logs could still hide. It falls with the noise, as the square root of the log time. A map is resolved
    when ``sqrt(relative_at_confidence² + outside_order_limit² + ridge_bias² + quantisation_bias²)`` is within
    :data:`RESOLVED_SHARE`: without the limit, a map whose noise part was within 5 % came out at 5-5.4 % on
    three zoo motors, with the zoo's outside order (3 % of the map's RMS) unseen.

    ``quantisation_bias`` (``shift``: the fit's shift were the encoder-noise correction
    :data:`QUANTISATION_UNCERTAINTY` smaller, :func:`_fit`) is the RMS of that shift over the revolution, relative:
    what the correction may leave. It does not fall with longer logs of the same kind.

    ``pll_bias`` (``reading``: :data:`PLL_UNCERTAINTY` times the fit's move from the angle as logged to the angle read
    through a drive's PLL, :func:`_angle_pll`; zero when the angle is the encoder's) is the RMS of that over the
    revolution, relative: what the PLL's reading may leave. It counts like the quantisation bias.
    """
    out = {"blocks": int(blocks), "resolved_share": RESOLVED_SHARE, "confidence": RESOLVED_CONFIDENCE}
    th = 2 * math.pi * np.arange(4096) / 4096
    for name, cols, fn, map_orders in (("cogging", o_c, model.cogging, orders.cogging),
                                       ("ripple", o_r, model.ripple, orders.ripple),
                                       ("direction", o_d, model.direction, orders.direction)):
        gram, c = _map_gram(map_orders), cov[np.ix_(cols, cols)]
        se = _map_standard_error(c, gram)
        se_q = _map_error_quantile(c, gram, RESOLVED_CONFIDENCE)
        b = bias[cols]
        b_rms = float(np.sqrt(max(float(b @ gram @ b), 0.0)))
        rms = float(np.sqrt(np.mean(fn(th) ** 2)))
        rel = se / rms if rms > 0 else float("inf")
        b_rel = b_rms / rms if rms > 0 else float("inf")
        rel_q = se_q / rms if rms > 0 else float("inf")
        sh = np.zeros(len(cols)) if shift is None else shift[cols]
        q_rel = float(np.sqrt(max(float(sh @ gram @ sh), 0.0))) / rms if rms > 0 else float("inf")
        rd = np.zeros(len(cols)) if reading is None else reading[cols]
        p_rel = float(np.sqrt(max(float(rd @ gram @ rd), 0.0))) / rms if rms > 0 else float("inf")
        lim = (blind or {}).get(name)
        lim_rel = (float(lim) / rms if rms > 0 else float("inf")) if lim is not None else None
        noise = math.hypot(rel_q, lim_rel or 0.0)
        fixed = math.hypot(b_rel, q_rel, p_rel)
        out[name] = {"rms_error": se, "rms": rms, "relative": rel, "relative_at_confidence": rel_q,
                     "outside_order_limit": lim_rel, "ridge_bias": b_rel, "quantisation_bias": q_rel,
                     "pll_bias": p_rel, "resolved": bool(math.hypot(noise, fixed) <= RESOLVED_SHARE),
                     "log_time_factor_to_resolve": _time_factor(noise, fixed)}
    # the ripple is seen only through q-current that varies at a given angle: its need falls with the square of that
    # variation, which constant-speed logs hardly carry (zoo 9N6P: 34 s of constant speeds left its standard error at
    # 22 %, 17 s of accelerations added brought it to 4.4 %)
    out["ripple"]["excitation_hint"] = ("more q-current variation at each angle (a dither that keeps the speed's sign, "
                                        "or accelerations) resolves it sooner than longer logs of the same kind")
    return out


def _time_factor(noise: float, fixed: float) -> float:
    """How many times the log so far brings the noise part (falling as the square root of the log time) within
    what :data:`RESOLVED_SHARE` leaves beside the parts longer logs do not change (``fixed``); ``inf`` if none."""
    room = RESOLVED_SHARE**2 - fixed**2
    if room <= 0.0:
        return float("inf")
    return float(max(1.0, noise**2 / room))


def resolution_verdict(entry: dict, log_seconds: float | None = None) -> str:
    """One phrase for a map's entry of ``info["standard_error"]`` (:func:`_standard_errors`): ``"resolved"``, or
    why not and what would help (and the entry's ``excitation_hint``, the ripple's: more q-current variation):
    longer logs of the same kind when the noise part is too large (with
    ``log_seconds``, the seconds of running log so far, also the total it would take; with the noise part at
    :data:`RESOLVED_CONFIDENCE` and the outside-order limit it weighs, when the entry has them), a different
    excitation when the ridge sets the map or the encoder's rounding could move it by more than the share (then
    longer logs of the same kind do not help)."""
    if entry["resolved"]:
        return "resolved"
    ridge, quant = entry.get("ridge_bias", 0.0), entry.get("quantisation_bias", 0.0)
    if math.hypot(ridge, quant) >= RESOLVED_SHARE and ridge >= quant:
        return (f"not resolved: the ridge sets {100 * entry['ridge_bias']:.0f} % of it (the logs do not excite it; "
                "log with more q-current variation, e.g. a dither or accelerations)")
    pll = entry.get("pll_bias", 0.0)
    if math.hypot(ridge, quant, pll) >= RESOLVED_SHARE and pll >= quant and pll >= ridge:
        return (f"not resolved: the drive PLL's reading of the angle could move it by {100 * pll:.0f} % (log the "
                "encoder's count if the drive has it)")
    if math.hypot(ridge, quant) >= RESOLVED_SHARE:
        return (f"not resolved: the encoder's rounding could move it by {100 * entry['quantisation_bias']:.0f} % (the "
                "logs hardly carry the rotor's acceleration above it; log accelerations or a dither, or use a finer "
                "encoder)")
    # rounded up to a tenth: a factor just above 1 would otherwise read "1.0x", as if no more log were needed
    factor = max(1.1, math.ceil(10 * entry["log_time_factor_to_resolve"]) / 10)
    total = "" if log_seconds is None else f" ({factor * log_seconds:.0f} s)"
    # what the verdict weighs, so a standard error below 5 % next to "not resolved" reads as intended
    parts = []
    if entry.get("relative_at_confidence") is not None:
        parts.append(f"noise up to {100 * entry['relative_at_confidence']:.1f} % at {100 * RESOLVED_CONFIDENCE:.0f} %")
    if entry.get("outside_order_limit") is not None:
        parts.append(f"an unseen order outside the basis up to {100 * entry['outside_order_limit']:.1f} %")
    if entry.get("quantisation_bias", 0.0) >= 0.1 * RESOLVED_SHARE:
        parts.append(f"the encoder's rounding up to {100 * entry['quantisation_bias']:.1f} %")
    if entry.get("pll_bias", 0.0) >= 0.1 * RESOLVED_SHARE:
        parts.append(f"the PLL's reading up to {100 * entry['pll_bias']:.1f} %")
    why = f" ({', '.join(parts)})" if parts else ""
    hint = f"; {entry['excitation_hint']}" if entry.get("excitation_hint") else ""
    return (f"not resolved{why}: about {factor:.1f}x the running log so far{total}, at the same excitation, "
            f"would resolve it{hint}")


def _times(ratio: float) -> str:
    """A factor for a sentence: ``"1.9x"``, ``"190x"``."""
    return f"{ratio:.0f}x" if ratio >= 10 else f"{ratio:.2g}x"


def delay_text(timing: dict) -> str | None:
    """One sentence on the logged current's timing (``info["current_delay"]`` of
    :func:`pgcomm.rotary.identify.identify`), or ``None`` when it was given rather than detected."""
    if not timing or not timing.get("detected"):
        return None
    costs = {int(k): v for k, v in (timing.get("cost_by_delay") or {}).items()}
    d = int(timing["samples"])
    if d == 0:
        near = [costs[k] / costs[0] for k in (-1, 1) if k in costs and costs.get(0)]
        return ("the logged q-current is in time with the angle" + (
            f" (shifted by one sample it fits {_times(min(near))} worse)" if near else ""))
    ratio = costs[0] / costs[d] if costs.get(d) else float("nan")
    return (f"the logged q-current is {abs(d)} sample(s) {'late' if d > 0 else 'early'} against the angle: used "
            f"shifted by {d} (it fits {_times(ratio)} better so; the drive samples its current at another point of its "
            "cycle than the encoder, or the logger writes it late)")


def pll_text(estimate: dict) -> str | None:
    """One sentence on how the logged angle was read (``info["angle_pll"]`` of :func:`identify`), or ``None`` when
    nothing was searched or given."""
    if not estimate:
        return None
    w = estimate.get("natural_frequency_rad_s")
    if w is None and not estimate.get("searched"):
        return None
    if w is None:
        return ("the logged angle is not on an encoder's lattice, and it fits best as the rotor's angle (no drive "
                "PLL's lag found in it)")
    how = (f"it fits {_times(estimate['cost_as_logged'] / estimate['cost'])} better so"
           if estimate.get("searched") else "as given")
    return (f"the logged angle is read as a drive's PLL estimate of natural frequency {w:.0f} rad/s and damping "
            f"{estimate['damping']:.3g}, and its lag taken out ({how}; log the encoder's count if the drive has it)")


def lines_text(lines: dict) -> str | None:
    """One sentence on the time-periodic disturbances (``info["time_lines"]`` of :func:`identify`), or ``None`` when
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


def fit_mechanics(logs, motor: RotaryMotor, orders: Orders | None = None,
                  min_samples_per_period: float = MIN_SAMPLES_PER_PERIOD, taps: int = FILTER_TAPS,
                  encoder_step="detect", current_delay: int = 0, angle_pll=None, time_lines=()) -> dict:
    """The feedforward a drive user tunes: ``i_q ≈ (J/k0) θ̈ + b ω + d0 sign(ω)`` fitted on the same
    windows as :func:`identify`, without any position dependence, with the same correction for the encoder's
    quantisation (:mod:`pgcomm.rotary.quantisation`; ``encoder_step`` as in :func:`identify`), the current
    shifted by ``current_delay`` samples, the angle read through ``angle_pll`` and the time-periodic disturbances
    ``time_lines`` (Hz) fitted beside (the ones :func:`identify` reports: ``info["current_delay"]["samples"]``,
    ``info["angle_pll"]``'s natural frequency and damping, ``info["time_lines"]["hz"]``; a 50 Hz pickup of 1 % of
    the current limit moved the Coulomb term by up to 27 % and turned the viscous term's sign on zoo seed 0).

    Returns:
        ``{"inertia_ratio": A·s²/rad, "viscous": A·s/rad, "coulomb": A}``.
    """
    orders = orders or Orders.for_motor(motor)
    lines = tuple(float(f) for f in time_lines or ())
    d, _, _, _ = _design(logs, motor, orders, min_samples_per_period, taps, encoder_step, current_delay, angle_pll,
                         lines)
    # the Coulomb column is the order-0 direction column (cos 0 · s)
    j0 = int(np.flatnonzero(orders.direction == 0)[0]) if np.any(orders.direction == 0) else None
    s_col = d["dir"][:, j0] if j0 is not None else np.sign(d["visc"])
    X = np.column_stack([d["acc"], d["visc"], s_col] + ([_line_columns(d, int(d["log"].max()) + 1)] if lines else []))
    G, _, _ = _quantisation_correction((X.T @ X)[None], np.array([float(np.sum(d["acc_noise"]))]))
    beta = np.linalg.lstsq(G[0], X.T @ d["y"], rcond=None)[0]
    return {"inertia_ratio": float(beta[0]), "viscous": float(beta[1]), "coulomb": float(beta[2])}


def _identify_torque(logs, motor, orders, t0) -> RotaryIdentification:
    ys, xs = [], []
    for i, log in enumerate(logs):
        name, th, iq, torque, _ = _log_arrays(log, i, motor.sample_time)
        if torque is None:
            raise DataError(f"{name}: column 'torque' missing (identification with a torque sensor)")
        if not np.all(np.isfinite(torque)):
            raise DataError(f"{name}: column 'torque' has a non-finite value at row "
                            f"{np.flatnonzero(~np.isfinite(torque))[0] + 1}")
        phi_r = harmonic_columns(th, orders.ripple)
        phi_c = harmonic_columns(th, orders.cogging)
        xs.append(np.column_stack([iq, iq[:, None] * phi_r, phi_c]))
        ys.append(torque)
    X, y = np.concatenate(xs), np.concatenate(ys)
    keep = np.any(X != 0, axis=0)
    if np.ptp(X[:, 0]) == 0:
        raise ExcitationError("torque-sensor identification needs a varying q-current")
    beta = np.zeros(X.shape[1])
    beta[keep] = np.linalg.lstsq(X[:, keep], y, rcond=None)[0]
    k0 = float(beta[0])
    nr = 2 * orders.ripple.size
    model = RotaryModel(motor.pole_pairs, Fourier.from_vector(orders.cogging, beta[1 + nr:] / k0),
                        Fourier.from_vector(orders.ripple, beta[1:1 + nr] / k0), Fourier.zeros([0]), k_t=k0,
                        info={"method": "torque sensor"})
    return RotaryIdentification(model, {"k0": k0, "cost_Nm2": float(np.mean((y - X @ beta) ** 2)),
                                        "seconds": time.perf_counter() - t0})
