"""The mechanics from the same data sets: mass, viscous friction and the direction force along the stroke.

The paper's stated future work is to merge commutation with the feedforward. With a force
model ``F̂`` identified from the measured force (:mod:`pgcomm.identify.spline`), the motion of
the same experiments gives the translator's mechanics::

    F̂_y(y, i, ẏ) = m ÿ + f_v ẏ + D(y) s(ẏ),      s(ẏ) = tanh(ẏ / v_ε)

``F̂_y`` is the model's driving force of the coil set that was active (its direction term
included: the electromagnetic direction force is the commutation law's to cancel), so ``D(y)``
is the rest of what depends on the direction of motion: Coulomb friction of guides and cable
slab, position dependent, on a uniform knot grid (hat functions, as every table of the package).
Everything is linear in ``θ = [m, f_v, D_0 … D_M]``, one least-squares problem over all coil
sets' experiments (they share one translator) with a second-difference penalty on ``D``; its
knot spacing and weight are chosen by cross-validation over time blocks
(:class:`pgcomm.identify.spline.Normal`).

Both sides go through the zero-phase filter of identification without a force sensor
(:class:`pgcomm.sensorless.AccelerationFilter`): ``ÿ`` from the second difference of the
positions, ``F̂_y`` with the zero-order hold's half-sample average, the friction columns without
it (:meth:`pgcomm.sensorless.SensorlessData.filtered_friction` says why); windows where the
translator is slow (reversals, standstill) are left out (:func:`pgcomm.sensorless.moving_windows`).

The feedforward that follows (:meth:`MechanicsFit.feedforward`) is eq. FeedforwardController with
the position-dependent Coulomb term ``D(r) sign(ṙ)`` instead of one constant ``f_c``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from pgcomm.control import Feedforward
from pgcomm.data import CoilSetData
from pgcomm.errors import DataError
from pgcomm.identify.spline import Normal, fold_labels, second_difference
from pgcomm.interp import hat_basis
from pgcomm.sensorless import AccelerationFilter, filter_windows, filtered_acceleration, moving_windows
from pgcomm.spline_model import Grid

__all__ = ["MechanicsFit", "identify_mechanics", "combined_mechanics", "DIRECTION_SPACINGS"]

#: Candidate knot spacings of ``D(y)``, in pole pitches.
DIRECTION_SPACINGS = (4.0, 2.0, 1.0, 0.5, 0.25)
#: Candidate smoothness weights (dimensionless; the penalty is scaled by the mean diagonal of the ``D`` block).
LAMBDAS = (1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)
#: Cross-validation folds and block length in filtered windows.
FOLDS = 5
BLOCK_WINDOWS = 50


@dataclass(frozen=True)
class MechanicsFit:
    """The translator's mechanics identified from the motion (module docstring).

    Attributes:
        mass: ``m`` (kg). viscous: ``f_v`` (N s/m).
        knots: ``(M,)`` knots (m) of ``D(y)``; coulomb: ``(M,)`` ``D`` at the knots (N).
        direction_velocity: ``v_ε`` (m/s).
        cost: mean squared residual of the filtered equation (N²); cost_validation: its CV value.
        spacing: chosen knot spacing (m); lam: chosen weight; windows: filtered windows used;
        filter: the acceleration filter (``to_dict``); seconds: wall time (s).
    """

    mass: float
    viscous: float
    knots: np.ndarray
    coulomb: np.ndarray
    direction_velocity: float
    cost: float
    cost_validation: float
    spacing: float
    lam: float
    windows: int
    filter: dict = field(default_factory=dict)
    seconds: float = 0.0

    def coulomb_at(self, y) -> np.ndarray:
        """``D(y)`` (N) at positions ``y`` (m), held at the grid's ends."""
        return np.interp(np.asarray(y, float), self.knots, self.coulomb)

    def feedforward(self) -> Feedforward:
        """The feedforward of eq. FeedforwardController with ``D(r) sign(ṙ)`` in place of ``f_c sign(ṙ)``."""
        return Feedforward(mass=self.mass, viscous=self.viscous, coulomb=0.0,
                           coulomb_knots=tuple(float(k) for k in self.knots),
                           coulomb_table=tuple(float(c) for c in self.coulomb))

    def to_dict(self) -> dict:
        """JSON-ready (no computation)."""
        return {"mass": self.mass, "viscous": self.viscous, "coulomb_mean": float(np.mean(self.coulomb)),
                "coulomb_knots": [float(k) for k in self.knots], "coulomb_table": [float(c) for c in self.coulomb],
                "direction_velocity": self.direction_velocity, "cost": self.cost,
                "cost_validation": self.cost_validation, "spacing_m": self.spacing, "lambda": self.lam,
                "windows": self.windows, "filter": self.filter, "seconds": self.seconds}


def identify_mechanics(data: list[CoilSetData], model, sample_time: float, pole_pitch: float,
                       direction_velocity: float = 1e-3, spacings=DIRECTION_SPACINGS, lambdas=LAMBDAS) -> MechanicsFit:
    """``m``, ``f_v`` and ``D(y)`` from the motion of the data sets and a force model (module docstring).

    Args:
        data: per coil set its :class:`CoilSetData` (with velocities), experiments in ``experiment``.
        model: a combined force model with ``force(y, currents (S, L, 2), v)`` (e.g. a
            :class:`pgcomm.spline_model.SplineModel`), identified from the same data.
        sample_time: ``T_s`` (s); pole_pitch: ``d_m`` (m); direction_velocity: ``v_ε`` (m/s).
        spacings: candidate knot spacings of ``D`` (pole pitches); lambdas: candidate weights.

    Raises:
        DataError: data without velocities, or too few moving windows to cross-validate.
    """
    t0 = time.perf_counter()
    n_sets = len(data)
    force_cols, accel, fric_raw, segs = [], [], [], []
    filt = None
    for l, d in enumerate(data):
        if d.velocity is None:
            raise DataError(f"{d.name}: the mechanics need velocities (CoilSetData.with_velocity)")
        if filt is None:
            filt = AccelerationFilter.for_motion(np.concatenate([x.velocity for x in data]), sample_time, pole_pitch)
        starts, _ = moving_windows(filt, d.velocity, d.experiment, direction_velocity)
        if starts.size == 0:
            continue
        cur = np.zeros((d.n, n_sets, 2))
        cur[:, l, :] = d.currents
        fy = np.asarray(model.force(d.y, cur, d.velocity))[:, 0]
        force_cols.append(filter_windows(filt, starts, fy))
        accel.append(filtered_acceleration(filt, starts, d.y))
        idx = starts[:, None] + 1 + np.arange(filt.length)
        s = np.tanh(d.velocity / direction_velocity)
        fric_raw.append((d.y[idx], d.velocity[idx], s[idx]))
        segs.append(np.full(starts.size, l))
    if not force_cols:
        raise DataError("no window in which the translator moves: the mechanics cannot be identified")
    target = np.concatenate(force_cols)
    a_f = np.concatenate(accel)
    n_win = target.shape[0]
    if n_win < FOLDS * BLOCK_WINDOWS:
        raise DataError(f"{n_win} filtered windows of motion; the mechanics need at least {FOLDS * BLOCK_WINDOWS}")
    y_all = np.concatenate([f[0].ravel() for f in fric_raw])
    lo, hi = float(y_all.min()), float(y_all.max())
    taps = filt.taps
    fold = np.concatenate([fold_labels(s.size, FOLDS, BLOCK_WINDOWS) for s in segs])
    best = None
    for frac in spacings:
        grid = Grid.with_spacing(lo, hi, frac * pole_pitch)
        cols = [a_f, np.concatenate([v @ taps for _, v, _ in fric_raw])]
        hats = np.concatenate([np.einsum("jmk,m->jk", hat_basis(yw.ravel(), grid.lo, grid.hi, grid.n)
                                         .reshape(yw.shape + (grid.size,)) * sw[..., None], taps)
                               for yw, _, sw in fric_raw])
        m = np.column_stack(cols + [hats])

        def penalty(g, size=grid.size):
            d2 = second_difference(size, 1, 2, 2 + size)
            return float(np.mean(np.diag(g)[2:])) * d2.T @ d2

        normal = Normal.build(m, target, fold, FOLDS, penalty)
        theta, lam, cv, train = normal.fit(lambdas)
        if best is None or cv[0] < best[0]:
            best = (float(cv[0]), float(train[0]), theta[:, 0], float(lam[0]), grid)
    cv, train, theta, lam, grid = best
    return MechanicsFit(mass=float(theta[0]), viscous=float(theta[1]), knots=grid.knots, coulomb=theta[2:],
                        direction_velocity=float(direction_velocity), cost=train, cost_validation=cv,
                        spacing=grid.spacing, lam=lam, windows=n_win, filter=filt.to_dict(),
                        seconds=time.perf_counter() - t0)


def combined_mechanics(res) -> tuple[dict, dict]:
    """The translator's mechanics from every coil set's identification, and the feedforward's parameters.

    Every coil set's experiments move the same translator, so its friction is estimated once per
    coil set; the combination is their mean weighted by the number of filtered windows: viscous
    ``f_v``, the Coulomb table ``F_c(y)`` (each coil set's piecewise-linear table on common knots
    over the union of their spans, held constant beyond a table's own span) and its stroke mean
    ``f_c``. The mass is the given one.

    Returns:
        ``(mechanics, feedforward)``: ``{"mass", "coulomb", "viscous", "friction_velocity",
        "coulomb_knots", "coulomb_table", "coil_sets": [per coil set]}`` and ``{"mass" (kg),
        "viscous" (N s/m), "coulomb" (N)}`` (the fields of :class:`pgcomm.control.Feedforward`).
    """
    mech = [r.mechanics for r in res]
    w = np.array([m.windows for m in mech], float)
    coulomb = float(np.average([m.coulomb for m in mech], weights=w))
    viscous = float(np.average([m.viscous for m in mech], weights=w))
    mass = float(mech[0].mass)
    mechanics = {"mass": mass, "coulomb": coulomb, "viscous": viscous,
                 "friction_velocity": float(mech[0].friction_velocity)}
    lo = min(m.coulomb_knots[0] for m in mech)
    hi = max(m.coulomb_knots[-1] for m in mech)
    n = max(len(m.coulomb_knots) for m in mech)
    knots = np.linspace(lo, hi, n)
    table = np.average([np.interp(knots, m.coulomb_knots, m.coulomb_table) for m in mech], axis=0, weights=w)
    mechanics.update(coulomb_knots=[float(x) for x in knots], coulomb_table=[float(x) for x in table])
    mechanics["coil_sets"] = [dict(m.to_dict(), name=r.name) for m, r in zip(mech, res)]
    return mechanics, {"mass": mass, "viscous": viscous, "coulomb": coulomb}
