"""``pgcomm identify``: Algorithm 2 on data sets generated on the plant, or on logs (``--data``).

With ``--no-force-sensor`` (automatic when the logs have no force columns) the y row of every
coil set's PGNN is identified from the motion, jointly with the translator's friction
(:mod:`pgcomm.sensorless`); the x and z rows are the classical model with the motor's nominal
``k̂``, ``ζ̂``, ``μ̂`` and lever arms. The moving mass comes from the motor TOML (key ``mass``);
where the data are simulated (no ``--data``) the simulated translator's mass is known and used
when the motor TOML has none (said).

A rotary motor (``--motor`` with ``kind = "rotary"``) is identified from its drive's running logs
(``--data``: ``t``, ``theta``, ``iq_1`` through the column mapping; a ``torque`` column in every log
means a torque sensor) by :func:`pgcomm.rotary.identify.identify`: cogging, torque-constant ripple and
the direction-dependent torque over the revolution, in current units, with each map's standard error
and whether the logs resolve it. It writes ``model.json``, ``compensation.csv`` (the table
``pgcomm export --format moteus|odrive|c-angle`` reads, with the motor's current limit),
``results.json``, ``identify_rotary.png`` and ``report.html``.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from pgcomm.cli._common import ROTARY_READING, add_common_options, add_data_options, add_rotary_reading_options, \
    motor_is_rotary, read_data_logs, refuse_conflicts, settings_given, setup_from_args
from pgcomm.errors import ConfigError, DataError
from pgcomm.io.config import load_experiment, load_motor
from pgcomm.io.results import write_results

# Imports inside the functions below: JAX, SciPy and Matplotlib (and a rotary motor's pipeline) load only when
# the command runs; `import pgcomm.cli` loads none of them (`--help` and a bad option answer at once).

HELP = ("Algorithm 2: identify the PGNN (and the physics-only model) of every coil set; "
        "writes model.json/.npz, results.json and figures.")


#: ``[identification]`` settings only the PGNN family reads (``--family spline`` refuses them).
PGNN_ONLY = tuple(f"identification.{k}" for k in (
    "gain_widths", "cog_widths", "gain_width_candidates", "activation", "regularisation", "starts", "max_iterations",
    "screen_iterations", "validation_fraction", "ridge_output", "tol", "decrease_tol", "direction_harmonics"))


def configure(p) -> None:
    """Options of ``pgcomm identify``."""
    add_common_options(p)
    add_data_options(p)
    p.add_argument("--force", action="store_true", help="identify even if the excitation check fails (warn only)")
    p.add_argument("--family", choices=("pgnn", "spline"), default="pgnn",
                   help="model family: pgnn (the paper's, default) or spline (the fundamental's coefficients, "
                        "cogging and direction force tabulated along the stroke, knots by cross-validation; the "
                        "file also carries the mass, viscous friction and Coulomb table for the feedforward)")
    p.add_argument("--sweep", nargs="+", action="extend", metavar="LOG",
                   help="rotary motors: a logged slow position sweep in both directions (t, theta, iq_1), the "
                        "drives' own calibration: its table is computed, compared with the identified model's "
                        "against both noises, and written as standstill_table.csv; or the drive's own static map "
                        "(columns angle in rad or count in encoder counts, and the holding current): compared with the "
                        "identified table, an index offset between the two power-ups found and removed")
    add_rotary_reading_options(p)
    p.add_argument("--no-force-sensor", action="store_true",
                   help="identify without force measurements: the y row from the motion (m ÿ + friction, the "
                        "moving mass from the motor TOML key mass), x/z rows classical with the motor's nominal "
                        "k, zeta; automatic when the logs have no Fy, Fx, Tz. Without --data the generated data "
                        "lose their force columns")


def run(args, out: Path, progress) -> None:
    """Identify (:func:`pgcomm.identification.identify_coil_sets`); write ``model.json/.npz``, ``results.json``,
    ``cogging.png`` and ``gain_coilset{l}.png``."""
    from pgcomm import __version__, experiment
    from pgcomm.data import coil_set_data_from_logs, coil_set_data_from_runs
    from pgcomm.identification import CoilSetsOptions, identify_coil_sets
    from pgcomm.io.model import save_model
    from pgcomm.setup import sensorless_mass, simulated_mass

    t0 = time.perf_counter()
    if motor_is_rotary(args):
        from pgcomm.cli._identify_rotary import run_rotary

        run_rotary(args, out, progress, t0)
        return
    if args.sweep:
        raise ConfigError("--sweep: the drives' standstill sweep is a rotary motor's comparison (--motor with "
                          "kind = \"rotary\"); a linear motor's cogging table comes from pgcomm reproduce")
    for opt in ROTARY_READING:
        if getattr(args, opt, None) is not None:
            raise ConfigError(f"--{opt.replace('_', '-')}: how a rotary drive's log is read (--motor with kind = "
                              "\"rotary\")")
    if args.family == "spline" and args.config:
        refuse_conflicts("--family spline", settings_given(args.config, PGNN_ONLY),
                         "ignores (a setting of the PGNN's Algorithm 2; the spline model reads [identification] "
                         "direction_velocity only)")
    setup = _setup(args)
    sensorless = bool(args.no_force_sensor)
    _refuse_spline_without_force(args, sensorless)
    logs = None
    if args.data:
        with progress.stage(f"read {len(args.data)} log pattern(s)"):
            logs = read_data_logs(args, progress)
            progress.info(f"{len(logs)} log(s), {sum(lg.n_samples for lg in logs)} samples")
        without = [lg.source for lg in logs if not lg.has_force]
        if without and not sensorless:
            if len(without) < len(logs):
                shown = ", ".join(without[:3]) + (", ..." if len(without) > 3 else "")
                raise DataError(f"{len(without)} of {len(logs)} logs have no force columns Fy, Fx, Tz ({shown}); "
                                "pass --no-force-sensor to identify all of them from the motion, or drop them")
            sensorless = True
            _refuse_spline_without_force(args, sensorless)
            if not args.quiet:
                print("pgcomm: the logs have no force columns (Fy, Fx, Tz): identifying without a force sensor "
                      "(y row from the motion, x/z rows classical)", file=sys.stderr)
    mass_source = None
    if sensorless and logs is None:
        # the data are simulated: the simulated translator's mass is known (used, and said, if the motor has none)
        setup, mass_source = simulated_mass(setup)
        if not args.quiet:
            print(f"pgcomm: moving mass for identification without a force sensor: {mass_source}", file=sys.stderr)
    mass = sensorless_mass(setup, args.motor) if sensorless else None
    if logs is not None:
        with progress.stage("group logs by coil set"):
            data = coil_set_data_from_logs(logs, setup.motor, force=not sensorless)
        source = "logs"
        sample_time = _common_sample_time(logs) if sensorless else None
    else:
        ref = experiment.data_generation_reference(setup)
        with progress.stage(f"data generation on {setup.plant_name}: {setup.motor.n_coil_sets} coil sets x 2 data "
                            f"sets, {len(ref.r)} samples each"):
            data = coil_set_data_from_runs(experiment.generate(setup, ref, setup.motor.k, setup.motor.zeta,
                                                               seed=args.seed))
        if sensorless:  # what a rig without a force sensor records: the force columns are dropped
            data = [dataclasses.replace(d, force=np.zeros_like(d.force)) for d in data]
        source = setup.plant_name
        sample_time = setup.motor.sample_time
    if sensorless:
        # the drive's motor with the mass and the data's sample time (the acceleration scales with its square)
        setup = dataclasses.replace(setup, motor=dataclasses.replace(setup.motor, mass=mass, sample_time=sample_time))
    found = identify_coil_sets(setup, data, CoilSetsOptions(args.family, not sensorless, args.force), seed=args.seed,
                               progress=progress)
    results = {"command": "identify", **({"family": "spline"} if found.family == "spline" else {}),
               "plant": setup.plant_name, "data": source, "version": __version__, "seed": args.seed,
               "force_sensor": not sensorless, **found.to_dict()}
    metadata = {"seed": args.seed, "plant": setup.plant_name, "data": source, "fy_abs_max": found.fy_abs_max,
                "force_sensor": not sensorless, **law_metadata(args, setup),
                "identification": results["identification"]}
    if found.family == "spline":
        save_model(out / "model", found.model, metadata, mechanics=found.mechanics)
    else:
        if sensorless:
            metadata.update(mechanics=found.mechanics, feedforward=found.feedforward)
            results["mass_source"] = mass_source or (f"{mass:g} kg from --motor {args.motor}" if args.motor else
                                                     f"{mass:g} kg of the built-in twin's translator (no --motor)")
        save_model(out / "model", found.model, metadata,
                   identification="force_sensor" if not sensorless else "no_force_sensor")
    known = setup.plant is not None and (source != "logs" or args.plant is None)
    label = "spline model" if found.family == "spline" else "PGNN"
    title = ("identified cogging force (spline model)" if found.family == "spline" else
             "identified cogging force (x, z: not observable without a force sensor)" if sensorless else
             "identified cogging force")
    _figures(out, found.model, setup.plant if known else None, title, label)
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
        (_print_spline if found.family == "spline" else _print_pgnn)(found)
        print(f"wrote {args.out}/model.json, model.npz, results.json, cogging.png, gain_coilset*.png")


def _figures(out: Path, model, plant, title: str, label: str) -> None:
    """``cogging.png`` and ``gain_coilset{l}.png`` of ``model`` over its training range, with ``plant``'s truth
    where known (``None``: not drawn)."""
    import jax.numpy as jnp

    from pgcomm import plots

    y = np.linspace(*model.training_range, 2001)
    truth = None if plant is None else np.asarray(plant.cogging(jnp.asarray(y)))
    plots.save(plots.plot_cogging(y, np.asarray(model.cogging(jnp.asarray(y))), truth, title=title, label=label),
               out / "cogging.png")
    gm = np.asarray(model.gain(jnp.asarray(y)))
    gt = None if plant is None else np.asarray(plant.gain(jnp.asarray(y)))
    for l in range(model.n_coil_sets):
        plots.save(plots.plot_gain_columns(y, gm[:, l], None if gt is None else gt[:, l], l, label=label),
                   out / f"gain_coilset{l + 1}.png")


def _print_pgnn(found) -> None:
    """The PGNN's costs per coil set (and, without a force sensor, the feedforward) on standard output."""
    if not found.force_sensor:
        print("without a force sensor: costs of the y row on filtered windows, (m ÿ - F^y - friction)^2 [N^2]")
    print(f"{'coil set':24s} {'V physics':>10s} {'V PGNN':>10s} {'V phys val':>10s} {'V PGNN val':>10s} {'time':>6s}")
    print(f"{'':24s} {'[N^2]':>10s} {'[N^2]':>10s} {'[N^2]':>10s} {'[N^2]':>10s} {'[s]':>6s}")
    for r in found.results:
        print(f"{r.name[:24]:24s} {r.cost_physics:10.4g} {r.cost_pgnn:10.4g} {r.cost_physics_validation:10.4g} "
              f"{r.cost_pgnn_validation:10.4g} {r.seconds:6.1f}")
    for text in filter(None, (r.convergence_text() for r in found.results)):
        print("warning: " + text)
    if not found.force_sensor:
        print(format_feedforward(found.feedforward))


def _print_spline(found) -> None:
    """The spline model's knots, costs per coil set and feedforward on standard output."""
    fit, mech = found.spline, found.mechanics
    sp = fit.spacing
    print(f"spline model: knots every {1e3 * sp['gain']:.3g} mm (gain), {1e3 * sp['cogging']:.3g} mm (cogging), "
          f"{1e3 * sp['direction']:.3g} mm (direction), {fit.model.n_parameters} coefficients")
    print(f"{'coil set':10s} {'MSE y':>10s} {'x':>10s} {'z':>10s} {'CV y':>10s} {'x':>10s} {'z':>10s}")
    print(f"{'':10s} {'[N^2]':>10s} {'[N^2]':>10s} {'[N^2m^2]':>10s} {'[N^2]':>10s} {'[N^2]':>10s} {'[N^2m^2]':>10s}")
    for l, (c, v) in enumerate(zip(fit.cost, fit.cost_validation)):
        print(f"{l + 1:<10d} " + " ".join(f"{c[d]:10.4g}" for d in "yxz") + " "
              + " ".join(f"{v[d]:10.4g}" for d in "yxz"))
    print(f"feedforward: m = {mech.mass:.4g} kg, f_v = {mech.viscous:.4g} N s/m, Coulomb "
          f"{float(np.min(mech.coulomb)):.3g} .. {float(np.max(mech.coulomb)):.3g} N along the stroke "
          f"(in the model file)")


def _refuse_spline_without_force(args, sensorless: bool) -> None:
    """``--family spline`` fits the measured force: refuse it without a force sensor before any work."""
    if sensorless and args.family == "spline":
        raise DataError("--family spline needs force measurements (Fy, Fx, Tz); without a force sensor use "
                        "--family pgnn")


def _setup(args):
    """The set-up; logs with ``--motor`` but no ``--plant`` are a rig's: its motor description, no plant."""
    if args.data and args.motor is not None and args.plant is None:
        from pgcomm.settings import ExperimentConfig
        from pgcomm.setup import Setup

        motor = load_motor(args.motor)
        config = load_experiment(args.config) if args.config else ExperimentConfig()
        return Setup(plant=None, motor=motor, config=config, true_k=None, true_zeta=None, plant_name=str(args.motor))
    return setup_from_args(args)


def law_metadata(args, setup) -> dict:
    """What every export of the model needs from the motor: ``current_limit`` (A) and, with ``--motor``, ``drive``.

    The limit is the motor description's ``current_limit`` (the twin's own limit without ``--motor``;
    ``None`` when the description has none: ``pgcomm export`` then asks for ``--current-limit``). With a
    motor description its ``[nominal]`` ``k``, ``zeta`` are the commutation the drive ran while the data
    were recorded (on a rig, the last calibration round's values): the default drive of the exported
    anti-cogging table (:func:`pgcomm.io.model.drive_metadata`).
    """
    from pgcomm.io.model import drive_metadata

    meta = {"current_limit": setup.motor.current_limit}
    if getattr(args, "motor", None) is not None:
        meta["drive"] = drive_metadata(setup.motor.k, setup.motor.zeta,
                                       f"{args.motor} [nominal]: the drive's commutation while the data were recorded")
    return meta


def _common_sample_time(logs) -> float:
    """The one sample time (s) of all logs (the acceleration scales with its square)."""
    ts = logs[0].sample_time
    for lg in logs[1:]:
        if abs(lg.sample_time - ts) > 1e-6 * ts:
            raise DataError(f"{lg.source}: sample time {lg.sample_time:g} s differs from {ts:g} s of {logs[0].source}; "
                            "identification without a force sensor needs one sample time")
    return float(ts)


def format_feedforward(ff: dict) -> str:
    """One line: the identified mechanics as the feedforward's parameters."""
    return (f"feedforward: m = {ff['mass']:.4g} kg, f_v = {ff['viscous']:.4g} N s/m, f_c = {ff['coulomb']:.4g} N "
            "(identified with the y row; offered as the feedforward's parameters)")
