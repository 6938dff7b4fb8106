"""``pgcomm reproduce``: the paper's experiment end to end, with figures and an HTML report."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_reference_options, motor_is_rotary, print_calibration, \
    print_mse, reference_from_args, refuse_conflicts, settings_given, setup_from_args

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
    from dataclasses import replace

    import jax.numpy as jnp
    import numpy as np

    from pgcomm import __version__, plots, reproduce
    from pgcomm.io.model import save_model
    from pgcomm.io.results import write_results
    from pgcomm.report.linear import figure_captions, write_report

    t0 = time.perf_counter()
    if motor_is_rotary(args):
        return _run_rotary(args, out, progress, t0)
    for flag, given in (("--log-budget", args.log_budget is not None), ("--until-resolved", args.until_resolved)):
        if given:
            from pgcomm.errors import ConfigError
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

    with progress.stage("figures, model file and report"):
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
        y = np.linspace(*_train_range(o.pgnn, setup), 2001)
        truth = np.asarray(setup.plant.cogging(jnp.asarray(y)))
        fig("cogging.png", plots.plot_cogging(y, np.asarray(o.pgnn.cogging(jnp.asarray(y))), truth,
                                              title="cogging force identified by the PGNN (mean over coil sets)"))
        gm = np.asarray(o.pgnn.gain(jnp.asarray(y)))
        gt = np.asarray(setup.plant.gain(jnp.asarray(y)))
        fig("gain_coilset1.png", plots.plot_gain_columns(y, gm[:, 0], gt[:, 0], 0, label="PGNN"))
        cal = o.calibration
        fig("calibration.png", plots.plot_calibration(cal.k_initial, cal.zeta_initial, cal.k, cal.zeta, setup.true_k,
                                                      setup.true_zeta))
        fy_max = float(np.max(np.abs(o.runs["long"]["pgnn"].f_star[:, 0])))
        if o.spline is not None:
            ys = np.asarray(o.spline.model.gain_knots)
            yy = np.linspace(ys[0], ys[-1], 2001)
            truth_c = np.asarray(setup.plant.cogging(jnp.asarray(yy)))
            fig("cogging_spline.png", plots.plot_cogging(yy, np.asarray(o.spline.model.cogging(jnp.asarray(yy))),
                                                         truth_c, title="cogging force of the spline model",
                                                         label="spline model"))
            gs = np.asarray(o.spline.model.gain(jnp.asarray(yy)))
            gts = np.asarray(setup.plant.gain(jnp.asarray(yy)))
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
    from pgcomm.errors import ConfigError
    from pgcomm.io.model import rotary_model_from_dict
    from pgcomm.rotary.zoo import truth_from_identification

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


def _run_rotary(args, out: Path, progress, t0: float) -> None:
    """``pgcomm reproduce --motor rotary.toml``: :mod:`pgcomm.rotary.experiment` on the rotary twin.

    The twin's truth is ``--truth`` (a ``truth.json``, or an identified ``model.json`` with its ``results.json``: your
    motor as identified, :func:`_truth_from_identified`) or ``truth.json`` beside the motor file (the zoo writes one),
    else drawn from the description with ``--seed``.
    """
    from pgcomm import __version__
    from pgcomm.errors import ConfigError
    from pgcomm.io.config import load_rotary_motor
    from pgcomm.rotary import experiment as rexp
    from pgcomm.io.rotary_zoo import read_truth
    from pgcomm.rotary.zoo import default_truth

    for opt in ("plant", "config", "reference"):
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
        from dataclasses import replace
        truth = replace(truth, motor=motor)
        source = str(truth_path)
    else:
        truth = default_truth(motor, seed=args.seed)
        source = f"drawn from the description (seed {args.seed})"
    progress.info(f"rotary {motor.name}: twin truth {source}"
                  + (f"; its drive controls {truth.control_per_log} times per logged sample"
                     if truth.control_per_log > 1 else ""))
    settings = rexp.quick_settings() if args.quick else rexp.RotarySettings()
    settings = _log_budget(args, settings, motor.sample_time)
    results = rexp.run(truth, settings, seed=args.seed, progress=progress)
    results.update(command="reproduce", kind="rotary", version=__version__, quick=bool(args.quick), seed=args.seed,
                   truth_source=source)
    results["runtime_s"] = time.perf_counter() - t0
    with progress.stage("results.json, model.json, table.csv, figure"):
        _write_rotary_outputs(out, results, truth)
    if not args.quiet:
        _print_rotary(results)
        print(f"wrote {args.out}/results.json, model.json, table.csv, compensation.csv, rotary.png, report.html ({results['runtime_s']:.0f} s)")


def _log_budget(args, settings, sample_time: float):
    """``settings`` with ``--log-budget`` (rig s, turned into a share of the sweep's time) and ``--until-resolved``."""
    from dataclasses import replace

    from pgcomm.errors import ConfigError

    if args.log_budget is not None:
        if not (args.log_budget > 0 and args.log_budget < float("inf")):
            raise ConfigError(f"--log-budget {args.log_budget:g}: give the running logs' rig time in seconds, above 0")
        settings = replace(settings, log_budget_share=args.log_budget / settings.standstill.duration(sample_time))
    return replace(settings, stop_when_resolved=bool(args.until_resolved))


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
    import json
    import math

    import numpy as np

    from pgcomm import plots
    from pgcomm.io.atomic import atomic_open, atomic_write_text
    from pgcomm.io.results import write_results

    out = Path(out)
    models = results.pop("models")
    model, tm, table = models["model"], models["truth"], models["table"]
    from dataclasses import replace

    # as identify writes it: the motor and its current limit travel with the model (export --format c-rotary)
    saved = replace(model, info={**model.info, "motor": truth.motor.name, "current_limit": truth.motor.current_limit})
    atomic_write_text(out / "model.json", json.dumps(saved.to_dict(), indent=1) + "\n")
    n = table.size
    th = 2 * math.pi * np.arange(n) / n
    with atomic_open(out / "table.csv") as f:
        f.write("theta,standstill_table,model_table,model_forward,model_reverse\n")
        np.savetxt(f, np.column_stack([th, table, model.table(n), model.table(n, +1), model.table(n, -1)]),
                   delimiter=",", fmt="%.9g")
    from pgcomm.export.angle_table import make_table, write_angle_table

    # the model's table (both directions averaged, as the drives hold it) in the format pgcomm export
    # --table reads: reproduce -> export moteus|odrive|c-angle without a conversion step
    write_angle_table(out / "compensation.csv", make_table(model.table(n), "model from running logs",
                                                          current_limit=truth.motor.current_limit),
                      comments=(f"pgcomm rotary model of {truth.motor.name}, identified from running logs "
                                "without a torque sensor; forward and reverse averaged",))
    write_results(out / "results.json", results)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(3, 1, figsize=(10, 9))
    ax[0].plot(th, table, lw=0.6, label="standstill table (drives' method)")
    ax[0].plot(th, model.table(n), lw=0.8, label="model from running logs")
    ax[0].plot(th, tm.table(n), "k--", lw=0.6, label="truth")
    ax[0].set_ylabel("compensating $i_q$ [A]")
    ax[0].legend(fontsize=8)
    ax[1].plot(th, 100 * model.ripple(th), label="identified")
    ax[1].plot(th, 100 * tm.ripple(th), "k--", label="truth")
    ax[1].set_ylabel("torque-constant ripple [%]")
    ax[1].set_xlabel("mechanical angle θ [rad]")
    ax[1].legend(fontsize=8)
    rows = list(results["tracking_mse"])
    x = np.arange(len(rows))
    for k, loop in enumerate(("position", "speed")):
        vals = [results["tracking_mse"][r][loop] / results["tracking_mse"]["classical"][loop] for r in rows]
        ax[2].bar(x + 0.4 * k, vals, 0.4, label=f"{loop} loop")
    ax[2].set_xticks(x + 0.2, rows)
    ax[2].set_yscale("log")
    ax[2].set_ylabel("tracking MSE / classical")
    ax[2].legend(fontsize=8)
    fig.suptitle(f"rotary {truth.motor.name}: identification and tracking")
    plots.save(fig, out / "rotary.png")
    from pgcomm.report.rotary import write_rotary_report

    write_rotary_report(out / "report.html", results, {
        "Top: the compensating q current over one revolution, from the standstill sweep, from the model identified "
        "from running logs, and the truth. Middle: the torque-constant ripple, identified and true. Bottom: each "
        "row's tracking MSE over classical commutation's, position and speed loop (log scale).": out / "rotary.png"},
        version=str(results.get("version", "")))
    return ["results.json", "model.json", "table.csv", "compensation.csv", "rotary.png", "report.html"]
