"""The rotary plan on the twin: do a first round's runs determine the maps, and what does the dither's swing buy?

Usage: ``python bench/rotary_plan.py [--motors 0:0,0:4] [--swings 0.5,0.8] [--refine] [--real-drive]``. Each motor
is zoo motor ``seed:index`` (:func:`pgcomm.rotary.zoo.draw_rotary`; ``--real-drive``: with a real drive's and host's
habits, the host's jittered time stamps among them), described to the plan as its user knows it (the zoo's motor
TOML plus the true ``inertia`` and ``k_t``, so the first round carries a dither). Per swing, the first round of
:func:`pgcomm.rotary.plan.first_plan` runs on the twin in the drive's speed loop (the classical law and the gains of
``pgcomm reproduce``), and the identification's standard errors, as ``SE · sqrt(T)`` (the share of the map's RMS
times the root of the log time: the number that stays put as the logs grow), are printed beside the errors against
the twin's truth and the log time each map asks for. The row ``reproduce`` runs ``pgcomm reproduce``'s running
references (:func:`pgcomm.rotary.experiment.running_references`: two speeds, swing 0.8) for about the same time.
With ``--refine`` the plan's next round (:func:`pgcomm.rotary.plan.refined_plan`) is recorded too and the maps are
identified from both rounds. Minutes per motor and swing: the twin's time is about the logs' own, and the
identification of a minute of logs takes about as long.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")


def _record(truth, refs, law, gains, seed, tag):
    """The twin's logs of ``refs`` (speed-loop :class:`Reference` s), written as CSV and read back as ``pgcomm plan
    --data`` reads them (the host's stamps as recorded, split at gaps)."""
    import tempfile
    from pathlib import Path

    from pgcomm.io.logs import ROTARY_REQUIRED, Log, read_logs, write_log
    from pgcomm.rotary.experiment import running_log
    from pgcomm.rotary.plan import logs_as_data
    from pgcomm.seeds import stream_seed

    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        for i, ref in enumerate(refs):
            lg = running_log(truth, ref, law, gains, stream_seed(seed, "rotary plan bench", tag, i))
            paths.append(str(Path(tmp) / f"run{i}.csv"))
            write_log(paths[-1], Log({k: lg[k] for k in ("t", "theta", "iq_1", "id_1")}, truth.motor.sample_time))
        return logs_as_data(read_logs(paths, required=ROTARY_REQUIRED, gaps=True, stamps=True))


def _references(plan):
    import numpy as np

    from pgcomm.rotary.twin import Reference

    ts, refs = plan.sample_time, []
    for r in plan.runs:
        ref = r.reference(ts)
        refs.append(Reference(np.cumsum(ref["speed"]) * ts, ref["speed"], np.gradient(ref["speed"], ts), "speed",
                              ref["dither"]))
    return refs


def _row(name, label, data, motor, truth, t0):
    from pgcomm.rotary.experiment import identification_errors
    from pgcomm.rotary.identify import identify

    import numpy as np

    seconds = sum(float(d["t"][-1] - d["t"][0] + np.median(np.diff(d["t"]))) for d in data)
    res = identify(data, motor)
    se, err = res.standard_error, identification_errors(res.model, truth)
    cells = " ".join(f"{se[m]['relative'] * math.sqrt(seconds):7.3f}" for m in ("cogging", "ripple", "direction"))
    need = " ".join(f"{se[m]['log_time_factor_to_resolve'] * seconds:8.0f}" for m in ("cogging", "ripple"))
    print(f"{name:11s} {label:14s} {seconds:7.1f} {cells} {100 * err['cogging_rel']:7.2f} "
          f"{100 * err['ripple_rel']:7.2f} {need} {time.perf_counter() - t0:6.0f}", flush=True)
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motors", default="0:0,0:4", help="zoo motors as seed:index, comma-separated")
    ap.add_argument("--swings", default="0.5,0.8", help="the dither's swings to compare, comma-separated")
    ap.add_argument("--refine", action="store_true", help="record the plan's next round too (at the last swing)")
    ap.add_argument("--real-drive", action="store_true",
                    help="the zoo motors with a real drive's and host's habits (pgcomm zoo --kind rotary --real-drive)")
    args = ap.parse_args(argv)
    from dataclasses import replace

    from pgcomm.rotary.experiment import _tuned_drive, running_references
    from pgcomm.settings import RotarySettings
    from pgcomm.rotary.plan import RotaryPlanSettings, first_plan, read_first_round, refined_plan
    from pgcomm.rotary.zoo import draw_rotary

    print(f"{'motor':11s} {'runs':14s} {'T s':>7s} {'SE*sqrt(T): cog':>15s} {'rip':>7s} {'dir':>7s} {'cog %':>7s} "
          f"{'rip %':>7s} {'asks: cog s':>8s} {'rip s':>8s} {'wall s':>6s}")
    for spec in args.motors.split(","):
        seed, index = (int(x) for x in spec.split(":"))
        truth = draw_rotary(seed, index, real_drive=args.real_drive)
        motor = replace(truth.motor, inertia=truth.inertia, k_t=round(truth.k_t, 4))
        name = f"{seed}:{index} {motor.name}"
        orders, a_nom, gains, law = _tuned_drive(truth)
        plan = None
        for swing in (float(s) for s in args.swings.split(",")):
            t0 = time.perf_counter()
            plan = first_plan(motor, RotaryPlanSettings(swing=swing))
            data = _record(truth, _references(plan), law, gains, seed, f"swing {swing}")
            _row(name, f"plan {swing:g}", data, motor, truth, t0)
        t0 = time.perf_counter()
        refs = running_references(motor, a_nom, RotarySettings(), orders)
        per = sum(r.n for r in refs) * motor.sample_time
        refs = refs * max(1, round(plan.duration / per))
        _row(name, "reproduce", _record(truth, refs, law, gains, seed, "reproduce"), motor, truth, t0)
        if args.refine:
            t0 = time.perf_counter()
            first = read_first_round(data, motor)
            nxt = refined_plan(motor, first, plan.settings)
            more = _record(truth, _references(nxt), law, gains, seed, "refined") if nxt.runs else []
            _row(name, f"+next {nxt.duration:.0f} s", data + more, motor, truth, t0)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
