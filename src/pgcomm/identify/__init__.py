"""Identification of the electromagnetic part (Algorithm 2): cost, Proposition 1 and variable-projection training.

What this module implements (labels of the paper):

* the cost eq. Identification_CostFunction for one coil set ``l``::

      V = 1/(2N) Σ_{t ∈ Z_1 ∪ Z_2} ||F(t) - F̂(t)||² + ||Λ (θ_phy - θ_phy*)||²

  with ``2N`` the total number of (training) samples of both data sets, ``Λ`` diagonal
  (12 entries, default ``0.1 I``) and ``θ_phy = [col(A); col(B)]``;
* the physics-only fit (linear least squares for ``A, B``) giving ``θ_phy*``;
* the linear-in-the-parameters rewrite (eqs. PGNN_Rewritten_LIP, Linear_Parameter_Vector):
  ``F̂_q(t) = M(θ_NL, t) θ_L,q`` for ``q ∈ {y, x, z}`` with ONE regressor row shared by the
  three directions (each network outputs ``R^3`` from shared hidden features)::

      M = [cos·ia, cos·ib, sin·ia, sin·ib, h_1(s)·ia, ia, h_2(s)·ib, ib, h_φ(s), 1]

  (``cos, sin`` of ``2πy/d_m``, ``h`` the last hidden layers, ``s`` the scaled position);
  ``θ_L,q = [A_q1, A_q2, B_q1, B_q2, W_1[:, q], b_1[q], W_2[:, q], b_2[q], W_φ[:, q], b_φ[q]]``;
* Proposition 1 (eq. Optimal_Initialization): the optimal ``θ_L`` for given hidden
  weights ``θ_NL``, solved as a least-squares problem through an orthogonal factorisation
  (never by inverting the normal matrix);
* Algorithm 2 by variable projection: Levenberg–Marquardt over ``θ_NL`` only, with
  ``θ_L = Prop1(θ_NL)`` inside the loop and the exact Jacobian of the projected residual,
  several random starts evaluated together (a leading start axis; ``jax.vmap`` over the
  small per-start solves), the best kept; all starts run first on a subsample of the data,
  the best is then refined on all of it (see :func:`identify`);
* the persistent-excitation check of the paper's Remark runs first
  (:func:`pgcomm.excitation.check_excitation`).

Modules: :mod:`~pgcomm.identify.layout` (``θ_phy``, ``Λ``, ``θ_NL``, ``θ_L``),
:mod:`~pgcomm.identify.projection` (regressor, Proposition 1, cost, projected normal
equations), :mod:`~pgcomm.identify.lm` (the Levenberg–Marquardt loop, :func:`identify`), :mod:`~pgcomm.identify.options`
(:class:`IdentifyOptions`, the settings as one object),
:mod:`~pgcomm.identify.result` (:class:`IdentifyResult`). The public names are re-exported here.

Numerics (why it is done this way)
----------------------------------
The regressor of a 16-unit cogging network is nearly rank deficient (condition numbers of
``1e13``–``1e15`` even on scaled positions), so Proposition 1 needs an orthogonal
factorisation. A Householder QR from JAX on CPU is two orders of magnitude slower than a
matrix product, so the factorisation ``[M, F] D^{-1} = Q R`` is computed as a *repeated
Gram factorisation* (CholeskyQR2 with an eigenvalue floor in place of the Cholesky shift):
each pass accumulates ``G = Σ_chunks (A_c R^{-1})ᵀ (A_c R^{-1})`` over chunks of samples
(matrix products only), factors ``G = R_kᵀ R_k`` by a symmetric eigendecomposition with
eigenvalues floored at ``10·m·u·λ_max``, and updates ``R <- R_k R``. ``R`` is square
(``m = p + 3``), not triangular; the small least-squares problems are then solved by SVD of
``[R_M; √(2N) W_q; α B]``. After two passes this reproduces ``numpy.linalg.lstsq`` on the
full (column-scaled) problem to about ``1e-10`` in cost even at condition numbers of ``1e16``;
exactly dependent directions are damped instead of producing NaN. Memory is bounded by the
chunk size, independent of ``N``.

Damping. Without it the minimum-norm solution has output weights of ``1e7``–``1e8`` in the
directions the data cannot resolve, and the variable-projection gradient there is noise
(off by orders of magnitude against finite differences), so Levenberg–Marquardt stalls. A
fixed Tikhonov term ``α² Σ_k (b_k θ_k)²`` (``α = 1e-6`` relative to data-only column-norm
bounds ``b_k``) makes the projected cost smooth and its derivative exact; it is reported
separately and is not part of ``V``.

Sensitivity. The gradient of the projected cost depends on ``θ_L`` to first order, so
``JᵀJ`` and ``Jᵀr̃`` carry relative errors of about ``cond·u`` (``1e-12``–``1e-7``): they
agree with finite differences to ``1e-6`` but change at that level with the chunk size or
the summation order, while the cost and ``θ_L`` agree to ``1e-11``.

Sums over samples are never formed as an ``N x n`` Jacobian: the structured path (single
hidden layer, the paper's networks) reads every sum it needs from one Gram matrix of
``[M, F, V]`` accumulated in the first pass (``V`` are the derivatives of the features with
respect to their own hidden weights, obtained with ``jax.jvp`` of the activation); the
generic path (deeper networks) makes one more chunked pass with ``jax.jacfwd`` of the
feature map. Both give the same ``JᵀJ`` and ``Jᵀr`` (tested).
"""

from pgcomm.identify.layout import (
    DEFAULT_LAMBDA,
    hidden_vector,
    lambda_diagonal,
    theta_L_of,
    theta_phy,
    theta_phy_to_AB,
    with_hidden_vector,
    with_theta_L,
)
from pgcomm.identify.lm import identify, identify_all, identify_selecting_width
from pgcomm.identify.options import MIN_FEATURE_WIDTH, IdentifyOptions
from pgcomm.identify.projection import (
    DEFAULT_CHUNK,
    DEFAULT_CHUNK_GENERIC,
    DEFAULT_DAMPING,
    CostTerms,
    Proposition1Result,
    cost,
    cost_y,
    fit_physics,
    projected_normal_equations,
    projected_residual,
    proposition1,
    regressor,
)
from pgcomm.identify.result import STOP_REASONS, IdentifyResult

__all__ = [
    "DEFAULT_LAMBDA", "DEFAULT_DAMPING", "DEFAULT_CHUNK", "DEFAULT_CHUNK_GENERIC", "STOP_REASONS",
    "theta_phy", "theta_phy_to_AB", "lambda_diagonal", "hidden_vector", "with_hidden_vector", "theta_L_of",
    "with_theta_L", "regressor", "fit_physics", "CostTerms", "cost", "cost_y", "Proposition1Result", "proposition1",
    "projected_normal_equations", "projected_residual", "identify", "identify_all", "identify_selecting_width",
    "IdentifyOptions", "MIN_FEATURE_WIDTH", "IdentifyResult",
]
