"""``pgcomm identify``: Algorithm 2 on data sets generated on the plant, or on logs (``--data``)."""

from __future__ import annotations

import time
from pathlib import Path

from pgcomm.cli._common import add_common_options, add_data_options, read_data_logs, setup_from_args

HELP = ("Algorithm 2: identify the PGNN (and the physics-only model) of every coil set; "
        "writes model.json/.npz, results.json and figures.")


def configure(p) -> None:
    """Options of ``pgcomm identify``."""
    add_common_options(p)
    add_data_options(p)
    p.add_argument("--force", action="store_true", help="identify even if the excitation check fails (warn only)")


def run(args, out: Path, progress) -> None:
    """Identify; write ``model.json/.npz``, ``results.json``, ``cogging.png`` and ``gain_coilset{l}.png``."""
    import jax.numpy as jnp
    import numpy as np

    from pgcomm import __version__, experiment, plots
    from pgcomm.data import coil_set_data_from_logs, coil_set_data_from_runs
    from pgcomm.errors import ExcitationError
    from pgcomm.excitation import check_excitation
    from pgcomm.io.model import save_model
    from pgcomm.io.results import write_results

    t0 = time.perf_counter()
    setup = setup_from_args(args)
    if args.data:
        with progress.stage(f"read {len(args.data)} log pattern(s)"):
            logs = read_data_logs(args)
            data = coil_set_data_from_logs(logs, setup.motor)
            progress.info(f"{len(logs)} log(s), {sum(d.n for d in data)} samples")
        source = "logs"
    else:
        ref = experiment.data_generation_reference(setup)
        with progress.stage(f"data generation on {setup.plant_name}: {setup.motor.n_coil_sets} coil sets x 2 data "
                            f"sets, {len(ref.r)} samples each"):
            data = coil_set_data_from_runs(experiment.generate(setup, ref, setup.motor.k, setup.motor.zeta,
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
        pgnn, _, res = experiment.identify_models(setup, data, args.seed, progress, check_data=False)
        t_id = time.perf_counter() - t_id
    results = {"command": "identify", "plant": setup.plant_name, "data": source, "version": __version__,
               "seed": args.seed, "identification": experiment.identification_results(res, t_id)}
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
    write_results(out / "results.json", results)
    if not args.quiet:
        print(f"{'coil set':24s} {'V physics':>10s} {'V PGNN':>10s} {'V phys val':>10s} {'V PGNN val':>10s} {'s':>6s}")
        for r in res:
            print(f"{r.name[:24]:24s} {r.cost_physics:10.4g} {r.cost_pgnn:10.4g} {r.cost_physics_validation:10.4g} "
                  f"{r.cost_pgnn_validation:10.4g} {r.seconds:6.1f}")
        print(f"wrote {args.out}/model.json, model.npz, results.json, cogging.png, gain_coilset*.png")
