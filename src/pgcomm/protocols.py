"""The three interfaces the pipeline is written against, as :class:`typing.Protocol` s.

One argument order everywhere: position, then currents, then velocity (``force(y, currents, v)``),
shapes vectorised over a leading ``S``. The classes are structural: the twin, force maps and zoo
motors are :class:`Plant` s; PGNN, physics-only, spline models and the plants themselves are
:class:`ForceModel` s; the classical, drive-input and model-based laws are :class:`Law` s. Nothing
needs to inherit from them; ``isinstance(x, Plant)`` checks the methods' presence
(``runtime_checkable``), not their signatures. :class:`IdentificationData` is what the identification's
optimiser (:mod:`pgcomm.identify`) reads: force-sensor data (:class:`pgcomm.data.CoilSetData`) and data
without a force sensor (:class:`pgcomm.sensorless.SensorlessData`) are its two implementations.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["ForceModel", "Plant", "Law", "IdentificationData"]


@runtime_checkable
class ForceModel(Protocol):
    """A model of the electromagnetic force ``F = Σ_l K^l(y) i^l + F_cog(y) [+ F_dir(y, v)]``."""

    def gain(self, y):
        """``S + (L, 3, 2)`` gains (N/A, N/A, N·m/A) of every coil set for star currents ``(ia, ib)``."""

    def cogging(self, y):
        """``S + (3,)`` current-independent force ``[Fy, Fx, Tz]`` (N, N, N·m)."""

    def force(self, y, currents, v=None):
        """``S + (3,)`` force for currents ``S + (L, 2)`` (A); ``v`` (m/s) adds a direction term if the model has one."""


@runtime_checkable
class Plant(ForceModel, Protocol):
    """The electromagnetic truth a simulation runs against (:mod:`pgcomm.plant`)."""

    @property
    def y_range(self) -> tuple[float, float]:
        """``(y_min, y_max)`` (m): where the plant is defined."""

    def direction_force(self, y, v):
        """``S + (3,)`` velocity-direction-dependent force (N, N, N·m)."""

    def in_range(self, y):
        """``S`` booleans: ``y`` inside :attr:`y_range`."""


@runtime_checkable
class Law(Protocol):
    """A commutation law: the currents that should make the desired force (:mod:`pgcomm.commutation`)."""

    def currents(self, y, f_star, v=None):
        """``S + (L, 2)`` star currents (A) for position ``S`` (m), desired force ``S + (3,)`` (N, N, N·m) and
        velocity ``S`` (m/s; used by laws with a direction term)."""


@runtime_checkable
class IdentificationData(Protocol):
    """One coil set's data as the identification's optimiser reads them, whatever the sensor.

    Each of the ``n`` output samples ``j`` compares a measured side ``force[j, observed]`` with the model
    evaluated on a window of raw samples ``raw[window_index()[j]]`` and weighed by ``regressor_taps``
    (a linear filter; ``[1]`` for a force sensor's samples), minus the known friction columns times
    their coefficients (none for a force sensor). Force-sensor data are the case of a one-sample window,
    all three rows observed and no friction; data without a force sensor filter the motion
    (``m ÿ_f``), observe the driving row only and fit the friction with the model.

    Attributes:
        name: for messages; n: number of output samples.
        raw: the samples the model is evaluated on (:class:`pgcomm.data.CoilSetData`).
        force: ``(n, 3)`` measured side (N, N, N·m); only the rows ``observed`` are measured.
        observed: indices of the measured rows.
        n_friction: number of friction columns fitted with the model (0: none).
    """

    name: str
    observed: tuple

    @property
    def n(self) -> int: ...

    @property
    def raw(self): ...

    @property
    def force(self): ...

    @property
    def n_friction(self) -> int: ...

    @property
    def regressor_taps(self):
        """``(W,)`` taps weighing a window's ``W`` raw samples into one regressor row."""

    def window_index(self):
        """``(n, W)`` indices into ``raw`` of each output sample's window."""

    def filtered(self, columns):
        """``(n,)``/``(n, k)``: raw columns ``(N_raw,)``/``(N_raw, k)`` through the filter at the output samples."""

    def filtered_friction(self):
        """``(n, n_friction)`` friction columns at the output samples."""

    def physics_nuisance(self, pole_pitch: float):
        """``(n, k)`` position-only columns the physics-only least squares fits beside the model (may be ``k = 0``)."""

    def split(self, validation_fraction: float, block_size: int):
        """``(train, validation)``, each of the same kind, by contiguous blocks."""

    def mechanics(self, friction):
        """What the fitted friction coefficients ``(n_friction,)`` say of the mechanics, or ``None``."""

