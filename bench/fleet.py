"""Fleet throughput on Dask: motors per hour with 1 and 2 workers, overheads, extrapolation to 10 000 motors.

Usage: ``python bench/fleet.py [--motors 6] [--keep DIR]``. Writes a zoo with logs
(``pgcomm zoo --logs``), then runs ``pgcomm.fleet.run_fleet`` on an embedded ``LocalCluster``
with 1 and with 2 worker processes (fresh output and a fresh JAX cache each time), and measures:

* motors per hour and the speed-up of 2 workers over 1;
* the scheduler's per-task overhead: round trip of a no-op task;
* data sent per task: the pickled task (arguments are paths, not data);
* JAX compile cost per worker: a worker's first task vs its later ones (from the task records);
* an extrapolation to 10 000 motors on W workers, with what limits it.
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import tempfile
import time
from pathlib import Path


def _cluster(n):
    import dask
    from distributed import Client, LocalCluster

    from pgcomm.fleet import WORKER_ENV

    with dask.config.set({"distributed.nanny.pre-spawn-environ": WORKER_ENV}):
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               env=WORKER_ENV, silence_logs=40)
    return cluster, Client(cluster)


def _noop(x):
    return x


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--motors", type=int, default=6)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", type=Path, help="reuse/keep the zoo here")
    a = ap.parse_args()
    from pgcomm.fleet import process_motor, run_fleet
    from pgcomm.experiment import write_production_logs
    from pgcomm.zoo import draw_motor, motor_folder_name, write_motor

    root = Path(a.keep or tempfile.mkdtemp(prefix="pgcomm-bench-fleet-"))
    zoo = root / "zoo"
    t = time.perf_counter()
    for i in range(1, a.motors + 1):
        f = zoo / motor_folder_name(i, a.motors)
        if not (f / "logs").is_dir():
            write_production_logs(write_motor(draw_motor(a.seed, i - 1), f), seed=a.seed)
    print(f"zoo: {a.motors} motors with logs in {root} ({time.perf_counter() - t:.0f} s to write or check)")
    samples = sum(sum(1 for _ in open(p)) - 1 for p in zoo.glob("*/logs/*.csv"))
    print(f"logged samples: {samples} ({samples / a.motors:.0f} per motor)")

    res = {}
    for n in (1, 2):
        cluster, client = _cluster(n)
        try:
            # scheduler overhead: no-op round trips (after one warm-up)
            client.submit(_noop, 0, pure=False).result()
            rt = []
            for k in range(50):
                t = time.perf_counter()
                client.submit(_noop, k, pure=False).result()
                rt.append(time.perf_counter() - t)
            out = root / f"out_{n}"
            import shutil

            shutil.rmtree(out, ignore_errors=True)
            t = time.perf_counter()
            run = run_fleet(client, zoo, out)
            wall = time.perf_counter() - t
        finally:
            client.close()
            cluster.close()
        recs = [r for r in run.records.values() if r["status"] == "ok"]
        first = [r["seconds"] for r in recs if r["task_index"] == 1]
        later = [r["seconds"] for r in recs if r["task_index"] > 1]
        res[n] = dict(wall=wall, ok=len(recs), failed=len(run.failed), rt=statistics.median(rt), first=first,
                      later=later)
        print(f"{n} worker(s): {len(recs)} ok, {len(run.failed)} failed in {wall:.1f} s -> "
              f"{3600 * len(recs) / wall:.0f} motors/h; no-op task round trip {1e3 * statistics.median(rt):.2f} ms "
              f"(median of 50)")
        if first:
            print(f"    task seconds: first on a worker {statistics.mean(first):.1f} s (n={len(first)}), later "
                  + (f"{statistics.mean(later):.1f} s (n={len(later)})" if later else "none"))
    task_bytes = len(pickle.dumps((process_motor, str(zoo / "motor_01"), str(root / "out"), 0)))
    result_bytes = len(pickle.dumps({"rows": [dict.fromkeys(range(14), 1.0)], "motor": "motor_01"}))
    s1, s2 = res[1]["wall"], res[2]["wall"]
    print(f"speed-up 2 vs 1 worker: {s1 / s2:.2f}x (ideal 2x; this machine has {os.cpu_count()} cores)")
    print(f"data sent per task: {task_bytes} B out (paths), ~{result_bytes} B back (rows); logs are read by the "
          "worker from the shared file system")
    all_first = res[1]["first"] + res[2]["first"]
    all_later = res[1]["later"] + res[2]["later"]
    if all_first and all_later:
        f, l = statistics.mean(all_first), statistics.mean(all_later)
        print(f"JAX compile per worker: first task {f:.1f} s vs later {l:.1f} s: ratio {f / l:.1f}x, ~{f - l:.1f} s "
              "paid once per worker and size bucket (chunks padded to powers of two; persistent cache in OUT/.jax_cache)")
    else:
        f = l = s1 / max(res[1]["ok"], 1)
    per_motor = l if all_later else s1 / max(res[1]["ok"], 1)
    ovh = res[2]["rt"]
    print(f"scheduler overhead per task / task time: {ovh / per_motor:.1e}")
    for w in (16, 64, 256):
        hours = (10_000 * per_motor / w + (f - l)) / 3600
        print(f"extrapolation: 10 000 motors on {w} workers (one core each): {hours:.2f} h "
              f"({3600 * w / per_motor:.0f} motors/h)")
    print("limits: the per-motor compute (identification, ~%.0f s per motor here) dominates; the scheduler's "
          "~%.1f ms per task and the ~%d B of task data are negligible (a single scheduler handles ~1e3 tasks/s); "
          "each worker pays JAX's compilation once per size bucket (%.0f s), shared through the persistent cache; "
          "at scale the shared file system's read bandwidth (logs, ~%.0f MB per motor) and memory per worker "
          "limit before the scheduler does." % (per_motor, 1e3 * ovh, task_bytes, f - l,
                                                 sum(p.stat().st_size for p in zoo.glob('*/logs/*.csv'))
                                                 / a.motors / 1e6))


if __name__ == "__main__":
    main()
