"""Digital twin of an industrial coreless linear motor: the electromagnetic truth.

The twin is the stand-in for the paper's real CLM (three coil sets, Table
Parameters_CLM). Its force is

    F(y, v, i) = Σ_l K^l(y) i^l + F_cog(y) + F_dir(v),

with every parasitic effect of DESIGN.md switchable through its own parameter
(set it to zero to switch the effect off):

1. per-coil-set motor constant ``k`` and phase offset ``zeta``;
2. per-phase winding imbalance: amplitude ``phase_gain_error`` and angle
   ``phase_angle_error`` of each phase column;
3. slow position dependence of the field along the stroke, evaluated where the
   coil set sits (``y + d^l``): linear/quadratic magnet-strength drift
   ``field_slope``/``field_curvature``, a long-wavelength magnet-to-magnet
   intensity variation ``field_ripple``, a slow commutation-phase drift
   ``phase_drift`` (magnet orientation), and an end effect ``end_drop`` near the
   magnet-track ends ``track_ends`` with decay length ``end_length``;
4. higher spatial harmonics of the magnet field: ``harmonic_5``, ``harmonic_7``
   (relative amplitude) with phases ``harmonic_phase``;
5. out-of-plane coupling ``mu``, lever arms ``lever_arms`` (Tz row = d^l · Fx row)
   and lateral coil offsets ``lateral_offsets`` (Tz row gets ``-x^l`` · Fy row);
6. a current-independent force (cable slab / cogging): a smooth part
   (``cog_offset``, ``cog_slope``, ``cog_curvature``, ``cog_wave`` with wavelength
   ``cog_wave_length``) plus a weak periodic part ``cog_periodic`` with period
   ``cog_period`` that is not a multiple of the pole pitch;
7. a direction-dependent force ``direction_force · (1 + direction_ripple · sin(2π y / direction_ripple_length
   + 0.5)) · tanh(v / direction_velocity)``: its mean is what a constant ``C sign(ẏ)`` can learn,
   the part that varies along the stroke (hysteresis of the magnet track, cable slab) is not
   (paper, Remark on ``sign(dy/dt)``);
8. force-sensor noise and encoder quantisation live in :mod:`pgcomm.sensors`.

Effects 4 and 7 are outside the PGNN model class on purpose. The twin also knows
its exact static inverse: :meth:`TwinPlant.gain` and :meth:`TwinPlant.cogging` are
what the oracle commutation inverts.

Defaults are of the paper's scale: the fundamental ``k``, ``zeta`` are Table
Parameters_CLM's calibrated values, and the parasitic amplitudes are set from
typical magnitudes for a CLM with a cable slab so that classical commutation
shows a commutation error of the paper's size (Table Commutation_Performance).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.motor import PHASE_OFFSETS, Motor
from pgcomm.mechanics import Mechanics
from pgcomm.plant import fundamental, plant_force


@dataclass(frozen=True)
class TwinParams:
    """Parameters of the twin's electromagnetics (SI units; see the module docstring for the effects)."""

    # 1. fundamental
    pole_pitch: float = 0.03
    k: tuple[float, ...] = (61.34, 61.62, 60.07)
    zeta: tuple[float, ...] = (-0.54, -0.55, -0.55)
    # 2. winding imbalance, per coil set and phase a, b, c
    # Coreless windings: a few % spread between phases from turn length and coil placement,
    # mostly systematic (every coil set is wound alike) plus a small per-coil-set part.
    phase_gain_error: tuple[tuple[float, ...], ...] = (
        (0.040, -0.022, -0.018), (0.036, -0.016, -0.020), (0.042, -0.020, -0.022))
    phase_angle_error: tuple[tuple[float, ...], ...] = (
        (0.030, -0.012, -0.018), (0.026, -0.016, -0.010), (0.032, -0.014, -0.018))
    # 3. slow position dependence (relative to the fundamental; positions in m)
    field_slope: float = 0.006           # relative change per 0.1 m
    field_curvature: float = -0.004      # relative, times ((p/0.1)^2 - 1/3)
    field_ripple: float = 0.004          # long-wavelength magnet intensity variation
    field_ripple_length: float = 0.113   # m
    phase_drift: float = 0.006           # rad per 0.1 m
    end_drop: float = 0.03               # relative field drop at a track end
    end_length: float = 0.015            # m
    track_ends: tuple[float, float] = (-0.2, 0.2)
    # 4. higher harmonics
    harmonic_5: float = 0.006
    harmonic_7: float = 0.003
    harmonic_phase: tuple[float, float] = (0.3, -0.8)
    # 5. out-of-plane coupling
    mu: float = 0.05
    lever_arms: tuple[float, ...] = (-0.065, 0.005, 0.075)
    lateral_offsets: tuple[float, ...] = (0.003, -0.002, 0.004)
    # 6. current-independent force: [Fy (N), Fx (N), Tz (N*m)]
    cog_offset: tuple[float, float, float] = (2.7, 0.15, 0.35)
    cog_slope: tuple[float, float, float] = (6.0, 0.25, 0.45)        # per 0.1 m
    cog_curvature: tuple[float, float, float] = (-3.4, 0.1, -0.2)    # times ((y/0.1)^2 - 1/3)
    cog_wave: tuple[float, float, float] = (2.7, 0.2, 0.3)
    cog_wave_length: float = 0.16
    cog_periodic: tuple[float, float, float] = (0.5, 0.05, 0.05)
    cog_period: float = 0.0235
    # 7. direction-dependent force
    direction_force: tuple[float, float, float] = (3.0, 0.1, 0.2)
    direction_velocity: float = 0.002    # m/s
    direction_ripple: float = 0.35       # relative variation along the stroke
    direction_ripple_length: float = 0.07  # m

    @property
    def n_coil_sets(self) -> int:
        """Number of coil sets ``L``."""
        return len(self.k)

    def motor(self, k_hat=67.0, zeta_hat=-0.52, mu_hat=None, sample_time=1e-3, current_limit=10.0,
              mass=None) -> Motor:
        """Nominal :class:`Motor` description of this twin with a starting guess ``k̂`` (N/A), ``ζ̂`` (rad).

        ``mass`` (kg) defaults to the twin's default mechanics (:class:`pgcomm.mechanics.Mechanics`,
        30 kg): on the built-in twin the moving mass is known, so identification without a force
        sensor needs no motor file. :func:`pgcomm.setup.build_setup` passes the configured
        ``[mechanics] mass``.
        """
        return Motor(pole_pitch=self.pole_pitch, lever_arms=self.lever_arms, k=k_hat, zeta=zeta_hat,
                     mu=self.mu if mu_hat is None else mu_hat, sample_time=sample_time,
                     current_limit=current_limit, mass=Mechanics().mass if mass is None else mass)

    def plant(self) -> "TwinPlant":
        """The jittable plant (pytree of arrays) for these parameters."""
        a = lambda x: jnp.asarray(np.asarray(x, dtype=float))  # noqa: E731
        return TwinPlant(
            k=a(self.k), zeta=a(self.zeta), phase_gain_error=a(self.phase_gain_error),
            phase_angle_error=a(self.phase_angle_error), field=a([self.field_slope, self.field_curvature,
                                                                  self.field_ripple, self.phase_drift,
                                                                  self.end_drop]),
            harmonics=a([self.harmonic_5, self.harmonic_7, *self.harmonic_phase]), mu=a(self.mu),
            lever_arms=a(self.lever_arms), lateral_offsets=a(self.lateral_offsets),
            cog=a([self.cog_offset, self.cog_slope, self.cog_curvature, self.cog_wave, self.cog_periodic]),
            direction=a(self.direction_force), direction_ripple=a(self.direction_ripple),
            pole_pitch=float(self.pole_pitch), field_ripple_length=float(self.field_ripple_length),
            end_length=float(self.end_length), track_ends=tuple(float(t) for t in self.track_ends),
            cog_wave_length=float(self.cog_wave_length), cog_period=float(self.cog_period),
            direction_velocity=float(self.direction_velocity),
            direction_ripple_length=float(self.direction_ripple_length))

    def without(self, *effects: str) -> "TwinParams":
        """Copy with named effects switched off: any of ``imbalance, field, harmonics, out_of_plane,
        cogging, direction``."""
        z3 = (0.0, 0.0, 0.0)
        changes = {}
        L = self.n_coil_sets
        for e in effects:
            if e == "imbalance":
                changes.update(phase_gain_error=((0.0,) * 3,) * L, phase_angle_error=((0.0,) * 3,) * L)
            elif e == "field":
                changes.update(field_slope=0.0, field_curvature=0.0, field_ripple=0.0, phase_drift=0.0,
                               end_drop=0.0)
            elif e == "harmonics":
                changes.update(harmonic_5=0.0, harmonic_7=0.0)
            elif e == "out_of_plane":
                changes.update(lateral_offsets=(0.0,) * L)
            elif e == "cogging":
                changes.update(cog_offset=z3, cog_slope=z3, cog_curvature=z3, cog_wave=z3, cog_periodic=z3)
            elif e == "direction":
                changes.update(direction_force=z3)
            else:
                raise ValueError(f"unknown twin effect {e!r}")
        return replace(self, **changes)


DEFAULT_TWIN = TwinParams()


@pytree_dataclass
class TwinPlant:
    """Jittable electromagnetic truth of the twin (build it with :meth:`TwinParams.plant`).

    Implements the plant interface of :mod:`pgcomm.plant`.
    """

    k: jnp.ndarray                  # (L,)
    zeta: jnp.ndarray               # (L,)
    phase_gain_error: jnp.ndarray   # (L, 3)
    phase_angle_error: jnp.ndarray  # (L, 3)
    field: jnp.ndarray              # (5,) slope, curvature, ripple, phase drift, end drop
    harmonics: jnp.ndarray          # (4,) h5, h7, phase5, phase7
    mu: jnp.ndarray                 # ()
    lever_arms: jnp.ndarray         # (L,)
    lateral_offsets: jnp.ndarray    # (L,)
    cog: jnp.ndarray                # (5, 3)
    direction: jnp.ndarray          # (3,)
    direction_ripple: jnp.ndarray   # ()
    pole_pitch: float = static_field()
    field_ripple_length: float = static_field()
    end_length: float = static_field()
    track_ends: tuple = static_field()
    cog_wave_length: float = static_field()
    cog_period: float = static_field()
    direction_velocity: float = static_field()
    direction_ripple_length: float = static_field()

    @property
    def y_range(self):
        """Positions (m) where the twin is defined: coil sets stay on the magnet track."""
        lo = self.track_ends[0] - float(np.min(np.asarray(self.lever_arms)))
        hi = self.track_ends[1] - float(np.max(np.asarray(self.lever_arms)))
        return lo, hi

    def gain_phases(self, y):
        """True gain per coil set and phase, ``S + (L, 3, 3)`` (rows Fy, Fx, Tz; columns a, b, c)."""
        return jnp.stack(self._rows(y), axis=-2)

    def gain(self, y):
        """True star-reduced gain ``S + (L, 3, 2)`` (N/A, N/A, N·m/A)."""
        # reduce each row to (ia, ib) before stacking rows: one concatenation at the end keeps
        # XLA from re-evaluating the whole expression for every output element
        return jnp.stack([jnp.stack([r[..., 0] - r[..., 2], r[..., 1] - r[..., 2]], axis=-1)
                          for r in self._rows(y)], axis=-2)

    def _rows(self, y):
        """Rows ``(Fy, Fx, Tz)`` of the phase gain, each ``S + (L, 3)`` (columns phases a, b, c).

        Every angle is an affine function of ``y``: the electrical angle of coil set ``l``, phase ``p`` is
        ``θ_lp = ω y + c_lp``, so ``sin(nθ_lp + φ) = sin(nωy) cos(n c_lp + φ) + cos(nωy) sin(n c_lp + φ)``.
        Per position only ``sin/cos`` of ``ωy`` (``nωy`` by angle addition), of the ripple's angle and
        ``exp(±y/λ)`` are evaluated; everything that does not depend on ``y`` is a table of coefficients
        (computed once in a compiled loop: transcendentals dominate the cost of a closed-loop step).
        """
        y = jnp.asarray(y, dtype=float)
        slope, curv, ripple, drift, end_drop = (self.field[i] for i in range(5))
        d = self.lever_arms                               # (L,)
        lo, hi = self.track_ends
        wr = 2 * jnp.pi / self.field_ripple_length
        w = 2 * jnp.pi / self.pole_pitch + drift / 0.1    # the phase drift's slope folded into ω
        # --- position-independent coefficients
        c = self.zeta[:, None] + drift * d[:, None] / 0.1 + jnp.asarray(PHASE_OFFSETS) + self.phase_angle_error
        h5, h7, ph5, ph7 = (self.harmonics[i] for i in range(4))
        a5, a7 = 5 * c + ph5, 7 * c + ph7
        # wy = sin θ + h5 sin(5θ + φ5) + h7 sin(7θ + φ7), wx = cos θ + h5 cos(5θ + φ5) + h7 cos(7θ + φ7),
        # each (L, 3) = Σ over the basis [sin ωy, cos ωy, sin 5ωy, cos 5ωy, sin 7ωy, cos 7ωy]
        cy = jnp.stack([jnp.cos(c), jnp.sin(c), h5 * jnp.cos(a5), h5 * jnp.sin(a5), h7 * jnp.cos(a7),
                        h7 * jnp.sin(a7)], axis=-1)
        cx = jnp.stack([-jnp.sin(c), jnp.cos(c), -h5 * jnp.sin(a5), h5 * jnp.cos(a5), -h7 * jnp.sin(a7),
                        h7 * jnp.cos(a7)], axis=-1)
        amp0 = (2.0 / 3.0) * self.k[:, None] * (1.0 + self.phase_gain_error)                  # (L, 3)
        ripple_c, ripple_s = jnp.cos(wr * d + 0.7), jnp.sin(wr * d + 0.7)                       # (L,)
        end_hi, end_lo = jnp.exp((d - hi) / self.end_length), jnp.exp((lo - d) / self.end_length)
        # --- per position
        s1, c1 = jnp.sin(w * y), jnp.cos(w * y)
        # multiple angles by angle addition (no extra transcendentals): nωy = (n-2)ωy + 2ωy
        c2, s2 = c1 * c1 - s1 * s1, 2 * s1 * c1
        c3, s3 = c1 * c2 - s1 * s2, s1 * c2 + c1 * s2
        c5, s5 = c3 * c2 - s3 * s2, s3 * c2 + c3 * s2
        c7, s7 = c5 * c2 - s5 * s2, s5 * c2 + c5 * s2
        basis = jnp.stack([s1, c1, s5, c5, s7, c7], axis=-1)[..., None, None, :]               # S + (1, 1, 6)
        wy = jnp.sum(cy * basis, axis=-1)
        wx = jnp.sum(cx * basis, axis=-1)
        # slow field scale where the coil set sits, p = y + d (m)
        sr, cr = jnp.sin(wr * y)[..., None], jnp.cos(wr * y)[..., None]
        e_hi, e_lo = jnp.exp(y / self.end_length)[..., None], jnp.exp(-y / self.end_length)[..., None]
        u = (y[..., None] + d) / 0.1
        scale = (1.0 + slope * u + curv * (u * u - 1.0 / 3.0) + ripple * (sr * ripple_c + cr * ripple_s)
                 - end_drop * (e_hi * end_hi + e_lo * end_lo))                                   # S + (L,)
        amp = amp0 * scale[..., None]
        fy = amp * wy
        fx = amp * self.mu * wx
        tz = self.lever_arms[:, None] * fx - self.lateral_offsets[:, None] * fy
        return fy, fx, tz

    def cogging(self, y):
        """Current-independent force ``S + (3,)`` (N, N, N·m): cable slab plus weak periodic cogging."""
        y = jnp.asarray(y, dtype=float)[..., None]
        u = y / 0.1
        off, slope, curv, wave, per = (self.cog[i] for i in range(5))
        return (off + slope * u + curv * (u * u - 1.0 / 3.0)
                + wave * jnp.sin(2 * jnp.pi * y / self.cog_wave_length + 0.4)
                + per * jnp.sin(2 * jnp.pi * y / self.cog_period + 1.1))

    def direction_force(self, y, v):
        """Direction-dependent force ``S + (3,)``: ``c (1 + a sin(2π y/λ + 0.5)) tanh(v / v_d)`` (outside the PGNN class)."""
        y = jnp.asarray(y, dtype=float)[..., None]
        ripple = 1.0 + self.direction_ripple * jnp.sin(2 * jnp.pi * y / self.direction_ripple_length + 0.5)
        return self.direction * ripple * jnp.tanh(jnp.asarray(v, dtype=float)[..., None] / self.direction_velocity)

    def force(self, y, currents, v=None):
        """``S + (3,)`` total force (N, N, N·m) for star currents ``S + (L, 2)`` (A) at velocity ``v`` (m/s;
        ``None``: without the direction-dependent force)."""
        return plant_force(self, y, currents, v)

    def in_range(self, y):
        """``True`` where ``y`` lies inside :attr:`y_range`."""
        lo, hi = self.y_range
        return (jnp.asarray(y) >= lo) & (jnp.asarray(y) <= hi)


def true_fundamental(params: TwinParams, stroke=(-0.1, 0.1), n: int = 20001):
    """The twin's true fundamental ``(k^l, ζ^l)`` per coil set (N/A, rad): what calibration should recover.

    :func:`pgcomm.plant.fundamental` of the twin's plant over ``stroke`` (m): the
    least-squares fit of ``(2/3) k sin(2π y/d_m + ζ + φ_p)`` to the true ``Fy`` row of
    every phase ``p``, uniformly weighted in ``y``.

    Returns:
        ``(k (L,), zeta (L,))``.
    """
    return fundamental(params.plant(), params.pole_pitch, stroke, n)


__all__ = ["TwinParams", "TwinPlant", "DEFAULT_TWIN", "true_fundamental"]
