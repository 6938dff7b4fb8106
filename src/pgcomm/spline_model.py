"""Physics-guided spline model: the paper's structure with capacity along the stroke, linear in its parameters.

The paper's PGNN (eq. GainMatrix_Cogging) adds small tanh networks to the physics fundamental
``A cos θ + B sin θ`` (``θ = 2π y / d_m``). Here the fundamental's coefficients themselves are
functions of position, tabulated on a uniform knot grid and read by the package's one
interpolator (:func:`pgcomm.interp.interp_linear`, piecewise linear, held at the grid's ends)::

    K̂^l(y)   = A^l(y) cos θ + B^l(y) sin θ + Σ_{n∈{5,7}} H^l_{n,c} cos nθ + H^l_{n,s} sin nθ   (3 x 2, N/A)
    F̂_cog(y) = c(y)                                                                              (3,  N, N, N·m)
    F̂_dir(y, ẏ) = C(y) s(ẏ),   s(ẏ) = tanh(ẏ / v_ε)                                             (3,  N, N, N·m)
    F̂(y, i, ẏ) = Σ_l K̂^l(y) i^l + F̂_cog(y) + F̂_dir(y, ẏ)

with ``A^l(y) = Σ_k φ_k(y) A^l_k`` (``φ_k`` the hat functions of the gain grid) and likewise
``B``, ``c`` and ``C`` on grids of their own spacing. Why this form:

* a magnet's remanence and tilt, the field's drift along the track and end effects change the
  amplitude and phase of the fundamental where a coil set sits: that is exactly a slowly
  varying complex envelope ``A(y) + j B(y)`` of ``e^{jθ}``, so a knot spacing of a fraction of
  the pole pitch resolves magnet-by-magnet tolerances with few parameters;
* every parameter enters linearly, so identification is one regularised least-squares
  problem (Proposition 1 with no hidden layer: no local minima, no random starts), and the
  knot spacings and smoothness weight are chosen by cross-validation
  (:mod:`pgcomm.identify.spline`);
* the model is still analytically invertible (it has ``gain`` and ``cogging`` like every model
  of the package, so :class:`pgcomm.commutation.ModelLaw` inverts it), and beyond its grid it
  holds the end coefficients while the fundamental goes on: a bounded, physical extrapolation
  (a tanh network's output layer can grow without bound there);
* the cogging and the direction-dependent force are tables a drive already knows how to hold.

The cogging and direction tables are those of the combined model (each coil set's
identification sees the whole current-independent force; they are averaged over coil sets, as
:class:`pgcomm.models.CombinedModel` averages its cogging networks).
"""

from __future__ import annotations

import dataclasses

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.interp import interp_linear
from pgcomm.models import DEFAULT_DIRECTION_VELOCITY, HARMONIC_ORDERS, harmonic_basis, harmonic_gain, smooth_sign

__all__ = ["Grid", "SplineModel"]


@dataclasses.dataclass(frozen=True)
class Grid:
    """A uniform knot grid ``lo + k h``, ``k = 0 .. n`` (m): ``n + 1`` knots, ``n >= 1`` intervals."""

    lo: float
    hi: float
    n: int

    @classmethod
    def with_spacing(cls, lo: float, hi: float, spacing: float) -> "Grid":
        """The grid over ``[lo, hi]`` (m) with the largest spacing not above ``spacing`` (m)."""
        if not (hi > lo and spacing > 0):
            raise ValueError(f"grid [{lo}, {hi}] m with spacing {spacing} m: expected hi > lo and spacing > 0")
        return cls(float(lo), float(hi), max(1, int(np.ceil((hi - lo) / spacing - 1e-9))))

    @property
    def spacing(self) -> float:
        """Knot spacing ``h`` (m)."""
        return (self.hi - self.lo) / self.n

    @property
    def knots(self) -> np.ndarray:
        """``(n + 1,)`` knot positions (m)."""
        return np.linspace(self.lo, self.hi, self.n + 1)

    @property
    def size(self) -> int:
        """Number of knots ``n + 1``."""
        return self.n + 1


@pytree_dataclass
class SplineModel:
    """Physics-guided spline model of ``L`` coil sets (module docstring); a pytree, jittable.

    Attributes:
        gain_table: ``(M_g, L, 2, 3, 2)`` coefficients at the gain knots: ``[..., 0, :, :]`` is
            ``A^l_k`` (multiplies ``cos θ``), ``[..., 1, :, :]`` is ``B^l_k`` (``sin θ``); N/A, rows
            ``[Fy, Fx, Tz]``, columns ``ia, ib``.
        H: ``(L, 4, 3, 2)`` coefficients of ``cos 5θ, sin 5θ, cos 7θ, sin 7θ`` (N/A).
        cog_table: ``(M_c, 3)`` cogging at the cogging knots (N, N, N·m).
        dir_table: ``(M_d, 3)`` direction force ``C(y)`` at the direction knots (N, N, N·m), or ``None``.
        gain_knots, cog_knots, dir_knots: ``(M,)`` uniform knot positions (m).
        pole_pitch: ``d_m`` (m).
        y_min, y_max: the range the data covered (m), per coil set (tuples of length ``L``).
        direction_velocity: ``v_ε`` (m/s) of the smooth sign.
    """

    gain_table: jnp.ndarray
    H: jnp.ndarray
    cog_table: jnp.ndarray
    dir_table: jnp.ndarray | None
    gain_knots: jnp.ndarray
    cog_knots: jnp.ndarray
    dir_knots: jnp.ndarray
    pole_pitch: float = static_field()
    y_min: tuple | None = static_field(default=None)
    y_max: tuple | None = static_field(default=None)
    direction_velocity: float = static_field(default=DEFAULT_DIRECTION_VELOCITY)

    @property
    def n_coil_sets(self) -> int:
        """``L``."""
        return int(self.gain_table.shape[1])

    @property
    def training_range(self) -> tuple[float, float] | None:
        """Positions covered by the data of every coil set, ``(y_min, y_max)`` (m), or ``None``."""
        if self.y_min is None or self.y_max is None:
            return None
        return max(self.y_min), min(self.y_max)

    @property
    def has_direction(self) -> bool:
        """Whether the direction term ``C(y) s(ẏ)`` is on."""
        return self.dir_table is not None

    @property
    def has_harmonics(self) -> bool:
        """Always ``True``: the 5th/7th columns are part of the family (zero when the data say so)."""
        return True

    def gain(self, y):
        """``K̂^l(y)`` for all coil sets, ``S + (L, 3, 2)`` (N/A, N/A, N·m/A)."""
        y = jnp.asarray(y, dtype=float)
        ab = interp_linear(self.gain_knots, self.gain_table, y)            # S + (L, 2, 3, 2)
        c, s = harmonic_basis(y, self.pole_pitch)
        k = ab[..., 0, :, :] * c[..., None, None, None] + ab[..., 1, :, :] * s[..., None, None, None]
        return k + harmonic_gain(self.H, y, self.pole_pitch)

    def cogging(self, y):
        """``F̂_cog(y)``, ``S + (3,)`` (N, N, N·m)."""
        return interp_linear(self.cog_knots, self.cog_table, jnp.asarray(y, dtype=float))

    def direction_force(self, y, v):
        """``C(y) s(ẏ)``, ``S + (3,)`` (N, N, N·m) for velocity ``v`` ``S`` (m/s); zeros when off."""
        y = jnp.asarray(y, dtype=float)
        if self.dir_table is None:
            return jnp.zeros(y.shape + (3,))
        return interp_linear(self.dir_knots, self.dir_table, y) * smooth_sign(v, self.direction_velocity)[..., None]

    def force(self, y, currents, v=None):
        """``F̂ = Σ_l K̂^l i^l + F̂_cog [+ C(y) s(v)]``; currents ``S + (L, 2)`` (A) -> ``S + (3,)``.

        The direction term is added when the model has one and ``v`` (m/s) is given.
        """
        f = jnp.einsum("...lqj,...lj->...q", self.gain(y), currents) + self.cogging(y)
        if self.dir_table is not None and v is not None:
            f = f + self.direction_force(y, v)
        return f

    def without_direction(self) -> "SplineModel":
        """The same electromagnetics without the direction term (a static law needs no velocity)."""
        return dataclasses.replace(self, dir_table=None)

    @property
    def n_parameters(self) -> int:
        """Number of identified coefficients (all rows)."""
        n = self.gain_table.size + self.H.size + self.cog_table.size
        return int(n + (0 if self.dir_table is None else self.dir_table.size))

    @property
    def nbytes(self) -> int:
        """Size of the tables a controller stores, as float32 (bytes)."""
        # the coefficients plus (first knot, spacing) of each of the three grids
        return 4 * (self.n_parameters + 6)


#: Orders of the fixed harmonic columns (shared with :mod:`pgcomm.models`).
ORDERS = HARMONIC_ORDERS
