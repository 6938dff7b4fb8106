"""Reference files: a position reference ``r`` (m) with an optional time base, read into a
:class:`~pgcomm.trajectory.Reference`.

Formats (by suffix; columns read by :func:`pgcomm.io.tables.read_table`):

* CSV (``.csv``/``.txt``) with a header: column ``r`` (m) required, ``t`` (s) optional;
* MATLAB ``.mat`` (v5 or v7.3) and HDF5: a vector ``r``, optionally a vector ``t`` (s) or a
  scalar ``Ts`` (s).

The time base must be uniform within 1e-6 relative.
"""

from __future__ import annotations

import math
import os

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.io.tables import read_table
from pgcomm.trajectory import Reference, reference_from_positions

__all__ = ["read_reference"]

#: Relative tolerance of a uniform time base (and of a file's sample time against the given one).
UNIFORM_RTOL = 1e-6
#: Largest plausible |r| (m): a reference beyond 10 m is in another unit (mm).
MAX_POSITION = 10.0

_SUFFIXES = (".csv", ".txt", ".mat", ".h5", ".hdf5")


def read_reference(path, sample_time=None, variable="r") -> Reference:
    """Read a position reference from a file.

    Args:
        path: file path (see the module docstring for the formats).
        sample_time: sample period (s); required when the file has no ``t`` (or ``Ts``); if
            both are present they must agree within 1e-6.
        variable: name of the position column/variable (m).

    Returns:
        :class:`~pgcomm.trajectory.Reference` with ``N >= 2`` samples; ``t`` from the file if
        it has one, else ``k * sample_time``; velocity, acceleration and jerk by finite
        differences (:func:`pgcomm.trajectory.reference_from_positions`).

    Raises:
        DataError: missing/unreadable file, missing column or variable, non-numeric or
            non-finite values, non-uniform time, no sample time.
        ConfigError: ``sample_time`` given but not finite and > 0.
    """
    p = os.fspath(path)
    ts_arg = None
    if sample_time is not None:
        try:
            ts_arg = float(sample_time)
        except (TypeError, ValueError):
            raise ConfigError(f"sample_time must be a finite number > 0 (s), got {sample_time!r}") from None
        if not (math.isfinite(ts_arg) and ts_arg > 0):
            raise ConfigError(f"sample_time must be a finite number > 0 (s), got {sample_time!r}")
    if not os.path.isfile(p):
        raise DataError(f"{p}: reference file not found")
    ext = os.path.splitext(p)[1].lower()
    if ext not in _SUFFIXES:
        raise DataError(f"{p}: unsupported reference file type '{ext}'; expected .csv, .txt, .mat, .h5 or .hdf5")
    names = (variable, "t", "Ts")
    table = read_table(p, lambda n: n in names, source=p, what="reference", csv_suffixes=(".csv", ".txt"))
    cols = table.columns
    if variable not in cols:
        what = {"column": "column", "variable": "variable", "dataset": "dataset"}[table.kind]
        found = ", ".join(table.found) or "(none)"
        raise DataError(f"{p}: no {what} '{variable}' (position, m); {what}s found: {found}")
    r = _finite(p, variable, cols[variable])
    t = _finite(p, "t", cols["t"]) if "t" in cols and variable != "t" else None
    ts_file = None
    if "Ts" in cols and table.kind != "column":
        ts = cols["Ts"]
        if ts.size != 1:
            raise DataError(f"{p}: 'Ts' has shape {ts.shape}, expected a scalar sample time (s)")
        ts_file = float(ts[0])
        if not (math.isfinite(ts_file) and ts_file > 0.0):
            raise DataError(f"{p}: 'Ts' is {ts_file!r}, expected a sample time > 0 (s)")

    if r.shape[0] < 2:
        raise DataError(f"{p}: '{variable}' has {r.shape[0]} sample(s); a reference needs at least 2")
    if t is not None:
        if t.shape != r.shape:
            raise DataError(f"{p}: 't' has {t.shape[0]} samples but '{variable}' has {r.shape[0]}")
        ts_file = _uniform_step(p, t)
    if ts_file is not None:
        if ts_arg is not None and not math.isclose(ts_file, ts_arg, rel_tol=UNIFORM_RTOL, abs_tol=0.0):
            raise DataError(f"{p}: the file's sample time {ts_file!r} s disagrees with sample_time={ts_arg!r} s")
        ts = ts_file
    elif ts_arg is not None:
        ts = ts_arg
    else:
        raise DataError(f"{p}: no 't' column or 'Ts' variable in the file; give its sample time in s "
                        "(--reference-sample-time on the command line, sample_time= in Python)")
    big = float(np.max(np.abs(r)))
    if big > MAX_POSITION:
        hint = "; looks like mm: give r in m (divide by 1000)" if big / 1000 <= MAX_POSITION else ""
        raise DataError(f"{p}: '{variable}' reaches {big:.6g}, implausible for a position in m "
                        f"(at most {MAX_POSITION:g} m){hint}")
    return reference_from_positions(r, ts, t)


def _finite(p: str, name: str, x: np.ndarray) -> np.ndarray:
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        k = int(bad[0])
        raise DataError(f"{p}: '{name}' holds {float(x[k])!r} at row {k + 1}, expected finite numbers")
    return x


def _uniform_step(p: str, t: np.ndarray) -> float:
    """Sample time of a uniform time vector, or DataError at the first irregular step."""
    dt = np.diff(t)
    dt0 = dt[0]
    if not dt0 > 0.0:
        raise DataError(f"{p}: 't' does not increase from row 1 to row 2 ({float(t[0])!r} -> {float(t[1])!r} s)")
    off = np.flatnonzero(np.abs(dt - dt0) > UNIFORM_RTOL * dt0)
    if off.size:
        k = int(off[0])  # step from row k+1 to row k+2 (1-based)
        raise DataError(
            f"{p}: 't' is not uniformly sampled: the step changes at row {k + 2} "
            f"({float(dt[k])!r} s instead of {float(dt0)!r} s)"
        )
    return float((t[-1] - t[0]) / (t.shape[0] - 1))
