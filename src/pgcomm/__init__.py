"""pgcomm: physics-guided commutation for multi-coil-set linear motors.

Data flow (one module per stage)::

    trajectory -> control -> commutation -> drive -> plant (twin / forcemap)
    -> sensors -> logs -> calibration / identify -> models -> commutation
    -> evaluation (metrics, report) / export (C, LUT)

Conventions: SI units (m, s, N, N*m, A, rad); force vectors ``F = [Fy, Fx, Tz]``;
star-connected coil sets with independent currents ``(ia, ib)``, ``ic = -ia - ib``.
All numerics are float64: every module that computes with JAX enables x64 when imported
(:mod:`pgcomm._x64`); importing the package alone loads no JAX and changes no process-wide setting.
"""

__version__ = "0.1.0"

from pgcomm.errors import PgcommError  # noqa: E402

__all__ = ["PgcommError", "__version__"]
