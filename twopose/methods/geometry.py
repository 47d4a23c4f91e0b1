"""What a method's measurements make, geometrically: one object on its spec.

A method's :attr:`~twopose.methods.specs.MethodSpec.geometry` says what its views' measurements
meet in (thesis chapter 3):

- :class:`RaysToPoint`: each view's ray through its image point; the rays meet at the
  point (method 1, thesis eq. 3.9);
- :class:`PlanesToLine`: each view's image line back-projected to a plane; the planes meet
  in the line (the fixed line, eq. 3.17);
- :class:`PlanesToPlanePoint`: those planes' line cut by the method's plane (method 2 on
  the ground ``y = h``, eq. 19; any :class:`~twopose.methods.planes.ConstraintPlane`).

A caller that does something different per geometry (draws a trial from above, draws its
views in 3-D, places the simulator's target, sets up the sensitivity sweeps) writes one
:class:`GeometryCases` (a method per kind, the one place its meaning lives) and asks the
spec: ``spec.geometry_cases(cases)``. The type checker then fails a caller that misses a
kind; nothing switches on flags or names. Plain classes: this module imports nothing heavy.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Protocol, TypeVar

from typing_extensions import override

from twopose.methods.planes import ConstraintPlane

__all__ = [
    "GeometryCases",
    "MethodGeometry",
    "PlanesToLine",
    "PlanesToPlanePoint",
    "RaysToPoint",
]

T = TypeVar("T")
T_co = TypeVar("T_co", covariant=True)


class GeometryCases(Protocol[T_co]):
    """What a caller does for each kind of geometry (:meth:`MethodGeometry.cases`)."""

    def rays_to_point(self) -> T_co:
        """Method 1's: each view's ray through its image point; the rays meet at the point."""
        ...

    def planes_to_line(self) -> T_co:
        """The fixed line's: each view's plane (its image line back-projected); their line."""
        ...

    def planes_to_plane_point(self, plane: ConstraintPlane) -> T_co:
        """Method 2's: the views' planes' line cut by ``plane`` (the ground, a wall)."""
        ...


class MethodGeometry(ABC):
    """What a method's views' measurements meet in (the module docstring)."""

    #: Whether the method's spec names a plane (:attr:`~twopose.methods.specs.MethodSpec.plane`)
    #: that this geometry cuts with (checked when the spec is made).
    takes_plane = False

    @abstractmethod
    def cases(self, cases: GeometryCases[T], plane: ConstraintPlane | None) -> T:
        """``cases``' case of this geometry (``plane``: the method's, for one that takes it)."""


@dataclass(frozen=True)
class RaysToPoint(MethodGeometry):
    """Each view's ray through its image point; the rays meet at the point (method 1)."""

    @override
    def cases(self, cases: GeometryCases[T], plane: ConstraintPlane | None) -> T:
        """The rays' case."""
        return cases.rays_to_point()


@dataclass(frozen=True)
class PlanesToLine(MethodGeometry):
    """Each view's image line back-projected to a plane; the planes meet in the line."""

    @override
    def cases(self, cases: GeometryCases[T], plane: ConstraintPlane | None) -> T:
        """The line's case."""
        return cases.planes_to_line()


@dataclass(frozen=True)
class PlanesToPlanePoint(MethodGeometry):
    """The views' planes' line cut by the method's plane (method 2: the ground)."""

    takes_plane = True

    @override
    def cases(self, cases: GeometryCases[T], plane: ConstraintPlane | None) -> T:
        """The plane's case, with the method's plane."""
        if plane is None:  # pragma: no cover - MethodSpec refuses such an entry
            raise ValueError("a point on a plane needs the method's plane")
        return cases.planes_to_plane_point(plane)
