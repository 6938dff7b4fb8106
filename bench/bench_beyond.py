"""Benchmark of the extensions beyond the paper: the y identification cost with and without the direction term
(against the paper's 3.52 / 1.20 N²) and the exported C law's cost per call with the new terms.

1. Identification: the paper's data sets ``Z_{1,2}^1`` of coil set 1 on the default twin
   (drive at ``k̂ = 67``, ``ζ̂ = -0.52``, as ``pgcomm reproduce``), the paper's PGNN
   (widths 2/16, ``Λ = 0.1 I``, 8 starts) and the PGNN with the direction term (and with
   the 5th/7th harmonics as well), warm-started from it; printed: the y cost
   ``mean (Fy - F̂y)²`` on the training data (N²), the identified ``C_y`` and the wall time.
2. C law: the paper-size model of ``bench/bench_export.py`` with a direction term and the
   harmonics, exported in double, timed with the same harness (fastest block of 10^4 calls)
   against the plain law; the law is called through a one-line wrapper in the harness's
   translation unit that passes the velocity.

3. Without a force sensor: ``pgcomm reproduce`` (``--quick`` settings unless ``--full``) on the
   default twin; printed: the filtered y commutation MSE of classical, pgnn, pgnn_sensorless, the
   two anti-cogging tables and the oracle, the sensorless/force-sensor improvement ratio
   ``(classical - pgnn_sensorless) / (classical - pgnn)`` (target >= 0.8), each row's MSE
   with the plant's direction-dependent force taken out of the error (known on the twin only: no
   sensorless law can tell it from friction), and the identification times (s) with and without a
   force sensor.

Usage::

    /work/venv/bin/python bench/bench_beyond.py [--samples 1000000] [--repeats 5] [--skip-identification]
        [--skip-sensorless] [--full]
"""

from __future__ import annotations

import argparse
import dataclasses
import shutil
import sys
import tempfile
import time
from pathlib import Path

import jax.numpy as jnp
import numpy as np

import pgcomm  # noqa: F401  (x64)
from pgcomm.export.c import CLawOptions, write_c

sys.path.insert(0, str(Path(__file__).parent))
from bench_export import _compile_and_run, paper_size_model  # noqa: E402

WRAPPER = """#include "law.h"
int law_call(double y, const double f[3], double cur[LAW_L][2]);
int law_call(double y, const double f[3], double cur[LAW_L][2]) { return law_currents(y, 0.01 * f[1], f, cur); }
"""
DECL = """#define LAW_L 3
int law_call(double y, const double f[3], double cur[LAW_L][2]);
"""


def bench_identification() -> None:
    from pgcomm import experiment
    from pgcomm.data import coil_set_data_from_runs
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig
    from pgcomm.identify import IdentifyOptions, identify

    setup = build_setup(ExperimentConfig())
    ref = experiment.data_generation_reference(setup)
    data = coil_set_data_from_runs(experiment.generate(setup, ref, setup.motor.k, setup.motor.zeta, seed=0,
                                                       coil_sets=[0]))[0]
    t0 = time.perf_counter()
    plain = identify(data, setup.motor.pole_pitch, IdentifyOptions(tol=1e-9), seed=0)
    t_plain = time.perf_counter() - t0
    print("coil set 1, default twin, training data: y cost mean (Fy - Fy_hat)^2 (N^2)")
    print(f"  {'model':34s} {'cost_y':>8s} {'paper':>6s} {'C_y (N)':>8s} {'s':>6s}")
    print(f"  {'paper PGNN':34s} {plain.cost_y:8.3f} {3.52:6.2f} {'-':>8s} {t_plain:6.1f}")
    for name, harm in (("PGNN + direction term", False), ("PGNN + direction + 5th/7th", True)):
        t0 = time.perf_counter()
        r = identify(data, setup.motor.pole_pitch, IdentifyOptions(tol=1e-9, starts=1, direction=True, harmonics=harm),
                     seed=0, start_from=plain.model)
        print(f"  {name:34s} {r.cost_y:8.3f} {1.20:6.2f} {float(r.model.C[0]):8.3f} {time.perf_counter() - t0:6.1f}")
    noise = setup.config.sensors.force_noise[0]
    print(f"  (force-sensor noise alone: {noise ** 2:.3f} N^2)")


def bench_c(cc, n, reps) -> None:
    base = paper_size_model()
    rng = np.random.default_rng(0)
    L = base.n_coil_sets
    ext = dataclasses.replace(base, H=jnp.asarray(rng.normal(size=(L, 4, 3, 2)) * 0.3),
                              C=jnp.asarray(np.tile([3.0, 0.1, 0.2], (L, 1))))
    rows = []
    with tempfile.TemporaryDirectory(prefix="pgcomm_bench_") as tmp:
        d = Path(tmp) / "plain"
        write_c(base, d, CLawOptions("law"))
        rows.append(("paper PGNN law", *_compile_and_run(cc, d, "law.h", [str(d / "law.c")], "law_currents",
                                                         "double", n, reps)))
        d = Path(tmp) / "ext"
        write_c(ext, d, CLawOptions("law"))
        (d / "wrap.c").write_text(WRAPPER)
        (d / "decl.h").write_text(DECL)
        rows.append(("+ direction term + 5th/7th harmonics",
                     *_compile_and_run(cc, d, "decl.h", [str(d / "wrap.c"), str(d / "law.c")], "law_call",
                                       "double", n, reps)))
    print(f"C law, double, L = 3, widths 2 / 16; {n} samples x {reps} passes")
    print(f"  {'law':40s} {'best ns':>9s} {'mean ns':>9s}")
    for name, best, mean in rows:
        print(f"  {name:40s} {best:9.1f} {mean:9.1f}")


def bench_sensorless(full: bool) -> None:
    from pgcomm import reproduce
    from pgcomm.setup import build_setup
    from pgcomm.settings import ExperimentConfig
    cfg = ExperimentConfig() if full else reproduce.quick_config(ExperimentConfig())
    setup = build_setup(cfg)
    t0 = time.perf_counter()
    res = reproduce.run(setup, seed=0)
    wall = time.perf_counter() - t0
    d = res.to_dict()
    cm = d["commutation_mse"]
    print(f"\nwithout a force sensor, default twin ({'full' if full else 'quick'} settings, reproduce {wall:.0f} s)")
    print(f"  {'row':26s} {'y MSE [N^2]':>12s} {'y MSE without the direction force':>34s}")
    rest = d["sensorless"]["y_mse_without_direction_force"]
    for row in ("classical", "pgnn", "pgnn_sensorless", "cogging_table", "cogging_table_sensorless", "oracle"):
        # only for rows that leave the direction force alone (the others compensate some or all of it)
        rest_s = f"{rest[row]:34.4g}" if row in ("classical", "pgnn_sensorless", "cogging_table",
                                                 "cogging_table_sensorless") else f"{'-':>34s}"
        print(f"  {row:26s} {cm[row]['y']['filtered']:12.4g} {rest_s}")
    sl = d["sensorless"]
    print(f"  sensorless / force-sensor improvement (classical -> row): {sl['share_of_pgnn_reduction_y']:.3f} "
          "(target >= 0.8)")
    t_force = d["identification"]["seconds_total"]
    t_sl = sum(c["seconds"] for c in sl["coil_sets"])
    print(f"  identification: force sensor {t_force:.1f} s, sensorless {t_sl:.1f} s (ratio {t_sl / t_force:.2f})")
    print(f"  sensorless calibration error k: {np.round(100 * np.asarray(sl['calibration']['error']['k_relative']), 3)} %,"
          f" zeta: {np.round(1e3 * np.asarray(sl['calibration']['error']['zeta_rad']), 3)} mrad")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--samples", type=int, default=1_000_000)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--cc", default=shutil.which("cc") or shutil.which("gcc") or "cc")
    p.add_argument("--skip-identification", action="store_true")
    p.add_argument("--skip-sensorless", action="store_true")
    p.add_argument("--full", action="store_true", help="full reproduce settings for the sensorless rows")
    args = p.parse_args(argv)
    bench_c(args.cc, args.samples, args.repeats)
    if not args.skip_identification:
        bench_identification()
    if not args.skip_sensorless:
        bench_sensorless(args.full)
    return 0


if __name__ == "__main__":
    sys.exit(main())
