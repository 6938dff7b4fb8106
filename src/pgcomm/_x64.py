"""JAX in float64 (DESIGN.md: numerics in float64), imported by every module that computes with JAX.

Each such module imports this one before JAX, so importing any part of the library that makes
arrays turns x64 on first; importing :mod:`pgcomm` itself (the command line's front door) does not
load JAX at all, so ``pgcomm --help`` stays fast. The platform and the BLAS threads are the host
program's choice: the command line sets them (:mod:`pgcomm.cli`), the library does not.
"""

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax

jax.config.update("jax_enable_x64", True)
