"""Wall time of ``pgcomm reproduce --quick`` in fresh processes (target: under 30 s on 2 cores, second run).

Runs ``python -m pgcomm reproduce --quick --out DIR`` twice as subprocesses (the first run fills
JAX's persistent compilation cache in ``~/.cache/pgcomm/jax``, see
:func:`pgcomm.cli.compile_cache_dir`; the second loads the compiled programs) and prints the wall
time and the stage times of each. ``--cold`` empties the cache first (a first run on a new machine).
``--full RESULTS.json`` compares the quick numbers with a full run's ``results.json``.

What ``--quick`` cuts (:func:`pgcomm.reproduce.quick_config`): two reference velocities instead
of three (0.075, 0.15 m/s) with 0.2 s dwells instead of 0.5 s, so the data sets are ~9 400
instead of ~18 000 samples per coil set; 2 random starts instead of 8 and at most 25 LM
iterations instead of 100; 2 feedforward passes instead of 3. The full ``reproduce`` is
unchanged.

What it costs: ``--full`` prints the quick run's figures beside the full run's. The rows are evaluated on
each run's own references, and quick has no slow 0.025 m/s reference, so the numbers compare what a
first look tells, not the same experiment. The compilation cache changes no number: the compiled code
is the same. With a warm cache, what is left is JAX tracing/lowering (not cached), imports and
matplotlib. The figures: docs/validation.md.

Usage::

    python bench/bench_quick.py [--cold] [--full out/results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def run_quick(out: Path) -> tuple[float, list[tuple[str, float]]]:
    """Wall time (s) of one ``pgcomm reproduce --quick`` in a fresh process, and its stage times."""
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "pgcomm", "reproduce", "--quick", "--out", str(out)],
                       env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"pgcomm reproduce --quick failed ({p.returncode}):\n{p.stderr}")
    stages, name = [], None
    for line in (p.stdout + p.stderr).splitlines():
        m = re.match(r"\[\d+\] (.*?) \.\.\.", line)
        if m:
            name = m.group(1)[:60]
        m = re.match(r"\s+done in ([0-9.]+) s", line)
        if m and name:
            stages.append((name, float(m.group(1))))
    return wall, stages


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cold", action="store_true", help="empty the compilation cache before the first run")
    ap.add_argument("--full", type=Path, help="results.json of a full `pgcomm reproduce` to compare with")
    args = ap.parse_args()
    sys.path.insert(0, str(SRC))
    from pgcomm.cli import compile_cache_dir

    cache = compile_cache_dir()
    if args.cold and cache:
        shutil.rmtree(cache, ignore_errors=True)
    with tempfile.TemporaryDirectory() as d:
        for i in (1, 2):
            out = Path(d) / f"q{i}"
            wall, stages = run_quick(out)
            print(f"run {i}: {wall:.1f} s wall (cache {cache})")
            for name, s in stages:
                print(f"    {s:6.1f} s  {name}")
        quick = json.loads((out / "results.json").read_text())
    if args.full:
        full = json.loads(args.full.read_text())
        print(f"{'row':18s} {'dir':3s} {'quick':>10s} {'full':>10s}  (filtered commutation MSE)")
        for row in ("classical", "pgnn", "oracle"):
            for d in "yxz":
                q = quick["commutation_mse"][row][d]["filtered"]
                f = full["commutation_mse"][row][d]["filtered"]
                print(f"{row:18s} {d:3s} {q:10.4g} {f:10.4g}")
        kq, kf = quick["calibration"]["calibrated"]["k"], full["calibration"]["calibrated"]["k"]
        print("calibrated k quick/full - 1:", ", ".join(f"{a / b - 1:+.2%}" for a, b in zip(kq, kf)))


if __name__ == "__main__":
    main()
