"""Progress display on stderr for long commands (stages with timings; silent when disabled)."""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager


class Progress:
    """Prints ``[stage n] message ... done (x.x s)`` lines to ``stream`` (stderr by default).

    Args:
        enabled: ``False`` makes every call a no-op (``--quiet``, library use).
    """

    def __init__(self, enabled: bool = True, stream=None):
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.n = 0
        self.t0 = time.perf_counter()

    def info(self, msg: str) -> None:
        """One line of information, indented under the current stage."""
        if self.enabled:
            print(f"    {msg}", file=self.stream, flush=True)

    @contextmanager
    def stage(self, msg: str):
        """Context manager around one stage; prints its start and its duration."""
        self.n += 1
        t = time.perf_counter()
        if self.enabled:
            print(f"[{self.n}] {msg} ...", file=self.stream, flush=True)
        yield self
        if self.enabled:
            print(f"    done in {time.perf_counter() - t:.1f} s", file=self.stream, flush=True)

    def elapsed(self) -> float:
        """Seconds since construction."""
        return time.perf_counter() - self.t0
