"""Closed-loop simulation: trajectory -> control -> commutation -> drive -> plant -> sensors.

One ``jax.lax.scan`` step per controller sample ``k``:

1. the encoder reads ``y_m[k] = Q(y(t_k))``; ``e[k] = r[k] - y_m[k]``;
2. feedback + feedforward give ``F*[k] = [u_ff[k] + u_fb[k], 0, 0]``;
3. the commutation law maps ``(y_m[k], F*[k], v_c[k])`` (encoder position, desired
   force, a velocity the controller has) to star currents — the oracle
   (``law.true_state``) gets the true ``(y(t_k), v(t_k))`` instead — the drive limits
   them and holds them over ``[t_k, t_k+1)`` (zero-order hold). ``v_c`` is the reference
   velocity ``v_r[k]`` unless the law has ``velocity_source = "encoder"``: then it is the
   encoder difference ``(y_m[k] - y_m[k-1]) / T_s`` through a causal first-order low-pass
   with cut-off ``law.velocity_cutoff_hz`` (ZOH-discretised, the filter a drive would run).
   A law with memory (a drive that keeps one of two direction tables until its speed leaves a
   hysteresis band) has ``direction_state(d, v)`` and ``currents_with_state(y, F*, v, d)``: its
   state ``d`` (+1/-1, starting at +1) is carried from sample to sample;
4. the plant produces ``F[k] = F(y(t_k), v(t_k), i[k])``; the mechanics integrate
   ``F_y[k]`` over the sample in RK4 sub-steps.

Force-sensor noise is added to ``F`` afterwards (it does not act on the motion),
and the drive inputs ``(Fy^l*, Δ^l)`` that a fixed-commutation drive would need for
the same currents are computed afterwards (eq. Current_To_ForceDelta), vectorised.

One compiled program runs the law, the plant, the controller and the mechanics over a chunk of
:data:`CHUNK` samples: the law, the plant and the controller's values are its arguments, so other
values (another identified model, another gain, another reference of any length) reuse it; a new
law or plant class or another number of sub-steps compiles a new one. It is fastest when XLA
compiles the whole loop as one function (:mod:`pgcomm._x64`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm import mechanics as mech_mod
from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.commutation import currents_to_drive_inputs, limit_currents
from pgcomm.control import PID, Feedforward, feedforward_signal
from pgcomm.errors import DataError, SimulationError
from pgcomm.mechanics import Mechanics
from pgcomm.motor import Motor
from pgcomm.plant import plant_force
from pgcomm.sensors import Sensors, force_noise


@dataclass(frozen=True)
class ClosedLoop:
    """What surrounds the commutation law in the closed loop: the feedback, the translator and the sensors.

    Attributes:
        pid: the feedback controller (:class:`pgcomm.control.PID`); ``None``: :meth:`PID.tuned` for
            ``mechanics.mass``.
        mechanics: the translator (:class:`pgcomm.mechanics.Mechanics`: mass in kg, friction, sub-steps).
        sensors: the encoder and the force sensor (:class:`pgcomm.sensors.Sensors`: resolution in m, noise).
    """

    pid: PID | None = None
    mechanics: Mechanics = field(default_factory=Mechanics)
    sensors: Sensors = field(default_factory=Sensors)


@dataclass(frozen=True)
class SimResult:
    """Everything logged by a closed-loop run; all arrays have ``N`` rows (one per controller sample).

    Attributes:
        t: (N,) s; r: (N,) reference (m); y: (N,) true position (m); y_meas: (N,) encoder (m);
        e: (N,) tracking error ``r - y`` (m); f_star: (N, 3) desired force;
        f_meas: (N, 3) measured force (with sensor noise); f_true: (N, 3) generated force;
        currents: (N, L, 2) star currents (A); sample_time: s;
        drive: the :class:`Motor` whose ``k̂``, ``ζ̂`` define the drive inputs ``drive_fy``, ``drive_delta``.
    """

    t: np.ndarray
    r: np.ndarray
    y: np.ndarray
    y_meas: np.ndarray
    e: np.ndarray
    f_star: np.ndarray
    f_meas: np.ndarray
    f_true: np.ndarray
    currents: np.ndarray
    sample_time: float
    drive: Motor
    info: dict = field(default_factory=dict)

    @cached_property
    def _drive_inputs(self) -> tuple[np.ndarray, np.ndarray]:
        # computed when first asked for (logs, data sets), not for every evaluation run
        fy, delta = _drive_inputs(jnp.asarray(self.y_meas), jnp.asarray(self.currents), jnp.asarray(self.drive.k),
                                  jnp.asarray(self.drive.zeta), float(self.drive.pole_pitch))
        return np.asarray(fy), np.asarray(delta)

    @property
    def drive_fy(self) -> np.ndarray:
        """(N, L) drive input ``Fy^l*`` (N, signed) that makes :attr:`currents` on :attr:`drive` (eq. Current_To_ForceDelta)."""
        return self._drive_inputs[0]

    @property
    def drive_delta(self) -> np.ndarray:
        """(N, L) drive input ``Δ^l`` (rad, in ``(-π/2, π/2]``) that makes :attr:`currents` on :attr:`drive`."""
        return self._drive_inputs[1]

    @property
    def commutation_error(self) -> np.ndarray:
        """Measured commutation error ``F - F*`` (N, 3)."""
        return self.f_meas - self.f_star

    def columns(self) -> dict[str, np.ndarray]:
        """Log columns in the DESIGN.md log format (plus ``Fy_star, Fx_star, Tz_star``)."""
        cols = {"t": self.t, "r": self.r, "y": self.y_meas,
                "Fy": self.f_meas[:, 0], "Fx": self.f_meas[:, 1], "Tz": self.f_meas[:, 2],
                "Fy_star": self.f_star[:, 0], "Fx_star": self.f_star[:, 1], "Tz_star": self.f_star[:, 2]}
        for l in range(self.currents.shape[1]):
            cols[f"ia_{l + 1}"] = self.currents[:, l, 0]
            cols[f"ib_{l + 1}"] = self.currents[:, l, 1]
        for l in range(self.currents.shape[1]):
            cols[f"Fy_ref_{l + 1}"] = self.drive_fy[:, l]
            cols[f"delta_{l + 1}"] = self.drive_delta[:, l]
        return cols


#: Controller samples per call of the compiled loop. A reference of any length runs as consecutive chunks of
#: this many samples (the last one padded by holding the reference's last sample), so one compiled program
#: serves every reference length; a chunk is long enough that the call's own cost (~0.1 ms) is a few per cent
#: of its run time.
CHUNK = 4096


@pytree_dataclass
class _Loop:
    """The controller's, the sensors' and the mechanics' values of a closed loop, traced (not static): other
    gains, masses or encoder resolutions reuse the compiled loop. Only the number of RK4 sub-steps and
    whether the drive's current limit acts after the law's shape it.

    Attributes (scalars): kp (N/m), ki (N/(m s)), kd_ts = kd / T_s (N/m): the PID; alpha: its output
    low-pass coefficient; a_v: the encoder-velocity low-pass coefficient; sample_time ``T_s`` (s);
    resolution: encoder quantum (m, 0: none); current_limit (A, ``inf``: none); mass (kg), viscous (N s/m),
    coulomb (N), coulomb_velocity (m/s): the translator.
    """

    kp: jnp.ndarray
    ki: jnp.ndarray
    kd_ts: jnp.ndarray
    alpha: jnp.ndarray
    a_v: jnp.ndarray
    sample_time: jnp.ndarray
    resolution: jnp.ndarray
    current_limit: jnp.ndarray
    mass: jnp.ndarray
    viscous: jnp.ndarray
    coulomb: jnp.ndarray
    coulomb_velocity: jnp.ndarray
    substeps: int = static_field()
    drive_limit: bool = static_field(default=True)

    @classmethod
    def make(cls, pid: PID, mech: Mechanics, sensors: Sensors, sample_time: float, current_limit, law) -> "_Loop":
        """The loop's values for ``law`` (its velocity source sets ``a_v``) at ``sample_time`` (s), drive
        current limit ``current_limit`` (A or ``None``)."""
        encoder = getattr(law, "velocity_source", "reference") == "encoder"
        # first-order low-pass of the encoder difference (ZOH): v_f <- v_f + a (Δy_m / T_s - v_f)
        a_v = 1.0 - np.exp(-2 * np.pi * getattr(law, "velocity_cutoff_hz", 100.0) * sample_time) if encoder else 0.0
        # a law that limits its currents to at most the drive's limit leaves the drive nothing to scale
        law_limit = getattr(law, "current_limit", None)
        drive_limit = current_limit is not None and (law_limit is None or law_limit > current_limit)
        f = lambda x: np.asarray(float(x))  # noqa: E731
        return cls(f(pid.kp), f(pid.ki), f(pid.kd / sample_time), f(pid.alpha(sample_time)), f(a_v), f(sample_time),
                   f(sensors.encoder_resolution), f(np.inf if current_limit is None else current_limit),
                   f(mech.mass), f(mech.viscous), f(mech.coulomb), f(mech.coulomb_velocity), int(mech.substeps),
                   bool(drive_limit))

    def mechanics(self) -> Mechanics:
        """The translator as a :class:`Mechanics` of traced values."""
        return Mechanics(mass=self.mass, viscous=self.viscous, coulomb=self.coulomb,
                         coulomb_velocity=self.coulomb_velocity, substeps=self.substeps)


def _quantise(y, resolution):
    """:func:`pgcomm.sensors.quantise` with a traced resolution (m; 0: none)."""
    return jnp.where(resolution > 0, jnp.round(y / jnp.where(resolution > 0, resolution, 1.0)) * resolution, y)


@jax.jit
def _chunk(plant, law, loop: _Loop, carry, r, v_ref, u_ff):
    """One closed loop over one chunk of ``K`` samples: ``lax.scan`` of the sample step (module docstring)
    over the ``(K,)`` inputs ``r`` (m), ``v_ref`` (m/s), ``u_ff`` (N). Returns the carry after the chunk and
    the logged ``(y, y_m, F*, F, i)``, each ``(K, ...)``. One compiled program per law and plant class."""
    ts = loop.sample_time
    inv_ts = 1.0 / ts
    mech = loop.mechanics()
    true_state = getattr(law, "true_state", False)
    encoder_velocity = getattr(law, "velocity_source", "reference") == "encoder"

    stateful = hasattr(law, "direction_state")

    def body(c, x):
        y, v, integ, e_prev, u_fb, ym_prev, v_f, d = c
        r_k, vr_k, uff_k = x
        ym = _quantise(y, loop.resolution)
        if encoder_velocity:
            v_f = v_f + loop.a_v * ((ym - ym_prev) * inv_ts - v_f)
        e = r_k - ym
        integ = integ + e * ts
        u_pid = loop.kp * e + loop.ki * integ + loop.kd_ts * (e - e_prev)
        u_fb = u_fb + loop.alpha * (u_pid - u_fb)
        zero = jnp.zeros_like(u_fb)
        f_star = jnp.stack([uff_k + u_fb, zero, zero])
        v_law = v_f if encoder_velocity else vr_k
        if stateful:
            d = law.direction_state(d, v_law)
            i = law.currents_with_state(ym, f_star, v_law, d)
        else:
            i = law.currents(y, f_star, v) if true_state else law.currents(ym, f_star, v_law)
        if loop.drive_limit:
            i = limit_currents(i, loop.current_limit)
        f = plant_force(plant, y, i, v)
        y_next, v_next = mech_mod.step(mech, y, v, f[0], ts)
        return (y_next, v_next, integ, e, u_fb, ym, v_f, d), (y, ym, f_star, f, i)

    return jax.lax.scan(body, carry, (r, v_ref, u_ff))


_drive_inputs = jax.jit(currents_to_drive_inputs, static_argnames="pole_pitch")


def simulate(plant, law, reference, *, drive: Motor, loop: ClosedLoop = ClosedLoop(),
             feedforward: Feedforward = Feedforward(), seed: int = 0, y0: float | None = None) -> SimResult:
    """Run the closed loop on ``plant`` with commutation ``law`` along ``reference``.

    Args:
        plant: electromagnetic truth (:mod:`pgcomm.plant` interface): twin or force map.
        law: commutation law with ``currents(y, F*)`` (:mod:`pgcomm.commutation`).
        reference: a :class:`pgcomm.trajectory.Reference` (``r, v, a`` sampled at ``drive.sample_time``).
        drive: motor description: sample time, current limit, and the drive's fixed
            commutation ``k̂``, ``ζ̂`` used to express currents as drive inputs.
        loop: the feedback, translator and sensor models (:class:`ClosedLoop`).
        feedforward: ``m, f_v, f_c`` of eq. FeedforwardController (zeros = none).
        seed: force-sensor noise seed.
        y0: initial position (m), default ``r[0]``.

    Returns:
        :class:`SimResult`.

    Raises:
        DataError: a reference sampled at another rate than the drive's.
        SimulationError: a reference outside the plant's range, or a motion that leaves it (divergence).
    """
    return simulate_many(plant, [law], reference, drive=drive, loop=loop, feedforwards=[feedforward], seeds=[seed],
                         y0=y0)[0]


def simulate_many(plant, laws, reference, *, drive: Motor, loop: ClosedLoop = ClosedLoop(), feedforwards=None,
                  seeds=None, y0: float | None = None) -> list[SimResult]:
    """Run several closed loops that differ in the law, feedforward, noise seed and reference.

    The runs go one after the other through the compiled loop of their law's class (laws of one
    class with other values, and references of any length, reuse it). Running ``B`` loops side by
    side in one program (``jax.vmap``) was measured no faster per sample once the loop is one
    compiled function (1.0 µs per sample with the PGNN law at ``B = 1``, 6 and 16), and each ``B``
    compiled a program of its own.

    Args:
        laws: list of ``B`` laws (any classes).
        reference: one :class:`~pgcomm.trajectory.Reference` for all, or a list of ``B``.
        feedforwards: list of ``B`` :class:`Feedforward` (default none);
        seeds: list of ``B`` noise seeds (default ``0..B-1``). Other arguments as :func:`simulate`.

    Returns:
        list of ``B`` :class:`SimResult`.
    """
    ts = float(drive.sample_time)
    b = len(laws)
    refs = list(reference) if isinstance(reference, (list, tuple)) else [reference] * b
    for ref in refs:
        if abs(ref.sample_time - ts) > 1e-12 * ts:
            raise DataError(f"reference sample time {ref.sample_time} s differs from the motor's {ts} s")
    mechanics, sensors = loop.mechanics, loop.sensors
    mech_mod.check_stable(mechanics, ts)
    if hasattr(plant, "y_range"):
        lo, hi = (float(v) for v in plant.y_range)
        for j, ref in enumerate(refs):
            rr = np.asarray(ref.r, float)
            bad = np.flatnonzero((rr < lo) | (rr > hi))
            if bad.size:
                k = int(bad[0])
                raise SimulationError(f"reference{'' if len(refs) == 1 else f' {j + 1}'}: r = {rr[k]:.6g} m at sample "
                                      f"{k} is outside the plant's range [{lo:.6g}, {hi:.6g}] m; keep the reference "
                                      "inside the plant's range", "reference")
    pid = loop.pid or PID.tuned(mechanics.mass)
    feedforwards = feedforwards or [Feedforward()] * b
    seeds = list(range(b)) if seeds is None else list(seeds)
    return [_run(plant, law, ref, ff, seed, drive, pid, mechanics, sensors, y0)
            for law, ref, ff, seed in zip(laws, refs, feedforwards, seeds)]


def _run(plant, law, ref, ff: Feedforward, seed: int, drive: Motor, pid: PID, mechanics: Mechanics,
         sensors: Sensors, y0) -> SimResult:
    """One closed loop, chunk after chunk of :data:`CHUNK` samples (arguments of :func:`simulate`)."""
    ts = float(drive.sample_time)
    n = len(ref.r)
    n_pad = -(-n // CHUNK) * CHUNK
    r = _pad(np.asarray(ref.r, float), n_pad)
    v_ref = _pad(np.asarray(ref.v, float), n_pad)
    u_ff = _pad(feedforward_signal(ff, np.asarray(ref.v), np.asarray(ref.a), np.asarray(ref.r)), n_pad)
    loop = _Loop.make(pid, mechanics, sensors, ts, drive.current_limit, law)
    start = float(r[0] if y0 is None else y0)
    res = float(sensors.encoder_resolution)
    ym0 = np.round(start / res) * res if res > 0 else start  # as _quantise
    # host values throughout: the compiled loop takes them as they are (jnp.asarray of each would run an
    # eager program, compiled per shape)
    carry = tuple(np.float64(x) for x in (start, 0.0, 0.0, r[0] - ym0, 0.0, ym0, 0.0, 1.0))
    parts = []
    for k0 in range(0, n, CHUNK):
        sl = slice(k0, k0 + CHUNK)
        carry, out = _chunk(plant, law, loop, carry, r[sl], v_ref[sl], u_ff[sl])
        out = [np.asarray(o) for o in out]
        parts.append(out)
        # a loop that has left the plant stops here rather than at the end of the reference
        _check_range(plant, out[0][:n - k0], r[sl][:n - k0], k0)
    y, ym, f_star, f_true, cur = (np.concatenate(o)[:n] for o in zip(*parts))
    return SimResult(t=np.arange(n) * ts, r=r[:n], y=y, y_meas=ym, e=r[:n] - y, f_star=f_star,
                     f_meas=f_true + force_noise(seed, n, sensors), f_true=f_true, currents=cur, sample_time=ts,
                     drive=drive)


def _pad(x, n):
    """Pad ``x`` (N,) to length ``n`` by holding its last value."""
    return np.concatenate([x, np.full(n - x.shape[0], x[-1])]) if x.shape[0] < n else x


def _check_range(plant, y, r, k0: int = 0):
    """Raise :class:`SimulationError` (``cause="divergence"``) if the motion ``y`` (m) left the plant's range;
    ``y`` and the reference ``r`` (m) start at sample ``k0``."""
    lo, hi = (float(v) for v in plant.y_range)
    ok = (y >= lo) & (y <= hi)  # NaN is outside
    if not ok.all():
        k = int(np.argmin(ok))
        raise SimulationError(
            f"simulation diverged: position y = {y[k]:.6g} m at sample {k0 + k} is outside the plant's range "
            f"[{lo:.6g}, {hi:.6g}] m while the reference is at r = {r[k]:.6g} m; the loop is unstable or saturated: "
            "check the controller (bandwidth_hz, mass), the mechanics and the plant's k, zeta against the drive's",
            "divergence")
