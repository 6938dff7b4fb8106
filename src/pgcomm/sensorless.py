"""Identification without a force sensor: the driving force from the motion.

A coil set driving the translator alone obeys (DESIGN.md, "Without a force sensor")::

    m ÿ = F_y(y, i) - c ẏ - F_c s(ẏ)        F_y = K_y(y) i + F_cog,y(y)   (+ what the plant adds)

With the moving mass ``m`` given (only ``k/m`` is observable from motion), ``m ÿ`` is the
measured side; viscous ``c`` and Coulomb ``F_c`` friction are more linear parameters that
Proposition 1 eliminates with ``θ_L``. A direction-dependent force of the motor and Coulomb
friction are the same column ``s(ẏ)``, so there is no separate direction term.

The Coulomb friction may vary along the stroke (guides, cable slab; and so may the motor's
direction-dependent force, which it includes): ``F_c(y)`` is piecewise linear on knots a quarter
pole pitch apart (half a magnet, so a force that changes magnet by magnet is resolved; at most
``MAX_FRICTION_BINS`` bins), columns ``s(ẏ) φ_j(y)``. A constant ``F_c`` left a stroke-varying
direction force unexplained, and the closed loop put it into the currents, which biased the
identified gain: on the default twin (±35 % ripple of a 3 N direction force) the gain came out
3.4 % low with a constant ``F_c``; a linear fit of the true gain shape with the table is within
0.1 % (0.2 % with knots half a pole pitch apart). Only the y row
is observable; the x and z rows come from the classical model with the calibrated ``k``, ``ζ``
(:func:`with_classical_rows`).

**The filter** (one, applied to ``ÿ`` and to every regressor column alike). Positions are
differentiated twice by the second difference ``Δ²y[i] = y[i+1] - 2y[i] + y[i-1]``; a drive
holds the current over a sample (zero-order hold), and then exactly
``Δ²y[i] = T_s²/(2m) (F[i-1] + F[i])`` (friction aside): the second difference is centred half a
sample after the force samples. Both sides are smoothed by one symmetric (zero-phase) Hann
window ``g`` of ``T`` samples, and the regressor side also gets the half-sample average::

    m ÿ_f[j] = m Σ_k g_k Δ²y[s_j + k + 1] / T_s²   =   Σ_m g'_m M(s_j + m) θ_L,   g' = g * [½, ½]

Why this filter: a finite window (FIR) has an exact, local inverse problem (every output
sample is one equation on ``T + 1`` samples, so the chunked identification can evaluate it
without the whole series in memory) and no phase. The noise of ``Δ²y`` (encoder quanta) grows as
``f²``; the Hann window's side lobes fall 18 dB per octave, and its noise gain on ``Δ²y`` falls
as ``T^{-2.5}``: a 0.1 µm encoder at 1 ms gives 0.08 N rms on a 30 kg translator with a 10 ms
window. The window must stay short against the electrical period of the fastest motion
(``d_m / v``), else the position dependence of the regressor averages out: its length is
``WINDOW_POLE_SHARE · d_m / v_95`` (``v_95`` the 95th percentile of the speed), clipped to
``[MIN_WINDOW_SAMPLES, MAX_WINDOW]``. Output samples are taken every ``T/2`` samples
(consecutive outputs would repeat the same information; on the default twin ``T/4`` gave the same
gain within 0.01 % in twice the time).

Windows in which the translator is slower than ``v_min`` anywhere (standstill, reversals) are
left out: there stiction and the shape of the friction curve are not the model's.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pgcomm.data import CoilSetData, split_indices
from pgcomm.errors import DataError
from pgcomm.interp import hat_basis
from pgcomm.models import physics_from_ideal

#: Window length in pole pitches travelled at the fast speed ``v_95`` (see the module docstring).
WINDOW_POLE_SHARE = 0.1
#: Shortest window (samples): below this the noise gain of ``Δ²y`` explodes (``∝ T^{-2.5}``).
MIN_WINDOW_SAMPLES = 8
#: Longest window (s).
MAX_WINDOW = 0.2
#: Windows with a speed below ``max(MIN_SPEED_VEPS · v_ε, MIN_SPEED_SHARE · v_95)`` anywhere are left out.
MIN_SPEED_VEPS = 5.0
MIN_SPEED_SHARE = 0.02
#: The data must accelerate: at least ``MIN_ACCEL_WINDOWS`` windows with ``|ÿ_f| >= MIN_ACCELERATION`` (m/s²)
#: per experiment, else mass and friction cannot be told from the gain.
MIN_ACCELERATION = 0.2
MIN_ACCEL_WINDOWS = 10
#: Share of samples at the drive's current limit above which a log is refused (the logged
#: current is then the demand, not what flowed).
MAX_SATURATED_SHARE = 0.01
#: Knot spacing of the Coulomb friction table ``F_c(y)``, in pole pitches, and the most bins.
FRICTION_KNOT_PITCH = 0.25
MAX_FRICTION_BINS = 64


@dataclass(frozen=True)
class AccelerationFilter:
    """The one zero-phase filter of sensorless identification (module docstring).

    Attributes:
        taps: ``(T,)`` Hann window, sum 1 (applied to ``Δ²y / T_s²``).
        stride: samples between output samples (``max(1, T // 2)``).
        sample_time: ``T_s`` (s).
    """

    taps: np.ndarray
    stride: int
    sample_time: float

    @classmethod
    def for_motion(cls, velocity, sample_time: float, pole_pitch: float) -> "AccelerationFilter":
        """The filter for a motion with velocity samples ``velocity`` (m/s), ``T_s`` (s), ``d_m`` (m)."""
        speed = np.abs(np.asarray(velocity, float))
        v95 = float(np.percentile(speed, 95)) if speed.size else 0.0
        window = WINDOW_POLE_SHARE * pole_pitch / v95 if v95 > 0 else MAX_WINDOW
        n = int(round(min(window, MAX_WINDOW) / sample_time))
        return cls.of_length(max(MIN_WINDOW_SAMPLES, n), sample_time)

    @classmethod
    def of_length(cls, n_taps: int, sample_time: float) -> "AccelerationFilter":
        """Hann window of ``n_taps`` samples (>= 2), stride ``n_taps // 2``."""
        n = int(n_taps)
        if n < 2:
            raise ValueError(f"the acceleration filter needs at least 2 taps, got {n}")
        g = np.hanning(n + 2)[1:-1]  # no zero end taps
        return cls(g / g.sum(), max(1, n // 2), float(sample_time))

    @property
    def length(self) -> int:
        """``T`` (samples)."""
        return int(self.taps.shape[0])

    @property
    def window(self) -> float:
        """Window length ``T T_s`` (s)."""
        return self.length * self.sample_time

    @property
    def regressor_taps(self) -> np.ndarray:
        """``g' = g * [½, ½]``: ``(T + 1,)`` taps applied to the regressor samples ``s_j .. s_j + T``."""
        return 0.5 * (np.concatenate([self.taps, [0.0]]) + np.concatenate([[0.0], self.taps]))

    @property
    def span(self) -> int:
        """Samples of ``y`` one output needs: ``s_j .. s_j + T + 1``."""
        return self.length + 2

    def to_dict(self) -> dict:
        return {"kind": "hann", "taps": self.length, "window_s": self.window, "stride": self.stride}


def window_starts(filt: AccelerationFilter, segments, keep=None) -> np.ndarray:
    """Starts ``s_j`` (every ``stride``-th) of the windows ``[s_j, s_j + T + 1]`` inside one segment.

    Args:
        segments: ``(N,)`` labels (a window never crosses a label change, e.g. two logs).
        keep: ``(N,)`` bool or ``None``: windows must lie where ``keep`` is true throughout.
    """
    labels = np.asarray(segments)
    n = labels.shape[0]
    span = filt.span
    if n < span:
        return np.zeros(0, int)
    bad = np.zeros(n, bool)
    bad[1:] = labels[1:] != labels[:-1]  # a window may not contain a sample whose label differs from its start's
    if keep is not None:
        bad |= ~np.asarray(keep, bool)
    # s is valid when no "bad" (change or excluded) lies in (s, s + span - 1] and s itself is kept
    c = np.concatenate([[0], np.cumsum(bad)])
    s = np.arange(0, n - span + 1)
    changes = c[s + span] - c[s + 1]
    ok = changes == 0
    if keep is not None:
        ok &= np.asarray(keep, bool)[s]
    starts = s[ok]
    # every stride-th valid start, restarting the count in every run of valid starts
    if starts.size == 0:
        return starts
    run = np.concatenate([[0], np.cumsum(np.diff(starts) != 1)])
    first = np.concatenate([[0], np.flatnonzero(np.diff(run)) + 1])
    offset = np.arange(starts.size) - np.repeat(first, np.diff(np.concatenate([first, [starts.size]])))
    return starts[offset % filt.stride == 0]


def moving_windows(filt: AccelerationFilter, velocity, segments, friction_velocity: float, keep=None):
    """``(starts, v_min)``: the windows (:func:`window_starts`) in which the translator moves faster than
    ``v_min = max(MIN_SPEED_VEPS · v_ε, MIN_SPEED_SHARE · v_95)`` (m/s) throughout (and ``keep`` holds).

    Args:
        velocity: ``(N,)`` m/s; segments: ``(N,)`` labels; friction_velocity: ``v_ε`` (m/s);
        keep: ``(N,)`` bool or ``None``.
    """
    speed = np.abs(np.asarray(velocity, float))
    v95 = float(np.percentile(speed, 95)) if speed.size else 0.0
    v_min = max(MIN_SPEED_VEPS * friction_velocity, MIN_SPEED_SHARE * v95)
    moving = speed > v_min
    return window_starts(filt, segments, moving if keep is None else moving & keep), v_min


def filter_windows(filt: AccelerationFilter, starts, columns) -> np.ndarray:
    """``Σ_m g'_m x[s_j + m]`` for columns ``x`` ``(N,)`` or ``(N, k)``: ``(J,)`` or ``(J, k)``."""
    x = np.asarray(columns, float)
    idx = np.asarray(starts)[:, None] + np.arange(filt.length + 1)
    return np.tensordot(x[idx], filt.regressor_taps, axes=([1], [0])) if x.ndim == 1 else \
        np.einsum("jmk,m->jk", x[idx], filt.regressor_taps)


def filtered_acceleration(filt: AccelerationFilter, starts, y) -> np.ndarray:
    """``ÿ_f[j] = Σ_k g_k Δ²y[s_j + k + 1] / T_s²`` (m/s²), ``(J,)``."""
    y = np.asarray(y, float)
    idx = np.asarray(starts)[:, None] + np.arange(filt.length)
    d2 = y[idx + 2] - 2.0 * y[idx + 1] + y[idx]
    return d2 @ filt.taps / filt.sample_time**2


@dataclass(frozen=True)
class FrictionFit:
    """The translator's friction identified with the y row from the motion (one coil set's experiments).

    Attributes:
        mass: the given moving mass ``m`` (kg).
        coulomb: mean of the Coulomb table over its knots' span (trapezoid), N.
        viscous: viscous coefficient ``f_v`` (N s/m).
        coulomb_table, coulomb_knots: the piecewise-linear Coulomb table ``F_c(y)`` (N) at its knots (m).
        friction_velocity: ``v_ε`` (m/s) of the smooth sign ``tanh(ẏ/v_ε)``.
        filter: the zero-phase acceleration filter the fit used.
        windows: filtered windows fitted.
    """

    mass: float
    coulomb: float
    viscous: float
    coulomb_table: tuple[float, ...]
    coulomb_knots: tuple[float, ...]
    friction_velocity: float
    filter: AccelerationFilter
    windows: int

    def to_dict(self) -> dict:
        """JSON-ready: every field, lists for the table (model files and results.json hold this)."""
        return {"mass": self.mass, "coulomb": self.coulomb, "viscous": self.viscous,
                "coulomb_table": list(self.coulomb_table), "coulomb_knots": list(self.coulomb_knots),
                "friction_velocity": self.friction_velocity, "filter": self.filter.to_dict(), "windows": self.windows}


@dataclass(frozen=True)
class SensorlessData:
    """One coil set's data for identification without a force sensor (module docstring).

    ``n`` is the number of output samples (filtered windows), and ``force`` ``(n, 3)`` the
    measured side ``[m ÿ_f, 0, 0]`` (N): only the driving direction is observed.

    Attributes:
        raw: the samples (positions, currents, velocity, experiment labels; its ``force`` is unused).
        starts: ``(J,)`` window starts into ``raw``.
        target: ``(J,)`` ``m ÿ_f`` (N).
        filt: the :class:`AccelerationFilter`.
        mass: moving mass ``m`` (kg), given.
        friction_velocity: ``v_ε`` (m/s) of the Coulomb columns ``tanh(ẏ/v_ε) φ_j(y)``.
        friction_knots: ``(B + 1,)`` knots (m) of the Coulomb friction table ``F_c(y)``.
    """

    raw: CoilSetData
    starts: np.ndarray
    target: np.ndarray
    filt: AccelerationFilter
    mass: float
    friction_velocity: float
    friction_knots: np.ndarray

    @property
    def n(self) -> int:
        return int(self.starts.shape[0])

    @property
    def name(self) -> str:
        return self.raw.name

    @property
    def y(self) -> np.ndarray:
        """Positions of the samples the windows cover (m)."""
        return self.raw.y[self.window_index().ravel()] if self.n else self.raw.y[:0]

    @property
    def velocity(self) -> np.ndarray:
        return self.raw.velocity

    @property
    def force(self) -> np.ndarray:
        return np.column_stack([self.target, np.zeros((self.n, 2))])

    #: Rows of ``force`` that are measured: only the driving direction ``m ÿ_f``.
    observed = (0,)

    def window_index(self) -> np.ndarray:
        """``(J, T + 1)`` indices into ``raw`` of each window's regressor samples."""
        return self.starts[:, None] + np.arange(self.filt.length + 1)

    @property
    def regressor_taps(self) -> np.ndarray:
        """``(T + 1,)`` taps of a window's regressor rows (:attr:`AccelerationFilter.regressor_taps`)."""
        return self.filt.regressor_taps

    def physics_nuisance(self, pole_pitch: float) -> np.ndarray:
        """``(J, B)`` filtered position-only columns (hat basis over the data's range, ``d_m/4`` apart, 4 to 200)
        for the physics-only fit: in closed loop the current carries ``-F_cog/k``, so leaving the cogging
        out biases ``k`` low (~0.5x); these columns stand in for it, as the calibration's offset tables do."""
        y = self.raw.y
        lo, hi = float(y.min()), float(y.max())
        bins = int(np.clip((hi - lo) / (pole_pitch / 4), 4, 200))
        return self.filtered(hat_basis(y, lo, hi, bins))

    def filtered(self, columns) -> np.ndarray:
        """Filtered raw columns ``(N,)``/``(N, k)`` at the output samples (:func:`filter_windows`)."""
        return filter_windows(self.filt, self.starts, columns)

    @property
    def n_friction(self) -> int:
        """Number of friction columns: ``B + 1`` Coulomb table entries and the viscous column."""
        return int(self.friction_knots.shape[0]) + 1

    def friction_columns(self) -> np.ndarray:
        """``(N, B + 2)`` raw friction regressors ``[tanh(ẏ/v_ε) φ_0(y) … φ_B(y), ẏ]`` (-, m/s)."""
        v, k = self.raw.velocity, self.friction_knots
        hats = hat_basis(self.raw.y, float(k[0]), float(k[-1]), k.shape[0] - 1)
        return np.column_stack([hats * np.tanh(v / self.friction_velocity)[:, None], v])

    def filtered_friction(self) -> np.ndarray:
        """``(J, B + 2)`` filtered friction columns: ``Σ_k g_k x[s_j + k + 1]``, without the half-sample average.

        The second difference weighs a force that varies within the samples (friction of the
        continuous velocity) by a triangle centred on its middle sample, not as the held current's
        ``(F[i-1] + F[i]) / 2``: with the average, the viscous term ``c ẏ`` lags half a sample, which
        looks like ``c T_s / 2`` more mass and biased the gain (-0.13 % on the default twin).
        """
        cols = self.friction_columns()
        idx = self.starts[:, None] + 1 + np.arange(self.filt.length)
        return np.einsum("jmk,m->jk", cols[idx], self.filt.taps)

    def mechanics(self, friction) -> "FrictionFit":
        """Friction (opposing motion) from the fitted coefficients of :meth:`friction_columns`.

        Args:
            friction: ``(K + 1,)`` fitted coefficients (the Coulomb table's ``K`` knots, then viscous).
        """
        f = -np.asarray(friction, float)  # the columns enter with the force: m ÿ = F + θ_f cols
        table = f[:-1]
        w = np.full(table.shape[0], 1.0)
        if w.size > 1:
            w[[0, -1]] = 0.5
        return FrictionFit(mass=float(self.mass), coulomb=float(w @ table / w.sum()), viscous=float(f[-1]),
                           coulomb_table=tuple(float(x) for x in table),
                           coulomb_knots=tuple(float(x) for x in self.friction_knots),
                           friction_velocity=float(self.friction_velocity), filter=self.filt, windows=int(self.n))

    def take(self, index) -> "SensorlessData":
        """The output samples ``index``."""
        return dataclasses.replace(self, starts=self.starts[index], target=self.target[index])

    def split(self, validation_fraction: float = 0.2, block_size: int = 500):
        """``(train, validation)`` by contiguous blocks of output samples (``block_size`` raw samples each)."""
        tr, va = split_indices(self.n, validation_fraction, max(1, block_size // self.filt.stride))
        return self.take(tr), self.take(va)


def sensorless_data(data: CoilSetData, sample_time: float, pole_pitch: float, mass: float, *,
                    current_limit: float | None = None, friction_velocity: float = 1e-3,
                    filt: AccelerationFilter | None = None) -> SensorlessData:
    """Build :class:`SensorlessData` from one coil set's samples (its ``force`` is ignored).

    Args:
        data: positions (m), currents (A), velocity (m/s; from the positions if missing) and
            experiment labels (windows never cross a label change).
        sample_time: ``T_s`` (s); pole_pitch: ``d_m`` (m); mass: moving mass ``m`` (kg).
        current_limit: the drive's peak current (A); samples at the limit are refused.
        friction_velocity: ``v_ε`` (m/s) of the Coulomb column.
        filt: the filter, default :meth:`AccelerationFilter.for_motion`.

    Raises:
        DataError: saturated currents, no window where the translator moves, or an
            experiment without acceleration (message names the coil set and experiment).
    """
    if not (mass is not None and np.isfinite(mass) and mass > 0):
        raise DataError(f"{data.name}: identification without a force sensor needs the moving mass (kg): "
                        f"set mass in the motor TOML (got {mass!r})")
    if data.velocity is None:
        data = data.with_velocity(sample_time)
    name = data.name
    if current_limit:
        sat = np.max(np.abs(_phase_currents(data.currents)), axis=1) >= 0.999 * current_limit
        if sat.mean() > MAX_SATURATED_SHARE:
            raise DataError(f"{name}: currents at the drive's limit {current_limit:g} A in {100 * sat.mean():.1f} % "
                            f"of the samples (first at row {int(np.argmax(sat))}); saturated samples do not obey "
                            "m ÿ = F(y, i): log slower or lighter motions")
    else:
        sat = np.zeros(data.n, bool)
    filt = filt or AccelerationFilter.for_motion(data.velocity, sample_time, pole_pitch)
    starts, v_min = moving_windows(filt, data.velocity, data.experiment, friction_velocity, ~sat)
    if starts.size == 0:
        raise DataError(f"{name}: no window of {filt.span} samples ({1e3 * filt.span * sample_time:.0f} ms) in "
                        f"which the translator moves faster than {1e3 * v_min:.3g} mm/s; the logs are too short "
                        "or too slow for identification without a force sensor")
    acc = filtered_acceleration(filt, starts, data.y)
    exp = data.experiment[starts]
    for e in np.unique(data.experiment):
        n_acc = int(np.sum((exp == e) & (np.abs(acc) >= MIN_ACCELERATION)))
        if n_acc < MIN_ACCEL_WINDOWS:
            raise DataError(f"{name}: no acceleration above {MIN_ACCELERATION:g} m/s^2 in Z_{int(e) + 1} "
                            f"({n_acc} of {int(np.sum(exp == e))} moving windows); without acceleration the mass "
                            "and friction cannot be told from the motor force")
    covered = data.y[(starts[:, None] + np.arange(filt.span)).ravel()]
    lo, hi = float(covered.min()), float(covered.max())
    bins = int(np.clip(np.ceil((hi - lo) / (FRICTION_KNOT_PITCH * pole_pitch)), 1, MAX_FRICTION_BINS))
    return SensorlessData(data, starts, mass * acc, filt, float(mass), float(friction_velocity),
                          np.linspace(lo, hi, bins + 1))


def _phase_currents(star):
    """``(N, 3)`` phase currents of star currents ``(N, 2)`` ``(ia, ib)`` (``ic = -ia - ib``)."""
    star = np.asarray(star, float)
    return np.column_stack([star, -star.sum(axis=1)])


def with_classical_rows(model, k: float, zeta: float, mu: float, lever_arm: float):
    """Copy of a sensorless :class:`~pgcomm.models.CoilSetModel` whose x and z rows are the classical model.

    The y row (identified from the motion) is kept; the Fx and Tz rows become the ideal motor's
    with the calibrated ``k`` (N/A), ``ζ`` (rad), nominal ``μ`` (-) and lever arm (m)
    (:func:`pgcomm.models.physics_from_ideal`): no network, cogging, harmonic or direction part.
    """
    a, b = physics_from_ideal(model.pole_pitch, k, zeta, mu, lever_arm)

    def y_row_only(w, axis=-1):  # output columns / rows are the directions [Fy, Fx, Tz]
        w = np.array(w, float)
        w[(slice(None),) * (w.ndim + axis if axis < 0 else axis) + (slice(1, None),)] = 0.0
        return w

    A, B = np.array(model.A, float), np.array(model.B, float)
    A[1:], B[1:] = a[1:], b[1:]
    gain = None if model.gain_nets is None else tuple((y_row_only(n.W_out), y_row_only(n.b_out))
                                                      for n in model.gain_nets)
    cog = None if model.cog_net is None else (y_row_only(model.cog_net.W_out), y_row_only(model.cog_net.b_out))
    H = None if model.H is None else y_row_only(model.H, axis=1)
    C = None if model.C is None else y_row_only(model.C)
    return model.with_outputs(A, B, gain, cog, H, C)


__all__ = ["AccelerationFilter", "FrictionFit", "SensorlessData", "sensorless_data", "window_starts", "filter_windows",
           "filtered_acceleration", "with_classical_rows"]
