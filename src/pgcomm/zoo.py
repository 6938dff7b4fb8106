"""The motor zoo: random, physically plausible coreless linear motors (CLMs) as force maps with their truth.

DESIGN, "Generality": nothing may be tuned to the built-in twin; the zoo is where every
claim is checked. :func:`draw_motor` draws one motor from a seed and an index (each index
independent: ``np.random.default_rng([seed, index])``); :func:`write_motor` writes it as a
folder a user could have brought, and :func:`write_zoo` writes ``n`` of them::

    motor_01/plant.csv    force map (pgcomm.forcemap format) on a non-uniform grid
    motor_01/motor.toml   what a user knows: pole pitch, sample time, current limit,
                          nominal k̂, ζ̂ (a few % / tens of mrad off), μ̂, lever arms,
                          moving mass (the true one)
    motor_01/config.toml  experiment settings (--config): a whole machine scaled to the motor
    motor_01/truth.json   true fundamental k, zeta per coil set, the range it was fitted
                          over, seed, index and every generating parameter

**Electromagnetics** (:meth:`ZooMotor.gain_phases`). Coil set ``l`` sits at track position
``p = y + d^l`` (``y`` the translator's centre of mass, ``d^l`` its lever arm). With the
commutation phase of phase ``p ∈ {a, b, c}``::

    θ_lp(y) = 2π y/d_m + ζ^l + φ_p + α_lp + δφ(p) + arg A_lp(y)

the per-ampere forces are::

    Fy_lp = (2/3) k^l (1 + g_lp) s(p) |A_lp|   [sin θ + h5 sin(5θ + ψ5) + h7 sin(7θ + ψ7)]
    Fx_lp = (2/3) k^l (1 + g_lp) s(p) |B_lp| μ^l(p) [cos θ' + h5 cos(5θ' + ψ5) + h7 cos(7θ' + ψ7)]
    Tz_lp = d^l Fx_lp − x^l Fy_lp

(``θ'`` is ``θ`` with ``arg B`` in place of ``arg A``), with these effects, each drawn
over a realistic range and each absent with some probability (``ZooMotor.effects``):

* ``imbalance``: per-phase gain errors ``g_lp`` and angle errors ``α_lp`` (a few %, rad);
* ``field``: slow field drift along the track ``s(p)`` (slope, curvature, a long wave) and a
  slow commutation-phase drift ``δφ(p)``;
* ``end_effects``: field drop ``s(p)`` near the magnet-track ends;
* ``harmonics``: 5th/7th spatial harmonics ``h5, h7`` (outside the PGNN class);
* ``out_of_plane``: lateral coil offsets ``x^l``, per-coil-set normal-force factors (coil
  offset from the gap mid-plane) and a track bow, ``μ^l(p) = μ (1 + ε^l + bow(p))``;
* ``magnets``: magnet-by-magnet tolerances. Every magnet ``j`` (length ``d_m/2``) has its
  own remanence error and tilt: complex factors ``m_j = (1 + r_j) e^{i φ_j}`` for the driving
  force and ``n_j = (1 + r_j + t_j) e^{i(φ_j + ψ_j)}`` (larger spread) for the normal force. A
  coil sees the factors averaged over its width (a box average of the piecewise-constant
  magnet factors, exact), and a phase with several coils in series the mean over its coils:
  ``A_lp``, ``B_lp``. So each phase's gain varies irregularly from magnet to magnet, smoothed
  over the coil, never as white noise (``A = B = 1`` when absent);
* ``cable``: a current-independent force of the cable slab (:meth:`ZooMotor.cogging`): one
  to three smooth terms of different shapes (offset, linear, quadratic, sigmoid, long wave)
  with an amplitude up to a few % of the continuous force capacity;
* ``cogging``: a weak periodic force whose period is not a multiple of ``d_m``;
* ``direction``: ``c tanh(v / v_d)``, only in the twin-type plant :meth:`ZooMotor.plant`
  (a force map cannot hold it).

**The whole machine** (DESIGN clarification "Zoo motors need a whole machine"): with
``F_1 = min_l k^l · I_max`` the force of one coil set at the current limit (calibration
drives one coil set at a time with ``Δ = ±π/4``), the moving mass, friction, cable force and
reference acceleration/speeds are drawn so that the largest force the data-generation
reference demands stays below :data:`FORCE_BUDGET` ``· F_1``, and the reference
acceleration is small against the controller bandwidth so that the following error stays
well inside the map's margin (:func:`reference_span`). No motor saturates or leaves its map
by construction.

**Truth**: ``k``, ``zeta`` of ``truth.json`` are :func:`pgcomm.plant.fundamental` of the
force map *as written and read back*, over exactly the span of the calibration reference
(``reference_span`` of the map's range), which ``truth.json`` records as ``y_range``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.motor import PHASE_OFFSETS, Motor, star_reduce
from pgcomm.setup import reference_span
from pgcomm.plant import fundamental, plant_force

__all__ = [
    "EFFECTS",
    "FORCE_BUDGET",
    "ForceTerm",
    "ZooMotor",
    "ZooPlant",
    "config_toml",
    "draw_motor",
    "write_motor",
    "write_zoo",
    "motor_folder_name",
    "MAX_MOTORS",
]

from pgcomm.defaults import MAX_MOTORS  # noqa: E402  (re-exported)
from pgcomm.forcemap import ForceMapPlant
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.config import motor_to_toml
from pgcomm.io.forcemap import load_forcemap, write_forcemap

#: Parasitic effects a zoo motor may have (each absent with some probability).
EFFECTS = ("imbalance", "field", "end_effects", "harmonics", "out_of_plane", "magnets", "cable", "cogging",
           "direction")

#: Probability that an effect is absent from a drawn motor.
ABSENT_PROBABILITY = {"imbalance": 0.15, "field": 0.2, "end_effects": 0.25, "harmonics": 0.2,
                      "out_of_plane": 0.2, "magnets": 0.1, "cable": 0.1, "cogging": 0.25, "direction": 0.3}

#: Largest driving force the data-generation reference may demand, as a fraction of ``F_1``
#: (one coil set at the current limit): leaves room for ``cos Δ`` with ``Δ = π/4``, a starting
#: guess ``k̂`` a few % off, and feedback transients.
FORCE_BUDGET = 0.3

#: Ratio of the drive's peak current limit to the continuous current (for the continuous force
#: capacity ``L · k · I_max / PEAK_TO_CONTINUOUS`` that scales the cable force).
PEAK_TO_CONTINUOUS = 3.0


@dataclass(frozen=True)
class ForceTerm:
    """One smooth current-independent force term of the cable slab, in ``u = y / (stroke/2)`` (-).

    ``kind`` and its shape ``f(u)``: ``"offset"`` 1; ``"linear"`` ``u``; ``"quadratic"``
    ``u² − 1/3``; ``"sigmoid"`` ``tanh((u − a)/b)`` (centre ``a``, width ``b``, both in units of
    the half stroke); ``"wave"`` ``sin(2π u/a + b)`` (wavelength ``a`` in half strokes, phase
    ``b`` rad). The force is ``amplitude · f(u)`` with ``amplitude = (Fy N, Fx N, Tz N·m)``.
    """

    kind: str
    amplitude: tuple[float, float, float]
    a: float = 0.0
    b: float = 0.0

    def shape(self, u):
        """``f(u)`` (-) for ``u`` of any shape (NumPy)."""
        u = np.asarray(u, dtype=float)
        if self.kind == "offset":
            return np.ones_like(u)
        if self.kind == "linear":
            return u
        if self.kind == "quadratic":
            return u * u - 1.0 / 3.0
        if self.kind == "sigmoid":
            return np.tanh((u - self.a) / self.b)
        if self.kind == "wave":
            return np.sin(2 * np.pi * u / self.a + self.b)
        raise ValueError(f"unknown force term kind {self.kind!r}")


@dataclass(frozen=True)
class ZooMotor:
    """All generating parameters of one zoo motor (SI units: m, s, kg, N, A, rad).

    Build with :func:`draw_motor`. Electromagnetics: see the module docstring; the map covers
    ``y ∈ [−stroke/2, stroke/2]``; the magnet track covers ``p ∈ track`` with magnets of
    length ``d_m/2`` starting at ``track[0]``.
    """

    seed: int
    index: int
    effects: tuple[str, ...]            # effects present (subset of EFFECTS)
    # geometry and fundamental
    pole_pitch: float                   # d_m (m)
    stroke: float                       # full stroke of the map (m)
    k: tuple[float, ...]                # per coil set (N/A), generating value
    zeta: tuple[float, ...]             # per coil set (rad), in (−π, π]
    mu: float                           # out-of-plane ratio (-)
    lever_arms: tuple[float, ...]       # d^l (m)
    lateral_offsets: tuple[float, ...]  # x^l (m)
    coil_width: float                   # width of one coil (m)
    coils_per_phase: int                # coils in series per phase
    track: tuple[float, float]          # magnet-track ends (m, track coordinate p = y + d)
    # parasitic effects
    phase_gain_error: tuple[tuple[float, float, float], ...]   # (L, 3) relative
    phase_angle_error: tuple[tuple[float, float, float], ...]  # (L, 3) rad
    field_slope: float                  # relative change per half track
    field_curvature: float              # relative, times (u² − 1/3), u = position / half track
    field_wave: float                   # relative amplitude of a long wave along the track
    field_wave_length: float            # m
    field_wave_phase: float             # rad
    phase_drift: float                  # rad per half track
    end_drop: float                     # relative field drop at a track end
    end_length: float                   # decay length of the end effect (m)
    harmonic_5: float                   # relative
    harmonic_7: float                   # relative
    harmonic_phase: tuple[float, float]  # rad
    normal_factor: tuple[float, ...]    # ε^l: per-coil-set normal-force factor (-)
    bow: float                          # relative normal-force change from the track bow
    bow_length: float                   # wavelength of the bow (m)
    bow_phase: float                    # rad
    magnet_remanence: tuple[float, ...]  # r_j (-), one per magnet
    magnet_phase: tuple[float, ...]      # φ_j (rad)
    magnet_normal: tuple[float, ...]     # t_j (-)
    magnet_normal_phase: tuple[float, ...]  # ψ_j (rad)
    cable: tuple[ForceTerm, ...]        # smooth current-independent force terms
    cog_periodic: tuple[float, float, float]  # N, N, N·m
    cog_period: float                   # m, not a multiple of d_m
    cog_phase: float                    # rad
    direction_force: tuple[float, float, float]  # N, N, N·m (twin-type plant only)
    direction_velocity: float           # m/s
    # what the user knows (motor TOML)
    k_hat: float                        # N/A, one value for all coil sets
    zeta_hat: float                     # rad
    mu_hat: float                       # -
    # the whole machine (config TOML)
    sample_time: float                  # s
    current_limit: float                # peak phase current (A)
    mass: float                         # kg
    viscous: float                      # N·s/m
    coulomb: float                      # N
    coulomb_velocity: float             # m/s
    substeps: int
    bandwidth_hz: float                 # Hz
    controller_mass: float              # kg (the tuning's mass estimate)
    velocities: tuple[float, ...]       # m/s, of the data-generation reference
    a_max: float                        # m/s²
    j_max: float                        # m/s³
    dwell: float                        # s
    encoder_resolution: float           # m
    force_noise: tuple[float, float, float]  # N, N, N·m
    # force-map grid
    grid_points_per_pitch: float        # mean number of rows per pole pitch
    grid_jitter: float                  # relative spread of the row spacing

    # ------------------------------------------------------------------ derived

    @property
    def n_coil_sets(self) -> int:
        """Number of coil sets ``L``."""
        return len(self.k)

    @property
    def y_range(self) -> tuple[float, float]:
        """``(−stroke/2, stroke/2)`` (m): the range of the force map."""
        return -0.5 * self.stroke, 0.5 * self.stroke

    @property
    def reference_range(self) -> tuple[float, float]:
        """:func:`reference_span` of :attr:`y_range` (m): what the calibration reference covers."""
        return reference_span(*self.y_range)

    @property
    def coil_set_length(self) -> float:
        """Length of one coil set (m): ``3 · coils_per_phase · coil_width``."""
        return 3 * self.coils_per_phase * self.coil_width

    @property
    def force_capacity(self) -> float:
        """Continuous force capacity ``L · mean(k) · I_max / PEAK_TO_CONTINUOUS`` (N)."""
        return self.n_coil_sets * float(np.mean(self.k)) * self.current_limit / PEAK_TO_CONTINUOUS

    def motor(self) -> Motor:
        """What a user knows (the motor TOML): nominal ``k̂``, ``ζ̂``, ``μ̂``, lever arms, sample time, limit,
        and the moving mass (kg; the true one: a machine builder weighs the translator)."""
        return Motor(pole_pitch=self.pole_pitch, lever_arms=self.lever_arms, k=self.k_hat, zeta=self.zeta_hat,
                     mu=self.mu_hat, sample_time=self.sample_time, current_limit=self.current_limit,
                     mass=self.mass)

    def without(self, *effects: str) -> "ZooMotor":
        """Copy with the named effects (see :data:`EFFECTS`) switched off; ``without(*EFFECTS)`` is ideal.

        Amplitudes are zeroed (the drawn shapes are kept), so ``gain_phases`` of an ideal motor is
        exactly ``(2/3) k^l [sin, μ cos, d^l μ cos](θ)``.
        """
        L, n_mag = self.n_coil_sets, len(self.magnet_remanence)
        z3 = (0.0, 0.0, 0.0)
        ch: dict = {}
        for e in effects:
            if e == "imbalance":
                ch.update(phase_gain_error=(z3,) * L, phase_angle_error=(z3,) * L)
            elif e == "field":
                ch.update(field_slope=0.0, field_curvature=0.0, field_wave=0.0, phase_drift=0.0)
            elif e == "end_effects":
                ch.update(end_drop=0.0)
            elif e == "harmonics":
                ch.update(harmonic_5=0.0, harmonic_7=0.0)
            elif e == "out_of_plane":
                ch.update(lateral_offsets=(0.0,) * L, normal_factor=(0.0,) * L, bow=0.0)
            elif e == "magnets":
                ch.update(magnet_remanence=(0.0,) * n_mag, magnet_phase=(0.0,) * n_mag,
                          magnet_normal=(0.0,) * n_mag, magnet_normal_phase=(0.0,) * n_mag)
            elif e == "cable":
                ch.update(cable=())
            elif e == "cogging":
                ch.update(cog_periodic=z3)
            elif e == "direction":
                ch.update(direction_force=z3)
            else:
                raise ValueError(f"unknown zoo effect {e!r}; known: {', '.join(EFFECTS)}")
        present = tuple(e for e in self.effects if e not in effects)
        return replace(self, effects=present, **ch)

    # ------------------------------------------------------------------ electromagnetics

    def _envelope(self, q, factors):
        """Box average over one coil width of the per-magnet complex ``factors`` at coil centres ``q`` (m)."""
        half = 0.5 * self.pole_pitch
        knots = self.track[0] + half * np.arange(len(factors) + 1)
        cum = np.concatenate([[0.0], np.cumsum(factors) * half])  # ∫ m dp at the magnet boundaries
        w = self.coil_width

        def integral(x):
            return np.interp(x, knots, cum.real) + 1j * np.interp(x, knots, cum.imag)

        return (integral(q + 0.5 * w) - integral(q - 0.5 * w)) / w

    def _magnet_envelopes(self, p):
        """``A, B`` of shape ``S + (L, 3)`` for coil-set positions ``p`` ``S + (L,)`` (m)."""
        r = np.asarray(self.magnet_remanence)
        m = (1.0 + r) * np.exp(1j * np.asarray(self.magnet_phase))
        n = (1.0 + r + np.asarray(self.magnet_normal)) * np.exp(
            1j * (np.asarray(self.magnet_phase) + np.asarray(self.magnet_normal_phase)))
        # coils a, b, c, a, b, c, ... along the coil set; phase p's coils at these offsets (m)
        g = self.coils_per_phase
        offs = np.array([[(3 * j + ph + 0.5) * self.coil_width - 0.5 * self.coil_set_length for j in range(g)]
                         for ph in range(3)])  # (3, G)
        q = p[..., None, None] + offs                                       # S + (L, 3, G)
        return self._envelope(q, m).mean(-1), self._envelope(q, n).mean(-1)

    def gain_phases(self, y) -> np.ndarray:
        """True per-ampere force ``(M, L, 3, 3)``: rows ``Fy, Fx, Tz`` (N/A, N/A, N·m/A), columns phases a, b, c.

        Args:
            y: ``(M,)`` positions (m) of the translator's centre of mass (any shape ``S`` works:
                the result is ``S + (L, 3, 3)``).
        """
        y = np.asarray(y, dtype=float)
        d = np.asarray(self.lever_arms)
        p = y[..., None] + d                                  # S + (L,) track position of each coil set
        t0, t1 = self.track
        half_track = 0.5 * (t1 - t0)
        u = (p - 0.5 * (t0 + t1)) / half_track
        ell = 0.5 * self.coil_set_length
        scale = (1.0 + self.field_slope * u + self.field_curvature * (u * u - 1.0 / 3.0)
                 + self.field_wave * np.sin(2 * np.pi * p / self.field_wave_length + self.field_wave_phase)
                 - self.end_drop * (np.exp(-(t1 - ell - p) / self.end_length)
                                    + np.exp(-(p - t0 - ell) / self.end_length)))
        drift = self.phase_drift * u
        a_env, b_env = self._magnet_envelopes(p)             # S + (L, 3)
        base = (2 * np.pi * y[..., None, None] / self.pole_pitch + np.asarray(self.zeta)[:, None]
                + np.asarray(PHASE_OFFSETS) + np.asarray(self.phase_angle_error) + drift[..., None])
        theta = base + np.angle(a_env)
        theta_x = base + np.angle(b_env)
        amp = ((2.0 / 3.0) * np.asarray(self.k)[:, None] * (1.0 + np.asarray(self.phase_gain_error))
               * scale[..., None])
        h5, h7 = self.harmonic_5, self.harmonic_7
        s5, s7 = self.harmonic_phase
        fy = amp * np.abs(a_env) * (np.sin(theta) + h5 * np.sin(5 * theta + s5) + h7 * np.sin(7 * theta + s7))
        mu = self.mu * (1.0 + np.asarray(self.normal_factor)
                        + self.bow * np.sin(2 * np.pi * p / self.bow_length + self.bow_phase))  # S + (L,)
        fx = (amp * np.abs(b_env) * mu[..., None]
              * (np.cos(theta_x) + h5 * np.cos(5 * theta_x + s5) + h7 * np.cos(7 * theta_x + s7)))
        tz = d[:, None] * fx - np.asarray(self.lateral_offsets)[:, None] * fy
        return np.stack([fy, fx, tz], axis=-2)

    def cogging(self, y) -> np.ndarray:
        """Current-independent force ``(M, 3)`` (N, N, N·m): cable-slab terms plus weak periodic cogging.

        Args:
            y: ``(M,)`` positions (m) (any shape ``S``: result ``S + (3,)``).
        """
        y = np.asarray(y, dtype=float)
        u = y / (0.5 * self.stroke)
        out = np.zeros(y.shape + (3,))
        for term in self.cable:
            out = out + term.shape(u)[..., None] * np.asarray(term.amplitude)
        per = np.sin(2 * np.pi * y / self.cog_period + self.cog_phase)
        return out + per[..., None] * np.asarray(self.cog_periodic)

    # ------------------------------------------------------------------ plants

    def grid(self) -> np.ndarray:
        """``(M,)`` strictly increasing, non-uniform positions (m) of the force map over :attr:`y_range`.

        Mean spacing ``d_m / grid_points_per_pitch``, each spacing jittered by up to
        ``± grid_jitter`` (drawn from ``default_rng([seed, index, 1])``, so the grid is part of
        the motor); the ends are exactly :attr:`y_range`.
        """
        lo, hi = self.y_range
        m = int(math.ceil(self.stroke / self.pole_pitch * self.grid_points_per_pitch))
        rng = np.random.default_rng([self.seed, self.index, 1])
        h = 1.0 + self.grid_jitter * rng.uniform(-1.0, 1.0, m)
        y = lo + (hi - lo) * np.concatenate([[0.0], np.cumsum(h)]) / np.sum(h)
        y[-1] = hi
        return y

    def forcemap(self, source: str = "zoo motor"):
        """The motor as a :class:`pgcomm.forcemap.ForceMapPlant` on :meth:`grid` (no direction force)."""
        y = self.grid()
        return ForceMapPlant.from_arrays(y, self.gain_phases(y), self.cogging(y), source=source)

    def plant(self, direction: bool = True) -> "ZooPlant":
        """Twin-type jittable plant: :meth:`forcemap` plus the direction force ``c tanh(v / v_d)``.

        Args:
            direction: ``False`` leaves the direction force out (the static force map only).
        """
        c = np.asarray(self.direction_force if direction else (0.0, 0.0, 0.0), dtype=float)
        return ZooPlant(self.forcemap(source=f"zoo motor {self.seed}/{self.index}"), jnp.asarray(c),
                        float(self.direction_velocity))

    def parameters(self) -> dict:
        """Every generating parameter as plain JSON-able values (lists, floats, strings)."""
        return json.loads(json.dumps(dataclasses.asdict(self)))


@pytree_dataclass
class ZooPlant:
    """A force map plus a velocity-direction-dependent force (interface of :mod:`pgcomm.plant`).

    Attributes:
        static: the :class:`pgcomm.forcemap.ForceMapPlant` (gains and cogging).
        direction: ``(3,)`` amplitude ``c`` (N, N, N·m) of ``c tanh(v / v_d)``.
        direction_velocity: ``v_d`` (m/s), static.
    """

    static: object
    direction: jax.Array
    direction_velocity: float = static_field()

    @property
    def n_coil_sets(self) -> int:
        """Number of coil sets ``L``."""
        return self.static.n_coil_sets

    @property
    def y_range(self):
        """``(y_min, y_max)`` (m) of the force map."""
        return self.static.y_range

    @property
    def source(self) -> str:
        """Name for messages."""
        return self.static.source

    def gain_phases(self, y):
        """``S + (L, 3, 3)`` per-phase gains (N/A, N·m/A) at ``y`` (m, shape ``S``)."""
        return self.static.gain_phases(y)

    def gain(self, y):
        """``S + (L, 3, 2)`` star-reduced gains."""
        return star_reduce(self.static.gain_phases(y))

    def cogging(self, y):
        """``S + (3,)`` current-independent force (N, N, N·m)."""
        return self.static.cogging(y)

    def direction_force(self, y, v):
        """``S + (3,)``: ``c tanh(v / v_d)`` (N, N, N·m) for velocity ``v`` (m/s, shape ``S``)."""
        del y
        return self.direction * jnp.tanh(jnp.asarray(v, dtype=self.direction.dtype)[..., None]
                                         / self.direction_velocity)

    def force(self, y, currents, v=None):
        """``S + (3,)`` total force for star currents ``S + (L, 2)`` (A)."""
        return plant_force(self, y, currents, v)

    def in_range(self, y):
        """``S`` booleans: ``y`` inside the map."""
        return self.static.in_range(y)


# --------------------------------------------------------------------------- drawing


def _log_uniform(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def _signed(rng, lo, hi):
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(lo, hi))


def _wrap(a):
    """Angle(s) wrapped to ``(−π, π]`` (rad)."""
    a = np.asarray(a, dtype=float)
    w = np.mod(a + np.pi, 2 * np.pi) - np.pi
    return np.where(w == -np.pi, np.pi, w)


def _cog_period(rng, d_m):
    """A cogging period (m) whose ratio to ``d_m`` is far from integers and from 1/2, 1/3."""
    while True:
        rho = rng.uniform(0.3, 2.5)
        if min(abs(rho - round(rho)), abs(rho - 0.5), abs(rho - 1 / 3)) > 0.08:
            return float(rho * d_m)


def _cable_terms(rng, amplitude, half_stroke):
    """1–3 smooth terms of different shapes, scaled so that ``max |Fy|`` over the stroke is ``amplitude`` (N)."""
    kinds = ["offset", "linear", "quadratic", "sigmoid", "wave"]
    n = int(rng.choice([1, 2, 3], p=[0.35, 0.4, 0.25]))
    chosen = list(rng.choice(kinds, size=n, replace=False))
    terms = []
    lever = rng.uniform(0.02, 0.15)      # where the cable acts relative to the centre of mass (m)
    for kind in chosen:
        a = b = 0.0
        if kind == "sigmoid":
            a, b = rng.uniform(-0.6, 0.6), rng.uniform(0.08, 0.5)
        elif kind == "wave":
            a, b = rng.uniform(0.8, 3.0), rng.uniform(-np.pi, np.pi)
        w = rng.uniform(0.3, 1.0) * rng.choice([-1.0, 1.0])
        ax = w * rng.uniform(0.03, 0.3) * rng.choice([-1.0, 1.0])
        az = w * lever * rng.uniform(0.3, 1.0) * rng.choice([-1.0, 1.0])
        terms.append(ForceTerm(str(kind), (float(w), float(ax), float(az)), float(a), float(b)))
    u = np.linspace(-1.0, 1.0, 2001)
    fy = sum(t.shape(u) * t.amplitude[0] for t in terms)
    s = amplitude / max(float(np.max(np.abs(fy))), 1e-12)
    return tuple(ForceTerm(t.kind, tuple(float(x * s) for x in t.amplitude), t.a, t.b) for t in terms)


def draw_motor(seed: int, index: int) -> ZooMotor:
    """Draw zoo motor ``index`` of zoo ``seed``: random but physically plausible (module docstring).

    Independent per index (``np.random.default_rng([seed, index])``): motor 7 of seed 3 is the
    same whether 10 or 100 motors are drawn. Ranges: ``L`` 1–4 coil sets; ``d_m`` 10–60 mm;
    ``k`` 10–200 N/A (coil sets within ~1 % of each other); ``ζ`` anywhere on the circle
    (coil sets within ~10 mrad); full stroke 0.05–0.5 m (and at least 4 pole pitches); coil
    sets spaced by about a coil-set length, centre of mass anywhere among them; ``|μ|``
    0.01–0.1 either sign; the parasitic effects and the machine as in the module docstring.

    Args:
        seed: zoo seed (integer ≥ 0).
        index: motor index (integer ≥ 0).

    Returns:
        :class:`ZooMotor`.
    """
    seed, index = int(seed), int(index)
    rng = np.random.default_rng([seed, index])
    present = tuple(e for e in EFFECTS if rng.uniform() >= ABSENT_PROBABILITY[e])
    on = {e: (e in present) for e in EFFECTS}

    # --- geometry and fundamental
    L = int(rng.integers(1, 5))
    d_m = float(rng.uniform(0.010, 0.060))
    stroke = float(rng.uniform(max(0.05, 4 * d_m), 0.5))
    k0 = _log_uniform(rng, 10.0, 200.0)
    k = tuple(float(k0 * (1 + np.clip(rng.normal(0, 0.01), -0.03, 0.03))) for _ in range(L))
    z0 = rng.uniform(-np.pi, np.pi)
    zeta = tuple(float(_wrap(z0 + np.clip(rng.normal(0, 0.01), -0.03, 0.03))) for _ in range(L))
    mu = _signed(rng, 0.01, 0.1)
    coils_per_phase = int(rng.choice([1, 2, 3, 4], p=[0.4, 0.3, 0.2, 0.1]))
    coil_width = float(d_m * rng.uniform(0.6, 1.4))
    length = 3 * coils_per_phase * coil_width
    # coil sets an integer number of pole pitches apart, about one coil-set length plus a gap
    spacing = max(1, round(length * rng.uniform(1.05, 1.3) / d_m)) * d_m
    centres = spacing * np.arange(L)
    y_cm = rng.uniform(centres[0] - 0.3 * spacing, centres[-1] + 0.3 * spacing) if L > 1 else \
        rng.uniform(-0.3, 0.3) * length
    lever_arms = tuple(float(c - y_cm) for c in centres)
    lateral = tuple(float(rng.uniform(-0.005, 0.005)) if on["out_of_plane"] else 0.0 for _ in range(L))
    ext = rng.uniform(0.0, 2.0) * d_m  # track beyond the outermost coil at the stroke ends
    track = (float(-0.5 * stroke + min(lever_arms) - 0.5 * length - ext),
             float(0.5 * stroke + max(lever_arms) + 0.5 * length + ext))
    n_mag = int(math.ceil((track[1] - track[0]) / (0.5 * d_m))) + 2

    # --- parasitic effects (amplitudes zero where absent)
    # per-phase errors relative to the coil set's own mean (the mean belongs to k^l, ζ^l): mostly
    # systematic (every coil set wound alike) plus a small per-coil-set part
    sys_g = rng.normal(0, rng.uniform(0.005, 0.03), 3)
    sys_a = rng.normal(0, rng.uniform(0.005, 0.03), 3)

    def phase_errors(sys):
        e = sys + rng.normal(0, 0.005, 3)
        return tuple(float(x) for x in (e - e.mean()) * on["imbalance"])

    pge = tuple(phase_errors(sys_g) for _ in range(L))
    pae = tuple(phase_errors(sys_a) for _ in range(L))
    f = on["field"]
    field_slope = _signed(rng, 0.002, 0.02) * f
    field_curvature = _signed(rng, 0.002, 0.015) * f
    field_wave = rng.uniform(0.0, 0.008) * f
    field_wave_length = float(rng.uniform(0.3, 1.5) * (track[1] - track[0]))
    field_wave_phase = float(rng.uniform(-np.pi, np.pi))
    phase_drift = _signed(rng, 0.002, 0.03) * f
    end_drop = rng.uniform(0.01, 0.08) * on["end_effects"]
    end_length = float(rng.uniform(0.2, 0.6) * d_m)
    h5 = rng.uniform(0.002, 0.02) * on["harmonics"]
    h7 = rng.uniform(0.001, 0.01) * on["harmonics"]
    harmonic_phase = (float(rng.uniform(-np.pi, np.pi)), float(rng.uniform(-np.pi, np.pi)))
    o = on["out_of_plane"]
    normal_factor = tuple(float(rng.normal(0, 0.1) * o) for _ in range(L))
    bow = rng.uniform(0.0, 0.1) * o
    bow_length = float(rng.uniform(0.5, 2.0) * (track[1] - track[0]))
    bow_phase = float(rng.uniform(-np.pi, np.pi))
    mg = on["magnets"]
    sr, sp = rng.uniform(0.005, 0.015), rng.uniform(0.003, 0.015)
    sn, sq = rng.uniform(0.02, 0.08), rng.uniform(0.01, 0.05)
    magnet_remanence = tuple(float(x) for x in np.clip(rng.normal(0, sr, n_mag), -0.04, 0.04) * mg)
    magnet_phase = tuple(float(x) for x in rng.normal(0, sp, n_mag) * mg)
    magnet_normal = tuple(float(x) for x in rng.normal(0, sn, n_mag) * mg)
    magnet_normal_phase = tuple(float(x) for x in rng.normal(0, sq, n_mag) * mg)

    # --- drive and the force scale
    current_limit = float(_log_uniform(rng, 3.0, 20.0))
    f1 = min(k) * current_limit                         # one coil set at the current limit (N)
    f_cont = L * float(np.mean(k)) * current_limit / PEAK_TO_CONTINUOUS
    cable_amp = _log_uniform(rng, 0.005, 0.04) * f_cont * on["cable"]
    cable = _cable_terms(rng, cable_amp, 0.5 * stroke) if on["cable"] else ()
    cog_periodic = tuple(float(x) for x in (np.array([1.0, rng.uniform(0.1, 0.5), rng.uniform(0.005, 0.05)])
                                             * _log_uniform(rng, 3e-4, 3e-3) * f_cont * on["cogging"]
                                             * rng.choice([-1.0, 1.0], 3)))
    cog_period = _cog_period(rng, d_m)
    cog_phase = float(rng.uniform(-np.pi, np.pi))
    dir_y = _log_uniform(rng, 5e-4, 5e-3) * f1 * on["direction"]
    direction_force = (float(dir_y), float(dir_y * rng.uniform(-0.2, 0.2)), float(dir_y * rng.uniform(-0.1, 0.1)))
    direction_velocity = _log_uniform(rng, 1e-3, 5e-3)

    # --- the user's starting guess
    k_hat = float(np.mean(k) * (1 + _signed(rng, 0.02, 0.08)))
    zeta_hat = float(_wrap(np.mean(np.unwrap(zeta)) + _signed(rng, 0.01, 0.06)))
    mu_hat = float(mu * (1 + rng.uniform(-0.2, 0.2)))

    # --- the whole machine
    sample_time = float(rng.choice([1e-3, 5e-4], p=[0.6, 0.4]))
    mass = L * f1 / _log_uniform(rng, 20.0, 80.0)       # peak acceleration with all coil sets 20–80 m/s²
    # guides and seals: a friction coefficient on the weight plus a part that scales with the motor
    coulomb = mass * 9.81 * rng.uniform(0.01, 0.04) + f1 * rng.uniform(0.002, 0.01)
    coulomb_velocity = 1e-3
    half_ref = reference_span(-0.5 * stroke, 0.5 * stroke)[1]
    margin = 0.5 * stroke - half_ref
    # slow pass of the data-generation reference takes 4–8 s; speeds in the paper's ratios 1:3:6
    v1 = 2 * half_ref / rng.uniform(4.0, 8.0)
    ratios = np.array([1.0, 3.0, 6.0])
    viscous = mass / _log_uniform(rng, 0.2, 2.0)         # mechanical time constant m / f_v 0.2–2 s
    viscous = min(viscous, 0.04 * f1 / (6 * v1))       # viscous force at top speed <= 4 % of F_1
    cog_max = float(np.max(np.abs(_cable_max(cable, cog_periodic))))
    a_force = (FORCE_BUDGET * f1 - coulomb - viscous * 6 * v1 - cog_max) / mass
    a_max = float(min(_log_uniform(rng, 0.5, 5.0), a_force))
    # Following error of the loop without feedforward (data generation has none), with kp = m ω²/3
    # and the gain cos Δ ≈ 0.7 of the Δ = ±π/4 experiments: about 3 (a + (2 f_c + 2 f_v v + F_cog)/m)
    # / (0.7 ω²) (friction flips at reversals). Keep it below the margin of reference_span so that
    # the true position stays inside the map: raise the bandwidth (up to 1/40 of the sample rate),
    # then lower the acceleration.
    static = (2 * coulomb + 2 * viscous * 6 * v1 + cog_max) / mass
    w_cap = 2 * np.pi * 0.025 / sample_time
    w_bw = max(2 * np.pi * rng.uniform(6.0, 15.0), math.sqrt(3 * (a_max + static) / (0.7 * margin)))
    if w_bw > w_cap:
        w_bw = w_cap
        a_max = min(a_max, 0.7 * margin * w_cap ** 2 / 3 - static)
    if a_max < 0.05:
        raise AssertionError(f"zoo motor {seed}/{index}: no acceleration left in the budget")  # not reached
    bandwidth = float(w_bw / (2 * np.pi))
    v_top = min(6 * v1, math.sqrt(a_max * half_ref))  # top speed reachable within half the move
    velocities = tuple(float(x) for x in ratios * v_top / 6.0)
    j_max = float(a_max / rng.uniform(0.005, 0.03))
    substeps = 4
    while sample_time / substeps * (viscous + coulomb / coulomb_velocity) / mass > 2.0:
        substeps *= 2
    sigma = rng.uniform(5e-4, 2e-3) * f1
    force_noise = (float(sigma), float(sigma * rng.uniform(0.4, 0.8)), float(sigma * rng.uniform(0.3, 1.2)))
    encoder = float(rng.choice([1e-8, 5e-8, 1e-7, 5e-7, 1e-6]))

    return ZooMotor(
        seed=seed, index=index, effects=present, pole_pitch=d_m, stroke=stroke, k=k, zeta=zeta, mu=mu,
        lever_arms=lever_arms, lateral_offsets=lateral, coil_width=coil_width, coils_per_phase=coils_per_phase,
        track=track, phase_gain_error=pge, phase_angle_error=pae, field_slope=float(field_slope),
        field_curvature=float(field_curvature), field_wave=float(field_wave), field_wave_length=field_wave_length,
        field_wave_phase=field_wave_phase, phase_drift=float(phase_drift), end_drop=float(end_drop),
        end_length=end_length, harmonic_5=float(h5), harmonic_7=float(h7), harmonic_phase=harmonic_phase,
        normal_factor=normal_factor, bow=float(bow), bow_length=bow_length, bow_phase=bow_phase,
        magnet_remanence=magnet_remanence, magnet_phase=magnet_phase, magnet_normal=magnet_normal,
        magnet_normal_phase=magnet_normal_phase, cable=cable, cog_periodic=cog_periodic, cog_period=cog_period,
        cog_phase=cog_phase, direction_force=direction_force, direction_velocity=float(direction_velocity),
        k_hat=k_hat, zeta_hat=zeta_hat, mu_hat=mu_hat, sample_time=sample_time, current_limit=current_limit,
        mass=float(mass), viscous=float(viscous), coulomb=float(coulomb), coulomb_velocity=coulomb_velocity,
        substeps=substeps, bandwidth_hz=bandwidth, controller_mass=float(mass * (1 + rng.normal(0, 0.03))),
        velocities=velocities, a_max=a_max, j_max=j_max, dwell=float(rng.uniform(0.3, 0.5)),
        encoder_resolution=encoder, force_noise=force_noise,
        grid_points_per_pitch=float(rng.uniform(90.0, 130.0)), grid_jitter=float(rng.uniform(0.1, 0.4)),
    )


def _cable_max(cable, cog_periodic):
    """Upper bound of ``|F_cog|`` per direction (N, N, N·m) over the stroke."""
    u = np.linspace(-1.0, 1.0, 2001)
    tot = np.zeros((u.size, 3))
    for t in cable:
        tot += t.shape(u)[:, None] * np.asarray(t.amplitude)
    return np.max(np.abs(tot), axis=0) + np.abs(np.asarray(cog_periodic))


# --------------------------------------------------------------------------- writing


def _f(x) -> str:
    return repr(float(x))


def config_toml(motor: ZooMotor) -> str:
    """Experiment settings TOML (``--config``) of the motor's machine; keys of :class:`pgcomm.settings.ExperimentConfig`."""
    lo, hi = motor.reference_range
    lines = [
        f"# pgcomm experiment settings of zoo motor {motor.index} (seed {motor.seed}); SI units",
        f"sample_time = {_f(motor.sample_time)}  # s",
        f"current_limit = {_f(motor.current_limit)}  # A, peak phase current",
        "",
        "[mechanics]",
        f"mass = {_f(motor.mass)}  # kg",
        f"viscous = {_f(motor.viscous)}  # N s/m",
        f"coulomb = {_f(motor.coulomb)}  # N",
        f"coulomb_velocity = {_f(motor.coulomb_velocity)}  # m/s",
        f"substeps = {int(motor.substeps)}",
        "",
        "[sensors]",
        f"encoder_resolution = {_f(motor.encoder_resolution)}  # m",
        f"force_noise = [{', '.join(_f(x) for x in motor.force_noise)}]  # N, N, N m",
        "",
        "[controller]",
        f"bandwidth_hz = {_f(motor.bandwidth_hz)}  # Hz",
        f"mass = {_f(motor.controller_mass)}  # kg, for the tuning",
        "",
        "[reference]",
        f"stroke = {_f(hi)}  # m, half stroke: the reference spans [{lo:.6g}, {hi:.6g}] m of the map",
        f"velocities = [{', '.join(_f(v) for v in motor.velocities)}]  # m/s",
        f"a_max = {_f(motor.a_max)}  # m/s^2",
        f"j_max = {_f(motor.j_max)}  # m/s^3",
        f"dwell = {_f(motor.dwell)}  # s",
    ]
    return "\n".join(lines) + "\n"


def motor_folder_name(i: int, n: int) -> str:
    """``motor_01`` … for motor ``i`` (1-based) of ``n``: two digits, more when ``n >= 100``."""
    return f"motor_{i:0{max(2, len(str(n)))}d}"


def write_motor(motor: ZooMotor, folder) -> Path:
    """Write the motor's folder: ``plant.csv``, ``motor.toml``, ``config.toml``, ``truth.json`` (each atomically).

    The truth is :func:`pgcomm.plant.fundamental` of the force map as written and read back,
    over :attr:`ZooMotor.reference_range` (the calibration reference's span).

    Args:
        motor: the motor.
        folder: target directory (created with its parents).

    Returns:
        the folder as a :class:`Path`.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    y = motor.grid()
    write_forcemap(folder / "plant.csv", y, motor.gain_phases(y), motor.cogging(y))
    plant = load_forcemap(folder / "plant.csv")
    y_range = motor.reference_range
    k, zeta = fundamental(plant, motor.pole_pitch, y_range)
    atomic_write_text(folder / "motor.toml", motor_to_toml(motor.motor()))
    atomic_write_text(folder / "config.toml", config_toml(motor))
    truth = {
        "schema": "pgcomm-zoo-truth/1",
        "k": [float(v) for v in k],
        "zeta": [float(v) for v in zeta],
        "y_range": [float(v) for v in y_range],
        "map_range": [float(v) for v in plant.y_range],
        "seed": motor.seed,
        "index": motor.index,
        "effects": list(motor.effects),
        "force_capacity": motor.force_capacity,
        "parameters": motor.parameters(),
    }
    atomic_write_text(folder / "truth.json", json.dumps(truth, indent=1) + "\n")
    return folder


def write_zoo(n: int, seed: int, out_dir, progress=None) -> list[Path]:
    """Draw and write ``n`` zoo motors into ``out_dir/motor_01`` … (:func:`motor_folder_name`).

    Motor ``i`` (1-based folder number) is ``draw_motor(seed, i - 1)``.

    Args:
        n: number of motors, 1 to :data:`MAX_MOTORS`.
        seed: zoo seed.
        out_dir: output directory (created).
        progress: optional :class:`pgcomm.progress.Progress` (one line per motor).

    Returns:
        the ``n`` motor folders.
    """
    n = int(n)
    if not 1 <= n <= MAX_MOTORS:
        raise ValueError(f"write_zoo: n = {n}, expected 1 to {MAX_MOTORS} motors")
    out = Path(out_dir)
    folders = []
    for i in range(1, n + 1):
        m = draw_motor(seed, i - 1)
        folder = write_motor(m, out / motor_folder_name(i, n))
        folders.append(folder)
        if progress is not None:
            progress.info(f"{folder.name}: L = {m.n_coil_sets}, d_m = {m.pole_pitch * 1e3:.1f} mm, "
                          f"k ≈ {np.mean(m.k):.1f} N/A, stroke {m.stroke:.3f} m, effects: {', '.join(m.effects)}")
    return folders
