"""The fleet on a Dask cluster: worker set-up (one thread, shared compile cache) and :func:`run_fleet`.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
import sys
from distributed import as_completed


from pgcomm.defaults import DEFAULT_OUTLIER_Z
from pgcomm.fleet.motor import _FAILED, _failed_row, find_motors, is_finished, process_motor
from pgcomm.fleet.qa import fleet_rows
from pgcomm.fleet.report import write_fleet_table
import pgcomm
from pgcomm.io.atomic import atomic_write_text

#: Environment of a worker process: XLA and BLAS/OpenMP on one thread each (one task per worker).
WORKER_ENV = {
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "MALLOC_ARENA_MAX": "2",
}

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
        pinned = "jax" not in sys.modules
        if pinned:
            for k, v in WORKER_ENV.items():
                os.environ.setdefault(k, v)
        import jax  # after WORKER_ENV: JAX reads its thread settings when it loads

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

        atomic_write_text(out_dir / "fleet.json", json.dumps(
            {"motors": names, "skipped": run.skipped, "submitted": run.submitted, "failed": run.failed,
             "seconds": run.seconds, "tasks": list(run.records.values())}, indent=1, default=str) + "\n")
    return run


def _record_failure(out_dir: Path, rec: dict) -> None:
    (out_dir / _FAILED).mkdir(exist_ok=True)
    atomic_write_text(out_dir / _FAILED / f"{rec['motor']}.json", json.dumps(rec, indent=1) + "\n")


# --------------------------------------------------------------------------------------------
# the fleet table and its QA
# --------------------------------------------------------------------------------------------

