"""Commutation laws and the current <-> drive-input transformation.

* Minimum-energy inversion of any gain matrix ``K(y)`` (eq. Commutation_Solution_Ideal
  and eq. Commutation_Model_Currents): ``i = argmin |i|^2 s.t. K i = F*``.
* The single-direction closed form (eq. Commutation_Solution_Ideal_SingleCoilset)
  with force split ``k̂_l^2 / Σ_m k̂_m^2``.
* The drive with fixed commutation: ``Γ(y)`` (eq. Commutation_Rewritten1_Gamma),
  ``T`` / ``T^{-1}`` (eq. Input_Transformation, ``atan2``), the drive law
  (eq. Commutation_Solution_With_PhaseOffset) and currents -> ``(Fy^l*, Δ^l)``
  (eq. Current_To_ForceDelta). Sign convention of the drive inputs: ``Fy^l*`` signed,
  ``Δ^l ∈ (-π/2, π/2]`` (:func:`transform_T_inverse`).

Every law is a pytree with a method ``currents(y, F_star, v=None)`` taking positions of
shape ``S`` (m), desired forces ``S + (3,)`` (``[Fy, Fx, Tz]`` in N, N, N·m) and the
velocity ``S`` (m/s) the law may use, returning star currents ``S + (L, 2)`` (A). All are
vectorised and jittable. Static laws ignore ``v``. A law with ``true_state = True`` (the
oracle) is fed the plant's true position and velocity by the simulation; every other law
gets what a controller has: the encoder position and the reference velocity.

Energy metric. Copper loss is proportional to ``ia^2 + ib^2 + ic^2`` with
``ic = -ia - ib``, i.e. ``i^T Q i`` per coil set with ``Q = [[2, 1], [1, 2]]``.
Minimising it over the star currents equals the paper's ``K^†`` of the full
``3 x 3L`` phase matrix (its rows sum to zero over phases, so the pseudo-inverse
already satisfies the star constraint). ``metric="star"`` minimises the plain
``ia^2 + ib^2`` instead, which is the literal ``K̂^†`` of the reduced ``3 x 2L``
matrix of eq. Commutation_Model_Currents.
"""

from __future__ import annotations

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.motor import Motor, commutation_phase, ideal_gain_phases, star_reduce, star_to_phases
from pgcomm.protocols import Plant

#: Inverse of the per-coil-set copper-loss metric ``Q = [[2, 1], [1, 2]]``.
_QINV_PHASE = np.array([[2.0, -1.0], [-1.0, 2.0]]) / 3.0

#: Normalised determinant below which the 3x3 system is damped (see :func:`min_energy_currents`).
DEFAULT_DET_MIN = 1e-6
#: Tikhonov damping (relative, on the row-normalised system) when fully singular.
DEFAULT_DAMPING = 1e-6


def metric_inverse(n_coil_sets: int, metric: str = "phase"):
    """Inverse energy metric ``W^{-1}`` of shape ``(L, 2, 2)`` (block diagonal over coil sets)."""
    if metric == "phase":
        blk = _QINV_PHASE
    elif metric == "star":
        blk = np.eye(2)
    else:
        raise ValueError(f"metric must be 'phase' or 'star', got {metric!r}")
    return jnp.asarray(np.broadcast_to(blk, (n_coil_sets, 2, 2)).copy())


def _inv3_sym(a):
    """Inverse of symmetric ``(..., 3, 3)`` matrices by the adjugate (fast for large batches)."""
    a00, a01, a02 = a[..., 0, 0], a[..., 0, 1], a[..., 0, 2]
    a11, a12, a22 = a[..., 1, 1], a[..., 1, 2], a[..., 2, 2]
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    adj = jnp.stack(
        [jnp.stack([c00, c01, c02], -1), jnp.stack([c01, c11, c12], -1), jnp.stack([c02, c12, c22], -1)], -2
    )
    return adj / det[..., None, None], det


def min_energy_currents(gain, force, winv, det_min=DEFAULT_DET_MIN, damping=DEFAULT_DAMPING):
    """Minimum-energy currents that produce ``force`` through ``gain``.

    Solves ``min i^T W i  s.t.  K i = F`` in closed form,
    ``i = W^{-1} K^T (K W^{-1} K^T)^{-1} F``, with ``K`` the ``3 x 2L`` matrix
    ``[K^1, ..., K^L]``. The ``3 x 3`` matrix ``A = K W^{-1} K^T`` is row-normalised,
    ``Â = D A D`` with ``D = diag(A)^{-1/2}`` (so units of N and N·m do not matter),
    and its determinant ``c = det Â ∈ [0, 1]`` measures conditioning. If
    ``c >= det_min`` the solution is the exact minimum-norm one. Below it, Tikhonov
    damping ``(Â + ε² I)`` with ``ε² = damping · (1 - c/det_min)²`` is added, so the
    law stays bounded where ``K`` loses rank (e.g. one coil set, or a lever arm of
    zero) and approaches the least-squares compromise there.

    One coil set (``L = 1``) has two currents for three force rows: no current vector
    meets ``F*`` in general, and a least-squares compromise over rows in N and N·m would
    give up driving force. The paper's commutation serves ``Fy`` first, so with ``L = 1``
    the ``Fy`` and ``Fx`` rows are met exactly (``Tz`` follows from them: for one coil set
    it is ``d·Fx - x·Fy``), by the same row-normalised, damped solve on the ``2 x 2`` system.

    Args:
        gain: ``(..., L, 3, 2)`` gain matrices (N/A).
        force: ``(..., 3)`` desired force ``[Fy, Fx, Tz]``.
        winv: ``(L, 2, 2)`` inverse energy metric (:func:`metric_inverse`).

    Returns:
        ``(..., L, 2)`` star currents (A).
    """
    if gain.shape[-3] == 1:
        return _single_coil_set_currents(gain, force, det_min, damping)
    # broadcast-and-sum rather than einsum: tiny dots are slow inside XLA loops (scan bodies)
    kw = jnp.sum(gain[..., :, :, :, None] * winv[:, None, :, :], axis=-2)  # K^l W^{-1}: (..., L, 3, 2)
    a = jnp.sum(kw[..., :, :, None, :] * gain[..., :, None, :, :], axis=(-4, -1))  # Σ_l K^l W^{-1} K^lT
    diag = jnp.diagonal(a, axis1=-2, axis2=-1)
    scale = jnp.max(diag, axis=-1, keepdims=True)
    dinv = 1.0 / jnp.sqrt(jnp.maximum(diag, 1e-30 * scale + 1e-300))
    an = a * dinv[..., :, None] * dinv[..., None, :]
    _, c = _inv3_sym(an)
    eps2 = damping * jnp.clip(1.0 - c / det_min, 0.0, 1.0) ** 2
    inv, _ = _inv3_sym(an + eps2[..., None, None] * jnp.eye(3))
    z = jnp.sum(inv * (force * dinv)[..., None, :], axis=-1) * dinv
    return jnp.sum(kw * z[..., None, :, None], axis=-2)


def _single_coil_set_currents(gain, force, det_min, damping):
    """``L = 1``: currents meeting the ``Fy`` and ``Fx`` rows, ``(..., 1, 2)`` (see :func:`min_energy_currents`)."""
    k = gain[..., 0, :2, :]                                    # (..., 2, 2): rows Fy, Fx
    rn = 1.0 / jnp.sqrt(jnp.maximum(jnp.sum(k * k, axis=-1), 1e-300))  # row norms (A/N)
    kn = k * rn[..., :, None]
    f = force[..., :2] * rn
    a, b, c, d = kn[..., 0, 0], kn[..., 0, 1], kn[..., 1, 0], kn[..., 1, 1]
    det = a * d - b * c                                        # |det| <= 1 after row normalisation
    # Tikhonov on the normalised system where the rows become parallel (e.g. mu = 0)
    eps2 = damping * jnp.clip(1.0 - det * det / det_min, 0.0, 1.0) ** 2
    # i = Kn^T (Kn Kn^T + eps2 I)^{-1} f: the damped least-squares solution, exact when eps2 = 0
    g00, g01, g11 = a * a + b * b + eps2, a * c + b * d, c * c + d * d + eps2
    gdet = g00 * g11 - g01 * g01
    z0 = (g11 * f[..., 0] - g01 * f[..., 1]) / gdet
    z1 = (g00 * f[..., 1] - g01 * f[..., 0]) / gdet
    i = jnp.stack([a * z0 + c * z1, b * z0 + d * z1], axis=-1)
    return i[..., None, :]


def limit_currents(currents, current_limit):
    """Scale all coil sets by one factor so that no phase current exceeds ``current_limit`` (A).

    Scaling keeps the force direction; ``ic = -ia - ib`` is included. ``None`` = no limit.
    """
    if current_limit is None:
        return currents
    peak = jnp.max(jnp.abs(star_to_phases(currents)), axis=(-2, -1))
    s = jnp.minimum(1.0, current_limit / jnp.maximum(peak, 1e-300))
    return currents * s[..., None, None]


@pytree_dataclass
class ClassicalLaw:
    """Classical commutation ``i = K(y)^† F*`` with the ideal gain matrix (eq. Commutation_Solution_Ideal).

    Attributes:
        k, zeta: ``(L,)`` motor constants ``k̂^l`` (N/A) and phase offsets ``ζ̂^l`` (rad).
        mu: ``μ̂`` (-); lever_arms ``(L,)`` (m).
        pole_pitch: ``d_m`` (m).
    """

    k: jnp.ndarray
    zeta: jnp.ndarray
    mu: jnp.ndarray
    lever_arms: jnp.ndarray
    pole_pitch: float = static_field()
    metric: str = static_field(default="phase")
    current_limit: float | None = static_field(default=None)

    @classmethod
    def from_motor(cls, motor: Motor, k=None, zeta=None, metric="phase") -> "ClassicalLaw":
        """Build from a :class:`Motor`, optionally overriding ``k̂``, ``ζ̂`` (scalars or ``(L,)``)."""
        n = motor.n_coil_sets
        k = np.broadcast_to(np.asarray(motor.k if k is None else k, float), (n,))
        zeta = np.broadcast_to(np.asarray(motor.zeta if zeta is None else zeta, float), (n,))
        return cls(jnp.asarray(k), jnp.asarray(zeta), jnp.asarray(float(motor.mu)),
                   jnp.asarray(motor.lever_arms), float(motor.pole_pitch), metric, motor.current_limit)

    def gain(self, y):
        """Ideal star-reduced gain ``(..., L, 3, 2)`` of this law's parameters."""
        g3 = ideal_gain_phases(jnp.asarray(y)[..., None], self.k, self.zeta, self.mu, self.lever_arms,
                               self.pole_pitch)
        return star_reduce(g3)

    def currents(self, y, f_star, v=None):
        """Star currents ``(..., L, 2)`` (A) for positions ``y`` (m) and desired ``F*`` ``(..., 3)``; ``v`` unused."""
        winv = metric_inverse(self.k.shape[0], self.metric)
        i = min_energy_currents(self.gain(y), f_star, winv)
        return limit_currents(i, self.current_limit)


def force_split(k):
    """Weights ``k̂_l^2 / Σ_m k̂_m^2`` that split ``Fy*`` over coil sets (eq. Commutation_Solution_Ideal_SingleCoilset)."""
    k = jnp.asarray(k)
    return k**2 / jnp.sum(k**2)


def classical_single_direction(y, fy_star, k, zeta, pole_pitch):
    """Closed-form classical commutation for ``F* = [Fy*, 0, 0]`` (eq. Commutation_Solution_Ideal_SingleCoilset).

    ``i^l = [sin η̂^l, sin(η̂^l + 2π/3)] · w_l Fy* / k̂^l`` with ``w_l = k̂_l² / Σ k̂_m²``.

    Args:
        y: ``S`` positions (m); fy_star: ``S`` desired driving force (N).
        k, zeta: ``(L,)`` nominal ``k̂^l`` (N/A), ``ζ̂^l`` (rad).

    Returns:
        ``S + (L, 2)`` star currents (A).
    """
    k = jnp.asarray(k)
    eta = commutation_phase(jnp.asarray(y)[..., None], jnp.asarray(zeta), pole_pitch)
    amp = (force_split(k) / k) * jnp.asarray(fy_star)[..., None]
    return jnp.stack([jnp.sin(eta), jnp.sin(eta + 2 * jnp.pi / 3)], axis=-1) * amp[..., None]


# --- drives with fixed commutation -----------------------------------------------------------


def gamma(y, k_hat, zeta_hat, pole_pitch):
    """``Γ(y)`` of eq. Commutation_Rewritten1_Gamma, shape ``S + (2, 2)`` (A/N).

    ``Γ = (1/k̂) [[sin η̂, cos η̂], [sin(η̂ + 2π/3), cos(η̂ + 2π/3)]]``; its determinant
    is ``-(√3/2)/k̂²``, so it is invertible at every position.
    """
    eta = commutation_phase(jnp.asarray(y), zeta_hat, pole_pitch)
    e2 = eta + 2 * jnp.pi / 3
    g = jnp.stack([jnp.stack([jnp.sin(eta), jnp.cos(eta)], -1), jnp.stack([jnp.sin(e2), jnp.cos(e2)], -1)], -2)
    return g / jnp.asarray(k_hat)[..., None, None]


def gamma_inverse(y, k_hat, zeta_hat, pole_pitch):
    """Closed-form ``Γ(y)^{-1}``, shape ``S + (2, 2)`` (N/A)."""
    eta = commutation_phase(jnp.asarray(y), zeta_hat, pole_pitch)
    e2 = eta + 2 * jnp.pi / 3
    # inverse of [[a, b], [c, d]] is [[d, -b], [-c, a]] / (ad - bc); ad - bc = -sin(2π/3)
    det = -np.sin(2 * np.pi / 3)
    inv = jnp.stack([jnp.stack([jnp.cos(e2), -jnp.cos(eta)], -1), jnp.stack([-jnp.sin(e2), jnp.sin(eta)], -1)], -2)
    return inv * (jnp.asarray(k_hat)[..., None, None] / det)


def transform_T(fy, delta):
    """``T``: ``(Fy*, Δ) -> (F1*, F2*) = (cos Δ · Fy*, sin Δ · Fy*)`` (eq. Input_Transformation). Shape ``S + (2,)``."""
    return jnp.stack([jnp.cos(delta) * fy, jnp.sin(delta) * fy], axis=-1)


def transform_T_inverse(f12):
    """``T^{-1}``: ``(F1*, F2*) -> (Fy*, Δ)`` with the sign kept in the force: ``Δ ∈ (-π/2, π/2]``, ``Fy*`` signed.

    ``(Fy*, Δ)`` and ``(-Fy*, Δ ± π)`` make the same currents, so the pair is not unique; the one
    convention of the package (logs ``Fy_ref_l``, ``delta_l``, the C law's ``NAME_drive_inputs``) is
    ``Δ = atan2(F2*, F1*)`` folded by π onto ``(-π/2, π/2]``, flipping the sign of ``Fy* = ±|F|`` when
    it is folded. A data set ``Z_i^l`` driven at one ``Δ`` then logs that ``Δ`` throughout while
    ``Fy_ref_l`` follows the sign of the demand (no jump of ``Δ`` by π when the force reverses).
    The boundary belongs to the positive side: ``F1* = 0``, ``F2* > 0`` gives ``Δ = π/2``, ``Fy* > 0``;
    ``F1* = 0``, ``F2* < 0`` gives ``Δ = π/2``, ``Fy* < 0``. Zero force gives ``Fy* = 0``, ``Δ = 0``.

    Args:
        f12: ``S + (2,)`` (N). Returns ``(fy, delta)`` each of shape ``S`` (N, rad).
    """
    f1, f2 = f12[..., 0], f12[..., 1]
    mag = jnp.hypot(f1, f2)
    d = jnp.arctan2(f2, f1)
    half = jnp.pi / 2
    # the same operations as the exported C (NAME_drive_inputs), so both agree to rounding
    up, down = d > half, d <= -half
    flip = up | down
    d = jnp.where(up, d - jnp.pi, jnp.where(down, d + jnp.pi, d))
    fy = jnp.where(flip, -mag, mag)
    zero = mag == 0.0  # atan2 of (±0, ±0) is 0, ±π: no direction, report Δ = 0 and +0 N
    return jnp.where(zero, 0.0, fy), jnp.where(zero, 0.0, d)


def drive_currents(y, fy, delta, k_hat, zeta_hat, pole_pitch):
    """Currents a fixed-commutation drive makes from ``(Fy^l*, Δ^l)`` (eq. Commutation_Solution_With_PhaseOffset).

    ``i^l = (1/k̂) [sin(η̂ + Δ^l), sin(η̂ + Δ^l + 2π/3)] Fy^l* = Γ(y) T(Fy^l*, Δ^l)``.

    Args:
        y: ``S`` (m); fy, delta: ``S + (L,)`` (N, rad; any sign of ``fy``, any ``Δ``: the convention of
            :func:`transform_T_inverse` is one of the equivalent pairs); k_hat, zeta_hat: drive's fixed
            ``k̂`` (N/A), ``ζ̂`` (rad), scalars or ``(L,)``.

    Returns:
        ``S + (L, 2)`` star currents (A).
    """
    eta = commutation_phase(jnp.asarray(y)[..., None], zeta_hat, pole_pitch) + delta
    amp = fy / jnp.asarray(k_hat)
    return jnp.stack([jnp.sin(eta), jnp.sin(eta + 2 * jnp.pi / 3)], axis=-1) * amp[..., None]


def currents_to_drive_inputs(y, currents, k_hat, zeta_hat, pole_pitch):
    """Drive inputs ``(Fy^l*, Δ^l) = T^{-1}(Γ(y)^{-1} i^l)`` (eq. Current_To_ForceDelta).

    ``drive_currents(y, fy, delta, ...)`` gives the currents back. Convention of
    :func:`transform_T_inverse`: ``Fy^l*`` signed, ``Δ^l ∈ (-π/2, π/2]``.

    Args:
        y: ``S`` (m); currents: ``S + (L, 2)`` (A); k_hat, zeta_hat: the drive's ``k̂`` (N/A),
            ``ζ̂`` (rad), scalars or ``(L,)``; pole_pitch: ``d_m`` (m).

    Returns:
        ``(fy, delta)`` each ``S + (L,)`` in N (signed) and rad (in ``(-π/2, π/2]``).
    """
    ginv = gamma_inverse(jnp.asarray(y)[..., None], k_hat, zeta_hat, pole_pitch)
    f12 = jnp.sum(ginv * currents[..., None, :], axis=-1)
    return transform_T_inverse(f12)


@pytree_dataclass
class DriveInputLaw:
    """Fixed-commutation operation of one coil set with a constant phase offset (data sets ``Z_i^l``, eq. DataSets).

    The active coil set gets ``Fy^l* = Fy*`` and ``Δ^l = delta``; all others get zero force.
    The drive's commutation uses ``k_hat`` (N/A) and ``zeta_hat`` (rad) of that coil set.
    ``active`` is a one-hot ``(L,)`` array (data, not static), so the ``2L`` data-set
    experiments share one compiled simulation and can run batched.
    """

    k_hat: jnp.ndarray
    zeta_hat: jnp.ndarray
    delta: jnp.ndarray
    active: jnp.ndarray
    pole_pitch: float = static_field()

    @classmethod
    def for_coil_set(cls, motor: Motor, coil_set: int, delta: float) -> "DriveInputLaw":
        """Law exciting coil set ``coil_set`` (0-based) with phase offset ``delta`` (rad), drive ``k̂``, ``ζ̂`` of ``motor``."""
        active = np.zeros(motor.n_coil_sets)
        active[coil_set] = 1.0
        return cls(jnp.asarray(motor.k[coil_set]), jnp.asarray(motor.zeta[coil_set]), jnp.asarray(float(delta)),
                   jnp.asarray(active), float(motor.pole_pitch))

    def currents(self, y, f_star, v=None):
        """Star currents ``(..., L, 2)``: only the active coil set carries current (``v`` unused)."""
        y = jnp.asarray(y)
        eta = commutation_phase(y, self.zeta_hat, self.pole_pitch) + self.delta
        amp = f_star[..., 0] / self.k_hat
        i_l = jnp.stack([jnp.sin(eta), jnp.sin(eta + 2 * jnp.pi / 3)], axis=-1) * amp[..., None]
        return i_l[..., None, :] * self.active[:, None]


@pytree_dataclass
class ModelLaw:
    """Model-based minimum-energy commutation ``i = K̂(y)^† (F* - F̂_cog(y) - F̂_dir(y, v))`` (eq. Commutation_Model_Currents).

    ``model`` is any pytree with ``gain(y) -> (..., L, 3, 2)`` and ``cogging(y) -> (..., 3)``:
    a PGNN, the physics-only model, or a plant's exact truth (the oracle). A model that
    also has ``direction_force(y, v) -> (..., 3)`` (a plant, a PGNN with a direction term)
    has that force subtracted too when the law is given a velocity ``v``.
    Damped where ``K̂`` is ill-conditioned (see :func:`min_energy_currents`) and scaled
    to respect ``current_limit`` (A).

    ``true_state``: the simulation feeds this law the plant's true position and velocity
    instead of the encoder position and the reference velocity (the oracle, which no
    commutation can beat except by noise; see :func:`oracle_law`).

    ``velocity_source``: which velocity the controller gives the law (:mod:`pgcomm.simulate`):
    ``"reference"`` (default: the reference velocity ``ṙ``, exact and without lag, where the
    encoder's difference lags behind its filter or carries its noise; docs/extensions.md) or ``"encoder"`` (the encoder difference through a
    first-order low-pass at ``velocity_cutoff_hz``, Hz).
    """

    model: object
    metric: str = static_field(default="phase")
    current_limit: float | None = static_field(default=None)
    det_min: float = static_field(default=DEFAULT_DET_MIN)
    true_state: bool = static_field(default=False)
    velocity_source: str = static_field(default="reference")
    velocity_cutoff_hz: float = static_field(default=100.0)

    def currents(self, y, f_star, v=None):
        """Star currents ``(..., L, 2)`` (A) for ``y`` (m), ``F*`` ``(..., 3)`` and velocity ``v`` (m/s, or ``None``).

        Safe for every input a controller can pass: beyond the model's training range
        (``model.training_range``, where it has one) the position is held at the range's end (the
        model was not identified there; a network extrapolates without bound); a sample with a
        non-finite position, force demand or velocity gets zero currents; the current limit bounds
        every phase current; a demand so large that the currents overflow gets zero currents. The
        exported C law (:mod:`pgcomm.export.c`) does the same and tells the cases apart by its return
        code (0 inside the range, 1 held at its end, 2 non-finite input: zero currents).
        """
        y = jnp.asarray(y, dtype=float)
        f_star = jnp.asarray(f_star, dtype=float)
        ok = jnp.isfinite(y) & jnp.all(jnp.isfinite(f_star), axis=-1)
        if v is not None:
            v = jnp.asarray(v, dtype=float)
            ok = ok & jnp.isfinite(v)
            v = jnp.where(ok, v, 0.0)
        rng = getattr(self.model, "training_range", None)
        y = jnp.where(ok, y, 0.0 if rng is None else 0.5 * (rng[0] + rng[1]))
        if rng is not None:
            y = jnp.clip(y, rng[0], rng[1])
        f_star = jnp.where(ok[..., None], f_star, 0.0)
        gain = self.model.gain(y)
        winv = metric_inverse(gain.shape[-3], self.metric)
        target = f_star - self.model.cogging(y)
        if v is not None and hasattr(self.model, "direction_force"):
            target = target - self.model.direction_force(y, v)
        i = limit_currents(min_energy_currents(gain, target, winv, det_min=self.det_min), self.current_limit)
        # a finite demand so large that the solve overflows (|F*| near 1e308) gets zero currents too, as
        # the exported C law does (its return code 2)
        ok = ok & jnp.all(jnp.isfinite(i), axis=(-2, -1))
        return jnp.where(ok[..., None, None], i, 0.0)


def oracle_law(plant: Plant, current_limit: float | None = None) -> ModelLaw:
    """The oracle: the exact inverse of everything the plant knows, fed its true state.

    ``i = K(y)^† (F* - F_cog(y) - F_dir(y, v))`` with the plant's true gain, cogging and
    velocity-dependent force at the true position ``y`` and velocity ``v`` of each sample
    (DESIGN.md: the floor that no commutation beats except by noise).
    """
    return ModelLaw(plant, current_limit=current_limit, true_state=True)


@pytree_dataclass
class OffsetLaw:
    """Classical commutation of ``F* - F_off(y)``: a drive's anti-cogging table or harmonic fit.

    ``offset`` is a pytree with ``__call__(y) -> (..., 3)`` force offset (N, N, N·m).
    """

    base: ClassicalLaw
    offset: object

    def currents(self, y, f_star, v=None):
        """Star currents ``(..., L, 2)`` (A); ``v`` unused."""
        return self.base.currents(y, f_star - self.offset(y))

