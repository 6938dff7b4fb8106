"""Deployment export of a commutation law: generated C code and lookup tables.

* :mod:`pgcomm.export.c` — :func:`write_c` / :func:`c_source`: the model-based law
  ``i = K̂(y)^† (F* - F̂_cog(y))`` (eq. Commutation_Model_Currents) and the drive inputs
  (eq. Current_To_ForceDelta) as self-contained C99, agreeing with
  :class:`pgcomm.commutation.ModelLaw` to rounding.
* :mod:`pgcomm.export.lut` — :func:`build_lut` / :func:`write_lut`: the same law as a
  table of the pseudo-inverse ``P(y)`` and cogging force on a uniform position grid
  with linear interpolation, its worst-case force error (:func:`lut_error`), and an
  anti-cogging table for drives that only take a position -> force-offset table
  (:func:`build_cogging_table`, :func:`cogging_table_error`).

Rotary drives, from a compensation table over one mechanical revolution
(:mod:`pgcomm.export.angle_table`: reading, periodic resampling, reconstruction error):

* :mod:`pgcomm.export.moteus` — ``conf set`` lines of moteus' ``motor.cogging_dq_comp`` (1024 int8)
  and ``motor.cogging_dq_scale``;
* :mod:`pgcomm.export.odrive` — the 3600-entry ``cogging_map`` (N·m) of ODrive's open firmware 0.5.x
  (a format stock firmware cannot load; the file says so);
* :mod:`pgcomm.export.angle_lut` — a safe C99 lookup indexed by the mechanical angle.

``pgcomm export`` (:mod:`pgcomm.cli.export`) drives all of them: from a model file (``--model``,
formats ``c`` and ``lut``) or from a table (``--table``, formats ``moteus``, ``odrive``, ``c-angle``).

The names below load on first use: importing a submodule (the command line's option parsing,
:mod:`pgcomm.export.options`) does not load JAX, so that ``pgcomm --help`` answers at once and an
interrupt that arrives while the command line starts finds its handler installed.
"""

from __future__ import annotations

import importlib

_LUT = ("DEFAULT_RESOLUTION", "Lut", "LutError", "CoggingTable", "CoggingTableError", "build_lut", "lut_currents",
        "lut_error", "write_lut", "read_lut", "lut_header", "lut_columns", "f_star_set", "build_cogging_table",
        "cogging_table_error", "write_cogging_table", "classical_parameters")
_PUBLIC = {"CLawOptions": "pgcomm.export.c", "c_source": "pgcomm.export.c", "write_c": "pgcomm.export.c", **{n: "pgcomm.export.lut" for n in _LUT}}

__all__ = list(_PUBLIC)


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'pgcomm.export' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
