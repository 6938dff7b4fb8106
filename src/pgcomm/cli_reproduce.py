"""``pgcomm reproduce``: the paper's experiment end to end, with figures and an HTML report."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from pgcomm.cli import _common, _print_mse, _setup, _write_results, command, print_calibration


def _configure(p):
    _common(p)
    p.add_argument("--quick", action="store_true",
                   help="shorter run for a first look (two velocities, fewer starts); under 30 s")
    p.add_argument("--reference", type=Path, help="extra evaluation reference (CSV with r[,t], or .mat with r)")
    p.add_argument("--reference-sample-time", type=float, help="sample time (s) of --reference if it has no t")


@command("reproduce", "The paper's experiment on the twin (or a force-map plant): calibration, PGNN "
                      "identification, all commutation laws in closed loop; report.html, results.json, figures.")
def cmd_reproduce(args, out: Path, progress):
    from dataclasses import replace

    import jax.numpy as jnp

    from pgcomm import __version__, plots, reproduce
    from pgcomm.cli import _reference
    from pgcomm.modelfile import save_model
    from pgcomm.report import write_report

    t0 = time.perf_counter()
    setup = _setup(args)
    if args.quick:
        setup = replace(setup, config=reproduce.quick_config(setup.config))
    extra = _reference(args, setup) if args.reference else None
    o = reproduce.run(setup, seed=args.seed, extra_reference=extra, progress=progress)
    results = o.results
    results.update(command="reproduce", version=__version__, quick=bool(args.quick), seed=args.seed)

    with progress.stage("figures, model file and report"):
        lp = setup.config.evaluation.lowpass_hz
        figs = {}

        def fig(name, f, caption):
            plots.save(f, out / name)
            figs[caption] = out / name

        fig("reference.png", plots.plot_reference(o.references["long"]),
            "Fig. Data_Generation: the reference used for the data sets and the long evaluation.")
        fig("mse.png", plots.plot_mse_bars({r: {d: results["commutation_mse"][r][d]["filtered"] for d in "yxz"}
                                            for r in reproduce.ROWS}),
            "Filtered commutation-error MSE per row and direction (log scale).")
        for rname, label in (("slow", "slow (0.025 m/s)"), ("fast", "fast (0.15 m/s)"), ("user", "user reference")):
            if rname in o.runs:
                fig(f"compare_{rname}.png", plots.plot_comparison(o.runs[rname], lp, title=f"{label} reference"),
                    f"Figs. CommutationError_Ref1/2: {label} reference — filtered commutation error in y, x, z "
                    "and tracking error, every row.")
        y = np.linspace(*_train_range(o.pgnn, setup), 2001)
        truth = np.asarray(setup.plant.cogging(jnp.asarray(y)))
        fig("cogging.png", plots.plot_cogging(y, np.asarray(o.pgnn.cogging(jnp.asarray(y))), truth),
            "Fig. Cogging_Force: identified cogging force (mean over coil sets) against the plant's truth.")
        gm = np.asarray(o.pgnn.gain(jnp.asarray(y)))
        gt = np.asarray(setup.plant.gain(jnp.asarray(y)))
        fig("gain_coilset1.png", plots.plot_gain_columns(y, gm[:, 0], gt[:, 0], 0),
            "Gain-matrix columns of coil set 1: PGNN against the plant's truth.")
        cal = o.calibration
        fig("calibration.png", plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta, setup.true_k,
                                                      setup.true_zeta),
            "Table Parameters_CLM: initial, calibrated and true k, zeta per coil set.")
        fy_max = float(np.max(np.abs(o.runs["long"]["pgnn"].f_star[:, 0])))
        save_model(out / "model", o.pgnn, {"seed": args.seed, "plant": setup.plant_name, "fy_abs_max": fy_max,
                                           "identification": results["identification"]})
        results["runtime_s"] = time.perf_counter() - t0
        _write_results(out / "results.json", results)
        write_report(out / "report.html", results, figs)
    if not args.quiet:
        print_calibration(results["calibration"])
        _print_mse(results, reproduce.ROWS)
        imp = results["improvement_over_classical"]["pgnn"]
        print(f"classical -> pgnn: y {imp['y']:.1f}x, x {imp['x']:.1f}x, z {imp['z']:.1f}x, "
              f"tracking {imp['tracking']:.1f}x  (paper: 11.2x, 2.5x, 2.4x, 4.6x)")
        print(f"wrote {args.out}/report.html, results.json, model.json/.npz and figures "
              f"({results['runtime_s']:.0f} s)", file=sys.stdout)


cmd_reproduce.configure = _configure


def _train_range(model, setup):
    rng = getattr(model, "training_range", None)
    if rng:
        return rng
    s = setup.config.reference.stroke
    return (-s, s)
