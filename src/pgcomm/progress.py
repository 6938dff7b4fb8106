"""Progress display on stderr for long commands (stages with timings; silent when disabled)."""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager


class Progress:
    """Prints ``[stage n] message ... done (x.x s)`` lines to ``stream`` (stderr by default).

    Args:
        enabled: ``False`` makes every call print nothing (``--quiet``, library use).
        checkpoint: called (enabled or not) at every stage boundary and :meth:`info`; the
            command line passes a function that raises if a signal arrived whose exception
            was swallowed (a signal handler's exception raised inside a garbage-collector
            callback is only printed by Python), so an interrupt always stops the run.
        on_stage: called at the start of every stage (not at :meth:`info`, which loops call); the command
            line passes :func:`pgcomm._memory.release_compiled_programs`, so a command's finished stages
            do not keep their compiled programs while the next ones compile theirs.
    """

    def __init__(self, enabled: bool = True, stream=None, checkpoint=None, on_stage=None):
        self.enabled = enabled
        self._checkpoint = checkpoint
        self._on_stage = on_stage
        self.stream = stream or sys.stderr
        self.n = 0
        self.t0 = time.perf_counter()

    def info(self, msg: str) -> None:
        """One line of information, indented under the current stage."""
        self.checkpoint()
        if self.enabled:
            print(f"    {msg}", file=self.stream, flush=True)

    @property
    def releases(self) -> bool:
        """Whether a stage's start calls an ``on_stage`` hook (the command line's release of compiled programs)."""
        return self._on_stage is not None

    @contextmanager
    def stage(self, msg: str, release: bool = True):
        """Context manager around one stage; prints its start and its duration.

        ``release=False`` skips the ``on_stage`` hook: a stage that runs the programs of the stage before it again
        (the command line's hook drops every compiled program)."""
        self.checkpoint()
        if release and self._on_stage is not None:
            self._on_stage()
        self.n += 1
        t = time.perf_counter()
        if self.enabled:
            print(f"[{self.n}] {msg} ...", file=self.stream, flush=True)
        yield self
        self.checkpoint()
        if self.enabled:
            print(f"    done in {time.perf_counter() - t:.1f} s", file=self.stream, flush=True)

    def checkpoint(self) -> None:
        """Call the ``checkpoint`` hook, if any (may raise to stop the run)."""
        if self._checkpoint is not None:
            self._checkpoint()

    def elapsed(self) -> float:
        """Seconds since construction."""
        return time.perf_counter() - self.t0
