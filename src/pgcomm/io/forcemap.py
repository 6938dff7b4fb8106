"""Force-map files (CSV): :func:`load_forcemap` and :func:`write_forcemap` of a :class:`~pgcomm.forcemap.ForceMapPlant`.

Format (docs/formats.md, "Force map"): column ``y`` (m, strictly increasing); for each coil set
``l = 1..L`` and phase ``p ∈ {a, b, c}`` the columns ``Fy_{l}{p}``, ``Fx_{l}{p}`` (N/A) and
``Tz_{l}{p}`` (N·m/A); optional ``Fy_cog``, ``Fx_cog`` (N), ``Tz_cog`` (N·m). ``L`` is read
from the column names. The table is read by :func:`pgcomm.io.tables.read_csv_columns`.
"""

from __future__ import annotations

import re

import numpy as np

from pgcomm.errors import DataError
from pgcomm.forcemap import ForceMapPlant
from pgcomm.io.atomic import atomic_open
from pgcomm.io.config import closest_hint
from pgcomm.io.tables import read_csv_columns, read_csv_header

__all__ = ["load_forcemap", "write_forcemap", "forcemap_columns"]

_QUANTITIES = ("Fy", "Fx", "Tz")
#: Plausibility bounds that catch a wrong unit: a stroke beyond 10 m (positions in mm), a force per
#: ampere beyond 10 kN/A (mN/A, or a force table that is not per ampere).
MAX_SPAN = 10.0
MAX_GAIN = 1e4
_PHASES = ("a", "b", "c")
_COG = ("Fy_cog", "Fx_cog", "Tz_cog")
_GAIN_RE = re.compile(r"^(Fy|Fx|Tz)_([0-9]+)([abc])$")


def forcemap_columns(n_coil_sets: int, cogging: bool = True) -> list[str]:
    """Column names of a force map with ``n_coil_sets`` coil sets, in file order."""
    names = ["y"]
    for l in range(1, n_coil_sets + 1):
        names += [f"{q}_{l}{p}" for q in _QUANTITIES for p in _PHASES]
    return names + (list(_COG) if cogging else [])


def _validate_names(header: list[str], src: str) -> int:
    """Check the column names of a force map; return ``L``."""
    sets: dict[int, set] = {}
    unknown = []
    for n in header:
        if n == "y" or n in _COG:
            continue
        m = _GAIN_RE.match(n)
        if m is not None and int(m.group(2)) >= 1:
            sets.setdefault(int(m.group(2)), set()).add((m.group(1), m.group(3)))
        else:
            unknown.append(n)
    n_sets = max(sets, default=0)
    expected = forcemap_columns(max(n_sets, 1))
    missing = [e for e in expected if e not in header and e not in _COG]
    if unknown:
        u = unknown[0]
        hint = closest_hint(u, missing or expected)
        why = " (coil sets are numbered from 1)" if _GAIN_RE.match(u) else ""
        if not hint and "y" not in header:
            hint = f" (and there is no column 'y': is '{u}' the position in m?)"
        raise DataError(
            f"{src}: column '{u}' unknown{why}{hint}; expected y, Fy_<l><p>, Fx_<l><p>, Tz_<l><p> "
            "(l = 1..L, p = a, b, c) and optionally Fy_cog, Fx_cog, Tz_cog"
        )
    if "y" not in header:
        raise DataError(f"{src}: column 'y' (position in m) missing; found {', '.join(header[:8])}")
    if n_sets == 0:
        raise DataError(f"{src}: no coil-set columns (expected Fy_1a, Fy_1b, Fy_1c, Fx_1a, ..., Tz_1c for coil set 1)")
    for l in range(1, n_sets + 1):
        have = sets.get(l, set())
        if not have:
            raise DataError(
                f"{src}: no columns for coil set {l} but coil set {n_sets} has some "
                "(coil sets must be numbered 1..L without holes)"
            )
        for q in _QUANTITIES:
            for p in _PHASES:
                if (q, p) in have:
                    continue
                same = [f"{q}_{l}{pp}" for pp in _PHASES if (q, pp) in have]
                if same:
                    why = f"coil set {l} has {', '.join(same)} but no phase {p}"
                else:
                    why = f"coil set {l} has no {q} columns; each coil set needs Fy, Fx and Tz for phases a, b, c"
                raise DataError(f"{src}: column '{q}_{l}{p}' missing ({why})")
    return n_sets


def load_forcemap(path) -> ForceMapPlant:
    """Read and validate a force-map CSV (format in the module docstring).

    Args:
        path: CSV file.

    Returns:
        :class:`ForceMapPlant` with ``L`` coil sets read from the column names.

    Raises:
        DataError: missing, misnamed or unknown columns; incomplete or
            non-consecutive coil sets; non-numeric or empty cells; NaN/inf
            (row and column); ``y`` not strictly increasing (row); fewer than 2 rows.
    """
    src = str(path)
    header = read_csv_header(path, src)  # names first: a misnamed column is the likelier mistake
    n_sets = _validate_names(header, src)
    data = read_csv_columns(path, src)
    m = len(data["y"])
    if m < 2:
        raise DataError(f"{src}: {m} data rows, a force map needs at least 2")
    for name in header:  # NaN/inf: name row and column
        a = data[name]
        if not np.isfinite(a).all():
            i = int(np.flatnonzero(~np.isfinite(a))[0])
            raise DataError(f"{src} row {i + 1} column '{name}': {a[i]} is not a finite number")
    y = data["y"]
    span = float(np.max(y) - np.min(y))
    if span > MAX_SPAN or float(np.max(np.abs(y))) > MAX_SPAN:
        hint = "; looks like mm: give y in m (divide by 1000)" if span / 1000 <= MAX_SPAN else ""
        raise DataError(f"{src} column 'y': positions span [{np.min(y):.6g}, {np.max(y):.6g}], implausible for a "
                        f"linear motor in m (at most {MAX_SPAN:g} m){hint}")
    for name in header:
        if name == "y" or name.endswith("_cog"):
            continue
        big = float(np.max(np.abs(data[name])))
        if big > MAX_GAIN:
            raise DataError(f"{src} column '{name}': |{name}| reaches {big:.6g} per A, implausible (at most "
                            f"{MAX_GAIN:g} N/A or N m/A); give force per ampere in N/A (not mN/A) for 1 A in one phase")
    gain = np.empty((m, n_sets, 3, 3))
    for l in range(n_sets):
        for r, q in enumerate(_QUANTITIES):
            for c, p in enumerate(_PHASES):
                gain[:, l, r, c] = data[f"{q}_{l + 1}{p}"]
    cog = np.stack([data[n] if n in data else np.zeros(m) for n in _COG], axis=-1)
    return ForceMapPlant.from_arrays(data["y"], gain, cog, source=src)


def write_forcemap(path, y, gain_phases, cogging=None) -> None:
    """Write a force-map CSV (atomically) that :func:`load_forcemap` reads back bit-identically.

    Args:
        path: target ``.csv`` file.
        y: ``(M,)`` positions (m), strictly increasing.
        gain_phases: ``(M, L, 3, 3)``: rows ``[Fy, Fx, Tz]`` (N/A, N·m/A), columns phases a, b, c.
        cogging: ``(M, 3)`` (N, N, N·m), or ``None`` to leave the cogging columns out (= zero).

    Raises:
        DataError: the arrays do not form a valid force map (shapes, NaN, ordering).
    """
    plant = ForceMapPlant.from_arrays(y, gain_phases, cogging, source=str(path))
    y = np.asarray(plant.y_grid)
    g = np.asarray(plant.gain_table)
    m, n_sets = g.shape[:2]
    blocks = [y[:, None], g.reshape(m, n_sets * 9)]  # (l, q, p) order = forcemap_columns
    if cogging is not None:
        blocks.append(np.asarray(plant.cog_table))
    table = np.concatenate(blocks, axis=1)
    names = forcemap_columns(n_sets, cogging is not None)
    with atomic_open(path, "w", newline="") as f:
        # %.17g: every float64 reads back to the identical value.
        np.savetxt(f, table, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
