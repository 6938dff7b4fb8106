"""From logs (files a rig or ``pgcomm simulate`` wrote) to identification data per coil set.

Algorithm 2 identifies each coil set from experiments in which only that coil set
carried current (data sets ``Z_i^l``). A log is assigned to the coil set that carries
current in it; logs holding drive inputs ``(Fy_ref_l, delta_l)`` instead of currents are
converted with the drive's fixed commutation ``i = Γ(y) T(Fy*, Δ)`` (``k̂``, ``ζ̂`` of the
motor description).
"""

from __future__ import annotations

import numpy as np

from pgcomm.commutation import drive_currents
from pgcomm.errors import DataError
from pgcomm.identify import CoilSetData
from pgcomm.motor import Motor

#: A coil set counts as active in a log when its RMS current exceeds this share of the largest.
ACTIVE_SHARE = 1e-3


def log_currents(log, motor: Motor) -> np.ndarray:
    """Star currents ``(N, L, 2)`` (A) of a log: logged currents, or drive inputs converted by ``motor``'s drive."""
    cur = log.currents()
    if cur is not None:
        return cur
    di = log.drive_inputs()
    if di is None:
        raise DataError(f"{log.source}: needs currents ia_l, ib_l or drive inputs Fy_ref_l, delta_l per coil set")
    fy, delta = di
    if fy.shape[1] != motor.n_coil_sets:
        raise DataError(f"{log.source}: {fy.shape[1]} coil sets in the log, the motor has {motor.n_coil_sets}")
    return np.asarray(drive_currents(log["y"], fy, delta, np.asarray(motor.k), np.asarray(motor.zeta),
                                     motor.pole_pitch))


def active_coil_set(log, currents: np.ndarray) -> int:
    """0-based index of the only coil set carrying current in ``log``; refuses logs with none or several."""
    rms = np.sqrt(np.mean(currents**2, axis=(0, 2)))
    if rms.max() <= 0:
        raise DataError(f"{log.source}: no coil set carries current")
    active = np.flatnonzero(rms > ACTIVE_SHARE * rms.max())
    if active.size != 1:
        names = ", ".join(str(a + 1) for a in active)
        raise DataError(f"{log.source}: coil sets {names} all carry current; identification needs logs with one "
                        "coil set active (data sets Z_i^l)")
    return int(active[0])


def coil_set_data_from_logs(logs, motor: Motor) -> list[CoilSetData]:
    """Group logs by active coil set into :class:`~pgcomm.identify.CoilSetData` (one per coil set, in order).

    Each log becomes one experiment label. Raises :class:`DataError` naming the coil sets
    that no log excites.
    """
    groups: dict[int, list] = {}
    for log in logs:
        cur = log_currents(log, motor)
        if cur.shape[1] != motor.n_coil_sets:
            raise DataError(f"{log.source}: {cur.shape[1]} coil sets in the log, the motor has {motor.n_coil_sets}")
        l = active_coil_set(log, cur)
        groups.setdefault(l, []).append((log, cur[:, l, :]))
    missing = [l + 1 for l in range(motor.n_coil_sets) if l not in groups]
    if missing:
        raise DataError(f"no log with coil set(s) {', '.join(map(str, missing))} active; "
                        f"got {sum(len(g) for g in groups.values())} log(s)")
    out = []
    for l in range(motor.n_coil_sets):
        ys, cs, fs, ex = [], [], [], []
        for i, (log, cur) in enumerate(groups[l]):
            ys.append(log["y"])
            cs.append(cur)
            fs.append(log.force())
            ex.append(np.full(len(log["y"]), i))
        out.append(CoilSetData(np.concatenate(ys), np.concatenate(cs), np.concatenate(fs), np.concatenate(ex),
                               name=f"coil set {l + 1} ({', '.join(lg.source for lg, _ in groups[l])})"))
    return out
