"""The reference optimum of Algorithm 2 on the default twin, and a run's training costs against it.

For each seed and coil set, the data sets are those of ``pgcomm reproduce --seed S`` (step [1]: the
default experiment, data generated at the drive's nominal ``k̂, ζ̂``). The reference optimum is the
lowest training cost ``V`` that many long starts reach on them: ``--starts`` random starts (default
32) screened for 400 iterations, the best 4 refined until the Gauss–Newton step predicts less than
1e-6 of the cost (at most 2000 iterations). ``V`` is a non-convex function of the hidden layers, so a
run with the defaults (8 starts, 300 screening iterations) may stop in another basin: the stored
optimum tells how far. It is the best these starts found, not a bound: a run with more starts can end
below it (negative figures).

Usage:

* ``python bench/reference_optimum.py --seeds 0 1 2 3 4``: compute and store in
  ``bench/reference_optimum.json`` (about 3 minutes per coil set on one core; seeds already stored are
  recomputed);
* ``python bench/reference_optimum.py --check OUT/results.json [...]``: each run's ``cost_pgnn`` per
  coil set against the stored optimum of its seed (``V / V_ref - 1``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false")

STORE = Path(__file__).with_name("reference_optimum.json")


def twin_data(seed: int):
    """``(data sets per coil set, pole pitch (m), the default identification options)`` of ``reproduce --seed``."""
    from pgcomm import experiment
    from pgcomm.data import coil_set_data_from_runs
    from pgcomm.settings import ExperimentConfig
    from pgcomm.setup import build_setup, simulated_mass

    setup, _ = simulated_mass(build_setup(ExperimentConfig()))
    runs = experiment.generate(setup, experiment.data_generation_reference(setup), setup.motor.k, setup.motor.zeta,
                               seed=seed)
    return coil_set_data_from_runs(runs), setup.motor.pole_pitch, setup.config.identification.options()


def compute(seeds, starts: int) -> dict:
    """The reference optimum per seed and coil set: ``{seed: [{"cost_pgnn", "stop_reason", ...}, ...]}``."""
    from pgcomm.identify import identify
    from pgcomm.seeds import stream_seed

    out = {}
    for seed in seeds:
        data, pole_pitch, opts = twin_data(seed)
        o = replace(opts, starts=starts, screen_iterations=400, refine_starts=4, max_iterations=2000,
                    decrease_tol=1e-6)
        rows = []
        for l, d in enumerate(data):
            t0 = time.perf_counter()
            # another stream than the run's own starts: the reference does not reuse the starts it judges
            r = identify(d, pole_pitch, o, seed=stream_seed(seed, "reference-optimum", l))
            rows.append({"coil_set": l + 1, "cost_pgnn": r.cost_pgnn, "cost_pgnn_validation": r.cost_pgnn_validation,
                         "stop_reason": r.stop_reason, "iterations": r.iterations,
                         "seconds": time.perf_counter() - t0})
            print(f"seed {seed} coil set {l + 1}: V = {r.cost_pgnn:.5f} (validation {r.cost_pgnn_validation:.4f}), "
                  f"{r.stop_reason}, {r.iterations} iterations, {rows[-1]['seconds']:.0f} s", flush=True)
        out[str(seed)] = rows
    return out


def check(paths) -> int:
    """Print each run's ``cost_pgnn`` per coil set against the stored optimum of its seed; 1 if one is missing."""
    store = json.loads(STORE.read_text()) if STORE.exists() else {}
    missing = 0
    for p in paths:
        res = json.loads(Path(p).read_text())
        ref = store.get(str(res["seed"]))
        if ref is None:
            print(f"{p}: no reference optimum stored for seed {res['seed']}: run --seeds {res['seed']}")
            missing = 1
            continue
        for c, r in zip(res["identification"]["coil_sets"], ref):
            v, v_ref = c["cost_pgnn"], r["cost_pgnn"]
            print(f"{p}: seed {res['seed']} coil set {r['coil_set']}: V = {v:.5f}, reference {v_ref:.5f}: "
                  f"{100 * (v / v_ref - 1):+.2f} %, {'converged' if c.get('converged') else 'NOT converged'} "
                  f"({c['stop_reason']}, {c['iterations']} iterations)")
    return missing


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=[], help="compute and store these seeds' optima")
    ap.add_argument("--starts", type=int, default=32, help="random starts of the reference (default 32)")
    ap.add_argument("--check", nargs="*", default=[], help="results.json files of reproduce runs to compare")
    args = ap.parse_args()
    if args.seeds:
        store = json.loads(STORE.read_text()) if STORE.exists() else {}
        store.update(compute(args.seeds, args.starts))
        STORE.write_text(json.dumps(dict(sorted(store.items())), indent=1) + "\n")
        print(f"stored in {STORE}")
    return check(args.check) if args.check else 0


if __name__ == "__main__":
    sys.exit(main())
