"""``pgcomm identify`` on a rotary motor (``--motor`` with ``kind = "rotary"``): parse, read, write.

The logs (``--data``: ``t``, ``theta``, ``iq_1`` through the column mapping; a ``torque`` column in every log means a
torque sensor) are identified by :func:`pgcomm.rotary.from_logs.identify_from_logs` (the Python API of this command):
cogging, torque-constant ripple and the direction-dependent torque over the revolution, in current units, with each
map's standard error and whether the logs resolve it. The reading options come from ``--config``'s ``[rotary]`` table
(:class:`pgcomm.settings.RotaryIdentifyOptions`), a flag taking its value's place. This module writes ``model.json``,
``compensation.csv`` (the table ``pgcomm export --format moteus|odrive|c-angle`` reads, with the motor's current
limit), ``results.json``, ``identify_rotary.png`` (:func:`pgcomm.plots.plot_rotary_maps`) and ``report.html``
(:mod:`pgcomm.report.rotary`); ``--sweep`` adds ``standstill_table.csv``.
"""

from __future__ import annotations

import glob
import json
import math
import time
from dataclasses import replace
from pathlib import Path

from pgcomm.cli._common import ROTARY_READING
from pgcomm.errors import ConfigError, DataError
from pgcomm.export.angle_table import make_table, write_angle_table
from pgcomm.io.atomic import atomic_write_text
from pgcomm.io.config import load_experiment, load_rotary_motor
from pgcomm.io.logs import ROTARY_REQUIRED, load_column_mapping, read_logs, with_encoder_counts
from pgcomm.io.results import write_results
from pgcomm.io.static_map import is_static_map, read_static_map
from pgcomm.plots import plot_rotary_maps, save
from pgcomm.report.rotary import write_rotary_report
from pgcomm.rotary.from_logs import identify_from_logs
from pgcomm.rotary.plan import check_rotary_logs
from pgcomm.settings import RotaryIdentifyOptions


def _rotary_options(args):
    """The :class:`pgcomm.settings.RotaryIdentifyOptions` of ``--config``'s ``[rotary]`` table (defaults without
    one), with the reading options given on the command line (:data:`~pgcomm.cli._common.ROTARY_READING`) in their
    place."""
    options = load_experiment(args.config).rotary if args.config else RotaryIdentifyOptions()
    for dest, kind in ROTARY_READING.items():
        text = getattr(args, dest, None)
        if text is not None:
            options = _with_flag(options, dest, text, kind)
    return options


def _with_flag(options, dest: str, text: str, kind: str):
    """``options`` with ``--DEST TEXT`` read as ``kind`` (:data:`~pgcomm.cli._common.ROTARY_READING`) in the field's
    place; the options' own check refuses a bad value, in one line naming the option."""
    word = text.strip().lower()
    if word in ("none", "held", "detect"):
        value = word
    else:
        try:
            numbers = [float(x) for x in text.split(",")]
        except ValueError:
            numbers = [math.nan]  # not a number: refused below with what the option expects
        if kind == "numbers":
            value = tuple(numbers)
        else:
            value = numbers[0] if len(numbers) == 1 else math.nan
            if kind == "integer" and value.is_integer():
                value = int(value)
    try:
        return replace(options, **{dest: value})
    except ValueError as e:
        # the options say "name = value: what is expected"; the command line names the option as written
        raise ConfigError(f"--{dest.replace('_', '-')} {text}: {str(e).split(': ', 1)[-1]}") from None


def run_rotary(args, out: Path, progress, t0: float) -> None:
    """``pgcomm identify --motor rotary.toml --data LOG...`` (module docstring)."""
    if getattr(args, "plant", None):
        raise ConfigError(f"--plant: not used with a rotary motor (--motor {args.motor} has kind = \"rotary\")")
    if args.family != "pgnn":
        raise ConfigError(f"--family {args.family}: a rotary motor's model is a Fourier series on the circle; "
                          "leave --family out")
    if not args.data:
        raise ConfigError(f"--data: a rotary motor ({args.motor}) is identified from its drive's running logs "
                          "(t, theta, iq_1); the rotary twin writes some with pgcomm zoo --kind rotary --logs")
    motor = load_rotary_motor(args.motor)
    options = _rotary_options(args)
    with progress.stage(f"read {len(args.data)} log pattern(s)"):
        mapping = with_encoder_counts(load_column_mapping(args.columns) if args.columns else None, motor)
        logs = read_logs(args.data, sample_time=args.sample_time, columns=mapping, required=ROTARY_REQUIRED, gaps=True,
                         stamps=True)
        check_rotary_logs(logs, f"--motor {args.motor}")
        n_samples = sum(lg.n_samples for lg in logs)
        progress.info(f"{len(logs)} log(s), {n_samples} samples, {n_samples * logs[0].sample_time:.0f} s")
        for lg in logs:
            for note in lg.notes:
                progress.info(f"{lg.source}: {note}")
    torque_sensor = (options.torque_sensor or all("torque" in lg.columns for lg in logs)) and not args.no_force_sensor
    options = replace(options, torque_sensor=torque_sensor)
    # --sweep: the drive's own static maps, and a logged sweep (the rest)
    sweeps = args.sweep or []
    maps = [p for pat in sweeps for p in sorted(glob.glob(pat)) or [pat] if is_static_map(p)]
    static_maps = [read_static_map(p, motor.encoder_counts) for p in maps]
    sweep_logs = _sweep_logs([p for p in sweeps if p not in maps], args.sample_time, mapping)
    found = identify_from_logs(logs, motor, options, sweep_logs=sweep_logs, static_maps=static_maps,
                               progress=progress, started=t0)
    results, motor, model, sweep = found.to_dict(), found.motor, found.model, found.sweep
    written = ["model.json", "compensation.csv", "results.json", "identify_rotary.png", "report.html"]
    if sweep is not None and found.sweep_comparison["table_written"]:
        written.insert(2, "standstill_table.csv")
    written[2:2] = [name for name, *_ in found.combined_tables]
    with progress.stage(", ".join(written)):
        atomic_write_text(out / "model.json", json.dumps(model.to_dict(), indent=1) + "\n")
        write_angle_table(out / "compensation.csv",
                          make_table(found.table, "model from running logs", current_limit=motor.current_limit),
                          comments=(f"pgcomm rotary model of {motor.name}, identified {found.how} from "
                                    f"{len(logs)} log(s); forward and reverse averaged",))
        if "standstill_table.csv" in written:
            write_angle_table(out / "standstill_table.csv",
                              make_table(sweep.table, "standstill sweep", current_limit=motor.current_limit),
                              comments=(f"the drives' table of {motor.name} from the logged sweep "
                                        f"{', '.join(found.sweep_comparison['logs'])}: forward and reverse bin "
                                        "averages, their mean",))
        for (name, iq, _), m in zip(found.combined_tables, static_maps):
            write_angle_table(out / name, make_table(iq, name, current_limit=motor.current_limit),
                              comments=(f"pgcomm rotary model of {motor.name} from {len(logs)} log(s) and the drive's "
                                        f"static map {m.source} as one table, each weighed by its error (forward and "
                                        "reverse averaged; the map's index offset removed)",))
        write_results(out / "results.json", results)
        static = [(Path(m.source).name, iq, aligned) for (_, iq, aligned), m in zip(found.combined_tables, static_maps)]
        save(plot_rotary_maps(model, found.identification, motor.name, sweep=sweep, static=static),
             out / "identify_rotary.png")
        write_rotary_report(out / "report.html", results, {
            "The identified maps over one revolution with their standard error as a band: the compensating q "
            "current (cogging and direction term, forward and reverse and their mean, the table that is "
            "exported), the torque-constant ripple, and the direction-dependent torque.":
                out / "identify_rotary.png"}, version=results["version"])
    if not args.quiet:
        _summary(args, found, results, written, time.perf_counter() - t0)


def _sweep_logs(paths, sample_time, mapping) -> list:
    """The logged sweep's pieces (``t``, ``theta``, ``iq_1``), read as the running logs are."""
    if not paths:
        return []
    logs = read_logs(paths, sample_time=sample_time, columns=mapping, required=ROTARY_REQUIRED)
    for lg in logs:
        if not lg.is_rotary or "iq_1" not in lg.columns:
            raise DataError(f"{lg.source}: a sweep log needs 'theta' and 'iq_1' (map the drive's columns in --columns)")
    return logs


def _summary(args, found, results: dict, written: list, seconds: float) -> None:
    """What ``identify`` found on a rotary motor, in a few lines on standard output."""
    motor, logs = found.motor, found.logs
    refused = found.identification.windows_refused_alias
    print(f"rotary {motor.name}: identified {found.how} from {len(logs)} log(s)"
          + (f"; {refused} windows refused as too fast for the encoder-sampled cogging" if refused else ""))
    table = results["table"]
    nm = table.get("rms_Nm")
    print(f"compensation table: {table['rms_A']:.3g} A RMS, {table['peak_A']:.3g} A peak ({table['entries']} entries)"
          + (f"; {nm:.3g} N·m RMS with {table['torque_constant_from']}" if nm else ""))
    voltage = results["identification"].get("back_emf") or {}
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
    if found.sweep is not None:
        sw = results["standstill_sweep"]
        print(f"standstill sweep: model minus sweep table {sw['rms_model_minus_sweep_A']:.3g} A RMS, "
              f"{sw['rms_model_minus_sweep_A'] / sw['expected_rms_difference_A']:.2f}x what the two noises give "
              f"({'within' if sw['within_noise'] else 'NOT within'} the noise); the sweep took "
              f"{sw['seconds']:.0f} s, the running logs {found.samples * motor.sample_time:.0f} s")
    print(f"wrote {args.out}/{', '.join(written)} ({seconds:.0f} s)")
    if (si or {}).get("inertia_kg_m2"):
        # reproduce builds the twin from the TOML, which needs the slot count (read here if it was not there)
        print("preview the law against the drive's table on this motor: "
              + (f"add slots = {motor.slots} to {args.motor}, then " if found.slots_detected is not None else "")
              + f"pgcomm reproduce --motor {args.motor} --truth {args.out}/model.json --quick --out preview")
