"""Handing memory back between the steps of a long run: JAX's compiled programs and the freed heap.

JAX keeps every program it has traced and compiled for the life of the process, and glibc keeps
freed heap for reuse. A run whose steps each compile their own programs (``pgcomm reproduce``:
data generation, identification, feedforward passes, the closed-loop evaluation of every law)
therefore grows step after step: ``reproduce --quick`` reached 1.55 GiB, of which about half were
programs of finished steps. Releasing them at each step boundary kept it at 0.74 GiB in the same
time on 2 cores. A program needed again is compiled again, or loaded from JAX's persistent
compilation cache when one is enabled (the command line enables it: :func:`pgcomm.cli.compile_cache_dir`);
the compiled code, and so every number, is the same.
"""

from __future__ import annotations

import gc
import ctypes
import sys

__all__ = ["release_compiled_programs", "trim_heap"]


def trim_heap() -> None:
    """Hand the heap the process has freed back to the system (glibc only; elsewhere nothing happens)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc: the heap stays with the process
        pass


def release_compiled_programs() -> None:
    """Drop JAX's in-memory caches of traced and compiled programs, collect garbage and trim the heap.

    Call between independent steps of a run, never inside a loop that reuses a program (it would be
    compiled again on every pass).
    """
    jax = sys.modules.get("jax")  # not loaded: no programs to drop (and no reason to load it)
    if jax is not None:
        jax.clear_caches()
    gc.collect()
    trim_heap()
