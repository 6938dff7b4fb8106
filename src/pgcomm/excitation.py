"""Excitation report: do logs persistently excite the PGNN of every coil set (paper, Remark on excitation)?

The paper's Remark asks, for every position ``y`` of the stroke,

1. different magnitudes of the desired force ``Fy^l*`` (to separate the Lorentz force
   from the cogging force), and
2. different ratios ``ia^l : ib^l`` (to separate the two columns of ``K̂^l(y)``); the paper
   gets them by repeating the experiment with ``Δ^l = ∓Δ``.

This module holds the one criterion, judged per position bin (:func:`excitation_report`
gives the numbers, :func:`check_excitation` the verdict that identification acts on:
:func:`pgcomm.identify.identify` refuses data it flags). For a user who wants to know what
to measure next the report gives, over the whole stroke:

* samples per bin, split by the sign of the phase offset ``Δ`` of the current relative to
  the drive's commutation angle (``Δ < 0``, ``Δ ≈ 0``, ``Δ > 0``) and samples without current;
* the spread of the current direction (5–95 % range of ``ψ``, rad) and of the current
  vectors across their direction(s) per bin (the criterion below);
* one readable message per range of bins with the same problem, e.g.
  ``coil set 2: no samples for y in [0.020, 0.040] m``.

The criterion: a bin's problem is the first that applies:

* ``gap``: fewer than ``min_samples`` samples;
* ``no current``: fewer than 2 samples with a current above 5 % of the median;
* ``single direction``: the 5–95 % range of the current direction ``ψ`` (mod π) is below
  ``min_angle`` — one ratio ``ia : ib``, i.e. a single ``Δ``;
* ``single magnitude``: the current vectors ``p = Γ(y)^{-1} i`` (``k̂ = 1``, ``ζ̂ = 0``; N/A)
  of the bin lie (nearly) on one line: ``sqrt(λ_min) / rms|p| <= min_spread`` with
  ``λ_min`` the smaller eigenvalue of their 2×2 covariance (the force-magnitude test below).

The force-magnitude test: within a bin (``y`` about constant) the model is
``F = K̂ i + F̂_cog``, linear in ``(i, 1)``, so the gain columns and the cogging force are
separable only if the current vectors do not lie on one line (their affine span must be the
plane). The spread is ``sqrt(λ_min(cov p)) / rms|p|`` of the currents ``p = Γ(y)^{-1} i``
(``k̂ = 1``, ``ζ̂ = 0``) with the population covariance (``ddof = 0``), which is 0 exactly when
the points are collinear (two data sets ``Δ = ∓Δ0`` with ONE magnitude each span only a line).

Conventions: positions in m, angles in rad, currents in A; ``Δ`` is folded onto
``(-π/2, π/2]`` because a negative force with ``Δ`` is the same current direction as a
positive force with ``Δ ± π`` (the magnitude spread, not ``Δ``, sees the force sign).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import numpy as np

from pgcomm.commutation import currents_to_drive_inputs
from pgcomm.errors import DataError
from pgcomm.data import CoilSetData, active_coil_set, log_currents
from pgcomm.motor import Motor

__all__ = ["BinStats", "CoilSetExcitation", "ExcitationReport", "excitation_report",
           "group_logs", "problem_runs", "check_excitation", "DEFAULT_BINS", "MAX_BINS", "MIN_SAMPLES", "MIN_ANGLE",
           "MIN_SPREAD", "DELTA_ZERO", "PROBLEMS"]

#: Default number of position bins over the stroke.
DEFAULT_BINS = 20
#: Most position bins of a report: each bin needs MIN_SAMPLES samples of each kind, so more bins than
#: this cannot be filled by any log that fits in memory (and the per-bin arrays stay small).
MAX_BINS = 10_000
#: Fewest samples per bin (else a gap).
MIN_SAMPLES = 20
#: Smallest 5–95 % spread (rad) of the current direction ψ (mod π) per bin (else a single Δ).
MIN_ANGLE = 0.1
#: Smallest ``sqrt(λ_min(cov p)) / rms|p|`` per bin (else a single force magnitude).
MIN_SPREAD = 0.1

#: ``|Δ|`` (rad) below which a sample counts as ``Δ ≈ 0`` (plain commutation) in the report.
DELTA_ZERO = 0.05
#: Samples whose current amplitude is below this share of the median are "no current"
#: (they are ignored when judging current directions).
_CURRENT_SHARE = 0.05

# jitted once per data length: eager jnp dispatch costs about 1 s per new array shape
_drive_inputs = jax.jit(currents_to_drive_inputs, static_argnums=(4,))

#: Per-bin problem kinds, in the order a bin is judged (the first that applies is reported).
PROBLEMS = ("gap", "no current", "single direction", "single magnitude")


@dataclass(frozen=True)
class BinStats:
    """Per-position-bin statistics of one coil set's data (arrays of length ``n_bins``).

    Attributes:
        edges: ``(n_bins + 1,)`` bin edges (m); bin ``b`` is ``[edges[b], edges[b+1])``, the last one closed.
        samples: samples per bin.
        delta_negative, delta_zero, delta_positive: samples with current whose ``Δ`` (rad,
            folded onto ``(-π/2, π/2]``, relative to the drive's ``ζ̂``) is ``< -DELTA_ZERO``,
            within ``±DELTA_ZERO``, ``> DELTA_ZERO``.
        no_current: samples whose current amplitude is below 5 % of the median.
        angle_spread: 5–95 % range of the current direction ``ψ`` (rad), NaN with < 2 samples with current.
        magnitude_spread: ``sqrt(λ_min(cov p)) / rms|p|`` of the currents ``p = Γ^{-1} i`` in the bin
            (-; 0 when they lie on one line), NaN when the bin has no current.
        delta_median: median ``Δ`` (rad) of the samples with current, NaN when none.
        problem: per bin ``None`` or one of :data:`PROBLEMS`.
    """

    edges: np.ndarray
    samples: np.ndarray
    delta_negative: np.ndarray
    delta_zero: np.ndarray
    delta_positive: np.ndarray
    no_current: np.ndarray
    angle_spread: np.ndarray
    magnitude_spread: np.ndarray
    delta_median: np.ndarray
    problem: tuple

    def to_dict(self) -> dict:
        """JSON-ready dict of lists (NaN becomes ``null`` when written)."""
        return {"edges": self.edges, "samples": self.samples, "delta_negative": self.delta_negative,
                "delta_zero": self.delta_zero, "delta_positive": self.delta_positive,
                "no_current": self.no_current, "angle_spread": self.angle_spread,
                "magnitude_spread": self.magnitude_spread, "delta_median": self.delta_median,
                "problem": list(self.problem)}


@dataclass(frozen=True)
class CoilSetExcitation:
    """Excitation of one coil set ``coil_set`` (0-based).

    Attributes:
        files: logs in which this coil set is the active one (empty: none).
        samples: total samples; y_min, y_max: their position range (m), NaN without samples.
        bins: :class:`BinStats` over the report's position range, or ``None`` without data.
        problems: readable one-line messages (empty = fine).
        identify_check: what :func:`check_excitation` (the verdict identification acts on) says on this coil
            set's own range (what ``pgcomm identify`` would refuse); empty = accepted.
    """

    coil_set: int
    files: tuple
    samples: int
    y_min: float
    y_max: float
    bins: BinStats | None
    problems: tuple
    identify_check: tuple = ()

    @property
    def ok(self) -> bool:
        """``True`` when the data excite this coil set's model everywhere."""
        return not self.problems

    def to_dict(self) -> dict:
        """``check.coil_sets[l]`` of results.json."""
        return {"coil_set": self.coil_set + 1, "ok": self.ok, "problems": list(self.problems),
                "identify_check": list(self.identify_check), "files": list(self.files), "samples": self.samples,
                "y_range": [self.y_min, self.y_max], "bins": None if self.bins is None else self.bins.to_dict()}


@dataclass(frozen=True)
class ExcitationReport:
    """Excitation of every coil set over one position range.

    Attributes:
        coil_sets: one :class:`CoilSetExcitation` per coil set, in order.
        y_range: ``(lo, hi)`` (m) cut into bins; n_bins: number of bins.
        thresholds: ``min_samples``, ``min_angle`` (rad), ``min_spread`` (-), ``delta_zero`` (rad).
    """

    coil_sets: tuple
    y_range: tuple
    n_bins: int
    thresholds: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """``True`` when every coil set is excited."""
        return all(c.ok for c in self.coil_sets)

    @property
    def problems(self) -> list[str]:
        """All problem messages, coil set by coil set."""
        return [p for c in self.coil_sets for p in c.problems]

    def to_dict(self) -> dict:
        """The ``check`` block of results.json."""
        return {"ok": self.ok, "y_range": list(self.y_range), "n_bins": self.n_bins, "thresholds": self.thresholds,
                "coil_sets": [c.to_dict() for c in self.coil_sets]}


def group_logs(logs, motor: Motor) -> dict[int, list]:
    """Logs grouped by their active coil set: ``{l (0-based): [(log, currents (N, 2) A), ...]}``.

    Drive-input logs are converted with ``motor``'s ``k̂``, ``ζ̂`` (:func:`pgcomm.data.log_currents`).
    Coil sets without a log are absent from the dict (a finding for the report, not an error).

    Raises:
        DataError: a log with another number of coil sets than ``motor``, or with none or
            several coil sets carrying current.
    """
    groups: dict[int, list] = {}
    for log in logs:
        cur = log_currents(log, motor)
        if cur.shape[1] != motor.n_coil_sets:
            raise DataError(f"{log.source}: {cur.shape[1]} coil sets in the log, the motor has {motor.n_coil_sets} "
                            "(pass --motor MOTOR.toml)")
        l = active_coil_set(log, cur)
        groups.setdefault(l, []).append((log, cur[:, l, :]))
    return groups


def excitation_report(logs, motor: Motor, n_bins: int = DEFAULT_BINS, y_range=None, min_samples: int = MIN_SAMPLES,
                      min_angle: float = MIN_ANGLE, min_spread: float = MIN_SPREAD) -> ExcitationReport:
    """Excitation report of logs (:class:`pgcomm.io.logs.Log`) for every coil set of ``motor``.

    Args:
        logs: logs, each with one active coil set (data sets ``Z_i^l``); positions and currents
            (or drive inputs) are all the criterion needs, so logs without force columns (no
            force sensor) are checked alike.
        motor: coil-set count, pole pitch ``d_m`` and the drive's ``k̂``, ``ζ̂`` (drive-input
            logs are converted with them; ``Δ`` is measured against ``ζ̂``).
        n_bins: position bins over ``y_range``.
        y_range: ``(lo, hi)`` (m); default the span of ALL logs, so a coil set that covers
            less of the stroke than the others is flagged.
        min_samples, min_angle, min_spread: per-bin thresholds (the criterion of the module docstring).

    Returns:
        :class:`ExcitationReport`.
    """
    logs = list(logs)
    if not logs:
        raise DataError("no logs to check")
    if y_range is None:
        y_range = (min(float(lg["y"].min()) for lg in logs), max(float(lg["y"].max()) for lg in logs))
    lo, hi = map(float, y_range)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise DataError(f"position range [{lo:g}, {hi:g}] m is empty; the logs need motion (or give a range)")
    if not 1 <= int(n_bins) <= MAX_BINS:
        raise DataError(f"number of position bins {n_bins}: expected 1 to {MAX_BINS}")
    groups = group_logs(logs, motor)
    out = []
    for l in range(motor.n_coil_sets):
        if l not in groups:
            out.append(CoilSetExcitation(l, (), 0, float("nan"), float("nan"), None,
                                         (f"coil set {l + 1}: no log with this coil set active (every coil set needs "
                                          "its own experiments Z_1, Z_2)",)))
            continue
        members = groups[l]
        # the criterion needs positions and currents only: logs without a force sensor are checked alike
        y = np.concatenate([lg["y"] for lg, _ in members])
        data = CoilSetData(y, np.concatenate([c for _, c in members]), np.zeros((y.shape[0], 3)),
                           name=f"coil set {l + 1}")
        out.append(_coil_set_excitation(data, l, motor, n_bins, (lo, hi), min_samples, min_angle, min_spread,
                                       files=tuple(lg.source for lg, _ in members)))
    thresholds = {"min_samples": min_samples, "min_angle": min_angle, "min_spread": min_spread,
                  "delta_zero": DELTA_ZERO}
    return ExcitationReport(tuple(out), (lo, hi), int(n_bins), thresholds)


def _coil_set_excitation(data: CoilSetData, coil_set: int, motor: Motor, n_bins: int, y_range, min_samples: int,
                         min_angle: float, min_spread: float, files=()) -> CoilSetExcitation:
    """Per-bin excitation of one coil set: the criterion of the module docstring, with its numbers.

    Args:
        data: the coil set's samples (positions ``(N,)`` m, currents ``(N, 2)`` A).
        coil_set: 0-based index (``ζ̂ = motor.zeta[coil_set]`` is the reference of ``Δ``).
        motor: pole pitch and drive parameters. y_range: ``(lo, hi)`` (m), default the data's span.
        files: names of the logs (for the report).
    """
    y = data.y
    lo, hi = (float(y.min()), float(y.max())) if y_range is None else map(float, y_range)
    bins = _bin_stats(data, float(motor.pole_pitch), float(motor.zeta[coil_set]), np.linspace(lo, hi, int(n_bins) + 1),
                      min_samples, min_angle, min_spread)
    problems = _messages(coil_set, bins, min_samples)
    # What identification itself will say (its own range and bins): the report must not pass data it refuses.
    ident = tuple(check_excitation(data, motor.pole_pitch, n_bins=n_bins, min_samples=min_samples,
                                   min_angle=min_angle, min_spread=min_spread))
    if ident and not problems:
        problems = tuple(f"coil set {coil_set + 1}: pgcomm identify would refuse: {m}" for m in ident)
    return CoilSetExcitation(coil_set, tuple(files), data.n, float(y.min()), float(y.max()), bins, problems, ident)


def _bin_stats(data: CoilSetData, pole_pitch: float, zeta: float, edges, min_samples: int, min_angle: float,
               min_spread: float) -> BinStats:
    """The criterion per position bin (``edges`` ``(n_bins + 1,)`` m); ``Δ`` measured against ``zeta`` (rad)."""
    y = data.y
    n_bins = edges.shape[0] - 1
    lo, hi = float(edges[0]), float(edges[-1])
    # Current direction ψ relative to the electrical angle (k̂ = 1, ζ̂ = 0).
    amp, ang = _drive_inputs(y, data.currents[:, None, :], 1.0, 0.0, pole_pitch)
    # the drive inputs are signed (Fy*, Δ ∈ (-π/2, π/2]): the amplitude is |Fy*|, and ψ (mod π), Δ
    # below and the vector p do not depend on which of the two equivalent pairs is returned
    famp, ang = np.asarray(amp)[:, 0], np.asarray(ang)[:, 0]
    amp = np.abs(famp)
    psi = np.mod(ang, np.pi)
    p = np.stack([famp * np.cos(ang), famp * np.sin(ang)], axis=-1)  # Γ0^{-1} i: (F1*, F2*) per ampere
    # Δ relative to the drive's commutation angle, folded onto (-π/2, π/2].
    delta = np.pi / 2 - np.mod(np.pi / 2 - (ang - zeta), np.pi)
    which = np.clip(np.searchsorted(edges, y, side="right") - 1, 0, n_bins - 1)
    inside = (y >= lo) & (y <= hi)
    big = amp > _CURRENT_SHARE * max(float(np.median(amp)), 1e-300)

    def count(mask):
        return np.bincount(which[inside & mask], minlength=n_bins)

    samples = count(np.ones_like(inside))
    neg, pos = count(big & (delta < -DELTA_ZERO)), count(big & (delta > DELTA_ZERO))
    zero = count(big & (np.abs(delta) <= DELTA_ZERO))
    nan = np.full(n_bins, np.nan)
    angle_spread, mag_spread, delta_med = nan.copy(), nan.copy(), nan.copy()
    problem = []
    for b in range(n_bins):
        sel = inside & (which == b)
        sb = sel & big
        if sb.sum() >= 1:
            delta_med[b] = float(np.median(delta[sb]))
        if sb.sum() >= 2:
            z = np.exp(2j * psi[sb])  # doubling the angle makes ψ and ψ + π the same direction
            # deviations from one sample's direction, not from the mean: with Δ = ±π/4 in equal
            # shares the two doubled directions cancel and the mean has no direction at all
            dev = np.angle(z * np.conj(z[0])) / 2.0
            angle_spread[b] = float(np.percentile(dev, 95) - np.percentile(dev, 5))
        if sb.any():
            q = p[sel]
            lam = np.linalg.eigvalsh(np.cov(q.T, bias=True))[0]
            mag_spread[b] = float(np.sqrt(max(lam, 0.0) / np.mean(amp[sel] ** 2)))
        if sel.sum() < min_samples:
            problem.append("gap")
        elif sb.sum() < 2:
            problem.append("no current")
        elif angle_spread[b] < min_angle:
            problem.append("single direction")
        elif mag_spread[b] <= min_spread:
            problem.append("single magnitude")
        else:
            problem.append(None)
    return BinStats(edges, samples, neg, zero, pos, samples - neg - zero - pos, angle_spread, mag_spread, delta_med,
                    tuple(problem))


def problem_runs(problem) -> list[tuple[int, int, str]]:
    """Runs ``(first_bin, last_bin, kind)`` of consecutive bins with the same problem (``None`` runs left out)."""
    out, b, n = [], 0, len(problem)
    while b < n:
        end = b
        while end + 1 < n and problem[end + 1] == problem[b]:
            end += 1
        if problem[b] is not None:
            out.append((b, end, problem[b]))
        b = end + 1
    return out


def _messages(coil_set: int, bins: BinStats, min_samples: int) -> tuple:
    """One message per run of consecutive bins with the same problem."""
    e = bins.edges
    width = e[1] - e[0]
    # enough decimals to tell neighbouring edges apart (at least 3: millimetres)
    dec = max(3, int(np.ceil(-np.log10(width))) + 1) if width > 0 else 3
    head = f"coil set {coil_set + 1}:"
    out = []
    for b, end, kind in problem_runs(bins.problem):
        where = f"y in [{e[b]:.{dec}f}, {e[end + 1]:.{dec}f}] m"
        run = slice(b, end + 1)
        if kind == "gap":
            if bins.samples[run].sum() == 0:
                out.append(f"{head} no samples for {where}")
            else:
                out.append(f"{head} too few samples for {where} ({int(bins.samples[run].min())} in the "
                           f"sparsest bin, need {min_samples})")
        elif kind == "no current":
            out.append(f"{head} no current for {where}")
        elif kind == "single direction":
            d = float(np.nanmedian(bins.delta_median[run]))
            out.append(f"{head} a single current direction (one ratio ia:ib, Delta = {d:+.3f} rad) for {where}; "
                       "repeat the experiment with the opposite sign of Delta")
        else:
            out.append(f"{head} a single force magnitude per current direction for {where}; move at several "
                       "velocities and in both directions (different Fy*)")
    return tuple(out)


#: Words of :func:`check_excitation` for each problem kind.
_CHECK_WORDS = {"gap": "no data (gap)", "no current": "no current", "single direction": "one ratio ia:ib (a single Δ)",
                "single magnitude": "a single force magnitude"}


def check_excitation(data: CoilSetData, pole_pitch: float, n_bins: int = DEFAULT_BINS, y_range=None,
                     min_samples: int = MIN_SAMPLES, min_angle: float = MIN_ANGLE,
                     min_spread: float = MIN_SPREAD) -> list[str]:
    """Problems with persistent excitation (the paper's Remark), per position bin; empty = fine.

    The position range (``y_range`` or the data's own, m) is cut into ``n_bins`` equal bins,
    each judged by the criterion of the module docstring (gap, no current, a single
    ratio ``ia : ib``, a single force magnitude). Consecutive bins with the same problem are
    merged into one range. :func:`pgcomm.identify.identify` runs this check first.

    Args:
        data: one coil set's samples; pole_pitch: ``d_m`` (m).
        n_bins, y_range: position bins over ``y_range`` (m) or the data's range.
        min_samples, min_angle (rad), min_spread (-): the thresholds.

    Returns:
        one-line messages such as ``"y ∈ [0.01, 0.03] m: one ratio ia:ib (a single Δ)"``.
    """
    lo, hi = (float(data.y.min()), float(data.y.max())) if y_range is None else map(float, y_range)
    edges = np.linspace(lo, hi, int(n_bins) + 1)
    bins = _bin_stats(data, float(pole_pitch), 0.0, edges, min_samples, min_angle, min_spread)
    return [f"y ∈ [{edges[b]:.4g}, {edges[e + 1]:.4g}] m: {_CHECK_WORDS[kind]}" for b, e, kind in problem_runs(bins.problem)]
