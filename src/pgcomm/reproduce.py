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
   residual), oracle (the plant's exact inverse with its true state, direction force included);
   beyond the paper: pgnn_direction (the PGNN with the direction term ``C^l s(ẏ)``,
   fed the controller's velocity); without a force sensor (the same data sets, force columns
   unused): pgnn_sensorless (calibration and the PGNN's y rows from the motion,
   :mod:`pgcomm.sensorless`; x, z rows classical) and cogging_table_sensorless (classical calibrated
   from the motion plus an anti-cogging table from the controller's effort at slow constant speed);
6. metrics: 50 Hz-filtered and unfiltered commutation-error MSE per direction, tracking-
   error MSE, and each row's share of the reducible error
   ``(classical - row) / (classical - oracle)``.
"""

from __future__ import annotations

import time
from contextlib import contextmanager

from dataclasses import dataclass, replace

import pgcomm._x64  # noqa: F401  (float64 before any array is made)
import jax
import numpy as np
import jax.numpy as jnp

from pgcomm import experiment
from pgcomm._memory import release_compiled_programs
from pgcomm.calibration import CalibrationResult
from pgcomm.commutation import ClassicalLaw, ModelLaw, OffsetLaw, oracle_law
from pgcomm.compensation import fit_cogging_table, fit_harmonic_cogging
from pgcomm.data import coil_set_data_from_runs
from pgcomm.seeds import stream_seed
from pgcomm.settings import ExperimentConfig
from pgcomm.sensorless_table import effort_reference, sensorless_cogging_table
from pgcomm.setup import Setup, check_reference, sensorless_mass, simulated_mass
from pgcomm.identify import IdentifyResult
from pgcomm.metrics import DIRECTIONS, lowpass, mse_difference_se, reducible_share
from pgcomm.models import CombinedModel
from pgcomm.protocols import ForceModel, Plant
from pgcomm.progress import Progress

ROWS = ("original", "classical", "physics", "pgnn", "pgnn_direction", "spline", "pgnn_sensorless", "cogging_table",
        "cogging_table_sensorless", "harmonic_cogging", "oracle")

#: Rows a user can deploy (every row but the oracle, which needs the plant's truth).
REALISABLE = tuple(r for r in ROWS if r != "oracle")

#: The paper's Table 2 (commutation performance: filtered, unfiltered MSE in N², N², N²m²), its tracking-error
#: MSE (m²) and its Table 1's calibrated k̂ (N/A), ζ̂ (rad).
PAPER = {
    "commutation_mse": {
        "original": {"y": (52.8, 53.4), "x": (0.111, 0.234), "z": (0.327, 0.781)},
        "classical": {"y": (27.4, 28.1), "x": (0.141, 0.307), "z": (0.436, 1.13)},
        "pgnn": {"y": (2.45, 3.08), "x": (0.056, 0.223), "z": (0.180, 0.930)},
    },
    "tracking_mse": {"classical": 2.75e-8, "pgnn": 5.94e-9},
    "calibrated": {"k": (61.34, 61.62, 60.07), "zeta": (-0.54, -0.55, -0.55)},
}


def model_error(model: ForceModel, plant: Plant, y_range, n: int = 2001) -> dict:
    """RMS error of a model's gain and cogging against the plant's truth over ``y_range`` (m).

    Args:
        model: a combined model with ``gain(y) -> (n, L, 3, 2)`` and ``cogging(y) -> (n, 3)``.
        plant: the simulated plant (its ``gain`` / ``cogging`` are the truth).
        y_range: ``(lo, hi)`` positions, uniformly sampled with ``n`` points.

    Returns:
        ``{"gain_rms": {y, x, z}, "cogging_rms": {y, x, z}, "gain_rms_relative": {y, x, z},``
        ``"gain_ratio_y": r}``: RMS over positions, coil sets and both current columns (N/A; N·m/A for
        z), RMS of the cogging (N; N·m), the gain RMS relative to the RMS of the true gain row, and
        the mean over positions and coil sets of the model's driving-force gain amplitude over the
        truth's, ``|K̂_y(y)| / |K_y(y)|`` (both current columns; 1.08 = the model's gain 8 % high).
    """
    y = jnp.linspace(y_range[0], y_range[1], n)
    g_hat, c_hat = (np.asarray(a) for a in gain_and_cogging(model, y))
    g, c = (np.asarray(a) for a in gain_and_cogging(plant, y))
    out = {"gain_rms": {}, "cogging_rms": {}, "gain_rms_relative": {}}
    for q, d in enumerate(DIRECTIONS):
        err = float(np.sqrt(np.mean((g_hat[:, :, q, :] - g[:, :, q, :]) ** 2)))
        ref = float(np.sqrt(np.mean(g[:, :, q, :] ** 2)))
        out["gain_rms"][d] = err
        out["gain_rms_relative"][d] = err / ref if ref > 0 else None
        out["cogging_rms"][d] = float(np.sqrt(np.mean((c_hat[:, q] - c[:, q]) ** 2)))
    amp = lambda gain: np.sqrt(np.sum(gain[:, :, 0, :] ** 2, axis=-1))  # noqa: E731  (N, L) N/A
    out["gain_ratio_y"] = float(np.mean(amp(g_hat) / amp(g)))
    return out


def filtered_noise_mse(sensors, sample_time: float, lowpass_hz: float) -> dict:
    """MSE of the force sensor's white noise after the evaluation's low-pass ``H(z)``, per direction.

    For white noise of standard deviation ``σ`` through ``H(z) = (1 − a) z⁻¹ / (1 − a z⁻¹)``,
    ``a = exp(−2π f_lp Ts)``, the output variance is ``σ² (1 − a) / (1 + a)``: the part of a measured
    filtered commutation-error MSE that no commutation law can remove.

    Args:
        sensors: :class:`pgcomm.sensors.Sensors` (``force_noise``: N, N, N·m rms).
        sample_time: ``Ts`` (s); lowpass_hz: ``f_lp`` (Hz).

    Returns:
        ``{"y": N², "x": N², "z": N²m²}``.
    """
    a = float(np.exp(-2 * np.pi * lowpass_hz * sample_time))
    return {d: float(s) ** 2 * (1 - a) / (1 + a) for d, s in zip(DIRECTIONS, sensors.force_noise)}


@jax.jit
def gain_and_cogging(model, y):
    """``(model.gain(y), model.cogging(y))`` of a model or plant at positions ``y`` (m, ``(n,)``): ``(n, L, 3, 2)``
    (N/A) and ``(n, 3)`` (N, N, N·m), one compiled program per model class (op by op, a network's forward pass
    compiled ~40 small programs per call: 1.7 s of a --quick run)."""
    return model.gain(y), model.cogging(y)


def reference_seed(seed: int, reference_name: str) -> int:
    """Sensor-noise seed of an evaluation run: by reference, never by row (DESIGN.md, Noise).

    Every law sees the same noise on the same reference, so rows compare without noise
    spread, and adding a reference leaves the other references' numbers unchanged.
    """
    return stream_seed(seed, "evaluation", reference_name)


#: The settings :func:`quick_config` overrides (``section.key`` of the experiment TOML).
QUICK_OVERRIDES = ("reference.velocities", "reference.dwell", "identification.starts", "identification.max_iterations",
                   "identification.screen_iterations", "controller.ff_iterations")


def quick_config(config: ExperimentConfig) -> ExperimentConfig:
    """A shorter experiment for a first look and for tests: the two fastest of the configured
    velocities, short dwells, fewer random starts and iterations, two feedforward passes."""
    ref = replace(config.reference, velocities=tuple(sorted(config.reference.velocities)[-2:]),
                  dwell=min(config.reference.dwell, 0.2))
    ident = replace(config.identification, starts=2, max_iterations=25, screen_iterations=25)
    ctrl = replace(config.controller, ff_iterations=2)
    return replace(config, reference=ref, identification=ident, controller=ctrl)


def paper_improvement(row: str) -> dict:
    """The paper's improvement of ``row`` over classical: filtered MSE ratio per direction and of the tracking MSE."""
    cm, tm = PAPER["commutation_mse"], PAPER["tracking_mse"]
    return {**{d: cm["classical"][d][0] / cm[row][d][0] for d in DIRECTIONS},
            "tracking": tm["classical"] / tm[row]}


@dataclass(frozen=True)
class SensorlessResult:
    """The chain without a force sensor of one run.

    Attributes:
        calibration: Algorithm 1 on the motion (method ``"sensorless"``).
        identification: per coil set, the y row with friction (``mechanics``, a :class:`~pgcomm.sensorless.FrictionFit`).
        model: the combined model (x, z rows classical with ``calibration``'s ``k``, ``ζ``).
        seconds: wall time of calibration and identification (s).
        mass: the given moving mass (kg).
        mass_source: where that mass comes from (:func:`pgcomm.setup.simulated_mass`), e.g.
            ``"30 kg from the simulated mechanics ([mechanics] mass; the motor description has none)"``.
        table_info: the run of the ``cogging_table_sensorless`` row
            (:func:`pgcomm.sensorless_table.sensorless_cogging_table`'s ``info``).
    """

    calibration: CalibrationResult
    identification: tuple
    model: CombinedModel
    seconds: float
    mass: float
    table_info: dict | None = None
    mass_source: str = ""

    def to_dict(self, setup: Setup) -> dict:
        mech = setup.config.mechanics
        return {"calibration": experiment.calibration_results(setup, self.calibration),
                "coil_sets": [r.to_dict() for r in self.identification],
                "mass": self.mass, "mass_source": self.mass_source, "seconds": self.seconds,
                "cogging_table": self.table_info,
                "simulated_mechanics": {"mass": mech.mass, "viscous": mech.viscous, "coulomb": mech.coulomb}}


@dataclass(frozen=True)
class Diagnostics:
    """Figures of a run computed once from its runs, models and the plant's truth (:func:`run` fills them),
    so that :meth:`ReproduceResult.to_dict` only arranges stored values.

    Attributes:
        model_error: model name (``pgnn``, ``physics``, optional ``pgnn_direction``, ``spline``) ->
            :func:`model_error` against the plant's truth.
        reducible_standard_error: :meth:`ReproduceResult.compute_reducible_standard_errors`.
        sensor_noise: :meth:`ReproduceResult.compute_sensor_noise`.
        y_mse_without_direction_force: :meth:`ReproduceResult.compute_mse_without_direction_force`
            (``None`` without the sensorless chain, where it is reported).
        sensorless_model_error: :func:`model_error` of the sensorless model, or ``None``.
    """

    model_error: dict
    reducible_standard_error: dict
    sensor_noise: dict
    y_mse_without_direction_force: dict | None = None
    sensorless_model_error: dict | None = None


@dataclass(frozen=True)
class ReproduceResult:
    """Everything the paper's experiment produced on one set-up.

    Attributes:
        setup: the resolved experiment it ran on (its ``config`` holds every setting).
        calibration: Algorithm 1's result (``k``, ``zeta`` per coil set, N/A and rad).
        identification: one :class:`~pgcomm.identify.IdentifyResult` per coil set.
        identification_seconds: wall time of Algorithm 2 for all coil sets (s).
        pgnn, physics: the identified combined models.
        references: reference name (``long``, ``slow``, ``fast``, optional ``user``) -> Reference.
        runs: reference name -> row -> :class:`~pgcomm.simulate.SimResult`.
        feedforward: row -> :class:`~pgcomm.control.Feedforward` (``m`` kg, ``f_v`` N s/m, ``f_c`` N).
        tables: ``"cogging_table"`` / ``"harmonic_cogging"`` / ``"cogging_table_sensorless"`` -> the drive-style offset.
        metrics: reference name -> row -> ``{"commutation_mse": {dir: {filtered, unfiltered}}, "tracking_mse": m²}``.
        diagnostics: the figures computed once at the end of :func:`run` (:class:`Diagnostics`).
    """

    setup: Setup
    calibration: CalibrationResult
    identification: tuple[IdentifyResult, ...]
    identification_seconds: float
    pgnn: CombinedModel
    physics: CombinedModel
    references: dict
    runs: dict
    feedforward: dict
    tables: dict
    metrics: dict
    identification_direction: tuple = ()
    pgnn_direction: CombinedModel | None = None
    sensorless: SensorlessResult | None = None
    spline: object = None
    mechanics: object = None
    diagnostics: Diagnostics | None = None

    @property
    def rows(self) -> tuple:
        """The rows this run computed, in :data:`ROWS` order."""
        return tuple(r for r in ROWS if r in self.metrics["long"])

    @property
    def commutation_mse(self) -> dict:
        """Row -> direction -> ``{filtered, unfiltered}`` (N², N², N²m²) on the long reference (the paper's table)."""
        return {row: m["commutation_mse"] for row, m in self.metrics["long"].items()}

    @property
    def tracking_mse(self) -> dict:
        """Row -> tracking-error MSE (m²) on the long reference."""
        return {row: m["tracking_mse"] for row, m in self.metrics["long"].items()}

    def reducible_share(self) -> dict:
        """Row -> direction (and ``tracking``) -> ``(classical - row) / (classical - oracle)`` of the filtered MSE.

        ``None`` where ``classical - oracle`` is below ``max(5 × its standard error, 0.2 × oracle)``
        (:func:`pgcomm.metrics.reducible_share`): a share of a difference lost in noise means nothing.
        """
        cm, tm = self.commutation_mse, self.tracking_mse
        se = self._diagnostics().reducible_standard_error
        share = {}
        for row in self.rows:
            share[row] = {d: reducible_share(cm[row][d]["filtered"], cm["classical"][d]["filtered"],
                                             cm["oracle"][d]["filtered"], se[d]) for d in DIRECTIONS}
            share[row]["tracking"] = reducible_share(tm[row], tm["classical"], tm["oracle"], se["tracking"])
        return share

    def _diagnostics(self) -> Diagnostics:
        if self.diagnostics is None:
            raise ValueError("this ReproduceResult has no diagnostics: results from pgcomm.reproduce.run have them "
                             "(or add them with with_diagnostics())")
        return self.diagnostics

    def with_diagnostics(self) -> "ReproduceResult":
        """This result with its :class:`Diagnostics` computed (what :func:`run` returns)."""
        models = {"pgnn": self.pgnn, "physics": self.physics}
        if self.pgnn_direction is not None:
            models["pgnn_direction"] = self.pgnn_direction
        if self.spline is not None:
            models["spline"] = self.spline.model
        span = self.setup.config.reference.span
        sl = self.sensorless
        return replace(self, diagnostics=Diagnostics(
            model_error={name: model_error(m, self.setup.plant, span) for name, m in models.items()},
            reducible_standard_error=self.compute_reducible_standard_errors(),
            sensor_noise=self.compute_sensor_noise(),
            y_mse_without_direction_force=None if sl is None else self.compute_mse_without_direction_force(),
            sensorless_model_error=None if sl is None else model_error(sl.model, self.setup.plant, span)))

    def compute_reducible_standard_errors(self) -> dict:
        """Standard errors of ``classical - oracle`` on the long reference: per direction (filtered, N² or
        N²m²) and ``tracking`` (m²), from block means (:func:`pgcomm.metrics.mse_difference_se`)."""
        c, o = self.runs["long"]["classical"], self.runs["long"]["oracle"]
        ts, lp = c.sample_time, self.setup.config.evaluation.lowpass_hz
        # blocks of ~20 filter time constants (at least 0.1 s): block means nearly independent
        block = max(int(round(20.0 / (2 * np.pi * lp * ts))), int(round(0.1 / ts)))
        fc = lowpass(c.f_meas - c.f_star, ts, lp)
        fo = lowpass(o.f_meas - o.f_star, ts, lp)
        se = {d: mse_difference_se(fc[:, q], fo[:, q], block) for q, d in enumerate(DIRECTIONS)}
        se["tracking"] = mse_difference_se(c.e, o.e, block)
        return se

    def compute_mse_without_direction_force(self) -> dict:
        """Row -> filtered y MSE (N²) of ``F - F* - F_dir`` on the long reference: the error with the
        plant's own direction-dependent force taken out (known only on a simulated plant; ``F_dir`` at the
        true position and a central-difference velocity of it).

        Without a force sensor that force cannot be told from Coulomb friction, so no sensorless row
        compensates it; this is what the rows that leave it alone (classical, the sensorless rows, the
        tables) differ by. Rows that compensate some of it (pgnn through its gain, pgnn_direction, the
        oracle) are not comparable here.
        """
        out = {}
        lp = self.setup.config.evaluation.lowpass_hz
        for row, r in self.runs["long"].items():
            v = np.gradient(r.y, r.sample_time)
            f_dir = np.asarray(self.setup.plant.direction_force(r.y, v))[:, :1]
            e = r.f_true[:, :1] - r.f_star[:, :1] - f_dir
            out[row] = float(np.mean(lowpass(e, r.sample_time, lp) ** 2))
        return out

    def compute_sensor_noise(self) -> dict:
        """What the force sensor's noise contributes to the filtered commutation-error MSE (N², N², N²m²).

        Returns:
            ``{"expected": {y, x, z}, "long": {y, x, z}, "oracle_true_force": {y, x, z}}``: the filtered
            noise MSE expected from the configured noise (:func:`filtered_noise_mse`), the one of this run's
            noise draw on the long reference (``F_meas − F_true``; every row sees the same draw), and the
            oracle's filtered MSE of the true force against the demand (``F_true − F*``; known only on a
            simulated plant). The oracle's measured error is the sum of the last two (up to their cross term):
            the noise is the floor of any error measured with this sensor.
        """
        cfg = self.setup.config
        lp = cfg.evaluation.lowpass_hz
        r = self.runs["long"]["oracle"]

        def fmse(x):
            return {d: float(np.mean(lowpass(x, r.sample_time, lp)[:, q] ** 2)) for q, d in enumerate(DIRECTIONS)}

        return {"expected": filtered_noise_mse(cfg.sensors, r.sample_time, lp), "long": fmse(r.f_meas - r.f_true),
                "oracle_true_force": fmse(r.f_true - r.f_star)}

    def tracking_order(self) -> list:
        """Rows by tracking-error MSE on the long reference, best first (the report's first table)."""
        return sorted(self.rows, key=lambda r: self.tracking_mse[r])

    def deployment_cost(self, row: str) -> dict:
        """What deploying ``row`` stores: ``table_bytes`` (float32 tables or weights a controller holds, bytes)
        and ``c_ns_per_call`` (``None``: measured by ``bench/bench_export.py``, not in this run)."""
        n_params = {"original": 0, "classical": 0}
        if row in n_params:
            size = 0
        elif row in ("cogging_table", "cogging_table_sensorless"):
            size = self.tables[row].nbytes
        elif row == "harmonic_cogging":
            size = 4 * int(self.tables[row].coef.shape[0])
        elif row == "spline":
            size = self.spline.model.nbytes + 4 * (2 + len(self.mechanics.knots))
        else:
            model = {"pgnn": self.pgnn, "physics": self.physics, "pgnn_direction": self.pgnn_direction,
                     "pgnn_sensorless": None if self.sensorless is None else self.sensorless.model}.get(row)
            size = None if model is None else 4 * sum(int(np.size(x)) for x in jax.tree_util.tree_leaves(model))
        return {"table_bytes": size, "c_ns_per_call": None}

    def recommended(self) -> dict:
        """The realisable row (not the oracle) with the least tracking error on the long reference, checked on
        the others: ``{row, reason, tracking_mse, tracking_mse_by_reference, best_on, c_ns_per_call, table_bytes}``."""
        cands = [r for r in self.rows if r in REALISABLE]
        best = min(cands, key=lambda r: self.tracking_mse[r])
        by_ref = {rn: m[best]["tracking_mse"] for rn, m in self.metrics.items()}
        best_on = [rn for rn, m in self.metrics.items()
                   if min((r for r in cands if r in m), key=lambda r: m[r]["tracking_mse"]) == best]
        second = min((r for r in cands if r != best), key=lambda r: self.tracking_mse[r], default=None)
        reason = (f"least tracking-error MSE on the long reference ({self.tracking_mse[best]:.3g} m²"
                  + (f", next {second} {self.tracking_mse[second]:.3g} m²" if second else "")
                  + f"); also the least on {', '.join(best_on) if best_on else 'no other reference'}")
        return {"row": best, "reason": reason, "tracking_mse": self.tracking_mse[best],
                "tracking_mse_by_reference": by_ref, "best_on": best_on, **self.deployment_cost(best)}

    def improvement_over_classical(self) -> dict:
        """Row -> direction (and ``tracking``) -> classical MSE / row MSE (filtered)."""
        cm, tm = self.commutation_mse, self.tracking_mse
        return {row: {**{d: cm["classical"][d]["filtered"] / cm[row][d]["filtered"] for d in DIRECTIONS},
                      "tracking": tm["classical"] / tm[row]} for row in self.rows}

    def to_dict(self) -> dict:
        """The JSON-ready ``results.json`` dict (keys in docs/results.md; the CLI adds ``command``, ``version``,
        ``quick``, ``seed`` and ``runtime_s``)."""
        out: dict = {"plant": self.setup.plant_name,
                     "calibration": experiment.calibration_results(self.setup, self.calibration),
                     "identification": experiment.identification_results(
                         self.identification, self.identification_seconds, self.identification_direction or None)}
        per_ref = {rname: {"commutation_mse": {row: v["commutation_mse"] for row, v in m.items()},
                           "tracking_mse": {row: v["tracking_mse"] for row, v in m.items()}}
                   for rname, m in self.metrics.items()}
        # the paper's table is on the long (data-generation) reference
        out["commutation_mse"] = per_ref["long"]["commutation_mse"]
        out["tracking_mse"] = per_ref["long"]["tracking_mse"]
        out["references"] = per_ref
        out["reducible_share"] = self.reducible_share()
        out["reducible_standard_error"] = self._diagnostics().reducible_standard_error
        out["improvement_over_classical"] = self.improvement_over_classical()
        out["feedforward"] = {row: {"mass": ff.mass, "viscous": ff.viscous, "coulomb": ff.coulomb,
                                    **({"coulomb_knots": list(ff.coulomb_knots), "coulomb_table": list(ff.coulomb_table)}
                                       if ff.coulomb_knots else {})}
                              for row, ff in self.feedforward.items()}
        out["tables"] = {name: {"entries": int(self.tables[name].values.shape[0]), "bytes": self.tables[name].nbytes}
                         for name in ("cogging_table", "cogging_table_sensorless") if name in self.tables}
        out["tables"].update({
                         "harmonic_cogging": {"harmonics": (int(self.tables["harmonic_cogging"].coef.shape[0]) - 1)
                                              // 2}})
        diag = self._diagnostics()
        if self.spline is not None:
            out["identification"]["spline"] = self.spline.to_dict()
            out["mechanics"] = {"identified": self.mechanics.to_dict(),
                                "simulated": {"mass": self.setup.config.mechanics.mass,
                                              "viscous": self.setup.config.mechanics.viscous,
                                              "coulomb": self.setup.config.mechanics.coulomb}}
        out["model_error"] = dict(diag.model_error)
        out["sensor_noise"] = diag.sensor_noise
        out["tracking_order"] = self.tracking_order()
        out["recommended"] = self.recommended()
        if self.sensorless is not None:
            sl = self.sensorless.to_dict(self.setup)
            cm = self.commutation_mse
            c, p, s_ = (cm[r]["y"]["filtered"] for r in ("classical", "pgnn", "pgnn_sensorless"))
            # the sensorless PGNN's share of what the force-sensor PGNN removes (its target: >= 80 %)
            sl["share_of_pgnn_reduction_y"] = (c - s_) / (c - p) if c - p > 0 else None
            sl["model_error"] = diag.sensorless_model_error
            sl["y_mse_without_direction_force"] = diag.y_mse_without_direction_force
            out["sensorless"] = sl
        out["paper"] = PAPER
        return out


@contextmanager
def _step(progress, message: str, release: bool = True):
    """One step of :func:`run`: the programs of the steps before it are released first (:mod:`pgcomm._memory`:
    the run's peak memory halves), then ``progress.stage(message)``. ``release=False`` for a step that runs the
    closed loops of the step before it again: its compiled loops are kept (a few MB), not traced again. A
    ``progress`` that releases at every stage (the command line's) is told which steps release instead: a second
    release at the same boundary would drop what ``release=False`` keeps."""
    if release and not progress.releases:
        release_compiled_programs()
    with progress.stage(message, release=release):
        yield


def run(setup: Setup, seed: int = 0, extra_reference=None, progress=None) -> ReproduceResult:
    """The whole experiment (module docstring) on ``setup``; returns a :class:`ReproduceResult`.

    Args:
        setup: the resolved experiment (plant, nominal motor, settings).
        seed: base seed of noise, data generation and random starts.
        extra_reference: an optional :class:`~pgcomm.trajectory.Reference` evaluated as ``"user"``.
        progress: a :class:`pgcomm.progress.Progress` (default: silent).
    """
    progress = progress or Progress(enabled=False)
    # the run simulates the translator, so its mass is known: a motor description without one takes it (said)
    setup, mass_source = simulated_mass(setup)
    progress.info(f"moving mass for the rows without a force sensor: {mass_source}")
    cfg = setup.config
    ic = cfg.identification
    motor = setup.motor
    refs = {"long": experiment.data_generation_reference(setup),
            "slow": experiment.single_velocity_reference(setup, min(cfg.reference.velocities)),
            "fast": experiment.single_velocity_reference(setup, max(cfg.reference.velocities))}
    if extra_reference is not None:
        refs["user"] = extra_reference
    for name, ref in refs.items():  # before any work: a reference off the plant fails now, not after minutes
        check_reference(setup, ref, f"the {name} reference")
    effort_reference(setup)  # the sensorless table's stroke and speed, needed minutes later
    long_ref = refs["long"]

    with _step(progress, f"data generation: {motor.n_coil_sets} coil sets x 2 data sets (Delta = -/+"
                        f"{cfg.calibration.delta:.4f} rad), {len(long_ref.r)} samples each"):
        data0 = experiment.generate(setup, long_ref, motor.k, motor.zeta, seed=seed)

    with _step(progress, "calibration (Algorithm 1)", release=False):
        cal, _ = experiment.run_calibration(setup, long_ref, seed=seed, progress=progress, first=data0)

    with _step(progress, "identification (Algorithm 2): PGNN and physics-only model per coil set"):
        t_id = time.perf_counter()
        pgnn, physics, id_res = experiment.identify_models(setup, coil_set_data_from_runs(data0), seed, progress)
        t_id = time.perf_counter() - t_id
        for r in id_res:
            progress.info(f"{r.name}: V physics {r.cost_physics:.4g} -> PGNN {r.cost_pgnn:.4g} (train), "
                          f"{r.cost_physics_validation:.4g} -> {r.cost_pgnn_validation:.4g} (validation), "
                          f"{r.seconds:.1f} s")
            unconverged = r.convergence_text()
            if unconverged:
                progress.info("warning: " + unconverged)

    with _step(progress, "identification with the direction term C^l s(dy/dt) (warm start from the PGNN)"):
        pgnn_dir, id_dir = experiment.identify_direction_models(
            setup, coil_set_data_from_runs(data0), [r.model for r in id_res], seed)
        for r0, r in zip(id_res, id_dir):
            progress.info(f"{r.name}: y cost (mean (Fy - Fy_hat)^2) PGNN {r0.cost_y:.4g} -> with direction term "
                          f"{r.cost_y:.4g} N^2, C_y = {float(r.model.C[0]):.3g} N, {r.seconds:.1f} s")

    with _step(progress, "spline model (capacity along the stroke, knots by cross-validation) and the mechanics "
                        "(mass, friction, Coulomb table) from the same data sets"):
        spline, mech = experiment.identify_spline_models(setup, coil_set_data_from_runs(data0), progress)
        sp = spline.spacing
        progress.info(f"knots every {1e3 * sp['gain']:.3g} mm (gain), {1e3 * sp['cogging']:.3g} mm (cogging), "
                      f"{1e3 * sp['direction']:.3g} mm (direction); y cost "
                      + ", ".join(f"{c['y']:.3g}" for c in spline.cost) + f" N^2; {spline.seconds:.1f} s")
        progress.info(f"mechanics: m = {mech.mass:.4g} kg, f_v = {mech.viscous:.4g} N s/m, Coulomb "
                      f"{float(np.min(mech.coulomb)):.3g} .. {float(np.max(mech.coulomb)):.3g} N along the stroke "
                      f"({len(mech.knots)} knots); {mech.seconds:.1f} s")

    with _step(progress, "without a force sensor: calibration (Algorithm 1 on m d2y/dt2) and identification of "
                        "the y row with friction"):
        t_sl = time.perf_counter()
        cal_sl, _ = experiment.run_calibration(setup, long_ref, seed=seed, progress=progress, first=data0,
                                               sensorless=True)
        pgnn_sl, id_sl = experiment.identify_sensorless_models(setup, coil_set_data_from_runs(data0), cal_sl.k,
                                                               cal_sl.zeta, seed, progress)
        sensorless = SensorlessResult(cal_sl, tuple(id_sl), pgnn_sl, time.perf_counter() - t_sl,
                                      sensorless_mass(setup), mass_source=mass_source)
        for r in id_sl:
            me = r.mechanics
            progress.info(f"{r.name}: y cost {r.cost_y:.4g} N^2 on {me.windows} filtered windows "
                          f"({1e3 * me.filter.window:.0f} ms); friction F_c = {me.coulomb:.3g} N, "
                          f"c = {me.viscous:.3g} N s/m (m = {me.mass:.3g} kg given)")

    limit = motor.current_limit
    laws = {"original": ClassicalLaw.from_motor(motor),
            "classical": ClassicalLaw.from_motor(motor, k=cal.k, zeta=cal.zeta),
            "physics": ModelLaw(physics, current_limit=limit),
            "pgnn": ModelLaw(pgnn, current_limit=limit),
            "pgnn_direction": ModelLaw(pgnn_dir, current_limit=limit, velocity_source=ic.law_velocity),
            "pgnn_sensorless": ModelLaw(pgnn_sl, current_limit=limit),
            "oracle": oracle_law(setup.plant, current_limit=limit)}
    # the spline row's feedforward is its own identification's, never tuned in closed loop
    spline_law = ModelLaw(spline.model, current_limit=limit, velocity_source=ic.law_velocity)

    with _step(progress, f"feedforward identification per law ({cfg.controller.ff_iterations} closed-loop passes)"):
        names = list(laws)
        ffs = dict(zip(names, experiment.tune_feedforward(setup, [laws[n] for n in names], long_ref, seed=stream_seed(seed, "feedforward", "rows"))))

    with _step(progress, "drive-style rows: anti-cogging table and harmonic fit from the classical residual, "
                        "anti-cogging table from the controller's effort (no force sensor)", release=False):
        run_c = experiment.run_laws(setup, [laws["classical"]], long_ref, [ffs["classical"]], seeds=[stream_seed(seed, "classical run for the tables")])[0]
        residual = run_c.f_meas[:, 0] - run_c.f_star[:, 0]
        tables = {"cogging_table": fit_cogging_table(run_c.y_meas, residual, cfg.evaluation.cogging_table_entries,
                                                     cfg.reference.span),
                  "harmonic_cogging": fit_harmonic_cogging(run_c.y_meas, residual, motor.pole_pitch,
                                                           cfg.evaluation.harmonics)}
        for name, tab in tables.items():
            laws[name] = OffsetLaw(laws["classical"], tab)
        # the drives' way without a force sensor: classical commutation calibrated without force data and
        # a table from the controller's effort (the feedforward is identified from the demand, no force)
        classical_sl = ClassicalLaw.from_motor(motor, k=cal_sl.k, zeta=cal_sl.zeta)
        tables["cogging_table_sensorless"], info = sensorless_cogging_table(
            setup, classical_sl, ffs["classical"], seed=stream_seed(seed, "sensorless table run"))
        laws["cogging_table_sensorless"] = OffsetLaw(classical_sl, tables["cogging_table_sensorless"])
        sensorless = replace(sensorless, table_info=info)
        extra = ["cogging_table", "harmonic_cogging", "cogging_table_sensorless"]
        ffs.update(zip(extra, experiment.tune_feedforward(setup, [laws[n] for n in extra], long_ref, seed=stream_seed(seed, "feedforward", "table rows"))))
    laws["spline"], ffs["spline"] = spline_law, mech.feedforward()

    rows = [row for row in ROWS if row in laws]
    runs: dict = {k: {} for k in refs}
    with _step(progress, f"closed-loop evaluation: {len(rows)} laws x {len(refs)} references", release=False):
        jobs = [(row, rname) for row in rows for rname in refs]
        out = experiment.run_laws(setup, [laws[row] for row, _ in jobs], [refs[rn] for _, rn in jobs],
                                [ffs[row] for row, _ in jobs], seeds=[reference_seed(seed, rn) for _, rn in jobs])
        for (row, rname), res in zip(jobs, out):
            runs[rname][row] = res

    metrics = {rname: {row: experiment.run_metrics(res, cfg.evaluation.lowpass_hz) for row, res in rows.items()}
               for rname, rows in runs.items()}
    return ReproduceResult(setup=setup, calibration=cal, identification=tuple(id_res), identification_seconds=t_id,
                           pgnn=pgnn, physics=physics, references=refs, runs=runs, feedforward=ffs, tables=tables,
                           metrics=metrics, identification_direction=tuple(id_dir), pgnn_direction=pgnn_dir,
                           sensorless=sensorless, spline=spline, mechanics=mech).with_diagnostics()


__all__ = ["ROWS", "REALISABLE", "PAPER", "Diagnostics", "ReproduceResult", "run", "quick_config", "paper_improvement", "model_error",
           "filtered_noise_mse"]
