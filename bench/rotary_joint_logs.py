"""Identification from logs that were not planned for pgcomm, on rotary zoo motors with a real drive's habits: what a
robot joint's drive records in its own speed loop.

Each zoo motor (``pgcomm zoo --kind rotary --real-drive``: a filtered current report, a PLL angle on some drives, the
current sensors' errors, a host's jittered clock with gaps and stamp noise) turns in one direction at a speed of its
own (``--speed``, default 5 rad/s, after a 0.5 s ramp from standstill), without a dither, for ``--seconds``, polled by a
host about every ``--step`` (default 2.3 ms, steps of 0.6-2.6 times it). The log is written as such a host writes it:
a CSV of its stamp, the position in revolutions and the q-current, nothing else (no d-current, no voltage). The motor
TOML has the pole pairs, ``k_t``, the current limit and the median step; the slots are left out unless ``--slots``.

Per motor, ``pgcomm identify`` runs as a user would (a subprocess, the CSV with its column map), and the bench prints
its exit and, where it wrote a table, the table's correlation with the drive's map (the true compensation at zero
demand, forward and reverse averaged: what a standstill calibration converges to) and with the map of the log's own
direction (a one-direction log carries that direction's friction), the RMS difference as a share of the map's RMS
beside the cogging's verdict (what the user is told of it), and the drives' own way from the same log: the logged current binned over the angle (512 bins). The bar for a real
joint's logs is a correlation of 0.97 with its drive's map. Each line also gives the report filter and ``J/k0`` the
identification read, the latter as a share of the truth's: at one speed the table is the current read back through the
filter, less the inertia torque of the speed's ripple, and at each order any filter and any ``J/k0`` explain a steady
log's angle-periodic content equally well (only its speed changes and its noise tell them apart), so where the filter
holds back the cogging's orders or a soft speed loop lets the cogging move the rotor (binning far below the table),
these readings are what the table rests on.

Usage: ``python bench/rotary_joint_logs.py [--seed 0] [--motors 0,1,2,3,4,5,6,7] [--speed 5] [--seconds 20]
[--step 0.0023] [--slots]``. About 10-40 s per motor on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

import numpy as np  # noqa: E402

BINS = 512
#: The bar for a real joint's logs: the table's correlation with its drive's map.
BAR = 0.97


def compare(table: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """Correlation and RMS difference (offsets removed, share of the reference's RMS) of two maps on one grid."""
    a, b = table - table.mean(), reference - reference.mean()
    return float(np.corrcoef(a, b)[0, 1]), float(np.sqrt(np.mean((a - b) ** 2) / np.mean(b ** 2)))


def binned(theta: np.ndarray, iq: np.ndarray, bins: int = BINS) -> np.ndarray:
    """The logged current averaged in ``bins`` bins of the angle (empty bins from their neighbours, circularly)."""
    idx = np.floor(np.mod(theta, 2 * math.pi) / (2 * math.pi) * bins).astype(int) % bins
    n = np.bincount(idx, None, bins)
    out = np.where(n > 0, np.bincount(idx, iq, bins) / np.maximum(n, 1), np.nan)
    good = ~np.isnan(out)
    grid = 2 * math.pi * np.arange(bins) / bins
    return np.interp(grid, grid[good], out[good], period=2 * math.pi) if not good.all() else out


def one_motor(seed: int, idx: int, args, tmp: Path) -> tuple[str, float | None]:
    """One motor's line and its table's correlation with the drive's map (``None`` where identify exited non-zero)."""
    from pgcomm.io.rotary_zoo import write_host_log
    from pgcomm.rotary.experiment import polled_by_host, speed_loop_log
    from pgcomm.rotary.zoo import draw_rotary
    truth = polled_by_host(draw_rotary(seed, idx, real_drive=True), args.step)
    m = truth.motor
    log = speed_loop_log(truth, args.speed, args.seconds, seed=1000 * seed + idx)
    d = write_host_log(truth, tmp / f"{seed}_{idx}", log, slots=args.slots)
    cmd = [sys.executable, "-m", "pgcomm", "identify", "--motor", str(d / "motor.toml"), "--columns",
           str(d / "columns.toml"), "--data", str(d / "log.csv"), "--out", str(d / "out"), "--quiet"]
    t0 = time.perf_counter()
    run = subprocess.run(cmd, capture_output=True, text=True)
    secs = time.perf_counter() - t0
    habits = (f"filter {1e3 * truth.report_filter:.1f} ms, PLL {truth.pll_bandwidth:.0f} rad/s"
              if truth.pll_bandwidth else f"filter {1e3 * truth.report_filter:.1f} ms, no PLL")
    head = f"{seed}:{idx} {m.name:8s} ({habits})"
    b_corr, _ = compare(binned(log["theta"], log["iq_1"]), truth.model().table(BINS))
    if run.returncode != 0:
        return (f"{head}: exit {run.returncode} ({secs:.0f} s): {run.stderr.strip().splitlines()[-1]}; binning "
                f"{b_corr:.3f}"), None
    lines = [ln for ln in (d / "out" / "compensation.csv").read_text().splitlines() if not ln.startswith("#")]
    table = np.loadtxt(lines[1:], delimiter=",")[:, 1]
    corr, rms = compare(table, truth.model().table(table.size))
    corr_dir, _ = compare(table, truth.model().table(table.size, math.copysign(1.0, args.speed)))
    ident = json.loads((d / "out" / "results.json").read_text())["identification"]
    cut = ident.get("orders_not_resolved")
    se = ident["standard_error"]["cogging"]
    verdict = f"{'resolved' if se['resolved'] else 'NOT resolved'}, se {100 * se['relative']:.1f} %" + (
        f", the encoder's rounding {100 * se['quantisation_bias']:.0f} %" if se.get("quantisation_bias", 0) > 0.05 else "")
    return (f"{head}: correlation {corr:.4f} (its direction's map {corr_dir:.4f}), RMS difference {100 * rms:.0f} % "
            f"({verdict}), binning {b_corr:.3f}; read: filter {1e3 * ident['current_filter']['tau_s']:.1f} ms, J/k0 "
            f"{ident['inertia_ratio'] / (truth.inertia / truth.k0):.2f} of the truth's; orders to {ident['highest_order']}" + (f" (cut from {max(cut['orders'])})" if cut else "")
            + f" ({secs:.0f} s)"), corr


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--motors", default="0,1,2,3,4,5,6,7", help="zoo indices, comma-separated")
    ap.add_argument("--speed", type=float, default=5.0, help="rad/s, its sign the direction")
    ap.add_argument("--seconds", type=float, default=20.0, help="at speed, after the ramp")
    ap.add_argument("--step", type=float, default=0.0023, help="the host's median step (s)")
    ap.add_argument("--slots", action="store_true", help="give the slot count in the motor TOML")
    args = ap.parse_args(argv)
    print(f"one-direction speed-loop logs at {args.speed:g} rad/s for {args.seconds:g} s, a host polling about every "
          f"{1e3 * args.step:g} ms; slots {'given' if args.slots else 'left out'}", flush=True)
    good = done = 0
    with tempfile.TemporaryDirectory() as tmp:
        for idx in (int(x) for x in args.motors.split(",")):
            line, corr = one_motor(args.seed, idx, args, Path(tmp))
            done += 1
            good += corr is not None and corr >= BAR
            print(line, flush=True)
    print(f"{good} of {done} motors at a correlation of {BAR} or more")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
