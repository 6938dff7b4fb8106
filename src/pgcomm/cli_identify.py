"""``pgcomm identify``: Algorithm 2 on data sets generated on the plant, or on logs (``--data``)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from pgcomm.cli import _common, _setup, _write_results, command


def add_data_options(p) -> None:
    """``--data`` / ``--columns`` / ``--sample-time`` for commands reading logs."""
    p.add_argument("--data", nargs="+", metavar="LOG", help="log files or globs (CSV, Parquet, .mat, HDF5)")
    p.add_argument("--columns", type=Path, metavar="MAP.toml", help="column-mapping TOML (names and units)")
    p.add_argument("--sample-time", type=float, help="sample time (s) for logs without a t column")


def read_data_logs(args):
    """Logs named by ``--data`` (with ``--columns`` and ``--sample-time``)."""
    from pgcomm.io.logs import load_column_mapping, read_logs

    mapping = load_column_mapping(args.columns) if args.columns else None
    return read_logs(args.data, sample_time=args.sample_time, columns=mapping)


def _configure(p):
    _common(p)
    add_data_options(p)
    p.add_argument("--force", action="store_true", help="identify even if the excitation check fails (warn only)")


@command("identify", "Algorithm 2: identify the PGNN (and the physics-only model) of every coil set; "
                     "writes model.json/.npz, results.json and figures.")
def cmd_identify(args, out: Path, progress):
    import jax.numpy as jnp

    from pgcomm import __version__, pipeline, plots, reproduce
    from pgcomm.errors import ExcitationError
    from pgcomm.identify import check_excitation
    from pgcomm.logdata import coil_set_data_from_logs
    from pgcomm.modelfile import save_model

    t0 = time.perf_counter()
    setup = _setup(args)
    if args.data:
        with progress.stage(f"read {len(args.data)} log pattern(s)"):
            logs = read_data_logs(args)
            data = coil_set_data_from_logs(logs, setup.motor)
            progress.info(f"{len(logs)} log(s), {sum(d.n for d in data)} samples")
        source = "logs"
    else:
        ref = pipeline.data_generation_reference(setup)
        with progress.stage(f"data generation on {setup.plant_name}: {setup.motor.n_coil_sets} coil sets x 2 data "
                            f"sets, {len(ref.r)} samples each"):
            data = reproduce.coil_set_data(pipeline.generate(setup, ref, setup.motor.k, setup.motor.zeta,
                                                             seed=args.seed))
        source = setup.plant_name
    problems = {d.name: check_excitation(d, setup.motor.pole_pitch) for d in data}
    bad = {k: v for k, v in problems.items() if v}
    if bad:
        msg = "; ".join(f"{k}: {', '.join(v)}" for k, v in bad.items())
        if not args.force:
            raise ExcitationError(f"data do not persistently excite the model ({msg}); use --force to identify anyway")
        progress.info(f"warning: {msg}")
    with progress.stage("identification (Algorithm 2) per coil set"):
        t_id = time.perf_counter()
        # the check above already ran (and, with --force, only warned)
        pgnn, _, res = reproduce.identify_models(setup, data, args.seed, progress, check_data=False)
        t_id = time.perf_counter() - t_id
    results = {"command": "identify", "plant": setup.plant_name, "data": source, "version": __version__,
               "seed": args.seed, "identification": reproduce.identification_results(res, t_id)}
    save_model(out / "model", pgnn, {"seed": args.seed, "plant": setup.plant_name, "data": source,
                                     "fy_abs_max": max(float(np.max(np.abs(d.force[:, 0]))) for d in data),
                                     "identification": results["identification"]})
    y = np.linspace(*pgnn.training_range, 2001)
    known = source != "logs" or args.plant is None
    truth_cog = np.asarray(setup.plant.cogging(jnp.asarray(y))) if known else None
    plots.save(plots.plot_cogging(y, np.asarray(pgnn.cogging(jnp.asarray(y))), truth_cog), out / "cogging.png")
    gm = np.asarray(pgnn.gain(jnp.asarray(y)))
    gt = np.asarray(setup.plant.gain(jnp.asarray(y))) if known else None
    for l in range(pgnn.n_coil_sets):
        plots.save(plots.plot_gain_columns(y, gm[:, l], None if gt is None else gt[:, l], l),
                   out / f"gain_coilset{l + 1}.png")
    results["runtime_s"] = time.perf_counter() - t0
    _write_results(out / "results.json", results)
    if not args.quiet:
        print(f"{'coil set':24s} {'V physics':>10s} {'V PGNN':>10s} {'V phys val':>10s} {'V PGNN val':>10s} {'s':>6s}")
        for r in res:
            print(f"{r.name[:24]:24s} {r.cost_physics:10.4g} {r.cost_pgnn:10.4g} {r.cost_physics_validation:10.4g} "
                  f"{r.cost_pgnn_validation:10.4g} {r.seconds:6.1f}")
        print(f"wrote {args.out}/model.json, model.npz, results.json, cogging.png, gain_coilset*.png")


cmd_identify.configure = _configure
