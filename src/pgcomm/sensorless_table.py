"""The drives' anti-cogging table without a force sensor, as a drive learns it on the machine: the
position controller's effort at slow constant velocity, both directions averaged.

:func:`effort_reference` builds the slow back-and-forth reference and picks the settled
constant-velocity samples; :func:`sensorless_cogging_table` runs it closed loop with the
classical law and fits the table (:func:`pgcomm.compensation.fit_effort_table`). It is the
``cogging_table_sensorless`` row of :mod:`pgcomm.reproduce`.
"""

from __future__ import annotations

import math
import time

import numpy as np

from pgcomm import trajectory
from pgcomm.control import Feedforward
from pgcomm.errors import ConfigError
from pgcomm.experiment import run_laws
from pgcomm.setup import Setup, check_reference
from pgcomm.compensation import fit_effort_table

__all__ = ["EFFORT_SPEED_FRACTION", "loop_settling_time", "sensorless_cogging_table", "effort_reference"]


#: Cruise speed of :func:`sensorless_cogging_table` as a fraction ``c`` of ``d_m · f_bw``: the
#: pole-pitch period ``d_m / v`` is then seen at ``f = c · f_bw``. For the loop-shaping tuning of
#: :meth:`pgcomm.control.PID.tuned` (normalised by the crossover, mass matched) the complementary
#: sensitivity is ``|T(j 0.1 ω_b)| = 1.020`` with 0.015 rad lag (``|T - 1| = 0.025``), against
#: ``|T - 1| = 0.07`` at 0.15 and 0.14 at 0.2 (resonance peak 1.31 near 0.5): at ``c = 0.1`` the
#: effort reproduces a disturbance at the pole-pitch period within 2.5 %.
EFFORT_SPEED_FRACTION = 0.1


def loop_settling_time(setup: Setup, decay: float = 0.01) -> float:
    """Time (s) for the slowest closed-loop mode of the position loop to decay to ``decay``.

    Continuous-time loop of the tuned PID (``kp``, ``ki``, ``kd``, output low-pass ``ω_lp``)
    around the mass the feedback is tuned for (``[controller] mass``, what a drive knows):
    roots of ``m s³ (1 + s/ω_lp) + kd s² + kp s + ki``; ``ln(1/decay) / min |Re p|``. With
    :meth:`~pgcomm.control.PID.tuned` the slowest pole is the integrator's, ``≈ -0.18 ω_b``
    (0.67 s to 1 % at 6 Hz).
    """
    pid, m = setup.pid, setup.config.controller.mass
    w_lp = 2 * np.pi * pid.lowpass_hz
    poles = np.roots([m / w_lp, m, pid.kd, pid.kp, pid.ki])
    return float(math.log(1.0 / decay) / np.min(np.abs(poles.real)))


def sensorless_cogging_table(setup: Setup, classical_law, feedforward: Feedforward, seed: int = 0,
                             speed: float | None = None):
    """The drives' anti-cogging table without a force sensor: the position controller's effort at
    slow constant velocity, both directions averaged (:func:`pgcomm.compensation.fit_effort_table`).

    The reference rests at the low end of the set-up's span, moves to the high end at ``speed``,
    rests and moves back (third-order moves with the configured ``a_max``, ``j_max``, rests of the
    configured dwell). Of the closed-loop run with ``classical_law`` and ``feedforward`` only
    settled constant-velocity samples are kept: reference acceleration 0 at the sample and the next
    (the feedforward looks one sample ahead), ``|v_ref|`` at the cruise speed, and at least
    :func:`loop_settling_time` after the cruise began (the loop's transient from the start of the
    move has decayed to 1 %). They are split by direction and indexed by the encoder position.

    Default ``speed``: ``min(slowest configured reference velocity, c · d_m · f_bw)`` with
    ``c =`` :data:`EFFORT_SPEED_FRACTION` (0.1): a disturbance with the pole pitch's period
    ``d_m / v`` then lies at a tenth of the loop's bandwidth, where the effort follows it within
    2.5 %; shorter periods are followed less well. The distance lost to settling at the start of
    each pass is ``v · t_settle ≈ 0.4 d_m`` for the default speed and tuning.

    Args:
        setup: the resolved experiment.
        classical_law: the (calibrated) classical commutation law the drive runs.
        feedforward: its feedforward (:func:`tune_feedforward`).
        seed: sensor-noise seed of the run.
        speed: cruise speed (m/s), > 0; default as above.

    Returns:
        ``(CoggingTable, info)`` with ``info``: ``speed`` (m/s), ``samples`` (``{"positive": n,
        "negative": n}`` samples used), ``duration`` (s of machine time, the reference's),
        ``settling_time`` (s), ``y_range`` (m, the table's grid ends: the span) and ``seconds``
        (wall time of the run and fit).

    Raises:
        ConfigError: a speed that is not > 0, a reference outside the plant, or a stroke too short
            to leave settled samples in both directions at the same positions.
    """
    t0 = time.perf_counter()
    ref, speed, pos, neg, settle = effort_reference(setup, speed)
    lo, hi = setup.config.reference.span
    res = run_laws(setup, [classical_law], ref, [feedforward], seeds=[seed])[0]
    fy = res.f_star[:, 0]
    try:
        table = fit_effort_table(res.y_meas[pos], fy[pos], res.y_meas[neg], fy[neg],
                                 setup.config.evaluation.cogging_table_entries, (lo, hi))
    except ValueError as err:
        raise ConfigError(f"sensorless cogging table at {speed:.4g} m/s: {err}") from None
    info = {"speed": speed, "samples": {"positive": int(pos.sum()), "negative": int(neg.sum())},
            "duration": ref.duration, "settling_time": settle, "y_range": (lo, hi),
            "seconds": time.perf_counter() - t0}
    return table, info


def effort_reference(setup: Setup, speed: float | None = None):
    """The reference of :func:`sensorless_cogging_table` and the samples it keeps, checked without simulating.

    Args:
        setup: the resolved experiment; speed: cruise speed (m/s) or ``None`` for the default
            (:func:`sensorless_cogging_table`).

    Returns:
        ``(reference, speed (m/s), positive (N,) bool, negative (N,) bool, settling time (s))``: the
        settled constant-velocity samples of each direction.

    Raises:
        ConfigError: a speed that is not > 0, a reference outside the plant, or a stroke too short to
            leave settled samples in both directions at the same positions.
    """
    rc = setup.config.reference
    lo, hi = rc.span
    if speed is None:
        speed = min(min(rc.velocities),
                    EFFORT_SPEED_FRACTION * setup.motor.pole_pitch * setup.config.controller.bandwidth_hz)
    speed = float(speed)
    if not (math.isfinite(speed) and speed > 0):
        raise ConfigError(f"sensorless cogging table: speed = {speed} m/s, expected > 0")
    ts = setup.motor.sample_time
    ref = trajectory.sequence([(hi, speed, rc.a_max, rc.j_max), (lo, speed, rc.a_max, rc.j_max)], ts,
                              dwell=rc.dwell, start=lo, initial_dwell=rc.dwell)
    check_reference(setup, ref, "the sensorless cogging-table reference")

    settle = loop_settling_time(setup)
    a_next = np.concatenate([ref.a[1:], ref.a[-1:]])
    cruise = (ref.a == 0) & (a_next == 0) & np.isclose(np.abs(ref.v), speed, rtol=1e-9, atol=0.0)
    # time since the current cruise began: samples in a run of cruise samples, times ts
    run_start = np.maximum.accumulate(np.where(~cruise, np.arange(len(ref)), -1))
    since = (np.arange(len(ref)) - run_start) * ts
    keep = cruise & (since >= settle)
    pos, neg = keep & (ref.v > 0), keep & (ref.v < 0)
    if (pos.sum() < 2 or neg.sum() < 2
            or not min(ref.r[pos].max(), ref.r[neg].max()) > max(ref.r[pos].min(), ref.r[neg].min())):
        raise ConfigError(f"sensorless cogging table: the stroke [{lo:.6g}, {hi:.6g}] m at {speed:.4g} m/s leaves "
                          "no positions passed in both directions at settled constant velocity "
                          f"({int(pos.sum())} positive, {int(neg.sum())} negative samples after the loop's "
                          f"settling time {settle:.3g} s); lower the speed or lengthen the stroke")
    return ref, speed, pos, neg, settle

