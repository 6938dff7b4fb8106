"""Rotary plan folders: the files of a :class:`pgcomm.rotary.plan.RotaryPlan` for a drive.

Layout (written by :func:`write_rotary_plan`)::

    DIR/plan.md                  what to run, how to set the drive, what to log, what next
    DIR/plan.json                the same for programs and for the script (schema ``pgcomm-rotary-plan/1``)
    DIR/motor.toml               the motor description the plan is for (``pgcomm identify --motor``)
    DIR/columns.toml             the column map of the drive's log names (``pgcomm identify --columns``)
    DIR/references/<run>.csv     one file per run, one row per log period: t (s), speed (rad/s, the
                                 speed loop's setpoint), dither (A, the q-current added to the loop's)
    DIR/run_<drive>.py           moteus and odrive: runs the plan with the drive's Python package and logs
                                 logs/<run>.csv under the drive's names (:mod:`pgcomm.rotary.drive_scripts`)

A first round without runs left (every map resolved) writes plan.md, plan.json and motor.toml only.
"""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path

from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.config import rotary_motor_to_toml
from pgcomm.io.logs import Log, write_log
from pgcomm.rotary.drive_scripts import SCRIPTS
from pgcomm.rotary.plan import DRIVE_COLUMNS, MAPS, RotaryPlan, swing_bound

__all__ = ["SCHEMA", "write_rotary_plan", "rotary_plan_to_dict", "rotary_plan_markdown", "columns_toml",
           "script_text"]

#: ``schema`` of plan.json.
SCHEMA = "pgcomm-rotary-plan/1"

#: What each log-format column holds, for plan.md.
_MEANING = {"t": "the host's time stamp (s), as taken: not a uniform grid",
            "theta": "the rotor's angle, multi-turn",
            "velocity": "the drive's speed estimate",
            "iq_1": "the measured q-axis current (A)",
            "id_1": "the measured d-axis current (A): its noise is read from it"}


def script_text(drive: str) -> str:
    """The source of the drive's script (:mod:`pgcomm.rotary.drive_scripts`), as written beside the plan."""
    return resources.files("pgcomm.rotary.drive_scripts").joinpath(f"{SCRIPTS[drive]}.py").read_text()


def columns_toml(drive: str) -> str:
    """The column map (``pgcomm.io.logs`` format) of the columns the drive's script writes."""
    cols = DRIVE_COLUMNS[drive]
    lines = [f"# pgcomm column map: the {drive} logs' names and units -> the log format (pgcomm identify --columns)"]
    if drive == "generic":
        lines.append("# edit the names and units to your logger's (units: theta rad, mrad, deg, rev; velocity rad/s, "
                     "deg/s, rev/s, rpm)")
    lines.append("[columns]")
    lines += [f'{name} = "{col}"' for name, (col, _) in cols.items()]
    lines.append("[units]")
    lines += [f'{name} = "{unit}"' for name, (_, unit) in cols.items() if unit is not None]
    return "\n".join(lines) + "\n"


def rotary_plan_to_dict(plan: RotaryPlan, drive: str, commands: dict) -> dict:
    """The JSON document of ``plan`` (SI units), as the scripts read it."""
    runs = []
    for r in plan.runs:
        runs.append({"name": r.name, "reference": f"references/{r.name}.csv", "speed_rad_s": r.speed,
                     "speed_rev_s": r.speed / (2.0 * math.pi), "cruise_s": r.cruise, "ramp_s": r.ramp,
                     "duration_s": r.duration, "revolutions": r.revolutions, "dither_hz": list(r.dither_hz),
                     "dither_amplitude_A": list(r.dither_amplitude),
                     "swing_bound_rad_s": swing_bound(r, plan.inertia_ratio)})
    first = None
    if plan.first_round is not None:
        fr = plan.first_round
        first = {"seconds": fr.seconds, "sample_time_s": fr.sample_time, "inertia_ratio_A_s2_per_rad": fr.inertia_ratio,
                 "slots_detected": fr.slots, "verdicts": fr.verdicts,
                 "standard_error": {m: {k: fr.standard_error[m].get(k) for k in ("relative", "resolved", "determined",
                                                                                 "log_time_factor_to_resolve")}
                                    for m in MAPS if m in fr.standard_error}}
    return {"schema": SCHEMA, "plan_id": plan.plan_id, "drive": drive, "motor": plan.motor.to_dict(),
            "sample_time_s": plan.sample_time, "highest_order": plan.highest_order,
            "speed_limit_rad_s": plan.speed_limit, "inertia_ratio_A_s2_per_rad": plan.inertia_ratio,
            "inertia_source": plan.inertia_source, "settings": dict(vars(plan.settings)), "runs": runs,
            "total_duration_s": plan.duration, "first_round": first, "need": plan.need, "notes": list(plan.notes),
            "log_columns": {name: {"column": col, "unit": unit} for name, (col, unit) in DRIVE_COLUMNS[drive].items()},
            "commands": dict(commands)}


def write_rotary_plan(folder, plan: RotaryPlan, drive: str, commands: dict) -> list[Path]:
    """Write ``plan`` for ``drive`` into ``folder`` (layout in the module docstring), every file atomically.

    Args:
        folder: target directory (created).
        plan: :class:`pgcomm.rotary.plan.RotaryPlan`; drive: one of :data:`pgcomm.rotary.plan.DRIVES`.
        commands: the pgcomm commands that take the logs back, ``{"identify": ..., "plan": ...}``.

    Returns:
        the written paths.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    if plan.runs:
        (folder / "references").mkdir(exist_ok=True)
        for r in plan.runs:
            p = folder / "references" / f"{r.name}.csv"
            write_log(p, Log(r.reference(plan.sample_time), plan.sample_time, source=str(p)))
            paths.append(p)
        atomic_write_text(folder / "columns.toml", columns_toml(drive))
        paths.append(folder / "columns.toml")
        if drive in SCRIPTS:
            atomic_write_text(folder / f"run_{drive}.py", script_text(drive))
            paths.append(folder / f"run_{drive}.py")
    atomic_write_text(folder / "motor.toml", rotary_motor_to_toml(plan.motor))
    atomic_write_text(folder / "plan.json", json.dumps(rotary_plan_to_dict(plan, drive, commands), indent=2) + "\n")
    atomic_write_text(folder / "plan.md", rotary_plan_markdown(plan, drive, commands))
    return paths + [folder / "motor.toml", folder / "plan.json", folder / "plan.md"]


def _seconds(s: float) -> str:
    return f"{s:.2g} s" if s < 10 else f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


_SETUP = {
    "moteus": ["Position mode as a velocity loop: the script sends position NaN, the run's velocity (rev/s) and the "
               "dither as `feedforward_torque` (N·m, the dither's current times `k_t`; `--torque-per-amp` overrides "
               "it). Tune the loop first; mjbots recommend a finite `servo.max_position_slip` for velocity control.",
               "Turn the controller's cogging compensation off (`motor.cogging_dq_scale` 0): the logs must show the "
               "cogging, not what the compensation leaves.",
               "The logged `position` is the output shaft's: the plan assumes a direct drive "
               "(`motor_position.rotor_to_output_ratio` 1)."],
    "odrive": ["Velocity control, input mode passthrough (the script sets both and enters closed loop on the axis): "
               "calibrate the axis first, and set `controller.config.vel_limit` above 1.2 times the fastest run.",
               "Turn the anti-cogging off (`controller.config.anticogging.anticogging_enabled = False`): the logs must "
               "show the cogging, not what the compensation leaves (the script refuses otherwise).",
               "`pos_estimate` is float32: start near zero turns (a reboot resets it). The runs alternate the "
               "direction so that the position stays within a run's revolutions of where it started."],
    "generic": ["Play each reference file back in your drive's speed loop: `speed` (rad/s) is the setpoint, `dither` "
                "(A) is added to the q-current the loop commands (a feed-forward current or torque).",
                "Turn the drive's own cogging compensation off: the logs must show the cogging."],
}


def rotary_plan_markdown(plan: RotaryPlan, drive: str, commands: dict) -> str:
    """plan.md: the plan in plain language for the engineer at the rig."""
    m = plan.motor
    lines = [f"# Running logs for the rotary maps: {m.name} on {'a ' + drive if drive != 'generic' else 'your drive'}",
             "", f"Plan id `{plan.plan_id}`.", ""]
    if not plan.runs:
        lines += ["The first round's logs resolve every map that more logs of the same kind can resolve: nothing more "
                  "to run.", ""]
        lines += _first_round_section(plan) + _notes(plan)
        lines += ["## Then", "", "Identify from the logs so far: `" + commands["identify"] + "`", ""]
        return "\n".join(lines)
    lines += [f"{len(plan.runs)} runs in the drive's speed loop, {_seconds(plan.duration)} of motion in all (plus a "
              "few seconds between runs): each speed in both directions, each with a q-current dither while it cruises"
              + ("" if plan.inertia_ratio is not None else " (none this round: see the dither below)") + ". "
              "Record them within one power-up: the drive must not search its encoder's index again in between (the "
              "maps are read in the encoder's frame).", ""]
    if plan.first_round is not None:
        lines += ["These runs are identified together with the first round's logs: record them before the drive "
                  "searches its index again (an absolute encoder, or the same power-on). An incremental encoder's "
                  "index can land elsewhere after a restart (half a revolution on the shared ODrive logs); then the "
                  "rounds' angles disagree, and this round's logs go on their own (plan again from them).", ""]
    lines += ["## Before you start", ""]
    lines += [f"* {s}" for s in _SETUP[drive]]
    lines += [f"* Log every {1e3 * plan.sample_time:.3g} ms. The speeds assume that period: the fastest run keeps the "
              f"model's highest order ({plan.highest_order} per revolution) at 3 or more samples per period, within "
              f"{plan.speed_limit:.4g} rad/s with the dither's swing. A slower host loses the fastest runs' windows; "
              "`pgcomm plan --data` plans again at the period the logs show."]
    if plan.inertia_ratio is not None:
        f = plan.runs[0].dither_hz
        lines.append(f"* Keep the speed loop's bandwidth well below the dither's {min(f):g}-{max(f):g} Hz: a loop that "
                     "answers the dither cancels the current variation the ripple needs (the ripple's standard error "
                     "after the round shows it).")
    if m.current_limit is not None and plan.inertia_ratio is not None:
        lines.append(f"* The q-current limit stays at {m.current_limit:g} A or above (the dither uses up to "
                     f"{100 * plan.settings.dither_share:.0f} % of it).")
    lines += ["* At the slowest speed the rotor may stall on its cogging (the logged speed drops to zero for a while): "
              "raise the speed loop's integrator gain, or leave that run out; the identification leaves out windows "
              "near standstill.", "", "## Runs, in this order", "",
              "| # | run | reference | speed (rad/s) | speed (rev/s) | cruise | dither (A at Hz) | swing (rad/s) |",
              "|---|---|---|---|---|---|---|---|"]
    for j, r in enumerate(plan.runs, start=1):
        dither = ", ".join(f"{a:.3g} at {f:g}" for a, f in zip(r.dither_amplitude, r.dither_hz)) \
            if any(r.dither_amplitude) else "none"
        lines.append(f"| {j} | {r.name} | `references/{r.name}.csv` | {r.speed:+.4g} | "
                     f"{r.speed / (2 * math.pi):+.4g} | "
                     f"{_seconds(r.cruise)} | {dither} | {swing_bound(r, plan.inertia_ratio):.3g} |")
    lines += ["", "Each run ramps from rest to its speed and back (raised cosine, "
              f"{_seconds(plan.runs[0].ramp)} each way). The reference files have one row per log period: `t` (s), "
              "`speed` (rad/s, the setpoint) and `dither` (A).", "", "## The dither", ""]
    if plan.inertia_ratio is None:
        lines.append(f"None this round: J/k0 is {plan.inertia_source}.")
    else:
        lines.append(f"A sum of cosines added to the q-current while each run cruises, sized from J/k0 = "
                     f"{plan.inertia_ratio:.4g} A·s²/rad ({plan.inertia_source}). On a free rotor it swings the speed "
                     "by at most Σ a/((J/k0) 2π f), the table's last column: at most "
                     f"{100 * plan.settings.swing:.0f} % of the run's speed, so the rotor never reverses. The "
                     f"frequencies keep {plan.settings.mains_margin_hz:g} Hz or more from every harmonic of 50 and "
                     "60 Hz.")
    lines += ["", "## Run it", ""]
    if drive == "generic":
        lines.append("Play the references back with your drive's tools and log the columns below.")
    else:
        lines += [f"`python run_{drive}.py` runs every run and writes `logs/<run>.csv`, each with a sidecar "
                  f"`<run>.csv.plan.json` (the plan id, the time steps the host reached). `python run_{drive}.py "
                  "--max-seconds 2` checks the wiring first; `--runs NAME ...` runs some only. It needs the "
                  f"`{drive}` Python package (`pip install {drive}`)."]
    lines += ["", "## What to log", "", "| pgcomm reads | column | unit | what |", "|---|---|---|---|"]
    for name, (col, unit) in DRIVE_COLUMNS[drive].items():
        lines.append(f"| `{name}` | `{col}` | {unit or 'SI'} | {_MEANING[name]} |")
    lines += ["", "`columns.toml` maps these names and units for pgcomm. Time stamps as the host took them are what "
              "the identification integrates over; do not resample them.", ""]
    lines += _first_round_section(plan) + _notes(plan)
    lines += ["## Then", "",
              "1. Identify from the logs: `" + commands["identify"] + "`",
              "2. Its standard errors say whether each map is resolved. If not, plan the next round from the logs "
              "so far: `" + commands["plan"] + "`", ""]
    if commands.get("note"):
        lines += [commands["note"], ""]
    return "\n".join(lines)


def _notes(plan: RotaryPlan) -> list:
    """The plan's notes as a section (none: nothing)."""
    return ["## Notes", "", *[f"* {n}" for n in plan.notes], ""] if plan.notes else []


def _first_round_section(plan: RotaryPlan) -> list:
    """The durations' origin: a first round's default, or the first round's standard errors."""
    lines = ["## How long", ""]
    if plan.first_round is None:
        st = plan.settings
        return lines + [f"A first round: every speed cruises {_seconds(plan.runs[0].cruise)} "
                        f"({st.first_round_seconds:g} s, or longer where the fastest would not pass "
                        f"{st.first_round_revolutions:g} revolution(s)). "
                        "That is a default, not a standard error: the first round's logs give each map's standard "
                        "error, and `pgcomm plan --data` sizes the next round from them.", ""]
    fr, need = plan.first_round, plan.need
    lines += [f"From the first round's logs ({fr.seconds:.0f} s, logged every {1e3 * fr.sample_time:.3g} ms):", "",
              "| map | standard error (of its RMS) | log time to resolve | verdict |", "|---|---|---|---|"]
    for name in MAPS:
        if name in fr.standard_error:
            se = fr.standard_error[name]
            f = se["log_time_factor_to_resolve"]
            if se.get("determined") is False:
                cells = "not determined | a different experiment"
            else:
                cells = f"{100 * se['relative']:.1f} % | " + ("not by time" if not math.isfinite(f) else f"{f:.2f}x")
            lines.append(f"| {name} | {cells} | {fr.verdicts.get(name, '')} |")
    lines.append("")
    if plan.runs and need["seconds"] <= 0.0:
        lines += [f"These runs ({plan.duration:.0f} s, a first round's size) are for what the first round did not "
                  "determine or excite (the notes below). Identify from all the logs together.", ""]
    elif plan.runs:
        lines.append(f"The standard errors ask for {need['seconds']:.0f} s more"
                     + (f" ({need['factor']:.2f}x the first round's log time in all, for the {need['driver']})"
                        if need["driver"] and need["factor"] > 1.0 else "")
                     + f"; these runs take {plan.duration:.0f} s, in a first round's proportions (each cruise at least "
                     f"{plan.settings.min_cruise_seconds:g} s). Identify from all the logs together.")
        lines.append("")
    return lines
