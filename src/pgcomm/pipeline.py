"""Steps of the paper's experiment shared by the CLI commands (simulate, calibrate, identify, reproduce).

Each step takes a resolved :class:`pgcomm.experiment.Setup` and returns plain results;
nothing here prints except through an optional :class:`pgcomm.progress.Progress`.
"""

from __future__ import annotations

import numpy as np

from pgcomm import trajectory
from pgcomm.calibration import CalibrationResult, calibrate
from pgcomm.commutation import ClassicalLaw
from pgcomm.control import Feedforward, identify_feedforward
from pgcomm.datasets import generate_datasets
from pgcomm.experiment import Setup
from pgcomm.metrics import commutation_mse, tracking_mse
from pgcomm.simulate import SimResult, simulate_many


def data_generation_reference(setup: Setup) -> trajectory.Reference:
    """The paper's data-generation reference (Fig. Data_Generation) for this set-up."""
    rc = setup.config.reference
    return trajectory.data_generation_reference(setup.motor.sample_time, rc.stroke, rc.velocities, rc.a_max,
                                                rc.j_max, rc.dwell)


def single_velocity_reference(setup: Setup, v_max: float) -> trajectory.Reference:
    """One back-and-forth over the stroke at ``v_max`` (m/s): the paper's slow/fast references."""
    rc = setup.config.reference
    return trajectory.single_velocity_reference(v_max, setup.motor.sample_time, rc.stroke, rc.a_max, rc.j_max,
                                                rc.dwell)


def generate(setup: Setup, reference, k_hat, zeta_hat, seed: int = 0, coil_sets=None):
    """Data sets ``Z_{1,2}^l`` with the drive at ``k̂`` (L,) N/A and ``ζ̂`` (L,) rad (no feedforward)."""
    drive = setup.motor.with_nominal(k=tuple(np.asarray(k_hat, float)), zeta=tuple(np.asarray(zeta_hat, float)))
    return generate_datasets(setup.plant, drive, reference, delta=setup.config.calibration.delta, pid=setup.pid,
                             mechanics=setup.config.mechanics, sensors=setup.config.sensors, seed=seed,
                             coil_sets=coil_sets)


def run_calibration(setup: Setup, reference, seed: int = 0, progress=None, first=None) -> tuple[CalibrationResult, list]:
    """Algorithm 1 from the set-up's initial ``k0``, ``ζ0``; returns the result and the last data sets.

    ``first``: data sets already generated at ``k0``, ``ζ0`` (used for the first pass).
    """
    cc = setup.config.calibration
    last = {"calls": 0}

    def gen(k, zeta):
        if last["calls"] == 0 and first is not None:
            last["data"] = first
        else:
            last["data"] = generate(setup, reference, k, zeta, seed=seed + 1000 * last["calls"])
        last["calls"] += 1
        return last["data"]

    def report(it, k, zeta):
        if progress:
            progress.info(f"pass {it}: k = {np.array2string(k, precision=3)} N/A, "
                          f"zeta = {np.array2string(zeta, precision=4)} rad")

    cal = calibrate(gen, np.asarray(setup.motor.k), np.asarray(setup.motor.zeta), delta=cc.delta,
                    iterations=cc.iterations, tol=cc.tol, method=cc.method, n_bins=cc.n_bins, progress=report,
                    pole_pitch=setup.motor.pole_pitch)
    return cal, last["data"]


def calibrated_law(setup: Setup, k, zeta) -> ClassicalLaw:
    """Classical law (eq. Commutation_Solution_Ideal) with calibrated ``k̂^l``, ``ζ̂^l``."""
    return ClassicalLaw.from_motor(setup.motor, k=k, zeta=zeta)


def tune_feedforward(setup: Setup, laws: list, reference, seed: int = 0) -> list[Feedforward]:
    """Feedforward ``m, f_v, f_c`` per law, identified from closed-loop data with that law.

    Iterated ``controller.ff_iterations`` times: each pass runs the loop with the previous
    estimate (the first with none) and refits :func:`pgcomm.control.identify_feedforward`
    on the demanded force; with the feedforward in the loop the feedback lag no longer
    biases the mass estimate. Laws of the same type are simulated batched.
    """
    ffs = [Feedforward()] * len(laws)
    for it in range(setup.config.controller.ff_iterations):
        runs = run_laws(setup, laws, reference, ffs, seeds=[seed + 7919 * it + j for j in range(len(laws))])
        ffs = [identify_feedforward(reference.v, reference.a, r.f_star[:, 0]) for r in runs]
    return ffs


def run_laws(setup: Setup, laws: list, reference, feedforwards: list, seeds) -> list[SimResult]:
    """Simulate each law with its feedforward; laws sharing a pytree structure run batched.

    ``reference`` is one reference for all laws or a list with one per law.
    """
    import jax

    refs = list(reference) if isinstance(reference, (list, tuple)) else [reference] * len(laws)
    groups: dict = {}
    for j, law in enumerate(laws):
        groups.setdefault(jax.tree_util.tree_structure(law), []).append(j)
    out: list = [None] * len(laws)
    kw = dict(drive=setup.motor, pid=setup.pid, mechanics=setup.config.mechanics, sensors=setup.config.sensors)
    for idx in groups.values():
        res = simulate_many(setup.plant, [laws[j] for j in idx], [refs[j] for j in idx],
                            feedforwards=[feedforwards[j] for j in idx], seeds=[seeds[j] for j in idx], **kw)
        for j, r in zip(idx, res):
            out[j] = r
    return out


def run_metrics(result: SimResult, lowpass_hz: float = 50.0) -> dict:
    """``{"commutation_mse": {dir: {filtered, unfiltered}}, "tracking_mse": m²}`` of one run."""
    return {"commutation_mse": commutation_mse(result.f_meas, result.f_star, result.sample_time, lowpass_hz),
            "tracking_mse": tracking_mse(result.e)}
