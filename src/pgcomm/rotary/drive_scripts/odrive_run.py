"""Run a pgcomm rotary plan on an ODrive (firmware 0.5.x) and log the columns ``pgcomm identify`` reads.

Written by ``pgcomm plan --drive odrive`` beside ``plan.json``; run it on the PC connected to the ODrive over USB::

    python run_odrive.py                   # every run of the plan on axis 0, logs into ./logs
    python run_odrive.py --max-seconds 2   # a wiring check: the first 2 s of each run

Each run plays ``references/<run>.csv`` back in velocity control (``input_vel``, the dither as ``input_torque``, the
feed-forward torque) and logs one row per loop:

=================  ==================================================================================
``time_s``         the host's clock (``time.perf_counter``, s since the script started), the middle of
                   the position's read: the stamps are as the host took them, not a uniform grid
``pos_estimate``   ``axis.encoder.pos_estimate``, turns (multi-turn)
``Iq_measured``    ``axis.motor.current_control.Iq_measured``, A (the drive's filtered report)
``Id_measured``    ``axis.motor.current_control.Id_measured``, A
``input_vel``      the velocity setpoint sent (turn/s)
``dither_A``       the dither current the feed-forward torque stands for (A)
=================  ==================================================================================

Every attribute is a round trip over USB: the script reads three per row (a few ms on a PC; the shared ODrive logs of
this motor class were stamped every 1.4-6 ms) and writes ``input_vel`` only while it changes. ``columns.toml`` beside
it maps the columns for pgcomm (``t``, ``theta`` in rev, ``iq_1``, ``id_1``). Beside each log, ``<run>.csv.plan.json``
records the plan's id, the run, the package's version and the rows and time steps the host reached (the logs carry
their round).

The ODrive calls, checked against odriverobotics/ODrive at tag fw-v0.5.6 (commit
a308314ed2ca613164b81e7bbdfacc53cd1859ff):

* ``docs/native-protocol.rst`` ("Python"; https://github.com/odriverobotics/ODrive/blob/fw-v0.5.6/docs/
  native-protocol.rst) and ``tools/odrive_demo.py``: ``odrive.find_any()``, ``from odrive.enums import ...``,
  ``axis.requested_state = AXIS_STATE_CLOSED_LOOP_CONTROL``;
* ``docs/control-modes.rst`` ("Velocity Control"; https://github.com/odriverobotics/ODrive/blob/fw-v0.5.6/docs/
  control-modes.rst): ``axis.controller.config.control_mode = CONTROL_MODE_VELOCITY_CONTROL``,
  ``axis.controller.input_vel`` in turn/s; "Torque Control": ``axis.motor.config.torque_constant`` (N·m/A);
* ``Firmware/odrive-interface.yaml``: ``controller.input_torque`` (N·m) "in CONTROL_MODE_VELOCITY_CONTROL ... sets the
  feed-forward torque"; ``controller.config.input_mode`` (``INPUT_MODE_PASSTHROUGH``), ``controller.config.vel_limit``
  (turn/s); ``encoder.pos_estimate`` "linear position estimate of the encoder, in turns" (float32);
  ``motor.current_control.Iq_measured`` / ``Id_measured`` (A); ``controller.config.anticogging.anticogging_enabled``;
  ``axis.error``.

Assumed, not fixed by those documents: the axis is calibrated and its encoder ready (the script only enters closed
loop); the drive's anti-cogging is off (the script refuses otherwise: the logs would show the remainder only); the
drive's ``torque_constant`` converts the dither's current to the feed-forward torque (the logged ``Iq_measured`` is
what identification reads). ``pos_estimate`` is float32: start near zero turns (a reboot resets it), or its step grows
with the distance turned.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import sys
import time
from pathlib import Path

#: The columns this script writes, in this order (the drive's own names: ``columns.toml`` maps them).
COLUMNS = ("time_s", "pos_estimate", "Iq_measured", "Id_measured", "input_vel", "dither_A")

#: Seconds of zero velocity commanded after each run.
SETTLE_S = 0.5
#: Rows between two reads of ``axis.error`` (each read is another USB round trip).
ERROR_CHECK_ROWS = 200

clock = time.perf_counter


def fail(message: str):
    """One line on stderr and exit code 2 (the plan or the set-up is at fault, not the script)."""
    print(f"run_odrive: error: {message}", file=sys.stderr)
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
    if plan.get("drive") != "odrive":
        fail(f"{path}: a plan for {plan.get('drive')}, not odrive (pgcomm plan --drive odrive)")
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


def run_one(axis, ref: tuple, sample_time: float, torque_per_amp: float, seconds: float, writer, t0: float) -> list:
    """Play one reference on ``axis`` for ``seconds`` (s) and write a row per loop; returns the stamps."""
    t, speed, dither = ref
    ctrl, cc, enc = axis.controller, axis.motor.current_control, axis.encoder
    stamps = []
    start = clock()
    n = 0
    last_vel = None
    while True:
        now = clock()
        tau = now - start
        if tau >= seconds:
            break
        i = min(int(tau / sample_time), len(t) - 1)
        v = speed[i] / (2.0 * math.pi)
        d = dither[i]
        if v != last_vel:
            ctrl.input_vel = v
            last_vel = v
        ctrl.input_torque = d * torque_per_amp
        before = clock()
        pos = enc.pos_estimate
        after = clock()
        iq = cc.Iq_measured
        id_ = cc.Id_measured
        stamp = 0.5 * (before + after) - t0
        stamps.append(stamp)
        writer.writerow([repr(stamp), repr(float(pos)), repr(float(iq)), repr(float(id_)), repr(v), repr(d)])
        n += 1
        if n % ERROR_CHECK_ROWS == 0 and axis.error:
            raise RuntimeError(f"the axis reports error {axis.error:#x} (odrivetool: dump_errors(odrv0))")
        delay = start + n * sample_time - clock()
        if delay > 0:
            time.sleep(delay)
    return stamps


def settle(axis) -> None:
    """Command zero velocity and no feed-forward torque, and wait :data:`SETTLE_S`."""
    axis.controller.input_torque = 0.0
    axis.controller.input_vel = 0.0
    time.sleep(SETTLE_S)


def run_plan(args, plan: dict, folder: Path) -> None:
    """Every selected run of the plan, one log each (written as ``.part``, renamed when the run is complete)."""
    try:
        import odrive
        from odrive.enums import (AXIS_STATE_CLOSED_LOOP_CONTROL, AXIS_STATE_IDLE, CONTROL_MODE_VELOCITY_CONTROL,
                                  INPUT_MODE_PASSTHROUGH)
    except ImportError as e:
        fail(f"the odrive package (firmware 0.5.x's enums) is not installed ({e}; pip install odrive; "
             "https://github.com/odriverobotics/ODrive/blob/fw-v0.5.6/docs/native-protocol.rst)")
    names = [r["name"] for r in plan["runs"]]
    unknown = [n for n in args.runs or () if n not in names]
    if unknown:
        fail(f"--runs {' '.join(unknown)}: not in the plan (its runs: {', '.join(names)})")
    runs = [r for r in plan["runs"] if not args.runs or r["name"] in args.runs]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for r in runs:
        if (out / f"{r['name']}.csv").exists():
            fail(f"{out / (r['name'] + '.csv')} exists; choose another --out")
    print("finding an ODrive ...", flush=True)
    drive = odrive.find_any()
    axis = getattr(drive, f"axis{args.axis}")
    ctrl = axis.controller
    top = max(abs(float(r["speed_rad_s"])) for r in runs) / (2.0 * math.pi)
    if ctrl.config.vel_limit < 1.2 * top:
        fail(f"axis{args.axis}.controller.config.vel_limit = {ctrl.config.vel_limit:g} turn/s is below 1.2 x the "
             f"plan's fastest run ({top:.3g} turn/s); raise it")
    if ctrl.config.anticogging.anticogging_enabled:
        fail(f"axis{args.axis}.controller.config.anticogging.anticogging_enabled is True: turn the drive's "
             "anti-cogging off, or the logs show only what it leaves")
    torque_per_amp = float(axis.motor.config.torque_constant)
    sample_time = float(plan["sample_time_s"])
    extra = {"package_version": getattr(odrive, "__version__", None), "axis": args.axis,
             "torque_per_amp_N_m_per_A": torque_per_amp}
    ctrl.input_vel = 0.0
    ctrl.input_torque = 0.0
    ctrl.config.control_mode = CONTROL_MODE_VELOCITY_CONTROL
    ctrl.config.input_mode = INPUT_MODE_PASSTHROUGH
    axis.requested_state = AXIS_STATE_CLOSED_LOOP_CONTROL
    t0 = clock()
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
                    stamps = run_one(axis, ref, sample_time, torque_per_amp, seconds, writer, t0)
            except BaseException:
                part.unlink(missing_ok=True)
                raise
            finally:
                settle(axis)
            part.replace(out / f"{r['name']}.csv")
            med = write_sidecar(out / f"{r['name']}.csv", plan, r["name"], stamps, **extra)["median_step_s"]
            if med is not None and med > 1.2 * sample_time:
                print(f"  the host logged every {1e3 * med:.2f} ms, the plan assumed {1e3 * sample_time:.2f} ms: the "
                      "fastest runs may exceed the alias guard; plan again with pgcomm plan --data", flush=True)
    finally:
        ctrl.input_torque = 0.0
        ctrl.input_vel = 0.0
        axis.requested_state = AXIS_STATE_IDLE


def main(argv=None) -> int:
    """Parse the options and run the plan beside this script."""
    p = argparse.ArgumentParser(description="Run a pgcomm rotary plan on an ODrive (firmware 0.5.x) and log it.")
    p.add_argument("--axis", type=int, choices=(0, 1), default=0, help="the ODrive's axis (default 0)")
    p.add_argument("--runs", nargs="+", metavar="NAME", help="only these runs (default: all, in the plan's order)")
    p.add_argument("--max-seconds", type=float, help="play at most this many seconds of each run (a wiring check)")
    p.add_argument("--out", default=str(Path(__file__).resolve().parent / "logs"), help="log folder (default: logs "
                                                                                        "beside this script)")
    args = p.parse_args(argv)
    folder = Path(__file__).resolve().parent
    run_plan(args, load_plan(folder), folder)
    return 0


if __name__ == "__main__":
    sys.exit(main())
