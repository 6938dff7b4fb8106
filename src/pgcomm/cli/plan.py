"""``pgcomm plan``: the experiments a rig runs for one round (references, drive settings, plan.md)."""

from __future__ import annotations

import shlex
from pathlib import Path

from pgcomm.cli._common import add_common_options

HELP = ("The experiments a rig runs for one round of calibration and for identification: reference files its "
        "controller plays back, the drive settings, and plan.md (what to run, what to log, what next).")


def configure(p) -> None:
    """Options of ``pgcomm plan``."""
    add_common_options(p)
    p.add_argument("--no-force-sensor", action="store_true",
                   help="the rig has no force sensor (the motor TOML must give the moving mass)")


def _commands(args, out: Path, force_sensor: bool) -> dict[str, str]:
    """The commands that take this plan's logs back (paths as the user gave them)."""
    plan_dir = shlex.quote(str(args.out))
    motor = f"{plan_dir}/motor.toml"
    extra = "" if force_sensor else " --no-force-sensor"
    cfg = f" --config {shlex.quote(str(args.config))}" if args.config else ""
    return {"check": f"pgcomm check --data '<logs>/*.csv' --motor {motor}",
            "calibrate": f"pgcomm calibrate --data '<logs>/*.csv' --motor {motor}{cfg}{extra} --out <calibration>",
            "identify": f"pgcomm identify --data '<logs>/*.csv' --motor {motor}{cfg}{extra} --out <model>"}


def plan_from_args(args):
    """The :class:`pgcomm.plan.Plan` of the options.

    ``--motor`` alone: a rig, the motor TOML's k̂, ζ̂ (this round's) and travel. Otherwise the
    twin or ``--plant`` (a simulated rig): its motor at the settings' initial ``k0``, ``ζ0``,
    the travel its reference spans.
    """
    from dataclasses import replace

    from pgcomm.settings import ExperimentConfig, load_experiment
    from pgcomm.plan import make_plan, reference_settings

    force_sensor = not args.no_force_sensor
    if args.motor is not None and args.plant is None:
        from pgcomm.io.config import load_motor

        config = load_experiment(args.config) if args.config else ExperimentConfig()
        motor = load_motor(args.motor)
        settings = reference_settings(config.reference, motor)
    else:
        from pgcomm.cli._common import setup_from_args

        setup = setup_from_args(args)
        config = setup.config
        # the span of the set-up's resolved reference: the next round's plan spans the same
        motor = replace(setup.motor, travel=tuple(float(x) for x in config.reference.span))
        settings = reference_settings(config.reference, motor)
    return make_plan(motor, settings, delta=config.calibration.delta, force_sensor=force_sensor)


def run(args, out: Path, progress) -> None:
    """Write the plan folder (:mod:`pgcomm.io.plan`)."""
    from pgcomm.io.plan import write_plan

    plan = plan_from_args(args)
    write_plan(out, plan, _commands(args, out, plan.force_sensor))
    if not args.quiet:
        n = len(plan.experiments)
        print(f"{n} experiments of {plan.duration:.1f} s ({n * plan.duration / 60:.1f} min of motion) at "
              + ", ".join(f"k̂{l + 1} = {k:.4g} N/A, ζ̂{l + 1} = {z:.4g} rad"
                          for l, (k, z) in enumerate(zip(plan.motor.k, plan.motor.zeta))))
        print(f"wrote {args.out}/plan.md (read it first), plan.json, motor.toml, references/*.csv")
