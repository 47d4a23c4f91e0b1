"""Camera calibration (beyond the thesis' fixed f = 525): a checkerboard seen from several
angles, OpenCV's corner finder and ``calibrateCamera``, written as a small TOML file that
``twopose-record new --calibration`` and plan files accept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from recorder.sources import FrameSource
from twopose.camera import Intrinsics
from twopose.config import read_toml
from twopose.errors import InputValueError, SessionExistsError, SourceError

__all__ = ["Calibration", "calibrate", "load_calibration", "save_calibration"]


@dataclass(frozen=True)
class Calibration:
    """Intrinsics with the quality of the fit behind them."""

    intrinsics: Intrinsics
    rms_px: float
    n_views: int


def calibrate(
    source: FrameSource,
    board: tuple[int, int],
    square: float,
    *,
    views: int = 15,
    max_frames: int = 300,
    min_spacing: int = 3,
    on_view: Callable[[int, bool], None] | None = None,
) -> Calibration:
    """Collect ``views`` frames where the ``board`` (inner corners, cols x rows) is found and fit.

    Parameters
    ----------
    source : FrameSource
        Opened by this function.
    square : float
        Side of a board square, in the session's units (scale does not change intrinsics).
    min_spacing : int
        Frames to skip after a kept view, so that a live camera moves between views.
    """
    cols, rows = board
    if cols < 2 or rows < 2:
        raise InputValueError(f"the board needs at least 2x2 inner corners, got {cols}x{rows}")
    pattern = np.zeros((cols * rows, 3), np.float32)
    pattern[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    object_points: list[NDArray[np.float32]] = []
    image_points: list[NDArray[np.float32]] = []
    size: tuple[int, int] | None = None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    skip = 0
    with source:
        for i in range(max_frames):
            if len(image_points) >= views:
                break
            try:
                frame = source.read()
            except SourceError:
                if i > 0:
                    break  # a folder or video that ran out: fit what it showed
                raise
            if skip:
                skip -= 1
                continue
            gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
            size = (gray.shape[1], gray.shape[0])
            found, corners = cv2.findChessboardCorners(gray, (cols, rows))
            if found:
                corners = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), criteria)
                image_points.append(np.asarray(corners, np.float32))
                object_points.append(pattern)
                skip = min_spacing
            if on_view is not None:
                on_view(i, bool(found))
    if len(image_points) < 3 or size is None:
        raise InputValueError(
            f"found the {cols}x{rows} board in only {len(image_points)} frame(s); need 3 or more "
            "(check --board: inner corners, not squares; show the board at different angles)"
        )
    rms, K, dist, _, _ = cv2.calibrateCamera(object_points, image_points, size, None, None)
    d = [float(x) for x in np.asarray(dist).ravel()[:5]] + [0.0] * 5
    intr = Intrinsics(
        size[0],
        size[1],
        float(K[0, 0]),
        float(K[1, 1]),
        float(K[0, 2]),
        float(K[1, 2]),
        (d[0], d[1], d[2], d[3], d[4]),
    )
    return Calibration(intr, float(rms), len(image_points))


def save_calibration(calibration: Calibration, path: str | Path) -> None:
    """Write the calibration as TOML (refuses to overwrite)."""
    i = calibration.intrinsics
    text = (
        "# twopose camera calibration (OpenCV plumb_bob)\n"
        f"width = {i.width}\nheight = {i.height}\n"
        f"fx = {i.fx!r}\nfy = {i.fy!r}\ncx = {i.cx!r}\ncy = {i.cy!r}\n"
        f"distortion = [{', '.join(repr(k) for k in i.distortion)}]\n"
        f"rms_px = {calibration.rms_px!r}\nviews = {calibration.n_views}\n"
    )
    try:
        with open(path, "x", encoding="utf-8") as fh:
            fh.write(text)
    except FileExistsError as err:
        raise SessionExistsError(f"{path} already exists; choose another calibration file") from err


def load_calibration(path: str | Path) -> Intrinsics:
    """Read a calibration file written by :func:`save_calibration`."""
    data = read_toml(path, "calibration", InputValueError)
    return Intrinsics.from_dict(data, f"calibration {path}")
