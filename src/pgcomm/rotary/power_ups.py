"""Running logs from several power-ups of one drive: the index offset between them, found and removed before the fit.

**Why.** An incremental encoder's zero is where the drive found its index on that power-up, and on a real ODrive it
moved by half a revolution between power-ups (the static maps of ``../real``). Logs of two power-ups then describe the
same motor in two frames: fitted together as they are, the cogging of one lies on the other's rotated by the offset,
and the table is neither (two ODrive logs, one of them re-indexed by half a revolution, gave a table that correlated
0.53 with the drive's static map, where the two in one frame give 0.99). Everything the table holds moves with the
rotor: the slot orders, and the drive's electrical orders too (its commutation is calibrated on the electrical angle,
which is the rotor's), so the whole map moves by the offset.

**Candidates from binned maps.** Each recording (a log file, its ``name``; the pieces it was split into at its gaps
are one, and logs without a name are one) is binned over the angle, as drives bin their calibration: the logged
current's mean per bin, each direction centred on its own mean (a direction's friction is a constant), on ``4 ×``
the highest order's bins. A recording whose bins do not cover :data:`MIN_COVERAGE` of the revolution is left as it is
(its binned map says too little). The first recording that covers it is the reference; every other one's circular
shift against it is :func:`pgcomm.rotary.static_map.index_offset`'s (the best shift, where its Fisher ``z`` beats no
shift by three standard errors, ``n`` the model's independent values): a candidate.

**Taken by the fit.** A binned current lags the angle by the speed loop's and a report filter's lag, so the binned
maps of recordings at different speeds are offset by the difference (two ODrive logs of one power-up, at 0.1 and 0.03
rev/s, by 1.8°, and the table fitted with that offset removed correlated 0.91 with the drive's map instead of 0.99).
So a candidate is only a start: once the logs are read as they are (the filter, the current's timing, the angle's
PLL), the fit finds the recording's best offset within :data:`REFINE_BINS` bins of it, and takes it only where it fits
better than none by the likelihood ratio every reading must pass
(:data:`pgcomm.rotary.readings.READING_EVIDENCE`); the logs are then read again in one frame (:func:`tested`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from pgcomm.rotary.static_map import index_offset

#: A recording's binned map stands for the revolution where this share of the bins holds samples.
MIN_COVERAGE = 0.95
#: The fit looks for a recording's offset within this many bins either way of its binned maps' (:func:`tested`).
REFINE_BINS = 3


def _bins(highest_order: int) -> int:
    """The binned maps' bins for a model up to ``highest_order`` per revolution."""
    return max(64, 4 * int(highest_order))


def _recording(log) -> str:
    """The file a log (or a piece of one split at its gaps: ``"FILE rows A-B"``) came from; ``""`` for a log without a
    name (logs given as arrays are taken as one recording)."""
    name = log.get("name", "") if isinstance(log, dict) else ""
    return str(name).split(" rows ")[0]


def binned_map(theta: np.ndarray, iq: np.ndarray, bins: int) -> np.ndarray | None:
    """The current's mean over ``bins`` equal bins of the revolution, each direction of travel centred on its own
    mean and the directions averaged where both hold a bin; empty bins interpolated circularly from their neighbours;
    ``None`` where fewer than :data:`MIN_COVERAGE` of the bins hold samples.

    Args:
        theta: ``(N,)`` multi-turn angle (rad); iq: ``(N,)`` logged q-current (A); bins: how many.

    Returns:
        ``(bins,)`` A, or ``None``.
    """
    th = np.asarray(theta, float)
    if th.size < 3:
        return None
    sign = np.sign(np.gradient(th))
    idx = np.floor(np.mod(th, 2 * math.pi) / (2 * math.pi) * bins).astype(int) % bins
    total, count = np.zeros(bins), np.zeros(bins)
    for s in (1.0, -1.0):
        on = sign == s
        if on.sum() < bins:
            continue
        n = np.bincount(idx[on], None, bins)
        mean = np.bincount(idx[on], iq[on], bins) / np.maximum(n, 1)
        held = n > 0
        total[held] += mean[held] - mean[held].mean()
        count[held] += 1
    held = count > 0
    if held.mean() < MIN_COVERAGE:
        return None
    out = np.where(held, total / np.maximum(count, 1), np.nan)
    grid = np.arange(bins)
    return out if held.all() else np.interp(grid, grid[held], out[held], period=bins)


def index_offsets(logs, highest_order: int) -> list:
    """The candidate index offset of every recording against the first that covers the revolution (module docstring).

    Args:
        logs: the running logs (dict-like, ``theta`` in rad, ``iq_1`` or ``iq`` in A, ``name`` where a file's);
        highest_order: the model's highest order per revolution.

    Returns:
        per recording other than the reference whose binned map suggests an offset: ``{"log", "binned_rad",
        "correlation_at_zero", "correlation"}`` (empty where fewer than two recordings cover the revolution).
    """
    bins = _bins(highest_order)
    recordings: dict[str, list[int]] = {}
    for i, log in enumerate(logs):
        recordings.setdefault(_recording(log), []).append(i)
    if len(recordings) < 2:
        return []
    maps = {}
    for name, members in recordings.items():
        th = np.concatenate([np.asarray(logs[i]["theta"], float) for i in members])
        iq = np.concatenate([np.asarray(logs[i]["iq_1"] if "iq_1" in logs[i] else logs[i]["iq"], float)
                             for i in members])
        m = binned_map(th, iq, bins)
        if m is not None:
            maps[name] = m
    names = list(maps)
    found = []
    for name in names[1:]:
        off = index_offset(maps[names[0]], maps[name], 2 * int(highest_order))
        if off["taken"]:
            found.append({"log": name, "binned_rad": off["rad"], "correlation_at_zero": off["correlation_at_zero"],
                          "correlation": off["correlation"]})
    return found


def tested(prepared, logs, found: list, cost, highest_order: int, taps: int) -> tuple[list, list]:
    """Each candidate offset tested by the fit (module docstring, "Taken by the fit").

    Args:
        prepared: the logs as the fit reads them (:class:`pgcomm.rotary.regression._Prepared`, their ``index`` into
            ``logs``); logs: the logs ``found`` was made from; found: :func:`index_offsets`'s candidates;
        cost: ``cost(prepared) -> (cost, rows)``, the basis fit under the logs' reading
            (:func:`pgcomm.rotary.regression._basis_cost`); highest_order: as :func:`index_offsets`; taps: the
            acceleration filter's.

    Returns:
        ``(prepared, found)``: the recordings' angles moved by the offsets taken, and each candidate with ``rad`` (the
        offset the fit found), ``evidence`` (its likelihood ratio over none) and ``taken``.
    """
    from scipy.optimize import minimize_scalar

    from pgcomm.rotary.readings import READING_EVIDENCE
    from pgcomm.rotary.regression import _evidence

    step = 2 * math.pi / _bins(highest_order)
    out, result = list(prepared), []
    for f in found:
        members = {k for k, p in enumerate(out) if _recording(logs[p.index]) == f["log"]}

        def moved(d, members=members):
            return [replace(p, theta=p.theta + d) if k in members else p for k, p in enumerate(out)]

        c0, rows = cost(out)
        span = REFINE_BINS * step
        res = minimize_scalar(lambda d: cost(moved(d))[0], bounds=(f["binned_rad"] - span, f["binned_rad"] + span),
                              method="bounded", options={"xatol": step / 50})
        evidence = _evidence(c0, float(res.fun), rows, taps) if res.fun < c0 else 0.0
        taken = evidence > READING_EVIDENCE
        if taken:
            out = moved(float(res.x))
        result.append({**f, "rad": float(res.x) if taken else 0.0, "evidence": float(evidence), "taken": taken})
    return out, result


def offsets_text(found: list) -> str | None:
    """One line on the index offsets taken between power-ups, or ``None`` where none was."""
    taken = [f for f in found if f["taken"]]
    if not taken:
        return None
    parts = ", ".join(f"{f['log']} by {math.degrees(f['rad']):+.1f}° (binned maps' correlation "
                      f"{f['correlation_at_zero']:.2f} -> {f['correlation']:.2f}; likelihood ratio {f['evidence']:.3g})"
                      for f in taken)
    return (f"the encoder's index moved between the logs' power-ups: re-aligned {parts} against the first log "
            "(check that these logs are of one motor and one mounting)")
