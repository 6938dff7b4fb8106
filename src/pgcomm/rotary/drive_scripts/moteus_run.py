"""Run a pgcomm rotary plan on a moteus controller and log the columns ``pgcomm identify`` reads.

Written by ``pgcomm plan --drive moteus`` beside ``plan.json``; run it on the PC connected to the controller::

    python run_moteus.py                   # every run of the plan, logs into ./logs
    python run_moteus.py --max-seconds 2   # a wiring check: the first 2 s of each run

Each run plays ``references/<run>.csv`` back in the controller's position mode as a velocity loop (position NaN, the
velocity setpoint, the dither as a feed-forward torque) and logs one row per command and reply:

=================  ==================================================================================
``time_s``         the host's clock (``time.perf_counter``, s since the script started), the middle of
                   the command's round trip: the stamps are as the host took them, not a uniform grid
``position``       register 0x001, revolutions of the output shaft
``velocity``       register 0x002, revolutions per second of the output shaft
``q_current``      register 0x004, measured q-axis current (A)
``d_current``      register 0x005, measured d-axis current (A)
``torque``         register 0x003, N·m (not read by pgcomm)
``velocity_cmd``   the velocity setpoint sent (rev/s)
``dither_A``       the dither current the feed-forward torque stands for (A)
=================  ==================================================================================

``columns.toml`` beside it maps them for pgcomm (``t``, ``theta`` in rev, ``velocity`` in rev/s, ``iq_1``,
``id_1``). Beside each log, ``<run>.csv.plan.json`` records the plan's id, the run, the package's version and the
rows and time steps the host reached (the logs carry their round).

The moteus calls, checked against mjbots/moteus (commit db1a7623d6a7d5568e7632b974a9ab521a4d2bab, June 2026):

* ``docs/integration/python.md`` ("Basic Usage", "Querying alternate registers";
  https://github.com/mjbots/moteus/blob/main/docs/integration/python.md): ``moteus.Controller(id=...,
  query_resolution=qr)``, ``await c.set_position(position=math.nan, velocity=..., query=True)``,
  ``result.values[moteus.Register.POSITION]``, ``qr = moteus.QueryResolution(); qr.q_current = moteus.F32``
  (``lib/python/moteus/moteus.py``: ``QueryResolution.q_current`` and ``d_current`` default to ``IGNORE``);
* ``lib/python/README.md`` ("Theory"): ``await Controller.set_stop()``, ``set_position()`` and ``query()`` for one
  controller;
* ``docs/guides/control-modes.md`` ("Understanding Position Mode", "Velocity Control";
  https://github.com/mjbots/moteus/blob/main/docs/guides/control-modes.md): position NaN and a velocity in
  revolutions/s is the velocity loop; ``feedforward_torque`` is extra torque (N·m) beyond the loop's;
* ``docs/protocol/registers.md`` (https://github.com/mjbots/moteus/blob/main/docs/protocol/registers.md): 0x001
  position in rotations of the output shaft, 0x002 velocity in Hz at the output shaft, 0x004/0x005 the measured
  Q/D phase currents in A, 0x000 mode (0 stopped, clears faults; 1 fault; 11 timeout), 0x00f fault code.

Assumed, not fixed by those documents: the feed-forward torque per ampere is the plan's ``k_t`` (``--torque-per-amp``
overrides it; the logged ``q_current`` is what identification reads, so an error here only scales the dither); a
direct drive (``motor_position.rotor_to_output_ratio`` 1): with a gearbox the logged position is the output's, not
the rotor's; the controller's own cogging compensation off (``motor.cogging_dq_scale`` 0), or the logs show the
remainder only.
"""

from __future__ import annotations

import argparse
import asyncio
import csv
import json
import math
import statistics
import sys
import time
from pathlib import Path

#: The columns this script writes, in this order (the drive's own names: ``columns.toml`` maps them).
COLUMNS = ("time_s", "position", "velocity", "q_current", "d_current", "torque", "velocity_cmd", "dither_A")

#: Seconds of zero velocity commanded after each run, before the stop.
SETTLE_S = 0.5

clock = time.perf_counter


def fail(message: str):
    """One line on stderr and exit code 2 (the plan or the set-up is at fault, not the script)."""
    print(f"run_moteus: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def load_plan(folder: Path) -> dict:
    """``plan.json`` of the plan folder, checked to be a rotary plan for this drive."""
    path = folder / "plan.json"
    try:
        plan = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        fail(f"{path}: not a readable plan ({e})")
    if plan.get("schema") != "pgcomm-rotary-plan/1":
        fail(f"{path}: not a pgcomm rotary plan (schema {plan.get('schema')!r})")
    if plan.get("drive") != "moteus":
        fail(f"{path}: a plan for {plan.get('drive')}, not moteus (pgcomm plan --drive moteus)")
    return plan


def read_reference(path: Path) -> tuple:
    """``(t s, speed rad/s, dither A)`` lists of a run's reference CSV."""
    t, speed, dither = [], [], []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            t.append(float(row["t"]))
            speed.append(float(row["speed"]))
            dither.append(float(row["dither"]))
    return t, speed, dither


def write_sidecar(log_path: Path, plan: dict, run: str, stamps: list, **extra) -> dict:
    """The log's plan sidecar ``<log>.plan.json`` (schema ``pgcomm-rotary-log-plan/1``): the plan's id, the run, the
    drive, the planned log period and the rows and time steps the host reached (s). Returns the document."""
    steps = [b - a for a, b in zip(stamps[:-1], stamps[1:])]
    doc = {"schema": "pgcomm-rotary-log-plan/1", "plan_id": plan["plan_id"], "run": run, "drive": plan["drive"],
           "sample_time_s": float(plan["sample_time_s"]), "columns": list(COLUMNS), "rows": len(stamps),
           "median_step_s": statistics.median(steps) if steps else None, "max_step_s": max(steps) if steps else None,
           **extra}
    log_path.with_name(log_path.name + ".plan.json").write_text(json.dumps(doc, indent=2) + "\n")
    return doc


async def run_one(moteus, c, ref: tuple, sample_time: float, torque_per_amp: float, seconds: float, writer,
                  t0: float) -> list:
    """Play one reference on controller ``c`` for ``seconds`` (s) and write a row per reply; returns the stamps."""
    t, speed, dither = ref
    stamps = []
    start = clock()
    n = 0
    while True:
        before = clock()
        tau = before - start
        if tau >= seconds:
            break
        i = min(int(tau / sample_time), len(t) - 1)
        v = speed[i] / (2.0 * math.pi)
        d = dither[i]
        result = await c.set_position(position=math.nan, velocity=v, feedforward_torque=d * torque_per_amp,
                                      query=True)
        after = clock()
        values = result.values
        mode = int(values.get(moteus.Register.MODE, 0))
        if mode in (int(moteus.Mode.FAULT), int(moteus.Mode.TIMEOUT)):
            raise RuntimeError(f"the controller left position mode (mode {mode}, fault code "
                               f"{values.get(moteus.Register.FAULT)})")
        stamp = 0.5 * (before + after) - t0
        stamps.append(stamp)
        writer.writerow([repr(stamp), repr(float(values[moteus.Register.POSITION])),
                         repr(float(values[moteus.Register.VELOCITY])), repr(float(values[moteus.Register.Q_CURRENT])),
                         repr(float(values[moteus.Register.D_CURRENT])), repr(float(values[moteus.Register.TORQUE])),
                         repr(v), repr(d)])
        n += 1
        delay = start + n * sample_time - clock()
        if delay > 0:
            await asyncio.sleep(delay)
    return stamps


async def settle(c) -> None:
    """Command zero velocity for :data:`SETTLE_S`, then stop."""
    end = clock() + SETTLE_S
    while clock() < end:
        await c.set_position(position=math.nan, velocity=0.0, feedforward_torque=0.0)
        await asyncio.sleep(0.01)
    await c.set_stop()


async def run_plan(args, plan: dict, folder: Path) -> None:
    """Every selected run of the plan, one log each (written as ``.part``, renamed when the run is complete)."""
    try:
        import moteus
    except ImportError:
        fail("the moteus package is not installed (pip install moteus; "
             "https://github.com/mjbots/moteus/blob/main/docs/integration/python.md)")
    torque_per_amp = args.torque_per_amp if args.torque_per_amp is not None else plan["motor"].get("k_t")
    names = [r["name"] for r in plan["runs"]]
    unknown = [n for n in args.runs or () if n not in names]
    if unknown:
        fail(f"--runs {' '.join(unknown)}: not in the plan (its runs: {', '.join(names)})")
    runs = [r for r in plan["runs"] if not args.runs or r["name"] in args.runs]
    if any(a != 0.0 for r in runs for a in r["dither_amplitude_A"]) and torque_per_amp is None:
        fail("the plan has a dither but no k_t: give --torque-per-amp (N·m per A of q current)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for r in runs:
        if (out / f"{r['name']}.csv").exists():
            fail(f"{out / (r['name'] + '.csv')} exists; choose another --out")
    qr = moteus.QueryResolution()
    qr.q_current = moteus.F32
    qr.d_current = moteus.F32
    c = moteus.Controller(id=args.id, query_resolution=qr)
    sample_time = float(plan["sample_time_s"])
    extra = {"package_version": getattr(moteus, "__version__", None), "controller_id": args.id,
             "torque_per_amp_N_m_per_A": torque_per_amp}
    t0 = clock()
    await c.set_stop()
    try:
        for r in runs:
            ref = read_reference(folder / r["reference"])
            seconds = min(float(r["duration_s"]), args.max_seconds) if args.max_seconds else float(r["duration_s"])
            part = out / f"{r['name']}.csv.part"
            print(f"run {r['name']}: {r['speed_rad_s']:+.4g} rad/s, {seconds:.1f} s", flush=True)
            try:
                with open(part, "w", newline="") as f:
                    writer = csv.writer(f)
                    writer.writerow(COLUMNS)
                    stamps = await run_one(moteus, c, ref, sample_time, torque_per_amp or 0.0, seconds, writer, t0)
            except BaseException:
                part.unlink(missing_ok=True)
                raise
            finally:
                await settle(c)
            part.replace(out / f"{r['name']}.csv")
            med = write_sidecar(out / f"{r['name']}.csv", plan, r["name"], stamps, **extra)["median_step_s"]
            if med is not None and med > 1.2 * sample_time:
                print(f"  the host logged every {1e3 * med:.2f} ms, the plan assumed {1e3 * sample_time:.2f} ms: the "
                      "fastest runs may exceed the alias guard; plan again with pgcomm plan --data", flush=True)
    finally:
        await c.set_stop()


def main(argv=None) -> int:
    """Parse the options and run the plan beside this script."""
    p = argparse.ArgumentParser(description="Run a pgcomm rotary plan on a moteus controller and log it.")
    p.add_argument("--id", type=int, default=1, help="the controller's CAN id (default 1)")
    p.add_argument("--torque-per-amp", type=float, help="N·m of feed-forward torque per A of q current (default: "
                                                        "the plan's k_t)")
    p.add_argument("--runs", nargs="+", metavar="NAME", help="only these runs (default: all, in the plan's order)")
    p.add_argument("--max-seconds", type=float, help="play at most this many seconds of each run (a wiring check)")
    p.add_argument("--out", default=str(Path(__file__).resolve().parent / "logs"), help="log folder (default: logs "
                                                                                        "beside this script)")
    args = p.parse_args(argv)
    folder = Path(__file__).resolve().parent
    plan = load_plan(folder)
    asyncio.run(run_plan(args, plan, folder))
    return 0


if __name__ == "__main__":
    sys.exit(main())
