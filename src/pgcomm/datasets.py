"""Data sets ``Z_i^l`` (eq. DataSets): one coil set active, fixed-commutation drive with ``Δ = ∓Δ0``.

For each coil set ``l`` and ``i = 1, 2`` the closed loop runs the reference with the
drive law (eq. Commutation_Solution_With_PhaseOffset) on coil set ``l`` only,
``Fy^l* = Fy*`` and ``Δ^l = (-1)^i Δ0``, no feedforward (paper, §Experimental results).
All ``2L`` experiments share one compiled simulation and run batched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pgcomm.commutation import DriveInputLaw
from pgcomm.control import PID
from pgcomm.mechanics import Mechanics
from pgcomm.motor import Motor
from pgcomm.sensors import Sensors
from pgcomm.simulate import SimResult, simulate_many


@dataclass(frozen=True)
class DataSet:
    """One experiment ``Z_i^l``: coil set ``coil_set`` (0-based), phase offset ``delta`` (rad), and its run."""

    coil_set: int
    delta: float
    result: SimResult

    def columns(self) -> dict[str, np.ndarray]:
        """Log columns (DESIGN.md format) plus ``experiment`` and ``active_coil_set`` (1-based)."""
        cols = dict(self.result.columns())
        n = self.result.t.shape[0]
        cols["active_coil_set"] = np.full(n, float(self.coil_set + 1))
        return cols


def generate_datasets(plant, drive: Motor, reference, *, delta: float = np.pi / 4, pid: PID | None = None,
                      mechanics: Mechanics = Mechanics(), sensors: Sensors = Sensors(), seed: int = 0,
                      coil_sets=None) -> list[list[DataSet]]:
    """Generate ``Z_1^l, Z_2^l`` for every coil set (eq. DataSets).

    Args:
        plant: electromagnetic truth (twin or force map).
        drive: the drive's fixed commutation ``k̂^l``, ``ζ̂^l`` (current estimates), sample time, limit.
        reference: :class:`pgcomm.trajectory.Reference`, e.g. the paper's data-generation reference.
        delta: ``Δ0`` (rad); ``|Δ0| <= π/4`` for safety as in the paper.
        seed: base noise seed; experiment ``(l, i)`` uses ``seed + 2 l + i``.
        coil_sets: which coil sets (0-based), default all.

    Returns:
        ``out[l][i]`` for ``i = 0`` (``Δ = -Δ0``) and ``i = 1`` (``Δ = +Δ0``).
    """
    coil_sets = list(range(drive.n_coil_sets)) if coil_sets is None else list(coil_sets)
    laws, keys = [], []
    for l in coil_sets:
        for i, sgn in enumerate((-1.0, 1.0)):
            laws.append(DriveInputLaw.for_coil_set(drive, l, sgn * delta))
            keys.append((l, sgn * delta, seed + 2 * l + i))
    runs = simulate_many(plant, laws, reference, drive=drive, pid=pid, mechanics=mechanics, sensors=sensors,
                         seeds=[k[2] for k in keys])
    out = []
    for j, l in enumerate(coil_sets):
        out.append([DataSet(l, keys[2 * j + i][1], runs[2 * j + i]) for i in range(2)])
    return out
