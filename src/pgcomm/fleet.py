"""A fleet of motors on Dask: one task per motor folder (calibrate, identify, evaluate, export), resumable.

A fleet directory holds one folder per motor, each with ``motor.toml``, optional
``config.toml`` (experiment settings: identification, calibration estimator, evaluation) and
``logs/*.csv`` (the data sets ``Z_i^l`` a production line records, as
``pgcomm calibrate --save-data`` / ``pgcomm zoo --logs`` write them). :func:`process_motor`
is the task, run on a Dask worker; it uses the same library calls as the commands run alone:

* calibration: :func:`pgcomm.calibration.calibrate_from_logs` (Algorithm 1 on the logs);
* identification: :func:`pgcomm.data.coil_set_data_from_logs` and
  :func:`pgcomm.experiment.identify_models` (as ``pgcomm identify --data``), excitation check first;
* evaluation: :func:`pgcomm.evaluation.evaluate_logs` with the model (as ``pgcomm evaluate --model``);
* export: :func:`pgcomm.export.c.write_c` and :mod:`pgcomm.export.lut` (as ``pgcomm export``).

**Resumable workspace.** A finished motor's outputs are staged in ``OUT/.NAME.tmp-*`` and the
folder is renamed to ``OUT/NAME`` when complete (a directory rename is atomic), with
``OUT/NAME/fleet_rows.json`` inside: a folder ``OUT/NAME`` is finished by construction, and a
rerun skips it (unless ``redo``). A motor whose input is bad (a :class:`pgcomm.errors.PgcommError`)
is recorded in ``OUT/failed/NAME.json`` with its one-line error (the line the CLI would print)
and retried on the next run; other motors go on. An interrupted run leaves finished motors
intact; stale staging folders are removed at the next start.

**Workers.** Each worker runs one task at a time with XLA and BLAS pinned to one thread
(:data:`WORKER_ENV`, set before JAX is imported in an embedded cluster's worker processes and
by the :class:`WorkerSetup` plugin on a running cluster whose workers have not imported JAX
yet). JAX compiles the identification per array shape; :class:`WorkerSetup` also points JAX's
persistent compilation cache at ``OUT/.jax_cache`` so compiled code is shared by all workers
that see ``OUT`` and survives reruns.

**QA.** :func:`fleet_rows` collects one row per motor × coil set (:data:`COLUMNS`);
:func:`robust_z` and :func:`flag_outliers` mark motors unlike the others;
:func:`write_fleet_table` writes ``fleet.parquet`` / ``fleet.csv`` and :func:`write_fleet_html`
the distributions with the outliers.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import json
import os
import shutil
import socket
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["WORKER_ENV", "COLUMNS", "QA_QUANTITIES", "DEFAULT_OUTLIER_Z", "ROWS_FILE", "find_motors",
           "is_finished", "process_motor", "analyse_motor", "fleet_rows", "robust_z", "flag_outliers",
           "write_fleet_table", "write_fleet_html", "WorkerSetup", "FleetRun", "run_fleet"]

#: Environment of a worker process: XLA and BLAS/OpenMP on one thread each (one task per worker).
WORKER_ENV = {
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}

#: Columns of ``fleet.parquet`` / ``fleet.csv`` (one row per motor × coil set; a failed motor has one
#: row with ``coil_set`` empty). ``k`` (N/A), ``zeta`` (rad): calibrated; ``cost_*``: Algorithm 2's
#: training costs (N²); ``improvement = cost_physics / cost_pgnn`` (-); ``seconds``: identification of
#: the coil set (s); ``cogging_pp``: peak-to-peak of the identified cogging force in y over the
#: training range (N).
COLUMNS = ("motor", "coil_set", "status", "error", "k", "zeta", "cost_physics", "cost_pgnn", "improvement",
           "seconds", "cogging_pp", "k_initial", "zeta_initial", "cost_pgnn_validation")

#: Quantities whose fleet distribution ``fleet.html`` shows and whose outliers it flags.
QA_QUANTITIES = ("k", "zeta", "cogging_pp", "improvement")

from pgcomm.defaults import DEFAULT_OUTLIER_Z  # noqa: E402  (re-exported)

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
    from pgcomm.errors import DataError

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
    from pgcomm.errors import PgcommError

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
        from pgcomm.io.atomic import atomic_write_text

        atomic_write_text(failed, json.dumps(record, indent=1) + "\n")
        return record
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    record = {**info, "status": "ok", "error": None, "rows": rows, "seconds": time.perf_counter() - t0}
    from pgcomm.io.atomic import atomic_write_text

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
    import jax.numpy as jnp

    from pgcomm import __version__
    from pgcomm.calibration import calibrate_from_logs
    from pgcomm.data import coil_set_data_from_logs
    from pgcomm.evaluation import evaluate_logs, evaluation_results
    from pgcomm.experiment import identification_results, identify_models
    from pgcomm.settings import ExperimentConfig, load_experiment
    from pgcomm.setup import Setup
    from pgcomm.export.c import write_c
    from pgcomm.export.lut import build_cogging_table, build_lut, write_cogging_table, write_lut
    from pgcomm.io.config import load_motor
    from pgcomm.io.logs import read_logs
    from pgcomm.io.model import drive_metadata, save_model
    from pgcomm.io.results import write_results

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
    write_c(pgnn, out, name="pgcomm_law", metadata={"motor": folder.name, "seed": seed},
            current_limit=motor.current_limit, limit_source=limit_source)
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


# --------------------------------------------------------------------------------------------
# workers
# --------------------------------------------------------------------------------------------


try:  # distributed is a dependency; the import is guarded only so that the QA helpers work without it
    from distributed.diagnostics.plugin import WorkerPlugin as _WorkerPluginBase
except ImportError:  # pragma: no cover
    _WorkerPluginBase = object


class WorkerSetup(_WorkerPluginBase):
    """Worker plugin: pin XLA/BLAS to one thread, enable JAX's persistent compilation cache, import pgcomm.

    On an embedded cluster :data:`WORKER_ENV` is already in the worker's environment at
    spawn; on a running cluster it takes effect only where JAX and NumPy were not yet
    imported by the worker (then the env is set before they are; otherwise the existing
    setting stays, and ``setup`` reports it).

    Args:
        cache_dir: directory for JAX's persistent compilation cache (shared by workers that
            see it), or ``None``.
    """

    name = "pgcomm-worker-setup"

    def __init__(self, cache_dir: str | None = None):
        self.cache_dir = cache_dir

    def setup(self, worker=None):
        """Runs once on each worker (and on workers that join later)."""
        import sys

        pinned = "jax" not in sys.modules
        if pinned:
            for k, v in WORKER_ENV.items():
                os.environ.setdefault(k, v)
        import jax

        import pgcomm  # noqa: F401  (x64, cpu)

        if self.cache_dir:
            jax.config.update("jax_compilation_cache_dir", self.cache_dir)
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
        return {"xla_flags": os.environ.get("XLA_FLAGS", ""), "pinned_here": pinned}


# --------------------------------------------------------------------------------------------
# the run
# --------------------------------------------------------------------------------------------


@dataclass
class FleetRun:
    """What one :func:`run_fleet` call did.

    Attributes:
        motors: every motor folder name of the fleet directory.
        skipped: finished motors not run again.
        submitted: motors sent to the cluster as tasks in this run.
        records: task records of this run (see :func:`process_motor`), by motor.
        seconds: wall time of the run (s).
    """

    motors: list
    skipped: list
    submitted: list
    records: dict = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def failed(self) -> list:
        """Motors that failed in this run."""
        return [m for m, r in self.records.items() if r["status"] != "ok"]


def run_fleet(client, data_dir, out_dir, redo: bool = False, seed: int = 0, outlier_z: float = DEFAULT_OUTLIER_Z,
              on_event=None) -> FleetRun:
    """Run every unfinished motor of ``data_dir`` as one Dask task on ``client``; write the fleet outputs.

    Args:
        client: a connected :class:`distributed.Client` (embedded ``LocalCluster`` or a running cluster;
            its workers must read ``data_dir`` and ``out_dir`` by the same paths).
        data_dir: fleet directory (one folder per motor, :func:`find_motors`).
        out_dir: output workspace (created); finished motors are skipped unless ``redo``.
        seed: identification seed.
        outlier_z: robust z-score threshold of ``fleet.html``.
        on_event: optional ``on_event(kind, run, record)`` called with ``kind`` ``"start"``
            (record ``None``) and ``"done"`` after each task (progress display).

    Returns:
        :class:`FleetRun`. ``OUT/fleet.parquet``, ``fleet.csv``, ``fleet.html`` and ``fleet.json``
        are (re)written from every motor's state, also after Ctrl-C.
    """
    from distributed import as_completed

    t0 = time.perf_counter()
    motors = find_motors(data_dir)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in list(out_dir.glob(".*.tmp-*")) + list(out_dir.glob(".*.old-*")):
        shutil.rmtree(stale, ignore_errors=True)
    names = [m.name for m in motors]
    todo = [m for m in motors if redo or not is_finished(out_dir, m.name)]
    run = FleetRun(motors=names, skipped=[n for n in names if n not in {m.name for m in todo}],
                   submitted=[m.name for m in todo])
    client.register_plugin(WorkerSetup(str((out_dir / ".jax_cache").resolve())))
    if on_event:
        on_event("start", run, None)
    futures = {client.submit(process_motor, str(m.resolve()), str(out_dir.resolve()), seed, key=f"pgcomm-{m.name}-"
                             f"{time.time_ns()}", pure=False, retries=0): m.name for m in todo}
    try:
        for fut in as_completed(futures):
            name = futures[fut]
            try:
                rec = fut.result()
            except Exception as e:  # a bug or a lost worker: recorded like a bad motor, the rest go on
                error = f"{type(e).__name__}: {' '.join(str(e).split())}"
                rec = {"motor": name, "status": "failed", "error": error, "rows": [_failed_row(name, error)],
                       "seconds": None, "host": None, "pid": None, "task_index": None}
                _record_failure(out_dir, rec)
            run.records[name] = rec
            if on_event:
                on_event("done", run, rec)
    finally:
        for fut in futures:
            if not fut.done():
                fut.cancel()
        run.seconds = time.perf_counter() - t0
        rows = fleet_rows(out_dir, names)
        write_fleet_table(out_dir, rows, outlier_z)
        from pgcomm.io.atomic import atomic_write_text

        atomic_write_text(out_dir / "fleet.json", json.dumps(
            {"motors": names, "skipped": run.skipped, "submitted": run.submitted, "failed": run.failed,
             "seconds": run.seconds, "tasks": list(run.records.values())}, indent=1, default=str) + "\n")
    return run


def _record_failure(out_dir: Path, rec: dict) -> None:
    from pgcomm.io.atomic import atomic_write_text

    (out_dir / _FAILED).mkdir(exist_ok=True)
    atomic_write_text(out_dir / _FAILED / f"{rec['motor']}.json", json.dumps(rec, indent=1) + "\n")


# --------------------------------------------------------------------------------------------
# the fleet table and its QA
# --------------------------------------------------------------------------------------------


def fleet_rows(out_dir, names) -> list[dict]:
    """Rows of :data:`COLUMNS` for motors ``names``: finished ones from ``OUT/NAME/fleet_rows.json``,
    failed ones from ``OUT/failed/NAME.json``; motors with neither (not run yet) have no row."""
    out_dir = Path(out_dir)
    rows = []
    for name in names:
        for path in (out_dir / name / ROWS_FILE, out_dir / _FAILED / f"{name}.json"):
            if path.is_file():
                rows += [{c: r.get(c) for c in COLUMNS} for r in json.loads(path.read_text())["rows"]]
                break
    return rows


def write_fleet_table(out_dir, rows, threshold: float = DEFAULT_OUTLIER_Z) -> list[Path]:
    """Write ``fleet.parquet``, ``fleet.csv`` (columns :data:`COLUMNS`) and ``fleet.html`` atomically.

    Returns:
        the three paths.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    from pgcomm.io.atomic import atomic_path

    out_dir = Path(out_dir)
    types = {"motor": pa.string(), "coil_set": pa.int64(), "status": pa.string(), "error": pa.string()}
    table = pa.table({c: pa.array([r.get(c) for r in rows], type=types.get(c, pa.float64())) for c in COLUMNS})
    with atomic_path(out_dir / "fleet.parquet") as tmp:
        pq.write_table(table, str(tmp))
    with atomic_path(out_dir / "fleet.csv") as tmp:
        pacsv.write_csv(table, str(tmp))
    html_path = write_fleet_html(out_dir / "fleet.html", rows, threshold)
    return [out_dir / "fleet.parquet", out_dir / "fleet.csv", html_path]


def robust_z(x) -> np.ndarray:
    """Robust z-score ``z_j = (x_j − median x) / (1.4826 · MAD)``, ``MAD = median |x − median x|``.

    ``1.4826 · MAD`` estimates the standard deviation of normal data without being moved by
    the outliers themselves. When more than half the values are equal (``MAD = 0``) the mean
    absolute deviation ``· 1.2533`` is used instead (Iglewicz & Hoaglin); when all values are
    equal every score is 0. NaN entries (failed motors) stay NaN.

    Args:
        x: ``(N,)`` values.

    Returns:
        ``(N,)`` scores (-).
    """
    x = np.asarray(x, dtype=float)
    z = np.full(x.shape, np.nan)
    ok = np.isfinite(x)
    if not ok.any():
        return z
    v = x[ok]
    med = np.median(v)
    scale = 1.4826 * np.median(np.abs(v - med))
    if scale == 0:
        scale = 1.2533 * np.mean(np.abs(v - med))
    z[ok] = 0.0 if scale == 0 else (v - med) / scale
    return z


def flag_outliers(rows, threshold: float = DEFAULT_OUTLIER_Z, quantities=QA_QUANTITIES) -> list[dict]:
    """Values with ``|robust_z| > threshold`` among the ``ok`` rows, per quantity across the fleet.

    ``zeta`` is compared on the circle (each value wrapped to within ``π`` of the circular mean).

    Args:
        rows: fleet rows (:data:`COLUMNS`).
        threshold: robust z-score limit (-).
        quantities: columns to check.

    Returns:
        ``[{"motor", "coil_set", "quantity", "value", "median", "z"}]`` sorted by ``|z|`` descending.
    """
    ok = [r for r in rows if r.get("status") == "ok"]
    flags = []
    for q in quantities:
        x = np.array([np.nan if r.get(q) is None else r[q] for r in ok], dtype=float)
        if q == "zeta" and np.isfinite(x).any():
            c = np.angle(np.nanmean(np.exp(1j * x)))
            x = c + np.angle(np.exp(1j * (x - c)))
        z = robust_z(x)
        med = float(np.nanmedian(x)) if np.isfinite(x).any() else float("nan")
        for r, xi, zi in zip(ok, x, z):
            if np.isfinite(zi) and abs(zi) > threshold:
                flags.append({"motor": r["motor"], "coil_set": r["coil_set"], "quantity": q, "value": float(xi),
                              "median": med, "z": float(zi)})
    return sorted(flags, key=lambda f: -abs(f["z"]))


_LABELS = {"k": "k (N/A)", "zeta": "zeta (rad)", "cogging_pp": "cogging amplitude, peak-to-peak in y (N)",
           "improvement": "improvement cost_physics / cost_pgnn (-)"}


def write_fleet_html(path, rows, threshold: float = DEFAULT_OUTLIER_Z) -> Path:
    """``fleet.html``: histograms of :data:`QA_QUANTITIES` (PNG embedded), outliers marked, a table of them, failures.

    Returns:
        ``path``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pgcomm.io.atomic import atomic_write_text

    flags = flag_outliers(rows, threshold)
    ok = [r for r in rows if r.get("status") == "ok"]
    failed = [r for r in rows if r.get("status") != "ok"]
    esc = html.escape
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>pgcomm fleet</title></head><body>",
             f"<h1>pgcomm fleet: {len({r['motor'] for r in rows})} motors</h1>",
             f"<p>{len({r['motor'] for r in ok})} ok ({len(ok)} coil sets), {len(failed)} failed. Outliers: robust "
             f"z-score |z| &gt; {threshold:g} (median and MAD &middot; 1.4826 across the fleet).</p>"]
    for q in QA_QUANTITIES:
        x = np.array([np.nan if r.get(q) is None else r[q] for r in ok], dtype=float)
        x = x[np.isfinite(x)]
        fig, ax = plt.subplots(figsize=(6, 3))
        if x.size:
            ax.hist(x, bins=max(5, min(40, int(np.sqrt(x.size)) * 2)), color="0.6")
            for f in flags:
                if f["quantity"] == q:
                    ax.axvline(f["value"], color="C3", lw=1)
        ax.set_xlabel(_LABELS[q])
        ax.set_ylabel("coil sets")
        n_out = sum(f["quantity"] == q for f in flags)
        ax.set_title(f"{q}: {x.size} values, {n_out} outlier(s) (red)")
        fig.tight_layout()
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=90)
        plt.close(fig)
        parts.append(f"<h2>{esc(_LABELS[q])}</h2><img src='data:image/png;base64,"
                     f"{base64.b64encode(buf.getvalue()).decode()}'>")
    parts.append("<h2>Outliers: which motor is unlike the others, and in what</h2>")
    if flags:
        parts.append("<table border='1' cellpadding='3'><tr><th>motor</th><th>coil set</th><th>quantity</th>"
                     "<th>value</th><th>fleet median</th><th>robust z</th></tr>")
        for f in flags:
            parts.append(f"<tr><td>{esc(f['motor'])}</td><td>{f['coil_set']}</td><td>{esc(f['quantity'])}</td>"
                         f"<td>{f['value']:.6g}</td><td>{f['median']:.6g}</td><td>{f['z']:+.2f}</td></tr>")
        parts.append("</table>")
    else:
        parts.append("<p>none</p>")
    parts.append("<h2>Failed motors</h2>")
    if failed:
        parts.append("<table border='1' cellpadding='3'><tr><th>motor</th><th>error</th></tr>")
        parts += [f"<tr><td>{esc(r['motor'])}</td><td>{esc(r['error'] or '')}</td></tr>" for r in failed]
        parts.append("</table>")
    else:
        parts.append("<p>none</p>")
    parts.append("</body></html>\n")
    atomic_write_text(path, "\n".join(parts))
    return Path(path)
