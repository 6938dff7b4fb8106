"""The paper's experiment, step by step, on a resolved :class:`~pgcomm.setup.Setup`.

Each step takes a set-up and returns plain results (nothing here prints except through an
optional :class:`pgcomm.progress.Progress`): the paper's references
(:func:`data_generation_reference`, :func:`single_velocity_reference`), data sets ``Z_i^l``
(:func:`generate`), Algorithm 1 (:func:`run_calibration`, :func:`calibration_results`),
Algorithm 2 for every coil set (:func:`identify_models`, :func:`identify_sensorless_models`,
:func:`identify_direction_models`, :func:`identify_spline_models`, :func:`identification_results`),
feedforward per law (:func:`tune_feedforward`), closed-loop runs (:func:`run_laws`) and their
metrics (:func:`run_metrics`). The CLI commands and :mod:`pgcomm.reproduce` use them.

Where the pieces are: the settings schema is :mod:`pgcomm.settings`, the set-up and its checks
:mod:`pgcomm.setup` (also reading one from files), and the drives' sensorless
anti-cogging table :mod:`pgcomm.sensorless_table`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import jax

from pgcomm import trajectory
from pgcomm.calibration import CalibrationResult, calibrate
from pgcomm.control import Feedforward, identify_feedforward
from pgcomm.data import CoilSetData, generate_datasets
from pgcomm.identify import identify, identify_all
from pgcomm.metrics import commutation_mse, tracking_mse
from pgcomm.models import CombinedModel
from pgcomm.seeds import stream_seed
from pgcomm.setup import build_setup, sensorless_mass, Setup
from pgcomm.simulate import SimResult, simulate_many
from pgcomm.identify.mechanics import identify_mechanics
from pgcomm.identify.spline import identify_spline, SplineOptions
from pgcomm.io.config import load_experiment
from pgcomm.io.logs import write_datasets
from pgcomm.sensorless import sensorless_data, with_classical_rows

__all__ = ["data_generation_reference", "single_velocity_reference", "generate", "run_calibration",
           "tune_feedforward", "run_laws", "run_metrics", "calibration_results", "identify_models",
           "identify_sensorless_models", "identify_spline_models", "identify_direction_models",
           "identification_results", "write_production_logs"]




def data_generation_reference(setup: Setup) -> trajectory.Reference:
    """The paper's data-generation reference (Fig. Data_Generation) for this set-up."""
    rc = setup.config.reference
    ref = trajectory.data_generation_reference(setup.motor.sample_time, rc.stroke, rc.velocities, rc.a_max,
                                               rc.j_max, rc.dwell)
    return replace(ref, r=ref.r + rc.center) if rc.center else ref


def single_velocity_reference(setup: Setup, v_max: float) -> trajectory.Reference:
    """One back-and-forth over the stroke at ``v_max`` (m/s): the paper's slow/fast references."""
    rc = setup.config.reference
    ref = trajectory.single_velocity_reference(v_max, setup.motor.sample_time, rc.stroke, rc.a_max, rc.j_max,
                                               rc.dwell)
    return replace(ref, r=ref.r + rc.center) if rc.center else ref


def generate(setup: Setup, reference, k_hat, zeta_hat, seed: int = 0, coil_sets=None):
    """Data sets ``Z_{1,2}^l`` with the drive at ``k̂`` (L,) N/A and ``ζ̂`` (L,) rad (no feedforward)."""
    drive = setup.motor.with_nominal(k=tuple(np.asarray(k_hat, float)), zeta=tuple(np.asarray(zeta_hat, float)))
    return generate_datasets(setup.plant, drive, reference, delta=setup.config.calibration.delta, loop=setup.loop,
                             seed=seed, coil_sets=coil_sets)


def run_calibration(setup: Setup, reference, seed: int = 0, progress=None, first=None,
                    sensorless: bool = False) -> tuple[CalibrationResult, list]:
    """Algorithm 1 from the set-up's initial ``k0``, ``ζ0``; returns the result and the last data sets.

    ``first``: data sets already generated at ``k0``, ``ζ0`` (used for the first pass).
    ``sensorless``: no force data (:func:`pgcomm.calibration.fit_coefficients` method
    ``"sensorless"`` with the moving mass :func:`sensorless_mass`).
    """
    cc = setup.config.calibration
    last = {"calls": 0}

    def gen(k, zeta):
        if last["calls"] == 0 and first is not None:
            last["data"] = first
        else:
            # pass 0 is the data set of the run's seed (what reproduce and --save-data write); later
            # passes draw their own named streams
            last["data"] = generate(setup, reference, k, zeta, seed=(seed if last["calls"] == 0 else
                                    stream_seed(seed, "calibration pass", last["calls"])))
        last["calls"] += 1
        return last["data"]

    def report(it, k, zeta):
        if progress:
            progress.info(f"pass {it}: k = {np.array2string(k, precision=3)} N/A, "
                          f"zeta = {np.array2string(zeta, precision=4)} rad")

    cal = calibrate(gen, np.asarray(setup.motor.k), np.asarray(setup.motor.zeta),
                    cc.options(method="sensorless") if sensorless else cc.options(),
                    pole_pitch=setup.motor.pole_pitch, mass=sensorless_mass(setup) if sensorless else None,
                    progress=report)
    return cal, last["data"]



def tune_feedforward(setup: Setup, laws: list, reference, seed: int = 0) -> list[Feedforward]:
    """Feedforward ``m, f_v, f_c`` per law, identified from closed-loop data with that law.

    Iterated ``controller.ff_iterations`` times: each pass runs the loop with the previous
    estimate (the first with none) and refits :func:`pgcomm.control.identify_feedforward`
    on the demanded force; with the feedforward in the loop the feedback lag no longer
    biases the mass estimate. Laws of the same type are simulated batched. Pass ``it`` of law
    ``j`` draws its sensor noise from the named stream ``stream_seed(seed, "feedforward", it, j)``.
    """
    ffs = [Feedforward()] * len(laws)
    for it in range(setup.config.controller.ff_iterations):
        runs = run_laws(setup, laws, reference, ffs, seeds=[stream_seed(seed, "feedforward", it, j) for j in range(len(laws))])
        ffs = [identify_feedforward(reference.v, reference.a, r.f_star[:, 0]) for r in runs]
    return ffs


def run_laws(setup: Setup, laws: list, reference, feedforwards: list, seeds) -> list[SimResult]:
    """Simulate each law with its feedforward; laws sharing a pytree structure run batched.

    ``reference`` is one reference for all laws or a list with one per law.
    """
    refs = list(reference) if isinstance(reference, (list, tuple)) else [reference] * len(laws)
    groups: dict = {}
    for j, law in enumerate(laws):
        groups.setdefault(jax.tree_util.tree_structure(law), []).append(j)
    out: list = [None] * len(laws)
    loop = setup.loop
    for idx in groups.values():
        res = simulate_many(setup.plant, [laws[j] for j in idx], [refs[j] for j in idx], drive=setup.motor, loop=loop,
                            feedforwards=[feedforwards[j] for j in idx], seeds=[seeds[j] for j in idx])
        for j, r in zip(idx, res):
            out[j] = r
    return out


def run_metrics(result: SimResult, lowpass_hz: float = 50.0) -> dict:
    """``{"commutation_mse": {dir: {filtered, unfiltered}}, "tracking_mse": m²}`` of one run."""
    return {"commutation_mse": commutation_mse(result.f_meas, result.f_star, result.sample_time, lowpass_hz),
            "tracking_mse": tracking_mse(result.e)}


def calibration_results(setup: Setup, cal: CalibrationResult) -> dict:
    """The ``calibration.*`` keys of results.json: initial, calibrated and (twin only) true ``k`` (N/A), ``ζ`` (rad)."""
    true = setup.true_k is not None
    return cal.to_dict() | {
        "true": {"k": setup.true_k if true else None, "zeta": setup.true_zeta if true else None},
        "error": ({"k_relative": cal.k / setup.true_k - 1.0, "zeta_rad": cal.zeta - setup.true_zeta} if true else None),
        "method": setup.config.calibration.method, "delta": setup.config.calibration.delta}


def identify_models(setup: Setup, data: list[CoilSetData], seed: int, progress=None, check_data: bool = True):
    """Algorithm 2 for every coil set; returns ``(pgnn, physics, [IdentifyResult])``.

    ``check_data=False`` skips the excitation check (the caller ran it and chose to go on).
    """
    pgnn, res = identify_all(data, setup.motor.pole_pitch, setup.config.identification.options(), seed=seed,
                             progress=_lm_progress(progress), check_data=check_data)
    physics = CombinedModel.from_coil_sets([r.physics_model for r in res])
    return pgnn, physics, res


#: Iterations of the identification without a force sensor at most (one phase over filtered windows; the cap of
#: ``[identification] max_iterations`` applies where it is lower).
SENSORLESS_ITERATIONS = 100


def identify_sensorless_models(setup: Setup, data: list[CoilSetData], k, zeta, seed: int, progress=None,
                               check_data: bool = True):
    """Algorithm 2 without a force sensor for every coil set (:mod:`pgcomm.sensorless`); force columns unused.

    The y row of each coil set's PGNN is identified jointly with its Coulomb and viscous
    friction from the motion (moving mass :func:`sensorless_mass`); the x and z rows are the
    classical model with ``k`` (L,) N/A and ``ζ`` (L,) rad (e.g. a sensorless calibration).

    Returns:
        ``(CombinedModel, [IdentifyResult])``; each result's ``mechanics`` holds the friction.
    """
    ic = setup.config.identification
    motor = setup.motor
    mass = sensorless_mass(setup)
    sdata = [sensorless_data(d, motor.sample_time, motor.pole_pitch, mass, current_limit=motor.current_limit,
                             friction_velocity=ic.direction_velocity) for d in data]
    # one phase over filtered windows at ~0.35 s an iteration on the twin: SENSORLESS_ITERATIONS at most (run to
    # convergence, up to 400 iterations, it took three times as long and tracked the same); results.json says
    # whether each converged
    budget = min(ic.max_iterations, SENSORLESS_ITERATIONS)
    _, res = identify_all(sdata, motor.pole_pitch, ic.options(max_iterations=budget), seed=seed,
                          progress=_lm_progress(progress), check_data=check_data)
    models = [with_classical_rows(r.model, float(k[l]), float(zeta[l]), motor.mu, motor.lever_arms[l])
              for l, r in enumerate(res)]
    return CombinedModel.from_coil_sets(models), res


def _lm_progress(progress):
    """Per-iteration callback of :func:`pgcomm.identify.identify` printing to ``progress`` every 10 iterations."""
    if progress is None:
        return None

    def show(info):
        progress.checkpoint()
        if progress.enabled and info["iteration"] % 10 == 0:
            progress.info(f"iteration {info['iteration']:3d}: best V = {info['best_cost']:.5g}, "
                          f"{info['active']}/{info['starts']} starts active")
    return show


def identify_spline_models(setup: Setup, data: list[CoilSetData], progress=None):
    """The physics-guided spline model of all coil sets and the mechanics from the same data.

    Returns:
        ``(SplineFit, MechanicsFit)``: :func:`pgcomm.identify.spline.identify_spline` with the direction
        table's ``v_ε`` of ``[identification] direction_velocity``, and
        :func:`pgcomm.identify.mechanics.identify_mechanics` on the model's force.
    """
    ic, motor = setup.config.identification, setup.motor
    fit = identify_spline(data, motor.pole_pitch, SplineOptions(direction_velocity=ic.direction_velocity), progress)
    mech = identify_mechanics(data, fit.model, motor.sample_time, motor.pole_pitch, ic.direction_velocity)
    return fit, mech


def identify_direction_models(setup: Setup, data: list[CoilSetData], start_models, seed: int, progress=None):
    """The PGNN with the direction term ``C^l s(ẏ)`` (and the harmonics if configured) per coil set.

    Warm-started from ``start_models`` (the paper's PGNN per coil set, same widths): the
    extension adds only linear columns, which Proposition 1 sets for any hidden weights, so
    one start refined from the trained hidden layers replaces the random restarts.

    Returns:
        ``(CombinedModel, [IdentifyResult])``.
    """
    ic = setup.config.identification
    res = []
    for l, (d, m0) in enumerate(zip(data, start_models)):
        # the widths of the start model (chosen by validation per coil set)
        gw = None if m0.gain_nets is None else m0.gain_nets[0].widths
        cw = None if m0.cog_net is None else m0.cog_net.widths
        options = ic.options(gain_widths=gw, cog_widths=cw, starts=1, harmonics=ic.direction_harmonics,
                             direction=True)
        res.append(identify(d, setup.motor.pole_pitch, options, seed=stream_seed(seed, "direction starts", l),
                            check_data=False, start_from=m0))
    return CombinedModel.from_coil_sets([r.model for r in res]), res


def identification_results(res, seconds_total: float, res_direction=None) -> dict:
    """The ``identification.*`` keys of results.json from ``[IdentifyResult]`` and the total time (s).

    Per coil set also ``cost_y_pgnn`` (the paper's PGNN) and, with ``res_direction``,
    ``cost_y_pgnn_direction`` and ``direction_term`` (``C^l``, N, N, N·m): the y cost
    ``mean (Fy - F̂y)²`` (N²) of the paper's Remark on training data.
    """
    sets = []
    for l, r in enumerate(res):
        d = r.to_dict()
        d["cost_y_pgnn"] = d.get("cost_y")
        if res_direction is not None:
            rd = res_direction[l]
            d["cost_y_pgnn_direction"] = rd.cost_y
            d["direction_term"] = [float(c) for c in np.asarray(rd.model.C)]
            d["cost_pgnn_direction"] = rd.cost_pgnn
            d["cost_pgnn_direction_validation"] = rd.cost_pgnn_validation
            d["seconds_direction"] = rd.seconds
        sets.append(d)
    return {"coil_sets": sets, "seconds_total": seconds_total}


def write_production_logs(folder, seed: int = 0) -> list[Path]:
    """Write the data sets a production line records for the motor in ``folder``: ``folder/logs/Z{i}_coilset{l}.csv``.

    The experiments of Algorithm 1's first pass (eq. DataSets): the data-generation
    reference of ``folder/config.toml`` run closed loop on the force map ``folder/plant.csv``,
    one coil set at a time with the drive at the nominal ``k̂``, ``ζ̂`` of ``folder/motor.toml``
    and ``Δ = ∓Δ0`` (``[calibration] delta``, default π/4); noise seeded by ``seed`` as in
    ``pgcomm calibrate --seed``. The files are exactly those of ``pgcomm calibrate --save-data``
    with the same folder and seed (:func:`pgcomm.io.logs.write_datasets`).

    Args:
        folder: a motor folder of :func:`pgcomm.zoo.write_motor` (``plant.csv``, ``motor.toml``, ``config.toml``).
        seed: noise seed.

    Returns:
        the ``2 L`` log paths.
    """
    folder = Path(folder)
    setup = build_setup(load_experiment(folder / "config.toml"), forcemap_path=folder / "plant.csv",
                        motor_path=folder / "motor.toml")
    data = generate(setup, data_generation_reference(setup), setup.motor.k, setup.motor.zeta, seed=seed)
    return write_datasets(folder / "logs", data)
