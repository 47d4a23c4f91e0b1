"""Whether the stills show a larger board than ``--board`` says.

OpenCV's board search finds an 8x6 grid inside a 9x6 board (any part of a board is a
board), and the fit on it is a wrong calibration whose checks pass: the squares are
numbered from the wrong corner, differently in each view. So the first view found is
searched again for one more column and one more row; a larger grid found there whose
extra corners lie on the next column or row of the given one (within
:data:`NEXT_LINE_SQUARES`, extrapolated through the view's homography) is refused in
words. OpenCV sometimes finds a larger grid that ends on the board's printed border,
half a square out (``left13.jpg`` of its own pairs at 10x6): that one is not a larger
board and is let through.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F32
from twopose.detect.checkerboard import find_board
from twopose.errors import InputValueError

__all__ = ["NEXT_LINE_SQUARES", "larger_board", "refuse_larger_board"]

#: The largest distance (in squares) of a larger grid's corner from the given grid's
#: columns and rows extended by one: the homography ignores the lens' distortion, which
#: moves OpenCV's own stills' next column by up to 0.2 of a square.
NEXT_LINE_SQUARES = 0.3


def larger_board(
    image: NDArray[np.uint8], board: tuple[int, int], corners: F32
) -> tuple[int, int] | None:
    """The larger board (one more column or row than ``board``) ``image`` shows around the
    given board's ``corners`` (``find_board``'s, OpenCV's order), or None."""
    cols, rows = board
    grid = np.stack(np.meshgrid(np.arange(cols), np.arange(rows)), -1).reshape(-1, 2)
    H, _ = cv2.findHomography(grid.astype(np.float64), corners.reshape(-1, 2).astype(np.float64))
    if H is None:
        return None
    for larger in ((cols + 1, rows), (cols, rows + 1)):
        found = find_board(image, larger)
        if found is None:
            continue
        # Each corner of the larger grid in the given grid's squares: a real larger board's
        # lie on whole squares, the given grid's and one more column or row.
        at = cv2.perspectiveTransform(found.reshape(1, -1, 2).astype(np.float64), np.linalg.inv(H))[
            0
        ]
        if np.abs(at - np.round(at)).max() <= NEXT_LINE_SQUARES:
            return larger
    return None


def refuse_larger_board(
    image: NDArray[np.uint8], board: tuple[int, int], corners: F32, name: str
) -> None:
    """Refuse in words a ``--board`` smaller than the board ``image`` shows
    (:func:`larger_board`)."""
    larger = larger_board(image, board, corners)
    if larger is not None:
        raise InputValueError(
            f"the board has more corners than --board says: {name} shows {larger[0]}x"
            f"{larger[1]} inner corners, --board {board[0]}x{board[1]}; count the inner "
            "corners (where four squares meet) along each side and give --board COLSxROWS"
        )
