"""The PGNN parameter layout of one coil set: ``θ_phy``, ``Λ``, ``θ_NL`` (hidden layers) and ``θ_L`` (linear part).

``θ_phy = [col(A); col(B)]`` (12,); ``θ_L`` is ``(p, 3)`` with column ``q`` the linear
parameters of direction ``q`` (eq. Linear_Parameter_Vector); ``θ_NL`` is the flat vector of
the hidden layers of the networks ``f_1, f_2, f_φ`` (those present).

Row order of ``θ_L`` (= column order of the regressor ``M``): the 4 physics entries
``A[:, 0], A[:, 1], B[:, 0], B[:, 1]``; when on, the 8 harmonic entries ``H[j, :, 0], H[j, :, 1]``
for ``j = cos 5θ, sin 5θ, cos 7θ, sin 7θ``; when on, the direction term ``C``; then the
output layers of the networks. The first ``n_known`` columns are known functions of the data
(no hidden weights); the network blocks follow.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp
import numpy as np

from pgcomm.models import MLP, CoilSetModel

#: Default regularisation weight (``Λ = 0.1 I``, paper §Experimental results).
DEFAULT_LAMBDA = 0.1


def theta_phy(A, B) -> np.ndarray:
    """``θ_phy = [col(A); col(B)]`` (12,) for ``A, B`` of shape ``(3, 2)`` (column stacking)."""
    return np.concatenate([np.asarray(A, float).T.ravel(), np.asarray(B, float).T.ravel()])


def theta_phy_to_AB(theta) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`theta_phy`: ``(A, B)``, each ``(3, 2)``."""
    theta = np.asarray(theta, float)
    return theta[:6].reshape(2, 3).T, theta[6:].reshape(2, 3).T


def lambda_diagonal(Lambda) -> np.ndarray:
    """The 12 diagonal entries of ``Λ`` from a scalar, a ``(12,)`` vector or a diagonal ``(12, 12)`` matrix."""
    lam = np.asarray(Lambda, dtype=float)
    if lam.ndim == 0:
        return np.full(12, float(lam))
    if lam.shape == (12,):
        return lam.copy()
    if lam.shape == (12, 12):
        if np.any(lam - np.diag(np.diag(lam))):
            raise ValueError("Λ must be diagonal (Proposition 1 needs a diagonal Λ)")
        return np.diag(lam).copy()
    raise ValueError(f"Λ must be a scalar, (12,) or (12, 12); got shape {lam.shape}")


def _physics_columns(q: int) -> np.ndarray:
    """Indices in ``θ_phy`` of ``A[q, 0], A[q, 1], B[q, 0], B[q, 1]`` (the first 4 entries of ``θ_L,q``)."""
    return np.array([q, 3 + q, 6 + q, 9 + q])


@dataclass(frozen=True)
class _Layout:
    """Static structure of the LIP rewrite: which networks, widths, activation, Jacobian method."""

    gain_widths: tuple | None
    cog_widths: tuple | None
    activation: str
    method: str = "auto"  # "structured" | "generic" | "auto"
    harmonics: bool = False
    direction: bool = False
    direction_velocity: float = 1e-3
    #: sensorless identification (:mod:`pgcomm.sensorless`): the number of friction columns
    #: (Coulomb table and viscous) after the model's own known columns; their parameters are
    #: mechanics, not part of the model
    friction: int = 0

    @property
    def n_known(self) -> int:
        """Number of known (data-only) regressor columns: 4 physics + 8 harmonic + 1 direction + friction (when on)."""
        return 4 + 8 * int(self.harmonics) + int(self.direction) + int(self.friction)

    @property
    def friction_rows(self) -> slice:
        """Rows of ``θ_L`` holding the friction parameters (empty unless ``friction``)."""
        end = self.n_known
        return slice(end - int(self.friction), end)

    @classmethod
    def of(cls, model: CoilSetModel, method="auto") -> "_Layout":
        gw = None if model.gain_nets is None else model.gain_nets[0].widths
        if model.gain_nets is not None and model.gain_nets[1].widths != gw:
            raise ValueError("both gain networks must have the same widths")
        cw = None if model.cog_net is None else model.cog_net.widths
        acts = {net.activation for net in model.networks} or {"tanh"}
        if len(acts) != 1:
            raise ValueError(f"all networks must share one activation, got {sorted(acts)}")
        return cls(gw, cw, acts.pop(), method, model.H is not None, model.C is not None,
                   float(model.direction_velocity))

    @property
    def blocks(self) -> tuple:
        """``(multiplier, widths)`` per network in column order; multiplier 0 = ia, 1 = ib, 2 = 1."""
        out = []
        if self.gain_widths is not None:
            out += [(0, self.gain_widths), (1, self.gain_widths)]
        if self.cog_widths is not None:
            out.append((2, self.cog_widths))
        return tuple(out)

    @property
    def p(self) -> int:
        """Length of one regressor row (of ``θ_L,q``)."""
        return self.n_known + sum(w[-1] + 1 for _, w in self.blocks)

    @property
    def n_nl(self) -> int:
        """Number of hidden-layer parameters ``θ_NL``."""
        total = 0
        for _, widths in self.blocks:
            n_prev = 1
            for n in widths:
                total += n_prev * n + n
                n_prev = n
        return total

    @property
    def structured(self) -> bool:
        """Use the single-hidden-layer structure for the Jacobian sums."""
        single = all(len(w) == 1 for _, w in self.blocks)
        if self.method == "structured" and not single:
            raise ValueError("the structured Jacobian needs networks with one hidden layer")
        return single if self.method == "auto" else self.method == "structured"

    def feature_columns(self) -> list[int]:
        """First column in ``M`` of each network's hidden-feature block."""
        cols, c = [], self.n_known
        for _, w in self.blocks:
            cols.append(c)
            c += w[-1] + 1
        return cols

    def first_layer_weight_mask(self) -> np.ndarray:
        """``(n_nl,)`` True at the entries of ``θ_NL`` that are first-layer weights (slopes in ``s``).

        Order of ``θ_NL`` (see :func:`hidden_vector`): per network, per hidden layer, the
        weights then the biases; the first layer's weights are the first ``n_1`` entries.
        """
        mask = []
        for _, widths in self.blocks:
            n_prev = 1
            for i, n in enumerate(widths):
                mask += [i == 0] * (n_prev * n) + [False] * n
                n_prev = n
        return np.asarray(mask, bool)

    def output_weight_mask(self) -> np.ndarray:
        """``(p,)`` True at the columns of ``M`` whose parameters are network output WEIGHTS."""
        mask = np.zeros(self.p, bool)
        for c, (_, w) in zip(self.feature_columns(), self.blocks):
            mask[c:c + w[-1]] = True
        return mask

    def param_units(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Structured path (one hidden layer): for each entry ``i`` of ``θ_NL`` the hidden unit
        ``k(i)`` it feeds (counted over all networks), the power ``a(i)`` of ``s`` in its
        derivative (1 for a weight, 0 for a bias) and the column ``col(i)`` of ``M`` of that unit.
        """
        unit, power, col, offset = [], [], [], 0
        for c, (_, w) in zip(self.feature_columns(), self.blocks):
            units = np.arange(w[0])
            unit += [offset + units, offset + units]  # weights, then biases
            power += [np.ones(w[0], int), np.zeros(w[0], int)]
            col += [c + units, c + units]
            offset += w[0]
        if not unit:
            return np.zeros(0, int), np.zeros(0, int), np.zeros(0, int)
        return np.concatenate(unit), np.concatenate(power), np.concatenate(col)


def hidden_vector(model: CoilSetModel) -> jnp.ndarray:
    """``θ_NL`` of ``model`` as a flat vector.

    Order: networks ``f_1, f_2, f_φ`` (those present); per network its hidden layers in
    order; per layer ``W.ravel()`` (row-major ``(n_{i-1}, n_i)``) then ``b``.
    """
    parts = [jnp.ravel(a) for net in model.networks for wb in net.hidden for a in wb]
    return jnp.concatenate(parts) if parts else jnp.zeros(0)


def _unflatten(layout: _Layout, flat) -> list:
    """Hidden layers per network from a flat ``θ_NL`` of shape ``lead + (n,)`` (arrays get the leading dims)."""
    lead = flat.shape[:-1]
    out, i = [], 0
    for _, widths in layout.blocks:
        layers, n_prev = [], 1
        for n in widths:
            w = flat[..., i:i + n_prev * n].reshape(lead + (n_prev, n))
            i += n_prev * n
            b = flat[..., i:i + n]
            i += n
            layers.append((w, b))
            n_prev = n
        out.append(tuple(layers))
    return out


def with_hidden_vector(model: CoilSetModel, flat) -> CoilSetModel:
    """Copy of ``model`` with ``θ_NL`` replaced by the flat vector ``flat`` (order of :func:`hidden_vector`)."""
    layout = _Layout.of(model)
    hidden = iter(_unflatten(layout, jnp.asarray(flat, dtype=float)))
    gain = None
    if model.gain_nets is not None:
        gain = tuple(MLP(next(hidden), net.W_out, net.b_out, net.activation) for net in model.gain_nets)
    cog = None
    if model.cog_net is not None:
        cog = MLP(next(hidden), model.cog_net.W_out, model.cog_net.b_out, model.cog_net.activation)
    return dataclasses.replace(model, gain_nets=gain, cog_net=cog)


def theta_L_of(model: CoilSetModel) -> jnp.ndarray:
    """``θ_L`` of ``model`` as a ``(p, 3)`` matrix whose column ``q`` is ``θ_L,q`` (eq. Linear_Parameter_Vector)."""
    rows = [model.A[:, 0], model.A[:, 1], model.B[:, 0], model.B[:, 1]]
    if model.H is not None:
        rows += [model.H[j, :, c] for j in range(4) for c in range(2)]
    if model.C is not None:
        rows.append(model.C)
    for net in model.networks:
        rows += list(net.W_out) + [net.b_out]
    return jnp.stack(rows)


def with_theta_L(model: CoilSetModel, theta_L) -> CoilSetModel:
    """Copy of ``model`` with the linear parameters from a ``(p, 3)`` ``θ_L`` (inverse of :func:`theta_L_of`)."""
    theta_L = jnp.asarray(theta_L)
    A = jnp.stack([theta_L[0], theta_L[1]], axis=1)
    B = jnp.stack([theta_L[2], theta_L[3]], axis=1)
    i = 4
    H = C = None
    if model.H is not None:
        H = jnp.stack([jnp.stack([theta_L[i + 2 * j], theta_L[i + 2 * j + 1]], axis=1) for j in range(4)])
        i += 8
    if model.C is not None:
        C = theta_L[i]
        i += 1
    outs = []
    for net in model.networks:
        n = net.W_out.shape[0]
        outs.append((theta_L[i:i + n], theta_L[i + n]))
        i += n + 1
    gain_out = outs[:2] if model.gain_nets is not None else None
    cog_out = outs[-1] if model.cog_net is not None else None
    return model.with_outputs(A, B, gain_out, cog_out, H, C)
