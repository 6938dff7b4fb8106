"""Data-based calibration of ``k̂^l`` and ``ζ̂^l`` (Algorithm 1, eqs. Ci and Update_Calibration).

With the drive's phase offset ``ζ̂_i = ζ̂ + (-1)^i Δ`` the ideal motor gives
``F_y = c_i F_y*`` with ``c_i = (k/k̂) cos(ζ - ζ̂_i)``. From the least-squares
coefficients ``ĉ_1, ĉ_2`` (eq. Ci):

    ζ̂ <- ζ̂_1 + atan((ĉ_2/ĉ_1 - cos 2Δ) / sin 2Δ)
    k̂ <- ĉ_1 k̂ / cos(ζ̂ - ζ̂_1)

(``ζ̂_1 = ζ̂ - Δ``). ``method="paper"`` estimates ``c_i`` by eq. Ci exactly. With forces
in the data that do not scale with the current, eq. Ci is biased: the loop's demand is
``F_y* = (F_tot - D)/c`` with ``D`` the cable-slab/cogging force and the
direction-dependent force, so ``ĉ_i/c_i - 1 ≈ (Σ F_tot D - Σ D²) / Σ F_tot²``. The
direction-dependent force correlates with the friction the loop must overcome, which
makes eq. Ci about 1-2 % high on the default twin.

``method="offset"`` (default) fits both data sets jointly, still by linear least squares,
with what they share as nuisance and the gain resolved along the stroke::

    F_y,i(t) = F_y*,i(t) (c_i(y) + ripple_i(y)) + b_sign(v)(y) + e(t),   |v| > v_min

* ``c_i(y)``: piecewise linear on ``gain_bins`` bins; ``ĉ_i`` is its mean over the stroke
  (the field varies along the stroke; only the mean is the fundamental);
* ``ripple_i``: 2nd and 6th electrical harmonics of ``2π y/d_m`` (winding imbalance and
  5th/7th field harmonics make force ripple proportional to the current);
* ``b_+``, ``b_-``: one offset table per direction of motion on ``n_bins`` bins (cable
  slab/cogging, the direction-dependent force, and the ripple of the friction the loop
  demands);
* samples slower than ``v_min`` (standstill, reversals) are left out.

``method="sensorless"`` (no force sensor, DESIGN.md "Without a force sensor") replaces the
measured force by the motion: ``m ÿ = F_y - c ẏ - F_c s(ẏ)``. The regression is the one of
``"offset"`` with ``m ÿ`` on the measured side and a viscous column ``ẏ`` added (the per-direction
offset tables already hold the Coulomb friction), every column and ``ÿ`` passed through the one
zero-phase filter of :mod:`pgcomm.sensorless` (windows never cross a data set or a slow sample).
The moving mass ``m`` is given.

The update equations are unchanged. On noise-free data from an ideal motor the methods
return the exact ``k``, ``ζ``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from pgcomm.errors import DataError
from pgcomm.interp import hat_basis
from pgcomm.data import active_coil_set, log_currents, velocity_from_positions
from pgcomm.sensorless import AccelerationFilter, filter_windows, filtered_acceleration, window_starts
from pgcomm.settings import CalibrationOptions


@dataclass(frozen=True)
class CalibrationStep:
    """One update of one coil set: coefficients ``c1, c2`` and the new ``k̂`` (N/A), ``ζ̂`` (rad).

    ``k_se`` (N/A) and ``zeta_se`` (rad) are the standard errors of the new values from the data's
    residuals (:func:`fit_coefficients` with ``return_cov``, propagated through eq.
    Update_Calibration); the step of a round is significant only above a few of them.
    """

    coil_set: int
    c1: float
    c2: float
    k: float
    zeta: float
    k_se: float = float("nan")
    zeta_se: float = float("nan")


@dataclass(frozen=True)
class CalibrationResult:
    """Calibrated ``k`` (L,) N/A and ``zeta`` (L,) rad, initial values, and the history of updates."""

    k: np.ndarray
    zeta: np.ndarray
    k_initial: np.ndarray
    zeta_initial: np.ndarray
    iterations: int
    history: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready: ``initial`` and ``calibrated`` ``{k (N/A), zeta (rad)}`` per coil set, ``iterations``,
        and of the last pass per coil set the ``standard_error`` ``{k, zeta}`` and the ``coefficients``
        ``{c1, c2}`` (empty lists without a history)."""
        steps = sorted(self.history[-1], key=lambda s: s.coil_set) if self.history else []
        return {"initial": {"k": [float(x) for x in self.k_initial], "zeta": [float(x) for x in self.zeta_initial]},
                "calibrated": {"k": [float(x) for x in self.k], "zeta": [float(x) for x in self.zeta]},
                "iterations": int(self.iterations),
                "standard_error": {"k": [s.k_se for s in steps], "zeta": [s.zeta_se for s in steps]},
                "coefficients": {"c1": [s.c1 for s in steps], "c2": [s.c2 for s in steps]}}


def fit_coefficients(set1, set2, options: CalibrationOptions = CalibrationOptions(), *, sample_time: float = 1e-3,
                     pole_pitch=None, mass: float | None = None, return_cov: bool = False):
    """Least-squares ``ĉ_1, ĉ_2`` of eq. Ci from the two data sets of one coil set.

    Args:
        set1, set2: ``(F_y, F_y*, y)`` of data set ``Z_i``: ``(N_i,)`` measured ``F_y`` (N), demanded ``F_y*`` (N),
            position (m).
        options: :class:`~pgcomm.settings.CalibrationOptions`: ``method`` ``"paper"`` (eq. Ci per data set) or ``"offset"`` (module
            docstring), with ``n_bins`` offset bins and ``gain_bins`` gain bins over ``y_range`` (m, default the
            data's range), samples with ``|v| <= min_speed`` (m/s; ``v`` from the positions and ``sample_time``, s)
            left out, ripple terms when ``pole_pitch`` (m) is given; or ``"sensorless"`` (module docstring; ``F_y``
            unused, ``mass`` (kg) and ``pole_pitch`` needed).
        return_cov: also return the ``(2, 2)`` covariance of ``(ĉ_1, ĉ_2)`` from the residuals
            (:func:`_block_covariance`: samples correlated within :data:`NOISE_BLOCK` seconds).

    Returns:
        ``(c1, c2)``, or ``(c1, c2, cov)`` with ``return_cov``.
    """
    (fy1, fs1, y1), (fy2, fs2, y2) = set1, set2
    fy1, fs1, fy2, fs2 = (np.asarray(a, float) for a in (fy1, fs1, fy2, fs2))
    method, n_bins, gain_bins, min_speed = options.method, options.n_bins, options.gain_bins, options.min_speed
    if method == "paper":
        c, var = [], []
        for fy, fs in ((fy1, fs1), (fy2, fs2)):
            den = float(fs @ fs)
            if den <= 0:
                raise DataError("calibration: the demanded force F_y* is zero throughout a data set")
            c.append(float(fy @ fs) / den)
            var.append(float(_block_covariance(fs[:, None], fy - c[-1] * fs,
                                               np.arange(fs.shape[0]) // _block(sample_time),
                                               np.ones((1, 1)))[0, 0]))
        return (c[0], c[1]) if not return_cov else (c[0], c[1], np.diag(var))
    y = np.concatenate([np.asarray(y1, float), np.asarray(y2, float)])
    lo, hi = (float(y.min()), float(y.max())) if options.y_range is None else options.y_range
    n1 = fy1.shape[0]
    sensorless = method == "sensorless"
    if sensorless:
        labels = (np.arange(y.shape[0]) >= n1).astype(int)
        v = velocity_from_positions(y, sample_time, labels)
    else:
        v = np.concatenate([np.gradient(np.asarray(y1, float)), np.gradient(np.asarray(y2, float))]) / sample_time
    # Standstill and reversals are left out: there the direction-dependent force and the
    # friction change shape with speed and no position-only term can describe them.
    keep = np.abs(v) > min_speed
    if keep.sum() < 10 * (n_bins + gain_bins):
        raise DataError(f"calibration: only {int(keep.sum())} samples move faster than {min_speed:g} m/s")
    # noise blocks never span the two data sets
    block = np.concatenate([np.arange(n1), 10**9 + np.arange(fy2.shape[0])]) // _block(sample_time)
    if sensorless:
        out = _sensorless_coefficients(y, v, np.concatenate([fs1, fs2]), labels, keep, lo, hi, sample_time, mass,
                                       pole_pitch, n_bins, gain_bins, block)
        return out if return_cov else out[:2]
    y, v = y[keep], v[keep]
    fs = np.concatenate([fs1, fs2])[keep]
    first = (np.arange(fy1.shape[0] + fy2.shape[0]) < n1)[keep]
    x, m = _offset_design(y, v, fs, first, lo, hi, pole_pitch, n_bins, gain_bins)
    target = np.concatenate([fy1, fy2])[keep]
    # pivoted QR: handles empty bins (rank deficiency) and is ~10x faster than SVD here
    theta = scipy.linalg.lstsq(x, target, lapack_driver="gelsy")[0]
    c1, c2 = _mean_gains(theta, m, gain_bins)
    if not return_cov:
        return c1, c2
    return c1, c2, _block_covariance(x, target - x @ theta, block[keep], _mean_weights(x.shape[1], m, gain_bins))


#: Length (s) of the blocks within which calibration residuals count as correlated (the force
#: sensor's noise is white, but model mismatch along the stroke and the loop's response are not).
NOISE_BLOCK = 0.5


def _block(sample_time: float) -> int:
    """Samples per :data:`NOISE_BLOCK`."""
    return max(1, int(round(NOISE_BLOCK / sample_time)))


def _block_covariance(x, resid, blocks, g):
    """Covariance of ``g θ̂`` for the least-squares ``θ̂`` of ``x θ ≈ b`` with residuals ``resid``.

    The sandwich ``G A (Σ_b x_bᵀ r_b r_bᵀ x_b) Aᵀ Gᵀ``, ``A = (xᵀx)^+``, with the samples of a
    block ``b`` (equal labels in ``blocks``, contiguous) as one cluster: residuals may be
    correlated within a block, not between blocks.

    Args:
        x: ``(N, p)``; resid: ``(N,)``; blocks: ``(N,)`` labels, non-decreasing; g: ``(q, p)``.

    Returns:
        ``(q, q)``.
    """
    ga = g @ np.linalg.pinv(x.T @ x)
    starts = np.flatnonzero(np.r_[True, np.diff(blocks) != 0])
    scores = np.add.reduceat(x * resid[:, None], starts, axis=0) @ ga.T    # (blocks, q)
    return scores.T @ scores


def _mean_weights(p, m, gain_bins):
    """``(2, p)`` rows that give ``(ĉ_1, ĉ_2)`` from ``θ`` (:func:`_mean_gains` as a matrix)."""
    g = np.zeros((2, p))
    w = np.full(gain_bins + 1, 1.0 / gain_bins)
    w[[0, -1]] *= 0.5
    g[0, : gain_bins + 1] = w
    g[1, m: m + gain_bins + 1] = w
    return g


def _offset_design(y, v, fs, first, lo, hi, pole_pitch, n_bins, gain_bins):
    """Columns of method ``"offset"`` ``(N, 2 m + 2 (n_bins + 1))`` and ``m`` (columns per data set)."""
    # Position-resolved gain c_i(y) on a coarse grid (the field varies along the stroke; its
    # mean is the fundamental) and current-proportional ripple at the 2nd (winding imbalance)
    # and 6th (5th/7th field harmonics) electrical harmonics, separately per data set.
    gain = hat_basis(y, lo, hi, gain_bins)
    cols = [gain]
    if pole_pitch:
        w = 4 * np.pi / pole_pitch
        cols += [np.stack([np.cos(h * w * y), np.sin(h * w * y)], axis=1) for h in (1, 3)]
    per_set = np.hstack(cols) * fs[:, None]
    # Shared nuisance: one offset table per direction of motion (cogging, direction-dependent
    # force, and the ripple of the friction force the loop demands).
    hats = hat_basis(y, lo, hi, n_bins)
    nuisance = np.hstack([hats * (v > 0)[:, None], hats * (v < 0)[:, None]])
    return np.hstack([per_set * first[:, None], per_set * ~first[:, None], nuisance]), per_set.shape[1]


def _mean_gains(theta, m, gain_bins):
    """``(ĉ_1, ĉ_2)``: the stroke means of the piecewise-linear gains ``c_i(y)`` in ``theta``
    (trapezoid means of piecewise-linear functions over ``[lo, hi]``)."""
    c = _mean_weights(theta.shape[0], m, gain_bins) @ theta
    return float(c[0]), float(c[1])


def _sensorless_coefficients(y, v, fs, labels, keep, lo, hi, sample_time, mass, pole_pitch, n_bins, gain_bins,
                             block):
    """``(ĉ_1, ĉ_2, cov)`` of method ``"sensorless"``: the ``"offset"`` columns and ``ẏ``, filtered, against
    ``m ÿ_f`` (``block``: noise-block label per sample, for the covariance)."""
    if not (mass is not None and mass > 0):
        raise DataError(f"calibration without a force sensor needs the moving mass (kg), got {mass!r}")
    if not pole_pitch:
        raise ValueError("method 'sensorless' needs the pole pitch")
    filt = AccelerationFilter.for_motion(v, sample_time, pole_pitch)
    starts = window_starts(filt, labels, keep)
    if starts.size < 4 * (n_bins + gain_bins):
        raise DataError(f"calibration: only {starts.size} windows of {filt.span} samples move faster than "
                        "the minimum speed; the data sets are too short or too slow for calibration without a "
                        "force sensor")
    x, m = _offset_design(y, v, fs, labels == 0, lo, hi, pole_pitch, n_bins, gain_bins)
    xf = filter_windows(filt, starts, np.column_stack([x, v]))
    target = mass * filtered_acceleration(filt, starts, y)
    theta = scipy.linalg.lstsq(xf, target, lapack_driver="gelsy")[0]
    c1, c2 = _mean_gains(theta, m, gain_bins)
    return c1, c2, _block_covariance(xf, target - xf @ theta, block[starts], _mean_weights(xf.shape[1], m, gain_bins))


def update(c1: float, c2: float, k_hat: float, zeta_hat: float, delta: float):
    """Update of eq. Update_Calibration; returns ``(k_new, zeta_new)`` (N/A, rad).

    Args:
        c1, c2: coefficients of data sets ``i = 1`` (``ζ̂ - Δ``) and ``i = 2`` (``ζ̂ + Δ``).
        k_hat, zeta_hat: drive values used to generate the data; delta: ``Δ`` (rad), ``0 < |Δ| < π/2``.
    """
    if c1 == 0:
        raise DataError("calibration: coefficient c1 is zero; the coil set produced no driving force")
    zeta1 = zeta_hat - delta
    x = np.arctan((c2 / c1 - np.cos(2 * delta)) / np.sin(2 * delta))
    zeta_new = zeta1 + x
    return float(c1 * k_hat / np.cos(x)), float(zeta_new)


def calibrate_from_datasets(datasets, k_hat, zeta_hat, delta: float, method: str = "offset",
                            n_bins: int = 40, pole_pitch=None, mass: float | None = None) -> list[CalibrationStep]:
    """One pass of Algorithm 1 over coil sets, from already generated data sets.

    Args:
        datasets: ``datasets[l] = (Z_1, Z_2)``, each with ``.result.f_meas``, ``.result.f_star``,
            ``.result.y_meas`` and ``.coil_set`` (see :func:`pgcomm.data.generate_datasets`).
        k_hat, zeta_hat: ``(L,)`` values the data were generated with.
        delta: ``Δ`` (rad). mass: moving mass (kg), method ``"sensorless"`` only (``f_meas`` unused).

    Returns:
        one :class:`CalibrationStep` per coil set in ``datasets``.
    """
    steps = []
    for z1, z2 in datasets:
        r1, r2 = z1.result, z2.result
        steps.append(_step(z1.coil_set, (r1.f_meas[:, 0], r1.f_star[:, 0], r1.y_meas),
                           (r2.f_meas[:, 0], r2.f_star[:, 0], r2.y_meas), r1.sample_time, k_hat, zeta_hat, delta,
                           method, n_bins, pole_pitch, mass))
    return steps


def calibrate_from_logs(logs, motor, method: str = "offset", n_bins: int = 40) -> CalibrationResult:
    """Algorithm 1 (one pass) from logged data sets ``Z_1^l, Z_2^l``, e.g. the files of ``pgcomm calibrate --save-data``.

    Each log is one experiment with one coil set carrying current (:func:`pgcomm.data.active_coil_set`)
    and the drive's fixed commutation at ``motor``'s nominal ``k̂``, ``ζ̂`` with a constant phase
    offset ``Δ``. The offset is read from the drive inputs ``(Fy_ref_l, delta_l)``: in the log
    format ``Fy_ref_l`` is signed and ``delta_l`` stays at ``±Δ0``; logs of older writers with
    ``Fy_ref_l ≥ 0`` are read too (where ``Fy_ref_l`` and ``Fy_star`` have opposite signs the
    applied offset is ``delta_l + π``). Per coil set exactly one log with ``Δ = −Δ0`` and one
    with ``+Δ0`` are needed. The coefficients and the update are those of
    :func:`calibrate_from_datasets` (the same numbers as calibrating on the simulated data sets).

    Args:
        logs: :class:`pgcomm.io.logs.Log` list with ``y``, ``Fy``, ``Fy_star`` and per coil set
            ``Fy_ref_l``, ``delta_l`` (and currents ``ia_l, ib_l`` or not).
        motor: :class:`pgcomm.motor.Motor`: the drive's ``k̂`` (L,) N/A, ``ζ̂`` (L,) rad, pole pitch (m),
            and for ``method="sensorless"`` the moving mass (kg).
        method, n_bins: as :func:`fit_coefficients`; ``"sensorless"`` needs no ``Fy`` column.

    Returns:
        :class:`CalibrationResult` with ``iterations = 1``.

    Raises:
        DataError: missing columns, no or several active coil sets in a log, a coil set without
            exactly one log of each sign of ``Δ``, or ``|Δ|`` that differs between the two logs.
    """
    mass = None
    if method == "sensorless":
        if motor.mass is None:
            raise DataError("calibration without a force sensor needs the moving mass: add mass = ... (kg) to the "
                            "motor TOML")
        mass = motor.mass
    L = motor.n_coil_sets
    groups: dict[int, dict[int, tuple]] = {}
    for log in logs:
        di = log.drive_inputs()
        if di is None or "Fy_star" not in log:
            raise DataError(f"{log.source}: calibration needs the drive inputs Fy_ref_l, delta_l and the demanded "
                            "force Fy_star (as pgcomm calibrate --save-data writes them)")
        if "Fy" not in log and method != "sensorless":
            raise DataError(f"{log.source}: calibration from logs needs the measured force Fy (a force sensor); "
                            "this log has none (without a force sensor: method 'sensorless', "
                            "pgcomm calibrate --no-force-sensor)")
        l = active_coil_set(log, log_currents(log, motor))
        fy_ref, dl = di[0][:, l], di[1][:, l]
        fs = log["Fy_star"]
        use = np.abs(fs) > 1e-6 * max(float(np.max(np.abs(fs))), 1e-300)
        if not use.any():
            raise DataError(f"{log.source}: the demanded force Fy_star is zero throughout")
        applied = dl[use] + np.pi * (np.sign(fy_ref[use]) * np.sign(fs[use]) < 0)
        d = float(np.angle(np.mean(np.exp(1j * applied))))
        if abs(d) < 1e-3 or abs(d) > np.pi / 2 - 1e-3:
            raise DataError(f"{log.source}: phase offset Delta = {d:.4g} rad; Algorithm 1 needs 0 < |Delta| < pi/2")
        sign = 1 if d > 0 else -1
        if sign in groups.setdefault(l, {}):
            raise DataError(f"{log.source} and {groups[l][sign][0].source}: two logs of coil set {l + 1} with "
                            f"Delta {'>' if sign > 0 else '<'} 0; expected one with -Delta0 and one with +Delta0")
        groups[l][sign] = (log, d)
    missing = [f"coil set {l + 1} ({'-' if -1 not in groups.get(l, {}) else '+'}Delta)" for l in range(L)
               if len(groups.get(l, {})) != 2]
    if missing:
        raise DataError(f"calibration: no log for {', '.join(missing)}; every coil set needs one log with "
                        "Delta = -Delta0 and one with +Delta0")
    k0, z0 = np.asarray(motor.k, float), np.asarray(motor.zeta, float)
    k, zeta, steps = k0.copy(), z0.copy(), []
    for l in range(L):
        (g1, d1), (g2, d2) = groups[l][-1], groups[l][1]
        if abs(d1 + d2) > 1e-3 * abs(d2):
            raise DataError(f"{g1.source}, {g2.source}: Delta = {d1:.6g} and {d2:.6g} rad are not opposite")
        fy1, fy2 = ((g["Fy"] if "Fy" in g else np.zeros_like(g["y"])) for g in (g1, g2))  # sensorless: unused
        s = _step(l, (fy1, g1["Fy_star"], g1["y"]), (fy2, g2["Fy_star"], g2["y"]), g1.sample_time,
                  k0, z0, 0.5 * (d2 - d1), method, n_bins, motor.pole_pitch, mass)
        k[l], zeta[l] = s.k, s.zeta
        steps.append(s)
    return CalibrationResult(k=k, zeta=zeta, k_initial=k0, zeta_initial=z0, iterations=1, history=[steps])


def _step(l, set1, set2, sample_time, k_hat, zeta_hat, delta, method, n_bins, pole_pitch,
          mass=None) -> CalibrationStep:
    """Coefficients of eq. Ci from ``set_i = (Fy, Fy*, y)`` of coil set ``l`` and the update of eq. Update_Calibration."""
    c1, c2, cov = fit_coefficients(set1, set2, CalibrationOptions(method=method, n_bins=n_bins),
                                   sample_time=sample_time, pole_pitch=pole_pitch, mass=mass, return_cov=True)
    k_new, z_new = update(c1, c2, float(k_hat[l]), float(zeta_hat[l]), delta)
    # first-order propagation of cov(c1, c2) through the update (central differences)
    jac = np.zeros((2, 2))
    for j, c in enumerate((c1, c2)):
        h = 1e-6 * max(abs(c1), abs(c2))
        dc = np.zeros(2)
        dc[j] = h
        hi = update(c1 + dc[0], c2 + dc[1], float(k_hat[l]), float(zeta_hat[l]), delta)
        lo = update(c1 - dc[0], c2 - dc[1], float(k_hat[l]), float(zeta_hat[l]), delta)
        jac[:, j] = (np.asarray(hi) - np.asarray(lo)) / (2 * h)
    var = np.diag(jac @ cov @ jac.T)
    return CalibrationStep(l, c1, c2, k_new, z_new, float(np.sqrt(var[0])), float(np.sqrt(var[1])))


def calibrate(generate, k0, zeta0, options: CalibrationOptions = CalibrationOptions(), *, pole_pitch=None,
              mass: float | None = None, progress=None) -> CalibrationResult:
    """Algorithm 1, optionally iterated until the update is below ``options.tol``.

    Args:
        generate: ``generate(k_hat (L,), zeta_hat (L,)) -> datasets`` producing ``Z_{1,2}^l``
            with the drive set to those values (e.g. a closure over
            :func:`pgcomm.data.generate_datasets` on the twin).
        k0, zeta0: ``(L,)`` initial ``k̂`` (N/A), ``ζ̂`` (rad).
        options: :class:`~pgcomm.settings.CalibrationOptions` (``delta`` the data sets' ``Δ``; ``iterations`` the maximum passes,
            fewer when ``max |Δk̂/k̂|`` and ``max |Δζ̂|`` (rad) are both below ``tol``; ``method``, ``n_bins``).
        pole_pitch: ``d_m`` (m) for the ripple terms of ``method="offset"``.
        mass: moving mass (kg) for ``method="sensorless"`` (no force data used).
        progress: optional callable ``progress(iteration, k, zeta)``.

    Returns:
        :class:`CalibrationResult`.
    """
    k = np.asarray(k0, float).copy()
    zeta = np.asarray(zeta0, float).copy()
    history = []
    it = 0
    for it in range(1, options.iterations + 1):
        steps = calibrate_from_datasets(generate(k, zeta), k, zeta, options.delta, method=options.method,
                                        n_bins=options.n_bins, pole_pitch=pole_pitch, mass=mass)
        k_new, z_new = k.copy(), zeta.copy()
        for s in steps:
            k_new[s.coil_set], z_new[s.coil_set] = s.k, s.zeta
        change = max(np.max(np.abs(k_new - k) / np.abs(k)), np.max(np.abs(z_new - zeta)))
        k, zeta = k_new, z_new
        history.append(steps)
        if progress:
            progress(it, k, zeta)
        if change < options.tol:
            break
    return CalibrationResult(k=k, zeta=zeta, k_initial=np.asarray(k0, float), zeta_initial=np.asarray(zeta0, float),
                             iterations=it, history=history)


#: A round's step is within its noise when it is at most this many standard errors of the new values.
CONVERGENCE_SE = 3.0


def convergence(result: CalibrationResult, tol: float = 1e-4, n_se: float = CONVERGENCE_SE) -> dict:
    """Whether one round of Algorithm 1 has converged: the step from the drive's values is within the noise.

    Per coil set the step ``k̂_new/k̂ − 1`` (relative) and ``ζ̂_new − ζ̂`` (rad) is compared with the
    tolerance ``max(tol, n_se · √2 · SE)``, ``SE`` the standard error of the new value
    (:class:`CalibrationStep`): at the fixed point the step is the difference of two rounds'
    estimates, each with about this round's ``SE``, so a smaller step cannot be told from noise and
    another round would only move the values within it. Measured on the twin: the update is
    insensitive to the drive's values near the fixed point (a 0.1 % or 1 mrad change of ``k̂`` or
    ``ζ̂`` moves the new values by < 1e-5 relative and < 1 µrad), and over 10 noise seeds the spread of
    ``ζ̂`` was 1.45 times the residual-based ``SE`` (``k̂``: 1.05 times), which ``n_se = 3`` covers.

    Args:
        result: one round (``result.history[-1]`` holds its steps), e.g. :func:`calibrate_from_logs`.
        tol: floor of both tolerances (relative for ``k``, rad for ``ζ``), the settings' ``[calibration] tol``.
        n_se: standard errors a step may reach and still count as noise.

    Returns:
        ``{"step": {"k_relative": (L,), "zeta_rad": (L,)}, "standard_error": {...}, "tolerance": {...},``
        ``"converged": bool, "rule": str}``.
    """
    steps = sorted(result.history[-1], key=lambda s: s.coil_set)
    k_step = result.k / result.k_initial - 1.0
    z_step = result.zeta - result.zeta_initial
    k_se = np.array([s.k_se / s.k for s in steps])
    z_se = np.array([s.zeta_se for s in steps])
    k_tol = np.maximum(tol, n_se * np.sqrt(2.0) * np.nan_to_num(k_se, nan=0.0))
    z_tol = np.maximum(tol, n_se * np.sqrt(2.0) * np.nan_to_num(z_se, nan=0.0))
    converged = bool(np.all(np.abs(k_step) <= k_tol) and np.all(np.abs(z_step) <= z_tol))
    return {"step": {"k_relative": k_step, "zeta_rad": z_step},
            "standard_error": {"k_relative": k_se, "zeta_rad": z_se},
            "tolerance": {"k_relative": k_tol, "zeta_rad": z_tol}, "converged": converged,
            "rule": f"every |step| <= max({tol:g}, {n_se:g} x sqrt(2) x the new value's standard error)"}
