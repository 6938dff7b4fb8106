"""The drives' anti-cogging calibration: hold the rotor at N angles in both directions, average i_q.

This is what ODrive (3600 positions per revolution) and moteus (a table of 1024 entries, forward
and reverse averaged) do: the position loop holds each angle of a staircase; once settled, the
q-current it needs is averaged; the table is the mean of the forward and the reverse pass. At
standstill the current holds exactly the cogging torque (``i_q = −c(θ)/(1 + r(θ))``), and
nothing of the torque-constant ripple under load or of the direction-dependent torque; its noise
is that of ``avg`` samples of the measured current and of the encoder-quantised hold. Its cost is
time: ``2 N (settle + avg) T_s`` seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pgcomm.rotary.twin import Gains, LawParams, Reference, RotaryTruth, simulate

__all__ = ["StandstillPlan", "StandstillTable", "staircase", "run_standstill", "table_from_log"]


@dataclass(frozen=True)
class StandstillPlan:
    """A standstill sweep: ``points`` angles per revolution, ``settle`` and ``average`` samples per angle."""

    points: int = 3600
    settle: int = 30
    average: int = 20

    def duration(self, sample_time: float) -> float:
        """Seconds the sweep takes on the rig (both directions)."""
        return 2 * self.points * (self.settle + self.average) * sample_time


@dataclass
class StandstillTable:
    """Result of a sweep.

    Attributes:
        table: ``(points,)`` compensating q-current (A) at ``θ_j = 2π j / points``: forward/reverse mean.
        forward, reverse: ``(points,)`` the two passes (A).
        noise: estimated RMS noise of ``table`` (A) from the spread of the current within the holds.
        seconds: duration on a rig (s).
    """

    table: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray
    noise: float
    seconds: float


def staircase(plan: StandstillPlan, sample_time: float, theta_start: float = 0.0) -> tuple[Reference, np.ndarray]:
    """Position reference of the sweep and the sample index where each hold's average starts.

    Forward over one revolution (``θ_j = θ_start + 2π j / N``), then back; one hold per angle.

    Returns:
        ``(ref, starts)``: :class:`Reference` (``(2 N (settle + avg),)`` samples) and ``(2N,)`` indices.
    """
    n = plan.points
    hold = plan.settle + plan.average
    ang_f = theta_start + 2 * math.pi * np.arange(n) / n
    ang = np.concatenate([ang_f, ang_f[::-1]])
    theta = np.repeat(ang, hold)
    starts = np.arange(2 * n) * hold + plan.settle
    z = np.zeros_like(theta)
    return Reference(theta, z, z, "position"), starts


def table_from_log(log: dict, plan: StandstillPlan, starts) -> StandstillTable:
    """Average the logged ``iq_1`` over each hold; forward and reverse passes, their mean and its noise."""
    iq = np.asarray(log["iq_1"], float)
    idx = np.asarray(starts)[:, None] + np.arange(plan.average)
    means = iq[idx].mean(axis=1)
    n = plan.points
    fwd, rev = means[:n], means[n:][::-1]
    tab = 0.5 * (fwd + rev)
    # white-noise part: the spread within a hold over sqrt(samples), halved again by the two passes
    # (forward and reverse also differ systematically, by the friction the hold did not settle out)
    noise = float(np.sqrt(np.mean(iq[idx].var(axis=1, ddof=1)) / plan.average / 2.0))
    return StandstillTable(tab, fwd, rev, noise, plan.duration(float(log["t"][1] - log["t"][0])))


def run_standstill(truth: RotaryTruth, gains: Gains, plan: StandstillPlan = StandstillPlan(), seed: int = 0,
                   n_sub: int = 5) -> StandstillTable:
    """The sweep on the twin (classical law, no feedforward: the rotor stands still at every hold).

    Args:
        truth: the motor; gains: the drive's position loop; plan: points and samples per hold;
        seed: current-noise seed; n_sub: plant sub-steps per sample (5: the rotor barely moves).

    Returns:
        :class:`StandstillTable` (the table is in the encoder's angle, starting at 0).
    """
    ref, starts = staircase(plan, truth.motor.sample_time)
    log = simulate(truth, ref, LawParams.classical(truth.motor.pole_pairs), gains, seed=seed, n_sub=n_sub)
    return table_from_log(log, plan, starts)
