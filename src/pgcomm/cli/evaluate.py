"""``pgcomm evaluate``: commutation error ``F − F*`` and tracking error of logs, and with ``--model``
how well a model explains them (``F − F̂(y, i)``)."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_data_options, add_motor_option, motor_from_args, \
    read_data_logs, require_data
from pgcomm.errors import ConfigError

HELP = ("Commutation error F - F* (50 Hz-filtered and unfiltered MSE per direction) and tracking "
        "error of logs; with --model also the model error F - F^(y, i). Writes results.json and figures.")


def configure(p) -> None:
    """Options of ``pgcomm evaluate``."""
    add_common_options(p, out=True, plant=False)
    add_data_options(p)
    p.add_argument("--model", type=Path, metavar="M", help="model file: also report F - F^(y, i) and warn where "
                                                           "positions leave its training range")
    add_motor_option(p, "only for logs with drive inputs instead of currents, with --model")
    p.add_argument("--lowpass-hz", type=float, default=50.0,
                   help="cut-off of the ZOH low-pass H(z) applied to the errors (default 50 Hz, as the paper)")


def run(args, out: Path, progress) -> None:
    """Evaluate ``--data``; write ``results.json``, ``evaluation.png`` (and ``model_error.png`` with ``--model``)."""
    from pgcomm import __version__, evaluation, plots
    from pgcomm.io.model import load_model
    from pgcomm.io.results import write_results

    t0 = time.perf_counter()
    require_data(args)
    if not (math.isfinite(args.lowpass_hz) and args.lowpass_hz > 0):
        raise ConfigError(f"--lowpass-hz {args.lowpass_hz:g}: must be a positive frequency (Hz)")
    with progress.stage(f"read {len(args.data)} log pattern(s)"):
        logs = read_data_logs(args)
        for log in logs:
            evaluation.require_desired_force(log)
            if args.lowpass_hz >= 0.5 / log.sample_time:
                raise ConfigError(f"--lowpass-hz {args.lowpass_hz:g}: at or above the Nyquist frequency "
                                  f"{0.5 / log.sample_time:g} Hz of {log.source}")
        progress.info(f"{len(logs)} log(s), {sum(lg.n_samples for lg in logs)} samples")
    model = motor = None
    if args.model:
        model, _ = load_model(args.model)
        motor = motor_from_args(args)
    with progress.stage("evaluate logs"):
        evals = evaluation.evaluate_logs(logs, args.lowpass_hz, model=model, motor=motor)
    for ev in evals:
        if ev.range_warning:
            print(f"pgcomm: warning: {ev.file}: {ev.range_warning}", file=sys.stderr)
        for note in ev.notes:
            print(f"pgcomm: note: {ev.file}: {note}", file=sys.stderr)
    results = {"command": "evaluate", "version": __version__,
               "evaluation": evaluation.evaluation_results(evals, args.lowpass_hz,
                                                           None if args.model is None else str(args.model))}
    plots.save(evaluation.plot_logs(evals, title=f"{len(evals)} log(s)"), out / "evaluation.png")
    figures = ["evaluation.png"]
    if model is not None:
        plots.save(evaluation.plot_model_error(evals, title=f"model error of {Path(args.model).name}"),
                   out / "model_error.png")
        figures.append("model_error.png")
    results["runtime_s"] = time.perf_counter() - t0
    write_results(out / "results.json", results)
    if not args.quiet:
        print(evaluation.format_table(evals))
        print(f"wrote {args.out}/results.json, {', '.join(figures)}")
