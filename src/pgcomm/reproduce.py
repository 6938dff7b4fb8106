"""The paper's whole experiment (§Experimental results) on a plant, with the comparison rows.

Steps (each a stage of the progress display):

1. data generation: ``Z_{1,2}^l`` for every coil set on the data-generation reference,
   drive at the initial ``k̂ = k0``, ``ζ̂ = ζ0``, ``Δ = ∓π/4``, no feedforward;
2. calibration (Algorithm 1) from the same data sets;
3. identification of the PGNN (Algorithm 2) and the physics-only model from them;
4. per commutation law, feedforward ``m, f_v, f_c`` identified in closed loop with that
   law, then evaluation on the long (data-generation), slow (0.025 m/s) and fast
   (0.15 m/s) references (and an optional user reference);
5. rows: original (uncalibrated), classical (calibrated), pgnn, physics, cogging_table and
   harmonic_cogging (classical plus a drive-style force offset learned from the classical
   residual), oracle (the plant's exact static inverse);
6. metrics: 50 Hz-filtered and unfiltered commutation-error MSE per direction, tracking-
   error MSE, and each row's share of the reducible error
   ``(classical - row) / (classical - oracle)``.
"""

from __future__ import annotations

import time
import zlib
from dataclasses import dataclass, replace

import numpy as np

from pgcomm import pipeline
from pgcomm.commutation import ClassicalLaw, ModelLaw, OffsetLaw, oracle_law
from pgcomm.compensation import fit_cogging_table, fit_harmonic_cogging
from pgcomm.experiment import ExperimentConfig, IdentificationConfig, Setup
from pgcomm.identify import CoilSetData, identify_all
from pgcomm.metrics import DIRECTIONS, lowpass, mse_difference_se, reducible_share
from pgcomm.models import CombinedModel

ROWS = ("original", "classical", "physics", "pgnn", "cogging_table", "harmonic_cogging", "oracle")

#: The paper's Table Commutation_Performance (filtered, unfiltered) and tracking-error MSE.
PAPER = {
    "commutation_mse": {
        "original": {"y": (52.8, 53.4), "x": (0.111, 0.234), "z": (0.327, 0.781)},
        "classical": {"y": (27.4, 28.1), "x": (0.141, 0.307), "z": (0.436, 1.13)},
        "pgnn": {"y": (2.45, 3.08), "x": (0.056, 0.223), "z": (0.180, 0.930)},
    },
    "tracking_mse": {"classical": 2.75e-8, "pgnn": 5.94e-9},
    "calibrated": {"k": (61.34, 61.62, 60.07), "zeta": (-0.54, -0.55, -0.55)},
}


def quick_config(config: ExperimentConfig) -> ExperimentConfig:
    """A shorter experiment for a first look and for tests: two velocities, short dwells,
    fewer random starts and iterations, two feedforward passes."""
    ref = replace(config.reference, velocities=(0.075, 0.15), dwell=0.2)
    ident = replace(config.identification, starts=2, max_iterations=25)
    ctrl = replace(config.controller, ff_iterations=2)
    return replace(config, reference=ref, identification=ident, controller=ctrl)


@dataclass
class ReproduceOutput:
    """Everything the experiment produced: results (JSON-ready), runs per reference and row, models."""

    results: dict
    runs: dict            # reference name -> {row: SimResult}
    references: dict      # reference name -> Reference
    pgnn: CombinedModel
    physics: CombinedModel
    calibration: object
    identification: list
    tables: dict          # "cogging_table" / "harmonic_cogging" -> offset pytree


def coil_set_data(datasets) -> list[CoilSetData]:
    """:class:`~pgcomm.identify.CoilSetData` per coil set from ``Z_{1,2}^l`` runs (measured positions, currents, forces)."""
    out = []
    for pair in datasets:
        l = pair[0].coil_set
        ys, cs, fs, ex = [], [], [], []
        for i, ds in enumerate(pair):
            r = ds.result
            ys.append(r.y_meas)
            cs.append(r.currents[:, l, :])
            fs.append(r.f_meas)
            ex.append(np.full(r.t.shape[0], i))
        out.append(CoilSetData(np.concatenate(ys), np.concatenate(cs), np.concatenate(fs), np.concatenate(ex),
                               name=f"coil set {l + 1}"))
    return out


def identify_models(setup: Setup, data: list[CoilSetData], seed: int, progress=None, check_data: bool = True):
    """Algorithm 2 for every coil set; returns ``(pgnn, physics, [IdentifyResult])``.

    ``check_data=False`` skips the excitation check (the caller ran it and chose to go on).
    """
    ic: IdentificationConfig = setup.config.identification
    show = None
    if progress is not None and progress.enabled:
        def show(info):
            if info["iteration"] % 10 == 0:
                progress.info(f"iteration {info['iteration']:3d}: best V = {info['best_cost']:.5g}, "
                              f"{info['active']}/{info['starts']} starts active")
    pgnn, res = identify_all(data, setup.motor.pole_pitch, seed=seed, progress=show,
                             gain_widths=tuple(ic.gain_widths), cog_widths=tuple(ic.cog_widths),
                             activation=ic.activation, Lambda=ic.regularisation, ridge_output=ic.ridge_output,
                             n_starts=ic.starts, max_iter=ic.max_iterations, tol=ic.tol,
                             validation_fraction=ic.validation_fraction, check_data=check_data)
    physics = CombinedModel.from_coil_sets([r.physics_model for r in res])
    return pgnn, physics, res


def identification_results(res, seconds_total: float) -> dict:
    """The ``identification.*`` keys of results.json."""
    return {"coil_sets": [r.to_dict() for r in res], "seconds_total": seconds_total}


def reference_seed(seed: int, reference_name: str) -> int:
    """Sensor-noise seed of an evaluation run: by reference, never by row (DESIGN.md, Noise).

    Every law sees the same noise on the same reference, so rows compare without noise
    spread, and adding a reference leaves the other references' numbers unchanged.
    """
    return seed + 100 + zlib.crc32(reference_name.encode()) % 100_000


def run(setup: Setup, seed: int = 0, extra_reference=None, progress=None) -> ReproduceOutput:
    """The whole experiment; see the module docstring. ``progress``: a :class:`pgcomm.progress.Progress`."""
    from pgcomm.progress import Progress

    progress = progress or Progress(enabled=False)
    cfg = setup.config
    motor = setup.motor
    refs = {"long": pipeline.data_generation_reference(setup),
            "slow": pipeline.single_velocity_reference(setup, min(cfg.reference.velocities)),
            "fast": pipeline.single_velocity_reference(setup, max(cfg.reference.velocities))}
    if extra_reference is not None:
        refs["user"] = extra_reference
    long_ref = refs["long"]

    with progress.stage(f"data generation: {motor.n_coil_sets} coil sets x 2 data sets (Delta = -/+"
                        f"{cfg.calibration.delta:.4f} rad), {len(long_ref.r)} samples each"):
        data0 = pipeline.generate(setup, long_ref, motor.k, motor.zeta, seed=seed)

    with progress.stage("calibration (Algorithm 1)"):
        cal, _ = pipeline.run_calibration(setup, long_ref, seed=seed, progress=progress, first=data0)

    with progress.stage("identification (Algorithm 2): PGNN and physics-only model per coil set"):
        t_id = time.perf_counter()
        pgnn, physics, id_res = identify_models(setup, coil_set_data(data0), seed, progress)
        t_id = time.perf_counter() - t_id
        for r in id_res:
            progress.info(f"{r.name}: V physics {r.cost_physics:.4g} -> PGNN {r.cost_pgnn:.4g} (train), "
                          f"{r.cost_physics_validation:.4g} -> {r.cost_pgnn_validation:.4g} (validation), "
                          f"{r.seconds:.1f} s")

    limit = motor.current_limit
    laws = {"original": ClassicalLaw.from_motor(motor),
            "classical": ClassicalLaw.from_motor(motor, k=cal.k, zeta=cal.zeta),
            "physics": ModelLaw(physics, current_limit=limit),
            "pgnn": ModelLaw(pgnn, current_limit=limit),
            "oracle": oracle_law(setup.plant, current_limit=limit)}

    with progress.stage(f"feedforward identification per law ({cfg.controller.ff_iterations} closed-loop passes)"):
        names = list(laws)
        ffs = dict(zip(names, pipeline.tune_feedforward(setup, [laws[n] for n in names], long_ref, seed=seed + 50)))

    with progress.stage("drive-style rows: anti-cogging table and harmonic fit from the classical residual"):
        run_c = pipeline.run_laws(setup, [laws["classical"]], long_ref, [ffs["classical"]], seeds=[seed + 60])[0]
        residual = run_c.f_meas[:, 0] - run_c.f_star[:, 0]
        stroke = (-cfg.reference.stroke, cfg.reference.stroke)
        tables = {"cogging_table": fit_cogging_table(run_c.y_meas, residual, cfg.evaluation.cogging_table_entries,
                                                     stroke),
                  "harmonic_cogging": fit_harmonic_cogging(run_c.y_meas, residual, motor.pole_pitch,
                                                           cfg.evaluation.harmonics)}
        for name, tab in tables.items():
            laws[name] = OffsetLaw(laws["classical"], tab)
        extra = ["cogging_table", "harmonic_cogging"]
        ffs.update(zip(extra, pipeline.tune_feedforward(setup, [laws[n] for n in extra], long_ref, seed=seed + 70)))

    runs: dict = {k: {} for k in refs}
    with progress.stage(f"closed-loop evaluation: {len(ROWS)} laws x {len(refs)} references"):
        jobs = [(row, rname) for row in ROWS for rname in refs]
        out = pipeline.run_laws(setup, [laws[row] for row, _ in jobs], [refs[rn] for _, rn in jobs],
                                [ffs[row] for row, _ in jobs], seeds=[reference_seed(seed, rn) for _, rn in jobs])
        for (row, rname), res in zip(jobs, out):
            runs[rname][row] = res

    lp = cfg.evaluation.lowpass_hz
    results = _results(setup, cal, id_res, t_id, runs, ffs, tables, lp)
    return ReproduceOutput(results, runs, refs, pgnn, physics, cal, id_res, tables)


def _reducible_se(classical, oracle, lowpass_hz: float) -> dict:
    """Standard errors of ``classical - oracle`` per direction (filtered) and for tracking."""
    ts = classical.sample_time
    # blocks of ~20 filter time constants (at least 0.1 s): block means nearly independent
    block = max(int(round(20.0 / (2 * np.pi * lowpass_hz * ts))), int(round(0.1 / ts)))
    fc = lowpass(classical.f_meas - classical.f_star, ts, lowpass_hz)
    fo = lowpass(oracle.f_meas - oracle.f_star, ts, lowpass_hz)
    se = {d: mse_difference_se(fc[:, q], fo[:, q], block) for q, d in enumerate(DIRECTIONS)}
    se["tracking"] = mse_difference_se(classical.e, oracle.e, block)
    return se


def _results(setup, cal, id_res, t_id, runs, ffs, tables, lowpass_hz) -> dict:
    from pgcomm.cli import calibration_results

    out: dict = {"plant": setup.plant_name, "calibration": calibration_results(setup, cal),
                 "identification": identification_results(id_res, t_id)}
    per_ref = {}
    for rname, rows in runs.items():
        m = {row: pipeline.run_metrics(res, lowpass_hz) for row, res in rows.items()}
        per_ref[rname] = {"commutation_mse": {row: v["commutation_mse"] for row, v in m.items()},
                          "tracking_mse": {row: v["tracking_mse"] for row, v in m.items()}}
    # the paper's table is on the long (data-generation) reference
    out["commutation_mse"] = per_ref["long"]["commutation_mse"]
    out["tracking_mse"] = per_ref["long"]["tracking_mse"]
    out["references"] = per_ref
    cm, tm = out["commutation_mse"], out["tracking_mse"]
    se = _reducible_se(runs["long"]["classical"], runs["long"]["oracle"], lowpass_hz)
    share = {}
    for row in ROWS:
        share[row] = {d: reducible_share(cm[row][d]["filtered"], cm["classical"][d]["filtered"],
                                         cm["oracle"][d]["filtered"], se[d]) for d in DIRECTIONS}
        share[row]["tracking"] = reducible_share(tm[row], tm["classical"], tm["oracle"], se["tracking"])
    out["reducible_share"] = share
    out["improvement_over_classical"] = {
        row: {**{d: cm["classical"][d]["filtered"] / cm[row][d]["filtered"] for d in DIRECTIONS},
              "tracking": tm["classical"] / tm[row]} for row in ROWS}
    out["feedforward"] = {row: {"mass": ff.mass, "viscous": ff.viscous, "coulomb": ff.coulomb}
                          for row, ff in ffs.items()}
    out["tables"] = {"cogging_table": {"entries": int(tables["cogging_table"].values.shape[0]),
                                       "bytes": tables["cogging_table"].nbytes},
                     "harmonic_cogging": {"harmonics": (int(tables["harmonic_cogging"].coef.shape[0]) - 1) // 2}}
    out["paper"] = PAPER
    return out


__all__ = ["ROWS", "PAPER", "run", "quick_config", "coil_set_data", "identify_models"]
