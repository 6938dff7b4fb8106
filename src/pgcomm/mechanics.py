"""Translator mechanics ``G``: mass with viscous and smoothed Coulomb friction.

    m dv/dt = F_y - f_v v - f_c tanh(v / v_c) + d(t),   dy/dt = v

integrated with classical fourth-order Runge–Kutta in ``substeps`` sub-steps of a
controller sample, with the driving force held over the sample (zero-order hold).
The smoothing velocity ``v_c`` keeps the friction Lipschitz, so the explicit
integrator is stable when ``h f_c / (m v_c) < 2.7`` (checked by :func:`check_stable`).

One sub-step is the default: for the default translator at 1 ms (``h (f_v + f_c/v_c)/m = 0.4``)
its error over one sample, against 256 sub-steps along the paper's closed-loop references, is at
most 7e-10 m in position and 1.7e-7 m/s in velocity, under 1 % of the 0.1 µm encoder quantum
(tests/test_mechanics.py checks the bound). A stiffer friction or a longer sample needs more: the
error of a step grows with the fifth power of ``h``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import jax.numpy as jnp

#: Most RK4 sub-steps per controller sample (1000 already resolve any plausible friction).
MAX_SUBSTEPS = 1000


@dataclass(frozen=True)
class Mechanics:
    """Translator parameters (SI).

    Attributes:
        mass: moving mass ``m`` (kg).
        viscous: viscous friction ``f_v`` (N·s/m).
        coulomb: Coulomb friction ``f_c`` (N) of guides and cable slab.
        coulomb_velocity: smoothing velocity ``v_c`` (m/s) of ``tanh(v / v_c)``.
        substeps: RK4 sub-steps per controller sample.
    """

    mass: float = field(default=30.0, metadata={"range": (1e-3, 1e5), "unit": "kg", "hint": "the moving mass"})
    viscous: float = field(default=80.0, metadata={"range": (0.0, 1e6), "unit": "N s/m"})
    coulomb: float = field(default=12.0, metadata={"range": (0.0, 1e6), "unit": "N"})
    coulomb_velocity: float = field(default=1e-3, metadata={"range": (1e-9, 10.0), "unit": "m/s"})
    substeps: int = field(default=1, metadata={"range": (1, MAX_SUBSTEPS),
                                               "hint": f"RK4 sub-steps per controller sample; 1 to {MAX_SUBSTEPS}"})

    def __post_init__(self):
        if not all(isinstance(v, (int, float)) for v in (self.mass, self.substeps, self.coulomb_velocity)):
            return  # traced or array values (jax.vmap over parameters): checked where they are made
        if not self.mass > 0:
            raise ValueError(f"mass = {self.mass} kg: expected a positive moving mass")
        if not 1 <= self.substeps <= MAX_SUBSTEPS:
            raise ValueError(f"substeps = {self.substeps}: expected 1 to {MAX_SUBSTEPS} RK4 sub-steps per sample "
                             "(more cost run time without changing the result)")
        if not self.coulomb_velocity > 0:
            raise ValueError(f"coulomb_velocity = {self.coulomb_velocity} m/s: expected > 0")


def acceleration(mech: Mechanics, v, force_y):
    """``dv/dt`` (m/s²) for velocity ``v`` (m/s) and driving force ``force_y`` (N); any shape."""
    friction = mech.viscous * v + mech.coulomb * jnp.tanh(v / mech.coulomb_velocity)
    return (force_y - friction) / mech.mass


def step(mech: Mechanics, y, v, force_y, dt):
    """Advance ``(y, v)`` by ``dt`` (s) under a held force ``force_y`` (N) with ``mech.substeps`` RK4 steps.

    Returns:
        ``(y, v)`` after ``dt``, same shapes as the inputs.
    """
    h = dt / mech.substeps
    # multiplications by reciprocals: the stages are the longest chain of dependent operations in a
    # closed-loop step, and a division takes several times a multiplication's latency
    inv_m = 1.0 / mech.mass
    inv_vc = 1.0 / mech.coulomb_velocity

    def f(v_):
        return (force_y - mech.viscous * v_ - mech.coulomb * jnp.tanh(v_ * inv_vc)) * inv_m

    def substep(_, yv):
        y_, v_ = yv
        k1v = f(v_)
        k2v = f(v_ + 0.5 * h * k1v)
        k3v = f(v_ + 0.5 * h * k2v)
        k4v = f(v_ + h * k3v)
        # position stages are the velocity stages: k1y = v, k2y = v + h/2 k1v, ...
        y_ = y_ + h / 6.0 * (6 * v_ + h * (k1v + k2v + k3v))
        v_ = v_ + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        return y_, v_

    # A loop rather than unrolled sub-steps: XLA splits a long unrolled chain into many
    # small kernels, which costs ~5x more inside the simulation's scan.
    return jax.lax.fori_loop(0, mech.substeps, substep, (y, v))


def check_stable(mech: Mechanics, dt: float) -> None:
    """Raise ``ValueError`` if the sub-step is too long for the friction's stiffness."""
    h = dt / mech.substeps
    stiff = (mech.viscous + mech.coulomb / mech.coulomb_velocity) / mech.mass
    if h * stiff > 2.5:
        raise ValueError(
            f"mechanics: sub-step {h:.3g} s too long for friction stiffness {stiff:.3g} 1/s; "
            f"use at least {int(dt * stiff / 2.5) + 1} substeps")
