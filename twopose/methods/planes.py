"""The planes a method's estimate is constrained to: what a plane is, once.

Method 2 (thesis section 3.3) finds where the finger points by cutting the line of its two
back-projected planes with the ground plane ``y = h`` (thesis eq. 19, DESIGN.md's method 2),
``h`` the camera centre's height above the table, typed by the operator. Nothing in that
solution needs the plane to be the ground: any plane ``n . p = c`` of the grid frame whose
offset ``c`` the operator measures serves (a wall ``x = c``). A :class:`ConstraintPlane`
says which plane, and every layer reads it from the method's spec
(:attr:`twopose.methods.specs.MethodSpec.plane`):

- the setup asks its offset under :attr:`ConstraintPlane.setup_key` (the terminal's
  question, the page's field, a plan's key), with its words and its bound;
- the session stores it as a :class:`twopose.format.entries.PlaneEntry` (normal, offset);
- the solver cuts the planes' line with it (:func:`twopose.solve.nview.triangulate_ground`);
- a typed ground-truth point is checked to lie on it (:meth:`ConstraintPlane.gap`);
- the simulator places the finger's target on it (:meth:`ConstraintPlane.point`,
  :meth:`ConstraintPlane.toward`);
- every drawing and table of the analysis reads a trial in its two in-plane axes
  (:meth:`ConstraintPlane.in_plane`, :attr:`ConstraintPlane.axis_names`,
  :attr:`ConstraintPlane.axis_titles`): the top view, the error's scatter, the running
  averages and the terminal's bias lines look at the plane face on (the ground from above,
  its x across and z in depth; a wall ``x = c`` from in front, its y across and z up). A
  method on no plane is drawn on the ground's axes
  (:attr:`twopose.methods.specs.MethodSpec.seen_on`).

The planes are registered (:data:`CONSTRAINT_PLANES`, by their setup key): the ground, and
each plane an extension registers (:func:`register_plane`, or with a method that names it,
:func:`twopose.methods.specs.register_method`); a plan's keys, the setup's fields and the
terminal's questions are the registered planes'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from twopose.registry import Registry
from twopose.values.bounds import GROUND_HEIGHT, Quantity
from twopose.values.checks import Vec3

if TYPE_CHECKING:
    from twopose.arrays import F64

__all__ = ["CONSTRAINT_PLANES", "GRID_AXES", "GROUND_PLANE", "ConstraintPlane", "register_plane"]

#: The grid frame's axes by name: an in-plane axis along one of them (positively) is read
#: as that column of a table (``err_x``, ``t_z``, ``sigma_y``) and named by its letter.
GRID_AXES: tuple[tuple[str, Vec3], ...] = (
    ("x", (1.0, 0.0, 0.0)),
    ("y", (0.0, 1.0, 0.0)),
    ("z", (0.0, 0.0, 1.0)),
)


@dataclass(frozen=True, kw_only=True)
class ConstraintPlane:
    """A plane ``normal_grid . p = offset`` of the grid frame, its offset typed per session.

    ``in_plane_grid`` are two unit axes spanning the plane (with ``normal_grid``, a right- or
    left-handed frame, it does not matter): a point of the plane is ``offset * normal +
    a * in_plane[0] + b * in_plane[1]``. For the ground, ``(x, z)`` on the table.
    """

    #: What the plane is, in the operator's words ("the ground", "the wall").
    name: str
    #: The plane's unit normal in the grid frame ((0, 1, 0): y down to the table).
    normal_grid: Vec3
    #: Two unit axes spanning the plane, orthogonal to the normal and to each other.
    in_plane_grid: tuple[Vec3, Vec3]
    #: The setup's key for the offset: the page's field, a plan's key, the session's
    #: setup record ("ground_height").
    setup_key: str
    #: The setup's label for the offset (the page's field and the terminal's question).
    label: str
    #: What the operator measures for the offset, for an empty answer's message ("the
    #: height of the camera centre above the table").
    measured: str
    #: The offset's equation, for messages ("y = h").
    equation: str
    #: The axis letter a ground-truth point's coordinate on the normal is named by ("y").
    axis: str
    #: The offset's range and words (:mod:`twopose.values.bounds`): what a typed offset may be.
    bound: Quantity
    #: The offset in the thesis' setup, in inches (None: nothing to assume); the setup
    #: offers it where the units are the thesis'.
    thesis_offset_in: float | None = None
    #: The offset's key in ``twopose-analyze solve``'s request (None: :attr:`setup_key`).
    request_key: str | None = None
    #: How a drawing's axes name the two in-plane axes, in :attr:`in_plane_grid`'s order
    #: (the ground's "x" across and "z, depth"); empty: their :attr:`axis_names`.
    axis_titles: tuple[str, str] | tuple[()] = ()
    #: What a drawing looking at the plane face on is called ("top view"); empty: "view
    #: facing" and the plane's :attr:`name` ("view facing the wall").
    view_name: str = ""
    #: How a caption says where it is seen from ("from above"); empty: "facing" and the
    #: plane's :attr:`name`.
    seen_from: str = ""
    #: How a caption says which way its axes run ("x across, z in depth"); empty: the
    #: first of :attr:`axis_names` across, the second up.
    axes_words: str = ""

    def __post_init__(self) -> None:
        """Check the axes: unit length and orthogonal (a typo in a new plane's entry)."""

        # Plain Python: the registry builds its planes on import, which loads no NumPy.
        def dot(a: Vec3, b: Vec3) -> float:
            return sum(x * y for x, y in zip(a, b, strict=True))

        n, (u, v) = self.normal_grid, self.in_plane_grid
        if not all(math.isclose(dot(a, a), 1.0, abs_tol=1e-9) for a in (n, u, v)):
            raise ValueError(f"{self.name}: every axis must be a unit vector")
        if not all(math.isclose(dot(a, b), 0.0, abs_tol=1e-9) for a, b in ((n, u), (n, v), (u, v))):
            raise ValueError(f"{self.name}: the normal and in-plane axes must be orthogonal")

    @property
    def axis_names(self) -> tuple[str, str]:
        """The in-plane axes' short names: a grid axis' letter, else ``u`` and ``v``.

        The ground's are ``("x", "z")``, a wall ``x = c``'s ``("y", "z")``. A lettered
        axis is read straight from a table's column of that letter (``err_x``); ``u`` and
        ``v`` are computed (:func:`analysis.report.plane_axes.with_in_plane`).
        """
        named = {axis: name for name, axis in GRID_AXES}
        u, v = self.in_plane_grid
        return named.get(u, "u"), named.get(v, "v")

    @property
    def noun(self) -> str:
        """The plane's :attr:`name` without its article ("ground", "wall").

        The margin's warning says "line-ground angle".
        """
        return self.name.removeprefix("the ")

    @property
    def titles(self) -> tuple[str, str]:
        """How a drawing's axes name the in-plane axes.

        Its :attr:`axis_titles`, else its :attr:`axis_names`.
        """
        return self.axis_titles or self.axis_names

    @property
    def drawing_name(self) -> str:
        """What a drawing looking at the plane face on is called (:attr:`view_name`)."""
        return self.view_name or f"view facing {self.name}"

    @property
    def seen_words(self) -> str:
        """Where such a drawing is seen from, in a caption's words (:attr:`seen_from`)."""
        return self.seen_from or f"facing {self.name}"

    @property
    def axes_said(self) -> str:
        """Which way a drawing's axes run, in a caption's words (:attr:`axes_words`)."""
        a, b = self.axis_names
        return self.axes_words or f"{a} across, {b} up"

    def in_plane(self, points: F64) -> F64:
        """``points`` (..., 3) of the grid frame as their in-plane coordinates (..., 2).

        An axis that is a grid axis takes that coordinate as it is (its sign, a NaN of
        another coordinate, unchanged): the ground's ``(x, z)`` are the points' x and z.
        """
        import numpy as np  # on use: importing the registry stays light

        u, v = self.in_plane_grid
        return np.stack([_along(points, u), _along(points, v)], axis=-1)

    def along_normal(self, points: F64) -> F64:
        """``points`` (..., 3) along the plane's normal: each point's ``normal . p``.

        The ground's is the points' y, as it is (a grid axis' coordinate).
        """
        return _along(points, self.normal_grid)

    def in_plane_cov(self, cov: F64) -> F64:
        """Covariances (..., 3, 3) of the grid frame as their in-plane marginals (..., 2, 2).

        ``A C A^T``, ``A`` the in-plane axes as rows.
        """
        import numpy as np  # on use: importing the registry stays light

        A = np.asarray(self.in_plane_grid, dtype=np.float64)
        return np.asarray(A @ np.asarray(cov, dtype=np.float64) @ A.T)

    def plane(self, offset: float) -> tuple[Vec3, float]:
        """``(normal_grid, offset)``: the plane as sessions store it and solvers take it."""
        return self.normal_grid, float(offset)

    def gap(self, point: Vec3 | F64, offset: float) -> float:
        """How far ``point`` lies off the plane, along its normal (+: beyond it)."""
        import numpy as np  # on use: importing the registry stays light

        return float(np.asarray(self.normal_grid) @ np.asarray(point, dtype=np.float64)) - offset

    def point(self, in_plane: tuple[float, float], offset: float) -> F64:
        """The plane's point at ``in_plane`` coordinates (the ground's ``(x, z)``)."""
        import numpy as np  # on use: importing the registry stays light

        n, (u, v) = np.asarray(self.normal_grid), (np.asarray(a) for a in self.in_plane_grid)
        return np.asarray(offset * n + in_plane[0] * u + in_plane[1] * v, dtype=np.float64)

    def toward(self, tilt_deg: float, azimuth_deg: float) -> F64:
        """A unit direction ``tilt_deg`` off the normal, turned by ``azimuth_deg``.

        Turned from the second in-plane axis toward the first: the simulated finger's axis.
        """
        import numpy as np  # on use: importing the registry stays light

        tilt, az = np.deg2rad(tilt_deg), np.deg2rad(azimuth_deg)
        n, (u, v) = np.asarray(self.normal_grid), (np.asarray(a) for a in self.in_plane_grid)
        return np.asarray(
            np.cos(tilt) * n + np.sin(tilt) * (np.sin(az) * u + np.cos(az) * v), dtype=np.float64
        )


def _along(points: F64, axis: Vec3) -> F64:
    """``axis . p`` of each of ``points`` (..., 3).

    The coordinate itself when ``axis`` is a grid axis: exact, whatever the other
    coordinates hold (a NaN, an infinity).
    """
    import numpy as np  # on use: importing the registry stays light

    p = np.asarray(points, dtype=np.float64)
    for i, (_, grid_axis) in enumerate(GRID_AXES):
        if axis == grid_axis:
            return np.asarray(p[..., i])
    return np.asarray(p @ np.asarray(axis, dtype=np.float64))


#: The thesis' ground: the table top ``y = h``, ``h`` the camera centre's height above it
#: (9.625 in in the thesis' setup), method 2's plane.
GROUND_PLANE = ConstraintPlane(
    name="the ground",
    normal_grid=(0.0, 1.0, 0.0),
    in_plane_grid=((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    setup_key="ground_height",
    label="ground height: camera centre to table",
    measured="the height of the camera centre above the table",
    equation="y = h",
    axis="y",
    bound=GROUND_HEIGHT,
    thesis_offset_in=9.625,
    request_key="ground_y",
    axis_titles=("x", "z, depth"),
    view_name="top view",
    seen_from="from above",
    axes_words="x across, z in depth",
)

#: The plane registry, by each plane's :attr:`~ConstraintPlane.setup_key`: the ground first,
#: then those registered (:func:`register_plane`).
CONSTRAINT_PLANES: Registry[str, ConstraintPlane] = Registry(
    "plane", lambda plane: plane.setup_key, (GROUND_PLANE,)
)


def register_plane(plane: ConstraintPlane) -> ConstraintPlane:
    """Add a plane to the registry and return it.

    The plane already registered under its setup key, if it is that plane; another plane
    under a key taken is refused (:class:`ValueError`).
    """
    known = CONSTRAINT_PLANES.get(plane.setup_key)
    if known == plane:
        return known
    return CONSTRAINT_PLANES.register(plane)
