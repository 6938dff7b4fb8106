"""pgcomm: physics-guided commutation for multi-coil-set linear motors.

Data flow (one module per stage)::

    trajectory -> control -> commutation -> drive -> plant (twin / forcemap)
    -> sensors -> logs -> calibration / identify -> models -> commutation
    -> evaluation (metrics, report) / export (C, LUT)

Conventions: SI units (m, s, N, N*m, A, rad); force vectors ``F = [Fy, Fx, Tz]``;
star-connected coil sets with independent currents ``(ia, ib)``, ``ic = -ia - ib``.
All numerics are float64: importing the package enables JAX x64.
"""

import jax as _jax

_jax.config.update("jax_enable_x64", True)
_jax.config.update("jax_platforms", "cpu")

__version__ = "0.1.0"

from pgcomm.errors import PgcommError  # noqa: E402

__all__ = ["PgcommError", "__version__"]
