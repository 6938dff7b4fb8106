"""``pgcomm reproduce`` on a rotary motor (``--motor`` with ``kind = "rotary"``): the rotary experiment
(:func:`pgcomm.rotary.experiment.run`) on the twin of the motor, and its files.

The experiment's sizes are ``--config``'s ``[rotary_experiment]`` table (:class:`pgcomm.settings.RotarySettings`).
The twin's truth is ``--truth`` (a ``truth.json``, or an identified ``model.json`` with its ``results.json``: your
motor as identified) or ``truth.json`` beside the motor file (the zoo writes one), else drawn from the description
with ``--seed``. Writes ``results.json``, ``model.json``, ``table.csv``, ``compensation.csv``, ``rotary.png``
(:func:`pgcomm.plots.plot_rotary_run`) and ``report.html`` (:mod:`pgcomm.report.rotary`).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from pgcomm import __version__
from pgcomm.cli._common import refuse_conflicts, settings_given
from pgcomm.errors import ConfigError
from pgcomm.export.angle_table import make_table, write_angle_table
from pgcomm.io.atomic import atomic_open, atomic_write_text
from pgcomm.io.config import load_experiment, load_rotary_motor
from pgcomm.io.rotary_model import rotary_model_from_dict
from pgcomm.io.results import write_results
from pgcomm.io.rotary_zoo import read_truth
from pgcomm.plots import plot_rotary_run, save
from pgcomm.report.rotary import write_rotary_report
from pgcomm.rotary.experiment import QUICK_OVERRIDES, quick_settings, run
from pgcomm.rotary.zoo import default_truth, truth_from_identification
from pgcomm.settings import RotarySettings


def _identified_model(path: Path) -> dict | None:
    """``path``'s JSON when it is an identified rotary model (``model.json`` of ``pgcomm identify``), else ``None``
    (a truth file, read as such)."""
    try:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
    except (OSError, ValueError):
        return None
    return d if isinstance(d, dict) and d.get("schema") == "pgcomm.rotary_model" else None


def _truth_from_identified(path: Path, model_dict: dict, motor, seed: int):
    """The twin of a user's motor from ``identify``'s ``model.json`` (``model_dict``, read from ``path``) and the
    ``results.json`` beside it (:func:`pgcomm.rotary.zoo.truth_from_identification`). Returns ``(truth, source)``."""
    model = rotary_model_from_dict(model_dict, path)
    res_path = path.parent / "results.json"
    try:
        with open(res_path, encoding="utf-8") as f:
            results = json.load(f)
        ident = results["identification"]
    except (OSError, ValueError, KeyError, TypeError):
        raise ConfigError(f"{path}: an identified model; the twin of your motor also needs the results.json that "
                          f"pgcomm identify wrote beside it (not found or not readable: {res_path})") from None
    if model.pole_pairs != motor.pole_pairs:
        raise ConfigError(f"{path}: a model of a motor with {model.pole_pairs} pole pairs, but --motor has "
                          f"{motor.pole_pairs}")
    try:
        truth = truth_from_identification(model, ident, motor, seed)
    except ConfigError as e:
        raise ConfigError(f"{res_path}: {e}") from None
    k_from = (results.get("in_SI") or {}).get("torque_constant_from") or "the motor description's k_t"
    source = (f"your motor as identified in {path} (k0 {truth.k0:.4g} N·m/A from {k_from}, J {truth.inertia:.4g} "
              f"kg·m², current noise {truth.current_noise:.3g} A, {truth.encoder_counts}-count encoder)")
    return truth, source


def run_rotary(args, out: Path, progress, t0: float) -> None:
    """``pgcomm reproduce --motor rotary.toml``: :mod:`pgcomm.rotary.experiment` on the rotary twin.

    The twin's truth is ``--truth`` (a ``truth.json``, or an identified ``model.json`` with its ``results.json``: your
    motor as identified, :func:`_truth_from_identified`) or ``truth.json`` beside the motor file (the zoo writes one),
    else drawn from the description with ``--seed``.
    """
    for opt in ("plant", "reference"):
        if getattr(args, opt, None):
            raise ConfigError(f"--{opt}: not used with a rotary motor (--motor {args.motor} has kind = \"rotary\")")
    motor = load_rotary_motor(args.motor)
    if motor.slots is None:
        raise ConfigError(f"{args.motor}: key 'slots' missing: reproduce builds a twin of the motor and needs its slot "
                          "count (pgcomm identify reads it from running logs)")
    truth_path = args.truth or (Path(args.motor).parent / "truth.json")
    model_dict = _identified_model(args.truth) if args.truth else None
    if model_dict is not None:
        truth, source = _truth_from_identified(args.truth, model_dict, motor, args.seed)
    elif args.truth or truth_path.is_file():
        truth = read_truth(truth_path)
        if truth.motor.pole_pairs != motor.pole_pairs or truth.motor.slots != motor.slots:
            raise ConfigError(f"{truth_path}: truth of a {truth.motor.name} motor, but --motor {args.motor} is "
                              f"{motor.name}")
        truth = replace(truth, motor=motor)
        source = str(truth_path)
    else:
        truth = default_truth(motor, seed=args.seed)
        source = f"drawn from the description (seed {args.seed})"
    progress.info(f"rotary {motor.name}: twin truth {source}"
                  + (f"; its drive controls {truth.control_per_log} times per logged sample"
                     if truth.control_per_log > 1 else ""))
    settings = _rotary_settings(args, motor.sample_time)
    results = run(truth, settings, seed=args.seed, progress=progress)
    results.update(command="reproduce", kind="rotary", version=__version__, quick=bool(args.quick), seed=args.seed,
                   truth_source=source)
    results["runtime_s"] = time.perf_counter() - t0
    with progress.stage("results.json, model.json, table.csv, figure"):
        _write_rotary_outputs(out, results, truth)
    if not args.quiet:
        _print_rotary(results)
        print(f"wrote {args.out}/results.json, model.json, table.csv, compensation.csv, rotary.png, report.html "
              f"({results['runtime_s']:.0f} s)")


def _rotary_settings(args, sample_time: float) -> RotarySettings:
    """The :class:`pgcomm.settings.RotarySettings` of ``--config``'s ``[rotary_experiment]`` table (defaults without
    one; the file's other tables are the linear experiment's and ``identify``'s), shortened by ``--quick``, with
    ``--log-budget`` (rig s at ``sample_time``, turned into a share of the sweep's time) and ``--until-resolved`` in
    their keys' place."""
    settings = load_experiment(args.config).rotary_experiment if args.config else RotarySettings()
    if args.quick:
        if args.config:
            refuse_conflicts("--quick", settings_given(args.config, QUICK_OVERRIDES),
                             "overrides (a quick run logs one revolution per segment, evaluates half a revolution "
                             "and sweeps 720 angles)")
        settings = quick_settings(settings)
    if args.log_budget is not None:
        if not (args.log_budget > 0 and args.log_budget < float("inf")):
            raise ConfigError(f"--log-budget {args.log_budget:g}: give the running logs' rig time in seconds, above 0")
        settings = replace(settings, log_budget_share=args.log_budget / settings.standstill.duration(sample_time))
    return replace(settings, stop_when_resolved=True) if args.until_resolved else settings


def _print_rotary(r: dict) -> None:
    e = r["identification"]["errors"]
    print(f"identification (no torque sensor): cogging {100 * e['cogging_rel']:.1f} %, ripple "
          f"{100 * e['ripple_rel']:.1f} % RMS error of the truth's RMS; J/k0 {100 * e['inertia_ratio_rel']:.2f} %")
    a = r["standstill"]["agreement"]
    print(f"running-log table vs standstill sweep: {a['rms_model_minus_sweep_A']:.3g} A RMS (sweep's own error "
          f"{a['rms_sweep_minus_truth_A']:.3g} A); time {r['timing']['running_logs_s']:.0f} s running vs "
          f"{r['timing']['standstill_s']:.0f} s standstill")
    print(f"{'row':18s} {'position [rad^2]':>17s} {'speed [(rad/s)^2]':>18s} {'torque err [A^2]':>17s}")
    for row, v in r["tracking_mse"].items():
        print(f"{row:18s} {v['position']:17.3g} {v['speed']:18.3g} {r['commutation_mse'][row]['position']:17.3g}")
    q = r["tracking_ratio_model_over_standstill"]
    print(f"tracking model/standstill table: position {q['position']:.2f}, speed {q['speed']:.2f}")


def _write_rotary_outputs(out, results: dict, truth) -> list:
    """Write ``results.json``, ``model.json`` (identified :class:`pgcomm.rotary.model.RotaryModel`), ``table.csv`` (the
    standstill table and the model's table at the same angles), ``compensation.csv`` (the model's
    averaged table in the format ``pgcomm export --table`` reads), the figure and ``report.html`` into ``out``.

    Args:
        out: folder (exists); results: :func:`pgcomm.rotary.experiment.run`'s dict (``models`` is taken out of it);
        truth: the twin (for the figures).

    Returns:
        names of the files written.
    """
    out = Path(out)
    models = results.pop("models")
    model, tm, table = models["model"], models["truth"], models["table"]
    # as identify writes it: the motor and its current limit travel with the model (export --format c-rotary)
    saved = replace(model, info={**model.info, "motor": truth.motor.name, "current_limit": truth.motor.current_limit})
    atomic_write_text(out / "model.json", json.dumps(saved.to_dict(), indent=1) + "\n")
    n = table.size
    th = 2 * math.pi * np.arange(n) / n
    with atomic_open(out / "table.csv") as f:
        f.write("theta,standstill_table,model_table,model_forward,model_reverse\n")
        np.savetxt(f, np.column_stack([th, table, model.table(n), model.table(n, +1), model.table(n, -1)]),
                   delimiter=",", fmt="%.9g")
    # the model's table (both directions averaged, as the drives hold it) in the format pgcomm export
    # --table reads: reproduce -> export moteus|odrive|c-angle without a conversion step
    write_angle_table(out / "compensation.csv", make_table(model.table(n), "model from running logs",
                                                          current_limit=truth.motor.current_limit),
                      comments=(f"pgcomm rotary model of {truth.motor.name}, identified from running logs "
                                "without a torque sensor; forward and reverse averaged",))
    write_results(out / "results.json", results)
    save(plot_rotary_run(table, model, tm, results["tracking_mse"], truth.motor.name), out / "rotary.png")
    write_rotary_report(out / "report.html", results, {
        "Top: the compensating q current over one revolution, from the standstill sweep, from the model identified "
        "from running logs, and the truth. Middle: the torque-constant ripple, identified and true. Bottom: each "
        "row's tracking MSE over classical commutation's, position and speed loop (log scale).": out / "rotary.png"},
        version=str(results.get("version", "")))
    return ["results.json", "model.json", "table.csv", "compensation.csv", "rotary.png", "report.html"]
