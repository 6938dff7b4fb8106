"""The regression behind :func:`pgcomm.rotary.identify.identify` without a torque sensor: the filtered rows, their
normal equations built a chunk at a time, the ridge fit validated on time blocks, and the screening of orders outside
the slot/pole basis. How the logs are read (:mod:`pgcomm.rotary.readings`) and the search for time-periodic
disturbances (:mod:`pgcomm.rotary.time_lines`) repeat its fit; :mod:`pgcomm.rotary.identify` turns it into a model
with standard errors.

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
phase within a sample, down to 3 samples per period of the highest cogging order. (Taking the torque as a
quadratic in time, ``[1/12, 5/6, 1/12]`` on the samples, would need about 8 samples per period; the
speed of the running logs, and so the dither current they can carry, is bounded by this number.)

**Alias guard.** A window is used only where the highest modelled harmonic has at least
``MIN_SAMPLES_PER_PERIOD`` samples per period at the window's fastest speed (DESIGN: "refuse
windows whose cogging period is below a few samples, and say so"); the result reports how many
windows were refused and the speed limit. Windows near standstill (stiction, reversals) and
windows whose direction changes are left out too.

**Encoder quantisation.** The logged angle's rounding to the encoder's step is noise in the acceleration
*regressor*, which pulls ``J/k0`` towards zero and the maps with it (errors in variables; tens of per cent at
constant speed with 16–17-bit encoders). Where the logged angle sits on an encoder's lattice, the
step is read from it and the noise's known variance taken out of the normal equations
(:mod:`pgcomm.rotary.quantisation`, :func:`_quantisation_correction`). A host's clock adds a noise of the same kind
that grows with the speed (:mod:`pgcomm.rotary.host_clock`): where it is read from the angle, its variance per row
(:attr:`_Prepared.timing_noise`) is taken out the same way.

**The current's noise.** The logged current is in the target and, through ``i_q φ_h``, in the ripple's columns: its
noise is the same in both, and their product does not average out where the rotor's angle is not sampled evenly over
the revolution. A speed loop that answers the cogging makes the rotor slower at some angles of the largest cogging
order than at others, so the rows hold more of those angles, and the ripple at that order (where it is one of the
ripple's orders: ``LCM(Q, 2p) = 12p`` on 36N42P and 24N20P motors) is pulled towards zero as the noise's variance
grows, most where the dither is small against the noise (``bench/rotary_ripple_bias.py``; the noise in the target
alone or in the columns alone moves nothing). The expectation of that product is known given the noise's variance:
the sum over rows and logged samples of ``a_j a_jᵀ``, ``a_j`` the part of a row that sample ``j`` sets, built by running the rows on probe currents, each
1 on every ``P``-th sample (no row reads two of them). :func:`_current_noise_equations` builds it and
:func:`_current_noise_correction` subtracts it times the variance. The noise is read from the logged d-current
(:mod:`pgcomm.rotary.identify`); where the logs have none, from the q-current's sixth difference less the current the
loop commands from the encoder's noise (real current, which the logged angle predicts:
:func:`pgcomm.rotary.readings.current_noise_beside_angle`).

**Weighted rows.** Where a host's clock makes the logged angle's noise grow with the speed, the rows carry
weights (:mod:`pgcomm.rotary.host_clock`, :attr:`_Prepared.weight`): every row's target and columns, the current-noise
probes' and the lines' alike, are scaled by the square root of its weight where the rows are made
(:func:`_reading_chunks`), and the acceleration's encoder noise by the weight, so that the fit, its validation, its
corrections, its standard errors, the screening and the readings' search all solve the same generalised least squares.

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
(training and validation blocks apart), so the screening's hundreds of orders cost tens of MB."""

from __future__ import annotations

import math
import threading
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve, eigh
from scipy.stats import chi2, f as f_dist

from pgcomm.errors import DataError, ExcitationError
from pgcomm.rotary.model import cogging_orders, direction_orders, drive_orders, fundamental_cogging_order, \
    harmonic_columns, harmonic_rows, ripple_orders
from pgcomm.rotary import quantisation
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.over_the_angle import has_steady_segment

#: Fewest samples per period of the highest modelled harmonic for a window to be used. The kernel is
#: exact along the path (module docstring); below ~3 the cubic between encoder samples no longer follows a
#: cogging-driven speed ripple and the interpolation's error grows.
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
#: Steps within this share of their median are a uniform grid (the kernel's constant weights); beyond it the
#: regression integrates over each real interval (module docstring, "Time stamps").
UNIFORM_TOLERANCE = 1e-6
#: Filter windows per block of rows built at once (memory: rows x columns x 8 bytes).
CHUNK_WINDOWS = 512
#: The encoder-noise correction of the acceleration (:func:`_quantisation_correction`) removes at most this
#: share of the acceleration's part that the maps and friction do not explain: beyond it the logs do not carry
#: the rotor's acceleration above the encoder's noise, and ``J/k0`` would be noise over almost nothing.
MAX_NOISE_SHARE = 0.75
#: Where the correction is capped, the verdict also weighs the fit under the correction the noise model asks for, up
#: to this share of the acceleration's part the maps and friction leave (:func:`_fit`'s ``quantisation_shift``).
UNCAPPED_SHARE = 0.99
#: A basis fit's cost (:func:`_fit_of_normal_equations`) is the encoder-noise corrected residual, but at least this
#: share of the residual on the rows as logged: a correction that would leave less has outgrown the noise it
#: estimates.
MIN_CORRECTED_SHARE = 0.01
#: The current-noise correction (:func:`_current_noise_correction`) removes at most this share of the ripple
#: columns' part that the other columns do not explain, as :data:`MAX_NOISE_SHARE` does for the acceleration.
MAX_CURRENT_NOISE_SHARE = 0.75
#: The share of the encoder-noise correction taken as uncertain in the verdict: the noise the acceleration actually
#: carries, with the drive's loop reacting to it, differs from the white model's by up to about half of it from one
#: constant-speed log to another.
QUANTISATION_UNCERTAINTY = 0.5


@dataclass(frozen=True)
class Orders:
    """Harmonics per revolution of the three maps (int arrays)."""

    cogging: np.ndarray
    ripple: np.ndarray
    direction: np.ndarray

    @classmethod
    def for_motor(cls, motor: RotaryMotor) -> "Orders":
        """The orders the slot/pole combination sets (:mod:`pgcomm.rotary.model`), the drive's own
        (:func:`~pgcomm.rotary.model.drive_orders`: its current sensors' offsets and mismatch, dead time) in the
        cogging map, and order 0 there: a constant torque (a load, the current sensor's offset) that the law compensates with the cogging.
        Without it, a constant offset of the current (1 % of the limit is plausible) goes into the ripple, which is
        far smaller, and into the cogging, beyond what its standard error says."""
        return cls(np.union1d(np.union1d([0], cogging_orders(motor.slots, motor.pole_pairs)),
                              drive_orders(motor.pole_pairs)),
                   ripple_orders(motor.slots, motor.pole_pairs), direction_orders(motor.pole_pairs))

    @property
    def highest(self) -> int:
        return int(max(self.cogging.max(initial=0), self.ripple.max(initial=0), self.direction.max(initial=0)))


def max_speed(orders: Orders, sample_time: float, min_samples: float = MIN_SAMPLES_PER_PERIOD) -> float:
    """The fastest speed (rad/s) at which the alias guard keeps a window:
    ``2π / (T_s · min_samples · h_max)``."""
    return 2.0 * math.pi / (sample_time * min_samples * max(orders.highest, 1))


#: Where the basis's alias guard would keep fewer windows at speed than this many per unknown (its columns), the basis
#: is cut to the orders the logs resolve (:func:`resolved_orders`): below it the fit of the full basis is poorly
#: determined (the refusal is at two), and the windows the guard refuses cost the maps more than the top orders left
#: out (the multiples of a motor's cogging fundamental fall with the multiple). Logs that already give the full basis
#: that many windows (a slow log beside a fast one) keep it.
CUT_WINDOWS_PER_UNKNOWN = 10.0
#: The share of the windows at speed whose fastest step the cut basis's highest order still resolves.
GUARD_QUANTILE = 0.9


def steps_at_speed(logs, sample_time: float, taps: int = FILTER_TAPS) -> np.ndarray:
    """The fastest angle one step turns in each filter window at speed, every log (rad): what the alias guard of
    :func:`_prepare` judges (windows near standstill or reversing left out).

    Args:
        logs: logs as for :func:`_prepare` (``theta`` rad, multi-turn; ``(N_i,)`` each).
        sample_time: the drive's period (s), where a log has no ``t``; taps: the filter's taps.

    Returns:
        ``(M,)`` float array (rad per median step), all logs' windows at speed.
    """
    return _steps_and_step(logs, sample_time, taps)[0]


def _steps_and_step(logs, sample_time: float, taps: int) -> tuple[np.ndarray, float]:
    """:func:`steps_at_speed` and the logs' median step (s), in one pass over the logs."""
    steps, ts_all = [], []
    for i, log in enumerate(logs):
        _, th, _, _, ts = _log_arrays(log, i, sample_time)
        ts_all.append(ts)
        if th.size < taps + 4:
            continue
        _, _, slow, wmax, _ = _windows(th, _log_time(log), ts, taps)
        steps.append(wmax[~slow] * ts)
    return (np.concatenate(steps) if steps else np.zeros(0)), float(np.median(ts_all)) if ts_all else sample_time


def _median_speed(logs, sample_time: float) -> float:
    """The median speed (rad/s) over every log's moving samples: ``|Δθ| / Δt`` where the angle moves."""
    speeds = []
    for log in logs:
        th = np.asarray(log["theta"], float)
        t = np.asarray(log["t"], float) if "t" in log else np.arange(th.size) * sample_time
        v = np.abs(np.diff(th)) / np.maximum(np.diff(t), 1e-12)
        speeds.append(v[v > 0])
    v = np.concatenate(speeds) if speeds else np.zeros(0)
    return float(np.median(v)) if v.size else 0.0


def highest_resolved_order(steps: np.ndarray, min_samples: float = MIN_SAMPLES_PER_PERIOD,
                           share: float = GUARD_QUANTILE) -> int:
    """The highest order per revolution with ``min_samples`` samples per period in ``share`` of the windows
    (``steps``: :func:`steps_at_speed`): ``⌊2π / (min_samples · q)⌋``, ``q`` their ``share`` quantile (0 for none)."""
    if not steps.size:
        return 0
    return int(math.floor(2 * math.pi / (min_samples * float(np.quantile(steps, share)))))


def resolved_orders(logs, motor: RotaryMotor, orders: Orders,
                    min_samples: float = MIN_SAMPLES_PER_PERIOD) -> tuple[Orders, dict | None]:
    """``orders`` cut to what the logs resolve where they turn too fast for the basis's highest order.

    A log recorded at a speed of its own (a robot's joint in its speed loop, a host that polls every few
    milliseconds) can put most of its windows beyond the alias guard of the full basis (three multiples of the
    cogging fundamental ``L``), and the guard would refuse them. Where it would keep fewer than
    :data:`CUT_WINDOWS_PER_UNKNOWN` windows per unknown, every map keeps the orders up to the highest that
    :data:`GUARD_QUANTILE` of the windows at speed resolve (:func:`highest_resolved_order`), and those windows are
    kept. The orders above are not resolved in time by these logs (slower logs or a faster host would resolve
    them); the cogging's among them are read over the angle instead (:mod:`pgcomm.rotary.over_the_angle`).

    Args:
        logs: as for :func:`_prepare`; motor: :class:`RotaryMotor` (its slots set ``L``, its ``sample_time`` is
            used where a log has no ``t``); orders: the basis (:meth:`Orders.for_motor`);
        min_samples: the alias guard's samples per period.

    Returns:
        ``(orders, cut)``: ``cut`` is ``None`` where nothing was cut, else ``{"highest_order", "orders"`` (the orders
        left out, every map), ``"speed_rad_s"`` (the speed ``GUARD_QUANTILE`` of the windows at speed stay below),
        ``"speed_to_resolve_rad_s"`` (the basis's guard: below it every order is resolved)``}``.

    Raises:
        ExcitationError: the cut would leave out the cogging's fundamental ``L`` and no log holds a steady stretch
            to read it over the angle (:func:`pgcomm.rotary.over_the_angle.has_steady_segment`).
    """
    steps, ts = _steps_and_step(logs, motor.sample_time, FILTER_TAPS)
    if not steps.size or orders.highest < 1:
        return orders, None
    kept = int(np.sum(steps <= 2 * math.pi / (min_samples * orders.highest)))
    top = highest_resolved_order(steps, min_samples)
    if kept >= CUT_WINDOWS_PER_UNKNOWN * int(_Layout.of(orders).keep.sum()) or top >= orders.highest:
        return orders, None
    speed = float(np.quantile(steps, GUARD_QUANTILE)) / ts
    full = max_speed(orders, ts, min_samples)
    fundamental = fundamental_cogging_order(motor.slots, motor.pole_pairs) if motor.slots else None
    # the speed below which the guard keeps the fundamental: the logs' own speed scaled by the orders, as their steps
    # (a host's uneven ones, the speed's ripple) make the guard's quantile of the fastest step in a window
    need = (None if fundamental is None else
            min(2 * math.pi / (ts * min_samples * fundamental), _median_speed(logs, motor.sample_time)
                * 2 * math.pi / (min_samples * float(np.quantile(steps, GUARD_QUANTILE)) * fundamental)))
    if fundamental is not None and top < fundamental and not has_steady_segment(logs, motor.sample_time):
        raise ExcitationError(
            f"the logs turn too fast for their sampling to resolve the cogging's fundamental (order {fundamental} "
            f"per revolution): nine in ten filter windows at speed turn at up to {speed:.4g} rad/s (their fastest step "
            f"over the median step, {1e3 * ts:.3g} ms), where the highest order with {min_samples:g} samples per "
            f"period is {top}; log at most {need:.3g} rad/s (every order of the basis: {full:.3g} rad/s) or poll the "
            "drive faster, or hold a steady speed for two revolutions or more to read it over the angle"
            + _unit_hint(speed, need))
    cut = Orders(*(o[o <= top] for o in (orders.cogging, orders.ripple, orders.direction)))
    left = sorted(set(np.concatenate([orders.cogging, orders.ripple, orders.direction]).tolist())
                  - set(np.concatenate([cut.cogging, cut.ripple, cut.direction]).tolist()))
    return cut, {"highest_order": int(top), "orders": [int(h) for h in left], "speed_rad_s": speed,
                 "speed_to_resolve_rad_s": full,
                 "fundamental_over_the_angle": fundamental if fundamental is not None and top < fundamental else None,
                 "speed_to_resolve_fundamental_rad_s": need}


_ZOH = np.array([0.5, 0.5])
_TRI = np.array([1.0 / 12.0, 5.0 / 6.0, 1.0 / 12.0])
#: Gauss–Legendre nodes and weights on [0, 1] for the per-interval integrals (exact for degree 7; at three
#: samples per period of the highest order the phase turns 2.1 rad per interval: error ~1e-6 of a column).
_GL_NODES = 0.5 * (1.0 + np.polynomial.legendre.leggauss(4)[0])
_GL_WEIGHTS = 0.5 * np.polynomial.legendre.leggauss(4)[1]
def _lagrange(xs) -> np.ndarray:
    """``(4, len(xs))``: the cubic Lagrange weights of the samples at ``-1, 0, 1, 2`` (sample intervals) at ``xs``."""
    return np.array([[-x * (x - 1) * (x - 2) / 6, (x + 1) * (x - 1) * (x - 2) / 2,
                      -(x + 1) * x * (x - 2) / 2, (x + 1) * x * (x - 1) / 6] for x in np.asarray(xs, float)]).T


#: ``(4, nodes)``: the cubic Lagrange weights of the samples at ``-1, 0, 1, 2`` (sample intervals) at each node.
_GL_LAGRANGE = _lagrange(_GL_NODES)


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
            ts = float(np.median(d))  # non-uniform stamps: their median step (:func:`_log_time` keeps them)
    if ts is None:
        raise DataError(f"{name}: no 't' column and no sample time given")
    torque = np.asarray(log["torque"], float) if "torque" in log else None
    return name, th, iq, torque, float(ts)


def _log_time(log) -> np.ndarray | None:
    """The log's time stamps ``(N,)`` (s) where they are not uniform (a host's clock: the regression integrates over
    the real intervals), ``None`` where they are (the kernel's constant weights then hold)."""
    if "t" not in log:
        return None
    t = np.asarray(log["t"], float)
    d = np.diff(t)
    if d.size == 0 or np.max(np.abs(d - np.median(d))) <= UNIFORM_TOLERANCE * np.median(d):
        return None
    return t


def _lagrange_at(u: np.ndarray, xs) -> np.ndarray:
    """``(n_int, 4, len(xs))``: the cubic Lagrange weights of four samples at the times ``u`` ``(n_int, 4)`` (in units
    of each interval's own length, from its start) at ``xs`` (same units); :func:`_lagrange` for ``u = -1, 0, 1, 2``."""
    xs = np.asarray(xs, float)
    w = np.ones((u.shape[0], 4, xs.size))
    for j in range(4):
        for m in range(4):
            if m != j:
                w[:, j, :] *= (xs[None, :] - u[:, m, None]) / (u[:, j, None] - u[:, m, None])
    return w


@dataclass(frozen=True)
class _Steps:
    """A chunk's non-uniform sample intervals (module docstring, "Time stamps"): ``u`` ``(n_int, 4)`` the four samples
    around each interval in units of its length, ``h`` ``(n_int,)`` its length (s), ``rise``/``fall`` ``(n_int,)`` the
    weights ``h_k / h̄_{k+1}`` and ``h_k / h̄_k`` of its torque integrals in the rows of the samples at its end and
    start (``h̄_i`` the mean of the two intervals around sample ``i``)."""

    u: np.ndarray
    h: np.ndarray
    rise: np.ndarray
    fall: np.ndarray
    t0: np.ndarray

    @classmethod
    def of(cls, t: np.ndarray, lo: int, hi: int) -> "_Steps":
        te = _extended(t, lo, hi)  # te[j] is t_{lo - 1 + j}
        n_int = hi - lo - 1
        h = te[2:n_int + 2] - te[1:n_int + 1]
        u = np.stack([(te[j:j + n_int] - te[1:n_int + 1]) / h for j in range(4)], axis=1)
        hb = 0.5 * (te[2:n_int + 3] - te[:n_int + 1])  # h̄ at samples lo .. hi - 1
        return cls(u, h, h / hb[1:], h / hb[:-1], te[1:n_int + 1])

    def at(self, xs) -> np.ndarray:
        return _lagrange_at(self.u, xs)


def _rise_fall(a: np.ndarray, b: np.ndarray, steps: "_Steps | None"):
    """The interval weights ``(A, B)`` scaled by the intervals' rise and fall weights (unchanged where uniform)."""
    if steps is None:
        return a, b
    if a.ndim == 1:
        return a * steps.rise, b * steps.fall
    return a * steps.rise[:, None], b * steps.fall[:, None]


def _require_current(logs, sample_time) -> None:
    """Refuse logs whose q-current carries no excitation: the same value in every row of every log.

    The fit weighs the current against the motion (``J/k0 θ̈`` and the maps in current units): a current that
    never changes (a column of zeros: a drive that logged a disabled channel, a wrong column map) determines
    neither, and its normal equations, once corrected for the current's noise, are not positive definite.
    One log with a varying current is enough (a coasting log beside running ones still shows the cogging).

    Raises:
        ExcitationError: naming the first log, the column and its value.
    """
    flat = []
    for i, log in enumerate(logs):
        name, _, iq, _, _ = _log_arrays(log, i, sample_time)
        if iq.size and np.ptp(iq) > 0:
            return
        flat.append((name, float(iq[0]) if iq.size else 0.0))
    if flat:
        name, value = flat[0]
        more = f" (and in the {len(flat) - 1} other log(s))" if len(flat) > 1 else ""
        raise ExcitationError(f"{name}: column 'iq_1' is {value:g} A in every row{more}: the current carries no "
                              "excitation; identification needs the q-current the drive commanded while the rotor "
                              "ran (check the column and its --columns mapping)")


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
    #: The logged current between two samples (:mod:`pgcomm.rotary.readings`): ``None`` held from each sample to the
    #: next (a drive that controls at its log rate); a number: smooth, the cubic through the four samples around
    #: each interval, that many samples late (one that controls faster and logs a snapshot of its current every
    #: ``T_s``: at ``K`` control cycles per logged sample the held cycles lag that curve by ``1/(2K)``).
    lag: float | None = None
    #: The log's time stamps where they are not uniform (:func:`_log_time`), else ``None``.
    t: np.ndarray | None = None
    #: ``(N,)`` the weight of the row centred on each sample (:mod:`pgcomm.rotary.host_clock`: a speed-dependent
    #: angle noise), or ``None``: every row weighs 1.
    weight: np.ndarray | None = None
    #: ``(N,)`` the acceleration's noise variance from the host's clock in the row centred on each sample
    #: (:func:`pgcomm.rotary.host_clock.timing_noise`), taken out of the normal equations with ``acc_noise``; ``None``:
    #: none.
    timing_noise: np.ndarray | None = None


def _prepare(logs, motor: RotaryMotor, orders: Orders, min_samples: float, taps: int, encoder_step="detect",
             current_lag: float | None = None):
    """The usable windows of every log: the alias guard, and no window near standstill or reversing; and the
    encoder's quantisation noise in each log's acceleration (:mod:`pgcomm.rotary.quantisation`): ``encoder_step``
    ``"detect"`` reads the step from each logged angle, a number (rad) gives it, ``None`` leaves it out. The current is
    read held between samples (``current_lag`` ``None``) or as the smooth curve through them, ``current_lag`` samples
    late (:attr:`_Prepared.lag`).

    Returns:
        ``(prepared, counts, v_limit, ts)``: a :class:`_Prepared` per log with windows, the window counts
        (``windows``, ``alias``, ``slow``), the alias guard's speed limit (rad/s), the median sample time (s).
    """
    _require_current(logs, motor.sample_time)
    span = taps + 2  # samples of θ one output needs: s .. s+T+1
    counts = {"windows": 0, "alias": 0, "slow": 0}
    prepared, ts_all, fastest = [], [], 0.0
    v_limit = None
    for i, log in enumerate(logs):
        name, th, iq, _, ts = _log_arrays(log, i, motor.sample_time)
        t = _log_time(log)
        ts_all.append(ts)
        if th.size < span + 2:
            continue
        w, s_all, slow, wmax, v95 = _windows(th, t, ts, taps)
        fastest = max(fastest, v95)
        v_limit = max_speed(orders, ts, min_samples)
        alias = ~slow & (wmax > v_limit)
        ok = ~slow & ~alias
        counts["windows"] += int(s_all.size)
        counts["slow"] += int(slow.sum())
        counts["alias"] += int(alias.sum())
        if np.any(ok):
            q = quantisation.encoder_step(th) if isinstance(encoder_step, str) else encoder_step
            noise = 0.0 if q is None else quantisation.acceleration_noise(quantisation.angle_noise(th, q), _hann(taps),
                                                                          ts)
            prepared.append(_Prepared(i, th, iq, np.sign(w), w, s_all[ok], ts, q, noise,
                                      lag=None if current_lag is None else float(current_lag), t=t))
    if not prepared:
        lim = f"{v_limit:.3g} rad/s" if v_limit is not None else "?"
        raise ExcitationError(
            f"no usable window in {len(logs)} log(s): {counts['alias']} of {counts['windows']} windows too fast for "
            f"the encoder-sampled cogging (highest order {orders.highest} per revolution needs <= {lim} for "
            f"{min_samples:g} samples per period), {counts['slow']} near standstill or reversing"
            + _unit_hint(fastest, v_limit))
    return prepared, counts, v_limit, float(np.median(ts_all))


def _windows(th: np.ndarray, t: np.ndarray | None, ts: float, taps: int):
    """One log's filter windows and what the alias guard judges of them.

    Args:
        th: ``(n,)`` angle (rad), ``n ≥ taps + 4``; t: ``(n,)`` stamps (s) or ``None`` (samples ``ts`` apart);
        ts: the log's median step (s); taps: the filter's taps.

    Returns:
        ``(w, starts, slow, wmax, v95)``: the speed ``(n,)`` (rad/s, central differences), the windows' first samples
        ``(W,)``, whether each is near standstill or reversing ``(W,)``, the fastest angle a step turns in each
        (rad/s over ``ts``: on stamps, the speed times the longer of the two steps around a sample) ``(W,)``, and the
        log's 95th-percentile speed (rad/s).
    """
    n = th.size
    span = taps + 2  # samples of θ one output needs: s .. s+T+1
    w = np.empty(n)
    w[1:-1] = (th[2:] - th[:-2]) / (2 * ts if t is None else t[2:] - t[:-2])
    w[0], w[-1] = w[1], w[-2]
    speed = np.abs(w)
    v95 = float(np.percentile(speed, 95))
    s_all = np.arange(0, n - span + 1, max(1, taps // 2))
    idx = s_all[:, None] + np.arange(span)
    wmin = speed[idx].min(axis=1)
    if t is None:
        wmax = speed[idx].max(axis=1)
    else:
        # the guard on the angle one step turns: the speed times the longer of the two steps around a sample
        h = np.diff(t)
        h_at = np.maximum(np.r_[h[0], h], np.r_[h, h[-1]])
        wmax = (speed * h_at)[idx].max(axis=1) / ts
    one_dir = np.all(np.sign(w[idx]) == np.sign(w[idx[:, :1]]), axis=1)
    return w, s_all, (wmin <= MIN_SPEED_SHARE * v95) | ~one_dir, wmax, v95


def _unit_hint(speed: float, limit: float | None) -> str:
    """A hint on the angle's unit where the logs turn far faster than the alias guard allows (``speed`` the logs'
    95th-percentile speed, rad/s): an angle in degrees read as radians turns 57 times as fast, one in counts
    thousands of times."""
    if limit is None or speed <= 10.0 * limit:
        return ""
    return (f"; the logs turn at up to {speed:.4g} rad/s ({speed * 60 / (2 * math.pi):.4g} rpm): if 'theta' is in "
            "degrees or encoder counts, declare it in the --columns map's [units] (theta = \"deg\", or \"counts\" "
            "with encoder_counts)")


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
    return _at_nodes(theta_ext, n_int, _GL_LAGRANGE)


def _at_nodes(ext: np.ndarray, n_int: int, weights: np.ndarray) -> np.ndarray:
    """``(n_int, nodes)``: the cubic through the four samples around each interval (``ext[k + 1]`` the sample at
    ``t_k``, as :func:`_path_angles` takes them) at the nodes whose Lagrange weights are ``weights``: ``(4, nodes)``
    on a uniform grid (:func:`_lagrange`), ``(n_int, 4, nodes)`` per interval on non-uniform stamps
    (:meth:`_Steps.at`)."""
    pts = np.stack([ext[j:j + n_int] for j in range(4)], axis=1)  # x_{k-1}, x_k, x_{k+1}, x_{k+2}
    return pts @ weights if weights.ndim == 2 else np.einsum("kj,kjn->kn", pts, weights)


def _interval_weights(path: np.ndarray, orders, current=None):
    """The exact second-difference weights of a Fourier map over each sample interval (module docstring,
    "The kernel"): ``A_k = ∫₀¹ x φ(θ(t_k + x T_s)) dx`` and ``B_k = ∫₀¹ (1 − x) φ(θ(t_k + x T_s)) dx``,
    by Gauss–Legendre quadrature; with ``current``, of ``φ i_q`` (the ripple's columns under a current that varies
    within the interval).

    Args:
        path: ``(n_int, nodes)`` angles at the nodes (:func:`_path_angles`).
        orders: ``(n,)`` harmonics per revolution.
        current: ``(n_int, nodes)`` the current at the nodes (A), or ``None``.

    Returns:
        ``(A, B)``, each ``(n_int, 2n)`` (cosines, then sines).
    """
    return _weights_at_nodes(_node_columns(path, orders), current)


def _node_columns(path: np.ndarray, orders) -> np.ndarray:
    """``(2n, nodes, n_int)``: the Fourier rows at every node, in one call (per node, the calls' overhead rather
    than their arithmetic set the time on a chunk's ~1500 intervals)."""
    return harmonic_rows(path.T.ravel(), orders).reshape(-1, *path.T.shape)


def _weights_at_nodes(phi: np.ndarray, current=None):
    """:func:`_interval_weights` from the rows at the nodes ``phi`` ``(2n, nodes, n_int)`` (:func:`_node_columns`)
    and the current at the nodes ``(n_int, nodes)`` (A) or ``None``; ``(A, B)`` each ``(n_int, 2n)``."""
    A = np.zeros((phi.shape[0], phi.shape[2]))
    B = np.zeros_like(A)
    for m, (x, w) in enumerate(zip(_GL_NODES, _GL_WEIGHTS)):
        node = phi[:, m] if current is None else phi[:, m] * current[:, m]
        A += (w * x) * node
        B += (w * (1.0 - x)) * node
    return np.ascontiguousarray(A.T), np.ascontiguousarray(B.T)


def _chunks(prepared, orders: Orders, taps: int, chunk: int = CHUNK_WINDOWS, block_seconds: float = BLOCK_SECONDS,
            lines=(), probes: bool = False):
    """Filtered target and regressor blocks (module docstring), ``chunk`` windows at a time: the Fourier
    columns are built only over the samples a chunk needs, so a basis of hundreds of orders on minutes of
    1 kHz logs stays within a few tens of MB.

    Yields:
        dict of ``(J,)`` / ``(J, k)`` arrays: ``y``, ``acc``, ``rip``, ``cog``, ``dir``, ``visc``, ``sgn``,
        ``block`` (time block of ``block_seconds``, unique over the logs), ``acc_noise`` (the encoder's noise
        variance in ``acc``, (rad/s²)²), ``row`` (each window's first sample in its log), ``log`` (the log's
        position in ``prepared``) and, with ``lines``, ``line`` (``(J, 2 len(lines))``: a cosine and a sine of each time
        frequency of ``lines`` (Hz) over the log's own time, through the current's kernel and filter: a
        time-periodic disturbance, :mod:`pgcomm.rotary.time_lines`); with ``probes``, ``noise_rows``: a list of
        ``(y, rip)`` pairs whose products, summed over the list, are each row's products of the parts that one
        logged current sample puts in ``y`` and ``rip``, summed over the samples (:func:`_current_noise_equations`).
    """
    for chunks in _reading_chunks([prepared], orders, taps, chunk, block_seconds, lines, probes):
        yield chunks[0]


def _angle_part(p, pos: int, k: int, chunk: int, span: int, union, cols, g, g_tri, block_seconds: float,
                need_phi_r: bool) -> dict:
    """What chunk ``k`` of log ``p`` (:class:`_Prepared`) puts in :func:`_reading_chunks`' rows that depends on the angle
    alone (not on the current's reading): ``common`` (the rows' acceleration, cogging, direction and drag columns,
    signs, blocks, noise), the ripple's columns before the current multiplies them (``a_rh``, ``b_rh``
    ``(n_int, 2 n_r)``; ``phi_r`` at the nodes where a smooth current is read) and the chunk's real intervals
    (``steps``)."""
    st = p.starts[k:k + chunk]
    lo, hi = int(st[0]), int(st[-1]) + span
    loc = st - lo
    th, sgn = p.theta[lo:hi], p.sgn[lo:hi]
    n_int = hi - lo - 1
    steps = None if p.t is None else _Steps.of(p.t, lo, hi)
    if steps is None:
        acc = (th[2:] - 2 * th[1:-1] + th[:-2]) / p.ts**2  # acc[i-1] at sample i
        path = _path_angles(_extended(p.theta, lo, hi), n_int)
        t_rows = st * p.ts
    else:
        # the divided difference over the two real intervals around each sample (module docstring)
        tt = p.t[lo:hi]
        acc = ((th[2:] - th[1:-1]) / (tt[2:] - tt[1:-1]) - (th[1:-1] - th[:-2]) / (tt[1:-1] - tt[:-2])) \
            / (0.5 * (tt[2:] - tt[:-2]))
        path = _at_nodes(_extended(p.theta, lo, hi), n_int, steps.at(_GL_NODES))
        t_rows = p.t[st] - p.t[0]
    # the sample at j weighs interval j-1 (held iq[j-1]) rising and interval j (iq[j]) falling
    # the three maps share orders (the slot and pole multiples): their columns in one call
    phi = _node_columns(path, union)
    a_0, b_0 = _weights_at_nodes(phi)
    a_u, b_u = _rise_fall(a_0, b_0, steps)
    a_c, b_c = a_u[:, cols["cogging"]], b_u[:, cols["cogging"]]
    a_d, b_d = a_u[:, cols["direction"]], b_u[:, cols["direction"]]
    sg_i = sgn[:n_int, None]
    common = {"row": st, "log": np.full(st.size, pos), "acc": _filt(acc, loc, g),
              "cog": _filt(a_c, loc, g) + _filt(b_c, loc + 1, g),
              "dir": _filt(sg_i * a_d, loc, g) + _filt(sg_i * b_d, loc + 1, g),
              "visc": _filt(p.w[lo:hi], loc, g_tri),
              "sgn": sgn[loc + span // 2],
              "block": np.floor(t_rows / block_seconds).astype(np.int64) + 100003 * p.index,
              "acc_noise": np.full(st.size, p.acc_noise) + (0.0 if p.timing_noise is None
                                                             else p.timing_noise[st + span // 2])}
    # the ripple's columns are scaled with the current that multiplies them (current_rows)
    return {"common": common, "a_rh": a_0[:, cols["ripple"]], "b_rh": b_0[:, cols["ripple"]],
            "phi_r": np.ascontiguousarray(phi[cols["ripple"]]) if need_phi_r else None, "steps": steps}


class _AngleParts:
    """The angle's part of :func:`_reading_chunks`' rows (:func:`_angle_part`), kept while an identification runs
    (:func:`angle_parts_kept`).

    The search for how the logs were read fits the same logs tens of times under different readings of the
    current; the angle, and so the Fourier columns along the rotor's path (most of a pass's time), is the same in
    most of them. A part is found again by the log it belongs to (the very angle, windows, time and speed arrays,
    held here so that no other array can take their place) and the chunk's key; parts are dropped oldest first
    beyond :attr:`budget` bytes, so minutes of logs fall back to computing each pass afresh.
    """

    def __init__(self, budget: int):
        self.budget = budget
        self.depth = 0
        self._parts: dict = {}
        self._derived: dict = {}
        self._bytes = 0

    def _key(self, p, key):
        # the arrays' identities: each entry holds the arrays themselves, so no other array can take an id it keys on
        return (id(p.theta), id(p.starts), id(p.t), id(p.w), id(p.sgn), p.index, p.ts, p.acc_noise,
                id(p.timing_noise)) + key

    def get(self, p, key):
        """The part kept for chunk ``key`` of log ``p``, or ``None`` (also outside :func:`angle_parts_kept`)."""
        if not self.depth:
            return None
        k = self._key(p, key)
        hit = self._parts.pop(k, None)
        if hit is None:
            return None
        self._parts[k] = hit  # the most recently used last: the oldest go first
        return hit[1]

    def put(self, p, key, part) -> None:
        """Keep ``part`` for chunk ``key`` of log ``p`` (inside :func:`angle_parts_kept`, within the budget)."""
        if not self.depth:
            return
        size = _nbytes(part)
        if size > self.budget:
            return
        while self._parts and self._bytes + size > self.budget:
            self._bytes -= self._parts.pop(next(iter(self._parts)))[2]
        self._parts[self._key(p, key)] = ((p.theta, p.starts, p.t, p.w, p.sgn, p.timing_noise), part, size)
        self._bytes += size

    def derived(self, source: np.ndarray, key, make):
        """``make()``, an array derived from ``source`` alone (e.g. the angle a PLL reading corrects), the same array
        object each time inside :func:`angle_parts_kept`: the parts built on it are then found again."""
        if not self.depth:
            return make()
        k = (id(source),) + tuple(key)
        hit = self._derived.get(k)
        if hit is None:
            hit = self._derived[k] = (source, make())  # the source held: its id stays its own
        return hit[1]

    def clear(self) -> None:
        self._parts.clear()
        self._derived.clear()
        self._bytes = 0


def _nbytes(part) -> int:
    total = 0
    for v in part.values():
        if isinstance(v, np.ndarray):
            total += v.nbytes
        elif isinstance(v, dict):
            total += _nbytes(v)
    return total


#: The angle parts kept while an identification runs, at most this many bytes per thread (about three minutes of
#: 1 kHz logs on a basis of a hundred orders).
ANGLE_PARTS_BUDGET = 256 * 2**20
_THREAD = threading.local()


def _angle_parts() -> _AngleParts:
    """This thread's :class:`_AngleParts`: identifications in threads of one process keep their parts apart."""
    parts = getattr(_THREAD, "parts", None)
    if parts is None:
        parts = _THREAD.parts = _AngleParts(ANGLE_PARTS_BUDGET)
    return parts


@contextmanager
def angle_parts_kept():
    """Keep the angle's part of the regression's rows between passes over the same logs inside this block
    (:class:`_AngleParts`, this thread's), and drop them when it ends. Nested blocks share the outer one's parts."""
    parts = _angle_parts()
    parts.depth += 1
    try:
        yield
    finally:
        parts.depth -= 1
        if not parts.depth:
            parts.clear()


def _reading_chunks(readings, orders: Orders, taps: int, chunk: int = CHUNK_WINDOWS,
                    block_seconds: float = BLOCK_SECONDS, lines=(), probes: bool = False):
    """:func:`_chunks` for several readings of the same logs' current (each a list of :class:`_Prepared` as
    :func:`pgcomm.rotary.readings._with_delay` makes them: the same angle arrays and windows, the current shifted or
    read smooth): what depends on the angle alone, most of the work, is built once per chunk.

    Yields:
        a list of :func:`_chunks`' dicts, one per reading (the angle's arrays shared between them).
    """
    first = readings[0]
    for r in readings[1:]:
        if len(r) != len(first) or any(p.theta is not q.theta or p.starts is not q.starts for p, q in zip(r, first)):
            raise ValueError("readings of the current must share the logs' angle and windows")
    g = _hann(taps)
    n_probes = taps + 4  # the samples one row reads its current from (the smooth reading's cubic reaches one further)
    g_zoh = np.convolve(g, _ZOH)  # (T+1,) on samples s .. s+T
    g_tri = np.convolve(g, _TRI)  # (T+2,) on samples s .. s+T+1
    span = taps + 2
    freqs = 2.0 * np.pi * np.asarray(lines, float)
    union = np.union1d(np.union1d(orders.cogging, orders.ripple), orders.direction)
    cols = {}
    for name in ("cogging", "ripple", "direction"):
        at = np.searchsorted(union, getattr(orders, name))
        cols[name] = np.concatenate([at, union.size + at])
    col_key = b"/".join(cols[name].tobytes() for name in ("cogging", "ripple", "direction"))
    kept = _angle_parts()
    for pos, p in enumerate(first):
        # the probe currents (below), once per log: probe k is 1 on the samples k, k + P, ... (bool: a byte a sample)
        probe_x = ((np.arange(p.theta.size) % n_probes)[None, :] == np.arange(n_probes)[:, None]) if probes else None
        need_phi_r = any(r[pos].lag is not None for r in readings)
        for k in range(0, p.starts.size, chunk):
            key = (pos, k, chunk, span, taps, block_seconds, union.tobytes(), col_key, need_phi_r)
            part = kept.get(p, key)
            if part is None:
                part = _angle_part(p, pos, k, chunk, span, union, cols, g, g_tri, block_seconds, need_phi_r)
                kept.put(p, key, part)
            common, a_rh, b_rh, phi_r, steps = part["common"], part["a_rh"], part["b_rh"], part["phi_r"], part["steps"]
            st = common["row"]
            lo, hi = int(st[0]), int(st[-1]) + span
            loc = st - lo
            n_int = hi - lo - 1

            def current_rows(x, lag):
                """``(y, rip)``: the filtered current and the ripple's columns of this chunk's rows under the current
                ``x`` (the log's ``(N,)`` samples, A), held (``lag`` ``None``) or smooth ``lag`` samples late."""
                if lag is None:
                    xi = x[lo:hi]
                    a_r, b_r = _rise_fall(xi[:n_int, None] * a_rh, xi[:n_int, None] * b_rh, steps)
                    if steps is None:
                        y = _filt(xi, loc, g_zoh)
                    else:
                        rise, fall = _rise_fall(0.5 * xi[:n_int], 0.5 * xi[:n_int], steps)
                        y = _filt(rise, loc, g) + _filt(fall, loc + 1, g)
                else:
                    # the current between snapshots: the cubic through the four around each interval (as the angle's
                    # path), ``lag`` late
                    lw = _lagrange(_GL_NODES - lag) if steps is None else steps.at(_GL_NODES - lag)
                    cur = _at_nodes(_extended(x, lo, hi), n_int, lw)
                    a_r, b_r = _rise_fall(*_weights_at_nodes(phi_r, cur), steps)
                    rise, fall = _rise_fall(cur @ (_GL_WEIGHTS * _GL_NODES), cur @ (_GL_WEIGHTS * (1.0 - _GL_NODES)),
                                            steps)
                    y = _filt(rise, loc, g) + _filt(fall, loc + 1, g)
                return y, _filt(a_r, loc, g) + _filt(b_r, loc + 1, g)

            root = None
            if p.weight is not None:
                # generalised least squares (module docstring, "Weighted rows"): every row and its target scaled by
                # the square root of its weight here, after the kept angle part (which holds no weight), so that every
                # consumer sees the same weighted problem
                w_rows = p.weight[st + span // 2]
                root = np.sqrt(w_rows)
                common = dict(common)
                for name in ("acc", "visc"):
                    common[name] = common[name] * root
                for name in ("cog", "dir"):
                    common[name] = common[name] * root[:, None]
                common["acc_noise"] = common["acc_noise"] * w_rows
            held_line = None
            out = []
            for r in readings:
                q = r[pos]
                ch = dict(common)
                ch["y"], ch["rip"] = _weighed(current_rows(q.iq, q.lag), root)
                if probes:
                    # the rows' sensitivity to each logged current sample: P is the samples one row reads, so no
                    # row reads two of a probe's samples and each probe's rows hold one sample's part of every row
                    ch["noise_rows"] = [_weighed(current_rows(x, q.lag), root) for x in probe_x]
                if lines:
                    if q.lag is None:
                        if held_line is None:
                            at = np.arange(lo, hi) * p.ts if steps is None else p.t[lo:hi] - p.t[0]
                            cs = np.concatenate([np.cos(at[:, None] * freqs), np.sin(at[:, None] * freqs)], axis=1)
                            if steps is None:
                                held_line = _filt(cs, loc, g_zoh)
                            else:
                                rise, fall = _rise_fall(0.5 * cs[:n_int], 0.5 * cs[:n_int], steps)
                                held_line = _filt(rise, loc, g) + _filt(fall, loc + 1, g)
                        ch["line"] = held_line
                    else:
                        # a time-periodic disturbance is smooth in time too: at the nodes' own instants
                        if steps is None:
                            at = (np.arange(lo, hi - 1)[:, None] + _GL_NODES - q.lag) * p.ts
                        else:
                            at = steps.t0[:, None] - p.t[0] + (_GL_NODES - q.lag) * steps.h[:, None]
                        ph = at[:, :, None] * freqs
                        cs = np.concatenate([np.cos(ph), np.sin(ph)], axis=2)  # (n_int, nodes, 2 lines)
                        rise, fall = _rise_fall(np.einsum("knc,n->kc", cs, _GL_WEIGHTS * _GL_NODES),
                                                np.einsum("knc,n->kc", cs, _GL_WEIGHTS * (1.0 - _GL_NODES)), steps)
                        ch["line"] = _filt(rise, loc, g) + _filt(fall, loc + 1, g)
                    if root is not None:
                        ch["line"] = ch["line"] * root[:, None]
                out.append(ch)
            yield out


def _weighed(rows, root):
    """``(y, rip)`` of :func:`_reading_chunks`' rows scaled by the rows' root weights ``root`` ``(J,)`` (or as they
    are where ``None``)."""
    if root is None:
        return rows
    y, rip = rows
    return y * root, rip * root[:, None]


@dataclass
class _Layout:
    """Columns of the regression ``[J/k0, -ripple, -cogging, direction, lines, b]`` for one set of orders: which
    are kept (the sine of order 0 is zero, and a constant in ``r`` is the ``1`` that fixes the scale; a constant
    in ``c`` is a constant torque, :meth:`Orders.for_motor`) and penalised. ``lines`` are time frequencies (Hz) of
    a disturbance (:mod:`pgcomm.rotary.time_lines`): a cosine and a sine per frequency and per log
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
    return _reading_normal_equations([prepared], layout, taps, block_seconds)[0]


def _reading_normal_equations(readings, layout: _Layout, taps: int, block_seconds: float = BLOCK_SECONDS) -> list:
    """:func:`_normal_equations` of each of several readings of the same logs' current (:func:`_reading_chunks`)."""
    p = int(layout.keep.sum())
    acc = [(np.zeros((2, p, p)), np.zeros((2, p)), np.zeros(2), np.zeros(2), np.zeros(2)) for _ in readings]
    for chunks in _reading_chunks(readings, layout.orders, taps, block_seconds=block_seconds, lines=layout.lines):
        val = _is_validation(chunks[0]["block"])
        for ch, (G, b, yy, n, noise) in zip(chunks, acc):
            X, y = layout.rows(ch), ch["y"]
            for k, m in ((0, ~val), (1, val)):
                Xm, ym = X[m], y[m]
                G[k] += Xm.T @ Xm
                b[k] += Xm.T @ ym
                yy[k] += ym @ ym
                n[k] += ym.size
                noise[k] += float(ch["acc_noise"][m].sum())
    return acc


def _current_noise_equations(prepared, layout: _Layout, taps: int, block_seconds: float = BLOCK_SECONDS):
    """What a white noise of unit variance in the logged current adds, in expectation, to the normal equations of
    :func:`_normal_equations` (module docstring, "The current's noise"): ``Σ_rows Σ_j a_j a_jᵀ``, ``a_j`` the part of
    a row's ``[X | y]`` that the current's sample ``j`` sets (the target and the ripple's columns), training and
    validation rows apart.

    Returns:
        ``(Gn (2, p, p), bn (2, p), yyn (2,))``.
    """
    p = int(layout.keep.sum())
    Gn, bn, yyn = np.zeros((2, p, p)), np.zeros((2, p)), np.zeros(2)
    kept = np.flatnonzero(layout.keep)
    rip_keep = layout.keep[layout.o_r]  # the ripple's columns of ``ch["rip"]`` that the layout keeps
    at = np.searchsorted(kept, layout.o_r[rip_keep])  # ... and where they sit among the kept columns
    for ch in _chunks(prepared, layout.orders, taps, block_seconds=block_seconds, lines=layout.lines, probes=True):
        val = _is_validation(ch["block"])
        for y_k, rip_k in ch["noise_rows"]:
            r_k = -rip_k[:, rip_keep]  # the layout's columns are -rip
            for k, m in ((0, ~val), (1, val)):
                rm, ym = r_k[m], y_k[m]
                Gn[k][np.ix_(at, at)] += rm.T @ rm
                bn[k][at] += rm.T @ ym
                yyn[k] += ym @ ym
    return Gn, bn, yyn


def _current_noise_correction(G, b, yy, noise_equations, variance: float):
    """Normal equations corrected for the logged current's white noise of ``variance`` (A²): its expectation
    (:func:`_current_noise_equations`) subtracted, at most :data:`MAX_CURRENT_NOISE_SHARE` of what the ripple's
    columns hold beyond the others (the largest generalised eigenvalue of their noise part over their Schur
    complement, over training and validation rows).

    Returns:
        ``(G, b, yy, applied, share)``: ``applied`` the variance subtracted (A²), ``share`` the noise part's largest
        share at the full variance.
    """
    Gn, bn, yyn = noise_equations
    if variance <= 0.0:
        return G, b, yy, 0.0, 0.0
    Gt, Gnt = G.sum(axis=0), Gn.sum(axis=0)
    idx = np.flatnonzero(np.diag(Gnt) > 0.0)
    if idx.size == 0:
        return G, b, yy, 0.0, 0.0
    d = np.sqrt(np.diag(Gt))
    d[d == 0] = 1.0
    A = Gt / np.outer(d, d)
    A[np.diag_indices_from(A)] += RIDGE_GRID[0] * np.trace(A) / A.shape[0]
    schur = np.linalg.inv(np.linalg.inv(A)[np.ix_(idx, idx)])
    part = variance * Gnt[np.ix_(idx, idx)] / np.outer(d[idx], d[idx])

    share = float(eigh(part, 0.5 * (schur + schur.T), eigvals_only=True)[-1])
    applied = variance * min(1.0, MAX_CURRENT_NOISE_SHARE / share) if share > 0 else variance
    return G - applied * Gn, b - applied * bn, yy - applied * yyn, float(applied), share


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


def _fit(prepared, layout: _Layout, taps: int, ridge: float | None, block_seconds: float = BLOCK_SECONDS,
         current_noise: float = 0.0, current_noise_uncertainty: float = 0.0):
    """Ridge fit of one layout: the weight validated on held-out time blocks (or ``ridge``), the refit on all
    rows, and the estimate's covariance ``A⁻¹ (Σ_b X_bᵀ e_b e_bᵀ X_b) A⁻¹`` (``A`` the regularised normal
    matrix, ``e`` the residuals, ``b`` the one-second blocks): the sandwich that holds when the rows are
    correlated within a block (the overlapping filter windows) and the noise is not white (encoder
    quantisation, friction), as long as the blocks are roughly independent. The normal matrices are
    corrected for the encoder's noise in the acceleration (:func:`_quantisation_correction`), and the
    sandwich's block scores are those of the corrected estimating equation; with ``current_noise`` (the logged
    current's white noise, A) for that noise in the target and the ripple's columns too
    (:func:`_current_noise_correction`; the module docstring, "The current's noise"), whose expectation the block
    scores keep (a little conservative).

    Args:
        current_noise_uncertainty: the share of the current-noise correction taken as uncertain: ``current_shift``
            is the fit's shift were the correction that share smaller.

    Returns:
        dict: ``beta`` (kept columns, unscaled), ``cov``, ``ridge``, ``curve`` (validation MSE per grid
        weight, A²), ``cost`` (mean squared residual, A²), ``rows``, ``blocks``, ``current_noise`` (the variance
        subtracted, A², and the noise part's share, :func:`_current_noise_correction`), ``current_shift``,
        ``quantisation_shift`` (the fit's shift were the encoder-noise correction :data:`QUANTISATION_UNCERTAINTY`
        smaller or, where it was capped, as large as the noise model asks, up to :data:`UNCAPPED_SHARE`: the one that
        moves ``J/k0`` more), ``equations`` (``(G, b, yy, n)`` of :func:`_normal_equations`, as the rows gave them: uncorrected).
    """
    G, b, yy, n, noise = _normal_equations(prepared, layout, taps, block_seconds)
    equations = (G, b, yy, n)
    applied, c_share, noise_eq = 0.0, 0.0, None
    if current_noise > 0.0:
        noise_eq = _current_noise_equations(prepared, layout, taps, block_seconds)
        G, b, yy, applied, c_share = _current_noise_correction(G, b, yy, noise_eq, float(current_noise) ** 2)
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
        if factor < 1.0:
            # capped: the acceleration beyond the maps is mostly noise, and the correction the noise model asks for
            # (up to UNCAPPED_SHARE of what the maps leave) is as likely as the capped one; J/k0 and every map along
            # the rotor's acceleration at speed (a function of the angle at one speed) can move that far
            more = (min(1.0, UNCAPPED_SHARE / share) - factor) * float(np.sum(noise)) / scale[0] ** 2
            A3 = A.copy()
            A3[0, 0] -= more
            try:
                full = cho_solve(cho_factor(A3), (b[0] + b[1]) / scale) / scale - beta
            except np.linalg.LinAlgError:  # the ridge's weight on the other columns left less than that
                full = shift
            if more > 0.0 and abs(full[0]) > abs(shift[0]):
                shift = full
    c_shift = np.zeros_like(beta)
    if applied > 0.0 and current_noise_uncertainty > 0.0:
        u = float(current_noise_uncertainty) * applied
        A2 = A + u * (noise_eq[0][0] + noise_eq[0][1]) / np.outer(scale, scale)
        c_shift = np.linalg.solve(A2, (b[0] + b[1] + u * (noise_eq[1][0] + noise_eq[1][1])) / scale) / scale - beta
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
            "noise_factor": factor, "quantisation_shift": shift,
            "current_noise": {"variance_A2": applied, "share": c_share}, "current_shift": c_shift,
            "equations": equations}


def _full(structured: np.ndarray) -> np.ndarray:
    """Every order from 1 to the basis's highest, and the basis's own (order 0 where it has it)."""
    top = int(np.max(structured, initial=0))
    return np.union1d(np.asarray(structured, int), np.arange(1, top + 1))


#: A map is determined by the logs where its columns keep at least this share of their information (the trace of
#: their Schur complement in the scaled Gram matrix over their own block) once every function of the angle alone, a
#: cogging of every order to the basis's highest, has taken its part: below it the map's variance is inflated more
#: than twentyfold against the same columns alone. Logs at one current per angle (one pass, no dither) leave the
#: ripple 1e-4 of it, logs in one direction the direction map 0-1e-2; logs at two speeds with a dither 0.5-0.9.
DETERMINED_SHARE = 0.05


def information_shares(prepared, orders: Orders, taps: int) -> dict:
    """How much of the ripple's and the direction map's information the logs hold beyond what any function of the
    angle alone explains (:data:`DETERMINED_SHARE`): ``{"ripple": share, "direction": share}``, each the trace of the
    map's Schur complement over its own block of the Gram matrix (columns scaled to unit norm), with the cogging of
    every order to the basis's highest beside it; a map without orders is absent."""
    layout = _Layout.of(Orders(_full(orders.cogging), orders.ripple, orders.direction))
    G = _normal_equations(prepared, layout, taps)[0].sum(axis=0)
    d = np.sqrt(np.diag(G))
    d[d == 0] = 1.0
    G = G / np.outer(d, d)
    kept = np.flatnonzero(layout.keep)
    out = {}
    for name, cols in (("ripple", layout.o_r), ("direction", layout.o_d)):
        m = np.isin(kept, cols)
        if not m.any():
            continue
        g_mo = G[np.ix_(m, ~m)]
        schur = G[np.ix_(m, m)] - g_mo @ np.linalg.pinv(G[np.ix_(~m, ~m)], rcond=1e-12, hermitian=True) @ g_mo.T
        out[name] = float(max(np.trace(schur), 0.0) / max(np.trace(G[np.ix_(m, m)]), 1e-300))
    return out


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

    The mean square ``δᵀ M δ`` (``gram`` = ``M``, :func:`_map_gram`) is a weighted sum of χ²₁ variables with weights
    ``λ``, the eigenvalues of ``Lᵀ Cov L`` (``M = L Lᵀ``); Satterthwaite's approximation takes it as
    ``(Σλ) χ²_ν / ν`` with ``ν = (Σλ)² / Σλ²`` degrees of freedom (exact when the weights are equal). Returns the RMS error (the map's
    units) that the noise part stays below with probability ``level``.
    """
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


def _basis_fit(prepared, layout: "_Layout", taps: int) -> tuple[np.ndarray, float, float]:
    """The ridge-validated fit of ``layout`` (encoder-noise corrected): its coefficients (kept columns), mean squared
    residual (A², from the normal equations) and the rows, ``(beta, cost, rows)``."""
    return _fit_of_normal_equations(_normal_equations(prepared, layout, taps), layout)


def _fit_of_normal_equations(equations, layout: "_Layout") -> tuple[np.ndarray, float, float]:
    """:func:`_basis_fit` from its normal equations (:func:`_normal_equations`).

    The cost is the encoder-noise corrected residual (what the fit leaves of the current beside the acceleration's
    rounding noise), at least :data:`MIN_CORRECTED_SHARE` of the residual on the rows as logged. The corrected
    quadratic form is not a sum of squares: it subtracts ``β_J²`` times the noise, and readings that grow ``J/k0``
    (a report filter read too long) can take it to zero or below where the encoder's noise is a large share of the
    acceleration (a 16-bit encoder polled every few ms). Readings that cost nothing all tie: a 2.1 ms filter was read
    at 10 ms, its cogging four times too large. The floor ranks those by their residual as logged and leaves every
    other ranking as it was."""
    G_raw, b, yy, n, noise = equations
    G, _, _ = _quantisation_correction(G_raw, noise)
    pen = layout.pen[layout.keep].astype(float)
    beta, _, _ = _ridge(G[0] + G[1], b[0] + b[1], n[0] + n[1], pen, _validated_ridge(G, b, yy, n, pen)[0])
    bt, yt = b[0] + b[1], yy[0] + yy[1]
    rows = float(n[0] + n[1])
    corrected, raw = (float(yt - 2 * beta @ bt + beta @ (g[0] + g[1]) @ beta) for g in (G, G_raw))
    return beta, max(corrected, MIN_CORRECTED_SHARE * raw, 1e-300) / max(rows, 1.0), rows


def _unexplained(fit, mean_square: float) -> float:
    """A :func:`_basis_fit`'s cost as the share of the current's mean square (over the same rows, ``mean_square``,
    A²) it leaves unexplained, ``cost / mean(y²)`` (``1 − R²``, uncentred): how readings of the current that change
    its scale are compared.

    A report filter's read-back, ``i_m + τ di_m/dt``, grows the current's moving part by up to ``ω τ``, and with it
    everything in it the model does not explain: the acceleration's noise times a ``J/k0`` that grows with it, the
    noise the read-back amplifies. In amperes, the current as logged then wins by being small: on a real-drive zoo
    motor with a 60 ms filter, a PLL's angle and a 100 Hz dither, the current read at 8 ms fitted better than at the
    true 60 ms, with ``J/k0`` at a seventh of the truth's and the cogging 58 % off. The likelihood of the data as
    logged carries the Jacobian of the read-back; taken as the scale it puts on these data, ``√(mean(y_τ²) /
    mean(y_0²))``, it turns the ratio of the costs into the ratio of the shares unexplained. Where the current's
    moving part is small beside its slow part (a speed loop at constant speed: the ODrive's logs), the share ranks
    the readings as the amperes do (its minimum at 78-92 ms where theirs is at 74-92 ms on ``slow2__nocomp_0``);
    where a dither dominates the current, as the acceleration's residual does (64-80 ms on that zoo motor). The full
    frequency-by-frequency Jacobian, the residual compared per acceleration, and the residual passed back through
    the filter all read the ODrive's filter at 120-200 ms, where the maps from its logs fall to 0.95-0.98
    correlation with its drive's own (0.99 at 78-123 ms)."""
    return fit[1] / mean_square if mean_square > 0 else math.inf


def _basis_cost(prepared, layout: "_Layout", taps: int, relative: bool = False) -> tuple[float, float]:
    """:func:`_basis_fit`'s ``(cost, rows)``; with ``relative``, the share of the current it leaves unexplained
    (:func:`_unexplained`)."""
    equations = _normal_equations(prepared, layout, taps)
    fit = _fit_of_normal_equations(equations, layout)
    return _relative(fit, equations) if relative else fit[1:]


def _relative(fit, equations) -> tuple[float, float]:
    """``(share unexplained, rows)`` of a fit from its normal equations (:func:`_unexplained`)."""
    return _unexplained(fit, float(equations[2][0] + equations[2][1]) / max(fit[2], 1.0)), fit[2]


def _basis_costs(readings, layout: "_Layout", taps: int, relative: bool = False) -> list:
    """:func:`_basis_cost` of each of several readings of the same logs' current, in one pass over the angle
    (:func:`_reading_chunks`)."""
    out = []
    for e in _reading_normal_equations(readings, layout, taps):
        fit = _fit_of_normal_equations(e, layout)
        out.append(_relative(fit, e) if relative else fit[1:])
    return out


def _evidence(cost_plain: float, cost_best: float, rows: float, taps: int) -> float:
    """``n_eff ln(cost_plain / cost_best)``, ``n_eff`` the rows times ``stride / span`` (the filter windows overlap):
    the likelihood ratio of a better-fitting reading of the logs over the logs as written."""
    n_eff = rows * max(1, taps // 2) / (taps + 2)
    return n_eff * math.log(cost_plain / cost_best) if cost_plain > 0 else 0.0


def _residuals(prepared, layout: "_Layout", taps: int, beta: np.ndarray) -> list:
    """Per log, ``(rows, e)``: each used window's first sample and the fit's residual there (A)."""
    out = [([], []) for _ in prepared]
    for ch in _chunks(prepared, layout.orders, taps, lines=layout.lines):
        out[ch["log"][0]][0].append(ch["row"])
        out[ch["log"][0]][1].append(ch["y"] - layout.rows(ch) @ beta)
    return [(np.concatenate(r), np.concatenate(e)) for r, e in out]
