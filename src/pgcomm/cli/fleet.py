"""``pgcomm fleet``: calibrate, identify, evaluate and export every motor of a fleet directory on Dask.

``--out`` is a resumable workspace (DESIGN, "--out"): it is written in place, not staged;
each motor's folder appears atomically when the motor is finished (:mod:`pgcomm.fleet`). It must be
a new or empty folder or the workspace of an earlier fleet run, and never the current folder or one
of its parents. The embedded cluster runs at most one worker process per core of this machine (a larger
``--workers`` is lowered to the cores, and said); more workers need a running cluster (``--scheduler``). A fleet in which any motor failed exits with code 2
and one line with the count, after writing the workspace (the finished motors are kept).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from pgcomm.cli._common import seed_value
from pgcomm.cli._output import refuse_working_folder
from pgcomm.defaults import DEFAULT_OUTLIER_Z
from pgcomm.errors import ConfigError, PgcommError

# Imports inside the functions below: Dask (and bokeh, only to say whether the dashboard can be served) load only
# when the fleet runs; `import pgcomm.cli` loads none of them (`--help` and a bad option answer at once).

HELP = ("Run a fleet of motors (one folder each: logs/*.csv, motor.toml, optional config.toml) on Dask: "
        "calibrate, identify, evaluate, export per motor; fleet.parquet/.csv/.html with outliers.")

#: ``fleet`` manages ``--out`` itself (resumable workspace), so the front end does not stage it.
STAGED_OUT = False


def configure(p) -> None:
    """Options of ``pgcomm fleet``."""
    p.add_argument("--data", required=True, type=Path, metavar="DIR", help="fleet directory: one folder per motor")
    p.add_argument("--out", required=True, type=Path,
                   help="output workspace (created; finished motors are kept and skipped on a rerun)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, metavar="N",
                   help=f"worker processes of the embedded LocalCluster, at most the machine's cores (default: "
                        f"as many as there are motors, at most {machine_cores()})")
    g.add_argument("--scheduler", metavar="ADDRESS", help="use a running Dask cluster, e.g. tcp://host:8786")
    p.add_argument("--redo", action="store_true", help="run finished motors again")
    p.add_argument("--outlier-z", type=float, default=DEFAULT_OUTLIER_Z, metavar="Z",
                   help=f"robust z-score above which fleet.html flags a value (default {DEFAULT_OUTLIER_Z:g})")
    p.add_argument("--seed", type=seed_value, default=0,
                   help="seed of the identification's random starts, 0 to 2**32-1 (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def machine_cores() -> int:
    """Cores this process may run on (its CPU affinity, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover  (not Linux)
        return os.cpu_count() or 1


#: Files and folders that mark an earlier fleet run's workspace (a rerun resumes it).
_WORKSPACE_MARKS = ("fleet.json", "failed", ".jax_cache")


def check_workspace(out: Path) -> Path:
    """``--out`` of ``fleet``: not the current folder or a parent of it, not a file, and new, empty or the
    workspace of an earlier fleet run (which a rerun resumes). Returns the folder; nothing is created.

    Raises:
        ConfigError: one line naming ``--out``.
    """
    from pgcomm.fleet.motor import ROWS_FILE

    out_dir = Path(out)
    refuse_working_folder(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {out_dir}: exists and is not a directory")
    if out_dir.is_dir():
        entries = list(out_dir.iterdir())
        marked = any((out_dir / m).exists() for m in _WORKSPACE_MARKS) or any(
            (e / ROWS_FILE).is_file() for e in entries if e.is_dir())
        if entries and not marked:
            shown = ", ".join(sorted(e.name for e in entries)[:3]) + (", ..." if len(entries) > 3 else "")
            raise ConfigError(f"--out {out_dir}: folder exists, is not empty ({len(entries)} entries: {shown}) and "
                              "is not the workspace of an earlier fleet run (no fleet.json); choose a new --out")
    return out_dir


def run(args, out, progress) -> None:
    """Run the fleet into ``args.out`` (``out`` is ``None``: not staged).

    Raises:
        ConfigError: a bad option or ``--out`` (before anything is written or started).
        PgcommError: one or more motors failed (after the workspace and the fleet table are written).
    """
    from pgcomm.fleet import WORKER_ENV, find_motors

    cores = machine_cores()
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers {args.workers}: need at least one worker")
    if not args.outlier_z > 0:
        raise ConfigError(f"--outlier-z {args.outlier_z:g}: must be a positive z-score")
    out_dir = check_workspace(args.out)
    motors = find_motors(args.data)  # fail in the first second on a bad --data
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ConfigError(f"--out {out_dir}: cannot create ({e.strerror})") from None
    import dask
    from distributed import Client, LocalCluster

    from pgcomm.fleet import run_fleet

    cluster = None
    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout="10s")
        except OSError as e:
            raise ConfigError(f"--scheduler {args.scheduler}: cannot connect ({e})") from None
    else:
        n = args.workers or max(1, min(cores, len(motors)))
        if n > cores:
            # each worker is a process identifying one motor at a time: more than the cores only adds memory
            print(f"pgcomm: --workers {n}: this machine has {cores} core(s); running {cores} worker process(es) "
                  "(for more, start a Dask cluster and give --scheduler ADDRESS)", file=sys.stderr)
            n = cores
        with dask.config.set({"distributed.nanny.pre-spawn-environ": WORKER_ENV}):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   env=WORKER_ENV, silence_logs=40)
        client = Client(cluster)
    show = _Display(args.quiet, client)
    try:
        fleet = run_fleet(client, args.data, out_dir, redo=args.redo, seed=args.seed, outlier_z=args.outlier_z,
                          on_event=show)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    if not args.quiet:
        ok = len(fleet.records) - len(fleet.failed)
        print(f"{len(fleet.motors)} motors: {ok} done, {len(fleet.failed)} failed, {len(fleet.skipped)} skipped "
              f"(finished before) in {fleet.seconds:.1f} s")
        for name in fleet.failed:
            print(f"  {name}: {fleet.records[name]['error']}")
        print(f"wrote {args.out}/fleet.parquet, fleet.csv, fleet.html, fleet.json and one folder per finished motor")
    if fleet.failed:
        first = fleet.failed[0]
        raise PgcommError(f"fleet: {len(fleet.failed)} of {len(fleet.submitted)} motor(s) failed ({first}: "
                          f"{fleet.records[first]['error']}" + (", ..." if len(fleet.failed) > 1 else "")
                          + f"); each motor's error is in {args.out}/failed/ and fleet.csv, the finished motors are "
                          "kept and a rerun runs only the failed ones")


class _Display:
    """Progress lines on stderr: done / failed / running, ETA; the dashboard address first."""

    def __init__(self, quiet: bool, client):
        self.quiet, self.client = quiet, client
        self.t0 = time.perf_counter()

    def __call__(self, kind, run, record) -> None:
        if self.quiet:
            return
        if kind == "start":
            self.t0 = time.perf_counter()
            workers = len(self.client.scheduler_info().get("workers", {}))
            print(f"[fleet] {len(run.motors)} motors: {len(run.submitted)} to run, {len(run.skipped)} finished "
                  f"before; {workers} worker(s)", file=sys.stderr, flush=True)
            print(f"[fleet] Dask dashboard: {_dashboard(self.client)}", file=sys.stderr, flush=True)
            return
        done = len(run.records)
        failed = len(run.failed)
        left = len(run.submitted) - done
        el = time.perf_counter() - self.t0
        eta = el / done * left if done else float("nan")
        running = min(left, len(self.client.scheduler_info().get("workers", {})))
        what = "ok" if record["status"] == "ok" else f"FAILED: {record['error']}"
        secs = "" if record.get("seconds") is None else f" ({record['seconds']:.1f} s)"
        print(f"[fleet] {record['motor']} {what}{secs} | done {done - failed}, failed {failed}, running {running}, "
              f"left {left}, ETA {_hms(eta)}", file=sys.stderr, flush=True)


def _dashboard(client) -> str:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return f"{client.dashboard_link} (needs bokeh installed where the scheduler runs)"
    return client.dashboard_link


def _hms(s: float) -> str:
    if s != s:
        return "?"
    s = int(round(s))
    return f"{s // 3600:d}:{s // 60 % 60:02d}:{s % 60:02d}"
