"""Position references: third-order (jerk-limited) point-to-point profiles.

The paper generates its identification data with "several third order
trajectories moving from -0.1 to 0.1 m" at maximum velocities 0.025, 0.075 and
0.15 m/s, acceleration 1 m/s^2 and jerk 1000 m/s^3 (§Experiments,
Fig. Data_Generation). This module builds such references:

* :func:`third_order_profile` - the continuous-time 7-segment profile of one
  move, with its switching times computed in closed form;
* :func:`point_to_point` - that profile sampled at ``k * sample_time``;
* :func:`sequence` - several moves with dwell times in between;
* :func:`data_generation_reference`, :func:`single_velocity_reference` - the
  paper's references;
* :func:`reference_from_positions` - a reference from sampled positions (a user's
  own file is read by :func:`pgcomm.io.references.read_reference`).

All quantities are SI: time s, position m, velocity m/s, acceleration m/s^2,
jerk m/s^3. A :class:`Reference` holds equally spaced samples of all five.

The 7 segments of a move (jerk ``+j, 0, -j, 0, -j, 0, +j``) are symmetric in
time: ``v(T - t) = v(t)``. The code uses this symmetry to evaluate the second
half backwards from the target, so the profile ends *exactly* on ``q1`` with
zero velocity and acceleration instead of accumulating rounding errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
import numpy as np

from pgcomm.errors import ConfigError, DataError

__all__ = [
    "INITIAL_DWELL",
    "Reference",
    "ThirdOrderProfile",
    "third_order_profile",
    "point_to_point",
    "sequence",
    "data_generation_reference",
    "single_velocity_reference",
]

#: Rest time (s) at the start position before the first move of the paper's
#: references, so that a closed loop starts from a settled state.
INITIAL_DWELL = 0.1

#: Relative tolerance on the spacing of a time column read from a file.
_UNIFORM_RTOL = 1e-6

#: Guard against a typo in the sample time (e.g. 1e-9 instead of 1e-3) silently
#: allocating tens of gigabytes.
_MAX_SAMPLES = 50_000_000

#: Times within this fraction of the move time of a switching time count as
#: at it when the (discontinuous) jerk is evaluated.
_KNOT_SNAP = 1e-12

#: A sample within this fraction of a sample period before the end of a move
#: counts as "at the end": guards ``ceil(T / Ts)`` against rounding in ``T``.
_END_SLACK = 1e-9


# ---------------------------------------------------------------------------
# Reference container
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Reference:
    """Equally spaced samples of a position reference and its derivatives.

    Attributes:
        t: ``(N,)`` sample times (s), spaced by ``sample_time``.
        r: ``(N,)`` position (m).
        v: ``(N,)`` velocity (m/s).
        a: ``(N,)`` acceleration (m/s^2).
        j: ``(N,)`` jerk (m/s^3).
        sample_time: sample period (s).

    The arrays are float64 copies and read-only (the dataclass is frozen).
    ``eq=False``: comparing array-valued dataclasses with ``==`` is ambiguous,
    compare the fields with ``numpy`` instead.
    """

    t: np.ndarray
    r: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray
    sample_time: float

    def __post_init__(self):
        sample_time = _as_positive("Reference.sample_time", self.sample_time, "s", DataError)
        object.__setattr__(self, "sample_time", sample_time)
        n = None
        for name in ("t", "r", "v", "a", "j"):
            arr = np.array(getattr(self, name), dtype=np.float64)
            if arr.ndim != 1:
                raise DataError(f"Reference.{name} must be a 1-D array, got shape {arr.shape}")
            if n is None:
                n = arr.shape[0]
            elif arr.shape[0] != n:
                raise DataError(f"Reference.{name} has {arr.shape[0]} samples, Reference.t has {n}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if n == 0:
            raise DataError("Reference must hold at least one sample, got 0")

    def __len__(self) -> int:
        """Number of samples ``N``."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return float(self.t[-1] - self.t[0])

    def concat(self, other: Reference) -> Reference:
        """Append ``other`` after this reference; time continues.

        The first sample of ``other`` is placed one ``sample_time`` after the
        last sample of ``self``. Positions are not shifted: to get a continuous
        position, ``other`` must start where ``self`` ends.

        Args:
            other: reference with the same ``sample_time`` (within 1e-9 relative).

        Returns:
            A new :class:`Reference` with ``len(self) + len(other)`` samples.
        """
        if not isinstance(other, Reference):
            raise TypeError(f"Reference.concat expects a Reference, got {type(other).__name__}")
        if not math.isclose(self.sample_time, other.sample_time, rel_tol=1e-9, abs_tol=0.0):
            raise DataError(
                f"cannot concatenate references with sample times {self.sample_time!r} s "
                f"and {other.sample_time!r} s; resample one of them first"
            )
        t_other = other.t - other.t[0] + self.t[-1] + self.sample_time
        return Reference(
            t=np.concatenate([self.t, t_other]),
            r=np.concatenate([self.r, other.r]),
            v=np.concatenate([self.v, other.v]),
            a=np.concatenate([self.a, other.a]),
            j=np.concatenate([self.j, other.j]),
            sample_time=self.sample_time,
        )


# ---------------------------------------------------------------------------
# Continuous-time third-order profile
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class ThirdOrderProfile:
    """Continuous-time jerk-limited move from ``q0`` to ``q1`` (all SI).

    Seven segments with jerk ``s*[+j, 0, -j, 0, -j, 0, +j]`` (``s`` the direction
    sign) and durations ``[t_j, t_a, t_j, t_v, t_j, t_a, t_j]``:

    Attributes:
        q0, q1: start and end position (m).
        t_j: duration of each constant-jerk segment (s).
        t_a: duration of each constant-acceleration segment (s), 0 if ``a_max``
            is not reached.
        t_v: duration of the constant-velocity segment (s), 0 if ``v_max`` is
            not reached.
        v_peak, a_peak, j_max: reached magnitudes (m/s, m/s^2, m/s^3).
    """

    q0: float
    q1: float
    t_j: float
    t_a: float
    t_v: float
    v_peak: float
    a_peak: float
    j_max: float

    @property
    def direction(self) -> float:
        """+1.0 for ``q1 >= q0``, else -1.0."""
        return 1.0 if self.q1 >= self.q0 else -1.0

    @property
    def duration(self) -> float:
        """Total move time ``T = 4 t_j + 2 t_a + t_v`` (s)."""
        return 4.0 * self.t_j + 2.0 * self.t_a + self.t_v

    @property
    def switching_times(self) -> np.ndarray:
        """``(8,)`` segment boundaries from 0 to ``T`` (s), including both ends.

        The second half is ``T`` minus the first, as the mirrored evaluation uses.
        """
        first = np.array([0.0, self.t_j, self.t_j + self.t_a, 2.0 * self.t_j + self.t_a])
        return np.concatenate([first, self.duration - first[::-1]])

    def _first_half_knots(self):
        """Knot times and (x, v, a, jerk) at the start of segments 1..4.

        ``x`` is the unsigned distance travelled from ``q0``. Each state follows
        from the previous one by the exact cubic of its segment.
        """
        tj, ta, j = self.t_j, self.t_a, self.j_max
        jerks = (j, 0.0, -j, 0.0)
        durations = (tj, ta, tj)
        taus = [0.0]
        states = [(0.0, 0.0, 0.0)]
        x, v, a = 0.0, 0.0, 0.0
        for jk, dt in zip(jerks[:3], durations):
            x = x + v * dt + a * dt**2 / 2.0 + jk * dt**3 / 6.0
            v = v + a * dt + jk * dt**2 / 2.0
            a = a + jk * dt
            taus.append(taus[-1] + dt)
            states.append((x, v, a))
        # The acceleration after segment 3 is 0 analytically; pin it so the
        # cruise segment is exactly flat.
        x3, v3, _ = states[3]
        states[3] = (x3, v3, 0.0)
        return np.array(taus), np.array(states), np.array(jerks)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration and jerk at times ``t``.

        Args:
            t: array-like of times (s), any shape ``S``; time 0 is the start of
                the move. Before 0 the profile rests at ``q0``, from ``T`` on at
                ``q1``.

        Returns:
            ``(r, v, a, j)``, each of shape ``S``, in m, m/s, m/s^2, m/s^3. The
            jerk is right-continuous (the value on ``[t, t + dt)``).
        """
        t = np.asarray(t, dtype=np.float64)
        shape = t.shape
        t = t.ravel()
        big_t = self.duration
        s = self.direction
        knots, states, jerks = self._first_half_knots()

        r = np.full(t.shape, self.q0)
        v = np.zeros(t.shape)
        a = np.zeros(t.shape)
        r[t >= big_t] = self.q1

        def poly(tau):
            idx = np.clip(np.searchsorted(knots, tau, side="right") - 1, 0, 3)
            x0, v0, a0 = states[idx, 0], states[idx, 1], states[idx, 2]
            jk = jerks[idx]
            dt = tau - knots[idx]
            x = x0 + v0 * dt + a0 * dt**2 / 2.0 + jk * dt**3 / 6.0
            vv = v0 + a0 * dt + jk * dt**2 / 2.0
            aa = a0 + jk * dt
            return x, vv, aa

        half = 0.5 * big_t
        fwd = (t >= 0.0) & (t < half)
        bwd = (t >= half) & (t < big_t)
        if np.any(fwd):
            x, vv, aa = poly(t[fwd])
            r[fwd] = self.q0 + s * x
            v[fwd] = s * vv
            a[fwd] = s * aa
        if np.any(bwd):
            # Mirror image: distance measured back from q1, v even, a odd.
            x, vv, aa = poly(big_t - t[bwd])
            r[bwd] = self.q1 - s * x
            v[bwd] = s * vv
            a[bwd] = -s * aa

        # The jerk is discontinuous, so its value exactly at a switching time
        # would depend on the last bit of t. Times within _KNOT_SNAP * T of a
        # switching time count as at it: a sample on a switching time gets the
        # jerk of the segment starting there (zero-length segments skipped).
        sw = self.switching_times
        tol = _KNOT_SNAP * big_t
        seg = np.searchsorted(sw, t + tol, side="right") - 1
        inside = (seg >= 0) & (seg < 7)
        seg_jerk = s * self.j_max * np.array([1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0])
        jj = np.where(inside, seg_jerk[np.clip(seg, 0, 6)], 0.0)
        return r.reshape(shape), v.reshape(shape), a.reshape(shape), jj.reshape(shape)

    def sample(self, sample_time: float) -> Reference:
        """Sample the move at ``t = k * sample_time``, ``k = 0 .. n``.

        ``n`` is the first sample at or after the end ``T``; it holds ``q1`` with
        zero velocity, acceleration and jerk.

        Args:
            sample_time: sample period (s), > 0.

        Returns:
            :class:`Reference` with ``n + 1`` samples.
        """
        ts = _as_positive("sample_time", sample_time, "s")
        n = _samples_to_cover(self.duration, ts)
        t = np.arange(n + 1) * ts
        r, v, a, j = self.evaluate(t)
        # The last sample may sit a hair before T (see _END_SLACK): pin it.
        r[-1], v[-1], a[-1], j[-1] = self.q1, 0.0, 0.0, 0.0
        return Reference(t=t, r=r, v=v, a=a, j=j, sample_time=ts)


def third_order_profile(q0, q1, v_max, a_max, j_max) -> ThirdOrderProfile:
    """Time-optimal symmetric jerk-limited move from ``q0`` to ``q1``.

    Switching times in closed form. With distance ``d = |q1 - q0|``:

    * if ``v_max * j_max >= a_max**2`` and ``d`` is long enough, all limits are
      reached and ``T = d / v_max + v_max / a_max + a_max / j_max``;
    * a move too short to reach ``v_max`` has no constant-velocity segment;
      one too short to reach ``a_max`` has no constant-acceleration segment;
    * ``d = 0`` gives a zero-length profile.

    Args:
        q0, q1: start and end position (m), finite.
        v_max: velocity limit (m/s), > 0.
        a_max: acceleration limit (m/s^2), > 0.
        j_max: jerk limit (m/s^3), > 0.

    Returns:
        :class:`ThirdOrderProfile`.

    Raises:
        ConfigError: a non-finite position or a limit that is not finite and > 0.
    """
    q0 = _as_finite("q0", q0, "m")
    q1 = _as_finite("q1", q1, "m")
    vm = _as_positive("v_max", v_max, "m/s")
    am = _as_positive("a_max", a_max, "m/s^2")
    jm = _as_positive("j_max", j_max, "m/s^3")
    d = abs(q1 - q0)
    if d == 0.0:
        return ThirdOrderProfile(q0, q1, 0.0, 0.0, 0.0, 0.0, 0.0, jm)

    # Acceleration phase that just reaches v_max (from rest).
    if vm * jm >= am * am:
        tj = am / jm
        ta = vm / am - tj
    else:
        tj = math.sqrt(vm / jm)
        ta = 0.0
    # Distance of acceleration + deceleration at v_max: average speed v/2 over
    # 2 * (2 tj + ta) seconds.
    d_ramps = vm * (2.0 * tj + ta)
    if d >= d_ramps:
        tv = (d - d_ramps) / vm
        vp = vm
    else:
        tv = 0.0
        tj_a = am / jm
        if d >= 2.0 * am**3 / jm**2:
            # a_max reached, v_max not: d = vp * (vp / a + tj). Rationalised
            # root avoids cancellation for short moves.
            tj = tj_a
            vp = 2.0 * d / (tj + math.sqrt(tj * tj + 4.0 * d / am))
            ta = max(vp / am - tj, 0.0)
        else:
            # Neither limit reached: pure jerk segments, d = 2 j tj^3.
            tj = (d / (2.0 * jm)) ** (1.0 / 3.0)
            ta = 0.0
            vp = jm * tj * tj
    ap = jm * tj
    return ThirdOrderProfile(q0, q1, tj, ta, tv, vp, ap, jm)


def point_to_point(q0, q1, v_max, a_max, j_max, sample_time) -> Reference:
    """Sampled third-order move from ``q0`` to ``q1`` starting at rest at ``t = 0``.

    Args:
        q0, q1: start and end position (m).
        v_max, a_max, j_max: limits (m/s, m/s^2, m/s^3), each > 0.
        sample_time: sample period (s), > 0.

    Returns:
        :class:`Reference` with samples ``t = k * sample_time``, ``k = 0 .. n``,
        where sample ``n`` is the first at or after the end of the move and
        holds exactly ``q1`` with ``v = a = j = 0``. A zero-distance move gives a
        single sample.

    Raises:
        ConfigError: a non-finite position or a limit/sample time that is not > 0.
    """
    ts = _as_positive("sample_time", sample_time, "s")
    return third_order_profile(q0, q1, v_max, a_max, j_max).sample(ts)


# ---------------------------------------------------------------------------
# Sequences of moves and the paper's references
# ---------------------------------------------------------------------------


def sequence(moves, sample_time, dwell=0.5, start=None, initial_dwell=0.0) -> Reference:
    """Several third-order moves, each followed by a rest.

    Each move starts at rest on a sample instant where the previous one left
    off. After move ``i`` lands (its first sample at or after its end), the
    reference rests at the target for ``round(dwell_i / sample_time)`` more
    samples before the next move starts.

    Args:
        moves: iterable of ``(target_position, v_max, a_max, j_max)`` in
            (m, m/s, m/s^2, m/s^3).
        sample_time: sample period (s), > 0.
        dwell: rest time after each move (s), >= 0: one float for all moves or
            one per move.
        start: start position (m); default 0.0.
        initial_dwell: rest time at ``start`` before the first move (s), >= 0.

    Returns:
        :class:`Reference` starting at ``t = 0``.

    Raises:
        ConfigError: no moves, a malformed move, a bad limit, dwell or sample time.
    """
    ts = _as_positive("sample_time", sample_time, "s")
    moves = [tuple(m) if isinstance(m, (tuple, list, np.ndarray)) else m for m in moves]
    if not moves:
        raise ConfigError("sequence: no moves given; expected (target_m, v_max, a_max, j_max) tuples")
    for i, m in enumerate(moves):
        if not isinstance(m, tuple) or len(m) != 4:
            raise ConfigError(f"sequence: move {i} is {m!r}; expected (target_m, v_max, a_max, j_max)")
    if np.ndim(dwell) == 0:
        dwells = [dwell] * len(moves)
    else:
        dwells = list(dwell)
        if len(dwells) != len(moves):
            raise ConfigError(f"sequence: {len(dwells)} dwell times for {len(moves)} moves; give one per move or a single value")
    dwell_samples = [_dwell_samples(f"dwell[{i}]", dw, ts) for i, dw in enumerate(dwells)]
    n_init = _dwell_samples("initial_dwell", initial_dwell, ts)
    pos = 0.0 if start is None else _as_finite("start", start, "m")

    # Layout: initial rest, then per move its samples 0..n-1 (n = landing
    # sample) followed by n_dw samples at the target, whose first is the
    # landing sample and whose last is the rest state the next move starts
    # from; finally the last landing sample. A move's sample 0 thus keeps its
    # right-continuous jerk instead of being replaced by a rest sample.
    rs, vs, as_, js = [np.full(n_init, pos)], [np.zeros(n_init)], [np.zeros(n_init)], [np.zeros(n_init)]
    total = n_init + 1
    for i, ((target, vm, am, jm), n_dw) in enumerate(zip(moves, dwell_samples)):
        try:
            prof = third_order_profile(pos, target, vm, am, jm)
            move = prof.sample(ts)
        except ConfigError as err:
            raise ConfigError(f"sequence: move {i}: {err}") from None
        total += len(move) - 1 + n_dw
        if total > _MAX_SAMPLES:
            raise ConfigError(f"sequence: more than {_MAX_SAMPLES} samples at sample_time={ts!r} s; use a larger sample time")
        for store, arr in zip((rs, vs, as_, js), (move.r, move.v, move.a, move.j)):
            store.append(arr[:-1])
        rs.append(np.full(n_dw, prof.q1))
        for store in (vs, as_, js):
            store.append(np.zeros(n_dw))
        pos = prof.q1
    rs.append(np.array([pos]))
    for store in (vs, as_, js):
        store.append(np.zeros(1))
    r = np.concatenate(rs)
    return Reference(
        t=np.arange(r.shape[0]) * ts,
        r=r,
        v=np.concatenate(vs),
        a=np.concatenate(as_),
        j=np.concatenate(js),
        sample_time=ts,
    )


def data_generation_reference(
    sample_time=1e-3,
    stroke=0.1,
    velocities=(0.025, 0.075, 0.15),
    a_max=1.0,
    j_max=1000.0,
    dwell=0.5,
) -> Reference:
    """The paper's identification reference (Fig. Data_Generation).

    Rests :data:`INITIAL_DWELL` s at ``-stroke``; then for each ``v_max`` in
    ``velocities``: move to ``+stroke``, rest ``dwell``, move back to
    ``-stroke``, rest ``dwell``.

    Args:
        sample_time: sample period (s).
        stroke: half stroke (m), > 0; the reference spans ``[-stroke, +stroke]``.
        velocities: maximum velocities of the back-and-forth pairs (m/s).
        a_max: acceleration limit (m/s^2).
        j_max: jerk limit (m/s^3).
        dwell: rest after each move (s).

    Returns:
        :class:`Reference` (about 27.6 s, 27 609 samples with the defaults).
    """
    stroke = _as_positive("stroke", stroke, "m")
    velocities = [velocities] if np.ndim(velocities) == 0 else list(velocities)
    if not velocities:
        raise ConfigError("data_generation_reference: velocities is empty; expected at least one v_max (m/s)")
    moves = []
    for vm in velocities:
        moves.append((stroke, vm, a_max, j_max))
        moves.append((-stroke, vm, a_max, j_max))
    return sequence(moves, sample_time, dwell=dwell, start=-stroke, initial_dwell=INITIAL_DWELL)


def single_velocity_reference(v_max, sample_time=1e-3, stroke=0.1, a_max=1.0, j_max=1000.0, dwell=0.5) -> Reference:
    """One back-and-forth between ``-stroke`` and ``+stroke`` at one ``v_max``.

    The paper's "slow" (0.025 m/s) and "fast" (0.15 m/s) evaluation references.
    Same layout as :func:`data_generation_reference` with one velocity.

    Args:
        v_max: velocity limit (m/s).
        sample_time: sample period (s).
        stroke: half stroke (m).
        a_max, j_max: acceleration (m/s^2) and jerk (m/s^3) limits.
        dwell: rest after each move (s).

    Returns:
        :class:`Reference`.
    """
    return data_generation_reference(sample_time, stroke, (v_max,), a_max, j_max, dwell)


def reference_from_positions(r, sample_time: float, t=None) -> Reference:
    """A :class:`Reference` from sampled positions ``r`` ``(N,)`` (m) at ``sample_time`` (s).

    Velocity, acceleration and jerk are central finite differences of ``r`` (one-sided at
    the ends), second-order accurate in the interior; noisy positions give a noisy jerk.
    ``t`` ``(N,)`` (s) defaults to ``k * sample_time``.
    """
    r = np.asarray(r, dtype=np.float64)
    ts = float(sample_time)
    t = np.arange(r.shape[0]) * ts if t is None else np.asarray(t, dtype=np.float64)
    v, a, j = _finite_differences(r, ts)
    return Reference(t=t, r=r, v=v, a=a, j=j, sample_time=ts)


def _finite_differences(r: np.ndarray, ts: float):
    """Central differences (one-sided at the ends): v, a, j of a sampled position."""
    v = np.gradient(r, ts)
    a = np.gradient(v, ts)
    j = np.gradient(a, ts)
    return v, a, j


# ---------------------------------------------------------------------------
# Validation helpers
# ---------------------------------------------------------------------------


def _to_float(name: str, value, unit: str, err) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise err(f"{name} must be a number ({unit}), got {value!r}") from None
    return x


def _as_finite(name: str, value, unit: str, err=ConfigError) -> float:
    x = _to_float(name, value, unit, err)
    if not math.isfinite(x):
        raise err(f"{name} must be a finite number ({unit}), got {x!r}")
    return x


def _as_positive(name: str, value, unit: str, err=ConfigError) -> float:
    x = _to_float(name, value, unit, err)
    if not (math.isfinite(x) and x > 0.0):
        raise err(f"{name} must be a finite number > 0 ({unit}), got {x!r}")
    return x


def _dwell_samples(name: str, value, ts: float) -> int:
    dw = _to_float(name, value, "s", ConfigError)
    if not (math.isfinite(dw) and dw >= 0.0):
        raise ConfigError(f"{name} must be a finite time >= 0 (s), got {dw!r}")
    n = int(round(dw / ts))
    if n > _MAX_SAMPLES:
        raise ConfigError(f"{name}={dw!r} s is more than {_MAX_SAMPLES} samples at sample_time={ts!r} s")
    return n


def _samples_to_cover(duration: float, ts: float) -> int:
    """Index of the first sample at or after ``duration`` (with rounding slack)."""
    n = max(0, math.ceil(duration / ts - _END_SLACK))
    if n > _MAX_SAMPLES:
        raise ConfigError(
            f"a move of {duration!r} s at sample_time={ts!r} s needs {n} samples (limit {_MAX_SAMPLES}); "
            "use a larger sample time"
        )
    return n
