"""Interrupt ``pgcomm reproduce --quick`` at random moments: every run must exit 130 (SIGINT) or 143 (SIGTERM)
with one line, no traceback, and no ``--out`` or staging folder left (a crash in XLA's teardown can
turn 130 into -11).

    python bench/interrupts.py [--runs 20] [--seed 0] [--max-delay 20]

Prints one line per run and the tally; exit status 1 if any run misbehaved.
"""

from __future__ import annotations

import argparse
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def one(delay: float, sig: int, root: Path) -> tuple[bool, str]:
    out = root / "D"
    p = subprocess.Popen([sys.executable, "-m", "pgcomm", "reproduce", "--quick", "--out", str(out), "--quiet"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(delay)
    finished_before = p.poll() is not None
    p.send_signal(sig)
    _, err = p.communicate(timeout=300)
    if finished_before:
        return True, f"finished before the signal (exit {p.returncode})"
    want = 128 + int(sig)
    left = [q.name for q in root.iterdir()]
    ok = p.returncode == want and "Traceback" not in err and not left
    return ok, f"exit {p.returncode} (want {want}), left {left or 'nothing'}, stderr: {' | '.join(err.split(chr(10)))[:160]}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-delay", type=float, default=20.0, help="latest moment of the signal (s)")
    args = ap.parse_args()
    rnd = random.Random(args.seed)
    bad = 0
    for k in range(args.runs):
        delay = rnd.uniform(0.2, args.max_delay)
        sig = rnd.choice((signal.SIGINT, signal.SIGTERM))
        with tempfile.TemporaryDirectory() as d:
            ok, what = one(delay, sig, Path(d))
        bad += not ok
        print(f"run {k + 1:2d}: {signal.Signals(sig).name} after {delay:5.2f} s: {'ok ' if ok else 'BAD'} {what}",
              flush=True)
    print(f"{args.runs - bad} of {args.runs} runs ok")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
