"""Identification from real drive logs, as recorded: the ODrive rig of ``../shared/real/odrive_cogging/``.

For each running log it runs ``pgcomm identify`` as a user would (the CSV as recorded, the column map
``bench/real_odrive/columns.toml``, the motor TOML ``bench/real_odrive/motor.toml``), and compares the
compensation table with the drive's own standstill map ``static_maps/map_a_16.csv`` (the holding current at
every 16th count, forward): their correlation and the RMS of their difference (offsets removed) as a share of
the map's RMS. Beside it, in the same run, the drives' own way: the logged current binned over the angle (512
bins, as the map). It also prints the report filter the identification found, and the verdicts of the maps the
logs do not determine. Then two logs identified together, as recorded and with the second re-indexed by half a
revolution (a power-up whose encoder index moved: :mod:`pgcomm.rotary.power_ups`).

The spin-up runs (``spinup/*.mat``, a MATLAB cell array per file, read here with SciPy in a few lines) give the
moment of inertia: per run a parabola through the angle over its first ``--spinup-window`` seconds (before the
drive's voltage limit caps the current at speed), the logged current read back through the report filter found
on the running logs, and ``k_t i = J θ̈ + c sign(θ̈)`` fitted over the runs that turn at least a revolution.

Usage: ``python bench/real_logs.py [--real ../shared/real/odrive_cogging] [--logs slow2_slower__nocomp_0,...]``.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pgcomm.rotary.static_map import index_offset

HERE = Path(__file__).resolve().parent
DEFAULT_REAL = HERE.parent.parent / "shared" / "real" / "odrive_cogging"
DEFAULT_LOGS = ("slow2_slower__nocomp_0", "slow2__nocomp_0", "slow2__nocomp_1", "slow2__nocomp_2",
                "slow_goodgains_2__nocomp_0", "slow2_slower__crosstalk_nocomp_0")
COUNTS = 8192


def read_map(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``(angle rad, holding current A)`` of a drive's static map (``count, Iq_A``)."""
    m = np.loadtxt(path, delimiter=",", skiprows=1)
    return 2 * np.pi * m[:, 0] / COUNTS, m[:, 1]


def compare(table: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """Correlation and RMS difference (offsets removed, share of the reference's RMS) of two maps on one grid."""
    a, b = table - table.mean(), reference - reference.mean()
    return float(np.corrcoef(a, b)[0, 1]), float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b ** 2)))


def binned(log: Path, angle: np.ndarray) -> np.ndarray:
    """The logged current averaged in bins of the map's spacing, bin ``k`` from the map's angle ``k`` to the next, as
    the rig's README bins it (empty bins: interpolated from their neighbours, circularly)."""
    d = np.genfromtxt(log, delimiter=",", names=True)
    th = np.mod(2 * np.pi * d["pos_estimate_counts"] / COUNTS, 2 * np.pi)
    step = angle[1] - angle[0]
    idx = np.floor(th / step).astype(int) % angle.size
    s = np.bincount(idx, d["Iq_measured_A"], angle.size)
    n = np.bincount(idx, None, angle.size)
    out = np.where(n > 0, s / np.maximum(n, 1), np.nan)
    if np.isnan(out).any():
        good = ~np.isnan(out)
        out = np.interp(angle, angle[good], out[good], period=2 * np.pi)
    return out


def identify(real: Path, name: str, out: Path, files=None) -> tuple[dict, np.ndarray, np.ndarray, float]:
    """``pgcomm identify`` on one log (or on ``files``); ``(results, table angle, table iq, seconds)``."""
    files = [real / "logs" / f"{name}.csv"] if files is None else files
    cmd = [sys.executable, "-m", "pgcomm", "identify", "--motor", str(HERE / "real_odrive" / "motor.toml"),
           "--columns", str(HERE / "real_odrive" / "columns.toml"), "--data", *map(str, files),
           "--out", str(out), "--quiet"]
    t0 = time.perf_counter()
    run = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if run.returncode != 0:
        raise SystemExit(f"{name}: pgcomm identify exited {run.returncode}: {run.stderr.strip().splitlines()[-1]}")
    lines = [ln for ln in (out / "compensation.csv").read_text().splitlines() if not ln.startswith("#")]
    table = np.loadtxt(lines[1:], delimiter=",")  # after the header line "angle,iq"
    return json.loads((out / "results.json").read_text()), table[:, 0], table[:, 1], seconds


def spinup_inertia(real: Path, k_t: float, tau: float, window: float) -> tuple[float, float, int]:
    """``(J kg·m², Coulomb N·m, runs)`` from the spin-up runs (module docstring)."""
    from scipy.io import loadmat

    rows, target = [], []
    for f in sorted(glob.glob(str(real / "spinup" / "spinup_*.mat"))):
        cells = loadmat(f)["data"]  # 4 x K cells: set current, t (s), position (counts), Iq (A)
        for j in range(cells.shape[1]):
            t = np.ravel(cells[1, j]).astype(float)
            if t.size < 50:
                continue
            t = t - t[0]
            pos = 2 * np.pi * np.ravel(cells[2, j]).astype(float) / COUNTS
            iq = np.ravel(cells[3, j]).astype(float)
            iq = iq + tau * np.gradient(iq, t)
            m = t <= window
            if abs(pos[m][-1] - pos[0]) < 2 * np.pi:
                continue  # the cogging averages out only over whole revolutions
            acc = 2 * np.polyfit(t[m], pos[m], 2)[0]
            rows.append([acc, np.sign(acc)])
            target.append(k_t * iq[m].mean())
    sol = np.linalg.lstsq(np.array(rows), np.array(target), rcond=None)[0]
    return float(sol[0]), float(sol[1]), len(target)


def two_power_ups(real: Path, tmp: Path, angle: np.ndarray, ref: np.ndarray) -> None:
    """Two logs of one power-up (0.1 and 0.03 rev/s), then the second as if recorded after a power-up whose index
    moved by half a revolution (its counts plus 4096): the tables against the map, and the offset identify found."""
    first, second = (real / "logs" / f"{n}.csv" for n in ("slow2__nocomp_0", "slow2_slower__nocomp_0"))
    lines = second.read_text().splitlines()
    moved = tmp / "slow2_slower__nocomp_0_reindexed.csv"
    rows = [ln.split(",") for ln in lines[1:]]
    moved.write_text("\n".join([lines[0], *(f"{t},{float(c) + COUNTS / 2:.3f},{i}" for t, c, i in rows)]) + "\n")
    for label, files in (("two logs, one power-up", [first, second]),
                         ("the second re-indexed by half a revolution", [first, moved])):
        res, a, iq, seconds = identify(real, "", tmp / label.replace(" ", "_"), files)
        corr, rms = compare(np.interp(angle, a, iq, period=2 * np.pi), ref)
        offs = res["identification"].get("index_offsets") or []
        said = ", ".join(f"{np.degrees(o['rad']):+.1f}°" for o in offs) or "none"
        print(f"{label:44s} corr {corr:.4f}, RMS diff {100 * rms:.1f} %, index offset found: {said} ({seconds:.1f} s)")
    print(f"  each: python -m pgcomm identify ... --data {first} SECOND.csv --out OUT")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real", type=Path, default=DEFAULT_REAL, help="the odrive_cogging folder")
    ap.add_argument("--logs", default=",".join(DEFAULT_LOGS), help="comma-separated log names (without .csv)")
    ap.add_argument("--map", default="map_a_16", help="the static map to compare with (static_maps/NAME.csv)")
    ap.add_argument("--spinup-window", type=float, default=0.3, help="seconds of each spin-up run fitted")
    args = ap.parse_args()
    if not args.real.is_dir():
        raise SystemExit(f"--real {args.real}: no such folder")
    angle, ref = read_map(args.real / "static_maps" / f"{args.map}.csv")
    print(f"reference: static_maps/{args.map}.csv ({ref.size} angles, RMS {ref.std():.3f} A)")
    print(f"{'log':36s} {'pgcomm corr':>11s} {'RMS diff':>9s} {'binned corr':>11s} {'RMS diff':>9s} "
          f"{'filter ms':>9s} {'cogging SE':>10s} {'s':>5s}  pinned")
    taus = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.logs.split(","):
            res, a, iq, seconds = identify(args.real, name, Path(tmp) / name)
            ours = compare(np.interp(angle, a, iq, period=2 * np.pi), ref)
            base = compare(binned(args.real / "logs" / f"{name}.csv", angle), ref)
            ident = res["identification"]
            tau = ident["current_filter"]["tau_s"]
            taus.append(tau)
            se = ident["standard_error"]["cogging"]["relative"]
            print(f"{name:36s} {ours[0]:11.4f} {100 * ours[1]:8.1f}% {base[0]:11.4f} {100 * base[1]:8.1f}% "
                  f"{1e3 * tau:9.1f} {100 * se:9.1f}% {seconds:5.1f}  {', '.join(ident.get('pinned', [])) or '-'}")
            # a log of another power-up: its table against the map with the index offset removed, as --sweep does
            off = index_offset(ref, np.interp(angle, a, iq, period=2 * np.pi), 2 * ident["highest_order"])
            if off["taken"]:
                print(f"{'':36s} {off['correlation']:11.4f} with the map's index moved by "
                      f"{np.degrees(off['rad']):+.1f}° (recorded in another power-up)")
        print(f"  each: python -m pgcomm identify --motor bench/real_odrive/motor.toml --columns "
              f"bench/real_odrive/columns.toml --data {args.real}/logs/NAME.csv --out OUT")
        print("  (crosstalk logs were taken with the neighbouring motor moved: another map, a lower correlation "
              "expected)")
        two_power_ups(args.real, Path(tmp), angle, ref)
    k_t = 8.27 / 150
    tau = float(np.median(taus))
    for window in sorted({args.spinup_window, 1.0}):
        j, c, n = spinup_inertia(args.real, k_t, tau, window)
        print(f"spin-up inertia over the first {window:g} s of {n} runs (report filter {1e3 * tau:.0f} ms): "
              f"J = {j:.3g} kg·m² ({100 * (j / 2.5e-4 - 1):+.0f} % against the author's 2.5e-4), "
              f"Coulomb {c:.3g} N·m")


if __name__ == "__main__":
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    main()
