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

import glob
import sys
import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_data_options, motor_is_rotary, read_data_logs, \
    refuse_conflicts, settings_given, setup_from_args
from pgcomm.errors import DataError

HELP = ("Algorithm 2: identify the PGNN (and the physics-only model) of every coil set; "
        "writes model.json/.npz, results.json and figures.")


#: ``[identification]`` settings only the PGNN family reads (``--family spline`` refuses them).
PGNN_ONLY = tuple(f"identification.{k}" for k in (
    "gain_widths", "cog_widths", "gain_width_candidates", "activation", "regularisation", "starts", "max_iterations",
    "validation_fraction", "ridge_output", "tol", "direction_harmonics"))


def configure(p) -> None:
    """Options of ``pgcomm identify``."""
    add_common_options(p)
    add_data_options(p)
    p.add_argument("--force", action="store_true", help="identify even if the excitation check fails (warn only)")
    p.add_argument("--family", choices=("pgnn", "spline"), default="pgnn",
                   help="model family: pgnn (the paper's, default) or spline (the fundamental's coefficients, "
                        "cogging and direction force tabulated along the stroke, knots by cross-validation; the "
                        "file also carries the mass, viscous friction and Coulomb table for the feedforward)")
    p.add_argument("--sweep", nargs="+", metavar="LOG",
                   help="rotary motors: a logged slow position sweep in both directions (t, theta, iq_1), the "
                        "drives' own calibration: its table is computed, compared with the identified model's "
                        "against both noises, and written as standstill_table.csv; or the drive's own static map "
                        "(columns angle in rad or count in encoder counts, and the holding current): compared with the "
                        "identified table, an index offset between the two power-ups found and removed")
    p.add_argument("--current-delay", metavar="N",
                   help="rotary motors: samples by which the logged q-current lags the current that acted over each "
                        "sample (an integer; default: detected, the fit repeated with the current shifted by -2..2)")
    p.add_argument("--current-lag", metavar="L|held",
                   help="rotary motors: how the logged q-current runs between samples: held (the drive controls at its "
                        "log rate) or L, the smooth curve through the samples L samples late (a drive that controls K "
                        "times per logged sample: 1/(2K), e.g. 0.0625 for an 8 kHz loop logged at 1 kHz); default: "
                        "detected")
    p.add_argument("--angle-pll", metavar="W[,ZETA]",
                   help="rotary motors: the logged angle is a drive's PLL estimate of natural frequency W rad/s "
                        "(damping ZETA, default 1; ODrive's encoder bandwidth), or 'none' for the encoder's own "
                        "angle (default: detected when no logged angle sits on an encoder's lattice)")
    p.add_argument("--current-noise", metavar="A|none",
                   help="rotary motors: the logged q-current's white noise (A, standard deviation) that the fit "
                        "corrects for, or 'none' (default: read from the logged d-current id_1 where every log has "
                        "it, else from the q-current's own less what the logged angle predicts of it)")
    p.add_argument("--current-filter", metavar="S|none",
                   help="rotary motors: the time constant (s) of the first-order filter through which the drive "
                        "reports the q-current, or 'none' (default: detected; a real ODrive's report lags by about "
                        "0.08 s)")
    p.add_argument("--time-lines", metavar="HZ[,HZ...]",
                   help="rotary motors: frequencies (Hz) of time-periodic disturbances to fit beside the maps (a "
                        "current sensor's mains pickup, a fan, a resonance), or 'none' (default: detected as lines at "
                        "one frequency in the residuals of logs at two speeds)")
    p.add_argument("--no-force-sensor", action="store_true",
                   help="identify without force measurements: the y row from the motion (m ÿ + friction, the "
                        "moving mass from the motor TOML key mass), x/z rows classical with the motor's nominal "
                        "k, zeta; automatic when the logs have no Fy, Fx, Tz. Without --data the generated data "
                        "lose their force columns")


def run(args, out: Path, progress) -> None:
    """Identify; write ``model.json/.npz``, ``results.json``, ``cogging.png`` and ``gain_coilset{l}.png``."""
    import dataclasses

    import jax.numpy as jnp
    import numpy as np

    from pgcomm import __version__, experiment, plots
    from pgcomm.setup import sensorless_mass, simulated_mass
    from pgcomm.data import coil_set_data_from_logs, coil_set_data_from_runs
    from pgcomm.errors import ExcitationError
    from pgcomm.excitation import check_excitation
    from pgcomm.io.model import save_model
    from pgcomm.io.results import write_results

    t0 = time.perf_counter()
    if motor_is_rotary(args):
        _identify_rotary(args, out, progress, t0)
        return
    if args.sweep:
        from pgcomm.errors import ConfigError

        raise ConfigError("--sweep: the drives' standstill sweep is a rotary motor's comparison (--motor with "
                          "kind = \"rotary\"); a linear motor's cogging table comes from pgcomm reproduce")
    for opt in ("current_delay", "current_lag", "angle_pll", "time_lines", "current_noise", "current_filter"):
        if getattr(args, opt, None) is not None:
            from pgcomm.errors import ConfigError

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
            logs = read_data_logs(args)
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
        # first: logs too short or slow, without acceleration or saturated get their own one-line message
        from pgcomm.sensorless import sensorless_data

        ic = setup.config.identification
        with progress.stage("filtered acceleration windows per coil set"):
            sl = [sensorless_data(d, sample_time, setup.motor.pole_pitch, mass,
                                  current_limit=setup.motor.current_limit, friction_velocity=ic.direction_velocity)
                  for d in data]
            progress.info(", ".join(f"{d.name.split(' (')[0]}: {d.n} windows of {d.filt.length} samples" for d in sl))
    problems = {d.name: check_excitation(d, setup.motor.pole_pitch) for d in data}  # positions and currents only
    bad = {k: v for k, v in problems.items() if v}
    if bad:
        msg = "; ".join(f"{k}: {', '.join(v)}" for k, v in bad.items())
        if not args.force:
            raise ExcitationError(f"data do not persistently excite the model ({msg}); use --force to identify anyway")
        progress.info(f"warning: {msg}")
    mechanics = feedforward = None
    if args.family == "spline":
        _identify_spline(args, out, progress, setup, data, source, t0)
        return
    if sensorless:
        with progress.stage("identification without a force sensor (y row and friction) per coil set"):
            t_id = time.perf_counter()
            # x/z rows: the classical model with the motor's nominal (calibrated) k, zeta
            pgnn, res = experiment.identify_sensorless_models(setup, data, setup.motor.k, setup.motor.zeta, args.seed,
                                                              progress, check_data=False)
            t_id = time.perf_counter() - t_id
        from pgcomm.identify.mechanics import combined_mechanics

        mechanics, feedforward = combined_mechanics(res)
        fy_abs_max = max(float(np.max(np.abs(np.asarray(r.model.force(jnp.asarray(d.y),
                                                                      jnp.asarray(d.currents)))[:, 0])))
                         for r, d in zip(res, data))
    else:
        with progress.stage("identification (Algorithm 2) per coil set"):
            t_id = time.perf_counter()
            # the check above already ran (and, with --force, only warned)
            pgnn, _, res = experiment.identify_models(setup, data, args.seed, progress, check_data=False)
            t_id = time.perf_counter() - t_id
        fy_abs_max = max(float(np.max(np.abs(d.force[:, 0]))) for d in data)
    results = {"command": "identify", "plant": setup.plant_name, "data": source, "version": __version__,
               "seed": args.seed, "force_sensor": not sensorless,
               "identification": experiment.identification_results(res, t_id)}
    metadata = {"seed": args.seed, "plant": setup.plant_name, "data": source, "fy_abs_max": fy_abs_max,
                "force_sensor": not sensorless, **law_metadata(args, setup)}
    if sensorless:
        results["mechanics"] = metadata["mechanics"] = mechanics
        results["feedforward"] = metadata["feedforward"] = feedforward
        results["mass_source"] = mass_source or (f"{mass:g} kg from --motor {args.motor}" if args.motor else
                                                 f"{mass:g} kg of the built-in twin's translator (no --motor)")
    metadata["identification"] = results["identification"]
    save_model(out / "model", pgnn, metadata, identification="force_sensor" if not sensorless else "no_force_sensor")
    y = np.linspace(*pgnn.training_range, 2001)
    known = setup.plant is not None and (source != "logs" or args.plant is None)
    truth_cog = np.asarray(setup.plant.cogging(jnp.asarray(y))) if known else None
    title = ("identified cogging force (x, z: not observable without a force sensor)" if sensorless
             else "identified cogging force")
    plots.save(plots.plot_cogging(y, np.asarray(pgnn.cogging(jnp.asarray(y))), truth_cog, title=title),
               out / "cogging.png")
    gm = np.asarray(pgnn.gain(jnp.asarray(y)))
    gt = np.asarray(setup.plant.gain(jnp.asarray(y))) if known else None
    for l in range(pgnn.n_coil_sets):
        plots.save(plots.plot_gain_columns(y, gm[:, l], None if gt is None else gt[:, l], l, label="PGNN"),
                   out / f"gain_coilset{l + 1}.png")
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
        if sensorless:
            print("without a force sensor: costs of the y row on filtered windows, (m ÿ - F^y - friction)^2 [N^2]")
        print(f"{'coil set':24s} {'V physics':>10s} {'V PGNN':>10s} {'V phys val':>10s} {'V PGNN val':>10s} {'time':>6s}")
        print(f"{'':24s} {'[N^2]':>10s} {'[N^2]':>10s} {'[N^2]':>10s} {'[N^2]':>10s} {'[s]':>6s}")
        for r in res:
            print(f"{r.name[:24]:24s} {r.cost_physics:10.4g} {r.cost_pgnn:10.4g} {r.cost_physics_validation:10.4g} "
                  f"{r.cost_pgnn_validation:10.4g} {r.seconds:6.1f}")
        if sensorless:
            print(format_feedforward(feedforward))
        print(f"wrote {args.out}/model.json, model.npz, results.json, cogging.png, gain_coilset*.png")


#: Entries of the compensation table ``identify`` writes for a rotary motor (ODrive's size; the exports resample).
ROTARY_TABLE_ENTRIES = 3600


def _reading_options(args):
    """``--current-delay``, ``--angle-pll`` and ``--current-lag`` as :func:`pgcomm.rotary.identify.identify` takes them
    (``"detect"`` when left out); one line naming the option on a bad value."""
    import math

    from pgcomm.errors import ConfigError

    delay = "detect"
    if args.current_delay is not None:
        try:
            delay = int(args.current_delay)
        except ValueError:
            raise ConfigError(f"--current-delay {args.current_delay}: an integer number of samples, e.g. 1") from None
    pll = "detect"
    if args.angle_pll is not None:
        if args.angle_pll.strip().lower() == "none":
            pll = None
        else:
            parts = args.angle_pll.split(",")
            try:
                w, z = float(parts[0]), float(parts[1]) if len(parts) > 1 else 1.0
            except ValueError:
                w = z = float("nan")
            if len(parts) > 2 or not (math.isfinite(w) and w > 0 and math.isfinite(z) and z > 0):
                raise ConfigError(f"--angle-pll {args.angle_pll}: a natural frequency in rad/s and optionally a "
                                  "damping, both positive (e.g. 1000 or 1000,0.707), or none")
            pll = (w, z)
    lag = "detect"
    if getattr(args, "current_lag", None) is not None:
        if args.current_lag.strip().lower() == "held":
            lag = None
        else:
            try:
                lag = float(args.current_lag)
            except ValueError:
                lag = float("nan")
            if not (math.isfinite(lag) and abs(lag) <= 0.5):
                raise ConfigError(f"--current-lag {args.current_lag}: held, or a lag in samples between -0.5 and 0.5 "
                                  "(1/(2K) for K control cycles per logged sample, e.g. 0.0625)")
    return delay, pll, lag


def _current_filter_option(args):
    """``--current-filter`` as :func:`pgcomm.rotary.identify.identify` takes it (``"detect"`` when left out, ``0.0``
    for none); one line naming the option on a bad value."""
    import math

    from pgcomm.errors import ConfigError

    text = getattr(args, "current_filter", None)
    if text is None:
        return "detect"
    if text.strip().lower() == "none":
        return 0.0
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and 0 <= value <= 10):
        raise ConfigError(f"--current-filter {text}: the report filter's time constant in s (0 to 10), or none")
    return value


def _current_noise_option(args):
    """``--current-noise`` as :func:`pgcomm.rotary.identify.identify` takes it (``"detect"`` when left out); one line
    naming the option on a bad value."""
    import math

    from pgcomm.errors import ConfigError

    text = getattr(args, "current_noise", None)
    if text is None:
        return "detect"
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value >= 0):
        raise ConfigError(f"--current-noise {text}: the logged current's noise in A (a standard deviation, >= 0), "
                          "or none")
    return value


def _time_lines_option(args):
    """``--time-lines`` as :func:`pgcomm.rotary.identify.identify` takes it (``"detect"`` when left out); one line
    naming the option on a bad value."""
    import math

    from pgcomm.errors import ConfigError

    text = getattr(args, "time_lines", None)
    if text is None:
        return "detect"
    if text.strip().lower() == "none":
        return ()
    try:
        hz = [float(x) for x in text.split(",")]
    except ValueError:
        hz = [float("nan")]
    if not all(math.isfinite(f) and f > 0 for f in hz):
        raise ConfigError(f"--time-lines {text}: frequencies in Hz, positive, comma-separated (e.g. 50 or 50,100), "
                          "or none")
    return tuple(hz)


def _identify_rotary(args, out: Path, progress, t0: float) -> None:
    """``pgcomm identify --motor rotary.toml --data LOG...`` (module docstring)."""
    import json
    from dataclasses import replace

    import numpy as np

    from pgcomm import __version__
    from pgcomm.errors import ConfigError
    from pgcomm.export.angle_table import make_table, write_angle_table
    from pgcomm.io.atomic import atomic_write_text
    from pgcomm.io.config import load_rotary_motor
    from pgcomm.io.logs import ROTARY_REQUIRED, load_column_mapping, read_logs, with_encoder_counts
    from pgcomm.io.results import write_results
    from pgcomm.rotary.identify import drive_text, fit_mechanics, identify, map_text, resolution_verdict
    from pgcomm.rotary.back_emf import offset_text, voltage_text
    from pgcomm.rotary.readings import delay_text, filter_text, lag_of, pll_text
    from pgcomm.rotary.regression import Orders
    from pgcomm.rotary.time_lines import lines_text

    for opt in ("plant", "config"):
        if getattr(args, opt, None):
            raise ConfigError(f"--{opt}: not used with a rotary motor (--motor {args.motor} has kind = \"rotary\")")
    if args.family != "pgnn":
        raise ConfigError(f"--family {args.family}: a rotary motor's model is a Fourier series on the circle; "
                          "leave --family out")
    if not args.data:
        raise ConfigError(f"--data: a rotary motor ({args.motor}) is identified from its drive's running logs "
                          "(t, theta, iq_1); the rotary twin writes some with pgcomm zoo --kind rotary --logs")
    motor = load_rotary_motor(args.motor)
    current_delay, angle_pll, current_lag = _reading_options(args)
    time_lines = _time_lines_option(args)
    current_noise = _current_noise_option(args)
    current_filter = _current_filter_option(args)
    with progress.stage(f"read {len(args.data)} log pattern(s)"):
        mapping = with_encoder_counts(load_column_mapping(args.columns) if args.columns else None, motor)
        logs = read_logs(args.data, sample_time=args.sample_time, columns=mapping, required=ROTARY_REQUIRED, gaps=True,
                         stamps=True)
        for lg in logs:
            if not lg.is_rotary:
                raise DataError(f"{lg.source}: a linear motor's log (it has 'y'), but --motor {args.motor} is rotary; "
                                "a rotary log has the mechanical angle 'theta' in place of 'y'")
            if "iq_1" not in lg.columns:
                raise DataError(f"{lg.source}: no q-axis current 'iq_1' (map the drive's q-current column to iq_1 "
                                "in --columns); rotary identification reads the current in the drive's frame")
        n_samples = sum(lg.n_samples for lg in logs)
        progress.info(f"{len(logs)} log(s), {n_samples} samples, {n_samples * logs[0].sample_time:.0f} s")
        for lg in logs:
            for note in lg.notes:
                progress.info(f"{lg.source}: {note}")
    torque_sensor = all("torque" in lg.columns for lg in logs) and not args.no_force_sensor
    # the q-voltage is read only when every log has it (pgcomm.rotary.back_emf)
    extra_columns = ("vq_1",) if all("vq_1" in lg.columns for lg in logs) and not torque_sensor else ()
    with_vq = sum("vq_1" in lg.columns for lg in logs)
    if 0 < with_vq < len(logs) and not torque_sensor:
        progress.info(f"q-voltage vq_1 in {with_vq} of {len(logs)} logs: not read (the back-EMF fit takes every log's "
                      "voltage or none)")
    # ... the d-voltage beside it, and the supply, for the inverter's voltage limit
    for name in ("vd_1", "vbus"):
        if extra_columns and all(name in lg.columns for lg in logs):
            extra_columns += (name,)
    # the d-current, held at zero, is the current's noise alone (and its command carries it into the d-voltage)
    if all("id_1" in lg.columns for lg in logs):
        extra_columns += ("id_1",)
    # a log with dropped samples is the stretches between them: no filter window may difference across a gap
    data = [{"name": lg.source if len(lg.gaps) == 0 else f"{lg.source} rows {a + 1}-{b}",
             **{k: lg.columns[k][a:b] for k in ("t", "theta", "iq_1", *extra_columns,
                                                *(("torque",) if torque_sensor else ()))}}
            for lg in logs for a, b in lg.segments()]
    slots_detected = None
    if motor.slots is None:
        from pgcomm.rotary.slots import count_slots

        with progress.stage(f"slot count from the logs (not in {args.motor}): every cogging order the logs carry"):
            q, slots_detected = count_slots(data, motor, current_delay=current_delay, angle_pll=angle_pll,
                                            current_lag=current_lag, time_lines=time_lines)
            motor = replace(motor, slots=q)
            others = [x for x in slots_detected["slots_with_that_fundamental"] if x != q]
            progress.info(f"cogging fundamental {slots_detected['cogging_fundamental']} per revolution (orders seen, "
                          f"strongest first: {', '.join(map(str, slots_detected['orders_seen'][:8]))}): slots = {q}, "
                          f"{motor.name}" + (f" (also {', '.join(map(str, others))} slots have that fundamental; "
                                             "set slots in the motor TOML if you know it)" if others else ""))
    orders = Orders.for_motor(motor)
    how = "with the torque sensor" if torque_sensor else "without a torque sensor (from the motion)"
    with progress.stage(f"identification {how}: cogging, ripple, direction map over the revolution"):
        res = identify(data, motor, orders, torque_sensor=torque_sensor, current_delay=current_delay,
                       angle_pll=angle_pll, time_lines=time_lines, current_lag=current_lag,
                       current_noise=current_noise, current_filter=current_filter)
        timing = res.info.get("current_delay") or {}
        estimate = res.info.get("angle_pll") or {}
        pll = (None if estimate.get("natural_frequency_rad_s") is None
               else (estimate["natural_frequency_rad_s"], estimate["damping"]))
        mech = None if torque_sensor else fit_mechanics(data, motor, orders, current_delay=timing.get("samples", 0),
                                                       angle_pll=pll, current_lag=lag_of(timing),
                                                       current_filter=(res.info.get("current_filter") or {}).get("tau_s", 0.0),
                                                       time_lines=(res.info.get("time_lines") or {}).get("hz", ()))
        for text in (filter_text(res.info.get("current_filter")), drive_text(res.info.get("drive_orders"),
                                                                             motor.pole_pairs),
                     pll_text(estimate), delay_text(timing), lines_text(res.info.get("time_lines")),
                     voltage_text(res.info.get("back_emf")), offset_text(res.info.get("back_emf"))):
            if text:
                progress.info(text)
        if (res.model.inertia_ratio or 0.0) < 0.0:
            progress.info(f"J/k0 = {res.model.inertia_ratio:.4g} A·s²/rad is negative: a positive q-current turns the "
                          "rotor against the logged angle's direction (the drive's sign convention); the maps and "
                          "tables are in the drive's own signs, as its compensation needs them")
        se = res.info.get("standard_error")
        quant = res.info.get("quantisation")
        if quant and quant["logs_on_lattice"]:
            from pgcomm.report.rotary import share_text

            progress.info(f"encoder: {quant['logs_on_lattice']} of {quant['logs']} logged angle(s) on a "
                          f"{'/'.join(map(str, quant['counts_per_revolution']))}-count lattice; its rounding noise "
                          f"({share_text(quant['noise_share'])} of the acceleration the maps do not explain) is taken "
                          "out of the normal equations, so that it does not pull J/k0 down"
                          + ("; capped: the logs hardly carry the rotor's acceleration above the encoder's noise, "
                             "log accelerations or a dither" if quant["correction_capped"] else ""))
        for name in ("cogging", "ripple", "direction") if se else ():
            e = se[name]
            progress.info(map_text(name, e))
    model = replace(res.model, info={**res.model.info, "motor": motor.name, "current_limit": motor.current_limit,
                                     "logs": [lg.source for lg in logs]})
    sweep = None
    static = []
    if args.sweep:
        from pgcomm.io.static_map import is_static_map, read_static_map
        from pgcomm.rotary.static_map import compare, text

        maps = [p for pat in args.sweep for p in sorted(glob.glob(pat)) or [pat] if is_static_map(p)]
        args.sweep = [p for p in args.sweep if p not in maps]
        # the maps' independent values: the cogging's highest order resolved, a sine and a cosine each
        independent = 2 * int(np.max(model.cogging.orders, initial=1))
        for path in maps:
            found = compare(read_static_map(path, motor.encoder_counts), model, independent)
            static.append(found)
            progress.info(text(found))
    if args.sweep:
        with progress.stage(f"the drives' table from the standstill sweep ({len(args.sweep)} log pattern(s))"):
            sweep, sweep_info = _sweep_table(args, mapping, model, res.info)
            progress.info(f"sweep table: {sweep.theta.size} bins, coverage {100 * sweep.coverage:.0f} %, noise "
                          f"{sweep_info['noise_A']:.3g} A; model minus sweep {sweep_info['rms_model_minus_sweep_A']:.3g}"
                          f" A RMS against {sweep_info['expected_rms_difference_A']:.3g} A from the two noises")
    n = ROTARY_TABLE_ENTRIES
    table = model.table(n)
    fwd_rev = model.table(n, +1) - model.table(n, -1)
    results = {"command": "identify", "kind": "rotary", "version": __version__, "motor": motor.to_dict(),
               "logs": [lg.source for lg in logs], "samples": n_samples, "torque_sensor": torque_sensor,
               "identification": res.info, "mechanics_fit": mech,
               **({"slots_detected": slots_detected} if slots_detected is not None else {}),
               "table": {"entries": n, "rms_A": float(np.sqrt(np.mean(table**2))),
                         "peak_A": float(np.max(np.abs(table))),
                         "forward_minus_reverse_rms_A": float(np.sqrt(np.mean(fwd_rev**2)))},
               "runtime_s": time.perf_counter() - t0}
    voltage = res.info.get("back_emf") or {}
    k_si, k_from = None, None
    if voltage.get("consistent"):
        # the back-EMF's torque constant is the one the drive's frame sees, k_t cos δ with the drive's electrical offset
        # off by δ (pgcomm.rotary.back_emf); a datasheet's k_t knows neither δ nor this motor's tolerance
        k_si, k_from = voltage["k0_amplitude_invariant"], "the logged q-voltage's back-EMF (amplitude-invariant)"
        if motor.k_t:
            voltage["ratio_to_motor_k_t"] = k_si / float(motor.k_t)
            if voltage.get("offset_error"):
                voltage["offset_error"]["ratio_to_motor_k_t"] = voltage["offset_error"]["k_t_aligned"] / float(motor.k_t)
    elif motor.k_t:
        k_si, k_from = float(motor.k_t), "the motor description's k_t"
    if k_si is not None:
        results["table"]["rms_Nm"] = results["table"]["rms_A"] * k_si
        results["table"]["torque_constant_from"] = k_from
        results["in_SI"] = _in_si(model, k_si, k_from)
    written = ["model.json", "compensation.csv", "results.json", "identify_rotary.png", "report.html"]
    if static:
        results["static_maps"] = static
    if sweep is not None:
        results["standstill_sweep"] = sweep_info
        if sweep_info["table_written"]:
            written.insert(2, "standstill_table.csv")
    with progress.stage(", ".join(written)):
        atomic_write_text(out / "model.json", json.dumps(model.to_dict(), indent=1) + "\n")
        write_angle_table(out / "compensation.csv",
                          make_table(table, "model from running logs", current_limit=motor.current_limit),
                          comments=(f"pgcomm rotary model of {motor.name}, identified {how} from "
                                    f"{len(logs)} log(s); forward and reverse averaged",))
        if sweep is not None and sweep_info["table_written"]:
            write_angle_table(out / "standstill_table.csv",
                              make_table(sweep.table, "standstill sweep", current_limit=motor.current_limit),
                              comments=(f"the drives' table of {motor.name} from the logged sweep "
                                        f"{', '.join(sweep_info['logs'])}: forward and reverse bin averages, "
                                        "their mean",))
        write_results(out / "results.json", results)
        _plot_rotary(out / "identify_rotary.png", model, res.info, motor, sweep=sweep)
        from pgcomm.report.rotary import write_rotary_report

        write_rotary_report(out / "report.html", results, {
            "The identified maps over one revolution with their standard error as a band: the compensating q "
            "current (cogging and direction term, forward and reverse and their mean, the table that is "
            "exported), the torque-constant ripple, and the direction-dependent torque.":
                out / "identify_rotary.png"}, version=__version__)
    if not args.quiet:
        refused = res.info.get("windows_refused_alias")
        print(f"rotary {motor.name}: identified {how} from {len(logs)} log(s)"
              + (f"; {refused} windows refused as too fast for the encoder-sampled cogging" if refused else ""))
        nm = results["table"].get("rms_Nm")
        print(f"compensation table: {results['table']['rms_A']:.3g} A RMS, {results['table']['peak_A']:.3g} A peak "
              f"({n} entries)" + (f"; {nm:.3g} N·m RMS with {results['table']['torque_constant_from']}" if nm else ""))
        si = results.get("in_SI")
        if si and si["inertia_kg_m2"] is not None:
            ratio = voltage.get("ratio_to_motor_k_t")
            aligned = voltage.get("offset_error") if voltage.get("consistent") else None
            print(f"in SI (k0 = {si['torque_constant_Nm_per_A']:.4g} N·m/A"
                  + (f", {ratio:.3f}x the motor description's k_t" if ratio is not None else "")
                  + (f"; along the magnets' axis {aligned['k_t_aligned']:.4g} N·m/A"
                     + (f", {aligned['ratio_to_motor_k_t']:.3f}x" if "ratio_to_motor_k_t" in aligned else "")
                     if aligned else "")
                  + f"): moment of inertia {si['inertia_kg_m2']:.4g} kg·m², Coulomb friction {si['coulomb_Nm']:.3g} "
                  f"N·m, viscous {si['viscous_Nm_s_per_rad']:.3g} N·m·s/rad")
        if sweep is not None:
            si = results["standstill_sweep"]
            print(f"standstill sweep: model minus sweep table {si['rms_model_minus_sweep_A']:.3g} A RMS, "
                  f"{si['rms_model_minus_sweep_A'] / si['expected_rms_difference_A']:.2f}x what the two noises give "
                  f"({'within' if si['within_noise'] else 'NOT within'} the noise); the sweep took "
                  f"{si['seconds']:.0f} s, the running logs {n_samples * logs[0].sample_time:.0f} s")
        print(f"wrote {args.out}/{', '.join(written)} ({time.perf_counter() - t0:.0f} s)")
        if (results.get("in_SI") or {}).get("inertia_kg_m2"):
            # reproduce builds the twin from the TOML, which needs the slot count (read here if it was not there)
            print("preview the law against the drive's table on this motor: "
                  + (f"add slots = {motor.slots} to {args.motor}, then " if slots_detected is not None else "")
                  + f"pgcomm reproduce --motor {args.motor} --truth {args.out}/model.json --quick --out preview")


def _sweep_table(args, mapping, model, info: dict):
    """The drives' table from ``--sweep`` logs and its agreement with ``model``'s table.

    Returns:
        ``(SweepTable, dict)``: the dict goes to ``results.json`` as ``standstill_sweep`` (module
        :mod:`pgcomm.rotary.experiment`'s agreement, with the model's standard error in place of the truth).
    """
    import numpy as np

    from pgcomm.io.logs import ROTARY_REQUIRED, read_logs
    from pgcomm.rotary.experiment import AGREEMENT_FACTOR
    from pgcomm.rotary.standstill import table_from_sweep

    logs = read_logs(args.sweep, sample_time=args.sample_time, columns=mapping, required=ROTARY_REQUIRED)
    for lg in logs:
        if not lg.is_rotary or "iq_1" not in lg.columns:
            raise DataError(f"{lg.source}: a sweep log needs 'theta' and 'iq_1' (map the drive's columns in --columns)")
    if len(logs) > 1:
        # one sweep recorded in pieces: one after the other, each piece's angle as logged
        theta = np.concatenate([lg.columns["theta"] for lg in logs])
        iq = np.concatenate([lg.columns["iq_1"] for lg in logs])
    else:
        theta, iq = logs[0].columns["theta"], logs[0].columns["iq_1"]
    try:
        sweep = table_from_sweep(theta, iq, logs[0].sample_time)
    except DataError as e:
        raise DataError(f"--sweep {', '.join(lg.source for lg in logs)}: {str(e).removeprefix('sweep log: ')}") from None
    ok = np.isfinite(sweep.table)
    mod = 0.5 * (model.iq_comp(sweep.theta, 1.0) + model.iq_comp(sweep.theta, -1.0))
    diff = float(np.sqrt(np.mean((mod[ok] - sweep.table[ok]) ** 2)))
    se = (info.get("standard_error") or {}).get("cogging", {}).get("rms_error", 0.0)
    expected = float(np.hypot(sweep.noise, se))
    fr = np.isfinite(sweep.forward) & np.isfinite(sweep.reverse)
    return sweep, {
        "logs": [lg.source for lg in logs], "points": int(sweep.theta.size), "coverage": sweep.coverage,
        "seconds": sweep.seconds, "noise_A": sweep.noise, "table_rms_A": float(np.sqrt(np.mean(sweep.table[ok] ** 2))),
        "rms_model_minus_sweep_A": diff, "model_standard_error_A": float(se),
        "expected_rms_difference_A": expected, "agreement_factor": AGREEMENT_FACTOR,
        "within_noise": bool(diff <= AGREEMENT_FACTOR * expected),
        "rms_forward_minus_reverse_A": float(np.sqrt(np.mean((sweep.forward[fr] - sweep.reverse[fr]) ** 2))),
        "table_written": bool(ok.all())}


def _in_si(model, k: float, source: str) -> dict:
    """The model's scale in SI with the torque constant ``k`` (N·m/A): cogging RMS (N·m), Coulomb friction (N·m),
    viscous friction (N·m·s/rad) and the moment of inertia of rotor and load (kg·m²), from the current-unit model."""
    import numpy as np

    si = model.in_newton_metres(k)
    th = 2 * np.pi * np.arange(4096) / 4096
    direction = model.direction
    coulomb = float(sum(c[0] for h, c in zip(direction.orders, direction.coef) if h == 0))
    return {"torque_constant_Nm_per_A": k, "torque_constant_from": source,
            "cogging_rms_Nm": float(np.sqrt(np.mean(si["cogging"](th) ** 2))), "coulomb_Nm": coulomb * k,
            "viscous_Nm_s_per_rad": si["viscous"], "inertia_kg_m2": si["inertia"]}


def _plot_rotary(path, model, info: dict, motor, n: int = 3600, sweep=None) -> None:
    """The identified maps over one revolution, each with its standard error as a band where known; the
    table of a logged standstill sweep (``sweep``, :class:`pgcomm.rotary.standstill.SweepTable`) beside
    the model's, and the ripple the logged q-voltage measures beside the currents' (:mod:`pgcomm.rotary.back_emf`)."""
    import matplotlib.pyplot as plt
    import numpy as np

    from pgcomm import plots

    th = 2 * np.pi * np.arange(n) / n
    se = info.get("standard_error") or {}
    panels = (("cogging", "compensating q current", "A", 1.0, model.table(n)),
              ("ripple", "torque-constant ripple", "%", 100.0, model.ripple(th)),
              ("direction", "direction-dependent torque", "A", 1.0, model.direction(th)))
    fig, ax = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    voltage = info.get("back_emf") or {}
    for a, (key, label, unit, scale, values) in zip(ax, panels):
        a.plot(th, scale * values, lw=0.7, label="identified" + (" (forward and reverse averaged)"
                                                                 if key == "cogging" else ""))
        if key in se and se[key].get("determined") is False:
            a.set_title(f"{label}: not determined by these logs ({se[key]['pinned']})", fontsize=9)
        elif key in se:
            band = scale * se[key]["rms_error"]
            a.fill_between(th, scale * values - band, scale * values + band, alpha=0.25, lw=0,
                           label=f"± standard error ({100 * se[key]['relative']:.1f} % of its RMS)")
        if key == "ripple" and voltage.get("ripple"):
            from pgcomm.rotary.model import Fourier

            rel = voltage["ripple_rms_error"] / voltage["ripple_rms"] if voltage["ripple_rms"] > 0 else float("inf")
            a.plot(th, scale * Fourier.from_dict(voltage["ripple"])(th), "k--", lw=0.6, alpha=0.7,
                   label=f"from the q-voltage's back-EMF (standard error {100 * rel:.0f} % of its RMS; "
                         f"{'agrees' if voltage['consistent'] else 'disagrees'})")
        if key == "cogging":
            a.plot(th, model.table(n, +1), lw=0.5, alpha=0.7, label="forward")
            a.plot(th, model.table(n, -1), lw=0.5, alpha=0.7, label="reverse")
            if sweep is not None:
                a.plot(sweep.theta, sweep.table, "k", lw=0.4, alpha=0.6,
                       label=f"standstill sweep ({sweep.seconds:.0f} s of rig time)")
        a.set_ylabel(f"{label} [{unit}]", fontsize=8)
        a.legend(fontsize=7, loc="upper right")
    ax[-1].set_xlabel("mechanical angle θ [rad]")
    fig.suptitle(f"rotary {motor.name}: maps identified from running logs")
    plots.save(fig, path)


def _identify_spline(args, out, progress, setup, data, source, t0) -> None:
    """``--family spline``: the spline model and the mechanics; model file with both, results, figures."""
    import jax.numpy as jnp
    import numpy as np

    from pgcomm import __version__, experiment, plots
    from pgcomm.io.model import save_model
    from pgcomm.io.results import write_results

    with progress.stage("spline model (knots by cross-validation) and mechanics from the same data"):
        fit, mech = experiment.identify_spline_models(setup, data, progress)
    fy_abs_max = max(float(np.max(np.abs(d.force[:, 0]))) for d in data)
    ident = {"spline": fit.to_dict(), "seconds_total": fit.seconds + mech.seconds}
    results = {"command": "identify", "family": "spline", "plant": setup.plant_name, "data": source,
               "version": __version__, "seed": args.seed, "force_sensor": True, "identification": ident,
               "mechanics": mech.to_dict()}
    save_model(out / "model", fit.model, {"seed": args.seed, "plant": setup.plant_name, "data": source,
                                          "fy_abs_max": fy_abs_max, "force_sensor": True, "identification": ident,
                                          **law_metadata(args, setup)}, mechanics=mech)
    y = np.linspace(*fit.model.training_range, 2001)
    known = setup.plant is not None and (source != "logs" or args.plant is None)
    truth = np.asarray(setup.plant.cogging(jnp.asarray(y))) if known else None
    plots.save(plots.plot_cogging(y, np.asarray(fit.model.cogging(jnp.asarray(y))), truth,
                                  title="identified cogging force (spline model)", label="spline model"),
               out / "cogging.png")
    gm = np.asarray(fit.model.gain(jnp.asarray(y)))
    gt = np.asarray(setup.plant.gain(jnp.asarray(y))) if known else None
    for l in range(fit.model.n_coil_sets):
        plots.save(plots.plot_gain_columns(y, gm[:, l], None if gt is None else gt[:, l], l, label="spline model"),
                   out / f"gain_coilset{l + 1}.png")
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
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
        print(f"wrote {args.out}/model.json, model.npz, results.json, cogging.png, gain_coilset*.png")


def _refuse_spline_without_force(args, sensorless: bool) -> None:
    """``--family spline`` fits the measured force: refuse it without a force sensor before any work."""
    if sensorless and args.family == "spline":
        raise DataError("--family spline needs force measurements (Fy, Fx, Tz); without a force sensor use "
                        "--family pgnn")


def _setup(args):
    """The set-up; logs with ``--motor`` but no ``--plant`` are a rig's: its motor description, no plant."""
    if args.data and args.motor is not None and args.plant is None:
        from pgcomm.settings import ExperimentConfig, load_experiment
        from pgcomm.setup import Setup
        from pgcomm.io.config import load_motor

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
