"""A drive's own static cogging map (:class:`pgcomm.rotary.static_map.StaticMap`) from a file.

**File format.** CSV (or any table :func:`pgcomm.io.tables.read_table` reads) with a position column, ``angle``
(rad) or ``count`` (encoder counts from the index, with the motor's ``encoder_counts``), and the holding current (A):
one column (one direction, any name such as ``iq`` or ``Iq_A``), or ``forward`` and ``reverse``. Positions within
one revolution, strictly increasing, evenly spaced: a hole (a step over 1.5 times the spacing) is refused with the
row.
"""

from __future__ import annotations

import math

import numpy as np

from pgcomm.errors import DataError
from pgcomm.io.tables import read_table
from pgcomm.rotary.static_map import StaticMap

__all__ = ["read_static_map", "is_static_map", "POSITION_COLUMNS", "HOLE_STEPS"]

#: Position columns a static map may have, and whether they are in encoder counts.
POSITION_COLUMNS = {"angle": False, "count": True}
#: A step of the positions beyond this many times their spacing is a hole in the map.
HOLE_STEPS = 1.5


def read_static_map(path, encoder_counts: int | None = None) -> StaticMap:
    """Read a drive's static map (module docstring, "File format").

    Args:
        path: the file.
        encoder_counts: counts per revolution, for a ``count`` column.

    Raises:
        DataError: no position column, no current column, counts without ``encoder_counts``, positions not
            increasing, beyond one revolution or with a hole, non-finite values; one line naming file, row, column.
    """
    src = str(path)
    table = read_table(path, source=src, what="static map")
    cols = table.columns
    pos = next((c for c in POSITION_COLUMNS if c in cols), None)
    if pos is None:
        raise DataError(f"{src}: no position column (a static map has 'angle' in rad or 'count' in encoder counts); "
                        f"found {', '.join(cols)}")
    currents = [c for c in cols if c != pos]
    if not currents:
        raise DataError(f"{src}: no holding-current column beside '{pos}'")
    if "forward" in cols and "reverse" in cols:
        both = True
    elif len(currents) == 1:
        both = False
    else:
        raise DataError(f"{src}: {len(currents)} current columns ({', '.join(currents)}); a static map has one, or "
                        "'forward' and 'reverse'")
    x = np.asarray(cols[pos], float)
    if POSITION_COLUMNS[pos]:
        if encoder_counts is None:
            raise DataError(f"{src}: column 'count' needs the encoder's counts per revolution (encoder_counts in the "
                            "motor TOML)")
        x = 2 * math.pi * x / encoder_counts
    iq = 0.5 * (np.asarray(cols["forward"], float) + np.asarray(cols["reverse"], float)) if both else \
        np.asarray(cols[currents[0]], float)
    for name, v in ((pos, x), ("current", iq)):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise DataError(f"{src} row {bad[0] + 1}: column '{name}' is not a finite number")
    if x.size < 16:
        raise DataError(f"{src}: {x.size} rows; a static map needs at least 16 positions over the revolution")
    d = np.diff(x)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        raise DataError(f"{src} row {i + 2}: column '{pos}' does not increase (a static map lists its positions in order)")
    if x[-1] - x[0] >= 2 * math.pi:
        raise DataError(f"{src}: column '{pos}' spans more than one revolution ({(x[-1] - x[0]) / (2 * math.pi):.3g}); "
                        "a static map covers one (check encoder_counts)")
    step = float(np.median(d))
    holes = np.flatnonzero(d > HOLE_STEPS * step)
    if holes.size:
        i = int(holes[0])
        raise DataError(f"{src} row {i + 2}: a hole in the map: column '{pos}' steps {d[i] / step:.3g} times its "
                        f"spacing after row {i + 1}; measure the missing positions or interpolate them yourself")
    return StaticMap(np.mod(x, 2 * math.pi), iq, 2 if both else 1, src)


def is_static_map(path) -> bool:
    """Whether ``path`` holds a static map (a position column ``angle`` or ``count`` and no time ``t``) rather than a
    logged sweep; a file that cannot be read is left to the log reader and its messages."""
    try:
        cols = read_table(path, source=str(path), what="static map").columns
    except DataError:
        return False
    return any(c in cols for c in POSITION_COLUMNS) and "t" not in cols
