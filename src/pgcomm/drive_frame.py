"""The frame of a field-oriented drive: ``(i_q, i_d)`` <-> phase currents <-> the paper's drive inputs.

A field-oriented (FOC) drive of a rotary motor commutates with its own electrical angle
``η = p θ + offset`` (``p`` pole pairs, ``θ`` the mechanical angle in rad, ``offset`` in rad
electrical) and logs the q- and d-axis currents ``i_q``, ``i_d`` (A) in that frame (DESIGN,
"Rotary motors"). In the package's conventions (:mod:`pgcomm.motor`: phase order a, b, c ↔
``sin(η), sin(η + 2π/3), sin(η − 2π/3)``, star connection ``ic = −ia − ib``) the drive makes the
phase currents::

    i_p = i_q sin(η_p) + i_d cos(η_p),   η_p = η, η + 2π/3, η − 2π/3   (p = a, b, c)

so the q axis is the force (torque) direction of an ideal motor whose true phase is ``η``
(``Fy = k i_q`` for the ideal gain of :func:`pgcomm.motor.ideal_gain_phases`), and ``i_d`` is the
current 90° electrical ahead of it. The transform is amplitude-invariant: the phase current
amplitude is ``hypot(i_q, i_d)``.

Relation to the textbook Park/Clarke transform (amplitude-invariant, phase b lagging:
``ia = i_d cos ϑ − i_q sin ϑ``, ``ib = i_d cos(ϑ − 2π/3) − i_q sin(ϑ − 2π/3)``; Clarke
``iα = ia``, ``iβ = (ia + 2 ib)/√3``; Park ``i_d = iα cos ϑ + iβ sin ϑ``, ``i_q = −iα sin ϑ + iβ cos ϑ``):
it is this frame with ``ϑ = −η``. A drive documented with the textbook transform and an angle
``ϑ_e`` that increases with the motion is therefore this frame with ``η = −ϑ_e`` (same phase labels;
``pole_pairs`` and ``offset`` of :func:`electrical_angle` negated). Relabelling the phases b ↔ c
instead (a reflection) makes it this frame at ``η = ϑ_e + π`` with ``i_d`` reversed. Both statements
are checked numerically in ``tests/test_drive_frame.py``.

The paper's drive inputs for fixed commutation (eq. Commutation_Solution_With_PhaseOffset) are the
same thing seen from a linear drive: :func:`pgcomm.commutation.drive_currents` makes
``i = (Fy*/k̂) [sin(η̂ + Δ), sin(η̂ + Δ + 2π/3)]``, i.e. ``i_q = Fy* cos Δ / k̂``,
``i_d = Fy* sin Δ / k̂`` at ``η = η̂``. :func:`dq_to_drive_inputs` and :func:`drive_inputs_to_dq`
convert with the package's one sign convention (:func:`pgcomm.commutation.transform_T_inverse`:
the magnitude signed, ``Δ ∈ (−π/2, π/2]``). With ``k_hat = 1`` the magnitude is a current (A): the
"equivalent q-current" units in which a rotary motor without a torque sensor is identified.

Every function takes and returns arrays of any broadcastable shape ``S`` (float64, JAX), jittable.
"""

from __future__ import annotations

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax.numpy as jnp

from pgcomm.commutation import transform_T_inverse

__all__ = ["electrical_angle", "dq_to_phase", "phase_to_dq", "dq_to_drive_inputs", "drive_inputs_to_dq"]

_TWO_PI_3 = 2.0 * jnp.pi / 3.0


def electrical_angle(theta, pole_pairs, offset=0.0):
    """The drive's electrical angle ``η = p θ + offset`` (rad).

    Args:
        theta: mechanical angle ``θ`` (rad), shape ``S`` (multi-turn allowed; not reduced, so
            ``sin``/``cos`` of it lose about ``|η|·1e-16`` rad).
        pole_pairs: ``p`` (integer > 0, or an array broadcastable against ``theta``).
        offset: the drive's commutation offset (rad, electrical), the rotary analogue of ``ζ̂``.

    Returns:
        ``η`` (rad), shape ``broadcast(S, pole_pairs, offset)``.
    """
    return jnp.asarray(pole_pairs, dtype=float) * jnp.asarray(theta, dtype=float) + jnp.asarray(offset, dtype=float)


def dq_to_phase(iq, id_, eta):
    """Star currents ``(ia, ib)`` (A) the drive makes from ``(i_q, i_d)`` (A) at electrical angle ``η`` (rad).

    ``ia = i_q sin η + i_d cos η``, ``ib = i_q sin(η + 2π/3) + i_d cos(η + 2π/3)``; ``ic = −ia − ib``
    (the star connection makes the third phase ``i_q sin(η − 2π/3) + i_d cos(η − 2π/3)``).

    Args:
        iq, id_: q- and d-axis currents (A), shapes broadcastable to ``S``.
        eta: electrical angle (rad), broadcastable to ``S`` (:func:`electrical_angle`).

    Returns:
        ``S + (2,)`` star currents ``[ia, ib]`` (A).
    """
    iq, id_, eta = jnp.asarray(iq, dtype=float), jnp.asarray(id_, dtype=float), jnp.asarray(eta, dtype=float)
    e2 = eta + _TWO_PI_3
    return jnp.stack([iq * jnp.sin(eta) + id_ * jnp.cos(eta), iq * jnp.sin(e2) + id_ * jnp.cos(e2)], axis=-1)


def phase_to_dq(currents, eta):
    """``(i_q, i_d)`` (A) of star currents ``(ia, ib)`` (A) at electrical angle ``η`` (rad); inverse of :func:`dq_to_phase`.

    From the three phase currents (``ic = −ia − ib``) by the orthogonality of the three phase
    patterns: ``i_q = (2/3) Σ_p i_p sin η_p``, ``i_d = (2/3) Σ_p i_p cos η_p``.

    Args:
        currents: ``S + (2,)`` star currents ``[ia, ib]`` (A).
        eta: electrical angle (rad), broadcastable to ``S``.

    Returns:
        ``(iq, id)``, each of shape ``S`` (A).
    """
    c = jnp.asarray(currents, dtype=float)
    eta = jnp.asarray(eta, dtype=float)
    ia, ib = c[..., 0], c[..., 1]
    ic = -(ia + ib)
    ea, eb, ec = eta, eta + _TWO_PI_3, eta - _TWO_PI_3
    iq = (2.0 / 3.0) * (ia * jnp.sin(ea) + ib * jnp.sin(eb) + ic * jnp.sin(ec))
    id_ = (2.0 / 3.0) * (ia * jnp.cos(ea) + ib * jnp.cos(eb) + ic * jnp.cos(ec))
    return iq, id_


def dq_to_drive_inputs(iq, id_, k_hat=1.0):
    """The paper's drive inputs ``(Fy*, Δ)`` of ``(i_q, i_d)``: ``T^{-1}(k̂ i_q, k̂ i_d)``.

    The package's sign convention (:func:`pgcomm.commutation.transform_T_inverse`): ``Fy*`` signed,
    ``Δ ∈ (−π/2, π/2]``, zero current as ``(0, 0)``. A drive holding ``i_d = 0`` gives ``Δ = 0`` and
    ``Fy* = k̂ i_q`` with the sign of ``i_q``.

    Args:
        iq, id_: q- and d-axis currents (A), broadcastable shapes ``S``.
        k_hat: the drive's constant ``k̂`` (N/A, or N·m/A for a rotary drive, > 0), broadcastable;
            1 gives the magnitude in A (equivalent q-current).

    Returns:
        ``(fy, delta)``, each of shape ``S``: signed magnitude (N, N·m or A with ``k_hat = 1``) and ``Δ`` (rad).
    """
    k = jnp.asarray(k_hat, dtype=float)
    f12 = jnp.stack(jnp.broadcast_arrays(k * jnp.asarray(iq, dtype=float), k * jnp.asarray(id_, dtype=float)), axis=-1)
    return transform_T_inverse(f12)


def drive_inputs_to_dq(fy, delta, k_hat=1.0):
    """``(i_q, i_d) = (Fy* cos Δ, Fy* sin Δ) / k̂`` (A): inverse of :func:`dq_to_drive_inputs` for any ``(Fy*, Δ)`` pair.

    Args:
        fy: drive-input magnitude (N, N·m, or A with ``k_hat = 1``), any sign; delta: ``Δ`` (rad), any value.
        k_hat: the drive's ``k̂`` (> 0), broadcastable.

    Returns:
        ``(iq, id)``, each of the broadcast shape (A).
    """
    fy, delta = jnp.asarray(fy, dtype=float), jnp.asarray(delta, dtype=float)
    k = jnp.asarray(k_hat, dtype=float)
    return fy * jnp.cos(delta) / k, fy * jnp.sin(delta) / k
