"""``pgcomm reproduce``: the paper's experiment end to end, with figures and an HTML report."""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from pgcomm.cli._common import add_common_options, add_reference_options, motor_is_rotary, print_calibration, \
    print_mse, reference_from_args, refuse_conflicts, settings_given, setup_from_args
from pgcomm.errors import ConfigError
from pgcomm.io.results import write_results

# Imports inside the functions below: JAX, SciPy and Matplotlib load only when the command runs; every
# command's parser is built by `import pgcomm.cli`, which loads none of them (`--help` and a bad option answer at once).

HELP = ("The paper's experiment on the twin (or a force-map plant): calibration, PGNN "
        "identification, all commutation laws in closed loop; report.html, results.json, figures.")


def configure(p) -> None:
    """Options of ``pgcomm reproduce``."""
    add_common_options(p)
    p.add_argument("--quick", action="store_true",
                   help="shorter run for a first look (two velocities, fewer starts); under 30 s")
    p.add_argument("--log-budget", type=float, metavar="SECONDS",
                   help="rotary --motor: the running logs may take this much rig time (s; default half the "
                        "standstill sweep's)")
    p.add_argument("--until-resolved", action="store_true",
                   help="rotary --motor: stop logging once the cogging and the ripple are resolved (their standard "
                        "errors within 5 %% of their RMS), within --log-budget; default: log the whole budget")
    add_reference_options(p, "extra evaluation reference (CSV with r[,t], or .mat with r)")


def run(args, out: Path, progress) -> None:
    """Run the experiment; write ``report.html``, ``results.json``, ``model.json/.npz`` and the figures."""
    import jax.numpy as jnp

    from pgcomm import __version__, plots, reproduce
    from pgcomm.io.model import save_model
    from pgcomm.report.linear import figure_captions, write_report

    t0 = time.perf_counter()
    if motor_is_rotary(args):
        from pgcomm.cli._reproduce_rotary import run_rotary

        return run_rotary(args, out, progress, t0)
    for flag, given in (("--log-budget", args.log_budget is not None), ("--until-resolved", args.until_resolved)):
        if given:
            raise ConfigError(f"{flag}: only for a rotary motor (a --motor TOML with kind = \"rotary\"); a linear "
                              "motor's data sets are sized by its config")
    if args.quick and args.config:
        refuse_conflicts("--quick", settings_given(args.config, reproduce.QUICK_OVERRIDES),
                         "overrides (a quick run keeps the two fastest velocities, dwell at most 0.2 s, 2 starts of 25 "
                         "iterations, 2 feedforward passes)")
    setup = setup_from_args(args)
    if args.quick:
        beside = Path(args.plant).parent / "config.toml" if (args.plant and not args.config) else None
        if beside is not None and beside.is_file() and not args.quiet:
            shortened = settings_given(beside, reproduce.QUICK_OVERRIDES)
            if shortened:  # settings the user did not name: said, not refused
                print(f"pgcomm: --quick shortens {', '.join(k.split(' ', 1)[1] for k in shortened)} of {beside}",
                      file=sys.stderr)
        setup = replace(setup, config=reproduce.quick_config(setup.config))
    extra = reference_from_args(args, setup) if args.reference else None
    o = reproduce.run(setup, seed=args.seed, extra_reference=extra, progress=progress)
    results = o.to_dict()
    results.update(command="reproduce", version=__version__, quick=bool(args.quick), seed=args.seed)

    # the figures evaluate the models and laws the closed-loop step compiled: its programs are kept
    with progress.stage("figures, model file and report", release=False):
        lp = setup.config.evaluation.lowpass_hz
        figs = {}
        captions = figure_captions(o, results)

        def fig(name, f):
            plots.save(f, out / name)
            figs[captions[name]] = out / name

        fig("reference.png", plots.plot_reference(o.references["long"]))
        fig("mse.png", plots.plot_mse_bars({r: {d: o.commutation_mse[r][d]["filtered"] for d in "yxz"}
                                            for r in o.rows},
                                           title=f"commutation-error MSE per row, {lp:g} Hz low-pass, long reference"))
        velocities = setup.config.reference.velocities
        labels = {"slow": f"slow reference ({min(velocities):g} m/s)", "fast": f"fast reference ({max(velocities):g} m/s)",
                  "user": "user reference"}
        for rname, label in labels.items():
            if rname in o.runs:
                fig(f"compare_{rname}.png", plots.plot_comparison(o.runs[rname], lp, title=label))
        # one compiled program per model class (the diagnostics compiled them for the same number of
        # positions); op by op, each curve compiled dozens of small programs
        def gain_and_cogging(model, positions):
            return tuple(np.asarray(a) for a in reproduce.gain_and_cogging(model, jnp.asarray(positions)))

        y = np.linspace(*_train_range(o.pgnn, setup), 2001)
        gm, cm = gain_and_cogging(o.pgnn, y)
        gt, truth = gain_and_cogging(setup.plant, y)
        fig("cogging.png", plots.plot_cogging(y, cm, truth,
                                              title="cogging force identified by the PGNN (mean over coil sets)"))
        fig("gain_coilset1.png", plots.plot_gain_columns(y, gm[:, 0], gt[:, 0], 0, label="PGNN"))
        cal = o.calibration
        fig("calibration.png", plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta, setup.true_k,
                                                      setup.true_zeta))
        fy_max = float(np.max(np.abs(o.runs["long"]["pgnn"].f_star[:, 0])))
        if o.spline is not None:
            ys = np.asarray(o.spline.model.gain_knots)
            yy = np.linspace(ys[0], ys[-1], 2001)
            gs, cs = gain_and_cogging(o.spline.model, yy)
            gts, truth_c = gain_and_cogging(setup.plant, yy)
            fig("cogging_spline.png", plots.plot_cogging(yy, cs, truth_c, title="cogging force of the spline model",
                                                         label="spline model"))
            fig("gain_spline_coilset1.png", plots.plot_gain_columns(yy, gs[:, 0], gts[:, 0], 0, label="spline model"))
        if o.spline is not None:
            save_model(out / "spline_model", o.spline.model,
                       {"seed": args.seed, "plant": setup.plant_name, "fy_abs_max": fy_max,
                        "current_limit": setup.motor.current_limit,
                        "identification": {"spline": results["identification"].get("spline")}},
                       mechanics=o.mechanics)
        from pgcomm.io.model import drive_metadata

        # the law's limit and the drive's calibrated commutation, which every export then uses by default
        save_model(out / "model", o.pgnn, {"seed": args.seed, "plant": setup.plant_name, "fy_abs_max": fy_max,
                                           "current_limit": setup.motor.current_limit,
                                           "drive": drive_metadata(cal.k, cal.zeta, "calibrated by Algorithm 1 "
                                                                   "(pgcomm reproduce)"),
                                           "identification": results["identification"]})
        results["runtime_s"] = time.perf_counter() - t0
        write_results(out / "results.json", results)
        write_report(out / "report.html", o, figs, version=__version__, runtime_s=results["runtime_s"])
    if not args.quiet:
        print_calibration(results["calibration"])
        print_mse(results, results["tracking_order"])
        rec = results["recommended"]
        print(f"recommended: {rec['row']} — {rec['reason']}; tracking MSE long/slow/fast "
              + "/".join(f"{v:.3g}" for v in rec["tracking_mse_by_reference"].values())
              + f" m²; tables {rec['table_bytes']} bytes")
        imp = results["improvement_over_classical"]["pgnn"]
        paper = reproduce.paper_improvement("pgnn")
        print(f"classical -> pgnn: y {imp['y']:.1f}x, x {imp['x']:.1f}x, z {imp['z']:.1f}x, "
              f"tracking {imp['tracking']:.1f}x  (paper: {paper['y']:.1f}x, {paper['x']:.1f}x, {paper['z']:.1f}x, "
              f"{paper['tracking']:.1f}x)")
        print(f"wrote {args.out}/report.html, results.json, model.json/.npz (PGNN), spline_model.json/.npz "
              "(spline model with its mechanics) and figures "
              f"({results['runtime_s']:.0f} s)", file=sys.stdout)


def _train_range(model, setup):
    rng = getattr(model, "training_range", None)
    if rng:
        return rng
    return setup.config.reference.span
