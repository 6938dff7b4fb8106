"""Rotary motors on field-oriented drives: twin, zoo, identification, law, experiment.

Most motors engineers tune are rotary PMSM/BLDC on a field-oriented (FOC) drive. The drive logs
``t``, the rotor's mechanical angle ``θ`` (rad, multi-turn), its velocity and the q-axis (and
d-axis) current in its own electrical frame ``p θ + offset`` — no phase currents, no torque
sensor. This subpackage mirrors the linear pipeline for them:

* :mod:`pgcomm.rotary.motor`: :class:`RotaryMotor` (pole pairs, slots, ``k_t``, inertia, limit);
* :mod:`pgcomm.rotary.model`: periodic maps over one revolution (Fourier on the circle, orders
  from the slot/pole combination) and :class:`RotaryModel` (with ``table(n)`` for exports);
* :mod:`pgcomm.rotary.twin`: the rotary PMSM twin on a FOC drive in closed loop (``lax.scan``), with a real drive's
  habits to switch on (current-sensor errors, a filtered report, a PLL angle, a host's clock, a moving index); its
  winding and the q- and d-voltages the drive logs in :mod:`pgcomm.rotary.winding`;
* :mod:`pgcomm.rotary.zoo`: random plausible motors (slot/pole combinations, tolerances);
* :mod:`pgcomm.rotary.identify`: least squares from running logs, with or without torque sensor, with standard
  errors; its regression in :mod:`pgcomm.rotary.regression`, the logs' readings (the current's timing, a PLL's
  angle) in :mod:`pgcomm.rotary.readings`, time-periodic disturbances in :mod:`pgcomm.rotary.time_lines`, the
  ripple and the back-EMF constant from the logged q-voltage, and the drive's offset error from the d-voltage, in
  :mod:`pgcomm.rotary.back_emf`;
* :mod:`pgcomm.rotary.slots`: the slot count from running logs, when the motor description lacks it;
* :mod:`pgcomm.rotary.standstill`: the drives' method (hold at N angles both ways, average ``i_q``);
* :mod:`pgcomm.rotary.law`: the commutation law ``i_q = (T* − cog − dir)/k_t(θ)``, safe for any input;
* :mod:`pgcomm.rotary.experiment`: ``pgcomm reproduce`` on a rotary motor (all rows, figures).

**The model and its units.** The electrical period ``2π/p`` takes the pole pitch's place;
everything position-dependent is periodic over one mechanical revolution. With ``k0`` the mean
torque constant the drive's frame sees (``k_t cos δ`` for a frame offset error ``δ``)::

    J θ̈ = k0 [ (1 + r(θ)) i_q + c(θ) − d(θ) sign(ω) − b ω ]

Without a torque sensor and without a known inertia only ratios are observable, so the model is
identified in **current units**: cogging ``c`` and drag ``d`` as equivalent q-currents (A), the
ripple ``r`` relative (-), ``J/k0`` in A·s²/rad — exactly what a drive's compensation table
holds (:meth:`RotaryModel.table`). Multiply by ``k0`` for N·m when ``k_t`` is known.

**Sampling.** Drive logs run at ~1 kHz; cogging at ``LCM(Q, 2p)`` periods per revolution aliases
at speed (100 periods per revolution at 50 rad/s is 1.3 samples per period).
Identification refuses windows whose highest modelled harmonic has fewer than
:data:`pgcomm.rotary.regression.MIN_SAMPLES_PER_PERIOD` samples per period and reports how many.
"""

from pgcomm.rotary.model import Fourier, RotaryModel, cogging_orders, direction_orders, ripple_orders
from pgcomm.rotary.motor import RotaryMotor

__all__ = ["RotaryMotor", "RotaryModel", "Fourier", "cogging_orders", "ripple_orders", "direction_orders"]
