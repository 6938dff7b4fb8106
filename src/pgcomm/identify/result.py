"""The result of identifying one coil set (Algorithm 2): models, costs, iterations, stop reason."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pgcomm.models import CoilSetModel

#: Why the Levenberg–Marquardt loop of a start stopped (codes of :mod:`pgcomm.identify.lm`).
STOP_REASONS = {0: "running", 1: "relative cost change below tol", 2: "step below tol",
                3: "damping above 1e10 (no further decrease)", 4: "maximum iterations", 5: "non-finite cost",
                6: "predicted decrease below decrease_tol"}

#: Iterations over which :attr:`IdentifyResult.final_fall` measures what a start still gained when it stopped.
FALL_WINDOW = 10


@dataclass(frozen=True)
class IdentifyResult:
    """Identification of one coil set (Algorithm 2).

    Costs follow eq. Identification_CostFunction with ``2N`` the number of samples of the set
    they are evaluated on:

    * ``cost_physics``: physics-only model on the training data (data term; its Λ term is 0
      because ``θ_phy = θ_phy*``);
    * ``cost_pgnn``: the paper's ``V`` of the PGNN on the training data (data + Λ term; the
      optional ``ridge`` and numerical ``damping`` terms, minimised with it, are NOT included,
      see ``ridge_term`` and ``damping_term``);
    * ``cost_pgnn_data``: data term only of ``cost_pgnn``;
    * ``cost_physics_validation``, ``cost_pgnn_validation``: DATA TERM ONLY on the validation
      data (a prediction error; comparable between models);
    * ``cost_pgnn_validation_full``: validation data term + the same Λ term (the full ``V``).

    Validation costs are NaN when ``n_validation == 0``.

    ``cost_y`` / ``cost_y_physics``: the paper's y cost of its Remark on ``sign(dy/dt)``,
    ``mean_t (Fy - F̂y)²`` (N²) on the training data, of the identified model / the physics-only model
    (:func:`pgcomm.identify.projection.cost_y`).

    ``mechanics``: identification without a force sensor only (else ``None``): the given mass
    (kg), the identified Coulomb ``coulomb`` (N, with the motor's direction-dependent force) and
    viscous ``viscous`` (N s/m) friction, the Coulomb column's ``friction_velocity`` (m/s), the
    acceleration filter and the number of filtered windows; costs are then of the y row on
    filtered windows (``mean (m ÿ_f - F̂_y,f - friction)²``, N²).

    ``iterations``: LM iterations of the kept start over both phases; ``start_costs``: the
    objective of every start at the end of phase 1 (on its subsample; the single phase if
    there is only one); ``history``: per phase, the best objective (``V`` plus the ridge and
    damping terms) after each iteration, index 0 being the starting points.
    """

    name: str
    model: CoilSetModel
    physics_model: CoilSetModel
    cost_physics: float
    cost_pgnn: float
    cost_pgnn_data: float
    cost_physics_validation: float
    cost_pgnn_validation: float
    cost_pgnn_validation_full: float
    iterations: int
    seconds: float
    ridge: float
    ridge_term: float
    damping: float
    damping_term: float
    n_train: int
    n_validation: int
    seed: int
    n_starts: int
    start_costs: tuple = ()
    stop_reason: str = ""
    slope_bound: float = float("inf")
    slope_term: float = 0.0
    width_selection: tuple = ()
    cost_y: float = float("nan")
    cost_y_physics: float = float("nan")
    mechanics: object = None  # FrictionFit (pgcomm.sensorless) without a force sensor
    history: tuple = field(default=(), repr=False)

    @property
    def converged(self) -> bool:
        """Whether the kept start stopped on a convergence test (not on the iteration cap or a non-finite cost)."""
        return self.stop_reason in (STOP_REASONS[1], STOP_REASONS[2], STOP_REASONS[3], STOP_REASONS[6])

    @property
    def final_fall(self) -> float | None:
        """The relative fall of the best objective over the last :data:`FALL_WINDOW` iterations of the last phase
        (``1 − V_end / V_{end−10}``; ``None`` with fewer iterations): how much a start still gained when it stopped.
        Near zero for a converged start; at the iteration cap, what more iterations would still give."""
        last = self.history[-1] if self.history else ()
        if len(last) <= FALL_WINDOW or not (np.isfinite(last[-1]) and np.isfinite(last[-1 - FALL_WINDOW])):
            return None
        return float(1.0 - last[-1] / last[-1 - FALL_WINDOW]) if last[-1 - FALL_WINDOW] > 0 else None

    def convergence_text(self) -> str | None:
        """One line where the kept start did not converge (the iteration cap or a non-finite cost), else ``None``."""
        if self.converged:
            return None
        fall = self.final_fall
        still = ("" if fall is None
                 else f"; its cost still fell {100 * fall:.2g} % over the last {FALL_WINDOW} iterations")
        return (f"{self.name}: the PGNN's optimisation stopped on {self.stop_reason!r} after {self.iterations} "
                f"iterations, not converged{still} (raise identification.max_iterations for a closer optimum)")

    def to_dict(self) -> dict:
        """JSON-ready summary (keys of ``results.json`` ``identification.coil_sets[l]``)."""
        keys = ("name", "cost_physics", "cost_pgnn", "cost_pgnn_data", "cost_physics_validation",
                "cost_pgnn_validation", "cost_pgnn_validation_full", "iterations", "seconds", "ridge",
                "ridge_term", "damping", "damping_term", "n_train", "n_validation", "seed", "n_starts", "stop_reason",
                "slope_bound", "slope_term", "cost_y", "cost_y_physics")
        out = {key: getattr(self, key) for key in keys}
        out["start_costs"] = list(self.start_costs)
        out["converged"] = self.converged
        out["cost_fall_last_iterations"] = self.final_fall
        out["force_sensor"] = self.mechanics is None
        if self.mechanics is not None:
            out["mechanics"] = self.mechanics.to_dict()
        out["gain_width"] = self.model.gain_nets[0].widths[-1] if self.model.gain_nets is not None else None
        out["width_selection"] = [{"gain_width": w, "cost_validation": v} for w, v in self.width_selection]
        return {key: (None if isinstance(v, float) and not np.isfinite(v) else v) for key, v in out.items()}
