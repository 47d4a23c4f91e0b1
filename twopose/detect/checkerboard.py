"""The checkerboard found in an image: the rig's search and the recorder's live check.

:func:`find_board` (OpenCV's ``findChessboardCorners`` refined to sub-pixel corners) serves
camera calibration, the pair's calibration and ``twopose-analyze rig``;
:func:`find_board_live` is the recorder's check: the fast check, then the same search in a
worker, bounded by :data:`LIVE_BOARD_BUDGET_S`. Every board fit shares the board's corners
on its plane (:func:`board_pattern`) and the rule that drops an outlier view
(:func:`outlier_view`).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BOARD_FLAGS",
    "LIVE_BOARD_BUDGET_S",
    "OUTLIER_FACTOR",
    "OUTLIER_FLOOR_PX",
    "BoardSearch",
    "board_pattern",
    "find_board",
    "find_board_live",
    "outlier_view",
]

Image = NDArray[np.uint8]


#: OpenCV's flags for a board search (its default): the one rule the rig's search
#: (``twopose-analyze rig``), the camera calibration and the recorder's live check share.
BOARD_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH + cv2.CALIB_CB_NORMALIZE_IMAGE

#: How long the recorder's live check waits for the full board search (seconds) when
#: OpenCV's fast check turns a frame down: far boards (squares of about 9 px) fail the fast
#: check though the full search finds them, in about 1-2 ms at 640x480 (docs/rig.md).
LIVE_BOARD_BUDGET_S = 1.5


def board_pattern(inner_corners: tuple[int, int], square: float) -> NDArray[np.float32]:
    """The board's inner corners (cols * rows, 3) on its plane z = 0, in ``square``'s unit.

    Row by row, in OpenCV's corner order (what :func:`find_board` returns), the first
    corner at the origin: the object points of every board fit (a camera's intrinsics, a
    pair's relative pose, the floor).
    """
    cols, rows = inner_corners
    pattern = np.zeros((cols * rows, 3), np.float32)
    pattern[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    return pattern


#: A view is an outlier when its RMS exceeds both this many times the median view's and
#: :data:`OUTLIER_FLOOR_PX`: a gross failure (a misdetected or misordered corner grid, a
#: blurred frame: several px), not a view the lens model fits less well at the image's
#: edge. OpenCV's own left02.jpg (1.2 px, 6x the median 0.19 px) is such a view: it is
#: the one that teaches the distortion near a corner, and it is kept. The one rule of every
#: board fit (a camera's intrinsics, a pair's relative pose).
OUTLIER_FACTOR = 5.0
OUTLIER_FLOOR_PX = 2.0


def outlier_view(view_rms_px: Sequence[float] | NDArray[np.float64]) -> int | None:
    """The view a board fit drops and fits again without (the worst, if an outlier).

    The index of the view with the largest RMS when it exceeds both :data:`OUTLIER_FACTOR`
    times the median view's and :data:`OUTLIER_FLOOR_PX`; None when no view does.
    """
    rms = np.asarray(view_rms_px, dtype=np.float64)
    worst = int(np.argmax(rms))
    limit = max(OUTLIER_FACTOR * float(np.median(rms)), OUTLIER_FLOOR_PX)
    return worst if rms[worst] > limit else None


def find_board(
    image_bgr: Image,
    inner_corners: tuple[int, int],
    *,
    window_px: int | None = 11,
) -> NDArray[np.float32] | None:
    """A checkerboard's inner corners, refined to sub-pixel; None if not found.

    A checkerboard's inner corners (cols * rows, 1, 2), refined to sub-pixel
    (``cv2.findChessboardCorners`` with :data:`BOARD_FLAGS`, then ``cv2.cornerSubPix`` in
    a (2 window + 1)^2 window: keep it under half a square; None: a third of the smallest
    spacing of the corners found, so a small or distant board is refined within its
    squares), in OpenCV's order; None where the board is not found. The full search: it
    may take a third of a second on a frame without a board; the recorder's live check is
    :func:`find_board_live`, this search behind a fast pre-check.
    """
    grey = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
    return _board_corners(grey, inner_corners, window_px, BOARD_FLAGS)


def _board_corners(
    grey: NDArray[Any], inner_corners: tuple[int, int], window_px: int | None, flags: int
) -> NDArray[np.float32] | None:
    """:func:`find_board` on a grey image, with OpenCV's ``flags``."""
    found, corners = cv2.findChessboardCorners(grey, inner_corners, flags=flags)
    if not found:
        return None
    if window_px is None:
        grid = corners.reshape(inner_corners[1], inner_corners[0], 2)
        along = np.linalg.norm(np.diff(grid, axis=1), axis=-1).min()
        across = np.linalg.norm(np.diff(grid, axis=0), axis=-1).min()
        window_px = max(2, int(min(along, across) / 3))
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    window = (window_px, window_px)
    return np.asarray(cv2.cornerSubPix(grey, corners, window, (-1, -1), criteria), np.float32)


@dataclass(frozen=True, kw_only=True)
class BoardSearch:
    """The live check's answer for one frame (:func:`find_board_live`).

    ``corners`` as :func:`find_board` gives them (None: not found); ``fast`` whether the
    fast pre-check found them; ``full_s`` how long the full search took (NaN: not run, or
    still running when the budget ran out); ``timed_out`` whether it ran out.
    """

    corners: NDArray[np.float32] | None
    fast: bool = False
    full_s: float = math.nan
    timed_out: bool = False


#: At most one full search in flight: one the live check gave up on keeps its worker (an
#: OpenCV call cannot be stopped) and the next frame waits for it within its own budget.
_BOARD_WORKER = threading.BoundedSemaphore(1)


def find_board_live(
    image_bgr: Image,
    inner_corners: tuple[int, int],
    *,
    budget_s: float = LIVE_BOARD_BUDGET_S,
) -> BoardSearch:
    """The recorder's live board check: finds what the rig's :func:`find_board` finds.

    OpenCV's fast check (``CALIB_CB_FAST_CHECK`` added to :data:`BOARD_FLAGS`) first,
    which finds a near board in milliseconds; where it fails (a far board, whose squares
    are a few pixels, fails it though the board is whole in view), :func:`find_board`
    itself, as ``twopose-analyze rig`` calls it (``window_px=None``), in a worker thread,
    waited for at most ``budget_s``.

    Parameters
    ----------
    image_bgr : ndarray
        (H, W, 3) BGR uint8, the frame as stored.
    inner_corners : tuple of int
        (columns, rows) of inner corners.
    budget_s : float
        The longest wait for the full search (seconds).

    Returns
    -------
    BoardSearch
        The corners (or None), whether the fast check found them, the full search's time,
        and whether it ran out of time (then the board counts as not found).
    """
    started = time.perf_counter()
    grey = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
    fast = _board_corners(grey, inner_corners, None, BOARD_FLAGS + cv2.CALIB_CB_FAST_CHECK)
    if fast is not None:
        return BoardSearch(corners=fast, fast=True)
    answer: list[tuple[NDArray[np.float32] | None, float]] = []
    done = threading.Event()

    def search() -> None:
        try:
            t0 = time.perf_counter()
            corners = find_board(image_bgr, inner_corners, window_px=None)
            answer.append((corners, time.perf_counter() - t0))
        finally:
            done.set()
            _BOARD_WORKER.release()

    if not _BOARD_WORKER.acquire(timeout=max(0.0, budget_s - (time.perf_counter() - started))):
        return BoardSearch(corners=None, timed_out=True)  # the last one still runs
    worker = threading.Thread(target=search, name="twopose-board-search", daemon=True)
    worker.start()
    done.wait(max(0.0, budget_s - (time.perf_counter() - started)))
    if not answer:
        return BoardSearch(corners=None, timed_out=True)
    corners, seconds = answer[0]
    return BoardSearch(corners=corners, full_s=seconds)
