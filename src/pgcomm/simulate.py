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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm import mechanics as mech_mod
from pgcomm.commutation import currents_to_drive_inputs, limit_currents
from pgcomm.control import PID, Feedforward, feedforward_signal
from pgcomm.errors import DataError, SimulationError
from pgcomm.mechanics import Mechanics
from pgcomm.motor import Motor
from pgcomm.plant import plant_force
from pgcomm.sensors import Sensors, force_noise, quantise


@dataclass(frozen=True)
class SimResult:
    """Everything logged by a closed-loop run; all arrays have ``N`` rows (one per controller sample).

    Attributes:
        t: (N,) s; r: (N,) reference (m); y: (N,) true position (m); y_meas: (N,) encoder (m);
        e: (N,) tracking error ``r - y`` (m); f_star: (N, 3) desired force;
        f_meas: (N, 3) measured force (with sensor noise); f_true: (N, 3) generated force;
        currents: (N, L, 2) star currents (A); drive_fy: (N, L) (N); drive_delta: (N, L) (rad);
        sample_time: s; drive: the :class:`Motor` whose ``k̂``, ``ζ̂`` define the drive inputs.
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
    drive_fy: np.ndarray
    drive_delta: np.ndarray
    sample_time: float
    drive: Motor
    info: dict = field(default_factory=dict)

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


@partial(jax.jit, static_argnames=("pid", "mech", "sample_time", "resolution", "current_limit"))
def _run(plant, law, r, v_ref, u_ff, y0, *, pid: PID, mech: Mechanics, sample_time: float, resolution: float,
         current_limit):
    ts = sample_time
    alpha = pid.alpha(ts)
    true_state = getattr(law, "true_state", False)
    encoder_velocity = getattr(law, "velocity_source", "reference") == "encoder"
    # first-order low-pass of the encoder difference (ZOH): v_f <- v_f + a (Δy_m / T_s - v_f)
    a_v = 1.0 - np.exp(-2 * np.pi * getattr(law, "velocity_cutoff_hz", 100.0) * ts) if encoder_velocity else 0.0

    stateful = hasattr(law, "direction_state")

    def body(carry, x):
        y, v, integ, e_prev, u_fb, ym_prev, v_f, d = carry
        r_k, vr_k, uff_k = x
        ym = quantise(y, resolution)
        v_f = v_f + a_v * ((ym - ym_prev) / ts - v_f)
        v_law = v_f if encoder_velocity else vr_k
        e = r_k - ym
        integ = integ + e * ts
        u_pid = pid.kp * e + pid.ki * integ + pid.kd * (e - e_prev) / ts
        u_fb = u_fb + alpha * (u_pid - u_fb)
        f_star = jnp.stack([uff_k + u_fb, 0.0, 0.0])
        if stateful:
            d = law.direction_state(d, v_law)
            i = law.currents_with_state(ym, f_star, v_law, d)
        else:
            i = law.currents(y, f_star, v) if true_state else law.currents(ym, f_star, v_law)
        i = limit_currents(i, current_limit)
        f = plant_force(plant, y, i, v)
        y_next, v_next = mech_mod.step(mech, y, v, f[0], ts)
        return (y_next, v_next, integ, e, u_fb, ym, v_f, d), (y, ym, f_star, f, i)

    e0 = r[0] - quantise(y0, resolution)
    carry0 = (y0, jnp.zeros_like(y0), jnp.zeros_like(y0), e0, jnp.zeros_like(y0), quantise(y0, resolution),
              jnp.zeros_like(y0), jnp.ones_like(y0))
    _, out = jax.lax.scan(body, carry0, (r, v_ref, u_ff))
    return out


def simulate(plant, law, reference, *, drive: Motor, pid: PID | None = None,
             feedforward: Feedforward = Feedforward(), mechanics: Mechanics = Mechanics(),
             sensors: Sensors = Sensors(), seed: int = 0, y0: float | None = None) -> SimResult:
    """Run the closed loop on ``plant`` with commutation ``law`` along ``reference``.

    Args:
        plant: electromagnetic truth (:mod:`pgcomm.plant` interface): twin or force map.
        law: commutation law with ``currents(y, F*)`` (:mod:`pgcomm.commutation`).
        reference: a :class:`pgcomm.trajectory.Reference` (``r, v, a`` sampled at ``drive.sample_time``).
        drive: motor description: sample time, current limit, and the drive's fixed
            commutation ``k̂``, ``ζ̂`` used to express currents as drive inputs.
        pid: feedback; default :meth:`PID.tuned` for ``mechanics.mass``.
        feedforward: ``m, f_v, f_c`` of eq. FeedforwardController (zeros = none).
        mechanics, sensors: translator and sensor models.
        seed: force-sensor noise seed.
        y0: initial position (m), default ``r[0]``.

    Returns:
        :class:`SimResult`.

    Raises:
        DataError: if the motion leaves the plant's defined position range (e.g. a force map).
    """
    return simulate_many(plant, [law], reference, drive=drive, pid=pid, feedforwards=[feedforward],
                         mechanics=mechanics, sensors=sensors, seeds=[seed], y0=y0)[0]


def simulate_many(plant, laws, reference, *, drive: Motor, pid: PID | None = None, feedforwards=None,
                  mechanics: Mechanics = Mechanics(), sensors: Sensors = Sensors(), seeds=None,
                  y0: float | None = None) -> list[SimResult]:
    """Run several closed loops that differ in the law's values, feedforward, noise seed and reference, batched.

    ``laws`` must share one pytree structure (same law class and static fields, e.g.
    the ``2L`` data-set experiments of :class:`pgcomm.commutation.DriveInputLaw`); they
    are stacked and simulated together with ``jax.vmap`` over one compiled scan.

    Args:
        laws: list of ``B`` laws.
        reference: one :class:`~pgcomm.trajectory.Reference` for all, or a list of ``B``
            (of any lengths: shorter ones are padded by holding their last sample, and the
            results are cut back to each reference's length).
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
    pid = pid or PID.tuned(mechanics.mass)
    feedforwards = feedforwards or [Feedforward()] * b
    seeds = list(range(b)) if seeds is None else list(seeds)
    lengths = [len(ref.r) for ref in refs]
    n_max = max(lengths)
    r = np.stack([_pad(np.asarray(ref.r, float), n_max) for ref in refs])
    v_ref = np.stack([_pad(np.asarray(ref.v, float), n_max) for ref in refs])
    u_ff = np.stack([_pad(feedforward_signal(ff, np.asarray(ref.v), np.asarray(ref.a), np.asarray(ref.r)), n_max)
                     for ff, ref in zip(feedforwards, refs)])
    y0s = np.array([float(rr[0] if y0 is None else y0) for rr in r])
    kw = dict(pid=pid, mech=mechanics, sample_time=ts, resolution=float(sensors.encoder_resolution),
              current_limit=drive.current_limit)
    if b == 1:
        outs = [tuple(np.asarray(o) for o in _run(plant, laws[0], jnp.asarray(r[0]), jnp.asarray(v_ref[0]),
                                                   jnp.asarray(u_ff[0]), jnp.asarray(y0s[0]), **kw))]
    else:
        stacked = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *laws)
        batched = _run_batched(plant, stacked, jnp.asarray(r), jnp.asarray(v_ref), jnp.asarray(u_ff),
                               jnp.asarray(y0s), **kw)
        batched = [np.asarray(o) for o in batched]
        outs = [tuple(o[j] for o in batched) for j in range(b)]
    k_hat = jnp.asarray(drive.k)
    zeta_hat = jnp.asarray(drive.zeta)
    results = []
    for j, ((y, ym, f_star, f_true, cur), seed) in enumerate(zip(outs, seeds)):
        n = lengths[j]
        y, ym, f_star, f_true, cur = y[:n], ym[:n], f_star[:n], f_true[:n], cur[:n]
        _check_range(plant, y, r[j, :n])
        noise = np.asarray(force_noise(jax.random.PRNGKey(seed), n, sensors))
        fy, delta = currents_to_drive_inputs(jnp.asarray(ym), jnp.asarray(cur), k_hat, zeta_hat, drive.pole_pitch)
        results.append(SimResult(t=np.arange(n) * ts, r=r[j, :n], y=y, y_meas=ym, e=r[j, :n] - y, f_star=f_star,
                                 f_meas=f_true + noise, f_true=f_true, currents=cur, drive_fy=np.asarray(fy),
                                 drive_delta=np.asarray(delta), sample_time=ts, drive=drive))
    return results


def _pad(x, n):
    """Pad ``x`` (N,) to length ``n`` by holding its last value."""
    return np.concatenate([x, np.full(n - x.shape[0], x[-1])]) if x.shape[0] < n else x


@partial(jax.jit, static_argnames=("pid", "mech", "sample_time", "resolution", "current_limit"))
def _run_batched(plant, laws, r, v_ref, u_ff, y0, **kw):
    return jax.vmap(lambda law, rr, vv, uff, y00: _run(plant, law, rr, vv, uff, y00, **kw))(laws, r, v_ref, u_ff, y0)


def _check_range(plant, y, r):
    """Raise :class:`SimulationError` (``cause="divergence"``) if the motion ``y`` (m) left the plant's range."""
    ok = np.asarray(plant.in_range(jnp.asarray(y)))
    if not ok.all():
        k = int(np.argmin(ok))
        lo, hi = plant.y_range
        raise SimulationError(
            f"simulation diverged: position y = {y[k]:.6g} m at sample {k} is outside the plant's range "
            f"[{lo:.6g}, {hi:.6g}] m while the reference is at r = {r[k]:.6g} m; the loop is unstable or saturated: "
            "check the controller (bandwidth_hz, mass), the mechanics and the plant's k, zeta against the drive's",
            "divergence")
