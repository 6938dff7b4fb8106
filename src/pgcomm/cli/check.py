"""``pgcomm check``: do logs persistently excite the PGNN of every coil set (paper, Remark on excitation)?

The criterion needs positions and currents (or drive inputs) only, so logs without force
columns (a rig without a force sensor) are checked alike.

Exit code 0 when they do, 1 when they do not (a finding), 2 for bad input.
"""

from __future__ import annotations

import math
import sys
import time

from pgcomm.cli._common import add_common_options, add_data_options, add_out_option, add_motor_option, \
    motor_from_args, read_data_logs, require_data
from pgcomm.cli._output import check_out, input_paths, staged_output
from pgcomm.errors import ConfigError
from pgcomm.io.results import write_results

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("Check that logs persistently excite the model (paper's Remark): both signs of Delta, "
        "several force magnitudes, every position of the stroke. Exit code 1 when they do not.")

#: Exit code of ``pgcomm check`` when the data do not excite the model (2 stays "bad input").
EXIT_NOT_EXCITED = 1


def configure(p) -> None:
    """Options of ``pgcomm check``."""
    add_common_options(p, out=False, plant=False)
    add_data_options(p)
    add_motor_option(p, "drive-input logs are converted with k and zeta; Delta is measured against zeta")
    # dest is not "out": cli.main would stage it and discard the report when check exits with code 1
    add_out_option(p, dest="report_dir", required=False)
    p.add_argument("--bins", type=int, default=None, metavar="N",
                   help="position bins over the stroke (default 20, as identification checks)")
    p.add_argument("--range", type=float, nargs=2, metavar=("YMIN", "YMAX"),
                   help="stroke to cover (m); default: the span of all logs")


def run(args, out, progress) -> None:
    """Check ``--data``; print the report; with ``--out`` write ``results.json`` and ``coverage.png``."""
    from pgcomm import excitation, plots

    t0 = time.perf_counter()
    require_data(args)
    n_bins = excitation.DEFAULT_BINS if args.bins is None else args.bins
    if not 1 <= n_bins <= excitation.MAX_BINS:
        raise ConfigError(f"--bins {n_bins}: expected 1 to {excitation.MAX_BINS} position bins (each bin needs "
                          f"{excitation.MIN_SAMPLES} samples of each kind; default {excitation.DEFAULT_BINS})")
    if args.range is not None:
        lo, hi = args.range
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ConfigError(f"--range {lo:g} {hi:g}: need YMIN < YMAX (m)")
    if args.report_dir is not None:
        check_out(args.report_dir, args.overwrite, input_paths(args))  # before the work: a bad --out fails at once
    motor = motor_from_args(args)
    with progress.stage(f"read {len(args.data)} log pattern(s)"):
        logs = read_data_logs(args, progress)
        progress.info(f"{len(logs)} log(s), {sum(lg.n_samples for lg in logs)} samples")
    with progress.stage("excitation per coil set and position bin"):
        report = excitation.excitation_report(logs, motor, n_bins=n_bins, y_range=args.range)
    without = [lg.source for lg in logs if not lg.has_force]  # no force sensor: checked alike
    if args.report_dir is not None:
        results = {"command": "check", "motor": str(args.motor) if args.motor else "twin (default)",
                   "logs": [lg.source for lg in logs], "logs_without_force": without, "check": report.to_dict(),
                   "runtime_s": time.perf_counter() - t0}
        # staged here (not by cli.main) so that the report is kept when the data fail the check
        with staged_output(args.report_dir, args.overwrite, input_paths(args)) as tmp:
            plots.save(plots.plot_coverage(report), tmp / "coverage.png")
            write_results(tmp / "results.json", results)
    if not args.quiet:
        print(format_check(report))
        if without:
            print(f"{len(without)} of {len(logs)} log(s) have no force columns (no force sensor): the criterion needs "
                  "positions and currents only; pgcomm identify uses the motion for them (--no-force-sensor, "
                  "with the motor's mass)")
        if args.report_dir is not None:
            print(f"wrote {args.report_dir}/results.json, coverage.png")
    if not report.ok:
        bad = ", ".join(str(c.coil_set + 1) for c in report.coil_sets if not c.ok)
        print(f"pgcomm: check: the data do not persistently excite the model of coil set(s) {bad} "
              f"({len(report.problems)} problem(s))", file=sys.stderr)
        raise SystemExit(EXIT_NOT_EXCITED)



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
