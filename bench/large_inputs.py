"""Large and hostile inputs: peak memory and time of the command line on each, against its target.

Usage: ``python bench/large_inputs.py [--rows 5000000] [--only evaluate,hdf5,header] [--keep DIR]``.

Builds the inputs in a temporary folder (or ``--keep DIR``), runs each command as a child process
(``python -m pgcomm ...``) and reads the child's peak resident memory from the kernel
(``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` of a fresh process per case) and its wall time:

* ``evaluate``: ``pgcomm evaluate --data log.csv --model model.json`` on a log of ``--rows`` rows
  (three coil sets: ``t, y, r``, the force, the desired force and the currents, 15 columns) and a PGNN
  of the default structure; target ≤ 1.5 GB. Also without ``--model`` (no target, for comparison).
* ``hdf5``: an 8 MB HDF5 file declaring 15 datasets of 2 GiB each (the first 512 KiB of each written):
  ``pgcomm evaluate --data lying.h5`` must refuse it (exit 2) in ≤ 2 s at ≤ 200 MB.
* ``header``: a CSV whose header names 300 000 columns: refused (exit 2) in ≤ 5 s.

Each line prints the figure, its target and whether it is met. The machine may be shared: the
times are wall-clock times of one run, printed beside the CPU seconds the command used.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GB = 1e9


def run_child(argv: list[str]) -> tuple[int, float, float, float, str]:
    """Run ``python -m pgcomm argv`` in a fresh process: ``(exit code, seconds, CPU seconds, peak RSS in bytes,
    stderr)``.

    The peak is the child's ``ru_maxrss``, read by a small wrapper process so that each case has its own
    (``RUSAGE_CHILDREN`` of one process holds the largest child it ever waited for). The CPU seconds (user and
    system) tell a slow machine from a slow command where the machine is shared.
    """
    wrapper = ("import resource, subprocess, sys, time\n"
               "t = time.perf_counter()\n"
               "p = subprocess.run([sys.executable, '-m', 'pgcomm'] + sys.argv[1:], capture_output=True, text=True)\n"
               "dt = time.perf_counter() - t\n"
               "r = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
               "sys.stderr.write(p.stderr)\n"
               "print(p.returncode, dt, r.ru_utime + r.ru_stime, r.ru_maxrss * 1024)\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-c", wrapper, *argv], capture_output=True, text=True, env=env)
    code, dt, cpu, peak = p.stdout.split()[-4:]
    return int(code), float(dt), float(cpu), float(peak), p.stderr


def build_log(path: Path, rows: int, model) -> None:
    """A log of ``rows`` rows at 1 kHz: back-and-forth moves, currents of a PI-like loop, the model's force plus noise.

    Written block by block (200 000 rows at a time) so that building it needs little memory.
    """
    import numpy as np
    import pyarrow as pa
    import pyarrow.csv as pacsv

    rng = np.random.default_rng(0)
    names = ["t", "y", "r", "Fy", "Fx", "Tz", "Fy_star", "Fx_star", "Tz_star"] + [
        f"{c}_{l}" for l in (1, 2, 3) for c in ("ia", "ib")]
    block = 200_000
    with pa.OSFile(str(path), "wb") as sink:
        sink.write((",".join(names) + "\n").encode())
        for start in range(0, rows, block):
            n = min(block, rows - start)
            t = (start + np.arange(n)) * 1e-3
            r = 0.1 * np.sin(2 * np.pi * 0.2 * t)
            y = r + 1e-5 * rng.standard_normal(n)
            cur = 3.0 * rng.standard_normal((n, 3, 2))
            f = np.asarray(model.force(y, cur)) + rng.standard_normal((n, 3)) * [0.5, 0.5, 0.05]
            f_star = f + rng.standard_normal((n, 3)) * [2.0, 2.0, 0.2]
            cols = [t, y, r, *f.T, *f_star.T] + [cur[:, l, j] for l in range(3) for j in range(2)]
            pacsv.write_csv(pa.table(dict(zip(names, cols))), sink,
                            write_options=pacsv.WriteOptions(include_header=False))


def build_model(path: Path):
    """A PGNN of the default structure (gain widths 2, cogging 16, three coil sets) with random weights."""
    import jax
    import numpy as np

    from pgcomm.io.model import save_model
    from pgcomm.models import CoilSetModel, CombinedModel, physics_from_ideal

    rng = np.random.default_rng(0)
    sets = []
    for l in range(3):
        a, b = physics_from_ideal(0.03, 61.0 + l, -0.54, 0.05, 0.07 * (l - 1))
        m = CoilSetModel.init(jax.random.PRNGKey(l), CoilSetModel.physics(a, b, 0.03, 0.0, 0.1, -0.11, 0.11), (2,), (16,),
                              "tanh")
        leaves, tree = jax.tree_util.tree_flatten(m)
        sets.append(jax.tree_util.tree_unflatten(tree, [np.asarray(x) + 0.1 * rng.normal(size=np.shape(x))
                                                        for x in leaves]))
    model = CombinedModel.from_coil_sets(sets)
    save_model(path, model, {"seed": 0})
    return model


def build_lying_hdf5(path: Path) -> None:
    """15 log-column datasets declaring 2**28 float64 values (2 GiB) each, chunked, only the first chunk written."""
    import h5py
    import numpy as np

    names = ["t", "y", "r", "Fy", "Fx", "Tz", "Fy_star", "Fx_star", "Tz_star", "ia_1", "ib_1", "ia_2", "ib_2",
             "ia_3", "ib_3"]
    with h5py.File(path, "w") as f:
        for name in names:
            d = f.create_dataset(name, shape=(2**28,), dtype="f8", chunks=(65536,))
            d[:65536] = np.random.default_rng(0).standard_normal(65536)


def build_wide_header(path: Path, columns: int = 300_000) -> None:
    """A CSV whose header names ``columns`` columns (the log's own first), with two data rows."""
    names = ["t", "y", "Fy", "Fx", "Tz", "ia_1", "ib_1"] + [f"signal_{j}" for j in range(columns - 7)]
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for i in range(2):
            f.write(",".join([repr(i * 1e-3)] + ["0.5"] * (columns - 1)) + "\n")


def report(name: str, code: int, seconds: float, cpu: float, peak: float, err: str, max_s=None, max_gb=None,
           expect_code: int = 0) -> None:
    ok = code == expect_code and (max_s is None or seconds <= max_s) and (max_gb is None or peak <= max_gb * GB)
    target = ", ".join(x for x in (f"≤ {max_s:g} s" if max_s else "", f"≤ {max_gb:g} GB" if max_gb else "",
                                   f"exit {expect_code}") if x)
    print(f"{name:44s} exit {code}  {seconds:7.2f} s ({cpu:6.2f} s CPU)  peak {peak / GB:6.3f} GB   target "
          f"{target}: {'met' if ok else 'MISSED'}")
    if code != expect_code:
        print("    " + (err.strip().splitlines() or [""])[-1])
    elif code == 2:
        print("    " + err.strip().splitlines()[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=5_000_000, help="rows of the evaluate log (default 5 000 000)")
    ap.add_argument("--only", default="evaluate,hdf5,header", help="cases to run (comma-separated)")
    ap.add_argument("--keep", type=Path, help="build the inputs here and keep them (reused when present)")
    a = ap.parse_args()
    cases = set(a.only.split(","))
    root = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="pgcomm-bench-large-"))
    root.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    print(f"inputs in {root}; {os.cpu_count()} cores (possibly shared)")
    if "hdf5" in cases:
        h5 = root / "lying.h5"
        if not h5.exists():
            build_lying_hdf5(h5)
        print(f"lying.h5: {h5.stat().st_size / 1e6:.1f} MB declaring 15 x 2 GiB")
        out = root / "out_hdf5"
        res = run_child(["evaluate", "--data", str(h5), "--out", str(out), "--quiet"])
        report("evaluate, HDF5 declaring 30 GiB in 8 MB", *res, max_s=2.0, max_gb=0.2, expect_code=2)
        assert not out.exists() and not list(root.glob(".out_hdf5.*")), "output or staging folder left"
    if "header" in cases:
        wide = root / "wide.csv"
        if not wide.exists():
            build_wide_header(wide)
        res = run_child(["evaluate", "--data", str(wide), "--out", str(root / "out_header"), "--quiet"])
        report("evaluate, CSV header of 300 000 columns", *res, max_s=5.0, expect_code=2)
    if "evaluate" in cases:
        log, model_path = root / f"log_{a.rows}.csv", root / "model"
        t = time.perf_counter()
        model = build_model(model_path)
        if not log.exists():
            build_log(log, a.rows, model)
        print(f"{log.name}: {a.rows} rows, {log.stat().st_size / 1e9:.2f} GB ({time.perf_counter() - t:.0f} s to "
              "build or find)")
        for name, extra, max_gb in (("evaluate --model", ["--model", str(model_path) + ".json"], 1.5),
                                    ("evaluate (no model)", [], None)):
            out = root / ("out_" + name.split()[-1].strip("()-"))
            res = run_child(["evaluate", "--data", str(log), *extra, "--out", str(out), "--quiet", "--overwrite"])
            report(f"{name}, {a.rows} rows", *res, max_gb=max_gb)


if __name__ == "__main__":
    main()
