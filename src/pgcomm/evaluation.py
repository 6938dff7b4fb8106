"""Evaluation of rig (or simulation) logs: commutation error, tracking error, model fit.

For each log (:class:`pgcomm.io.logs.Log`):

* the commutation error ``F − F*`` (N, N, N·m) from the measured force ``Fy, Fx, Tz`` and
  the desired force ``Fy_star, Fx_star, Tz_star`` (required), its MSE per direction
  unfiltered and filtered by the paper's 50 Hz ZOH low-pass ``H(z)``
  (:func:`pgcomm.metrics.commutation_mse`), as in Table Commutation_Performance;
* the tracking-error MSE of ``e = r − y`` (m²) when the reference ``r`` is logged (with the
  logged, i.e. measured, position ``y``); skipped otherwise, with a note;
* with a model ``F̂``: the model error ``F − F̂(y, i)`` (how well the model explains the
  rig) with the same MSEs, where currents are logged (or drive inputs converted with the
  drive's ``k̂``, ``ζ̂``), and a warning when positions leave the model's training range.

Figures (:func:`plot_logs`, :func:`plot_model_error`) overlay all logs, one line per log
labelled by its file stem, in the layout of the paper's Figs. CommutationError_Ref1/2
(:func:`pgcomm.plots.plot_comparison`). Logs may have different lengths, so every log is
drawn against its own time axis.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pgcomm.errors import DataError
from pgcomm.metrics import DIRECTIONS, commutation_mse, lowpass, tracking_mse

__all__ = ["LogEvaluation", "evaluate_log", "evaluate_logs", "evaluation_results", "plot_logs", "plot_model_error",
           "format_table", "require_desired_force", "STAR_COLUMNS"]

#: Desired-force columns a log needs to be evaluated.
STAR_COLUMNS = ("Fy_star", "Fx_star", "Tz_star")


@dataclass(frozen=True)
class LogEvaluation:
    """Evaluation of one log.

    The attributes ``t, r, e, commutation_error, sample_time`` mirror
    :class:`pgcomm.simulate.SimResult`.

    Attributes:
        file: the log's file name; label: its stem (figure legend).
        t: ``(N,)`` s; y: ``(N,)`` logged position (m); r: ``(N,)`` reference (m) or ``None``.
        e: ``(N,)`` tracking error ``r − y`` (m) or ``None`` without ``r``.
        commutation_error: ``(N, 3)`` ``F − F*`` (N, N, N·m).
        sample_time: s; lowpass_hz: cut-off of ``H(z)`` (Hz).
        commutation_mse: ``{dir: {"filtered", "unfiltered"}}`` (N², N²m² for z).
        tracking_mse: m², or ``None`` without ``r``.
        model_error: ``(N, 3)`` ``F − F̂(y, i)`` or ``None`` (no model).
        model_mse: as ``commutation_mse`` for ``model_error``, or ``None``.
        currents: ``"logged"``, ``"from drive inputs"`` or ``None`` (no model: not needed).
        range_warning: text when positions leave the model's training range, else ``None``.
        notes: what was skipped and why.
    """

    file: str
    label: str
    t: np.ndarray
    y: np.ndarray
    r: np.ndarray | None
    e: np.ndarray | None
    commutation_error: np.ndarray
    sample_time: float
    lowpass_hz: float
    commutation_mse: dict
    tracking_mse: float | None
    model_error: np.ndarray | None = None
    model_mse: dict | None = None
    currents: str | None = None
    range_warning: str | None = None
    notes: tuple = field(default=())

    @property
    def samples(self) -> int:
        """Number of samples ``N``."""
        return int(self.t.shape[0])

    def to_dict(self) -> dict:
        """``evaluation.logs[i]`` of results.json."""
        out = {"file": self.file, "samples": self.samples, "sample_time": self.sample_time,
               "commutation_mse": self.commutation_mse, "tracking_mse": self.tracking_mse, "notes": list(self.notes)}
        if self.model_mse is not None or self.range_warning is not None:
            out["model_mse"] = self.model_mse
            out["model_currents"] = self.currents
            out["range_warning"] = self.range_warning
        return out


def evaluate_log(log, lowpass_hz: float = 50.0, model=None, motor=None) -> LogEvaluation:
    """Evaluate one log (see the module docstring).

    Args:
        log: :class:`pgcomm.io.logs.Log` with ``y, Fy, Fx, Tz`` and ``Fy_star, Fx_star, Tz_star``.
        lowpass_hz: cut-off ``f_lp`` of ``H(z)`` (Hz); the paper uses 50 Hz.
        model: a combined model (``force(y, currents (N, L, 2)) -> (N, 3)``, ``n_coil_sets``,
            training range), or ``None``.
        motor: :class:`pgcomm.motor.Motor` converting drive-input logs to currents (model error only).

    Raises:
        DataError: the desired-force columns are missing (names the file and the columns), or
            the log's coil sets do not match the model's.
    """
    require_desired_force(log)
    f, f_star = log.force(), log.desired_force()
    ts = log.sample_time
    notes = []
    r = log["r"] if "r" in log else None
    e = None if r is None else r - log["y"]
    if r is None:
        notes.append("no column r (reference): tracking error skipped")
    ev = dict(file=log.source, label=Path(log.source).stem, t=log.t, y=log["y"], r=r, e=e,
              commutation_error=f - f_star, sample_time=ts, lowpass_hz=float(lowpass_hz),
              commutation_mse=commutation_mse(f, f_star, ts, lowpass_hz),
              tracking_mse=None if e is None else tracking_mse(e), notes=tuple(notes))
    if model is not None:
        ev.update(_model_fit(log, model, motor, lowpass_hz))
    return LogEvaluation(**ev)


def require_desired_force(log) -> None:
    """Raise :class:`DataError` naming the file and the missing columns if ``log`` has no ``F*``."""
    missing = [c for c in STAR_COLUMNS if c not in log]
    if missing:
        raise DataError(f"{log.source}: column(s) {', '.join(missing)} missing: evaluating the commutation error "
                        "F - F* needs the desired force Fy_star, Fx_star, Tz_star (N, N, N m) in every log")


def _model_fit(log, model, motor, lowpass_hz) -> dict:
    """``model_error``, ``model_mse``, ``currents``, ``range_warning`` of one log."""
    import jax.numpy as jnp

    from pgcomm.data import log_currents
    from pgcomm.models import warn_outside_training_range

    cur = log.currents()
    source = "logged"
    if cur is None:
        if motor is None:
            raise DataError(f"{log.source}: no currents ia_l, ib_l; converting drive inputs needs the drive's motor")
        cur, source = log_currents(log, motor), "from drive inputs"
    if cur.shape[1] != model.n_coil_sets:
        raise DataError(f"{log.source}: {cur.shape[1]} coil sets in the log, the model has {model.n_coil_sets}")
    y = log["y"]
    f_hat = np.asarray(model.force(jnp.asarray(y), jnp.asarray(cur)))
    f = log.force()
    return {"model_error": f - f_hat, "model_mse": commutation_mse(f, f_hat, log.sample_time, lowpass_hz),
            "currents": source, "range_warning": warn_outside_training_range(model, y)}


def evaluate_logs(logs, lowpass_hz: float = 50.0, model=None, motor=None) -> list[LogEvaluation]:
    """:func:`evaluate_log` for each log; every log is checked for ``F*`` before any work is done."""
    logs = list(logs)
    for log in logs:  # refuse before any work: a bad last log should not cost the first ones' time
        require_desired_force(log)
    return [evaluate_log(log, lowpass_hz, model, motor) for log in logs]


def evaluation_results(evaluations, lowpass_hz: float = 50.0, model: str | None = None) -> dict:
    """The ``evaluation`` block of results.json.

    ``logs[i]`` holds ``file``, ``samples``, ``commutation_mse.{y,x,z}.{filtered,unfiltered}``,
    ``tracking_mse`` (``null`` without ``r``) and, with a model, ``model_mse`` and
    ``range_warning``; ``warnings`` lists every range warning and note with its file.
    """
    warnings = [f"{ev.file}: {ev.range_warning}" for ev in evaluations if ev.range_warning]
    notes = [f"{ev.file}: {n}" for ev in evaluations for n in ev.notes]
    return {"lowpass_hz": float(lowpass_hz), "model": model, "logs": [ev.to_dict() for ev in evaluations],
            "warnings": warnings, "notes": notes}


# ------------------------------------------------------------------------------------------ figures

_MODEL_LABEL = ("$F_y - \\hat F_y$ [N]", "$F_x - \\hat F_x$ [N]", "$T_z - \\hat T_z$ [N m]")


def _colors(n):
    import matplotlib.pyplot as plt

    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    return [cycle[i % len(cycle)] for i in range(n)]


def plot_logs(evaluations, title: str = ""):
    """All logs overlaid: position, filtered commutation error in y, x, z, tracking error.

    The layout of :func:`pgcomm.plots.plot_comparison`, one line per log (legend: file stem);
    the first panel shows ``r`` where logged, else the logged position ``y`` (dashed).
    Returns a Matplotlib figure.
    """
    from pgcomm import plots  # selects the Agg backend
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(5, 1, figsize=(10, 10), sharex=True)
    for ev, c in zip(evaluations, _colors(len(evaluations))):
        if ev.r is not None:
            ax[0].plot(ev.t, ev.r * 1e3, lw=0.9, color=c, label=ev.label)
        else:
            ax[0].plot(ev.t, ev.y * 1e3, "--", lw=0.9, color=c, label=f"{ev.label} (y)")
        err = lowpass(ev.commutation_error, ev.sample_time, ev.lowpass_hz)
        plots.draw_error_lines(ax, ev.t, err, ev.e, c, ev.label)
    ax[0].set_ylabel("$y^*$ [mm]")
    if not any(ev.e is not None for ev in evaluations):
        ax[4].text(0.5, 0.5, "no reference r logged: tracking error not available", transform=ax[4].transAxes,
                   ha="center", va="center")
    ax[0].legend(loc="upper right", ncol=min(4, len(evaluations)), fontsize=8)
    lp = evaluations[0].lowpass_hz if evaluations else 50.0
    ax[1].set_title(f"commutation error, {lp:g} Hz low-pass", fontsize=10)
    plots.finish_error_axes(fig, ax, title)
    return fig


def plot_model_error(evaluations, title: str = "model error F - F̂(y, i)"):
    """Filtered model error ``F − F̂(y, i)`` in y, x, z, one line per log with a model fit."""
    from pgcomm import plots  # noqa: F401  (selects the Agg backend)
    import matplotlib.pyplot as plt

    evs = [ev for ev in evaluations if ev.model_error is not None]
    fig, ax = plt.subplots(3, 1, figsize=(10, 7), sharex=True)
    for ev, c in zip(evs, _colors(len(evs))):
        err = lowpass(ev.model_error, ev.sample_time, ev.lowpass_hz)
        for q in range(3):
            ax[q].plot(ev.t, err[:, q], lw=0.7, color=c, label=ev.label)
    for q in range(3):
        ax[q].set_ylabel(_MODEL_LABEL[q])
        ax[q].grid(alpha=0.3)
    ax[2].set_xlabel("time [s]")
    if evs:
        ax[0].legend(loc="upper right", ncol=min(4, len(evs)), fontsize=8)
    lp = evs[0].lowpass_hz if evs else 50.0
    ax[0].set_title(f"{title}, {lp:g} Hz low-pass", fontsize=10)
    fig.tight_layout()
    return fig


def format_table(evaluations) -> str:
    """Text table: per log, filtered (unfiltered) MSE per direction, tracking MSE and, with a model, model MSE."""
    with_model = any(ev.model_mse is not None for ev in evaluations)
    head = f"{'log':24s} {'y [N^2]':>19s} {'x [N^2]':>19s} {'z [N^2m^2]':>19s} {'tracking [m^2]':>15s}"
    lines = [head]
    for ev in evaluations:
        cells = [f"{ev.commutation_mse[d]['filtered']:.3g} ({ev.commutation_mse[d]['unfiltered']:.3g})"
                 for d in DIRECTIONS]
        tr = "-" if ev.tracking_mse is None else f"{ev.tracking_mse:.3g}"
        lines.append(f"{ev.label[:24]:24s} {cells[0]:>19s} {cells[1]:>19s} {cells[2]:>19s} {tr:>15s}")
    if with_model:
        lines.append("model error F - F^(y, i), filtered (unfiltered):")
        for ev in evaluations:
            if ev.model_mse is None:
                continue
            cells = [f"{ev.model_mse[d]['filtered']:.3g} ({ev.model_mse[d]['unfiltered']:.3g})" for d in DIRECTIONS]
            lines.append(f"{ev.label[:24]:24s} {cells[0]:>19s} {cells[1]:>19s} {cells[2]:>19s}")
    return "\n".join(lines)
