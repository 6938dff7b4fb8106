"""The experiment plan a rig runs for one round of Algorithm 1 and for Algorithm 2.

The data sets of both algorithms are the same experiments (paper, §Experimental results,
eq. DataSets): for every coil set ``l`` and ``i = 1, 2`` the closed loop follows the
data-generation reference (Fig. Data_Generation: back-and-forth moves over the stroke at
several speeds) with

* only coil set ``l`` commanded, by the drive's fixed commutation at this round's ``k̂^l``,
  ``ζ̂^l`` with the force command ``Fy_ref_l = Fy*`` and the phase offset ``Δ^l = (-1)^i Δ0``;
* every other coil set commanded to zero force (its drive enabled, its current zero), so that
  the force measured is coil set ``l``'s alone;
* no feedforward (the feedback loop alone; the feedforward would be built from the force
  model that is being calibrated).

A round: run the ``2 L`` experiments with the drive at ``k̂, ζ̂``, log them, calibrate
(``pgcomm calibrate --data``), put the new ``k̂, ζ̂`` into the drive and run the plan again,
until the step is below the round's noise. The logs of the last round identify the model
(``pgcomm identify --data``).

:func:`make_plan` builds a :class:`Plan`; :mod:`pgcomm.io.plan` writes it as files a
controller plays back and reads it back (``pgcomm simulate --plan`` runs it on the twin).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from pgcomm import trajectory
from pgcomm.errors import ConfigError
from pgcomm.motor import Motor

__all__ = ["Experiment", "Plan", "make_plan", "reference_settings", "log_columns"]


@dataclass(frozen=True)
class Experiment:
    """One data set ``Z_i^l`` of the plan.

    Attributes:
        name: file stem, ``"Z{i}_coilset{l}"`` (1-based ``i``, ``l``).
        coil_set: the commanded coil set (0-based).
        delta: its phase offset ``Δ^l`` (rad).
    """

    name: str
    coil_set: int
    delta: float


@dataclass(frozen=True)
class Plan:
    """The experiments of one round.

    Attributes:
        motor: the drive's fixed commutation this round (``k̂``, ``ζ̂`` per coil set), sample time,
            current limit, travel.
        reference: the data-generation reference every experiment follows (m, s).
        settings: the reference's parameters ``stroke, center`` (m), ``velocities`` (m/s),
            ``a_max`` (m/s²), ``j_max`` (m/s³), ``dwell`` (s).
        experiments: ``2 L`` experiments, coil set by coil set, ``Δ = -Δ0`` first.
        force_sensor: whether the rig measures ``Fy, Fx, Tz`` (else calibration and identification
            use the motion and the moving mass).
    """

    motor: Motor
    reference: trajectory.Reference
    settings: dict
    experiments: tuple[Experiment, ...]
    force_sensor: bool = True

    @property
    def delta(self) -> float:
        """``Δ0`` (rad)."""
        return abs(self.experiments[0].delta)

    @property
    def duration(self) -> float:
        """Length of one experiment (s)."""
        return float(self.reference.t[-1] + self.reference.sample_time)

    def experiment(self, name: str) -> Experiment:
        """The experiment called ``name``; :class:`ConfigError` listing the names otherwise."""
        for e in self.experiments:
            if e.name == name:
                return e
        raise ConfigError(f"no experiment {name!r} in the plan; it has {', '.join(e.name for e in self.experiments)}")


def reference_settings(rc, motor: Motor) -> dict:
    """The data-generation reference's parameters for a rig, resolved against its travel.

    Args:
        rc: :class:`pgcomm.settings.ReferenceConfig`; ``stroke`` (half stroke, m) and ``center`` (m)
            may be ``None``: then the reference spans the motor's ``travel``.
        motor: the rig's motor; its ``travel`` (m), when known, bounds the reference.

    Returns:
        ``{"stroke", "center", "velocities", "a_max", "j_max", "dwell"}`` (SI units).

    Raises:
        ConfigError: no stroke and no travel, or a reference that leaves the travel.
    """
    stroke, center = rc.stroke, rc.center
    if motor.travel is not None:
        lo, hi = motor.travel
        if stroke is None:
            center = 0.5 * (lo + hi) if center is None else center
            stroke = min(hi - center, center - lo)
            if stroke <= 0:
                raise ConfigError(f"[reference] center = {center:g} m lies outside the motor's travel "
                                  f"{list(motor.travel)} m")
        center = 0.0 if center is None else center
        if center - stroke < lo - 1e-12 or center + stroke > hi + 1e-12:
            raise ConfigError(f"the reference spans [{center - stroke:.6g}, {center + stroke:.6g}] m, outside the "
                              f"motor's travel {list(motor.travel)} m; reduce [reference] stroke or move center")
    elif stroke is None:
        raise ConfigError("the experiments' stroke is unknown: give the motor's travel (travel = [lo, hi] in m in "
                          "the motor TOML) or [reference] stroke (half stroke, m) in --config")
    center = 0.0 if center is None else center
    return {"stroke": float(stroke), "center": float(center), "velocities": [float(v) for v in rc.velocities],
            "a_max": float(rc.a_max), "j_max": float(rc.j_max), "dwell": float(rc.dwell)}


def make_plan(motor: Motor, settings: dict, delta: float = math.pi / 4, force_sensor: bool = True) -> Plan:
    """The plan of one round: ``Z_1^l`` (``Δ = -Δ0``) and ``Z_2^l`` (``+Δ0``) for every coil set.

    Args:
        motor: the drive's commutation this round (``k̂``, ``ζ̂``), its sample time (s).
        settings: :func:`reference_settings`.
        delta: ``Δ0`` (rad), ``0 < Δ0 <= π/4`` (the paper's bound for safety).
        force_sensor: whether the rig logs ``Fy, Fx, Tz``; without, ``motor.mass`` (kg) is required.

    Returns:
        :class:`Plan`.

    Raises:
        ConfigError: ``Δ0`` out of range, no mass without a force sensor, a bad reference setting.
    """
    if not 0 < abs(delta) <= math.pi / 4 + 1e-12:
        raise ConfigError(f"[calibration] delta = {delta:g} rad: expected 0 < |delta| <= pi/4 (paper: for safety)")
    if not force_sensor and motor.mass is None:
        raise ConfigError("a rig without a force sensor needs the moving mass: add mass = ... (kg) to the motor TOML")
    ref = trajectory.data_generation_reference(motor.sample_time, settings["stroke"], tuple(settings["velocities"]),
                                               settings["a_max"], settings["j_max"], settings["dwell"])
    if settings["center"]:
        ref = replace(ref, r=ref.r + settings["center"])
    d0 = abs(float(delta))
    exps = tuple(Experiment(f"Z{i + 1}_coilset{l + 1}", l, s * d0)
                 for l in range(motor.n_coil_sets) for i, s in enumerate((-1.0, 1.0)))
    return Plan(motor, ref, dict(settings), exps, bool(force_sensor))


def log_columns(n_coil_sets: int, force_sensor: bool = True) -> dict[str, str]:
    """Columns a rig logs for the plan's experiments: name -> meaning (with unit).

    Args:
        n_coil_sets: ``L``.
        force_sensor: include ``Fy, Fx, Tz``.
    """
    cols = {"t": "time (s), uniform at the controller's sample time",
            "r": "reference position (m), the plan's r",
            "y": "measured position (m), the encoder",
            "Fy_star": "demanded force Fy* of the feedback loop (N)"}
    for l in range(1, n_coil_sets + 1):
        cols[f"Fy_ref_{l}"] = f"force command sent to coil set {l}'s drive (N, signed; 0 when not commanded)"
        cols[f"delta_{l}"] = f"phase offset sent to coil set {l}'s drive (rad; the plan's Delta, else 0)"
        cols[f"ia_{l}"] = f"phase current a of coil set {l} (A), if the drive reports it"
        cols[f"ib_{l}"] = f"phase current b of coil set {l} (A), if the drive reports it"
    if force_sensor:
        cols.update({"Fy": "measured propulsion force (N)", "Fx": "measured normal force (N)",
                     "Tz": "measured torque about z (N m)"})
    return cols

