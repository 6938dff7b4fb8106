"""``pgcomm plan``: the experiments a rig runs for one round (references, drive settings, plan.md).

A rotary motor (``kind = "rotary"``): the speed-loop runs that determine its maps (:mod:`pgcomm.rotary.plan`),
written for ``--drive moteus|odrive|generic`` (:mod:`pgcomm.io.rotary_plan`); with ``--data``, the first round's logs
size the next round."""

from __future__ import annotations

import shlex
import tomllib
from dataclasses import replace
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_data_options, motor_is_rotary, setup_from_args
from pgcomm.errors import ConfigError
from pgcomm.io.config import load_experiment, load_motor, load_rotary_motor
from pgcomm.io.logs import ROTARY_REQUIRED, column_mapping, load_column_mapping, read_logs, with_encoder_counts

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("The experiments a rig runs for one round of calibration and for identification: reference files its "
        "controller plays back, the drive settings, and plan.md (what to run, what to log, what next). A rotary "
        "--motor: the speed-loop runs that determine its maps, with a script for --drive.")


def configure(p) -> None:
    """Options of ``pgcomm plan``."""
    add_common_options(p)
    add_data_options(p)
    p.add_argument("--no-force-sensor", action="store_true",
                   help="the rig has no force sensor (the motor TOML must give the moving mass)")
    p.add_argument("--drive", choices=("moteus", "odrive", "generic"),
                   help="rotary motors: the drive the plan is written for: a script with its Python package (moteus, "
                        "odrive 0.5.x) or reference CSVs only (generic)")
    p.add_argument("--swing", type=float,
                   help="rotary motors: the dither's largest speed swing as a share of each run's speed, 0 < swing < 1 "
                        "(default 0.8): larger carries more current for the ripple, closer to stopping the rotor")


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
    from pgcomm.settings import ExperimentConfig
    from pgcomm.plan import make_plan, reference_settings

    force_sensor = not args.no_force_sensor
    if args.motor is not None and args.plant is None:
        config = load_experiment(args.config) if args.config else ExperimentConfig()
        motor = load_motor(args.motor)
        settings = reference_settings(config.reference, motor)
    else:
        setup = setup_from_args(args)
        config = setup.config
        # the span of the set-up's resolved reference: the next round's plan spans the same
        motor = replace(setup.motor, travel=tuple(float(x) for x in config.reference.span))
        settings = reference_settings(config.reference, motor)
    return make_plan(motor, settings, delta=config.calibration.delta, force_sensor=force_sensor)


def _rotary_commands(args, drive: str, runs: bool) -> dict[str, str]:
    """The commands that take a rotary plan's logs back (paths as the user gave them); without ``runs``, the first
    round's logs alone."""
    plan_dir = shlex.quote(str(args.out))
    cols = f" --columns {plan_dir}/columns.toml"
    data = f"'{plan_dir}/logs/*.csv'" if drive != "generic" else "'<logs>/*.csv'"
    note = {}
    if args.data and not runs:
        data = " ".join(shlex.quote(d) for d in args.data)
        cols = f" --columns {shlex.quote(str(args.columns))}" if args.columns else ""
    elif args.data and _same_map(args, drive):
        # a next round is identified together with the logs before it (one column map per identify)
        data = " ".join([*(shlex.quote(d) for d in args.data), data])
    elif args.data:
        note = {"note": f"The first round's logs were read with another column map ({args.columns or 'none'}) than "
                        "this plan's columns.toml; `pgcomm identify` takes one map per call, so these commands read "
                        "this round's logs. To identify both rounds together, give their files the same column names."}
    return {"identify": f"pgcomm identify --motor {plan_dir}/motor.toml --data {data}{cols} --out <model>",
            "plan": f"pgcomm plan --motor {plan_dir}/motor.toml --drive {drive} --data {data}{cols} --out <next plan>",
            **note}


def _same_map(args, drive: str) -> bool:
    """Whether ``--columns`` (none: the log format's own names in SI) reads the first round's logs as the plan's
    ``columns.toml`` reads its script's."""
    from pgcomm.io.rotary_plan import columns_toml

    ours = column_mapping(tomllib.loads(columns_toml(drive)))
    if args.columns is None:
        return all(name == col and ours.factor(name) == 1.0 for name, col in ours.columns.items())
    given = load_column_mapping(args.columns)
    return given.columns == ours.columns and given.units == ours.units


def _run_rotary(args, out: Path, progress) -> None:
    """``pgcomm plan --motor rotary.toml --drive D [--data LOG...]`` (:mod:`pgcomm.rotary.plan`)."""
    from pgcomm.io.rotary_plan import write_rotary_plan
    from pgcomm.rotary.plan import first_plan, refined_plan

    for opt in ("plant", "config", "truth"):
        if getattr(args, opt, None):
            raise ConfigError(f"--{opt}: not used with a rotary motor (--motor {args.motor} has kind = \"rotary\")")
    if args.no_force_sensor:
        raise ConfigError(f"--no-force-sensor: a rotary plan never uses a force sensor (--motor {args.motor})")
    if args.drive is None:
        raise ConfigError(f"--drive: a rotary motor's plan is written for its drive: --drive moteus, odrive or generic "
                          f"(--motor {args.motor})")
    if args.columns and not args.data:
        raise ConfigError("--columns: maps the columns of --data; give the first round's logs with --data")
    settings = _rotary_settings(args)
    motor = load_rotary_motor(args.motor)
    if args.data:
        from pgcomm.rotary.plan import logs_as_data, read_first_round

        with progress.stage(f"read {len(args.data)} log pattern(s) of the first round"):
            mapping = with_encoder_counts(load_column_mapping(args.columns) if args.columns else None, motor)
            logs = read_logs(args.data, sample_time=args.sample_time, columns=mapping, required=ROTARY_REQUIRED,
                             gaps=True, stamps=True)
            data = logs_as_data(logs)
        with progress.stage("identification of the first round: the maps' standard errors"):
            first = read_first_round(data, motor)
        plan = refined_plan(motor, first, settings)
    else:
        plan = first_plan(motor, settings)
    write_rotary_plan(out, plan, args.drive, _rotary_commands(args, args.drive, bool(plan.runs)))
    if not args.quiet:
        if plan.runs:
            print(f"{len(plan.runs)} runs, {plan.duration / 60:.1f} min of motion, speeds up to "
                  f"{max(abs(r.speed) for r in plan.runs):.4g} rad/s (alias guard {plan.speed_limit:.4g} rad/s)")
        else:
            print("the first round's logs resolve every map more logs can resolve: nothing more to run")
        script = f", run_{args.drive}.py" if plan.runs and args.drive != "generic" else ""
        print(f"wrote {args.out}/plan.md (read it first), plan.json, motor.toml"
              + (", columns.toml, references/*.csv" if plan.runs else "") + script)


def _rotary_settings(args):
    """:class:`pgcomm.rotary.plan.RotaryPlanSettings` of the options (``--swing``)."""
    from pgcomm.rotary.plan import RotaryPlanSettings

    if args.swing is None:
        return RotaryPlanSettings()
    if not 0.0 < args.swing < 1.0:
        raise ConfigError(f"--swing {args.swing:g}: expected a share between 0 and 1 (exclusive): at 1 the dither "
                          "could stop the rotor")
    return RotaryPlanSettings(swing=float(args.swing))


def run(args, out: Path, progress) -> None:
    """Write the plan folder (:mod:`pgcomm.io.plan`, :mod:`pgcomm.io.rotary_plan` for a rotary motor)."""
    from pgcomm.io.plan import write_plan

    if motor_is_rotary(args):
        return _run_rotary(args, out, progress)
    for opt in ("drive", "swing", "data", "columns", "sample_time"):
        if getattr(args, opt, None) is not None:
            raise ConfigError(f"--{opt.replace('_', '-')}: only for a rotary motor's plan (a --motor with kind = "
                              "\"rotary\")")
    plan = plan_from_args(args)
    write_plan(out, plan, _commands(args, out, plan.force_sensor))
    if not args.quiet:
        n = len(plan.experiments)
        print(f"{n} experiments of {plan.duration:.1f} s ({n * plan.duration / 60:.1f} min of motion) at "
              + ", ".join(f"k̂{l + 1} = {k:.4g} N/A, ζ̂{l + 1} = {z:.4g} rad"
                          for l, (k, z) in enumerate(zip(plan.motor.k, plan.motor.zeta))))
        print(f"wrote {args.out}/plan.md (read it first), plan.json, motor.toml, references/*.csv")
