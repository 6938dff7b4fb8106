"""A linear motor's coil sets identified from their data sets: what ``pgcomm identify`` computes, as one call.

The Python API of the command line's linear identification::

    from pgcomm import build_setup, ExperimentConfig, identify_coil_sets, coil_set_data_from_logs, read_logs

    setup = build_setup(ExperimentConfig(), motor_path="motor.toml")
    data = coil_set_data_from_logs(read_logs(["logs/*.csv"]), setup.motor)
    found = identify_coil_sets(setup, data)              # CoilSetsOptions(): the PGNN, with a force sensor
    found.model                                          # the identified CombinedModel (or SplineModel)
    found.to_dict()                                      # results.json's identification (and mechanics) keys

:func:`identify_coil_sets` takes the data sets ``Z_1^l ∪ Z_2^l`` of every coil set (:class:`pgcomm.data.CoilSetData`:
from logs, :func:`pgcomm.data.coil_set_data_from_logs`, or generated on a plant, :func:`pgcomm.experiment.generate`),
checks that they persistently excite the model (the paper's Remark; :func:`pgcomm.excitation.check_excitation`) and
identifies one model family: the paper's PGNN (Algorithm 2, :func:`pgcomm.experiment.identify_models`), the PGNN
without a force sensor (the y row from the motion with the translator's friction,
:func:`pgcomm.experiment.identify_sensorless_models`), or the spline model with the mechanics from the same data
(:func:`pgcomm.experiment.identify_spline_models`). The result (:class:`CoilSetsIdentification`) is data; the files
are the caller's to write (``pgcomm identify`` writes ``model.json/.npz``, ``results.json`` and the figures).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np

from pgcomm import experiment
from pgcomm.data import CoilSetData
from pgcomm.errors import ExcitationError
from pgcomm.excitation import check_excitation
from pgcomm.identify.mechanics import combined_mechanics
from pgcomm.progress import Progress
from pgcomm.sensorless import sensorless_data
from pgcomm.setup import Setup

__all__ = ["CoilSetsOptions", "CoilSetsIdentification", "identify_coil_sets", "FAMILIES"]

#: The model families of a linear motor: the paper's PGNN, and the spline model (knots by cross-validation).
FAMILIES = ("pgnn", "spline")


@dataclass(frozen=True)
class CoilSetsOptions:
    """How :func:`identify_coil_sets` identifies (the settings of each family are ``setup.config.identification``).

    Attributes:
        family: ``"pgnn"`` (the paper's, Algorithm 2) or ``"spline"`` (the fundamental's coefficients, cogging and
            direction force tabulated along the stroke; needs a force sensor).
        force_sensor: the data's force columns are measurements; ``False``: the y row is identified from the motion
            (the setup's motor gives the moving mass ``mass`` in kg and the data's ``sample_time`` in s), the x and z
            rows are the classical model with the motor's nominal ``k̂``, ``ζ̂``.
        force: identify even where the excitation check fails (its findings become warnings).
    """

    family: str = "pgnn"
    force_sensor: bool = True
    force: bool = False

    def __post_init__(self):
        if self.family not in FAMILIES:
            raise ValueError(f"family = {self.family!r}: expected one of {', '.join(map(repr, FAMILIES))}")
        if self.family == "spline" and not self.force_sensor:
            raise ValueError("family = 'spline' fits the measured force: it needs force_sensor = True; without a "
                             "force sensor use the PGNN")


@dataclass(frozen=True)
class CoilSetsIdentification:
    """What :func:`identify_coil_sets` found; :meth:`to_dict` is results.json's ``identification`` (and, where
    identified, ``mechanics`` and ``feedforward``) keys (``docs/results.md``).

    Attributes:
        family: ``"pgnn"`` or ``"spline"``; force_sensor: identified from measured forces.
        model: the :class:`~pgcomm.models.CombinedModel` (PGNN) or :class:`~pgcomm.spline_model.SplineModel`.
        results: per coil set, :class:`~pgcomm.identify.IdentifyResult` (PGNN; empty for the spline model).
        spline: the :class:`~pgcomm.identify.spline.SplineFit` (spline model) or ``None``.
        mechanics: the translator's mechanics identified with the model: a
            :class:`~pgcomm.identify.mechanics.MechanicsFit` (spline model), the combined friction of
            :func:`~pgcomm.identify.mechanics.combined_mechanics` (no force sensor, a dict), or ``None``.
        feedforward: ``{"mass" (kg), "viscous" (N s/m), "coulomb" (N)}`` without a force sensor, else ``None``.
        fy_abs_max: largest ``|Fy|`` (N) in the data (measured, or the model's without a force sensor).
        warnings: the excitation check's findings that ``force`` let pass.
        seconds: the identification's time (s).
    """

    family: str
    force_sensor: bool
    model: object
    results: list = field(default_factory=list)
    spline: object = None
    mechanics: object = None
    feedforward: dict | None = None
    fy_abs_max: float = 0.0
    warnings: tuple[str, ...] = ()
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """The ``identification`` keys (and ``mechanics``, ``feedforward`` where identified), a new dict."""
        if self.family == "spline":
            return {"identification": {"spline": self.spline.to_dict(),
                                       "seconds_total": self.spline.seconds + self.mechanics.seconds},
                    "mechanics": self.mechanics.to_dict()}
        out = {"identification": experiment.identification_results(self.results, self.seconds)}
        if self.mechanics is not None:
            out["mechanics"] = self.mechanics
            out["feedforward"] = dict(self.feedforward)
        return out


def identify_coil_sets(setup: Setup, data: list[CoilSetData], options: CoilSetsOptions = CoilSetsOptions(), *,
                       seed: int = 0, progress=None) -> CoilSetsIdentification:
    """Identify every coil set's model of ``options.family`` from its data sets (module docstring).

    Args:
        setup: the set-up (motor: pole pitch, coil sets, ``k̂``, ``ζ̂``; without a force sensor also ``mass`` in kg and
            the data's ``sample_time`` in s; ``config.identification``: the family's settings).
        data: per coil set, its :class:`~pgcomm.data.CoilSetData` (``L`` entries; ``(N_l,)`` positions in m,
            ``(N_l, 2)`` currents in A, ``(N_l, 3)`` forces in N, N, N·m).
        options: :class:`CoilSetsOptions`.
        seed: seed of the random starts (named streams per coil set).
        progress: :class:`pgcomm.progress.Progress` or ``None``.

    Returns:
        :class:`CoilSetsIdentification`.

    Raises:
        ExcitationError: the data do not persistently excite the model (unless ``options.force``).
        DataError: without a force sensor, data too short or slow, without acceleration or saturated (one line).
    """
    progress = progress or Progress(enabled=False)
    motor = setup.motor
    if not options.force_sensor:
        # first: data too short or slow, without acceleration or saturated get their own one-line message
        ic = setup.config.identification
        with progress.stage("filtered acceleration windows per coil set"):
            windows = [sensorless_data(d, motor.sample_time, motor.pole_pitch, motor.mass,
                                       current_limit=motor.current_limit, friction_velocity=ic.direction_velocity)
                       for d in data]
            progress.info(", ".join(f"{d.name.split(' (')[0]}: {w.n} windows of {w.filt.length} samples"
                                    for d, w in zip(data, windows)))
    problems = {d.name: check_excitation(d, motor.pole_pitch) for d in data}  # positions and currents only
    bad = {k: v for k, v in problems.items() if v}
    warnings = ()
    if bad:
        msg = "; ".join(f"{k}: {', '.join(v)}" for k, v in bad.items())
        if not options.force:
            raise ExcitationError(f"data do not persistently excite the model ({msg}); use --force to identify anyway")
        progress.info(f"warning: {msg}")
        warnings = (msg,)
    if options.family == "spline":
        with progress.stage("spline model (knots by cross-validation) and mechanics from the same data"):
            fit, mech = experiment.identify_spline_models(setup, data, progress)
        return CoilSetsIdentification("spline", True, fit.model, spline=fit, mechanics=mech,
                                      fy_abs_max=_fy_abs_max(data), warnings=warnings,
                                      seconds=fit.seconds + mech.seconds)
    if not options.force_sensor:
        with progress.stage("identification without a force sensor (y row and friction) per coil set"):
            t0 = time.perf_counter()
            # x/z rows: the classical model with the motor's nominal (calibrated) k, zeta; the check above ran
            model, res = experiment.identify_sensorless_models(setup, data, motor.k, motor.zeta, seed, progress,
                                                               check_data=False)
            seconds = time.perf_counter() - t0
        mechanics, feedforward = combined_mechanics(res)
        # the data carry no force: the largest |Fy| the model gives on them
        fy = max(float(np.max(np.abs(np.asarray(r.model.force(jnp.asarray(d.y), jnp.asarray(d.currents)))[:, 0])))
                 for r, d in zip(res, data))
        return CoilSetsIdentification("pgnn", False, model, results=res, mechanics=mechanics, feedforward=feedforward,
                                      fy_abs_max=fy, warnings=warnings, seconds=seconds)
    with progress.stage("identification (Algorithm 2) per coil set"):
        t0 = time.perf_counter()
        model, _, res = experiment.identify_models(setup, data, seed, progress, check_data=False)
        seconds = time.perf_counter() - t0
    return CoilSetsIdentification("pgnn", True, model, results=res, fy_abs_max=_fy_abs_max(data), warnings=warnings,
                                  seconds=seconds)


def _fy_abs_max(data) -> float:
    """Largest measured ``|Fy|`` (N) over every coil set's data."""
    return max(float(np.max(np.abs(d.force[:, 0]))) for d in data)
