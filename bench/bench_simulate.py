"""Closed-loop simulation throughput: controller samples simulated per second of wall time, on one core.

Runs the twin in closed loop with the PGNN commutation law in the loop (a paper-size
model: L = 3, gain widths 2, cogging width 16) on the paper's data-generation reference
(27 609 samples), after a warm-up run that compiles. Reports, for classical commutation
(the baseline of the same process) and for the PGNN law:

* one run at a time (``simulate``);
* ``--batch`` runs at once (``simulate_many``: the laws stacked, one compiled loop), e.g. a
  Monte-Carlo study over noise seeds;
* the PGNN's rate as a share of classical commutation's.

Usage: ``python bench/bench_simulate.py [--batch 16] [--repeat 5] [--cpu N]``. The process is
pinned to one processor (``--cpu``, default the first it may use) and XLA to one thread. Each
figure is the best of ``--repeat`` runs: on a shared machine the best run is the one least
disturbed by other work.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false")

import jax  # noqa: E402
import numpy as np  # noqa: E402

import pgcomm  # noqa: E402,F401
from pgcomm.commutation import ClassicalLaw, ModelLaw  # noqa: E402
from pgcomm.models import CombinedModel, CoilSetModel, physics_from_ideal  # noqa: E402
from pgcomm.simulate import simulate, simulate_many  # noqa: E402
from pgcomm.trajectory import data_generation_reference  # noqa: E402
from pgcomm.twin import DEFAULT_TWIN, true_fundamental  # noqa: E402


def paper_size_pgnn(tw):
    """A PGNN with the paper's structure; physics part from the twin's fundamental, random networks."""
    k, zeta = true_fundamental(tw)
    models = []
    for l in range(tw.n_coil_sets):
        a, b = physics_from_ideal(tw.pole_pitch, k[l], zeta[l], tw.mu, tw.lever_arms[l])
        m = CoilSetModel.init(jax.random.PRNGKey(l), CoilSetModel.physics(a, b, tw.pole_pitch, 0.0, 0.1, -0.1, 0.1), (2,),
                              (16,), "tanh")
        models.append(m)
    return CombinedModel.from_coil_sets(models)


def rate(fn, n_samples, repeat):
    """Controller samples per second of wall time of ``fn`` (which simulates ``n_samples``): best of ``repeat``."""
    fn()  # compile
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return n_samples / best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=16, help="runs simulated at once (default 16)")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per figure; the best counts (default 5)")
    ap.add_argument("--cpu", type=int, help="processor to run on (default: the first this process may use)")
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        cpu = min(os.sched_getaffinity(0)) if args.cpu is None else args.cpu
        os.sched_setaffinity(0, {cpu})
    tw = DEFAULT_TWIN
    plant = tw.plant()
    motor = tw.motor()
    ref = data_generation_reference()
    n = len(ref.r)
    pgnn = ModelLaw(paper_size_pgnn(tw), current_limit=motor.current_limit)
    k, zeta = true_fundamental(tw)
    classical = ClassicalLaw.from_motor(motor, k=k, zeta=zeta)
    print(f"reference: {n} samples; batch B = {args.batch}; best of {args.repeat}; one processor, one XLA thread")
    rates = {}
    for name, law in (("classical", classical), ("pgnn", pgnn)):
        r1 = rate(lambda: simulate(plant, law, ref, drive=motor), n, args.repeat)
        rb = rate(lambda: simulate_many(plant, [law] * args.batch, ref, drive=motor), n * args.batch, args.repeat)
        rates[name] = (r1, rb)
        print(f"{name:10s} single run: {r1 / 1e6:6.3f} M samples/s   batched x{args.batch}: {rb / 1e6:6.3f} M samples/s")
    (c1, cb), (p1, pb) = rates["classical"], rates["pgnn"]
    print(f"pgnn / classical: {p1 / c1:.2f} (single run), {pb / cb:.2f} (batched)")


if __name__ == "__main__":
    main()
