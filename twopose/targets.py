"""The thesis' pointing finger as geometry (method 2 and the fixed line).

The finger is a straight axis that points at a spot on the ground: tilted ``tilt_deg`` from
straight down (+y), its horizontal part heading ``azimuth_deg`` from +z toward +x (180
points back at the camera). Used by the simulator to place the finger and by the
sensitivity sweeps to measure it, so both mean the same finger.
"""

from __future__ import annotations

import numpy as np

from twopose.arrays import F64

__all__ = ["FINGER_LENGTH", "FINGER_TIP_HEIGHT", "finger_axis"]

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
) -> tuple[F64, F64]:
    """Tip and base of a finger whose axis meets the ground at ``(x, h, z)``.

    Tip and base (grid frame) of a finger whose axis meets the ground ``y = h`` at ``(x, h,
    z)``; the tip is ``tip_height`` above the ground, the base ``length`` behind it.
    """
    tilt, az = np.deg2rad(tilt_deg), np.deg2rad(azimuth_deg)
    direction = np.array([np.sin(tilt) * np.sin(az), np.cos(tilt), np.sin(tilt) * np.cos(az)])
    ground = np.array([ground_point_xz[0], ground_height, ground_point_xz[1]])
    tip = ground - direction * (tip_height / np.cos(tilt))
    base = tip - direction * length
    return tip, base
