"""Benchmark: PGNN identification (Algorithm 2) on a paper-size data set.

Run ``python bench/bench_identify.py [--quick]``. Prints:

(a) our variable-projection Levenberg–Marquardt identification of one coil set
    (``pgcomm.identify.identify``, defaults: 8 starts, Prop. 1 inside the loop, exact
    Jacobians): wall time and final cost;
(b) the baseline done the way the authors' MATLAB toolbox does it: Levenberg–Marquardt
    (``scipy.optimize.least_squares(method="lm")``, MINPACK) with finite-difference Jacobians
    over ALL parameters (``θ_phy`` and every network weight, 121 per coil set), 20 sequential
    random starts, each started from Proposition 1's linear parameters for its random hidden
    weights; lsqnonlin's defaults (function and step tolerance 1e-6, at most 100 function
    evaluations per parameter, finite-difference ones included: about 100 iterations). Same
    data, same cost: the residual holds the data rows and the rows ``√(2N) Λ (θ_phy - θ_phy*)``,
    so ``|r|² = 2N·V``. ``--quick`` runs 1 baseline start and extrapolates the time of 20
    (said so in the output);
(c) identification of three coil sets (``identify_all``): total seconds.

Data: synthetic, as in ``tests/test_identify.py`` (ideal gain with a position-dependent
perturbation, cogging force, noise), 2 data sets x 35 000 samples at 1 ms per coil set,
sweeps over ±0.1 m at the paper's peak speeds 0.025, 0.075 and 0.15 m/s, ``Δ = ±π/4``.
Costs are eq. Identification_CostFunction on the training data (80 %, blocks of 500 samples).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import jax
import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_identify import D_M, synthetic_coil_set  # noqa: E402  (the tests' data generator)

from pgcomm import identify as idf  # noqa: E402
from pgcomm.data import train_validation_split  # noqa: E402
from pgcomm.models import CoilSetModel  # noqa: E402
from pgcomm.motor import Motor  # noqa: E402

N_PER = 35_000
PAPER_SPEEDS = (0.025, 0.075, 0.15)


def paper_size_data(coil_set: int, seed: int = 0):
    """2 x 35 000 samples of coil set ``coil_set`` (0-based) at the paper's speeds."""
    return synthetic_coil_set(N_PER, seed=seed + coil_set, speeds=PAPER_SPEEDS, name=f"coil set {coil_set + 1}",
                              lever_arm=Motor().lever_arms[coil_set])


# ----------------------------------------------------------------------------------- the baseline


class FullParameterProblem:
    """The PGNN of one coil set with all 121 parameters in one vector (the toolbox's formulation).

    ``θ = [col(A), col(B), f_1: W1 b1 W_out b_out, f_2: ..., f_φ: ...]``; ``residual(θ)`` is the
    data rows ``F - F̂`` (3N) and ``√(2N) Λ (θ_phy - θ_phy*)`` (12), vectorised numpy.
    """

    def __init__(self, data, model: CoilSetModel, lam12, star):
        self.f = data.force
        self.ia, self.ib = data.currents[:, 0], data.currents[:, 1]
        th = 2 * np.pi * data.y / model.pole_pitch
        self.c, self.s = np.cos(th), np.sin(th)
        self.sc = (data.y - model.y_center) / model.y_scale
        self.reg = np.sqrt(data.n) * np.asarray(lam12)
        self.star = np.asarray(star)
        self.n_units = [net.widths[0] for net in (*model.gain_nets, model.cog_net)]

    def pack(self, model: CoilSetModel) -> np.ndarray:
        parts = [idf.theta_phy(model.A, model.B)]
        for net in (*model.gain_nets, model.cog_net):
            (w, b), = net.hidden
            parts += [np.ravel(w), np.ravel(b), np.ravel(net.W_out), np.ravel(net.b_out)]
        return np.concatenate(parts)

    def _nets(self, theta):
        i = 12
        for n in self.n_units:
            w, b = theta[i:i + n], theta[i + n:i + 2 * n]
            w_out = theta[i + 2 * n:i + 5 * n].reshape(n, 3)
            b_out = theta[i + 5 * n:i + 5 * n + 3]
            i += 5 * n + 3
            yield np.tanh(self.sc[:, None] * w + b) @ w_out + b_out

    def residual(self, theta):
        a, b = idf.theta_phy_to_AB(theta[:12])
        f1, f2, fcog = self._nets(theta)
        k1 = np.outer(self.c, a[:, 0]) + np.outer(self.s, b[:, 0]) + f1  # column ia of K̂(y), (N, 3)
        k2 = np.outer(self.c, a[:, 1]) + np.outer(self.s, b[:, 1]) + f2
        f_hat = k1 * self.ia[:, None] + k2 * self.ib[:, None] + fcog
        return np.concatenate([(self.f - f_hat).ravel(), self.reg * (theta[:12] - self.star)])


def baseline(train, n_starts: int, seed: int = 0):
    """The toolbox way: per start, random hidden weights -> Prop. 1 -> LM with FD Jacobians on all parameters."""
    a, b = idf.fit_physics(train, D_M)
    star = idf.theta_phy(a, b)
    lam12 = idf.lambda_diagonal(idf.DEFAULT_LAMBDA)
    y_center = 0.5 * (train.y.min() + train.y.max())
    y_scale = 0.5 * (train.y.max() - train.y.min())
    keys = jax.random.split(jax.random.PRNGKey(seed + 1000), n_starts)
    costs, seconds, nfev = [], [], []
    for key in keys:
        t0 = time.perf_counter()
        model = CoilSetModel.init(key, CoilSetModel.physics(a, b, D_M, y_center, y_scale))
        model = idf.proposition1(model, train, lam12, star).model
        prob = FullParameterProblem(train, model, lam12, star)
        x0 = prob.pack(model)
        # lsqnonlin's MaxFunctionEvaluations = 100·n counts the finite-difference evaluations too;
        # scipy's max_nfev for "lm" does not (one count per Jacobian), hence 100·n / (n + 1).
        sol = least_squares(prob.residual, x0, method="lm", ftol=1e-6, xtol=1e-6, gtol=1e-10,
                            max_nfev=-(-100 * x0.size // (x0.size + 1)))
        seconds.append(time.perf_counter() - t0)
        costs.append(float(np.sum(sol.fun ** 2) / train.n))  # |r|² = 2N·V
        nfev.append(int(sol.nfev) * (x0.size + 1))
        print(f"  baseline start {len(costs):2d}: V = {costs[-1]:.5f}  (about {nfev[-1]} residual evaluations, "
              f"{seconds[-1]:.1f} s)", flush=True)
    return np.array(costs), np.array(seconds), nfev


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 baseline start instead of 20, time extrapolated")
    args = ap.parse_args(argv)
    print(f"pgcomm identification benchmark: 2 data sets x {N_PER} samples per coil set, "
          f"{jax.device_count()} JAX CPU device(s)")

    data = paper_size_data(0)
    train, _ = train_validation_split(data)

    print("(a) variable-projection LM (ours), one coil set, 8 starts:")
    t0 = time.perf_counter()
    ours = idf.identify(data, D_M)
    t_ours = time.perf_counter() - t0
    print(f"  wall time {t_ours:.1f} s (includes JIT compilation), V physics = {ours.cost_physics:.4f}, "
          f"V PGNN = {ours.cost_pgnn:.4f} (validation data term {ours.cost_pgnn_validation:.4f} vs physics "
          f"{ours.cost_physics_validation:.4f}), {ours.iterations} iterations")
    t0 = time.perf_counter()
    again = idf.identify(paper_size_data(0, seed=100), D_M)
    t_warm = time.perf_counter() - t0
    print(f"  same-size data again (compiled): {t_warm:.1f} s, V PGNN = {again.cost_pgnn:.4f}")

    n_base = 1 if args.quick else 20
    print(f"(b) baseline: scipy least_squares(method='lm'), finite-difference Jacobians over all 121 "
          f"parameters, {n_base} sequential starts{' (--quick)' if args.quick else ''}:")
    costs, seconds, _ = baseline(train, n_base)
    t_base = float(seconds.sum()) * (20 / n_base)
    label = f"extrapolated from {n_base} starts to 20" if args.quick else "20 starts"
    print(f"  wall time {t_base:.1f} s ({label}), best V = {costs.min():.4f}, median V = {np.median(costs):.4f}")
    print(f"  speed ratio baseline / ours = {t_base / t_ours:.1f}x (ours incl. compilation), "
          f"{t_base / t_warm:.1f}x (compiled)")
    better = "lower than" if ours.cost_pgnn < costs.min() else "higher than"
    print(f"  our V = {ours.cost_pgnn:.4f} is {better} the baseline's best V = {costs.min():.4f}")

    print("(c) three coil sets (identify_all):")
    sets = [paper_size_data(l) for l in range(3)]
    t0 = time.perf_counter()
    _, results = idf.identify_all(sets, D_M)
    t_all = time.perf_counter() - t0
    for r in results:
        print(f"  {r.name}: V physics {r.cost_physics:.4f} -> PGNN {r.cost_pgnn:.4f} "
              f"(validation {r.cost_physics_validation:.4f} -> {r.cost_pgnn_validation:.4f}), {r.seconds:.1f} s")
    print(f"  total {t_all:.1f} s (JIT compilation already done in (a); a cold start adds about "
          f"{max(t_ours - t_warm, 0.0):.0f} s)")


if __name__ == "__main__":
    main()
