"""Benchmark: batched PGNN commutation throughput (samples per second).

Run ``python bench/bench_commutation.py [--sizes 1e6 1e7]``. For a three-coil-set PGNN with
the paper's widths (2 units per gain column, 16 for cogging, non-zero output layers) it times,
jitted and after a warm-up (best of ``--repeat`` runs):

* ``ModelLaw(model).currents(y, F*)`` (eq. Commutation_Model_Currents, minimum copper loss),
  and with ``metric="star"`` (the literal ``K̂^†`` of the reduced ``3 x 2L`` matrix);
* its parts: the model alone (``gain`` and ``cogging``) and ``min_energy_currents`` alone
  on a precomputed gain;
* a numpy baseline in the same process: the same model evaluated with numpy and
  ``numpy.linalg.pinv`` on the stacked ``3 x 6`` matrices (the literal ``K̂^†``).
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from pgcomm.commutation import ModelLaw, metric_inverse, min_energy_currents
from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal
from pgcomm.motor import Motor

D_M = 0.03


def paper_model(seed: int = 0) -> CombinedModel:
    """Three coil sets, ideal physics part plus networks with random non-zero output layers."""
    motor = Motor()
    rng = np.random.default_rng(seed)
    sets = []
    for l in range(3):
        a, b = physics_from_ideal(D_M, 61.0 + l, -0.54, 0.05, motor.lever_arms[l])
        m = CoilSetModel.init(jax.random.PRNGKey(seed + l), CoilSetModel.physics(a, b, D_M, 0.0, 0.1, -0.1, 0.1))
        leaves, tree = jax.tree_util.tree_flatten(m)
        sets.append(jax.tree_util.tree_unflatten(tree, [np.asarray(x) + 0.2 * rng.normal(size=x.shape)
                                                        for x in leaves]))
    return CombinedModel.from_coil_sets(sets)


def best_time(fn, *args, repeat=3):
    """Best wall time (s) of ``repeat`` calls after one warm-up call."""
    jax.block_until_ready(fn(*args))
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        best = min(best, time.perf_counter() - t0)
    return best


def numpy_model(model: CombinedModel, y):
    """``(K̂ (N, 3, 6), F̂_cog (N, 3))`` with numpy (single hidden layer networks)."""
    c, s = np.cos(2 * np.pi * y / D_M), np.sin(2 * np.pi * y / D_M)
    a, b = np.asarray(model.A), np.asarray(model.B)
    sl = (y[:, None] - np.asarray(model.y_center)) / np.asarray(model.y_scale)  # (N, L)
    g, cg = model.gain_nets, model.cog_nets
    (wg, bg), = g.hidden
    hg = np.tanh(sl[:, :, None, None] * np.asarray(wg)[:, :, 0] + np.asarray(bg))  # (N, L, 2, n)
    out = np.einsum("nljk,ljkq->nlqj", hg, np.asarray(g.W_out)) + np.swapaxes(np.asarray(g.b_out), -1, -2)
    k = a * c[:, None, None, None] + b * s[:, None, None, None] + out  # (N, L, 3, 2)
    (wc, bc), = cg.hidden
    hc = np.tanh(sl[:, :, None] * np.asarray(wc)[:, 0] + np.asarray(bc))  # (N, L, 16)
    cog = (np.einsum("nlk,lkq->nq", hc, np.asarray(cg.W_out)) + np.asarray(cg.b_out).sum(0)) / k.shape[1]
    return np.concatenate([k[:, l] for l in range(k.shape[1])], axis=-1), cog


def numpy_pinv_law(model, y, f_star):
    """Baseline: ``i = K̂^† (F* - F̂_cog)`` per sample with ``numpy.linalg.pinv``; ``(N, L, 2)``."""
    k, cog = numpy_model(model, y)
    i = np.einsum("nij,nj->ni", np.linalg.pinv(k), f_star - cog)
    return i.reshape(len(y), -1, 2)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e6, 1e7], help="batch sizes (samples)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--baseline-size", type=float, default=1e5, help="samples for the numpy-pinv baseline")
    args = ap.parse_args(argv)
    model = paper_model()
    winv = metric_inverse(3)
    law = jax.jit(lambda m, y, f: ModelLaw(m).currents(y, f))
    law_star = jax.jit(lambda m, y, f: ModelLaw(m, metric="star").currents(y, f))
    parts = jax.jit(lambda m, y: (m.gain(y), m.cogging(y)))
    mec = jax.jit(lambda k, f: min_energy_currents(k, f, winv))
    rng = np.random.default_rng(0)
    print(f"PGNN commutation, L = 3, widths 2 (gain) / 16 (cogging), float64, {jax.device_count()} CPU device(s)")
    for n in (int(v) for v in args.sizes):
        y = jnp.asarray(rng.uniform(-0.1, 0.1, n))
        f = jnp.asarray(rng.normal(size=(n, 3)) * np.array([50.0, 2.0, 1.0]))
        t_law = best_time(law, model, y, f, repeat=args.repeat)
        t_star = best_time(law_star, model, y, f, repeat=args.repeat)
        t_model = best_time(parts, model, y, repeat=args.repeat)
        k = parts(model, y)[0]
        t_mec = best_time(mec, k, f, repeat=args.repeat)
        del k
        print(f"  N = {n:.0e}: ModelLaw {n / t_law / 1e6:6.2f} M samples/s (metric 'star': {n / t_star / 1e6:.2f}); "
              f"parts: model (gain + cogging) {n / t_model / 1e6:.2f} M/s, "
              f"min_energy_currents {n / t_mec / 1e6:.2f} M/s",
              flush=True)
    nb = int(args.baseline_size)
    y = rng.uniform(-0.1, 0.1, nb)
    f = rng.normal(size=(nb, 3)) * np.array([50.0, 2.0, 1.0])
    t0 = time.perf_counter()
    i_np = numpy_pinv_law(model, y, f)
    t_np = time.perf_counter() - t0
    i_jx = np.asarray(law_star(model, jnp.asarray(y), jnp.asarray(f)))
    print(f"  numpy-pinv baseline (N = {nb:.0e}): {nb / t_np / 1e6:.3f} M samples/s; "
          f"max |i_numpy - i_ModelLaw(star)| = {np.abs(i_np - i_jx).max():.1e} A")


if __name__ == "__main__":
    main()
