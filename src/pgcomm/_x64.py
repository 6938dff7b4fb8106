"""JAX in float64 (DESIGN.md: numerics in float64), imported by every module that computes with JAX.

Each such module imports this one before JAX, so importing any part of the library that makes
arrays turns x64 on first; importing :mod:`pgcomm` itself (the command line's front door) does not
load JAX at all, so ``pgcomm --help`` stays fast. The platform and the BLAS threads are the host
program's choice: the command line sets them (:mod:`pgcomm.cli`), the library does not.

It also asks XLA's CPU compiler to compile a loop whose one pass moves less than
:data:`SMALL_LOOP_BYTES` of memory as one function (``xla_cpu_small_while_loop_byte_threshold``,
default 1 KiB). The closed-loop simulation's step moves 2-10 KB per controller sample (law, plant,
controller, mechanics); run the other way, XLA calls one kernel per fused operation of the step,
31 of them for the PGNN law, and those calls cost twice the arithmetic (0.3 against 0.9 M samples/s
on one core). Only such small loops are affected, and their results agree with the other way to
rounding. XLA reads the option once, when the JAX backend starts: a program that ran JAX before
importing pgcomm's computing modules, or that set ``xla_backend_extra_options`` in ``XLA_FLAGS``
itself, keeps its own setting (the simulation is then slower, not different).
"""

import os

#: Largest memory traffic of one loop pass (bytes) for which XLA compiles the whole loop as one function.
SMALL_LOOP_BYTES = 1 << 20


def _compile_small_loops_whole() -> None:
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_backend_extra_options" in flags:  # the host program's own choice
        return
    os.environ["XLA_FLAGS"] = (
        f"{flags} --xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold={SMALL_LOOP_BYTES}".strip())


_compile_small_loops_whole()

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
