"""The fleet table's rows and their QA: rows of every motor, robust z-scores, outliers (the files they go
to: :mod:`pgcomm.fleet.report`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pgcomm.defaults import DEFAULT_OUTLIER_Z
from pgcomm.fleet.motor import _FAILED, COLUMNS, QA_QUANTITIES, ROWS_FILE


def fleet_rows(out_dir, names) -> list[dict]:
    """Rows of :data:`COLUMNS` for motors ``names``: finished ones from ``OUT/NAME/fleet_rows.json``,
    failed ones from ``OUT/failed/NAME.json``; motors with neither (not run yet) have no row."""
    out_dir = Path(out_dir)
    rows = []
    for name in names:
        for path in (out_dir / name / ROWS_FILE, out_dir / _FAILED / f"{name}.json"):
            if path.is_file():
                rows += [{c: r.get(c) for c in COLUMNS} for r in json.loads(path.read_text())["rows"]]
                break
    return rows


def robust_z(x) -> np.ndarray:
    """Robust z-score ``z_j = (x_j − median x) / (1.4826 · MAD)``, ``MAD = median |x − median x|``.

    ``1.4826 · MAD`` estimates the standard deviation of normal data without being moved by
    the outliers themselves. When more than half the values are equal (``MAD = 0``) the mean
    absolute deviation ``· 1.2533`` is used instead (Iglewicz & Hoaglin); when all values are
    equal every score is 0. NaN entries (failed motors) stay NaN.

    Args:
        x: ``(N,)`` values.

    Returns:
        ``(N,)`` scores (-).
    """
    x = np.asarray(x, dtype=float)
    z = np.full(x.shape, np.nan)
    ok = np.isfinite(x)
    if not ok.any():
        return z
    v = x[ok]
    med = np.median(v)
    scale = 1.4826 * np.median(np.abs(v - med))
    if scale == 0:
        scale = 1.2533 * np.mean(np.abs(v - med))
    z[ok] = 0.0 if scale == 0 else (v - med) / scale
    return z


def flag_outliers(rows, threshold: float = DEFAULT_OUTLIER_Z, quantities=QA_QUANTITIES) -> list[dict]:
    """Values with ``|robust_z| > threshold`` among the ``ok`` rows, per quantity across the fleet.

    ``zeta`` is compared on the circle (each value wrapped to within ``π`` of the circular mean).

    Args:
        rows: fleet rows (:data:`COLUMNS`).
        threshold: robust z-score limit (-).
        quantities: columns to check.

    Returns:
        ``[{"motor", "coil_set", "quantity", "value", "median", "z"}]`` sorted by ``|z|`` descending.
    """
    ok = [r for r in rows if r.get("status") == "ok"]
    flags = []
    for q in quantities:
        x = np.array([np.nan if r.get(q) is None else r[q] for r in ok], dtype=float)
        if q == "zeta" and np.isfinite(x).any():
            c = np.angle(np.nanmean(np.exp(1j * x)))
            x = c + np.angle(np.exp(1j * (x - c)))
        z = robust_z(x)
        med = float(np.nanmedian(x)) if np.isfinite(x).any() else float("nan")
        for r, xi, zi in zip(ok, x, z):
            if np.isfinite(zi) and abs(zi) > threshold:
                flags.append({"motor": r["motor"], "coil_set": r["coil_set"], "quantity": q, "value": float(xi),
                              "median": med, "z": float(zi)})
    return sorted(flags, key=lambda f: -abs(f["z"]))


