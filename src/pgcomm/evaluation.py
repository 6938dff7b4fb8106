"""Evaluation of rig (or simulation) logs: commutation error, tracking error, model fit.

For each log (:class:`pgcomm.io.logs.Log`):

* the commutation error ``F − F*`` (N, N, N·m) from the measured force ``Fy, Fx, Tz`` and
  the desired force ``Fy_star, Fx_star, Tz_star``, its MSE per direction unfiltered and
  filtered by the paper's 50 Hz ZOH low-pass ``H(z)`` (:func:`pgcomm.metrics.commutation_mse`),
  as in the paper's table of commutation performance. The desired force is required unless a
  model is given: the model error needs only ``y``, the currents and ``F``, so a log without
  ``F*`` then gets the model error and a note that its commutation error was skipped;
* the tracking-error MSE of ``e = r − y`` (m²) when the reference ``r`` is logged (with the
  logged, i.e. measured, position ``y``); skipped otherwise, with a note;
* with a model ``F̂``: the model error ``F − F̂(y, i)`` (how well the model explains the
  rig) with the same MSEs, where currents are logged (or drive inputs converted with the
  drive's ``k̂``, ``ζ̂``), and a warning when positions leave the model's training range.

**Logs without a force sensor** (no ``Fy, Fx, Tz``): the driving force is reconstructed from
the motion, ``F_y = m ÿ + f_v ẏ + F_c(y) s(ẏ)`` (:func:`reconstruct_force`), with the moving mass
and the friction identified without a force sensor (``pgcomm identify --no-force-sensor``)
and the zero-phase filtering of :mod:`pgcomm.sensorless` (one Hann window on ``Δ²y`` and,
with the half-sample shift of the zero-order hold, on every other column). The commutation
error is then ``F_y,f − F_y,f*`` on those filtered windows (``commutation_mse.y.filtered``;
``unfiltered`` and the x, z rows are ``None``: not observable), the model error
``F_y,f − F̂_y,f``, and the evaluation says so (``force_reconstructed``, a note). Windows in
which the translator is slower than the identification's speed bound are left out, as there.

A long log is evaluated in blocks of :data:`BLOCK_ROWS` rows: the stacked force, the currents and the
model's intermediate arrays exist for one block at a time (the model in float64, the filter's state
carried from block to block), so the memory is that of the log's columns and the error columns kept
for the figures (a 5 M-row log with a model: about 1 GB, where evaluating it whole took 7.6 GB).

Every log is named by the shortest end of its path that no other log shares (:func:`log_names`:
``a/log.csv`` and ``b/log.csv`` become ``a/log`` and ``b/log``); figures, the text table and
results.json use that name. Figures (:func:`pgcomm.plots.plot_logs`, :func:`pgcomm.plots.plot_model_error`) overlay all
logs, one line per log, in the layout of the paper's commutation-error figures
(:func:`pgcomm.plots.plot_comparison`). Logs may have different lengths, so every log is drawn
against its own time axis.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
import os
from collections import Counter

import jax
import numpy as np

from pgcomm.data import CoilSetData, log_currents, velocity_from_positions
from pgcomm.errors import DataError
from pgcomm.metrics import DIRECTIONS, RunningMse, tracking_mse
from pgcomm.models import warn_outside_training_range
from pgcomm import sensorless as sl
from pgcomm.sensorless import filter_windows

__all__ = ["LogEvaluation", "evaluate_log", "evaluate_logs", "evaluation_results", 
           "format_table", "require_desired_force", "missing_desired_force", "reconstruct_force", "ReconstructedForce",
           "STAR_COLUMNS", "log_names"]

#: Desired-force columns a log needs to be evaluated (a log without a force sensor: ``Fy_star`` only).
STAR_COLUMNS = ("Fy_star", "Fx_star", "Tz_star")

#: Rows per block of :func:`evaluate_log`: a PGNN's hidden units for a block of 65 536 rows and three coil
#: sets take about 25 MB, and blocks this long keep JAX's per-call overhead negligible.
BLOCK_ROWS = 2**16


def _blocks(n: int):
    """``(start, stop)`` of consecutive blocks of at most :data:`BLOCK_ROWS` rows covering ``range(n)``."""
    return [(a, min(n, a + BLOCK_ROWS)) for a in range(0, n, BLOCK_ROWS)]


def _rows(log, start: int, stop: int):
    """The rows ``start:stop`` of ``log`` as a :class:`pgcomm.io.logs.Log` of views (no copy)."""
    return type(log)({k: v[start:stop] for k, v in log.columns.items()}, log.sample_time, log.source)


def _model_force(model, y, currents, v=None) -> np.ndarray:
    """``model.force(y, currents, v)`` ``(n, 3)`` of one block, compiled once per block length.

    The block is padded (positions and velocities with their last value, currents with zeros) to
    :data:`BLOCK_ROWS` or, for a shorter log, to a power of two of at least 1024 rows, so that logs of
    any length share a few compiled programs; the padding's rows are dropped.
    """
    n = y.shape[0]
    size = BLOCK_ROWS if n > BLOCK_ROWS // 2 else max(1024, 1 << (n - 1).bit_length())
    pad = size - n
    y = np.pad(y, (0, pad), mode="edge")
    v = None if v is None else np.pad(v, (0, pad), mode="edge")  # None: no direction term, as model.force
    currents = np.pad(currents, ((0, pad), (0, 0), (0, 0)))
    return np.asarray(_force_program()(model, y, currents, v))[:n]


_FORCE = []


def _force_program():
    """The compiled ``(model, y, currents, v) -> model.force(y, currents, v)`` (made on first use: compiling is
    left to the logs that are evaluated with a model)."""
    if not _FORCE:
        _FORCE.append(jax.jit(lambda model, y, currents, v: model.force(y, currents, v)))
    return _FORCE[0]


def _has_pairs(log, a: str, b: str) -> bool:
    """Whether every coil set ``l`` of ``log`` has the columns ``{a}_{l}`` and ``{b}_{l}`` (without stacking them:
    :meth:`pgcomm.io.logs.Log.currents` would copy every current of a long log)."""
    n = log.n_coil_sets
    return n > 0 and all(f"{a}_{l}" in log and f"{b}_{l}" in log for l in range(1, n + 1))


@dataclass(frozen=True)
class ReconstructedForce:
    """The driving force of a log without a force sensor, from the motion, on filtered windows.

    Attributes:
        starts: ``(J,)`` window starts (samples); t: ``(J,)`` window centres (s).
        force: ``(J,)`` ``m ÿ_f + f_v ẏ_f + F_c(y) s(ẏ)_f`` (N).
        demanded: ``(J,)`` the filtered demand ``Fy*_f`` (N), or ``None`` for a log without ``Fy_star``.
        filt: the :class:`pgcomm.sensorless.AccelerationFilter`.
        mechanics: ``{"mass", "viscous", "coulomb", "friction_velocity"}`` used (kg, N s/m, N, m/s).
    """

    starts: np.ndarray
    t: np.ndarray
    force: np.ndarray
    demanded: np.ndarray | None
    filt: object
    mechanics: dict

    @property
    def error(self) -> np.ndarray | None:
        """``(J,)`` ``F_y,f − Fy*_f`` (N); ``None`` without a logged demand."""
        return None if self.demanded is None else self.force - self.demanded

    def filtered(self, columns) -> np.ndarray:
        """Raw columns ``(N,)``/``(N, k)`` filtered as the force (:func:`pgcomm.sensorless.filter_windows`)."""
        return filter_windows(self.filt, self.starts, columns)


def reconstruct_force(log, mechanics: dict, pole_pitch: float) -> ReconstructedForce:
    """``F_y = m ÿ + f_v ẏ + F_c(y) tanh(ẏ/v_ε)`` of a log, filtered as in identification without a force sensor.

    The velocity is :func:`pgcomm.data.velocity_from_positions` of the logged positions, the
    filter :meth:`pgcomm.sensorless.AccelerationFilter.for_motion` of that motion (its window is
    a share of the electrical period at the log's fast speed), the windows those of
    :func:`pgcomm.sensorless.window_starts` where the translator moves faster than the speed
    bound of :func:`pgcomm.sensorless.sensorless_data` throughout.

    Args:
        log: :class:`pgcomm.io.logs.Log` with ``y`` (and ``Fy_star`` for the demand; without it
            ``demanded`` is ``None``).
        mechanics: ``mass`` (kg), ``viscous`` (N s/m), ``coulomb`` (N), ``friction_velocity`` (m/s)
            and, if identified so, the Coulomb table ``F_c(y)``: ``coulomb_knots`` (m), ``coulomb_table``
            (N), piecewise linear (held beyond its ends); else ``F_c = coulomb`` everywhere.
        pole_pitch: ``d_m`` (m).

    Raises:
        DataError: no window in which the translator moves (names the log).
    """
    ts = log.sample_time
    y = log["y"]
    v = velocity_from_positions(y, ts)
    filt = sl.AccelerationFilter.for_motion(v, ts, pole_pitch)
    v_eps = float(mechanics["friction_velocity"])
    starts, v_min = sl.moving_windows(filt, v, np.zeros(y.shape[0], int), v_eps)
    if starts.size == 0:
        raise DataError(f"{log.source}: no window of {filt.span} samples in which the translator moves faster than "
                        f"{1e3 * v_min:.3g} mm/s; the force cannot be reconstructed from the motion")
    acc = sl.filtered_acceleration(filt, starts, y)
    # the friction columns exactly as identification filters them (SensorlessData.filtered_friction)
    knots, table = _coulomb_table(mechanics, y)
    n = y.shape[0]
    raw = CoilSetData(y, np.zeros((n, 2)), np.zeros((n, 3)), name=log.source, velocity=v)
    mass = float(mechanics["mass"])
    frame = sl.SensorlessData(raw, starts, mass * acc, filt, mass, v_eps, knots)
    force = mass * acc + frame.filtered_friction() @ np.concatenate([table, [float(mechanics["viscous"])]])
    demanded = sl.filter_windows(filt, starts, log["Fy_star"]) if "Fy_star" in log else None
    t = log.t[starts] + 0.5 * (filt.length + 1) * ts
    mech = {k: float(mechanics[k]) for k in ("mass", "viscous", "coulomb", "friction_velocity")}
    if "coulomb_table" in mechanics:
        mech.update(coulomb_knots=[float(x) for x in knots], coulomb_table=[float(x) for x in table])
    return ReconstructedForce(starts, t, force, demanded, filt, mech)


def _coulomb_table(mechanics: dict, y) -> tuple[np.ndarray, np.ndarray]:
    """``(knots (m), F_c at the knots (N))`` of the Coulomb friction: the identified table
    (``coulomb_knots``, ``coulomb_table``), else the constant ``coulomb`` over the log's span."""
    if mechanics.get("coulomb_table") is not None and mechanics.get("coulomb_knots") is not None:
        knots = np.asarray(mechanics["coulomb_knots"], float)
        table = np.asarray(mechanics["coulomb_table"], float)
        if knots.ndim != 1 or knots.shape != table.shape or knots.shape[0] < 2 or np.any(np.diff(knots) <= 0) \
                or not np.isfinite(table).all():
            raise DataError(f"mechanics: coulomb_knots ({knots.shape[0]}) must increase and match coulomb_table "
                            f"({table.shape[0]} finite values)")
        return knots, table
    lo, hi = float(np.min(y)), float(np.max(y))
    return np.array([lo, max(hi, lo + 1e-9)]), np.full(2, float(mechanics["coulomb"]))


def _mse_y_only(value: float | None) -> dict:
    """``{dir: {"filtered", "unfiltered"}}`` with only ``y.filtered`` known (reconstructed force)."""
    return {"y": {"filtered": value, "unfiltered": None}, "x": {"filtered": None, "unfiltered": None},
            "z": {"filtered": None, "unfiltered": None}}


def _mse_unknown() -> dict:
    """``{dir: {"filtered": None, "unfiltered": None}}``: the schema of an MSE that could not be computed."""
    return {d: {"filtered": None, "unfiltered": None} for d in DIRECTIONS}


def log_names(files) -> list[str]:
    """A distinct short name per log file: the shortest end of its path that no other file shares.

    The last part is the file's stem (``run.csv`` -> ``run``), or its full name where two files
    differ only in their extension; parent folders are added from the right until the name is
    unique (``a/log.csv``, ``b/log.csv`` -> ``a/log``, ``b/log``). Paths are made absolute first
    (without resolving links), so ``log.csv`` and ``../x/log.csv`` are told apart by their folders.
    A file given twice gets `` (2)``, `` (3)``, ... after its second and later occurrences.

    Args:
        files: ``(n,)`` paths (str or Path).

    Returns:
        ``(n,)`` names, in the order of ``files``.
    """
    paths = [Path(os.path.abspath(str(f))) for f in files]
    stems = [p.parent / p.stem for p in paths]
    # files that differ only in their extension keep it; a file given twice is no clash
    clash = {s for s, n in Counter(p.parent / p.stem for p in set(paths)).items() if n > 1}
    keys = [tuple((p.parent / (p.name if s in clash else p.stem)).parts) for p, s in zip(paths, stems)]
    names = []
    for i, key in enumerate(keys):
        others = [k for j, k in enumerate(keys) if j != i and k != key]
        n = 1
        while n < len(key) and any(k[-n:] == key[-n:] for k in others):
            n += 1
        names.append("/".join(key[-n:]).lstrip("/") or str(files[i]))
    seen: Counter = Counter()
    out = []
    for name, key in zip(names, keys):
        seen[key] += 1
        out.append(name if seen[key] == 1 else f"{name} ({seen[key]})")
    return out


@dataclass(frozen=True)
class LogEvaluation:
    """Evaluation of one log.

    The attributes ``t, r, e, commutation_error, sample_time`` mirror
    :class:`pgcomm.simulate.SimResult`.

    Attributes:
        file: the log's file name; label: its name in figures, tables and results.json (its stem;
            :func:`evaluate_logs` makes the names of several logs distinct, :func:`log_names`).
        t: ``(N,)`` s; y: ``(N,)`` logged position (m); r: ``(N,)`` reference (m) or ``None``.
        e: ``(N,)`` tracking error ``r − y`` (m) or ``None`` without ``r``.
        commutation_error: ``(N, 3)`` ``F − F*`` (N, N, N·m); ``None`` when the force is reconstructed
            or the log has no desired force (then every entry of ``commutation_mse`` is ``None``).
        sample_time: s; lowpass_hz: cut-off of ``H(z)`` (Hz).
        commutation_mse: ``{dir: {"filtered", "unfiltered"}}`` (N², N²m² for z).
        tracking_mse: m², or ``None`` without ``r``.
        model_error: ``(N, 3)`` ``F − F̂(y, i)`` or ``None`` (no model).
        model_mse: as ``commutation_mse`` for ``model_error``, or ``None``.
        currents: ``"logged"``, ``"from drive inputs"`` or ``None`` (no model: not needed).
        range_warning: text when positions leave the model's training range, else ``None``.
        notes: what was skipped and why.
        reconstructed: :class:`ReconstructedForce` for a log without a force sensor, else ``None``
            (then ``commutation_mse`` and ``model_mse`` hold the y row on its windows only).
        window_model_error: ``(J,)`` ``F_y,f − F̂_y,f`` on those windows (with a model), else ``None``.
    """

    file: str
    label: str
    t: np.ndarray
    y: np.ndarray
    r: np.ndarray | None
    e: np.ndarray | None
    commutation_error: np.ndarray | None
    sample_time: float
    lowpass_hz: float
    commutation_mse: dict
    tracking_mse: float | None
    model_error: np.ndarray | None = None
    model_mse: dict | None = None
    currents: str | None = None
    range_warning: str | None = None
    notes: tuple = field(default=())
    reconstructed: ReconstructedForce | None = None
    window_model_error: np.ndarray | None = None

    @property
    def force_reconstructed(self) -> bool:
        """Whether the driving force was reconstructed from the motion (log without a force sensor)."""
        return self.reconstructed is not None

    @property
    def samples(self) -> int:
        """Number of samples ``N``."""
        return int(self.t.shape[0])

    def to_dict(self) -> dict:
        """``evaluation.logs[i]`` of results.json."""
        out = {"file": self.file, "name": self.label, "samples": self.samples, "sample_time": self.sample_time,
               "commutation_mse": self.commutation_mse, "tracking_mse": self.tracking_mse, "notes": list(self.notes),
               "force_reconstructed": self.force_reconstructed}
        if self.reconstructed is not None:
            rc = self.reconstructed
            out["reconstruction"] = {"formula": "m*ddy + viscous*dy + F_c(y)*tanh(dy/friction_velocity), F_c(y) piecewise linear "
                                                "on coulomb_knots (else the constant coulomb)",
                                     "mechanics": rc.mechanics, "filter": rc.filt.to_dict(),
                                     "windows": int(rc.starts.shape[0])}
        if self.model_mse is not None or self.range_warning is not None:
            out["model_mse"] = self.model_mse
            out["model_currents"] = self.currents
            out["range_warning"] = self.range_warning
        return out


def evaluate_log(log, lowpass_hz: float = 50.0, model=None, motor=None, mechanics: dict | None = None,
                 pole_pitch: float | None = None) -> LogEvaluation:
    """Evaluate one log (see the module docstring).

    Args:
        log: :class:`pgcomm.io.logs.Log` with ``y, Fy, Fx, Tz`` and ``Fy_star, Fx_star, Tz_star``,
            or without a force sensor ``y`` and ``Fy_star``. With a ``model`` the desired force may be
            missing: the commutation error is then skipped (``commutation_mse`` all ``None``, a note).
        lowpass_hz: cut-off ``f_lp`` of ``H(z)`` (Hz); the paper uses 50 Hz.
        model: a combined model (``force(y, currents (N, L, 2)) -> (N, 3)``, ``n_coil_sets``,
            training range), or ``None``.
        motor: :class:`pgcomm.motor.Motor` converting drive-input logs to currents (model error only).
        mechanics: for a log without a force sensor: ``mass`` (kg), ``viscous`` (N s/m),
            ``coulomb`` (N), ``friction_velocity`` (m/s) of :func:`reconstruct_force`.
        pole_pitch: ``d_m`` (m) for the reconstruction's window; default the model's, else the motor's.

    Raises:
        DataError: without a model, the desired-force columns are missing (names the file and the
            columns); a log without a force sensor and no ``mechanics``; the log's coil sets do not
            match the model's.
    """
    _check_inputs(log, model, motor, mechanics)
    if not log.has_force:
        return _evaluate_reconstructed(log, lowpass_hz, model, motor, mechanics, pole_pitch)
    ts = log.sample_time
    notes = []
    r = log["r"] if "r" in log else None
    e = None if r is None else r - log["y"]
    if r is None:
        notes.append("no column r (reference): tracking error skipped")
    missing = missing_desired_force(log)
    if missing:
        notes.append(_skipped_note(missing))
        err, mse = None, _mse_unknown()
    else:
        err, acc = np.empty((log.n_samples, 3)), RunningMse(ts, lowpass_hz)
        for a, b in _blocks(log.n_samples):
            part = _rows(log, a, b)
            err[a:b] = part.force() - part.desired_force()
            acc.add(err[a:b])
        mse = acc.result()
    ev = dict(file=log.source, label=Path(log.source).stem, t=log.t, y=log["y"], r=r, e=e,
              commutation_error=err, sample_time=ts, lowpass_hz=float(lowpass_hz), commutation_mse=mse,
              tracking_mse=None if e is None else tracking_mse(e), notes=tuple(notes))
    if model is not None:
        ev.update(_model_fit(log, model, motor, lowpass_hz))
    return LogEvaluation(**ev)


def missing_desired_force(log) -> list[str]:
    """The desired-force columns ``log`` lacks for its commutation error: of ``Fy_star, Fx_star, Tz_star``
    with a force sensor, of ``Fy_star`` without one (only ``Fy`` is reconstructed). Empty when complete."""
    need = STAR_COLUMNS if log.has_force else STAR_COLUMNS[:1]
    return [c for c in need if c not in log]


def _skipped_note(missing) -> str:
    return (f"no desired force ({', '.join(missing)} missing): commutation error F - F* skipped; "
            "the model error F - F^(y, i) does not need it")


def require_desired_force(log) -> None:
    """Raise :class:`DataError` naming the file and the missing columns if ``log`` has no ``F*``
    (a log without a force sensor needs ``Fy_star`` only). Used where no model is given: the
    commutation error is then all there is to compute."""
    missing = missing_desired_force(log)
    if not missing:
        return
    if not log.has_force:
        raise DataError(f"{log.source}: column Fy_star missing: a log without a force sensor is evaluated by "
                        "comparing the force reconstructed from the motion with the demanded force Fy_star (N); "
                        "with --model its model error needs no Fy_star")
    raise DataError(f"{log.source}: column(s) {', '.join(missing)} missing: evaluating the commutation error "
                    "F - F* needs the desired force Fy_star, Fx_star, Tz_star (N, N, N m) in every log; "
                    "with --model the model error F - F^(y, i) is computed without it")


def _check_inputs(log, model, motor, mechanics) -> None:
    """Everything :func:`evaluate_log` needs from ``log`` that can be checked without computing (columns,
    coil sets, the motor for drive inputs, the mechanics for a log without a force sensor).

    Raises:
        DataError: naming the log and what is missing.
    """
    if model is None:
        require_desired_force(log)
    if not log.has_force and mechanics is None:
        raise DataError(f"{log.source}: no force columns Fy, Fx, Tz: evaluating it reconstructs the force from "
                        "the motion, which needs the mass and the friction identified without a force sensor "
                        "(a model of pgcomm identify --no-force-sensor)")
    if model is None:
        return
    n = log.n_coil_sets
    if not _has_pairs(log, "ia", "ib"):
        if not _has_pairs(log, "Fy_ref", "delta"):
            raise DataError(f"{log.source}: no currents ia_l, ib_l (or drive inputs Fy_ref_l, delta_l) for every coil "
                            "set: the model error F - F^(y, i) needs the currents")
        if motor is None:
            raise DataError(f"{log.source}: no currents ia_l, ib_l; converting drive inputs needs the drive's motor")
        if n != motor.n_coil_sets:
            raise DataError(f"{log.source}: {n} coil sets in the log, the motor has {motor.n_coil_sets}")
    if n != model.n_coil_sets:
        raise DataError(f"{log.source}: {n} coil sets in the log, the model has {model.n_coil_sets}")


def _evaluate_reconstructed(log, lowpass_hz, model, motor, mechanics, pole_pitch) -> LogEvaluation:
    """:func:`evaluate_log` of a log without a force sensor: the force from the motion (module docstring)."""
    if mechanics is None:
        raise DataError(f"{log.source}: no force columns Fy, Fx, Tz: evaluating it reconstructs the force from the "
                        "motion, which needs the mass and the friction identified without a force sensor (a model "
                        "of pgcomm identify --no-force-sensor)")
    if pole_pitch is None:
        pole_pitch = model.pole_pitch if model is not None else (motor.pole_pitch if motor is not None else None)
    if pole_pitch is None:
        raise ValueError("evaluate_log: a log without a force sensor needs pole_pitch, a model or a motor")
    rc = reconstruct_force(log, mechanics, float(pole_pitch))
    m = rc.mechanics
    compared = ("compared with the demanded Fy*" if rc.demanded is not None else "compared with the model's Fy")
    notes = [f"no force columns: Fy reconstructed from the motion as m ÿ + f_v ẏ + F_c(y) s(ẏ) (m = {m['mass']:.4g} "
             f"kg, f_v = {m['viscous']:.4g} N s/m, F_c of mean {m['coulomb']:.4g} N) and {compared} "
             f"on {rc.starts.shape[0]} filtered windows of {rc.filt.length} samples; x, z not observable (n/a)"]
    if rc.demanded is None:
        notes.append(_skipped_note(missing_desired_force(log)))
    r = log["r"] if "r" in log else None
    e = None if r is None else r - log["y"]
    if r is None:
        notes.append("no column r (reference): tracking error skipped")
    ev = dict(file=log.source, label=Path(log.source).stem, t=log.t, y=log["y"], r=r, e=e, commutation_error=None,
              sample_time=log.sample_time, lowpass_hz=float(lowpass_hz),
              commutation_mse=_mse_y_only(None if rc.error is None else float(np.mean(rc.error ** 2))),
              tracking_mse=None if e is None else tracking_mse(e), notes=tuple(notes), reconstructed=rc)
    if model is not None:

        source = _currents_source(log, model, motor)
        fy_hat = np.empty(log.n_samples)
        for a, b in _blocks(log.n_samples):
            part = _rows(log, a, b)
            fy_hat[a:b] = _model_force(model, part["y"], _currents(part, motor))[:, 0]
        err = rc.force - rc.filtered(fy_hat)
        ev.update(model_mse=_mse_y_only(float(np.mean(err ** 2))), window_model_error=err, currents=source,
                  range_warning=warn_outside_training_range(model, log["y"]))
    return LogEvaluation(**ev)


def _currents_source(log, model, motor) -> str:
    """``"logged"`` or ``"from drive inputs"``: where :func:`_currents` takes a log's currents from, checked
    against the model's coil sets."""
    cur = _has_pairs(log, "ia", "ib")
    if not cur and motor is None:
        raise DataError(f"{log.source}: no currents ia_l, ib_l; converting drive inputs needs the drive's motor")
    if log.n_coil_sets != model.n_coil_sets:
        raise DataError(f"{log.source}: {log.n_coil_sets} coil sets in the log, the model has {model.n_coil_sets}")
    return "logged" if cur else "from drive inputs"


def _currents(log, motor) -> np.ndarray:
    """Star currents ``(N, L, 2)`` (A) of a log (or of a block of its rows): logged, or from the drive inputs."""
    return np.asarray(log_currents(log, motor))


def _model_fit(log, model, motor, lowpass_hz) -> dict:
    """``model_error``, ``model_mse``, ``currents``, ``range_warning`` of one log, block by block."""
    source = _currents_source(log, model, motor)
    y = log["y"]
    # a model with a direction term predicts C(y) s(ẏ) too: give it the velocity, as identification did (the
    # whole log's: the velocity filter's window must not stop at a block's edge)
    v = velocity_from_positions(y, log.sample_time) if model.has_direction else None
    err, acc = np.empty((log.n_samples, 3)), RunningMse(log.sample_time, lowpass_hz)
    for a, b in _blocks(log.n_samples):
        part = _rows(log, a, b)
        err[a:b] = part.force() - _model_force(model, part["y"], _currents(part, motor), None if v is None else v[a:b])
        acc.add(err[a:b])
    return {"model_error": err, "model_mse": acc.result(), "currents": source,
            "range_warning": warn_outside_training_range(model, y)}


def evaluate_logs(logs, lowpass_hz: float = 50.0, model=None, motor=None, mechanics: dict | None = None,
                  pole_pitch: float | None = None) -> list[LogEvaluation]:
    """:func:`evaluate_log` for each log, each named distinctly (:func:`log_names`).

    Every log is checked before any work is done: ``F*`` where no model is given, the mechanics
    for a log without a force sensor, with a model its currents (or drive inputs and ``motor``)
    and coil sets.
    """
    logs = list(logs)
    for log in logs:  # refuse before any work: a bad last log should not cost the first ones' time
        _check_inputs(log, model, motor, mechanics)
    names = log_names([log.source for log in logs])
    return [replace(evaluate_log(log, lowpass_hz, model, motor, mechanics, pole_pitch), label=name)
            for log, name in zip(logs, names)]


def evaluation_results(evaluations, lowpass_hz: float = 50.0, model: str | None = None) -> dict:
    """The ``evaluation`` block of results.json.

    ``logs[i]`` holds ``file``, ``name`` (distinct, :func:`log_names`), ``samples``, ``commutation_mse.{y,x,z}.{filtered,unfiltered}``,
    ``tracking_mse`` (``null`` without ``r``) and, with a model, ``model_mse`` and
    ``range_warning``; ``warnings`` lists every range warning and note with its file. A log
    without a force sensor has ``force_reconstructed: true``, its ``reconstruction`` (mechanics,
    filter, windows) and only ``y.filtered`` of the MSEs (the others ``null``); the block's
    ``force_reconstructed`` says whether any log's force was reconstructed.
    """
    warnings = [f"{ev.file}: {ev.range_warning}" for ev in evaluations if ev.range_warning]
    notes = [f"{ev.file}: {n}" for ev in evaluations for n in ev.notes]
    return {"lowpass_hz": float(lowpass_hz), "model": model, "logs": [ev.to_dict() for ev in evaluations],
            "force_reconstructed": any(ev.force_reconstructed for ev in evaluations),
            "warnings": warnings, "notes": notes}


def format_table(evaluations) -> str:
    """Text table: per log, filtered (unfiltered) MSE per direction, tracking MSE and, with a model, model MSE."""
    with_model = any(ev.model_mse is not None for ev in evaluations)
    # the whole name, never cut: two logs whose names differ only at the start must stay apart
    w = max([24] + [len(ev.label) for ev in evaluations])
    head = f"{'log':{w}s} {'y [N^2]':>19s} {'x [N^2]':>19s} {'z [N^2m^2]':>19s} {'tracking [m^2]':>15s}"
    lines = [head]
    for ev in evaluations:
        cells = [_cell(ev.commutation_mse[d], ev.force_reconstructed) for d in DIRECTIONS]
        tr = "-" if ev.tracking_mse is None else f"{ev.tracking_mse:.3g}"
        lines.append(f"{ev.label:{w}s} {cells[0]:>19s} {cells[1]:>19s} {cells[2]:>19s} {tr:>15s}")
    if with_model:
        lines.append("model error F - F^(y, i), filtered (unfiltered):")
        for ev in evaluations:
            if ev.model_mse is None:
                continue
            cells = [_cell(ev.model_mse[d], ev.force_reconstructed) for d in DIRECTIONS]
            lines.append(f"{ev.label:{w}s} {cells[0]:>19s} {cells[1]:>19s} {cells[2]:>19s}")
    if any(ev.commutation_mse["y"]["filtered"] is None for ev in evaluations):
        lines.append("n/a: no desired force F* in the log, commutation error skipped (the model error does not "
                     "need it)")
    if any(ev.force_reconstructed for ev in evaluations):
        lines.append("(rec.): no force sensor; Fy reconstructed from the motion (m ÿ + f_v ẏ + F_c(y) s(ẏ)) and compared "
                     "on zero-phase filtered windows; x, z not observable")
    return "\n".join(lines)


def _cell(mse: dict, reconstructed: bool) -> str:
    """``filtered (unfiltered)``; a reconstructed force's y as ``value (rec.)``, unknowns as ``n/a``."""
    f, u = mse["filtered"], mse["unfiltered"]
    if f is None:
        return "n/a"
    return f"{f:.3g} (rec.)" if reconstructed else f"{f:.3g} ({u:.3g})"
