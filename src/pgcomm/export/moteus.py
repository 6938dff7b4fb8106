"""moteus cogging compensation: ``motor.cogging_dq_comp`` / ``motor.cogging_dq_scale`` as ``conf set`` lines.

What the moteus firmware does with the table (read in mjbots/moteus, commit
db1a7623d6a7d5568e7632b974a9ab521a4d2bab, April 2026; the feature dates from commit 22d30bc8,
release 0.1-20220628):

* ``fw/bldc_servo_structs.h``, ``struct BldcServoMotor``: ``float cogging_dq_scale = 0.0f;``
  ``std::array<int8_t, 1024> cogging_dq_comp;`` — "Each of the values in cogging_dq_comp is
  multiplied by cogging_dq_scale to arrive at the final correction current." So: **1024 entries,
  int8, value (A of q current) = entry × scale**; a scale of 0 (the default) turns it off.
* ``fw/bldc_servo_control.h``, ``ISR_DoPositionCommon``: ``commutation_position =
  sources[commutation_source].filtered_value × commutation_inv_cpr_`` — the commutation encoder's position
  as a fraction of its revolution in ``[0, 1)``; ``left = min(1023, int(1024 × position))``, ``right =
  (left + 1) % 1024``, and the correction is the **linear interpolation** of ``table[left] × scale`` and
  ``table[right] × scale`` (periodic: entry 1023 blends into entry 0). So entry ``j`` belongs to the fraction
  ``j / 1024`` of a revolution of the commutation source (the rotor). The result ``q_comp_A`` (telemetry
  ``servo_control.q_comp_A``) is **added to the q-current command** after the torque limit
  (``compensated_q_A = limited_q_A + q_comp_A``) and the sum is limited to ``max_current_A`` in
  ``ISR_DoCurrent``: positive entries add positive q current (the sign of the table pgcomm exports: the
  current to add).
* **Only in the position family of modes.** ``ISR_DoPositionCommon`` serves the position, zero-velocity and
  stay-within-bounds modes; the current (torque) mode calls ``ISR_DoCurrent`` directly and applies no
  table. A torque-commanded application gets the table through position mode with ``kp = kd = 0`` and the
  torque as feedforward.
* ``utils/compensate_cogging.py`` (mjbots' own calibration) runs the motor at constant speed forward and
  reverse, bins the q current over the commutation encoder's revolution (``fw/board_debug.cc``,
  ``DoHistogram``: bin ``k`` holds ``[k/N, (k+1)/N)``), **averages the forward and reverse runs** per entry,
  sets ``scale = max|x| / 127`` and each entry to ``int(x / scale)`` — **truncated toward zero** — and sends
  ``conf set motor.cogging_dq_scale`` / ``conf set motor.cogging_dq_comp.{i}`` and ``conf write``.
* ``lib/python/moteus/moteus_tool.py``: ``--write-config FILE`` sends each non-empty line of FILE
  as a command (no comment stripping), ``--restore-config FILE`` strips ``#`` comments and
  prefixes ``conf set``. The written file is therefore plain ``conf set`` lines without comments;
  provenance is in ``results.json`` and the printed summary. Persist with ``conf write``.

Where pgcomm's table differs from mjbots' calibration, on purpose:

* entries are **rounded** to the nearest step, not truncated: the int8 error is at most ``scale / 2``
  (truncation: up to a whole step, always toward zero, so the table is too small on average);
* entry ``j`` holds the compensation **at** ``j / 1024`` of the revolution, where the firmware applies it
  at full weight; mjbots' entry ``j`` is the mean over ``[j/1024, (j+1)/1024)``, which the firmware then
  applies half a bin (0.18°) early;
* the forward/reverse average is the model's (``RotaryModel.table(n)`` without a direction; a table file
  holds it), as mjbots averages its two runs.

Assumptions stated, not guessed (each export repeats them in ``results.json``):

* **Index origin and direction**: the table's ``θ = 0`` and positive direction are those of the
  moteus *commutation source* (``motor_position.sources[commutation_source]``, normally the rotor
  encoder, after its ``offset``/``sign``), i.e. ``θ = 2π · filtered_value / cpr``. A table
  identified from moteus' output position (``motor_position.output``: ``rotor_to_output_ratio``,
  ``output.offset``, ``output.sign``) must be converted to the rotor's angle first.
* **Units**: A of q-axis current per LSB (``cogging_dq_scale``), as the firmware adds it to the
  q-current command (the current the twin and identification report).

Quantisation: the scale is ``max|g| / 127`` of the resampled table ``g`` (as mjbots' tool) or the one given
(``scale=``, e.g. one scale for several axes; a scale under ``max|g| / 127`` would overflow int8 and is refused),
each entry is ``round(g_j / scale)``, so the int8 error is at most ``scale / 2`` at every entry and, the
interpolation being linear, everywhere.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.export.angle_table import (
    AngleTable,
    TableError,
    fine_grid_size,
    linear_on_grid,
    reconstruction_error,
)
from pgcomm.export.compensation import Compensation, from_angle_table
from pgcomm.export.drive_common import parameter_lines
from pgcomm.io.atomic import atomic_write_text

__all__ = ["ENTRIES", "LSB_MAX", "MoteusTable", "build_moteus", "moteus_lines", "write_moteus", "read_moteus",
           "moteus_current", "moteus_apply", "CITATION"]

#: ``std::array<int8_t, 1024> cogging_dq_comp`` (fw/bldc_servo_structs.h).
ENTRIES = 1024

#: Largest entry magnitude used (symmetric int8, as mjbots' compensate_cogging.py: ``max|x| / 127``).
LSB_MAX = 127

#: One-line provenance written into results.json.
CITATION = ("mjbots/moteus fw/bldc_servo_structs.h (BldcServoMotor::cogging_dq_comp, cogging_dq_scale), "
            "fw/bldc_servo_control.h (ISR_DoPositionCommon: index = commutation source position x 1024, linear "
            "interpolation, added to the q current), utils/compensate_cogging.py (conf set lines); "
            "commit db1a7623d6a7d5568e7632b974a9ab521a4d2bab")

ASSUMPTIONS = (
    "theta = 0 and the positive direction are the moteus commutation source's (rotor encoder after its offset and "
    "sign): entry j applies at the fraction j/1024 of its revolution",
    "units: A of q-axis current per LSB (cogging_dq_scale), added to the q-current command in the position family "
    "of modes only (position, zero velocity, stay within bounds; not current mode)",
)


@dataclass(frozen=True)
class MoteusTable:
    """A table ready for moteus, with its errors.

    Attributes:
        entries: ``(1024,)`` int8 values of ``motor.cogging_dq_comp``.
        scale: ``motor.cogging_dq_scale`` (A per LSB), a float32 value (what the firmware stores).
        resampled: ``(1024,)`` the table's interpolant at ``2π j / 1024`` (A), before quantisation
            (after the current limit).
        quantisation: largest ``|entry × scale − resampled|`` over the entries (A), <= ``scale / 2``.
        quantisation_rms: its RMS (A).
        interpolation: error of the firmware's linear interpolation of the *unquantised* entries
            against the input table's interpolant (A) — the resampling part.
        total: the same for the int8 entries: what the drive applies vs the input table (A).
        clipped: entries limited to ``± current_limit`` (0 without a limit).
        current_limit: the limit (A) or ``None``.
    """

    entries: np.ndarray
    scale: float
    resampled: np.ndarray
    quantisation: float
    quantisation_rms: float
    interpolation: TableError
    total: TableError
    clipped: int = 0
    current_limit: float | None = None
    assumptions: tuple = field(default=ASSUMPTIONS)

    def to_dict(self) -> dict:
        """Figures for results.json (A)."""
        return {"entries": ENTRIES, "scale_A_per_lsb": self.scale, "quantisation_max_A": self.quantisation,
                "quantisation_rms_A": self.quantisation_rms, "quantisation_bound_A": 0.5 * self.scale,
                "interpolation": self.interpolation.to_dict(), "total": self.total.to_dict(),
                "clipped_entries": self.clipped, "current_limit_A": self.current_limit,
                "citation": CITATION, "assumptions": list(self.assumptions)}


def moteus_current(entries, scale: float, points: int) -> np.ndarray:
    """What the firmware adds to the q current (A) at ``2π i / points`` (the rule of ``ISR_DoPositionCommon``)."""
    return linear_on_grid(np.asarray(entries, dtype=np.float64) * float(scale), points)


def build_moteus(table, current_limit: float | None = None, scale: float | None = None) -> MoteusTable:
    """Resample to 1024 entries, clip to the limit, quantise to int8; measure the errors.

    Args:
        table: the compensation over one revolution (A): an :class:`AngleTable` or a rotary
            :class:`pgcomm.export.compensation.Compensation` (its limit applies when ``current_limit`` is ``None``).
        current_limit: bound (A) on every entry's current, or ``None``.
        scale: ``motor.cogging_dq_scale`` (A per LSB) to use, or ``None`` for ``max|g| / 127``.

    Raises:
        ConfigError: a ``scale`` that is not positive, or so small that an entry would overflow int8.
    """
    comp = table if isinstance(table, Compensation) else from_angle_table(table)
    if not comp.rotary:
        raise ConfigError("moteus holds a table over the rotor's revolution; a linear model has none")
    if current_limit is None:
        current_limit = comp.limit
    unclipped = replace(comp, limit=None)
    g = unclipped.grid(ENTRIES)
    clipped = 0
    if current_limit is not None:
        clipped = int(np.count_nonzero(np.abs(g) > current_limit))
        g = np.clip(g, -current_limit, current_limit)
    peak = float(np.max(np.abs(g)))
    if scale is not None:
        if not (math.isfinite(scale) and scale > 0):
            raise ConfigError(f"--scale {scale}: motor.cogging_dq_scale must be a positive current in A per LSB")
        scale = float(np.float32(scale))
        if peak / scale > LSB_MAX + 0.5:
            raise ConfigError(f"--scale {scale:.6g}: the table's peak {peak:.6g} A would need {peak / scale:.4g} LSB, "
                              f"beyond int8 (+-{LSB_MAX}); use --scale {peak / LSB_MAX:.6g} or more")
    else:
        # the firmware holds the scale as a float; quantise against the float it will use
        scale = float(np.float32(peak / LSB_MAX)) if peak > 0 else 0.0
    if scale > 0:
        q = np.clip(np.rint(g / scale), -LSB_MAX, LSB_MAX).astype(np.int8)
    else:
        q = np.zeros(ENTRIES, dtype=np.int8)
    qerr = q.astype(np.float64) * scale - g
    n_in = comp.table.size if comp.table is not None else ENTRIES
    points = fine_grid_size(n_in, ENTRIES)
    ref = unclipped.grid(points)
    if current_limit is not None:
        ref = np.clip(ref, -current_limit, current_limit)
    interp = reconstruction_error(linear_on_grid(g, points), ref)
    total = reconstruction_error(moteus_current(q, scale, points), ref)
    return MoteusTable(q, scale, g, float(np.max(np.abs(qerr))), float(np.sqrt(np.mean(qerr**2))), interp, total,
                       clipped, current_limit)


def moteus_apply(mt: MoteusTable, theta) -> np.ndarray:
    """What the firmware adds to the q current (A) at rotor angles ``theta`` (rad, any turn), as
    ``ISR_DoPositionCommon`` computes it (module docstring); zero at a non-finite angle."""
    th = np.asarray(theta, dtype=float)
    ok = np.isfinite(th)
    frac = np.mod(np.where(ok, th, 0.0) / (2.0 * math.pi), 1.0)
    left = np.minimum(ENTRIES - 1, (ENTRIES * frac).astype(np.int64))
    t = (frac - left / ENTRIES) * ENTRIES
    e = mt.entries.astype(np.float64) * mt.scale
    v = (e[(left + 1) % ENTRIES] - e[left]) * t + e[left]
    return np.where(ok, v, 0.0)


def _scale_text(scale: float) -> str:
    # 9 significant digits round-trip a float32 exactly
    return "%.9g" % float(np.float32(scale))


def moteus_lines(mt: MoteusTable) -> list[str]:
    """The ``conf set`` lines (no comments: ``moteus_tool --write-config`` sends every line as a command)."""
    lines = [f"conf set motor.cogging_dq_scale {_scale_text(mt.scale)}"]
    lines += [f"conf set motor.cogging_dq_comp.{i} {int(v)}" for i, v in enumerate(mt.entries)]
    return lines


def write_moteus(mt: MoteusTable, path) -> Path:
    """Write the ``conf set`` lines to ``path`` atomically; load with ``python -m moteus.moteus_tool
    --target N --write-config FILE``, then ``conf write`` to keep them."""
    atomic_write_text(path, "\n".join(moteus_lines(mt)) + "\n")
    return Path(path)


_LINE = re.compile(r"^(?:conf\s+set\s+)?motor\.cogging_dq_(scale|comp\.(\d+))\s+(\S+)$")


def read_moteus(path) -> tuple[float, np.ndarray]:
    """Read ``motor.cogging_dq_scale`` and the 1024 ``motor.cogging_dq_comp`` entries back.

    Accepts ``conf set`` lines (:func:`write_moteus`) and ``name value`` lines (``moteus_tool
    --dump-config``); other configuration lines and ``#`` comments are skipped.

    Returns:
        ``(scale in A per LSB, (1024,) int8 entries)``.

    Raises:
        DataError: a missing or repeated entry, an entry outside int8, a non-finite scale; one line
            naming the file and line.
    """
    src = str(path)
    scale, entries, seen = None, np.zeros(ENTRIES, dtype=np.int8), {}
    for lineno, _, m in parameter_lines(path, _LINE):
        try:
            v = float(m.group(3))
        except ValueError:
            raise DataError(f"{src} line {lineno}: '{m.group(3)}' is not a number") from None
        if m.group(1) == "scale":
            if not math.isfinite(v):
                raise DataError(f"{src} line {lineno}: cogging_dq_scale {v} is not finite")
            scale = v
            continue
        i = int(m.group(2))
        if not (0 <= i < ENTRIES) or i in seen:
            raise DataError(f"{src} line {lineno}: cogging_dq_comp.{i} is "
                            f"{'repeated' if i in seen else f'outside 0..{ENTRIES - 1}'}")
        if v != int(v) or not -128 <= v <= 127:
            raise DataError(f"{src} line {lineno}: cogging_dq_comp.{i} = {m.group(3)} is not an int8")
        seen[i] = lineno
        entries[i] = int(v)
    if scale is None:
        raise DataError(f"{src}: no motor.cogging_dq_scale line")
    if len(seen) != ENTRIES:
        missing = next(i for i in range(ENTRIES) if i not in seen)
        raise DataError(f"{src}: motor.cogging_dq_comp.{missing} missing ({len(seen)} of {ENTRIES} entries)")
    return scale, entries
