"""``pgcomm check``, ``pgcomm evaluate``, ``pgcomm inspect``: the commands that face a rig's logs and a model file.

* ``check``: do the logs persistently excite the PGNN of every coil set (paper, Remark on
  excitation)? Exit code 0 when they do, 1 when they do not (a finding), 2 for bad input.
* ``evaluate``: commutation error ``F − F*`` and tracking error of logs, and with
  ``--model`` how well a model explains them (``F − F̂(y, i)``).
* ``inspect``: what a model file holds (structure, training range, costs, provenance).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from pgcomm.cli import _common, _write_results, command, staged_output
from pgcomm.cli_identify import add_data_options, read_data_logs
from pgcomm.errors import ConfigError, DataError, PgcommError

#: Exit code of ``pgcomm check`` when the data do not excite the model (2 stays "bad input").
EXIT_NOT_EXCITED = 1


def _motor(args):
    """The drive's motor description: ``--motor`` or the twin's nominal motor (k̂ = 67 N/A, ζ̂ = −0.52 rad)."""
    if getattr(args, "motor", None):
        from pgcomm.io.config import load_motor

        return load_motor(args.motor)
    from pgcomm.twin import TwinParams

    return TwinParams().motor()


def _require_data(args) -> None:
    if not args.data:
        raise ConfigError("--data: give at least one log file or glob (CSV, Parquet, .mat, HDF5)")


def _add_motor_option(p, what: str) -> None:
    p.add_argument("--motor", type=Path, metavar="MOTOR.toml",
                   help=f"motor description: pole pitch, coil sets, the drive's k and zeta ({what}); "
                        "default: the twin's nominal motor (k = 67 N/A, zeta = -0.52 rad)")


# ------------------------------------------------------------------------------------------- check


def _check_configure(p):
    _common(p, out=False, plant=False)
    add_data_options(p)
    _add_motor_option(p, "drive-input logs are converted with k and zeta; Delta is measured against zeta")
    # dest is not "out": cli.main would stage it and discard the report when check exits with code 1
    p.add_argument("--out", dest="report_dir", type=Path, metavar="DIR",
                   help="also write results.json and coverage.png into DIR (created; files replaced)")
    p.add_argument("--bins", type=int, default=None, metavar="N",
                   help="position bins over the stroke (default 20, as identification checks)")
    p.add_argument("--range", type=float, nargs=2, metavar=("YMIN", "YMAX"),
                   help="stroke to cover (m); default: the span of all logs")


@command("check", "Check that logs persistently excite the model (paper's Remark): both signs of Delta, "
                  "several force magnitudes, every position of the stroke. Exit code 1 when they do not.")
def cmd_check(args, out, progress):
    from pgcomm import excitation, plots

    t0 = time.perf_counter()
    _require_data(args)
    n_bins = excitation.DEFAULT_BINS if args.bins is None else args.bins
    if n_bins < 1:
        raise ConfigError(f"--bins {n_bins}: need at least 1 position bin")
    if args.range is not None:
        lo, hi = args.range
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ConfigError(f"--range {lo:g} {hi:g}: need YMIN < YMAX (m)")
    motor = _motor(args)
    with progress.stage(f"read {len(args.data)} log pattern(s)"):
        logs = read_data_logs(args)
        progress.info(f"{len(logs)} log(s), {sum(lg.n_samples for lg in logs)} samples")
    with progress.stage("excitation per coil set and position bin"):
        report = excitation.excitation_report(logs, motor, n_bins=n_bins, y_range=args.range)
    if args.report_dir is not None:
        results = {"command": "check", "motor": str(args.motor) if args.motor else "twin (default)",
                   "logs": [lg.source for lg in logs], "check": report.to_dict(),
                   "runtime_s": time.perf_counter() - t0}
        # staged here (not by cli.main) so that the report is kept when the data fail the check
        with staged_output(args.report_dir) as tmp:
            plots.save(excitation.plot_coverage(report), tmp / "coverage.png")
            _write_results(tmp / "results.json", results)
    if not args.quiet:
        print(format_check(report))
        if args.report_dir is not None:
            print(f"wrote {args.report_dir}/results.json, coverage.png")
    if not report.ok:
        bad = ", ".join(str(c.coil_set + 1) for c in report.coil_sets if not c.ok)
        print(f"pgcomm: check: the data do not persistently excite the model of coil set(s) {bad} "
              f"({len(report.problems)} problem(s))", file=sys.stderr)
        raise SystemExit(EXIT_NOT_EXCITED)


cmd_check.configure = _check_configure


def format_check(report) -> str:
    """The check's text table: per coil set logs, samples, position range, share of samples per sign of Δ,
    the sparsest bin and the verdict; then the problems, one per line."""
    lines = [f"excitation over y in [{report.y_range[0]:.4g}, {report.y_range[1]:.4g}] m, {report.n_bins} bins",
             f"{'coil set':>8s} {'logs':>4s} {'samples':>8s} {'y range [m]':>19s} {'Δ<0':>6s} {'Δ≈0':>6s} "
             f"{'Δ>0':>6s} {'none':>6s} {'min/bin':>7s}  status"]
    for c in report.coil_sets:
        if c.bins is None:
            lines.append(f"{c.coil_set + 1:8d} {0:4d} {0:8d} {'-':>19s} {'':6s} {'':6s} {'':6s} {'':6s} {'-':>7s}  "
                         "NO DATA")
            continue
        b = c.bins
        n = max(int(b.samples.sum()), 1)
        share = [f"{100 * int(v.sum()) / n:5.1f}%" for v in (b.delta_negative, b.delta_zero, b.delta_positive,
                                                             b.no_current)]
        rng = f"[{c.y_min:.3f}, {c.y_max:.3f}]"
        status = "ok" if c.ok else f"{len(c.problems)} PROBLEM(S)"
        lines.append(f"{c.coil_set + 1:8d} {len(c.files):4d} {c.samples:8d} {rng:>19s} {share[0]:>6s} {share[1]:>6s} "
                     f"{share[2]:>6s} {share[3]:>6s} {int(b.samples.min()):7d}  {status}")
    lines.append("(Δ: shares of samples by the current's phase offset from the drive's commutation angle; "
                 "none: no current; min/bin: samples in the sparsest position bin)")
    if report.ok:
        lines.append("the data excite the model of every coil set")
    else:
        lines.append("problems:")
        lines.extend(f"  {p}" for p in report.problems)
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------- evaluate


def _evaluate_configure(p):
    _common(p, out=True, plant=False)
    add_data_options(p)
    p.add_argument("--model", type=Path, metavar="M", help="model file: also report F - F^(y, i) and warn where "
                                                           "positions leave its training range")
    _add_motor_option(p, "only for logs with drive inputs instead of currents, with --model")
    p.add_argument("--lowpass-hz", type=float, default=50.0,
                   help="cut-off of the ZOH low-pass H(z) applied to the errors (default 50 Hz, as the paper)")


@command("evaluate", "Commutation error F - F* (50 Hz-filtered and unfiltered MSE per direction) and tracking "
                     "error of logs; with --model also the model error F - F^(y, i). Writes results.json and figures.")
def cmd_evaluate(args, out: Path, progress):
    from pgcomm import __version__, evaluation, plots

    t0 = time.perf_counter()
    _require_data(args)
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
        model, _ = load_model_file(args.model)
        motor = _motor(args)
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
    _write_results(out / "results.json", results)
    if not args.quiet:
        print(evaluation.format_table(evals))
        print(f"wrote {args.out}/results.json, {', '.join(figures)}")


cmd_evaluate.configure = _evaluate_configure


# ----------------------------------------------------------------------------------------- inspect


def load_model_file(path):
    """``(CombinedModel, document)`` from a model file; every failure becomes one :class:`DataError` line.

    :func:`pgcomm.modelfile.load_model` validates what it reads and raises :class:`DataError`;
    this guard keeps the CLI's promise (one line, exit code 2) should anything below it
    (numpy, zipfile, JAX) still give up in another way on a damaged file.
    """
    from pgcomm.modelfile import load_model

    try:
        return load_model(path)
    except (PgcommError, FileNotFoundError):
        raise
    except Exception as e:  # noqa: BLE001  (any failure of a damaged file is a user error here)
        raise DataError(f"{path}: not a readable pgcomm model file ({type(e).__name__}: "
                        f"{' '.join(str(e).split())})") from None


def _inspect_configure(p):
    p.add_argument("--model", required=True, type=Path, metavar="M", help="model file written by pgcomm identify")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    _common(p, out=False, plant=False)  # --quiet, which cli.main expects of every command


@command("inspect", "What a model file holds: structure (L, widths, activation, parameters), pole pitch, "
                    "training range, costs per coil set, seed, version, date, file sizes.")
def cmd_inspect(args, out, progress):
    model, document = load_model_file(args.model)
    info = model_summary(model, document, args.model)
    if args.json:
        from pgcomm.io.results import to_jsonable

        print(json.dumps(to_jsonable(info), indent=2, ensure_ascii=False))
    else:
        print(format_summary(info))


cmd_inspect.configure = _inspect_configure


def _n_params(tree) -> int:
    import jax

    return int(sum(np.size(x) for x in jax.tree_util.tree_leaves(tree)))


def _widths(net) -> list[int] | None:
    """Hidden widths of a stacked :class:`~pgcomm.models.MLP` (leading coil-set dims ignored)."""
    return None if net is None else [int(b.shape[-1]) for _, b in net.hidden]


def model_summary(model, document: dict, path) -> dict:
    """JSON-ready description of a combined model and its file's document (:func:`pgcomm.modelfile.load_model`).

    Keys: ``file``, ``files`` (name -> bytes: the JSON and its ``.npz``), ``structure``
    (``coil_sets``, ``gain_widths``, ``cog_widths``, ``activation``, ``parameters_per_coil_set``
    split into ``physics`` (``A, B``: 12), ``gain_networks``, ``cogging_network`` and ``total``;
    ``parameters_total``), ``pole_pitch`` (m), ``training_range`` (m, covered by every coil
    set) and ``training_range_per_coil_set``, ``costs`` (per coil set, from the metadata's
    ``identification``), ``seed``, ``version`` (package that wrote the file), ``date``,
    ``schema`` and the remaining ``metadata``.
    """
    L = model.n_coil_sets
    per_gain = _n_params(model.gain_nets) // L if model.gain_nets is not None else 0
    per_cog = _n_params(model.cog_nets) // L if model.cog_nets is not None else 0
    n_phy = int(np.size(model.A) + np.size(model.B)) // L
    net = model.gain_nets if model.gain_nets is not None else model.cog_nets
    per_cs = {"physics": n_phy, "gain_networks": per_gain, "cogging_network": per_cog,
              "total": n_phy + per_gain + per_cog}
    ranges = None
    if model.y_min is not None and model.y_max is not None:
        ranges = [[float(a), float(b)] for a, b in zip(model.y_min, model.y_max)]
    meta = document.get("metadata") or {}
    ident = meta.get("identification") or {}
    keys = ("cost_physics", "cost_pgnn", "cost_physics_validation", "cost_pgnn_validation", "iterations", "seconds",
            "n_train", "n_validation", "stop_reason")
    costs = [{"coil_set": l + 1, **{k: c[k] for k in keys if k in c}}
             for l, c in enumerate(ident.get("coil_sets") or []) if isinstance(c, dict)]
    return {
        "file": str(path),
        "files": _file_sizes(path, document.get("arrays")),
        "schema": document.get("schema"),
        "structure": {"coil_sets": L, "gain_widths": _widths(model.gain_nets), "cog_widths": _widths(model.cog_nets),
                      "activation": None if net is None else net.activation,
                      "parameters_per_coil_set": per_cs, "parameters_total": L * per_cs["total"]},
        "pole_pitch": float(model.pole_pitch),
        "training_range": None if model.training_range is None else list(model.training_range),
        "training_range_per_coil_set": ranges,
        "costs": costs,
        "seed": meta.get("seed"),
        "version": document.get("package_version"),
        "date": document.get("created"),
        "metadata": {k: v for k, v in meta.items() if k not in ("identification", "seed")},
    }


def _file_sizes(path, arrays_name) -> dict:
    """Bytes of the model's JSON and of the array file it names (name -> bytes)."""
    from pgcomm.modelfile import model_paths

    js, npz = model_paths(path)
    files = [js, js.with_name(str(arrays_name)) if arrays_name else npz]
    return {f.name: f.stat().st_size for f in files if f.is_file()}


def format_summary(info: dict) -> str:
    """Readable text of :func:`model_summary`."""
    s = info["structure"]
    pc = s["parameters_per_coil_set"]
    lines = [f"model {info['file']}",
             f"  files:          {', '.join(f'{k} ({_bytes(v)})' for k, v in info['files'].items()) or '-'}",
             f"  schema:         {_or_dash(info['schema'])}",
             f"  coil sets L:    {s['coil_sets']}",
             f"  gain networks:  {_fmt_widths(s['gain_widths'])}   cogging network: {_fmt_widths(s['cog_widths'])}"
             f"   activation: {s['activation'] or '-'}",
             f"  parameters:     {pc['total']} per coil set (A, B {pc['physics']}, gain networks "
             f"{pc['gain_networks']}, cogging {pc['cogging_network']}); {s['parameters_total']} in total",
             f"  pole pitch:     {info['pole_pitch']:.6g} m"]
    tr = info["training_range"]
    lines.append("  training range: " + ("unknown" if tr is None else f"[{tr[0]:.4g}, {tr[1]:.4g}] m (all coil sets)"))
    for l, r in enumerate(info["training_range_per_coil_set"] or []):
        lines.append(f"                  coil set {l + 1}: [{r[0]:.4g}, {r[1]:.4g}] m")
    if info["costs"]:
        lines.append(f"  {'coil set':>8s} {'V physics':>11s} {'V PGNN':>11s} {'V phys val':>11s} {'V PGNN val':>11s}")
        for c in info["costs"]:
            cells = [_num(c.get(k)) for k in ("cost_physics", "cost_pgnn", "cost_physics_validation",
                                              "cost_pgnn_validation")]
            lines.append(f"  {c['coil_set']:8d} {cells[0]:>11s} {cells[1]:>11s} {cells[2]:>11s} {cells[3]:>11s}")
    else:
        lines.append("  costs:          not recorded")
    lines += [f"  seed:           {_or_dash(info['seed'])}",
              f"  version:        {_or_dash(info['version'])}",
              f"  date:           {_or_dash(info['date'])}"]
    for k, v in info["metadata"].items():
        if isinstance(v, (str, int, float, bool)) or v is None:
            lines.append(f"  {k + ':':15s} {v}")
    return "\n".join(lines)


def _fmt_widths(w) -> str:
    return "none" if w is None else "x".join(map(str, w))


def _num(v) -> str:
    return "-" if v is None else f"{v:.5g}"


def _or_dash(v) -> str:
    return "-" if v is None else str(v)


def _bytes(n: int) -> str:
    return f"{n} B" if n < 1024 else f"{n / 1024:.1f} KiB" if n < 1024**2 else f"{n / 1024**2:.1f} MiB"
