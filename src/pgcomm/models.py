"""Electromagnetic models: MLP, physics-only and PGNN coil-set models, and their combination.

* :class:`MLP` — eq. NeuralNetwork on a scaled position ``s`` (any depth and widths).
* :class:`CoilSetModel` — one coil set (eqs. PGNN_Electromagnetics_SingleCoilset and
  GainMatrix_Cogging)::

      K̂(y) = A cos(2πy/d_m) + B sin(2πy/d_m) + [f_1(s), f_2(s)]      (3 x 2, N/A)
      F̂_cog(y) = f_φ(s)                                              (3,   N, N, N·m)
      F̂(y, i) = K̂(y) i + F̂_cog(y)

  with ``s = (y - y_center) / y_scale``. Two optional extensions beyond the paper,
  each off by default (``None``) so that the default model is exactly the paper's::

      K̂(y) += Σ_{n ∈ {5, 7}} H_n,c cos(2πn y/d_m) + H_n,s sin(2πn y/d_m)   (higher harmonics)
      F̂(y, i, ẏ) += C s(ẏ),   s(ẏ) = tanh(ẏ / v_ε)                      (direction term)

  ``H`` and ``C`` are linear parameters, eliminated by Proposition 1 with ``θ_L``.
  Without networks it is the physics-only model
  (``A cos + B sin``), which for the :func:`physics_from_ideal` values equals the ideal
  gain matrix of eq. Electromagnetics_GainMatrix reduced to the star currents.
* :class:`CombinedModel` — ``L`` coil-set models stacked (eq. PGNN_Electromagnetics):
  ``F̂ = Σ_l K̂^l i^l + (1/L) Σ_l F̂^l_cog``. It has ``gain(y) -> S + (L, 3, 2)`` and
  ``cogging(y) -> S + (3,)`` and so plugs into :class:`pgcomm.commutation.ModelLaw`.

Input scaling. The networks see ``s = (y - y_center) / y_scale`` (training positions map
to about ``[-1, 1]``) instead of ``y``. This is an exact reparametrisation of
eq. NeuralNetwork, ``W_1 y + B_1 = W_1' s + B_1'`` with ``W_1' = y_scale W_1`` and
``B_1' = B_1 + y_center W_1``, chosen because raw positions of ±0.1 m make the
least-squares problem of Proposition 1 hopelessly ill-conditioned.

Conventions: a network's hidden layer ``i`` computes ``h_i = α(h_{i-1} W_i + b_i)`` with
``W_i`` of shape ``(n_{i-1}, n_i)`` and ``h_0 = s`` (``n_0 = 1``); the output layer is
``h_I W_out + b_out`` with ``W_out`` of shape ``(n_I, 3)``. Output rows are
``[Fy, Fx, Tz]``. All models are immutable pytrees; methods are vectorised over any
leading shape ``S`` of ``y`` and jittable.
"""

from __future__ import annotations

import dataclasses
from dataclasses import replace
from functools import partial

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp
import numpy as np

from pgcomm._pytree import pytree_dataclass, static_field
from pgcomm.commutation import drive_currents
from pgcomm.motor import PHASE_OFFSETS, STAR

#: Activation functions by name (the static ``activation`` field of :class:`MLP`).
ACTIVATIONS = {
    "tanh": jnp.tanh,
    "sigmoid": jax.nn.sigmoid,
    "relu": jax.nn.relu,
    "softplus": jax.nn.softplus,
    "gelu": jax.nn.gelu,
    "linear": lambda z: z,
}

#: Paper defaults (§Experimental results): one hidden layer, 2 neurons per gain column, 16 for cogging.
DEFAULT_GAIN_WIDTHS = (2,)
DEFAULT_COG_WIDTHS = (16,)


def activation_fn(name: str):
    """The activation function called ``name`` (a key of :data:`ACTIVATIONS`)."""
    try:
        return ACTIVATIONS[name]
    except KeyError:
        raise ValueError(f"unknown activation {name!r}; expected one of {sorted(ACTIVATIONS)}") from None


@pytree_dataclass
class MLP:
    """Feed-forward network ``R -> R^3`` on the scaled position (eq. NeuralNetwork).

    Attributes:
        hidden: hidden layers ``((W_1, b_1), ..., (W_I, b_I))`` with ``W_i`` of shape
            ``G + (n_{i-1}, n_i)`` and ``b_i`` of shape ``G + (n_i,)``, ``n_0 = 1``.
        W_out: output weights ``G + (n_I, 3)``; b_out: output bias ``G + (3,)``.
        activation: name in :data:`ACTIVATIONS` (static).

    ``G`` is empty for one network. A leading ``G`` stacks several networks of the same
    structure (as :class:`CombinedModel` does); the input ``s`` then has shape ``S + G``
    and every network gets its own input.
    """

    hidden: tuple
    W_out: jnp.ndarray
    b_out: jnp.ndarray
    activation: str = static_field(default="tanh")

    @property
    def widths(self) -> tuple[int, ...]:
        """Hidden widths ``(n_1, ..., n_I)``."""
        return tuple(int(b.shape[-1]) for _, b in self.hidden)

    def features(self, s):
        """Last hidden layer ``h_I(s)``, shape ``S + G + (n_I,)`` for ``s`` of shape ``S + G``."""
        return hidden_features(self.hidden, s, self.activation)

    def __call__(self, s):
        """Network output ``S + G + (3,)`` for scaled positions ``s`` of shape ``S + G``."""
        h = self.features(s)
        if h.shape[:-1] == self.W_out.shape[:-2]:
            # one position per network (a closed-loop step): a matrix-vector product per network; the
            # multiply-and-sum below would evaluate every hidden unit once per output row there
            return jnp.einsum("...i,...ij->...j", h, self.W_out) + self.b_out
        # Many positions: multiply-and-sum over the MINOR axis: the contraction is tiny (n_I), XLA fuses
        # it, and on CPU a reduction over the minor axis runs ~10x faster than over a major one.
        return jnp.sum(h[..., None, :] * jnp.swapaxes(self.W_out, -1, -2), axis=-1) + self.b_out

    def padded(self, width: int) -> "MLP":
        """The same function with ``width`` hidden units (one hidden layer): the new units have
        zero weights, bias and output weights, so they add nothing. Lets networks of different
        widths share one stacked :class:`CombinedModel`."""
        if len(self.hidden) != 1:
            raise ValueError("padding needs a network with one hidden layer")
        (w, b), = self.hidden
        extra = int(width) - int(b.shape[-1])
        if extra < 0:
            raise ValueError(f"cannot pad a width-{b.shape[-1]} network to {width}")
        def pad(a, axis):
            ax = axis % a.ndim
            return jnp.concatenate([a, jnp.zeros(a.shape[:ax] + (extra,) + a.shape[ax + 1:], a.dtype)], axis=ax)

        return MLP(((pad(w, -1), pad(b, -1)),), pad(self.W_out, -2), self.b_out, self.activation)

    @classmethod
    def init(cls, key, widths=DEFAULT_GAIN_WIDTHS, activation="tanh", first_scale=2.0) -> "MLP":
        """Random hidden layers, zero output layer.

        First-layer weights ``~ N(0, first_scale²)`` and biases ``~ N(0, 1)`` put the
        units' transitions inside ``s ∈ [-1, 1]``; deeper layers are Glorot-normal with
        zero bias. The output layer is zero (Proposition 1 sets it).

        Args:
            key: ``jax.random.PRNGKey``. widths: hidden widths ``(n_1, ..., n_I)``, ``I >= 1``.
        """
        widths = tuple(int(n) for n in widths)
        if not widths or min(widths) < 1:
            raise ValueError(f"widths must be a non-empty tuple of positive ints, got {widths}")
        activation_fn(activation)
        hidden = _random_hidden(key, widths, float(first_scale))
        return cls(hidden, *jax.device_put((np.zeros((widths[-1], 3)), np.zeros(3))), activation)


# one compiled program per network shape: drawn outside a trace, each draw's dozen random and array operations
# would each be compiled anew after every release of compiled programs
@partial(jax.jit, static_argnames=("widths", "first_scale"))
def _random_hidden(key, widths: tuple, first_scale: float) -> tuple:
    """The hidden layers of :meth:`MLP.init`: ``((W_1, b_1), ...)``, ``W_i`` ``(n_{i-1}, n_i)``, ``b_i`` ``(n_i,)``."""
    keys = jax.random.split(key, 2 * len(widths))
    hidden, n_prev = [], 1
    for i, n in enumerate(widths):
        if i == 0:
            w = first_scale * jax.random.normal(keys[0], (1, n))
            b = jax.random.normal(keys[1], (n,))
        else:
            w = jax.random.normal(keys[2 * i], (n_prev, n)) / np.sqrt(n_prev)
            b = jnp.zeros((n,))
        hidden.append((w, b))
        n_prev = n
    return tuple(hidden)


def hidden_features(hidden, s, activation="tanh"):
    """Last hidden layer of a network with hidden layers ``hidden`` (see :class:`MLP`) at scaled positions ``s``.

    Returns ``S + G + (n_I,)`` for ``s`` of shape ``S + G``.
    """
    act = activation_fn(activation)
    (w1, b1), *rest = hidden
    # The first layer has one input, so it is a broadcast multiply (no matmul).
    h = act(jnp.asarray(s)[..., None] * w1[..., 0, :] + b1)
    for w, b in rest:
        h = act(jnp.einsum("...i,...ij->...j", h, w) + b)
    return h


def harmonic_basis(y, pole_pitch, order: int = 1):
    """``(cos, sin)`` of ``2π n y / d_m`` (-) with ``n = order``, each of the shape of ``y`` (m)."""
    theta = (2.0 * np.pi * order / pole_pitch) * jnp.asarray(y, dtype=float)
    return jnp.cos(theta), jnp.sin(theta)


#: Orders of the optional higher spatial harmonics of the gain (the 5th and 7th: a three-phase
#: winding cancels the triplen harmonics of the field, the 5th and 7th are the first that remain).
HARMONIC_ORDERS = (5, 7)
#: Default ``v_ε`` (m/s) of the smooth sign ``tanh(ẏ / v_ε)`` of the direction term. It must be
#: well below the slowest motion of interest (the paper's references move at >= 25 mm/s, so
#: ``s(ẏ) > 0.999`` there) and above the velocity noise of a differentiated encoder signal
#: (0.1 µm / 1 ms quanta, Savitzky–Golay smoothed: ~0.05 mm/s), so that the sign does not
#: chatter at standstill. 1 mm/s sits between the two with a margin of ~20x each way.
DEFAULT_DIRECTION_VELOCITY = 1e-3


def smooth_sign(v, v_eps):
    """``s(v) = tanh(v / v_ε)`` (-): the smooth sign of the direction term; ``v`` (m/s), ``v_ε`` (m/s)."""
    return jnp.tanh(jnp.asarray(v, dtype=float) / v_eps)


def harmonic_gain(H, y, pole_pitch):
    """Gain of the higher harmonics ``Σ_n H[2j] cos(2πn y/d_m) + H[2j+1] sin(2πn y/d_m)``.

    Args:
        H: ``G + (4, 3, 2)`` coefficients (N/A) of ``cos 5θ, sin 5θ, cos 7θ, sin 7θ``; ``G`` leading
            dims (e.g. coil sets ``(L,)``) broadcast against ``y``'s trailing dims.
        y: positions ``S`` (m) (with ``G`` non-empty, shape ``S`` is broadcast to ``S + G``).

    Returns:
        ``S + G + (3, 2)``.
    """
    out = 0.0
    for j, n in enumerate(HARMONIC_ORDERS):
        c, s = harmonic_basis(y, pole_pitch, n)
        extra = (None,) * (H.ndim - 3)
        c = c[(...,) + extra + (None, None)]
        s = s[(...,) + extra + (None, None)]
        out = out + H[..., 2 * j, :, :] * c + H[..., 2 * j + 1, :, :] * s
    return out


@pytree_dataclass
class CoilSetModel:
    """PGNN (or physics-only) model of one coil set (eqs. PGNN_Electromagnetics_SingleCoilset, GainMatrix_Cogging).

    Attributes:
        A, B: ``(3, 2)`` physical parameters (N/A); rows ``[Fy, Fx, Tz]``, columns ``ia, ib``.
        gain_nets: ``(f_1, f_2)`` two :class:`MLP` giving the columns of the gain
            correction, or ``None`` (physics-only gain).
        cog_net: :class:`MLP` for the cogging force, or ``None`` (no cogging).
        pole_pitch: ``d_m`` (m). y_center, y_scale: input scaling (m), ``s = (y - y_center) / y_scale``.
        y_min, y_max: positions covered by the training data (m), or ``None`` if unknown.
        H: ``(4, 3, 2)`` higher-harmonic gain coefficients (N/A) of ``cos 5θ, sin 5θ, cos 7θ,
            sin 7θ`` (``θ = 2πy/d_m``), or ``None`` (off: the paper's model).
        C: ``(3,)`` direction term (N, N, N·m) multiplying ``s(ẏ) = tanh(ẏ/v_ε)``, or ``None`` (off).
        direction_velocity: ``v_ε`` (m/s) of the smooth sign.
    """

    A: jnp.ndarray
    B: jnp.ndarray
    gain_nets: tuple | None
    cog_net: MLP | None
    pole_pitch: float = static_field()
    y_center: float = static_field(default=0.0)
    y_scale: float = static_field(default=1.0)
    y_min: float | None = static_field(default=None)
    y_max: float | None = static_field(default=None)
    H: jnp.ndarray | None = None
    C: jnp.ndarray | None = None
    direction_velocity: float = static_field(default=DEFAULT_DIRECTION_VELOCITY)

    @classmethod
    def physics(cls, A, B, pole_pitch, y_center=0.0, y_scale=1.0, y_min=None, y_max=None) -> "CoilSetModel":
        """Physics-only model ``K̂ = A cos + B sin``, no cogging."""
        return cls(jnp.asarray(A, float), jnp.asarray(B, float), None, None, float(pole_pitch),
                   float(y_center), float(y_scale), y_min, y_max)

    @classmethod
    def init(cls, key, physics: "CoilSetModel", gain_widths=DEFAULT_GAIN_WIDTHS, cog_widths=DEFAULT_COG_WIDTHS,
             activation="tanh", harmonics=False, direction=False,
             direction_velocity=DEFAULT_DIRECTION_VELOCITY) -> "CoilSetModel":
        """PGNN with random hidden layers (:meth:`MLP.init`) and zero output layers beside ``physics``.

        ``physics`` (:meth:`physics`) gives the fundamental's ``A``, ``B`` (``(3, 2)``, N/A), the pole pitch, the
        input scaling and the training range (m). ``gain_widths`` / ``cog_widths`` of ``None`` leave that
        network out. ``harmonics`` / ``direction`` switch the extensions on (zero coefficients; Proposition 1
        sets them); ``direction_velocity``: ``v_ε`` (m/s).
        """
        k1, k2, k3 = jax.random.split(key, 3)
        gain = None if gain_widths is None else (MLP.init(k1, gain_widths, activation),
                                                 MLP.init(k2, gain_widths, activation))
        cog = None if cog_widths is None else MLP.init(k3, cog_widths, activation)
        return replace(physics, gain_nets=gain, cog_net=cog, H=jnp.zeros((4, 3, 2)) if harmonics else None,
                       C=jnp.zeros(3) if direction else None, direction_velocity=float(direction_velocity))

    @property
    def networks(self) -> tuple:
        """The networks present, in the order ``f_1, f_2, f_φ`` (the column order of the LIP rewrite)."""
        gain = () if self.gain_nets is None else tuple(self.gain_nets)
        return gain + (() if self.cog_net is None else (self.cog_net,))

    def scaled_position(self, y):
        """``s = (y - y_center) / y_scale`` (-), shape of ``y``."""
        return (jnp.asarray(y, dtype=float) - self.y_center) / self.y_scale

    def gain(self, y):
        """``K̂(y)``, shape ``S + (3, 2)`` (N/A, N/A, N·m/A)."""
        c, s = harmonic_basis(y, self.pole_pitch)
        k = self.A * c[..., None, None] + self.B * s[..., None, None]
        if self.H is not None:
            k = k + harmonic_gain(self.H, y, self.pole_pitch)
        if self.gain_nets is not None:
            sc = self.scaled_position(y)
            k = k + jnp.stack([net(sc) for net in self.gain_nets], axis=-1)
        return k

    def cogging(self, y):
        """``F̂_cog(y)``, shape ``S + (3,)`` (N, N, N·m); zeros without a cogging network."""
        if self.cog_net is None:
            return jnp.zeros(jnp.shape(y) + (3,))
        return self.cog_net(self.scaled_position(y))

    def direction_force(self, y, v):
        """``C s(ẏ)``, shape ``S + (3,)`` (N, N, N·m) for velocity ``v`` ``S`` (m/s); zeros when off."""
        if self.C is None:
            return jnp.zeros(jnp.shape(y) + (3,))
        return self.C * smooth_sign(v, self.direction_velocity)[..., None]

    def force(self, y, currents, v=None):
        """``F̂ = K̂(y) i + F̂_cog(y) [+ C s(v)]``; currents ``S + (2,)`` (A) -> ``S + (3,)``.

        The direction term is added only when the model has one and ``v`` (m/s) is given.
        """
        f = jnp.einsum("...qj,...j->...q", self.gain(y), currents) + self.cogging(y)
        if self.C is not None and v is not None:
            f = f + self.direction_force(y, v)
        return f

    @property
    def has_direction(self) -> bool:
        """Whether the direction term ``C s(ẏ)`` is on."""
        return self.C is not None

    @property
    def has_harmonics(self) -> bool:
        """Whether the 5th/7th harmonic gain columns are on."""
        return self.H is not None

    def with_outputs(self, A, B, gain_out=None, cog_out=None, H=None, C=None) -> "CoilSetModel":
        """Copy with new linear parameters θ_L.

        Args:
            A, B: ``(3, 2)``. gain_out: ``((W_1, b_1), (W_2, b_2))`` output layers of the
                gain networks (``(n_I, 3)``, ``(3,)``). cog_out: ``(W, b)`` of the cogging network.
            H: ``(4, 3, 2)``, C: ``(3,)``: new extension coefficients (kept when ``None``).
        """
        gain = self.gain_nets
        if gain is not None:
            gain = tuple(MLP(net.hidden, w, b, net.activation) for net, (w, b) in zip(gain, gain_out))
        cog = self.cog_net
        if cog is not None:
            cog = MLP(cog.hidden, cog_out[0], cog_out[1], cog.activation)
        return dataclasses.replace(self, A=jnp.asarray(A), B=jnp.asarray(B), gain_nets=gain, cog_net=cog,
                                   H=self.H if H is None else jnp.asarray(H),
                                   C=self.C if C is None else jnp.asarray(C))

    def with_range(self, y_min, y_max) -> "CoilSetModel":
        """Copy with another training range (m)."""
        return dataclasses.replace(self, y_min=None if y_min is None else float(y_min),
                                   y_max=None if y_max is None else float(y_max))

    def physics_only(self) -> "CoilSetModel":
        """This model's ``A, B`` without networks and without extensions."""
        return dataclasses.replace(self, gain_nets=None, cog_net=None, H=None, C=None)


def force_from_drive_inputs(model: CoilSetModel, y, fy, delta, k_hat, zeta_hat):
    """Model force from drive inputs ``(Fy^l*, Δ^l)`` (the dotted block of Fig. PGNN_Parametrization).

    ``F̂ = K̂(y) Γ(y) T(Fy*, Δ) + F̂_cog(y)`` (eq. PGNN_Electromagnetics_SingleCoilset).

    Args:
        y: ``S`` (m); fy: ``S`` (N); delta: ``S`` (rad); k_hat (N/A), zeta_hat (rad): the
            drive's fixed commutation parameters.

    Returns:
        ``S + (3,)`` (N, N, N·m).
    """
    i = drive_currents(y, jnp.asarray(fy)[..., None], jnp.asarray(delta)[..., None], k_hat, zeta_hat,
                       model.pole_pitch)[..., 0, :]
    return model.force(y, i)


def physics_from_ideal(pole_pitch, k, zeta, mu, lever_arm):
    """``(A, B)`` for which the physics model equals the ideal star-reduced gain (eq. Electromagnetics_GainMatrix).

    With ``θ = 2π y / d_m`` and phase offsets ``φ_p``, eq. 8 gives per phase ``p``
    ``Fy: (2/3) k sin(θ + ζ + φ_p)`` and ``Fx: (2/3) k μ cos(θ + ζ + φ_p)``, ``Tz = d · Fx``;
    expanding the sums, the ``cos θ`` coefficients form ``A`` and the ``sin θ``
    coefficients ``B`` (per phase), then ``ic = -ia - ib`` reduces them to ``(3, 2)``.
    ``A`` and ``B`` do not depend on ``d_m``; ``pole_pitch`` (m) is only checked.

    Args:
        k (N/A), zeta (rad), mu (-), lever_arm (m): scalars of one coil set.

    Returns:
        ``(A, B)``, each ``(3, 2)`` numpy arrays (N/A, N/A, N·m/A).
    """
    if not pole_pitch > 0:
        raise ValueError(f"pole_pitch must be positive, got {pole_pitch}")
    ph = float(zeta) + np.asarray(PHASE_OFFSETS)
    amp = (2.0 / 3.0) * float(k)
    a3 = np.stack([amp * np.sin(ph), amp * mu * np.cos(ph), lever_arm * amp * mu * np.cos(ph)])
    b3 = np.stack([amp * np.cos(ph), -amp * mu * np.sin(ph), -lever_arm * amp * mu * np.sin(ph)])
    return a3 @ STAR, b3 @ STAR


def _common_widths(models: list) -> list:
    """Pad single-hidden-layer networks to the widest of their kind (:meth:`MLP.padded`): coil sets
    identified with different widths (chosen by validation) stack into one model, same function."""
    def width(net):
        return None if net is None or len(net.hidden) != 1 else net.widths[0]

    gw = {width(m.gain_nets[0]) for m in models if m.gain_nets is not None}
    cw = {width(m.cog_net) for m in models if m.cog_net is not None}
    if len(gw) <= 1 and len(cw) <= 1 or None in gw | cw:
        return models
    g_max, c_max = max(gw, default=0), max(cw, default=0)
    return [replace(m, gain_nets=None if m.gain_nets is None else tuple(n.padded(g_max) for n in m.gain_nets),
                    cog_net=None if m.cog_net is None else m.cog_net.padded(c_max)) for m in models]


@pytree_dataclass
class CombinedModel:
    """``L`` coil-set models with stacked parameters (eq. PGNN_Electromagnetics).

    ``F̂(y, i) = Σ_l K̂^l(y) i^l + (1/L) Σ_l F̂^l_cog(y)``: the cogging force is the MEAN over
    coil sets, because each coil set's identification captures the whole cogging force.

    Attributes:
        A, B: ``(L, 3, 2)`` (N/A).
        gain_nets: one :class:`MLP` with leading dims ``G = (L, 2)`` (coil set, current
            column) or ``None``.
        cog_nets: one :class:`MLP` with leading dim ``G = (L,)``, or ``None``.
        y_center, y_scale: ``(L,)`` input scaling of each coil set (m).
        pole_pitch: ``d_m`` (m).
        y_min, y_max: per-coil-set training range (m), tuples of length ``L`` or ``None``.
        H: ``(L, 4, 3, 2)`` higher-harmonic gain coefficients or ``None`` (see :class:`CoilSetModel`).
        C: ``(L, 3)`` direction terms or ``None``; the combined direction force is their MEAN
            times ``s(ẏ)``, like the cogging force (each coil set's data see the whole force).
        direction_velocity: ``v_ε`` (m/s).

    All coil sets must have the same network structure (so that their parameters stack
    and one vectorised evaluation covers all of them).
    """

    A: jnp.ndarray
    B: jnp.ndarray
    gain_nets: MLP | None
    cog_nets: MLP | None
    y_center: jnp.ndarray
    y_scale: jnp.ndarray
    pole_pitch: float = static_field()
    y_min: tuple | None = static_field(default=None)
    y_max: tuple | None = static_field(default=None)
    H: jnp.ndarray | None = None
    C: jnp.ndarray | None = None
    direction_velocity: float = static_field(default=DEFAULT_DIRECTION_VELOCITY)

    @property
    def n_coil_sets(self) -> int:
        """``L``."""
        return int(self.A.shape[0])

    @property
    def training_range(self) -> tuple[float, float] | None:
        """Positions covered by the training data of EVERY coil set, ``(y_min, y_max)`` (m), or ``None``."""
        if self.y_min is None or self.y_max is None:
            return None
        return max(self.y_min), min(self.y_max)

    @classmethod
    def from_coil_sets(cls, models) -> "CombinedModel":
        """Stack a sequence of :class:`CoilSetModel` (same pole pitch and network structure)."""
        models = list(models)
        if not models:
            raise ValueError("need at least one coil-set model")
        models = _common_widths(models)
        m0 = models[0]
        for l, m in enumerate(models):
            if m.pole_pitch != m0.pole_pitch:
                raise ValueError(f"coil set {l + 1}: pole pitch {m.pole_pitch} differs from {m0.pole_pitch}")
            if jax.tree_util.tree_structure((m.gain_nets, m.cog_net)) != jax.tree_util.tree_structure(
                    (m0.gain_nets, m0.cog_net)):
                raise ValueError(f"coil set {l + 1}: network structure differs from coil set 1")
            if jax.tree_util.tree_map(jnp.shape, (m.gain_nets, m.cog_net)) != jax.tree_util.tree_map(
                    jnp.shape, (m0.gain_nets, m0.cog_net)):
                raise ValueError(f"coil set {l + 1}: network widths differ from coil set 1")

        def stack(*xs):  # on the host, then placed: jnp.stack outside a trace compiles a program per shape
            return jax.device_put(np.stack([np.asarray(x, float) for x in xs]))

        gain = None
        if m0.gain_nets is not None:
            per_l = [jax.tree_util.tree_map(stack, *m.gain_nets) for m in models]  # leading (2,)
            gain = jax.tree_util.tree_map(stack, *per_l)  # leading (L, 2)
        cog = None if m0.cog_net is None else jax.tree_util.tree_map(stack, *[m.cog_net for m in models])
        for name in ("H", "C"):
            if len({getattr(m, name) is None for m in models}) != 1:
                raise ValueError(f"coil sets differ in whether the extension {name} is on")
        if len({m.direction_velocity for m in models}) != 1:
            raise ValueError("coil sets differ in the direction term's v_eps")
        has_range = all(m.y_min is not None and m.y_max is not None for m in models)
        return cls(stack(*[m.A for m in models]), stack(*[m.B for m in models]), gain, cog,
                   jax.device_put(np.asarray([m.y_center for m in models], float)),
                   jax.device_put(np.asarray([m.y_scale for m in models], float)),
                   float(m0.pole_pitch),
                   tuple(float(m.y_min) for m in models) if has_range else None,
                   tuple(float(m.y_max) for m in models) if has_range else None,
                   None if m0.H is None else stack(*[m.H for m in models]),
                   None if m0.C is None else stack(*[m.C for m in models]), float(m0.direction_velocity))

    def coil_set(self, l: int) -> CoilSetModel:
        """The model of coil set ``l`` (0-based) as a :class:`CoilSetModel`."""
        take = lambda x: x[l]  # noqa: E731
        gain = None
        if self.gain_nets is not None:
            g = jax.tree_util.tree_map(take, self.gain_nets)
            gain = tuple(jax.tree_util.tree_map(lambda x, j=j: x[j], g) for j in range(2))
        cog = None if self.cog_nets is None else jax.tree_util.tree_map(take, self.cog_nets)
        return CoilSetModel(self.A[l], self.B[l], gain, cog, self.pole_pitch, float(self.y_center[l]),
                            float(self.y_scale[l]), None if self.y_min is None else self.y_min[l],
                            None if self.y_max is None else self.y_max[l], None if self.H is None else self.H[l],
                            None if self.C is None else self.C[l], self.direction_velocity)

    def scaled_positions(self, y):
        """Per-coil-set scaled positions ``S + (L,)``."""
        return (jnp.asarray(y, dtype=float)[..., None] - self.y_center) / self.y_scale

    def gain(self, y):
        """``K̂^l(y)`` for all coil sets, ``S + (L, 3, 2)`` (N/A)."""
        c, s = harmonic_basis(y, self.pole_pitch)
        k = self.A * c[..., None, None, None] + self.B * s[..., None, None, None]
        if self.H is not None:
            k = k + harmonic_gain(self.H, y, self.pole_pitch)
        if self.gain_nets is not None:
            sl = self.scaled_positions(y)
            out = self.gain_nets(jnp.broadcast_to(sl[..., None], sl.shape + (2,)))  # S + (L, 2, 3)
            k = k + jnp.swapaxes(out, -1, -2)
        return k

    def cogging(self, y):
        """Mean cogging force of the coil sets, ``S + (3,)`` (N, N, N·m)."""
        if self.cog_nets is None:
            return jnp.zeros(jnp.shape(y) + (3,))
        out = self.cog_nets(self.scaled_positions(y))
        # An explicit sum over the (few) coil sets: a reduction over a non-minor axis is slow on CPU.
        return sum(out[..., l, :] for l in range(out.shape[-2])) / out.shape[-2]

    def direction_force(self, y, v):
        """Mean direction force ``(1/L) Σ_l C^l s(ẏ)``, ``S + (3,)`` (N, N, N·m); zeros when off.

        ``v``: velocity ``S`` (m/s) — what the controller has (see :class:`pgcomm.commutation.ModelLaw`).
        """
        if self.C is None:
            return jnp.zeros(jnp.shape(y) + (3,))
        c_mean = sum(self.C[l] for l in range(self.C.shape[0])) / self.C.shape[0]
        return c_mean * smooth_sign(v, self.direction_velocity)[..., None]

    @property
    def has_direction(self) -> bool:
        """Whether the direction term is on."""
        return self.C is not None

    @property
    def has_harmonics(self) -> bool:
        """Whether the 5th/7th harmonic gain columns are on."""
        return self.H is not None

    def force(self, y, currents, v=None):
        """``F̂ = Σ_l K̂^l i^l + mean_l F̂^l_cog [+ mean_l C^l s(v)]``; currents ``S + (L, 2)`` (A) -> ``S + (3,)``."""
        f = jnp.einsum("...lqj,...lj->...q", self.gain(y), currents) + self.cogging(y)
        if self.C is not None and v is not None:
            f = f + self.direction_force(y, v)
        return f

    def physics_only(self) -> "CombinedModel":
        """The same ``A, B`` without networks or extensions (the physics-only combined model)."""
        return dataclasses.replace(self, gain_nets=None, cog_nets=None, H=None, C=None)


def warn_outside_training_range(model, y) -> str | None:
    """A warning if positions ``y`` (m) leave the model's training range, else ``None``.

    Works for :class:`CoilSetModel` (``y_min, y_max``) and any model with ``training_range`` (a
    :class:`CombinedModel` or a :class:`~pgcomm.spline_model.SplineModel`: the range covered by every
    coil set). Models without a stored range give ``None``.
    """
    if hasattr(model, "training_range"):
        rng = model.training_range
    else:
        rng = None if model.y_min is None or model.y_max is None else (model.y_min, model.y_max)
    if rng is None:
        return None
    y = np.asarray(y, dtype=float).ravel()
    out = (y < rng[0]) | (y > rng[1])
    if not out.any():
        return None
    return (f"{int(out.sum())} of {y.size} positions ({out.mean():.1%}) lie outside the training range "
            f"[{rng[0]:.4g}, {rng[1]:.4g}] m (data span [{y.min():.4g}, {y.max():.4g}] m); "
            "the model extrapolates there")
