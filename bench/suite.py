"""Wall time and peak memory of the README's test command (targets: under 3 GB and under 8 min on a
2-core machine, idle).

    python bench/suite.py [--interval 0.2] [-- COMMAND ...]

Runs ``COMMAND`` (default ``python -m pytest -q``, the README's test command, from the repository root) and samples,
every ``--interval`` seconds, the summed resident set size of its whole process tree: the pytest-xdist workers,
the fleet test's Dask workers and every ``pgcomm`` subprocess a test starts. ``ps`` or ``/usr/bin/time`` report
one process; the suite's memory is the tree's. Prints the command's wall time, the peak (GiB, and as a share of
3 GB = 2.79 GiB), and the processes at the peak. Linux only (reads ``/proc``). Exit status: the command's.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

LIMIT_BYTES = 3e9  # the suite's memory target, 3 GB
PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


def _tree(root: int) -> list[tuple[int, int]]:
    """``(rss_bytes, pid)`` of ``root`` and all its descendants (a snapshot of ``/proc``)."""
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:  # the process ended between listdir and open
            continue
        pid = int(entry)
        children.setdefault(int(fields[1]), []).append(pid)
        rss[pid] = int(fields[21]) * PAGE  # field 24 of stat: resident pages
    out, stack = [], [root]
    while stack:
        pid = stack.pop()
        out.append((rss.get(pid, 0), pid))
        stack.extend(children.get(pid, []))
    return out


def _name(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ").strip()[:90]
    except OSError:
        return "?"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--interval", type=float, default=0.2, help="sampling period (s)")
    ap.add_argument("command", nargs="*", help="command to measure (after --); default: python -m pytest -q")
    args = ap.parse_args()
    command = args.command or [sys.executable, "-m", "pytest", "-q"]
    root = Path(__file__).resolve().parent.parent
    t0 = time.perf_counter()
    proc = subprocess.Popen(command, cwd=root)
    peak, at_peak = 0, []
    while proc.poll() is None:
        tree = _tree(proc.pid)
        total = sum(r for r, _ in tree)
        if total > peak:
            peak = total
            at_peak = [(r, p, _name(p)) for r, p in sorted(tree, reverse=True)[:6] if r > 0]
        time.sleep(args.interval)
    wall = time.perf_counter() - t0
    print(f"\n{' '.join(command)}: exit {proc.returncode}, wall {int(wall // 60)}:{wall % 60:02.0f}, "
          f"peak {peak / 2**30:.2f} GiB = {peak / LIMIT_BYTES:.0%} of 3 GB (process tree, sampled every "
          f"{args.interval:g} s)")
    for r, p, name in at_peak:
        print(f"  at the peak: {r / 2**20:6.0f} MiB  pid {p}  {name}")
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())
