"""The cameras a rig was fitted for, and the one rule that tells two cameras apart.

A rig's ``focal_scale`` and ``principal_offset_px`` are relative to the camera it was fitted
for (a rig file's ``[[camera]]``, :attr:`twopose.rig.RigConstants.cameras`): the same
constants on another camera's intrinsics describe no camera at all, so a rig is refused
for another (issue 55). Two cameras are the same when their image sizes are and their
intrinsics agree (:data:`CAMERA_TOLERANCE`). No I/O.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError

__all__ = ["CAMERA_TOLERANCE", "camera_words", "check_cameras", "same_camera", "same_size"]

#: Two cameras are the same when their image sizes are and their intrinsics agree to this
#: relative tolerance (a rig file writes them to the last digit; a calibration file gives
#: the same numbers each time it is read).
CAMERA_TOLERANCE = 1e-6
_FIT_AGAIN = (
    "its focal scale and principal offset are relative to the camera it was fitted for; "
    "calibrate a rig with a board session of this camera (twopose-analyze rig)"
)


def same_camera(a: Intrinsics, b: Intrinsics) -> bool:
    """Whether two cameras are the same: size, focal lengths and principal point."""
    return (a.width, a.height) == (b.width, b.height) and all(
        math.isclose(x, y, rel_tol=CAMERA_TOLERANCE, abs_tol=CAMERA_TOLERANCE)
        for x, y in ((a.fx, b.fx), (a.fy, b.fy), (a.cx, b.cx), (a.cy, b.cy))
    )


def camera_words(k: Intrinsics) -> str:
    """A camera in words: ``640x480, f 525 px, principal point (320, 240)``."""
    f = f"{k.fx:g}" if k.fx == k.fy else f"{k.fx:g}/{k.fy:g}"
    return f"{k.width}x{k.height}, f {f} px, principal point ({k.cx:g}, {k.cy:g})"


def same_size(fitted: Sequence[Intrinsics], size: tuple[int, int], what: str = "rig") -> None:
    """Refuse a rig none of whose ``fitted`` cameras takes images of ``size``.

    Known before the rest of a camera is (:func:`check_cameras` judges the whole camera).
    """
    if fitted and all((k.width, k.height) != tuple(size) for k in fitted):
        words = "; ".join(camera_words(c) for c in fitted)
        raise InputValueError(
            f"{what} was fitted for the camera {words}, not for {size[0]}x{size[1]} images: "
            + _FIT_AGAIN
        )


def check_cameras(
    fitted: Sequence[Intrinsics], cameras: Iterable[Intrinsics], what: str = "rig"
) -> list[str]:
    """Refuse a rig for a camera none of its ``fitted`` ones is.

    Returns the note for a rig that records none (a file from before), to show (empty:
    nothing to say).
    """
    cameras = list(cameras)
    if not cameras:
        return []
    if not fitted:
        return [
            f"{what} records no camera (written before rig files did): it is not checked "
            "against this session's camera; write it again with `twopose-analyze rig`"
        ]
    for k in cameras:
        if not any(same_camera(k, c) for c in fitted):
            words = "; ".join(camera_words(c) for c in fitted)
            raise InputValueError(
                f"{what} was fitted for the camera {words}, not for this session's "
                f"{camera_words(k)}: " + _FIT_AGAIN
            )
    return []
