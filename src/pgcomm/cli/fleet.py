"""``pgcomm fleet``: calibrate, identify, evaluate and export every motor of a fleet directory on Dask.

``--out`` is a resumable workspace (DESIGN, "--out"): it is written in place, not staged;
each motor's folder appears atomically when the motor is finished (:mod:`pgcomm.fleet`).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from pgcomm.errors import ConfigError

HELP = ("Run a fleet of motors (one folder each: logs/*.csv, motor.toml, optional config.toml) on Dask: "
        "calibrate, identify, evaluate, export per motor; fleet.parquet/.csv/.html with outliers.")

#: ``fleet`` manages ``--out`` itself (resumable workspace), so the front end does not stage it.
STAGED_OUT = False


def configure(p) -> None:
    """Options of ``pgcomm fleet``."""
    from pgcomm.defaults import DEFAULT_OUTLIER_Z

    p.add_argument("--data", required=True, type=Path, metavar="DIR", help="fleet directory: one folder per motor")
    p.add_argument("--out", required=True, type=Path,
                   help="output workspace (created; finished motors are kept and skipped on a rerun)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--workers", type=int, metavar="N",
                   help=f"worker processes of the embedded LocalCluster (default: the machine's cores, {os.cpu_count()})")
    g.add_argument("--scheduler", metavar="ADDRESS", help="use a running Dask cluster, e.g. tcp://host:8786")
    p.add_argument("--redo", action="store_true", help="run finished motors again")
    p.add_argument("--outlier-z", type=float, default=DEFAULT_OUTLIER_Z, metavar="Z",
                   help=f"robust z-score above which fleet.html flags a value (default {DEFAULT_OUTLIER_Z:g})")
    p.add_argument("--seed", type=int, default=0, help="seed of the identification's random starts (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def run(args, out, progress) -> None:
    """Run the fleet into ``args.out`` (``out`` is ``None``: not staged)."""
    import dask
    from distributed import Client, LocalCluster

    from pgcomm.fleet import WORKER_ENV, find_motors, run_fleet

    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers {args.workers}: need at least one worker")
    if not args.outlier_z > 0:
        raise ConfigError(f"--outlier-z {args.outlier_z:g}: must be a positive z-score")
    out_dir = Path(args.out)
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"--out {out_dir}: exists and is not a directory")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ConfigError(f"--out {out_dir}: cannot create ({e.strerror})") from None
    find_motors(args.data)  # fail in the first second on a bad --data
    cluster = None
    if args.scheduler:
        try:
            client = Client(args.scheduler, timeout="10s")
        except OSError as e:
            raise ConfigError(f"--scheduler {args.scheduler}: cannot connect ({e})") from None
    else:
        n = args.workers or os.cpu_count() or 1
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
