"""ODrive (open firmware 0.5.x) anticogging map: ``controller.config.anticogging.cogging_map`` as JSON.

What the firmware does with the map (read in odriverobotics/ODrive, tags fw-v0.5.1 to fw-v0.5.6,
commit a308314ed2ca613164b81e7bbdfacc53cd1859ff = fw-v0.5.6, and master f9b5419c, 2024):

* ``Firmware/MotorControl/controller.hpp``, ``struct Controller::Anticogging_t``:
  ``float cogging_map[3600];`` — **3600 float32 entries**, part of the controller's config (saved
  to NVM by ``save_configuration()`` since 0.5.1, CHANGELOG "Anticogging map is temporarily forced to
  0.1 deg precision, but saves with the config").
* ``Firmware/MotorControl/controller.cpp``, ``Controller::update()``: ``anticogging_pos =
  pos_estimate / encoder.getCoggingRatio()`` with ``getCoggingRatio() = 1/3600``
  (``Firmware/MotorControl/encoder.hpp``) and ``pos_estimate`` the encoder's position in turns
  (``encoder.pos_estimate_``, "[turn]"; in ``INPUT_MODE_TRAP_TRAJ`` the position setpoint instead),
  then ``torque += cogging_map[clamp(mod((int)anticogging_pos, 3600), 0, 3600)]``: **entry ``k``
  holds for ``pos_estimate`` in ``[k/3600, (k+1)/3600)`` turns** (zero-order hold, no interpolation;
  ``mod`` is the non-negative remainder of ``Firmware/MotorControl/utils.hpp``), and the value is
  **added to the torque setpoint in N·m**, which ``Firmware/MotorControl/motor.cpp`` turns into
  ``iq = torque / motor.config.torque_constant``. So an entry is ``k_t × iq_comp`` (N·m) for the
  compensating current ``iq_comp`` (A): pgcomm needs the drive's ``torque_constant`` (N·m/A).
* ``Controller::anticogging_calibration`` fills the map with the velocity integrator's torque
  while holding ``input_pos = index / 3600`` turns: the map is in the same frame as
  ``pos_estimate`` (its zero is the encoder's: index pulse or absolute encoder; the docs require
  one for ``pre_calibrated``), and its sign is the torque to add.

**Stock firmware cannot load it.** ``Firmware/odrive-interface.yaml`` (0.5.x) exposes
``controller.config.anticogging`` with ``index``, ``pre_calibrated``, ``calib_anticogging``,
``calib_pos_threshold``, ``calib_vel_threshold``, ``cogging_ratio``, ``anticogging_enabled`` and
the functions ``start_anticogging_calibration``, ``remove_anticogging_bias`` and (0.5.6)
``get_anticogging_value(index)`` — reading only: ``cogging_map`` itself has no protocol entry, so
no ``odrivetool``/fibre command writes it (the 0.4.x firmware's map, ``float*`` of encoder ``cpr``
entries in A, was not exposed either). The JSON therefore states ``"loadable_by_stock_firmware":
false``, and every export prints it. The ways around it (:data:`WORKAROUNDS`):

* **ODrive Pro / S1, firmware 0.6.x**: the drive's own anticogging calibration
  (docs.odriverobotics.com, guides, "Anticogging") measures and applies its map; pgcomm's table then
  serves to judge that map, not to replace it;
* **a 0.5.x firmware built with a setter**: a function beside ``get_anticogging_value`` in
  ``odrive-interface.yaml`` (and ``Controller``) that writes ``cogging_map[index]``; load the 3600
  entries with it, set ``anticogging.pre_calibrated = True`` and ``save_configuration()``: at the next
  start the map is used once the encoder's index is found (``Encoder::enc_index_cb``) or, with an
  absolute encoder, at once (``Encoder`` set-up) — ``anticogging_valid_`` is set only there or by the
  drive's own calibration.

The JSON is also what to compare with a map read back entry by entry with ``get_anticogging_value(k)``
after the drive's own calibration.

Assumptions stated, not guessed (repeated in the JSON and ``results.json``):

* **Index origin and direction**: the table's ``θ = 0`` and positive direction are those of the
  ODrive's ``pos_estimate`` (turns × 2π), i.e. a table identified from the ODrive's own position log.
* **Negative positions**: ``(int)`` truncates toward zero, so for ``pos_estimate < 0`` entry ``k``
  holds for ``((k−1)/3600, k/3600]`` modulo one turn — one bin (0.1°) later than for positive
  positions. Entries are the table's means over the positive-position bins; the error for negative
  positions is reported separately (``negative_positions``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.export.angle_table import (
    AngleTable,
    TableError,
    bin_means,
    fine_grid_size,
    reconstruction_error,
)
from pgcomm.export.compensation import Compensation, from_angle_table
from pgcomm.io.atomic import atomic_write_text

__all__ = ["ENTRIES", "OdriveMap", "build_odrive", "odrive_document", "write_odrive", "read_odrive",
           "odrive_current", "odrive_apply", "CITATION", "FORMAT", "WORKAROUNDS"]

#: ``float cogging_map[3600]`` (Firmware/MotorControl/controller.hpp).
ENTRIES = 3600

#: The JSON's ``format`` key.
FORMAT = "pgcomm-odrive-0.5-anticogging-map"

CITATION = ("odriverobotics/ODrive Firmware/MotorControl/controller.hpp (Anticogging_t::cogging_map[3600]), "
            "controller.cpp (Controller::update: torque += cogging_map[mod((int)(pos_estimate*3600), 3600)]), "
            "encoder.hpp (getCoggingRatio = 1/3600), motor.cpp (iq = torque / torque_constant), "
            "odrive-interface.yaml (cogging_map not exposed); tags fw-v0.5.1..fw-v0.5.6")

#: The documented ways to get a map into an ODrive (module docstring), printed by every export.
WORKAROUNDS = (
    "ODrive Pro/S1 firmware 0.6.x: run the drive's own anticogging calibration "
    "(https://docs.odriverobotics.com/v/latest/guides/anticogging.html) and compare its map with this one",
    "ODrive v3 firmware 0.5.x built with a setter beside get_anticogging_value (odrive-interface.yaml, Controller) "
    "that writes cogging_map[index]: write the 3600 entries, set anticogging.pre_calibrated = True, "
    "save_configuration(); the map is used after the index search (or at once with an absolute encoder)",
)

ASSUMPTIONS = (
    "theta = 0 and the positive direction are the ODrive's pos_estimate (turns x 2 pi): entry k holds for "
    "pos_estimate in [k/3600, (k+1)/3600) turns",
    "for negative pos_estimate the firmware's (int) truncation uses entry k on ((k-1)/3600, k/3600] turns: one "
    "bin later (error reported as negative_positions)",
    "units: N m added to the torque setpoint; entry = torque_constant x iq_comp",
    "stock 0.5.x firmware has no command that writes cogging_map (odrive-interface.yaml); loading needs a "
    "firmware that exposes or compiles in the map",
)


@dataclass(frozen=True)
class OdriveMap:
    """A 3600-entry map for ODrive 0.5.x, with its errors.

    Attributes:
        torque: ``(3600,)`` float32 map entries (N·m).
        torque_constant: the drive's ``motor.config.torque_constant`` (N·m/A) used.
        positive: error (A) of the firmware's zero-order hold vs the input table's interpolant, for
            positive positions (the bins the entries are fitted to).
        negative: the same for negative ``pos_estimate`` (one bin later).
        clipped: entries limited to ``± current_limit`` (0 without a limit).
        current_limit: the limit (A) or ``None``.
    """

    torque: np.ndarray
    torque_constant: float
    positive: TableError
    negative: TableError
    clipped: int = 0
    current_limit: float | None = None

    @property
    def current(self) -> np.ndarray:
        """``(3600,)`` the entries as q current (A): ``torque / torque_constant``."""
        return self.torque.astype(np.float64) / self.torque_constant

    def to_dict(self) -> dict:
        """Figures for results.json (A, N·m)."""
        return {"entries": ENTRIES, "torque_constant_Nm_per_A": self.torque_constant,
                "positive_positions": self.positive.to_dict(), "negative_positions": self.negative.to_dict(),
                "clipped_entries": self.clipped, "current_limit_A": self.current_limit,
                "loadable_by_stock_firmware": False, "ways_around": list(WORKAROUNDS), "citation": CITATION,
                "assumptions": list(ASSUMPTIONS)}


def odrive_current(current, points: int, negative: bool = False) -> np.ndarray:
    """What the firmware adds (A) at ``2π i / points`` (turn fractions ``i / points``), for positions of one sign.

    ``negative=False``: entry ``floor(3600 x)``; ``True``: ``ceil(3600 x) mod 3600`` (the ``(int)``
    truncation toward zero of ``Controller::update`` at ``pos_estimate = x − 1``).
    """
    c = np.asarray(current, dtype=np.float64)
    m = c.size
    if points % m:
        raise ValueError(f"points = {points} must be a multiple of the map size {m}")
    i = np.arange(points)
    f = points // m
    k = i // f if not negative else (-(-i // f)) % m
    return c[k]


def build_odrive(table, torque_constant: float, current_limit: float | None = None) -> OdriveMap:
    """Resample to the 3600 bins (bin means), clip to the limit, convert to N·m; measure the errors.

    Args:
        table: the compensation over one revolution (A): an :class:`AngleTable` or a rotary
            :class:`pgcomm.export.compensation.Compensation` (its limit applies when ``current_limit`` is ``None``).
        torque_constant: ``k_t`` (N·m/A) the ODrive is configured with (``motor.config.torque_constant``), > 0.
        current_limit: bound (A) on every entry, or ``None``.

    Raises:
        ValueError: a torque constant that is not a positive finite number.
    """
    if not (isinstance(torque_constant, (int, float)) and math.isfinite(torque_constant) and torque_constant > 0):
        raise ValueError(f"torque constant {torque_constant!r} must be a positive number of N m/A")
    comp = table if isinstance(table, Compensation) else from_angle_table(table)
    if current_limit is None:
        current_limit = comp.limit
    comp = replace(comp, limit=None)
    if comp.table is not None:
        g = bin_means(comp.table, ENTRIES)
    else:
        # the midpoint rule over 16 points per bin: the bin mean of every order below 16 x 3600 / 2
        g = comp.values(2.0 * math.pi * (np.arange(ENTRIES)[:, None] + (np.arange(16) + 0.5) / 16) / ENTRIES).mean(1)
    clipped = 0
    if current_limit is not None:
        clipped = int(np.count_nonzero(np.abs(g) > current_limit))
        g = np.clip(g, -current_limit, current_limit)
    torque = (g * torque_constant).astype(np.float32)
    points = fine_grid_size(comp.table.size if comp.table is not None else ENTRIES, ENTRIES)
    ref = comp.grid(points)
    if current_limit is not None:
        ref = np.clip(ref, -current_limit, current_limit)
    cur = torque.astype(np.float64) / torque_constant
    pos = reconstruction_error(odrive_current(cur, points), ref)
    neg = reconstruction_error(odrive_current(cur, points, negative=True), ref)
    return OdriveMap(torque, float(torque_constant), pos, neg, clipped, current_limit)


def odrive_apply(om: OdriveMap, theta) -> np.ndarray:
    """What ``Controller::update`` adds (A of q current) at ``pos_estimate = theta / 2π`` turns (any sign):
    entry ``mod((int)(pos · 3600), 3600)``, truncation toward zero; zero at a non-finite angle."""
    th = np.asarray(theta, dtype=float)
    ok = np.isfinite(th)
    idx = np.mod(np.trunc(np.where(ok, th, 0.0) / (2.0 * math.pi) * ENTRIES), ENTRIES).astype(np.int64)
    return np.where(ok, om.current[idx], 0.0)


def odrive_document(om: OdriveMap, provenance=()) -> dict:
    """The JSON document: the map (N·m, float32 values printed to round-trip) and what it means."""
    return {
        "format": FORMAT,
        "firmware": "ODrive open firmware 0.5.1 to 0.5.6 (ODrive v3.x)",
        "attribute": "axis.controller.config.anticogging.cogging_map",
        "loadable_by_stock_firmware": False,
        "ways_around": list(WORKAROUNDS),
        "units": "N m, added to the torque setpoint (iq = torque / torque_constant)",
        "index": "entry k for pos_estimate in [k/3600, (k+1)/3600) turns (mod 1 turn); zero-order hold",
        "torque_constant_Nm_per_A": om.torque_constant,
        "current_limit_A": om.current_limit,
        "citation": CITATION,
        "assumptions": list(ASSUMPTIONS),
        "provenance": list(provenance),
        "error_A": {"positive_positions": om.positive.to_dict(), "negative_positions": om.negative.to_dict()},
        "cogging_map": [float("%.9g" % v) for v in om.torque],
    }


def write_odrive(om: OdriveMap, path, provenance=()) -> Path:
    """Write :func:`odrive_document` to ``path`` atomically."""
    atomic_write_text(path, json.dumps(odrive_document(om, provenance), indent=1) + "\n")
    return Path(path)


def read_odrive(path) -> tuple[np.ndarray, float]:
    """Read a map written by :func:`write_odrive`: ``((3600,) float32 N·m, torque constant N·m/A)``.

    Raises:
        DataError: not JSON, another format, a map of the wrong length or with non-finite values.
    """
    src = str(path)
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, ValueError) as e:
        raise DataError(f"{src}: not a readable JSON file ({e})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise DataError(f"{src}: not a pgcomm ODrive map (format {FORMAT!r} expected)")
    m = np.asarray(doc.get("cogging_map"), dtype=np.float64)
    if m.shape != (ENTRIES,) or not np.all(np.isfinite(m)):
        raise DataError(f"{src}: cogging_map must hold {ENTRIES} finite numbers")
    return m.astype(np.float32), float(doc["torque_constant_Nm_per_A"])
