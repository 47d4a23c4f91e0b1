"""What voids a live pair's points though they solve: two copies of one recording, and a
pair file that is not these cameras' (:class:`PointVoids`).

Both are judged over the last pairs, not one: a copy over :data:`COPY_PAIRS` pairs
(:mod:`twopose.pair.copied_view`), a dot's rays missing each other over the last
:data:`GAP_PAIRS` pairs with the dot still (:mod:`twopose.pair.rays_miss`). Both, once
seen, are kept for the rest of the run: the cameras and the pair file do not change while
they run, and a copy's target pausing voided no point for a while (a new user's r7 K1:
green ``conditioning: ok`` at 4 s between two amber warnings). No I/O.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from twopose.pair.copied_view import CopiedView
from twopose.pair.dot_tracks import epipolar_gap_px
from twopose.pair.rays_miss import STILL_FRAMES, inside, pixel_sigma, rays_miss_words, still_frames

if TYPE_CHECKING:
    from twopose.arrays import F64
    from twopose.pair.calibration import PairCalibration

__all__ = ["COPY_PAIRS", "GAP_PAIRS", "PointVoids"]

#: The last pairs judged for camera 2's frames being camera 1's (a second at 30 fps).
COPY_PAIRS = 30
#: The last pairs with the dot still whose rays' gap judges the pair file.
GAP_PAIRS = 30


class PointVoids:
    """The words that void a live pair's point, pair by pair ("" where none).

    ``pair`` the pair file given; ``dot`` whether the target is a dot (a target with an
    image line, the glove, is not judged by its rays' gap: :mod:`twopose.pair.rays_miss`).
    """

    def __init__(self, pair: PairCalibration, *, dot: bool) -> None:
        self.pair, self.dot = pair, dot
        # The last pairs' detections (u1, v1, u2, v2): two copies of one recording alike.
        self._alike: deque[tuple[float, float, float, float]] = deque(maxlen=COPY_PAIRS)
        self._copied = ""
        self._gaps: deque[float] = deque(maxlen=GAP_PAIRS)  # pairs with the dot still
        self._missed = ""
        # camera 2's dot in its last frames, this one's included (NaN: not found)
        self._last2: deque[tuple[float, float]] = deque(maxlen=STILL_FRAMES + 1)

    @property
    def kept(self) -> str:
        """What voids every point from now on, once seen ("" none yet): a copy, or a pair
        file not these cameras'; not a target held still, which moving it tells."""
        return self._copied or self._missed

    def gaps(self, measured: F64) -> F64:
        """(P,) each pair's rays' gap (px) from the stream estimate's ``measured`` (P, 2, 3)
        (NaN for a target with an image line, and where a camera lost the dot)."""
        if not self.dot:
            return np.full(measured.shape[0], np.nan)
        return epipolar_gap_px(self.pair, measured[:, 0, :2], measured[:, 1, :2])

    def said(
        self, first: tuple[float, float] | None, second: tuple[float, float] | None,
        gap_px: float, noise_px: float,
    ) -> str:  # fmt: skip
        """The next pair: camera 1's and camera 2's detections (None: not found), its rays'
        gap and each frame's detection noise (px, the larger camera's); what voids it."""
        if first is not None and second is not None:
            self._alike.append((*first, *second))
        alike = np.array(self._alike, dtype=np.float64).reshape(-1, 4)
        return self.copy_warning(alike) or self._rays_missed(gap_px, (first, second), noise_px)

    def copy_warning(self, alike: F64) -> str:
        """What voids the pair's points as copies (:mod:`twopose.pair.copied_view`): a copy
        seen over the last :data:`COPY_PAIRS` pairs ``alike`` (N, 4), kept from then on;
        else, a target still at one pixel in both cameras, which cannot be told from one
        ("" else)."""
        view = CopiedView.of(alike[:, :2], alike[:, 2:])
        self._copied = self._copied or view.words()
        return self._copied or view.held_words()

    def _rays_missed(
        self, gap_px: float, seen: tuple[tuple[float, float] | None, ...], noise_px: float
    ) -> str:
        """A dot's rays missing each other over the last :data:`GAP_PAIRS` pairs with the
        dot still and whole (:func:`~twopose.pair.rays_miss.still_frames` over camera 2's
        last frames: a moving dot's gap holds the clock offset's error;
        :func:`~twopose.pair.rays_miss.inside` both images: a dot cut by an edge has its
        centroid moved), in words ("" where they meet, or too few pairs yet)."""
        first, second = seen
        self._last2.append(second if second is not None else (math.nan, math.nan))
        still = bool(still_frames(np.array(self._last2))[-1])
        whole = (
            first is not None
            and second is not None
            and all(
                bool(inside(np.array([p]), i.width, i.height)[0])
                for p, i in ((first, self.pair.intrinsics1), (second, self.pair.intrinsics2))
            )
        )
        if still and whole and math.isfinite(gap_px):
            self._gaps.append(gap_px)
        if self.dot and not self._missed:
            sigma = pixel_sigma(noise_px, self.pair.rms_px)
            self._missed = rays_miss_words(np.array(self._gaps), sigma)
        return self._missed
