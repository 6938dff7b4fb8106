"""A rotary PMSM twin on a field-oriented drive, in closed loop (``jax.lax.scan``).

**Truth.** The drive's electrical frame is ``p θ_enc + offset``; the motor's true frame is
offset from it by ``δ`` (rad, electrical), so a q-current ``i_q`` in the drive frame is
``i_q cos δ`` in the true q axis (the d-axis command is zero; the drive's ``i_d`` reads noise).
The air-gap torque and the mechanics are::

    T_em = k_t cos δ · (1 + ρ(θ)) i_q + T_cog(θ)                            (N·m)
    J θ̈  = T_em − (T_c + D(θ)) tanh(ω / ω_ε) − b ω

``ρ`` the relative torque-constant ripple (eccentricity at order 1, magnet tolerances at the
low orders and ``2p``, back-EMF harmonics at ``6p``, ``12p``, the slots at ``Q``, and a small
part outside any model's basis), ``T_cog`` the cogging torque at the multiples of
``LCM(Q, 2p)`` with the sidebands of magnet (``kQ``) and stator (``k·2p``) tolerances, ``T_c``
Coulomb friction, ``D`` the position-dependent part of the direction-dependent torque, ``b``
viscous friction. ``k0 = k_t cos δ`` is the mean effective torque constant the drive sees.

**Drive.** One step per controller sample ``T_s``: the encoder quantises the angle; the velocity
is the encoder difference through a first-order low-pass (the drive's estimator); a PID position
loop or a PI speed loop with feedforward gives the demand ``u`` (A, equivalent current at
``k0``); the commutation law (:mod:`pgcomm.rotary.law`) makes it a q-current, clipped to the
limit and held over the sample (ideal current loop). The law is evaluated at the angle the rotor
has in the middle of that hold, ``θ_enc + advance · ω̂ · T_s`` (:attr:`LawParams.advance`, default
½, :func:`pgcomm.rotary.law.hold_angle`): evaluated at the sample's start, a compensation held for a
sample lags half a sample, which at 16 samples per cogging period leaves ``2 sin(π/32) ≈ 20 %`` of
that harmonic uncompensated (the floor of every row, the oracle's included); the mechanics are integrated in
``n_sub`` sub-steps, each exact for a constant torque, with the torques taken at the sub-step's middle (second order:
taken at its start, each harmonic would lag half a sub-step, a torque odd in the direction that the identification
puts into the ripple at the largest cogging order, a sizeable share of a small ripple there). The log holds what the drive records: ``t``,
``theta`` (multi-turn, encoder), ``velocity``, ``iq_1``, ``id_1`` (measured, with noise), plus the truth
(``theta_true``, ``omega_true``, ``torque`` = air-gap torque, e.g. for a torque sensor).

**A drive faster than its log.** With :attr:`RotaryTruth.control_per_log` ``K > 1`` the drive runs all of the above
``K`` times per logged sample (``T_s/K``: encoder, velocity estimate, loops, law, held current) on references and
dither interpolated by a cubic spline, and logs a snapshot of every ``K``-th cycle: an ODrive at 8 kHz or a moteus at
15-40 kHz logged at 1 kHz. The logged current is then not the one that flowed until the next row
(:mod:`pgcomm.rotary.readings`, "Between logged samples").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np
from scipy.interpolate import CubicSpline

from pgcomm.rotary.model import Fourier, RotaryModel
from pgcomm.rotary.motor import RotaryMotor
from pgcomm.rotary.winding import Winding, d_voltage, logged_dq, q_voltage

__all__ = ["RotaryTruth", "Gains", "LawParams", "Reference", "simulate", "default_gains", "VELOCITY_CUTOFF_HZ",
           "SUBSTEPS", "HOLD_ADVANCE"]

#: Cut-off of the drive's velocity estimate (Hz): first-order low-pass on the encoder difference.
VELOCITY_CUTOFF_HZ = 200.0
#: Plant sub-steps per controller sample (the cogging at 8+ samples per period needs ~10).
SUBSTEPS = 10
#: Where in the sample the drive evaluates the law (share of ``T_s`` past the encoder sample, at the
#: estimated velocity): the middle of the sample over which the current is held.
HOLD_ADVANCE = 0.5


@dataclass(frozen=True)
class RotaryTruth:
    """The twin's electromagnetic and mechanical truth (SI units, module docstring).

    Attributes:
        motor: the nominal description the user has (:class:`RotaryMotor`).
        k_t: true mean torque constant in the true frame (N·m/A).
        offset_error: ``δ`` (rad, electrical): true frame minus drive frame.
        ripple: ``ρ(θ)`` (-), relative, zero mean.
        cogging: ``T_cog(θ)`` (N·m).
        drag: ``D(θ)`` (N·m), zero mean: the position-dependent direction-dependent torque.
        coulomb: ``T_c`` (N·m); viscous: ``b`` (N·m·s/rad); inertia: ``J`` (kg·m²).
        friction_velocity: ``ω_ε`` (rad/s) of the smooth sign.
        current_noise: std of the logged ``i_q``, ``i_d`` (A).
        torque_noise: std of the logged torque (N·m).
        encoder_counts: counts per revolution.
        winding: the winding and inverter behind the logged q-voltage (:mod:`pgcomm.rotary.winding`), or
            ``None`` for a twin that logs no voltage.
        control_per_log: the drive's control samples per logged sample (``motor.sample_time`` is the log's
            period). 1: the drive controls at its log rate. ``K > 1``: it controls at ``K`` times the log rate (an
            ODrive at 8 kHz, a moteus at 15-40 kHz logged at 1 kHz), and the log holds a snapshot at every
            ``K``-th control sample, so the current between two logged samples is not the one logged.
    """

    motor: RotaryMotor
    k_t: float
    offset_error: float
    ripple: Fourier
    cogging: Fourier
    drag: Fourier
    coulomb: float
    viscous: float
    inertia: float
    friction_velocity: float
    current_noise: float
    torque_noise: float
    encoder_counts: int
    winding: Winding | None = None
    control_per_log: int = 1

    def __post_init__(self):
        k = self.control_per_log
        if isinstance(k, bool) or int(k) != k or k < 1:
            raise ValueError(f"control_per_log = {k!r} must be a positive integer")
        object.__setattr__(self, "control_per_log", int(k))

    @property
    def k0(self) -> float:
        """Mean effective torque constant seen from the drive frame: ``k_t cos δ`` (N·m/A)."""
        return self.k_t * math.cos(self.offset_error)

    def model(self) -> RotaryModel:
        """The truth in current units (:class:`RotaryModel`): what an ideal identification returns."""
        k0 = self.k0
        direction = Fourier(np.concatenate([[0], self.drag.orders]),
                            np.concatenate([[[self.coulomb, 0.0]], self.drag.coef]) / k0)
        return RotaryModel(self.motor.pole_pairs, self.cogging.scaled(1.0 / k0), self.ripple, direction,
                           viscous=self.viscous / k0, inertia_ratio=self.inertia / k0, k_t=k0,
                           info={"source": "twin truth"})

    def air_gap_torque(self, theta, iq) -> np.ndarray:
        """``T_em`` (N·m) at angles ``theta`` (rad) and drive-frame q-currents ``iq`` (A), broadcast."""
        th = np.asarray(theta, float)
        return self.k0 * (1.0 + self.ripple(th)) * np.asarray(iq, float) + self.cogging(th)

    def rated_current(self) -> float:
        """A nominal scale for currents (A): the current limit, else 1 A."""
        return float(self.motor.current_limit) if self.motor.current_limit else 1.0

    def to_dict(self) -> dict:
        return {"motor": self.motor.to_dict(), "k_t": self.k_t, "offset_error": self.offset_error,
                "ripple": self.ripple.to_dict(), "cogging": self.cogging.to_dict(), "drag": self.drag.to_dict(),
                "coulomb": self.coulomb, "viscous": self.viscous, "inertia": self.inertia,
                "friction_velocity": self.friction_velocity, "current_noise": self.current_noise,
                "torque_noise": self.torque_noise, "encoder_counts": self.encoder_counts,
                **({"winding": self.winding.to_dict()} if self.winding is not None else {}),
                **({"control_per_log": self.control_per_log} if self.control_per_log != 1 else {})}

    @classmethod
    def from_dict(cls, d: dict) -> "RotaryTruth":
        m = dict(d["motor"])
        m.pop("kind", None)
        return cls(RotaryMotor(**m), float(d["k_t"]), float(d["offset_error"]), Fourier.from_dict(d["ripple"]),
                   Fourier.from_dict(d["cogging"]), Fourier.from_dict(d["drag"]), float(d["coulomb"]),
                   float(d["viscous"]), float(d["inertia"]), float(d["friction_velocity"]),
                   float(d["current_noise"]), float(d["torque_noise"]), int(d["encoder_counts"]),
                   Winding.from_dict(d["winding"]) if "winding" in d else None, d.get("control_per_log", 1))


@dataclass(frozen=True)
class Gains:
    """Feedback gains of the drive, in current units (A per rad, per rad/s, ...).

    Position loop (PID): ``u = kp e + ki ∫e + kd ė``; speed loop (PI): ``u = kpv e_v + kiv ∫e_v``.
    """

    kp: float
    ki: float
    kd: float
    kpv: float
    kiv: float


def default_gains(inertia_ratio: float, position_hz: float = 15.0, speed_hz: float = 30.0) -> Gains:
    """Pole-placement gains for the plant ``(J/k0) θ̈ = u``.

    Position: a triple pole at ``2π position_hz``; speed: a double pole at ``2π speed_hz``.

    Args:
        inertia_ratio: ``J/k0`` (A·s²/rad), nominal or identified.
    """
    a = float(inertia_ratio)
    wp, wv = 2 * math.pi * position_hz, 2 * math.pi * speed_hz
    return Gains(kp=3 * a * wp**2, ki=a * wp**3, kd=3 * a * wp, kpv=2 * a * wv, kiv=a * wv**2)


@dataclass(frozen=True)
class LawParams:
    """A commutation law plus its feedforward, as the simulator runs it (current units).

    ``i_q = (u − c(θ) + d(θ) s) / (1 + r(θ)) + table(θ)``, ``u = fb + ff_a α_r + ff_b ω_r + ff_d s + dither``
    with ``s = sign(ω_r)``; ``table`` (``(n,)`` A, linear interpolation on ``θ_j = 2π j/n``) is the
    drives' standstill table. The maps and the table are read at ``θ = θ_enc + advance · ω̂ T_s``
    (``advance`` in samples, ω̂ the drive's velocity estimate): ½ is the middle of the sample over
    which the current is held (module docstring), 0 the encoder angle as sampled.
    """

    model: RotaryModel
    table: np.ndarray | None = None
    ff_a: float = 0.0
    ff_b: float = 0.0
    ff_d: float = 0.0
    advance: float = HOLD_ADVANCE

    @classmethod
    def classical(cls, pole_pairs: int, ff_a=0.0, ff_b=0.0, ff_d=0.0) -> "LawParams":
        return cls(RotaryModel.zero(pole_pairs), None, ff_a, ff_b, ff_d)


@dataclass(frozen=True)
class Reference:
    """Reference samples for one run: ``(N,)`` each. ``mode`` ``"position"`` or ``"speed"``.

    Attributes:
        theta: rad; omega: rad/s; alpha: rad/s²; dither: current added to the demand (A).
    """

    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    mode: str = "position"
    dither: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(np.asarray(self.theta).shape[0])


def _pad(n: int) -> int:
    """Array length padded to a multiple of 16 (fewer distinct shapes, fewer compilations)."""
    return max(16, -(-n // 16) * 16)


def _pack_fourier(parts, n_pad):
    """Concatenate Fourier maps into one order vector and one coefficient block per map (zero-padded)."""
    orders = np.concatenate([p.orders for p in parts]).astype(float)
    total = orders.size
    pad = n_pad - total
    h = np.concatenate([orders, np.zeros(pad)])
    blocks = []
    pos = 0
    for p in parts:
        a = np.zeros(n_pad)
        b = np.zeros(n_pad)
        a[pos:pos + p.orders.size] = p.coef[:, 0]
        b[pos:pos + p.orders.size] = p.coef[:, 1]
        blocks.append((a, b))
        pos += p.orders.size
    return h, blocks


def _order_bits(orders: np.ndarray) -> np.ndarray:
    """``(n, B)`` the binary digits (0/1, least significant first) of non-negative integer orders, ``B`` the bit
    length of the highest (at least 1): what :func:`_harmonics` multiplies by."""
    h = np.asarray(orders, float)
    if np.any(h < 0) or not np.array_equal(h, np.round(h)):
        raise ValueError(f"the twin's orders must be non-negative integers, got {h[(h < 0) | (h != np.round(h))][:3]}")
    hi = h.astype(np.int64)
    nbits = max(1, int(hi.max(initial=0)).bit_length())
    return ((hi[:, None] >> np.arange(nbits)[None, :]) & 1).astype(float)


def _harmonics(bits, theta):
    """``(cos(h θ), sin(h θ))`` ``(n,)`` each, for the orders whose binary digits are ``bits`` (:func:`_order_bits`).

    ``e^{i h θ}`` is the product of ``e^{i 2^b θ}`` over the set bits ``b``, each the square of the one before: two
    trigonometric calls per step for any number of orders, where ``cos(h θ)`` took two per order and per plant
    evaluation and was most of the twin's time (XLA's float64 sine costs ~30 ns). The phase's error grows with
    the order as the rounding of ``h θ`` does in the closed form.
    """
    th = jnp.mod(theta, 2 * jnp.pi)
    zr, zi = jnp.cos(th), jnp.sin(th)
    cr = jnp.ones(bits.shape[0])
    ci = jnp.zeros(bits.shape[0])
    for b in range(bits.shape[1]):
        sel = bits[:, b]
        nr, ni = cr * zr - ci * zi, cr * zi + ci * zr
        cr, ci = cr + sel * (nr - cr), ci + sel * (ni - ci)
        zr, zi = zr * zr - zi * zi, 2.0 * zr * zi
    return cr, ci


@partial(jax.jit, static_argnames=("n_sub",))
def _run(params, xs, n_sub: int):
    (h_p, rho_a, rho_b, cog_a, cog_b, drag_a, drag_b, k0, coul, visc, inertia, w_eps, ts, q,
     h_l, lc_a, lc_b, lr_a, lr_b, ld_a, ld_b, table, n_table, ff_a, ff_b, ff_d,
     kp, ki, kd, kpv, kiv, beta, i_lim, mode_pos, theta0, advance) = params
    dt = ts / n_sub

    def plant_torque(theta, omega, iq):
        c, s = _harmonics(h_p, theta)
        # sums of products rather than dot products: XLA fuses them into one loop, where each small dot was a
        # library call of its own (the dots were half the twin's time)
        rho = jnp.sum(c * rho_a + s * rho_b)
        cog = jnp.sum(c * cog_a + s * cog_b)
        drag = jnp.sum(c * drag_a + s * drag_b)
        t_em = k0 * (1.0 + rho) * iq + cog
        return t_em, t_em - (coul + drag) * jnp.tanh(omega / w_eps) - visc * omega

    def step(carry, x):
        theta, omega, th_prev, w_f, integ, acc = carry
        th_r, w_r, a_r, dith = x
        th_m = jnp.round(theta / q) * q
        w_f = w_f + beta * ((th_m - th_prev) / ts - w_f)
        e_p, e_v = th_r - th_m, w_r - w_f
        integ = integ + ts * (mode_pos * e_p + (1.0 - mode_pos) * e_v)
        u_fb = mode_pos * (kp * e_p + ki * integ + kd * e_v) + (1.0 - mode_pos) * (kpv * e_v + kiv * integ)
        sgn = jnp.sign(w_r)
        u = u_fb + ff_a * a_r + ff_b * w_r + ff_d * sgn + dith
        # the commutation law at the angle of the middle of the hold (LawParams.advance)
        th_l = th_m + advance * ts * w_f
        c, s = _harmonics(h_l, th_l)
        x_t = jnp.mod(th_l, 2 * jnp.pi) / (2 * jnp.pi) * n_table
        j0 = jnp.floor(x_t)
        fr = x_t - j0
        n_int = jnp.maximum(n_table, 1.0).astype(jnp.int32)
        j0 = j0.astype(jnp.int32) % n_int
        j1 = (j0 + 1) % n_int
        tab = (1.0 - fr) * table[j0] + fr * table[j1]
        law_cog, law_dir = jnp.sum(c * lc_a + s * lc_b), jnp.sum(c * ld_a + s * ld_b)
        iq = (u - law_cog + law_dir * sgn) / (1.0 + jnp.sum(c * lr_a + s * lr_b)) + tab
        iq = jnp.where(jnp.isfinite(iq), iq, 0.0)  # a NaN demand gives zero current, never NaN torque
        iq = jnp.clip(iq, -i_lim, i_lim)
        t_em0, _ = plant_torque(theta, omega, iq)
        out = (th_m, w_f, theta, omega, t_em0, u, iq)

        def sub(_, st):
            th, om, acc = st
            # exact for a torque constant over the sub-step (the held current's part is): semi-implicit
            # Euler's dt²/2 error per sub-step would bias the identified friction by tens of per cent under a 100 Hz
            # dither.
            # The torques are taken at the sub-step's middle, the angle and speed predicted from the last sub-step's
            # acceleration (second order, at one evaluation per sub-step): taken at its start, the angle's lag half a
            # sub-step, a turn of h ω dt / 2 of each harmonic that is odd in the direction, and the fit can hold an
            # odd torque at the largest cogging order only in the ripple's column there (through the friction's
            # current), where the cogging is thousands of times the ripple's torque, so a small turn is a large share
            # of the ripple there (bench/rotary_ripple_bias.py)
            _, t_net = plant_torque(th + 0.5 * dt * om + 0.125 * dt * dt * acc, om + 0.5 * dt * acc, iq)
            acc = t_net / inertia
            return th + dt * om + 0.5 * dt * dt * acc, om + dt * acc, acc

        theta_n, omega_n, acc_n = jax.lax.fori_loop(0, n_sub, sub, (theta, omega, acc), unroll=n_sub <= 4)
        return (theta_n, omega_n, th_m, w_f, integ, acc_n), out

    q0 = jnp.round(theta0 / q) * q
    # the acceleration the first sub-step predicts its middle from: the rotor starts at rest, with none
    carry0 = (theta0, 0.0 * theta0, q0, 0.0 * theta0, 0.0 * theta0, 0.0 * theta0)
    _, outs = jax.lax.scan(step, carry0, xs)
    return outs


def simulate(truth: RotaryTruth, ref: Reference, law: LawParams, gains: Gains, seed: int = 0,
             n_sub: int = SUBSTEPS, theta0: float | None = None) -> dict[str, np.ndarray]:
    """Closed-loop run of the twin on a drive with ``law``.

    Args:
        truth: the motor (:class:`RotaryTruth`).
        ref: reference samples (:class:`Reference`); the run has ``ref.n`` samples of ``T_s``.
        law: commutation law and feedforward (:class:`LawParams`).
        gains: feedback gains (:class:`Gains`).
        seed: current-noise seed (same seed, same numbers).
        n_sub: plant sub-steps per logged sample (per control sample ``ceil(n_sub / K)``, at least 2, where the drive
            controls at ``K = truth.control_per_log`` times the log rate).
        theta0: initial true angle (rad; default the reference's first angle); starts at rest.

    Returns:
        dict of ``(N,)`` arrays at the logged instants ``j T_s``: ``t`` (s), ``theta`` (encoder, rad), ``velocity``
        (rad/s, the drive's estimate), ``iq_1``, ``id_1`` (A, measured), ``theta_true``, ``omega_true``, ``torque``
        (air-gap N·m, with ``torque_noise``), ``iq_true`` (A, what flows from that instant), ``demand`` (A),
        ``theta_ref``, ``omega_ref``; and ``vq_1``, ``vd_1`` (V, the drive's q- and d-voltage commands,
        :mod:`pgcomm.rotary.winding`) when ``truth.winding`` is set. Where the drive controls faster than it logs
        (``control_per_log = K > 1``) the references are interpolated to the control samples by a cubic spline and every
        column is the snapshot of every ``K``-th control sample; the measurement noises are drawn per logged
        sample, so they are the same numbers for every ``K``.
    """
    m = truth.motor
    ts = float(m.sample_time)
    k_ctl = truth.control_per_log
    tc = ts / k_ctl
    n = ref.n
    n_f = n * k_ctl
    n_pad = _pad(truth.ripple.orders.size + truth.cogging.orders.size + truth.drag.orders.size)
    h_p, ((ra, rb), (ca, cb), (da, db)) = _pack_fourier([truth.ripple, truth.cogging, truth.drag], n_pad)
    lm = law.model
    n_lpad = _pad(lm.cogging.orders.size + lm.ripple.orders.size + lm.direction.orders.size)
    h_l, ((lca, lcb), (lra, lrb), (lda, ldb)) = _pack_fourier([lm.cogging, lm.ripple, lm.direction], n_lpad)
    if law.table is None:
        table, n_table = np.zeros(16), 0
    else:
        t = np.asarray(law.table, float)
        table, n_table = np.concatenate([t, np.zeros(_pad(t.size) - t.size)]), t.size
    i_lim = float(m.current_limit) if m.current_limit else np.inf
    beta = 1.0 - math.exp(-2 * math.pi * VELOCITY_CUTOFF_HZ * tc)
    q = 2 * math.pi / truth.encoder_counts
    mode_pos = {"position": 1.0, "speed": 0.0}[ref.mode]
    th0 = float(ref.theta[0]) if theta0 is None else float(theta0)
    f = float
    params = (jnp.asarray(_order_bits(h_p)), *(jnp.asarray(v) for v in (ra, rb, ca, cb, da, db)), f(truth.k0),
              f(truth.coulomb),
              f(truth.viscous), f(truth.inertia), f(truth.friction_velocity), tc, q,
              jnp.asarray(_order_bits(h_l)), *(jnp.asarray(v) for v in (lca, lcb, lra, lrb, lda, ldb)),
              jnp.asarray(table),
              float(n_table), f(law.ff_a), f(law.ff_b), f(law.ff_d),
              f(gains.kp), f(gains.ki), f(gains.kd), f(gains.kpv), f(gains.kiv), beta, i_lim, mode_pos, th0,
              f(law.advance))
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((3, n))
    dither = np.zeros(n) if ref.dither is None else np.asarray(ref.dither, float)
    refs = [np.asarray(v, float) for v in (ref.theta, ref.omega, ref.alpha, dither)]
    if k_ctl > 1:
        # a drive generates its references and dither at its own rate: smooth between the logged samples (a linear
        # interpolation's kinks put 3 % of a 100 Hz dither's amplitude into every logged interval's mean)
        t_f = np.minimum(tc * np.arange(n_f), ts * (n - 1))
        refs = [CubicSpline(ts * np.arange(n), v)(t_f) if n > 1 else np.repeat(v, k_ctl) for v in refs]
        n_sub = max(2, -(-int(n_sub) // k_ctl))
    outs = [np.asarray(o) for o in _run(params, tuple(jnp.asarray(v) for v in refs), n_sub)]
    th_m, w_f, th_f, om_f, tq, u, iq_f = (o[::k_ctl] for o in outs)
    iq_act = iq_f
    iq = iq_act + truth.current_noise * noise[0]
    idd = truth.current_noise * noise[1]
    log = {"t": ts * np.arange(n), "theta": th_m, "velocity": w_f, "iq_1": iq, "id_1": idd, "theta_true": th_f,
           "omega_true": om_f, "iq_true": iq_act, "torque": tq + truth.torque_noise * noise[2], "demand": u,
           "theta_ref": np.asarray(ref.theta, float), "omega_ref": np.asarray(ref.omega, float)}
    if truth.winding is not None:
        w = truth.winding
        # the voltages the loop commands between logged samples follow the current at the control rate (its slope
        # L di/dt); the logged noises are per logged sample, added to the snapshots
        # only the slope needs the control rate's samples; the rest is read at the logged instants
        di = np.gradient(outs[6], tc)[::k_ctl] if outs[6].size > 1 else np.zeros(n)
        # drawn after the currents' noise, so a twin with a winding logs the same currents as one without
        v_noise = rng.standard_normal(n)
        log["vq_1"] = (q_voltage(w, truth.k0, truth.ripple, m.pole_pairs, m.commutation_offset, th_f, om_f, iq_act, tc,
                                 0.0, slope=di) - w.loop_gain * (iq - iq_act) + w.voltage_noise * v_noise)
        # drawn after the q-voltage's, which is then the same as a twin's that logs no d-voltage
        v_noise = rng.standard_normal(n)
        log["vd_1"] = (d_voltage(w, truth.k_t, truth.offset_error, truth.ripple, m.pole_pairs, m.commutation_offset,
                                 th_f, om_f, iq_act, 0.0) - w.loop_gain * idd + w.voltage_noise * v_noise)
        if w.voltage_lag:
            log["vd_1"], log["vq_1"] = logged_dq(log["vd_1"], log["vq_1"], m.pole_pairs, om_f, w.voltage_lag)
    return log


def with_motor(truth: RotaryTruth, **changes) -> RotaryTruth:
    """``truth`` with fields of its motor replaced (e.g. ``sample_time``)."""
    return replace(truth, motor=replace(truth.motor, **changes))
