"""Plan folders: the files of a :class:`pgcomm.plan.Plan` that a rig's controller plays back.

Layout (written by :func:`write_plan`, read by :func:`read_plan`)::

    DIR/plan.md                     what to run, in which order, how long, what to log, what next
    DIR/plan.json                   the same for programs (schema ``pgcomm-plan/1``)
    DIR/motor.toml                  this round's drive values k̂, ζ̂ (the motor description)
    DIR/references/Z1_coilset1.csv  one file per experiment, one row per controller sample:
                                    t (s), r (m), and per coil set l
                                    gain_l (-): Fy_ref_l = gain_l * Fy* (1 commanded, 0 not),
                                    delta_l (rad): the phase offset the drive adds

Drive-input convention (the log format's): ``Fy_ref_l`` is signed (it follows ``Fy*``) and
``delta_l`` stays at the plan's ``±Δ0`` for the whole experiment.

**Logs carry their round.** A plan has an id (:func:`plan_id`: a digest of plan.json's content, so
each round's plan has its own). A log recorded under a plan (``pgcomm simulate --plan`` writes them)
has a sidecar ``<log file name>.plan.json`` (schema ``pgcomm-log-plan/1``, :func:`log_identity`): the
plan id, the experiment, and the drive values it ran at: ``k̂``, ``ζ̂`` per coil set, the pole pitch and
the sample time. :func:`check_log_plans` compares them with the motor TOML a command is given, so a
round's logs calibrated against another round's (or another motor's) drive values are refused instead
of giving a wrong ``k``; a log without a sidecar (a rig's own) is taken as recorded at that TOML's
values, with a note.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np

from pgcomm.errors import ConfigError, DataError
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.config import load_motor, write_motor
from pgcomm.io.logs import Log, write_log
from pgcomm.plan import Experiment, Plan, log_columns
from pgcomm.io.references import read_reference

__all__ = ["SCHEMA", "LOG_SCHEMA", "write_plan", "read_plan", "plan_to_dict", "plan_markdown", "plan_id",
           "log_identity", "identity_path", "write_log_identity", "read_log_identity", "check_log_plans"]

#: ``schema`` of plan.json.
SCHEMA = "pgcomm-plan/1"

#: ``schema`` of a log's plan sidecar ``<log>.plan.json``.
LOG_SCHEMA = "pgcomm-log-plan/1"

#: Relative difference below which a drive value of a log's plan and of a motor TOML are the same value
#: (both files store floats that read back bit-identically; this only absorbs a hand-edited last digit).
SAME_VALUE = 1e-9


def plan_to_dict(plan: Plan) -> dict:
    """The JSON document of ``plan`` (SI units; coil sets 1-based as in the log columns)."""
    m = plan.motor
    exps = []
    for e in plan.experiments:
        exps.append({"name": e.name, "reference": f"references/{e.name}.csv", "coil_set": e.coil_set + 1,
                     "delta_rad": e.delta, "duration_s": plan.duration, "samples": int(plan.reference.r.shape[0]),
                     "feedforward": False,
                     "other_coil_sets": "zero force command (drive enabled, current zero)"})
    return {"schema": SCHEMA, "force_sensor": plan.force_sensor, "sample_time_s": m.sample_time,
            "delta0_rad": plan.delta, "reference": plan.settings,
            "drive": {"k_hat_N_per_A": list(m.k), "zeta_hat_rad": list(m.zeta), "pole_pitch_m": m.pole_pitch,
                      "current_limit_A": m.current_limit},
            "experiments": exps, "total_duration_s": plan.duration * len(plan.experiments),
            "log_columns": log_columns(m.n_coil_sets, plan.force_sensor)}


def write_plan(folder, plan: Plan, commands: dict[str, str]) -> list[Path]:
    """Write ``plan`` into ``folder`` (layout in the module docstring), every file atomically.

    Args:
        folder: target directory (created).
        plan: :class:`pgcomm.plan.Plan`.
        commands: the pgcomm commands that take the logs back, ``{"calibrate": ..., "identify": ...}``
            (shown in plan.md and stored in plan.json).

    Returns:
        the written paths.
    """
    folder = Path(folder)
    (folder / "references").mkdir(parents=True, exist_ok=True)
    paths = []
    ref = plan.reference
    L = plan.motor.n_coil_sets
    for e in plan.experiments:
        cols = {"t": ref.t, "r": ref.r}
        n = ref.r.shape[0]
        for l in range(L):
            cols[f"gain_{l + 1}"] = np.full(n, 1.0 if l == e.coil_set else 0.0)
            cols[f"delta_{l + 1}"] = np.full(n, e.delta if l == e.coil_set else 0.0)
        p = folder / "references" / f"{e.name}.csv"
        write_log(p, Log(cols, ref.sample_time, source=str(p)))
        paths.append(p)
    write_motor(folder / "motor.toml", plan.motor)
    doc = plan_to_dict(plan) | {"id": plan_id(plan), "commands": dict(commands)}
    atomic_write_text(folder / "plan.json", json.dumps(doc, indent=2) + "\n")
    atomic_write_text(folder / "plan.md", plan_markdown(plan, commands))
    return paths + [folder / "motor.toml", folder / "plan.json", folder / "plan.md"]


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def plan_markdown(plan: Plan, commands: dict[str, str]) -> str:
    """plan.md: the plan in plain language for the engineer at the rig."""
    m, s = plan.motor, plan.settings
    L = m.n_coil_sets
    deg = np.degrees(plan.delta)
    lines = [
        "# Experiment plan: calibration (Algorithm 1) and identification (Algorithm 2)",
        "",
        f"{len(plan.experiments)} experiments of {_minutes(plan.duration)} each "
        f"({_minutes(plan.duration * len(plan.experiments))} of motion, plus the time to load each file and "
        "home the axis).",
        "",
        "## Before you start",
        "",
        f"* Set the drive's fixed commutation to this round's values (also in `motor.toml`): "
        + ", ".join(f"coil set {l + 1}: k̂ = {m.k[l]:.6g} N/A, ζ̂ = {m.zeta[l]:.6g} rad" for l in range(L)) + ".",
        f"* Feedback only: **no feedforward** in these experiments. Sample time {m.sample_time * 1e3:g} ms.",
        "* Only one coil set is commanded per experiment. The others get a zero force command "
        "(drive enabled, current zero), so the force measured is that coil set's alone.",
        f"* Each coil set gets the force the feedback loop asks for, Fy_ref_l = Fy*, at a fixed phase offset "
        f"Δ = −{plan.delta:.4f} rad (−{deg:.0f}°) in experiment Z1 and +{plan.delta:.4f} rad (+{deg:.0f}°) in Z2. "
        "With the offset the coil set makes about cos Δ of the force it would make at Δ = 0: the loop makes up for "
        "it with current, so check that the current limit"
        + (f" ({m.current_limit:g} A)" if m.current_limit else "") + " is not reached.",
        f"* The reference moves between {s['center'] - s['stroke']:.4g} m and {s['center'] + s['stroke']:.4g} m "
        f"at {', '.join(f'{v:g}' for v in s['velocities'])} m/s (acceleration ≤ {s['a_max']:g} m/s², "
        f"rests of {s['dwell']:g} s). Start each experiment at r = {plan.reference.r[0]:.4g} m.",
        "",
        "## Run, in this order",
        "",
        "| # | experiment | reference file | commanded coil set | Δ (rad) | duration |",
        "|---|---|---|---|---|---|",
    ]
    for j, e in enumerate(plan.experiments, start=1):
        lines.append(f"| {j} | {e.name} | `references/{e.name}.csv` | {e.coil_set + 1} | {e.delta:+.4f} | "
                     f"{_minutes(plan.duration)} |")
    lines += [
        "",
        "Each reference file has one row per controller sample: `t` (s), `r` (m), and per coil set `gain_l` "
        "(Fy_ref_l = gain_l · Fy*) and `delta_l` (rad).",
        "",
        f"## Log each experiment as `<logs>/<experiment>.csv` with these columns",
        "",
    ]
    for name, meaning in log_columns(L, plan.force_sensor).items():
        lines.append(f"* `{name}`: {meaning}")
    lines += ["", "Currents or drive inputs per coil set are enough (both are better). "
              "Other names or units: map them with `--columns mapping.toml` (see the log format)."]
    if not plan.force_sensor:
        lines += ["", f"No force sensor: calibration and identification use the motion, m ÿ, with the moving mass "
                      f"m = {m.mass:g} kg of `motor.toml`. Use a fine encoder and log every sample."]
    lines += [
        "",
        "## Then",
        "",
        "1. Check that the logs excite the model: `" + commands["check"] + "`",
        "2. Calibrate k̂, ζ̂ (one round of Algorithm 1): `" + commands["calibrate"] + "`",
        "   It writes the next round's `motor.toml` and says whether the calibration has converged "
        "(the step below the round's own noise). If not, make the next plan from it "
        "(`pgcomm plan --motor <calibration>/motor.toml ...`), set the drive to its values and run again.",
        "3. When converged, identify the model from the last round's logs: `" + commands["identify"] + "`",
        "",
    ]
    return "\n".join(lines)


def read_plan(path) -> Plan:
    """Read a plan folder (or its ``plan.json``) written by :func:`write_plan`.

    Raises:
        ConfigError: a missing or inconsistent file, naming it.
    """
    p = Path(path)
    folder = p if p.is_dir() else p.parent
    doc_path = folder / "plan.json"
    if not doc_path.is_file():
        raise ConfigError(f"{path}: no plan.json (write a plan with pgcomm plan --out DIR)")
    try:
        doc = json.loads(doc_path.read_text())
    except (OSError, ValueError) as e:
        raise ConfigError(f"{doc_path}: not a readable plan ({' '.join(str(e).split())})") from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        raise ConfigError(f"{doc_path}: schema {doc.get('schema') if isinstance(doc, dict) else None!r}, "
                          f"expected {SCHEMA!r}")
    motor = load_motor(folder / "motor.toml")
    try:
        exps = tuple(Experiment(str(e["name"]), int(e["coil_set"]) - 1, float(e["delta_rad"]))
                     for e in doc["experiments"])
        settings, force_sensor = dict(doc["reference"]), bool(doc["force_sensor"])
    except (KeyError, TypeError, ValueError) as e:
        raise ConfigError(f"{doc_path}: malformed plan ({type(e).__name__}: {e})") from None
    if not exps:
        raise ConfigError(f"{doc_path}: the plan lists no experiments")
    ref = None
    for e in exps:
        if not 0 <= e.coil_set < motor.n_coil_sets:
            raise ConfigError(f"{doc_path}: experiment {e.name} commands coil set {e.coil_set + 1}, the motor "
                              f"has {motor.n_coil_sets}")
        r = read_reference(folder / "references" / f"{e.name}.csv", sample_time=motor.sample_time)
        if ref is not None and (r.r.shape != ref.r.shape or not np.array_equal(r.r, ref.r)):
            raise DataError(f"{folder / 'references' / (e.name + '.csv')}: the experiments of a plan follow one "
                            "reference; this file's r differs from the first experiment's")
        ref = r
    return Plan(motor, ref, settings, exps, force_sensor)



# --------------------------------------------------------------------------- logs carry their round


def plan_id(plan: Plan) -> str:
    """The plan's id: the first 12 hex digits of the SHA-256 of its canonical JSON (:func:`plan_to_dict`).

    Two plans share an id only if they share every drive value, reference setting and experiment.
    """
    text = json.dumps(plan_to_dict(plan), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def log_identity(plan: Plan, experiment) -> dict:
    """The sidecar document of a log recorded under ``plan`` in ``experiment`` (:class:`pgcomm.plan.Experiment`).

    Returns:
        ``{"schema", "plan_id", "experiment", "coil_set"`` (1-based), ``"delta_rad", "k_hat_N_per_A"`` (L,),
        ``"zeta_hat_rad"`` (L,), ``"pole_pitch_m", "sample_time_s"}``.
    """
    m = plan.motor
    return {"schema": LOG_SCHEMA, "plan_id": plan_id(plan), "experiment": experiment.name,
            "coil_set": experiment.coil_set + 1, "delta_rad": experiment.delta,
            "k_hat_N_per_A": [float(x) for x in m.k], "zeta_hat_rad": [float(x) for x in m.zeta],
            "pole_pitch_m": float(m.pole_pitch), "sample_time_s": float(m.sample_time)}


def identity_path(log_path) -> Path:
    """The sidecar of a log file: ``Z1_coilset1.csv`` -> ``Z1_coilset1.csv.plan.json`` (same folder)."""
    p = Path(log_path)
    return p.with_name(p.name + ".plan.json")


def write_log_identity(log_path, identity: dict) -> Path:
    """Write ``identity`` (:func:`log_identity`) as the sidecar of ``log_path`` (atomically); returns its path."""
    path = identity_path(log_path)
    atomic_write_text(path, json.dumps(identity, indent=2) + "\n")
    return path


def read_log_identity(log_path) -> dict | None:
    """The plan a log was recorded under (its sidecar, :func:`identity_path`), or ``None`` when it has none.

    Raises:
        DataError: a sidecar that is not a readable ``pgcomm-log-plan/1`` document, naming it.
    """
    path = identity_path(log_path)
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise DataError(f"{path}: not a readable plan sidecar ({' '.join(str(e).split())})") from None
    if not isinstance(doc, dict) or doc.get("schema") != LOG_SCHEMA:
        raise DataError(f"{path}: schema {doc.get('schema') if isinstance(doc, dict) else None!r}, expected "
                        f"{LOG_SCHEMA!r}")
    try:
        ident = {"plan_id": str(doc["plan_id"]), "k": [float(x) for x in doc["k_hat_N_per_A"]],
                 "zeta": [float(x) for x in doc["zeta_hat_rad"]], "pole_pitch": float(doc["pole_pitch_m"]),
                 "sample_time": float(doc["sample_time_s"]), "experiment": str(doc.get("experiment", "?"))}
    except (KeyError, TypeError, ValueError) as e:
        raise DataError(f"{path}: malformed plan sidecar ({type(e).__name__}: {e})") from None
    if len(ident["k"]) != len(ident["zeta"]) or not all(map(math.isfinite, ident["k"] + ident["zeta"])):
        raise DataError(f"{path}: k_hat_N_per_A and zeta_hat_rad must be finite and of one length per coil set")
    return ident


def _differs(a: float, b: float) -> bool:
    return abs(a - b) > SAME_VALUE * max(abs(a), abs(b))


def check_log_plans(logs, motor, motor_name: str) -> list[str]:
    """Check that ``logs`` were recorded at ``motor``'s drive values, as their plan sidecars say.

    Every log with a sidecar (:func:`read_log_identity`) must agree with ``motor`` in the number of
    coil sets, ``k̂``, ``ζ̂`` of each, the pole pitch and the sample time, and all of them must come from
    one plan. Logs without a sidecar are taken as recorded at ``motor``'s values (a rig's own logs).

    Args:
        logs: :class:`pgcomm.io.logs.Log` list (``source`` is the file).
        motor: :class:`pgcomm.motor.Motor` the command calibrates or identifies against.
        motor_name: how the user gave it, for messages (``"--motor round2/motor.toml"``).

    Returns:
        notes for the user (logs without a sidecar; their sample time where it differs from ``motor``'s).

    Raises:
        DataError: one line naming the log and the value that differs, or two logs of different plans.
    """
    notes, first = [], None
    without = []
    for log in logs:
        ident = read_log_identity(log.source)
        if ident is None:
            without.append(log)
            continue
        src, pid = log.source, ident["plan_id"]
        where = f"{src}: recorded under plan {pid} ({identity_path(src).name})"
        if len(ident["k"]) != motor.n_coil_sets:
            raise DataError(f"{where} with {len(ident['k'])} coil set(s), but {motor_name} has {motor.n_coil_sets}: "
                            "logs of another motor")
        for what, ours, theirs, unit, fmt in (("pole pitch", ident["pole_pitch"], motor.pole_pitch, "m", ".6g"),
                                              ("sample time", ident["sample_time"], motor.sample_time, "s", ".6g")):
            if _differs(ours, theirs):
                raise DataError(f"{where} with {what} {ours:{fmt}} {unit}, but {motor_name} has {theirs:{fmt}} {unit}: "
                                "logs of another motor")
        for l in range(motor.n_coil_sets):
            for sym, ours, theirs, unit in (("k̂", ident["k"][l], motor.k[l], "N/A"),
                                            ("ζ̂", ident["zeta"][l], motor.zeta[l], "rad")):
                if _differs(ours, theirs):
                    raise DataError(f"{where} with {sym}{l + 1} = {ours:.6g} {unit}, but {motor_name} has "
                                    f"{sym}{l + 1} = {theirs:.6g} {unit}: logs of another round; give the motor.toml "
                                    f"of the plan they were recorded under")
        if first is None:
            first = (src, pid)
        elif pid != first[1]:
            raise DataError(f"{where}, but {first[0]} under plan {first[1]}: give the logs of one round at a time")
    if without:
        shown = ", ".join(lg.source for lg in without[:2]) + (", ..." if len(without) > 2 else "")
        notes.append(f"{len(without)} log(s) without a plan sidecar ({shown}): taken as recorded at the drive values "
                     f"of {motor_name}")
        for log in without:
            if _differs(log.sample_time, motor.sample_time):
                notes.append(f"{log.source}: sample time {log.sample_time:.6g} s, {motor_name} has "
                             f"{motor.sample_time:.6g} s: check that the log is of this motor")
    return notes
