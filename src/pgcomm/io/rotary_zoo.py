"""A rotary zoo motor's folder: ``motor.toml`` (the user's view), ``truth.json`` (the twin), and the logs its drive
records (:mod:`pgcomm.rotary.zoo` draws the motors and simulates the logs; this module writes and reads the files).

A drive log is CSV: ``t, theta, velocity, iq_1, id_1`` and ``vq_1``, ``vd_1`` (V) when the twin has a winding, the
stamps as they are (a host's: non-uniform), to 12 digits: what :func:`pgcomm.io.logs.read_log` reads.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.io.atomic import atomic_open, atomic_write_text
from pgcomm.io.config import rotary_motor_to_toml
from pgcomm.rotary.twin import RotaryTruth
from pgcomm.rotary.zoo import running_logs, sweep_log

__all__ = ["write_rotary_motor", "read_truth", "write_running_logs", "write_sweep_log", "write_drive_log",
           "write_host_log"]

#: The columns of a drive log, in the order written (those the twin's run has).
DRIVE_LOG_COLUMNS = ("t", "theta", "velocity", "iq_1", "id_1", "vq_1", "vd_1")


def write_rotary_motor(truth: RotaryTruth, folder) -> Path:
    """Write ``folder/motor.toml`` (kind = "rotary", the user's view) and ``folder/truth.json``; returns ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write_text(folder / "motor.toml", rotary_motor_to_toml(truth.motor))
    atomic_write_text(folder / "truth.json", json.dumps(truth.to_dict(), indent=1) + "\n")
    return folder


def read_truth(path) -> RotaryTruth:
    """A ``truth.json`` written by :func:`write_rotary_motor`.

    Raises:
        DataError: the file is missing or is not a rotary truth file.
    """
    try:
        with open(path, encoding="utf-8") as f:
            return RotaryTruth.from_dict(json.load(f))
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except (ValueError, KeyError, TypeError) as e:
        raise DataError(f"{path}: not a rotary truth file ({' '.join(str(e).split())})") from None


def write_running_logs(truth: RotaryTruth, folder, seed: int = 0, stall: bool = False) -> list[str]:
    """Simulate the running logs (:func:`pgcomm.rotary.zoo.running_logs`) and write them to ``folder/run{k}.csv``
    (and ``folder/stall.csv`` with ``stall``); returns the file names."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = []
    for name, log in running_logs(truth, seed=seed, stall=stall):
        write_drive_log(folder / f"{name}.csv", log)
        names.append(f"{name}.csv")
    return names


def write_sweep_log(truth: RotaryTruth, folder, seed: int = 0, revolution_seconds: float = 60.0) -> Path:
    """Simulate the standstill sweep (:func:`pgcomm.rotary.zoo.sweep_log`) and write it as ``folder/sweep.csv``;
    returns its path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "sweep.csv"
    write_drive_log(path, sweep_log(truth, seed=seed, revolution_seconds=revolution_seconds))
    return path


def write_drive_log(path: Path, log: dict) -> None:
    """Write what a drive records of a twin's run as CSV (module docstring), atomically.

    Args:
        path: the file; log: columns (:data:`DRIVE_LOG_COLUMNS`, those present), each ``(N,)``.
    """
    cols = [c for c in DRIVE_LOG_COLUMNS if c in log]
    with atomic_open(path) as f:
        f.write(",".join(cols) + "\n")
        np.savetxt(f, np.column_stack([log[c] for c in cols]), delimiter=",", fmt="%.12g")


def write_host_log(truth: RotaryTruth, folder, log: dict, slots: bool = True) -> Path:
    """Write ``log`` as a host's script records a drive's telemetry: ``folder/log.csv`` with the stamp (s), the position
    in revolutions and the q-current (A), nothing else; ``folder/columns.toml``, the column map for it; and
    ``folder/motor.toml`` with what a datasheet gives (pole pairs, ``k_t``, the current limit, the median step), the
    slots only with ``slots``. Returns ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    m = truth.motor
    with atomic_open(folder / "log.csv") as f:
        f.write("time,position,q_current\n")
        np.savetxt(f, np.column_stack([log["t"], log["theta"] / (2 * np.pi), log["iq_1"]]), delimiter=",", fmt="%.9f")
    atomic_write_text(folder / "columns.toml", '[columns]\nt = "time"\ntheta = "position"\niq_1 = "q_current"\n'
                                               '[units]\ntheta = "rev"\n')
    atomic_write_text(folder / "motor.toml", f'kind = "rotary"\npole_pairs = {m.pole_pairs}\nk_t = {truth.k_t:.4g}\n'
                                             f'current_limit = {m.current_limit:.4g}\nsample_time = {m.sample_time}\n'
                                             + (f"slots = {m.slots}\n" if slots else ""))
    return folder
