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
from pgcomm.settings import StandstillPlan
from pgcomm.errors import DataError

__all__ = ["StandstillPlan", "StandstillTable", "staircase", "run_standstill", "table_from_log", "SweepTable",
           "table_from_sweep", "sweep_reference", "MIN_SAMPLES_PER_BIN"]

#: A bin of a logged sweep's table needs at least this many samples per direction (the table's resolution
#: follows from the log: :func:`table_from_sweep`).
MIN_SAMPLES_PER_BIN = 10
#: Most revolutions a sweep may travel in one direction: a drive's standstill sweep turns about one each way (a few
#: passes at most); an angle in degrees read as radians travels 57 times as far, one in encoder counts thousands.
MAX_SWEEP_REVOLUTIONS = 20.0


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


@dataclass(frozen=True)
class SweepTable:
    """The drives' table from a logged slow sweep (:func:`table_from_sweep`).

    Attributes:
        theta: ``(N,)`` bin centres ``2πj/N`` (rad, encoder angle in ``[0, 2π)``).
        table: ``(N,)`` mean of the forward and reverse bin averages of ``i_q`` (A); NaN where a
            direction did not cover the bin.
        forward, reverse: ``(N,)`` the two passes' bin averages (A, NaN where empty).
        noise: standard error of the table's white-noise part (A, RMS over the covered bins).
        coverage: share of the bins covered in both directions.
        seconds: the sweep's rig time (s).
    """

    theta: np.ndarray
    table: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray
    noise: float
    coverage: float
    seconds: float


def table_from_sweep(theta, iq, sample_time: float, points: int | None = None,
                     trend_seconds: float = 0.5) -> SweepTable:
    """The drives' anti-cogging table from a logged slow sweep in both directions (continuous or a
    staircase of holds): ``i_q`` averaged per angle bin, forward and reverse apart, their mean.

    The pass direction is the sign of the angle's trend over ``trend_seconds`` (a staircase stands
    still within a hold, but its pass still moves one way); samples where the trend is below a
    tenth of its median (the turn-arounds) are left out. In the mean of the two passes the Coulomb
    and viscous friction cancel, as in the drives' own tables.

    Args:
        theta: ``(M,)`` mechanical angle (rad, multi-turn, unwrapped); iq: ``(M,)`` q-current (A).
        sample_time: ``T_s`` (s).
        points: bins per revolution; default the most that give every bin
            :data:`MIN_SAMPLES_PER_BIN` samples per direction on average, at most 3600.
        trend_seconds: window of the trend (s).

    Returns:
        :class:`SweepTable`.

    Raises:
        DataError: fewer than 64 bins' worth of samples, no motion in one of the directions, or more than
            :data:`MAX_SWEEP_REVOLUTIONS` in one (an angle in degrees or counts read as radians).
    """
    th = np.asarray(theta, float)
    i = np.asarray(iq, float)
    k = max(1, int(round(trend_seconds / sample_time / 2)))
    if th.size < 4 * k:
        raise DataError(f"sweep log: {th.size} samples, shorter than the {2 * trend_seconds:g} s its direction "
                        "is judged over")
    trend = np.zeros_like(th)
    trend[k:-k] = th[2 * k:] - th[:-2 * k]
    trend[:k], trend[-k:] = trend[k], trend[-k - 1]  # the ends belong to the passes they start and end
    moving = np.abs(trend) > 0.1 * np.median(np.abs(trend[k:-k]))
    fwd, rev = moving & (trend > 0), moving & (trend < 0)
    n_min = min(int(fwd.sum()), int(rev.sum()))
    if n_min == 0:
        raise DataError("sweep log: the angle moves one way only; the drives' table needs a forward and a "
                        "reverse pass")
    d = np.diff(th)
    travel = [float(np.sum(np.abs(d[m[1:]]))) / (2 * math.pi) for m in (fwd, rev)]
    if max(travel) > MAX_SWEEP_REVOLUTIONS:
        raise DataError(f"sweep log: the angle travels {travel[0]:.0f} revolutions forward and {travel[1]:.0f} in "
                        f"reverse, where a standstill sweep turns about one each way (at most "
                        f"{MAX_SWEEP_REVOLUTIONS:g}): if 'theta' is in degrees or encoder counts, declare it in the "
                        "--columns map's [units] (theta = \"deg\", or \"counts\" with encoder_counts)")
    n = int(points) if points else int(min(3600, n_min // MIN_SAMPLES_PER_BIN))
    if n < 64:
        raise DataError(f"sweep log: {n_min} samples in its shorter direction give fewer than 64 bins of "
                        f"{MIN_SAMPLES_PER_BIN} samples over the revolution; record a longer sweep")
    # bin j is centred on 2πj/n: the drives' table convention (entry j at angle 2πj/n)
    b = np.round(np.mod(th, 2 * math.pi) / (2 * math.pi) * n).astype(int) % n

    def passes(mask):
        cnt = np.bincount(b[mask], minlength=n).astype(float)
        s1 = np.bincount(b[mask], i[mask], minlength=n)
        s2 = np.bincount(b[mask], i[mask] ** 2, minlength=n)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(cnt > 0, s1 / cnt, np.nan)
            var = np.where(cnt > 1, (s2 - cnt * mean**2) / (cnt - 1), np.nan)
        return mean, var, cnt

    f_mean, f_var, f_cnt = passes(fwd)
    r_mean, r_var, r_cnt = passes(rev)
    tab = 0.5 * (f_mean + r_mean)
    both = np.isfinite(tab)
    ok = both & (f_cnt > 1) & (r_cnt > 1)
    # the white-noise part of each bin's mean of the two passes, RMS over the bins
    noise = float(np.sqrt(np.mean(0.25 * (f_var[ok] / f_cnt[ok] + r_var[ok] / r_cnt[ok])))) if ok.any() else math.nan
    centres = 2 * math.pi * np.arange(n) / n
    return SweepTable(centres, tab, f_mean, r_mean, noise, float(both.mean()), float(th.size * sample_time))


def sweep_reference(sample_time: float, revolution_seconds: float = 60.0, ramp_seconds: float = 0.5) -> Reference:
    """A slow continuous sweep for the position loop: one revolution forward at ``2π/revolution_seconds``
    rad/s, a short pause, one revolution back (linear speed ramps of ``ramp_seconds``): what a drive's
    cogging calibration does when it moves instead of holding.

    Returns:
        :class:`pgcomm.rotary.twin.Reference` (position mode), about ``2 (revolution_seconds + ramp_seconds)`` s.
    """
    ts = float(sample_time)
    w = 2 * math.pi / revolution_seconds
    up = np.linspace(0.0, 1.0, max(2, int(ramp_seconds / ts)))
    cruise = np.ones(int(round(revolution_seconds / ts)))
    one = np.concatenate([up, cruise, up[::-1]]) * w
    om = np.concatenate([one, np.zeros(int(0.2 / ts)), -one])
    return Reference(np.cumsum(om) * ts, om, np.gradient(om, ts), "position")
