"""The three interfaces the pipeline is written against, as :class:`typing.Protocol` s.

One argument order everywhere: position, then currents, then velocity (``force(y, currents, v)``),
shapes vectorised over a leading ``S``. The classes are structural: the twin, force maps and zoo
motors are :class:`Plant` s; PGNN, physics-only, spline models and the plants themselves are
:class:`ForceModel` s; the classical, drive-input and model-based laws are :class:`Law` s. Nothing
needs to inherit from them; ``isinstance(x, Plant)`` checks the methods' presence
(``runtime_checkable``), not their signatures.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["ForceModel", "Plant", "Law"]


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
