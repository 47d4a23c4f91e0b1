"""The targets as geometry: the pointing finger and the rig calibration's checkerboard.

The finger is a straight axis that points at a spot on the ground: tilted ``tilt_deg`` from
straight down (+y), its horizontal part heading ``azimuth_deg`` from +z toward +x (180
points back at the camera). Used by the simulator to place the finger and by the
sensitivity sweeps to measure it, so both mean the same finger.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.values.checks import Vec3, finite, vec3

__all__ = [
    "FINGER_LENGTH",
    "FINGER_TIP_HEIGHT",
    "MAX_INNER_CORNERS",
    "BoardPlacement",
    "finger_axis",
]

#: A printed checkerboard's inner corners each way, at most (a larger count is a typo).
MAX_INNER_CORNERS = 100

#: The simulated finger's tip height above the ground (along its axis' vertical) and length.
FINGER_TIP_HEIGHT = 6.0
FINGER_LENGTH = 3.0


def finger_axis(
    ground_point_xz: tuple[float, float],
    ground_height: float,
    tilt_deg: float,
    azimuth_deg: float,
    tip_height: float = FINGER_TIP_HEIGHT,
    length: float = FINGER_LENGTH,
    *,
    plane: ConstraintPlane = GROUND_PLANE,
) -> tuple[F64, F64]:
    """Tip and base of a finger whose axis meets ``plane`` at ``ground_point_xz``.

    Tip and base (grid frame) of a finger whose axis meets the plane (the ground ``y = h``
    by default, ``h = ground_height``) at its point ``ground_point_xz`` (the ground's ``(x,
    z)``); tilted ``tilt_deg`` from the plane's normal, the tip ``tip_height`` off the
    plane along the normal, on the camera's side, the base ``length`` behind it.
    """
    direction = plane.toward(tilt_deg, azimuth_deg)
    toward_plane = direction @ np.asarray(plane.normal_grid)  # cos(tilt)
    # The camera (the grid origin) is on the side the offset's sign says: approach from it.
    side = 1.0 if plane.gap((0.0, 0.0, 0.0), ground_height) <= 0 else -1.0
    direction = direction * side
    target = plane.point(ground_point_xz, ground_height)
    tip = target - direction * (tip_height / toward_plane)
    base = tip - direction * length
    return tip, base


@dataclass(frozen=True, kw_only=True)
class BoardPlacement:
    """A printed checkerboard standing upright on the grid paper (a board session's truth).

    ``inner_corners`` (columns, rows) of squares of side ``square`` (session units), its first
    inner corner at the measured grid point ``first_corner``, its rows along +x and its
    columns rising (-y, up from the table), in the plane z = ``first_corner`` z, facing the
    camera (-z).
    """

    inner_corners: tuple[int, int]
    square: float
    first_corner: Vec3

    def __post_init__(self) -> None:
        """Check the corners (at least 2 x 2 whole numbers), the square and the corner."""
        cols_rows = tuple(self.inner_corners)
        if len(cols_rows) != 2 or not all(
            isinstance(n, int | np.integer)
            and not isinstance(n, bool)
            and 2 <= n <= MAX_INNER_CORNERS
            for n in cols_rows
        ):
            raise InputValueError(
                f"a board's inner corners must be two whole numbers 2-{MAX_INNER_CORNERS} "
                f"(columns, rows), got {self.inner_corners!r}"
            )
        object.__setattr__(self, "inner_corners", (int(cols_rows[0]), int(cols_rows[1])))
        object.__setattr__(self, "square", finite(self.square, "board square", positive=True))
        object.__setattr__(self, "first_corner", vec3(self.first_corner, "board first corner"))

    def corners_grid(self) -> F64:
        """The inner corners (cols * rows, 3) in the grid frame.

        Row by row from the first (rows along +x, columns rising along -y), as
        ``cv2.findChessboardCorners`` lists them for an upright board (put in this order by
        :func:`twopose.rig.board.board_order`).
        """
        cols, rows = self.inner_corners
        i, j = np.meshgrid(np.arange(cols), np.arange(rows))
        x0, y0, z0 = self.first_corner
        return np.stack(
            [x0 + self.square * i.ravel(), y0 - self.square * j.ravel(), np.full(i.size, z0)],
            axis=1,
        )

    def to_json(self) -> dict[str, Any]:
        """The session entry's ``board`` object."""
        return {
            "inner_corners": list(self.inner_corners),
            "square": self.square,
            "first_corner": list(self.first_corner),
        }

    @classmethod
    def from_json(cls, data: Any) -> BoardPlacement:
        """Inverse of :meth:`to_json` (the JSON Schema has checked the keys)."""
        return cls(
            inner_corners=tuple(data["inner_corners"]),
            square=data["square"],
            first_corner=data["first_corner"],
        )
