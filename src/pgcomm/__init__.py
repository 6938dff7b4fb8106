"""pgcomm: physics-guided commutation for multi-coil-set linear motors.

Data flow (one module per stage)::

    trajectory -> control -> commutation -> drive -> plant (twin / forcemap)
    -> sensors -> logs -> calibration / identify -> models -> commutation
    -> evaluation (metrics, report) / export (C, LUT)

Conventions: SI units (m, s, N, N*m, A, rad); force vectors ``F = [Fy, Fx, Tz]``;
star-connected coil sets with independent currents ``(ia, ib)``, ``ic = -ia - ib``.
All numerics are float64: importing the package enables JAX x64.
"""

import os as _os

# OpenBLAS worker threads busy-wait against XLA's thread pool on small machines, which made
# NumPy/SciPy least squares ~20x slower next to JAX work; one BLAS thread is faster here.
# (Only effective when NumPy is not imported yet, as in the ``pgcomm`` command.)
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import jax as _jax  # noqa: E402

_jax.config.update("jax_enable_x64", True)
_jax.config.update("jax_platforms", "cpu")

__version__ = "0.1.0"

from pgcomm.errors import PgcommError  # noqa: E402

__all__ = ["PgcommError", "__version__"]
