"""One motor of a fleet: find the motor folders, run one motor (the Dask task), its fleet rows.

See :mod:`pgcomm.fleet` for the workspace rules.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import time
from pathlib import Path

import numpy as np
from pgcomm import __version__
from pgcomm._memory import release_compiled_programs
from pgcomm.errors import DataError, PgcommError
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.config import load_experiment, load_motor
from pgcomm.io.logs import read_logs
from pgcomm.io.results import write_results

#: Columns of ``fleet.parquet`` / ``fleet.csv`` (one row per motor × coil set; a failed motor has one
#: row with ``coil_set`` empty). ``k`` (N/A), ``zeta`` (rad): calibrated; ``cost_*``: Algorithm 2's
#: training costs (N²); ``improvement = cost_physics / cost_pgnn`` (-); ``seconds``: identification of
#: the coil set (s); ``cogging_pp``: peak-to-peak of the identified cogging force in y over the
#: training range (N).
COLUMNS = ("motor", "coil_set", "status", "error", "k", "zeta", "cost_physics", "cost_pgnn", "improvement",
           "seconds", "cogging_pp", "k_initial", "zeta_initial", "cost_pgnn_validation")

#: Quantities whose fleet distribution ``fleet.html`` shows and whose outliers it flags.
QA_QUANTITIES = ("k", "zeta", "cogging_pp", "improvement")


#: File inside a finished motor's output folder holding its fleet rows (its presence = finished).
ROWS_FILE = "fleet_rows.json"

_FAILED = "failed"


# --------------------------------------------------------------------------------------------
# the motors of a fleet directory and their state in OUT
# --------------------------------------------------------------------------------------------


def find_motors(data_dir) -> list[Path]:
    """The motor folders of ``data_dir`` (sub-folders holding ``motor.toml``), sorted by name.

    Raises:
        DataError: ``data_dir`` is not a directory or holds no motor folder.
    """
    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        raise DataError(f"--data {data_dir}: not a directory")
    motors = sorted(p for p in data_dir.iterdir() if p.is_dir() and (p / "motor.toml").is_file())
    if not motors:
        raise DataError(f"--data {data_dir}: no motor folder (a sub-folder with motor.toml and logs/*.csv)")
    return motors


def is_finished(out_dir, name: str) -> bool:
    """Whether motor ``name`` has finished outputs in ``out_dir`` (``OUT/name/fleet_rows.json``)."""
    return (Path(out_dir) / name / ROWS_FILE).is_file()


# --------------------------------------------------------------------------------------------
# the task
# --------------------------------------------------------------------------------------------


def process_motor(folder, out_dir, seed: int = 0) -> dict:
    """The task of one motor: :func:`analyse_motor` into a staging folder, renamed to ``OUT/NAME`` when done.

    A :class:`pgcomm.errors.PgcommError` (bad logs, bad TOML, no excitation) is caught and
    recorded in ``OUT/failed/NAME.json``; any other exception propagates (a bug: the caller
    records it as failed with its type).

    Args:
        folder: the motor folder (``motor.toml``, optional ``config.toml``, ``logs/*.csv``).
        out_dir: the fleet's output directory (must exist).
        seed: seed of the identification's random starts.

    Returns:
        ``{"motor", "status" ("ok"/"failed"), "error", "rows", "seconds", "host", "pid", "task_index"}``;
        ``task_index`` counts the tasks this worker process ran (1 = its first, which pays JAX's compile).
    """
    folder, out_dir = Path(folder), Path(out_dir)
    name = folder.name
    _TASKS["n"] += 1
    info = {"motor": name, "host": socket.gethostname(), "pid": os.getpid(), "task_index": _TASKS["n"]}
    t0 = time.perf_counter()
    stage = out_dir / f".{name}.tmp-{os.getpid()}-{time.time_ns()}"
    stage.mkdir(parents=True)
    failed = out_dir / _FAILED / f"{name}.json"
    try:
        rows = analyse_motor(folder, stage, seed=seed)
    except PgcommError as e:
        shutil.rmtree(stage, ignore_errors=True)
        error = " ".join(str(e).split())
        record = {**info, "status": "failed", "error": error, "rows": [_failed_row(name, error)],
                  "seconds": time.perf_counter() - t0}
        failed.parent.mkdir(exist_ok=True)

        atomic_write_text(failed, json.dumps(record, indent=1) + "\n")
        return record
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    record = {**info, "status": "ok", "error": None, "rows": rows, "seconds": time.perf_counter() - t0}

    atomic_write_text(stage / ROWS_FILE, json.dumps(record, indent=1) + "\n")
    target = out_dir / name
    if target.exists():  # --redo: move the old outputs aside first, then swap in the new ones
        old = out_dir / f".{name}.old-{os.getpid()}-{time.time_ns()}"
        os.rename(target, old)
        os.rename(stage, target)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.rename(stage, target)
    with contextlib.suppress(FileNotFoundError):
        failed.unlink()
    return record


#: Tasks run by this process (a worker's first task pays JAX's compilation).
_TASKS = {"n": 0}


def analyse_motor(folder, out, seed: int = 0) -> list[dict]:
    """Calibrate, identify, evaluate and export one motor from its logs; write the outputs into ``out``.

    Writes ``results.json`` (``calibration.*``, ``identification.*``, ``evaluation.*`` as the
    commands write them), ``model.json/.npz``, the C law ``pgcomm_law.h/.c`` and the lookup
    tables ``pgcomm_lut.csv/.h``, ``pgcomm_lut_cogging.csv``.

    Args:
        folder: motor folder: ``motor.toml``, optional ``config.toml``, logs ``logs/*.csv``.
        out: existing output folder.
        seed: seed of the identification's random starts (as ``pgcomm identify --seed``).

    Returns:
        one row (dict with the keys of :data:`COLUMNS`) per coil set.

    Raises:
        PgcommError: bad or missing input, no excitation (one line naming the file).
    """
    # JAX and SciPy load here, in the worker that runs the motor: the command's own process (which imports this
    # module to plan and tabulate the fleet) never computes, and a worker's thread settings (WORKER_ENV) must be in
    # place before JAX loads
    import jax.numpy as jnp
    from pgcomm.calibration import calibrate_from_logs
    from pgcomm.data import coil_set_data_from_logs
    from pgcomm.evaluation import evaluate_logs, evaluation_results
    from pgcomm.experiment import identification_results, identify_models
    from pgcomm.export.c import CLawOptions, write_c
    from pgcomm.export.lut import build_cogging_table, build_lut, write_cogging_table, write_lut
    from pgcomm.io.model import drive_metadata, save_model
    from pgcomm.settings import ExperimentConfig
    from pgcomm.setup import Setup

    folder, out = Path(folder), Path(out)
    t0 = time.perf_counter()
    motor = load_motor(folder / "motor.toml")
    config = load_experiment(folder / "config.toml") if (folder / "config.toml").is_file() else ExperimentConfig()
    logs = read_logs([str(folder / "logs" / "*.csv")])
    # every log grouped (and so checked: force, currents or drive inputs, one active coil set) before any work
    data = coil_set_data_from_logs(logs, motor)
    cc = config.calibration
    cal = calibrate_from_logs(logs, motor, method=cc.method, n_bins=cc.n_bins)
    # identification exactly as `pgcomm identify --data` (plant unused with logs)
    setup = Setup(plant=None, motor=motor, config=config, true_k=None, true_zeta=None, plant_name=folder.name)
    t_id = time.perf_counter()
    pgnn, _, res = identify_models(setup, data, seed, None, check_data=True)
    t_id = time.perf_counter() - t_id
    # the identification's programs are the largest a worker holds: released before the evaluation and the
    # exports compile theirs (pgcomm._memory); the next motor loads them from the worker's compile cache
    release_compiled_programs()
    ident = identification_results(res, t_id)
    # the exports' defaults travel with the model: the motor's current limit and the calibrated commutation
    # the drive runs from now on (the anti-cogging table below is computed for it)
    save_model(out / "model", pgnn, {"seed": seed, "plant": folder.name, "data": "logs",
                                     "fy_abs_max": max(float(np.max(np.abs(d.force[:, 0]))) for d in data),
                                     "identification": ident, "current_limit": motor.current_limit,
                                     "drive": drive_metadata(cal.k, cal.zeta, "calibrated from the logs "
                                                             "(Algorithm 1, pgcomm fleet)")})
    lowpass = config.evaluation.lowpass_hz
    evals = evaluate_logs(logs, lowpass, model=pgnn, motor=motor)
    limit_source = "motor.toml current_limit" if motor.current_limit else "motor.toml has no current_limit"
    write_c(pgnn, out, CLawOptions("pgcomm_law", current_limit=motor.current_limit, limit_source=limit_source),
            metadata={"motor": folder.name, "seed": seed})
    write_lut(build_lut(pgnn, current_limit=motor.current_limit), out, "pgcomm_lut", limit_source=limit_source)
    write_cogging_table(build_cogging_table(pgnn, k_hat=cal.k, zeta_hat=cal.zeta), out, "pgcomm_lut_cogging",
                        comments=[f"anti-cogging table for a drive with classical commutation k_hat = "
                                  f"{', '.join(f'{k:.6g}' for k in cal.k)} N/A, zeta_hat = "
                                  f"{', '.join(f'{z:.6g}' for z in cal.zeta)} rad (calibrated from the logs)",
                                  "the drive commutates Fy* - Fy_cog(y); y in m, Fy_cog in N"])
    calibration = {"initial": {"k": cal.k_initial, "zeta": cal.zeta_initial},
                   "calibrated": {"k": cal.k, "zeta": cal.zeta}, "true": {"k": None, "zeta": None},
                   "iterations": cal.iterations, "method": cc.method}
    write_results(out / "results.json", {
        "command": "fleet", "motor": folder.name, "version": __version__, "seed": seed,
        "calibration": calibration, "identification": ident,
        "evaluation": evaluation_results(evals, lowpass, "model.json"), "runtime_s": time.perf_counter() - t0})
    rows = []
    for l, r in enumerate(res):
        m = pgnn.coil_set(l)
        y = np.linspace(m.y_min, m.y_max, 2001)
        cog_y = np.asarray(m.cogging(jnp.asarray(y)))[:, 0]
        rows.append({"motor": folder.name, "coil_set": l + 1, "status": "ok", "error": None,
                     "k": float(cal.k[l]), "zeta": float(cal.zeta[l]), "cost_physics": float(r.cost_physics),
                     "cost_pgnn": float(r.cost_pgnn), "improvement": float(r.cost_physics / r.cost_pgnn),
                     "seconds": float(r.seconds), "cogging_pp": float(np.ptp(cog_y)),
                     "k_initial": float(cal.k_initial[l]), "zeta_initial": float(cal.zeta_initial[l]),
                     "cost_pgnn_validation": (None if not np.isfinite(r.cost_pgnn_validation)
                                              else float(r.cost_pgnn_validation))})
    return rows


def _failed_row(name: str, error: str) -> dict:
    row = dict.fromkeys(COLUMNS)
    row.update(motor=name, status="failed", error=error)
    return row

