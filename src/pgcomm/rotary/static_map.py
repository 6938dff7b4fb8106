"""A drive's own static cogging map as data (read by :mod:`pgcomm.io.static_map`): find the index offset between its
power-up and the logs', compare it with the table identified from running logs, and combine the two.

**What a static map measures.** A drive calibrates its anti-cogging table by holding the rotor at each angle in
position control and recording the q-current that holds it: the cogging, the drive's own current-measurement
errors (:func:`pgcomm.rotary.model.drive_orders`) and, per direction, half the friction's sign. Averaging a forward
and a reverse map removes the friction; a one-direction map carries it as a constant, which the comparison removes
(offsets are not compared). The table to compare with is the identified compensation at zero demand, in the drive's
sign (:meth:`pgcomm.rotary.model.RotaryModel.iq_comp`).

**File format.** :func:`pgcomm.io.static_map.read_static_map` reads it (the format is described there).

**The index between power-ups.** An incremental encoder's zero is where it found its index on that power-up; on a
real ODrive it moved by half a revolution between power-ups. Comparing misaligned maps reads as disagreement, so the
offset is found by circular cross-correlation and removed where it fits clearly better than none: the Fisher
``z = atanh(r)`` of the best shift exceeds that of no shift by three standard errors ``1/√(n − 3)``, ``n`` the map's
independent values (:func:`index_offset`).

**Both as one table.** The identified table and a static map measure the same cogging with errors of their own: the
table's is its standard error (``σ_m``, the RMS over the revolution), the map's (``σ_s``) is not stated by the drive.
Their difference, offsets and index removed, has a mean square ``σ_m² + σ_s²`` where the two errors are
independent, so ``σ_s² = max(mean((m − s)²) − σ_m², 0)``; the combined table is the inverse-variance mean
``m + w (s − m)`` with ``w = σ_m² / (σ_m² + σ_s²)`` the map's weight (its offset is the identified table's: a
one-direction map's holds friction). Whatever the two disagree on beyond the table's own error is taken as the map's
error: a repeatable drive's map (``σ_s`` below ``σ_m``) carries the combination, a map the logs contradict does not
(:func:`combine`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StaticMap:
    """A drive's static map on one revolution.

    Attributes:
        theta: ``(n,)`` mechanical angle from the index (rad), evenly spaced in ``[0, 2π)``.
        iq: ``(n,)`` holding q-current (A): the mean of both directions where the file has both, else its one.
        directions: ``2`` where both directions were averaged (friction removed), ``1`` otherwise.
        source: the file, for messages.
    """

    theta: np.ndarray
    iq: np.ndarray
    directions: int
    source: str


def _centred(x: np.ndarray) -> np.ndarray:
    return x - x.mean()


def correlation(a: np.ndarray, b: np.ndarray) -> float:
    """The correlation of two maps on one grid (their offsets removed)."""
    a, b = _centred(a), _centred(b)
    return float(a @ b / math.sqrt(max((a @ a) * (b @ b), 1e-300)))


def index_offset(reference: np.ndarray, other: np.ndarray, independent: int) -> dict:
    """The index offset between two maps on the same evenly spaced grid of one revolution: the circular shift of
    ``other`` that correlates best with ``reference``, taken where it beats no shift clearly (module docstring).

    Args:
        reference, other: ``(n,)`` maps (A).
        independent: the maps' independent values (e.g. twice the highest order the model resolves).

    Returns:
        a dict: ``shift`` (entries ``other`` is rolled by), ``rad`` (the offset), ``correlation_at_zero``,
        ``correlation`` (at the shift taken) and ``taken`` (bool).
    """
    a, b = _centred(np.asarray(reference, float)), _centred(np.asarray(other, float))
    n = a.size
    xc = np.fft.irfft(np.fft.rfft(a) * np.conj(np.fft.rfft(b)), n) / math.sqrt(max((a @ a) * (b @ b), 1e-300))
    best = int(np.argmax(xc))
    r0, rb = float(xc[0]), float(xc[best])
    se = 1.0 / math.sqrt(max(independent - 3, 1))
    z = lambda r: math.atanh(min(max(r, -0.999999), 0.999999))  # noqa: E731
    taken = best != 0 and z(rb) - z(r0) > 3 * se
    shift = best if taken else 0
    return {"shift": int(shift), "rad": float(2 * math.pi * (shift if shift <= n // 2 else shift - n) / n),
            "correlation_at_zero": r0, "correlation": rb if taken else r0, "taken": bool(taken)}


def compare(static: StaticMap, model, independent: int) -> dict:
    """The identified table at zero demand against a drive's static map, the index offset found and removed.

    Args:
        static: :class:`StaticMap`.
        model: :class:`pgcomm.rotary.model.RotaryModel`.
        independent: the maps' independent values (:func:`index_offset`).

    Returns:
        ``{"source", "points", "directions", "index_offset": {...}, "correlation", "rms_difference_share"}``: the
        correlation and the RMS of the difference (offsets removed) as a share of the static map's RMS, after the
        offset is removed.
    """
    n = static.theta.size
    grid = 2 * math.pi * np.arange(n) / n
    # the static map on an even grid from angle 0 (its own spacing), then the model there
    ref = np.interp(grid, static.theta, static.iq, period=2 * math.pi)
    ours = 0.5 * (model.iq_comp(grid, 1.0) + model.iq_comp(grid, -1.0))
    off = index_offset(ours, ref, independent)
    aligned = np.roll(ref, off["shift"])
    diff = _centred(ours) - _centred(aligned)
    rms = float(np.sqrt(np.mean(_centred(aligned) ** 2)))
    return {"source": static.source, "points": int(n), "directions": static.directions, "index_offset": off,
            "correlation": correlation(ours, aligned),
            "rms_difference_share": float(np.sqrt(np.mean(diff ** 2)) / rms) if rms > 0 else math.inf}


def combine(static: StaticMap, model, found: dict, model_rms_error: float) -> dict:
    """The identified table and a drive's static map as one table, each weighed by its error (module docstring).

    Args:
        static: :class:`StaticMap`; found: its :func:`compare` (the index offset it removed is removed here too).
        model: :class:`pgcomm.rotary.model.RotaryModel`.
        model_rms_error: the identified cogging's standard error, RMS over the revolution (A;
            ``identification.standard_error.cogging.rms_error``).

    Returns:
        dict: ``iq`` ``(n,)`` A on ``θ_j = 2π j / n`` (``n`` the map's points), ``map_aligned`` ``(n,)`` A (the map there,
        its index offset removed and its offset the table's), ``weight_static``, ``static_rms_error_A`` and
        ``model_rms_error_A``.
    """
    n = static.theta.size
    grid = 2 * math.pi * np.arange(n) / n
    aligned = np.roll(np.interp(grid, static.theta, static.iq, period=2 * math.pi), found["index_offset"]["shift"])
    ours = model.table(n)
    var_model = float(model_rms_error) ** 2
    var_static = max(float(np.mean((_centred(ours) - _centred(aligned)) ** 2)) - var_model, 0.0)
    # both errors zero (a noise-free model and a map that agrees with it): either table, the mean of both
    w = var_model / (var_model + var_static) if var_model + var_static > 0 else 0.5
    return {"iq": ours + w * (_centred(aligned) - _centred(ours)), "map_aligned": _centred(aligned) + ours.mean(),
            "weight_static": float(w),
            "static_rms_error_A": math.sqrt(var_static), "model_rms_error_A": math.sqrt(var_model)}


def text(found: dict) -> str:
    """One line on :func:`compare`'s result."""
    off = found["index_offset"]
    moved = (f"; the index sits {off['rad'] / (2 * math.pi):+.3f} revolution away (correlation "
             f"{off['correlation_at_zero']:.3f} as indexed): removed" if off["taken"] else "")
    return (f"static map {found['source']}: correlation {found['correlation']:.3f} with the identified table, RMS "
            f"difference {100 * found['rms_difference_share']:.0f} % of its RMS"
            f"{' (one direction: its friction is a constant, not compared)' if found['directions'] == 1 else ''}"
            f"{moved}")
