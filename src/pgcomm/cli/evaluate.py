"""``pgcomm evaluate``: commutation error ``F − F*`` and tracking error of logs, and with ``--model``
how well a model explains them (``F − F̂(y, i)``).

Logs without force columns (no force sensor): the driving force is reconstructed from the
motion, ``m ÿ + f_v ẏ + F_c(y) s(ẏ)`` (:func:`pgcomm.evaluation.reconstruct_force`), with the
friction of a ``--model`` identified without a force sensor and the moving mass of ``--motor``
(key ``mass``) or, without ``--motor``, the mass that model was identified with; the command
says so.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from pgcomm import __version__
from pgcomm.cli._common import add_common_options, add_data_options, add_motor_option, motor_from_args, \
    read_data_logs, require_data
from pgcomm.errors import ConfigError
from pgcomm.io.config import load_motor
from pgcomm.io.results import write_results

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("Commutation error F - F* (50 Hz-filtered and unfiltered MSE per direction) and tracking "
        "error of logs; with --model also the model error F - F^(y, i). Writes results.json and figures.")


def configure(p) -> None:
    """Options of ``pgcomm evaluate``."""
    add_common_options(p, out=True, plant=False)
    add_data_options(p)
    p.add_argument("--model", type=Path, metavar="M", help="model file: also report F - F^(y, i) and warn where "
                                                           "positions leave its training range")
    add_motor_option(p, "for logs with drive inputs instead of currents, with --model; its mass for logs without "
                        "force columns (default: the mass the model was identified with)")
    p.add_argument("--lowpass-hz", type=float, default=50.0,
                   help="cut-off of the ZOH low-pass H(z) applied to the errors (default 50 Hz, as the paper)")


def run(args, out: Path, progress) -> None:
    """Evaluate ``--data``; write ``results.json``, ``evaluation.png`` (and ``model_error.png`` with ``--model``)."""
    t0 = time.perf_counter()
    require_data(args)
    if not (math.isfinite(args.lowpass_hz) and args.lowpass_hz > 0):
        raise ConfigError(f"--lowpass-hz {args.lowpass_hz:g}: must be a positive frequency (Hz)")
    model = motor = document = None
    if args.model:  # before the logs: a bad model file or motor is named before any log is read
        from pgcomm.io.model import load_model

        model, document = load_model(args.model)
        motor = motor_from_args(args)
    elif args.motor:  # a rotary motor is named as such, not by what its logs' columns lack
        motor_from_args(args)
    with progress.stage(f"read {len(args.data)} log pattern(s)"):
        logs = read_data_logs(args, progress)
        # the computing modules (SciPy's filters, Matplotlib) load after the logs: a damaged log is refused at once
        from pgcomm import evaluation, plots

        for log in logs:
            if not args.model:  # with a model, a log without F* still has a model error
                evaluation.require_desired_force(log)
            if args.lowpass_hz >= 0.5 / log.sample_time:
                raise ConfigError(f"--lowpass-hz {args.lowpass_hz:g}: at or above the Nyquist frequency "
                                  f"{0.5 / log.sample_time:g} Hz of {log.source}")
        progress.info(f"{len(logs)} log(s), {sum(lg.n_samples for lg in logs)} samples")
    mechanics = None
    without = [lg.source for lg in logs if not lg.has_force]
    if without:
        mechanics = reconstruction_mechanics(args, without, document)
        if not args.quiet:
            print(f"pgcomm: {len(without)} log(s) without force columns: reconstructing Fy from the motion "
                  f"(f_v = {mechanics['viscous']:.4g} N s/m, f_c = {mechanics['coulomb']:.4g} N from {args.model}, "
                  f"m = {mechanics['mass']:.4g} kg from {mechanics['mass_from']}); x, z not observable",
                  file=sys.stderr)
    with progress.stage("evaluate logs"):
        evals = evaluation.evaluate_logs(logs, args.lowpass_hz, model=model, motor=motor, mechanics=mechanics)
    del logs, log  # the figures need only what the evaluations keep (t, y, r, the errors): the other columns go
    for ev in evals:
        if ev.range_warning:
            print(f"pgcomm: warning: {ev.file}: {ev.range_warning}", file=sys.stderr)
        for note in ev.notes:
            print(f"pgcomm: note: {ev.file}: {note}", file=sys.stderr)
    results = {"command": "evaluate", "version": __version__, "force_reconstructed": mechanics is not None,
               "evaluation": evaluation.evaluation_results(evals, args.lowpass_hz,
                                                           None if args.model is None else str(args.model))}
    plots.save(plots.plot_logs(evals, title=f"{len(evals)} log(s)"), out / "evaluation.png")
    figures = ["evaluation.png"]
    if model is not None:
        plots.save(plots.plot_model_error(evals, title=f"model error of {Path(args.model).name}"),
                   out / "model_error.png")
        figures.append("model_error.png")
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
        print(evaluation.format_table(evals))
        print(f"wrote {args.out}/results.json, {', '.join(figures)}")


def reconstruction_mechanics(args, without, document) -> dict:
    """Mass and friction to reconstruct the force of logs without force columns (``without``: their names).

    The friction (and its ``v_ε``) is the one a ``--model`` identified without a force sensor records in
    its metadata (``mechanics``); the mass is ``--motor``'s key ``mass``, else the model's.

    Raises:
        ConfigError: no ``--model``, a model identified with a force sensor, or a ``--motor`` without ``mass``.
    """
    first = without[0] + (f" (and {len(without) - 1} more)" if len(without) > 1 else "")
    if document is None:
        raise ConfigError(f"{first}: no force columns Fy, Fx, Tz: evaluating such logs reconstructs the force from "
                          "the motion and needs --model MODEL.json of pgcomm identify --no-force-sensor (its friction)")
    meta = document.get("metadata") or {}
    mech = meta.get("mechanics")
    keys = ("mass", "viscous", "coulomb", "friction_velocity")
    if not isinstance(mech, dict) or not all(isinstance(mech.get(k), (int, float)) and not isinstance(mech.get(k), bool)
                                             and math.isfinite(mech[k]) for k in keys):
        raise ConfigError(f"--model {args.model}: no identified mechanics (mass, viscous, coulomb, friction_velocity) "
                          f"in its metadata, but {first} has no force columns; reconstructing the force needs a model "
                          "of pgcomm identify --no-force-sensor")
    out = {k: float(mech[k]) for k in keys}
    out["mass_from"] = str(args.model)
    if args.motor is not None:
        mass = load_motor(args.motor).mass
        if mass is None:
            raise ConfigError(f"--motor {args.motor}: key 'mass' missing: reconstructing the force of {first} (no force "
                              "columns) needs the moving mass of the translator (kg)")
        out["mass"], out["mass_from"] = float(mass), str(args.motor)
    if not (out["mass"] > 0 and out["friction_velocity"] > 0):
        raise ConfigError(f"--model {args.model}: mechanics mass = {out['mass']:g} kg, friction_velocity = "
                          f"{out['friction_velocity']:g} m/s must be positive")
    return out
