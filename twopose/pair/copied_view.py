"""Whether camera 2's frames are camera 1's: the target at one pixel in both, pair by pair.

Two cameras a baseline apart see a target at different pixels (the disparity ``f B / Z``:
some 100 px for the thesis' 6 in at 30 in), and the rotation between them moves it further;
along a moving target's track the two projections coincide nowhere but at single points.
Two copies of one recording see it at one pixel in every pair, whatever their bytes: a
still changed, a video transcoded, a folder exported again (a second new user's issue-58
F3a; byte-identical files are warned of where the sources open,
:func:`recorder.sources.base.refuse_same`). Their rays through two centres still meet
somewhere, so the pair "measures" points and a clock offset that mean nothing, and the
rays' gap cannot tell: for cameras side by side (a translation only) the epipolar
constraint ``x^T [t]x x = 0`` holds for every pixel ``x`` seen at one place in both.

The test pairs each camera-2 frame with camera 1's nearest in time at the offset and takes
the target's detected pixel (as detected, so a copy matches whatever the two cameras'
lenses) in each: a copy is :data:`MIN_PAIRS` pairs or more, at least
:data:`COPIED_SHARE` of them within :data:`COPIED_PX` of each other, **over a target that
moved** (its pixels in those pairs spread :data:`MIN_SPREAD_PX` RMS or more). A re-encoded
copy's detections differ by a few hundredths of a pixel; a real pair's by tens. The moving:
the points a real pair sees at one pixel in both cameras lie on one curve in space (for a
toed-in pair, the vertical line through the point the cameras converge on, and the circle
through both centres and it), so a target held still on it would read as a copy; one that
moves leaves it at once, unless moved along it within a third of an inch, which the docs
say. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["COPIED_PX", "COPIED_SHARE", "MIN_PAIRS", "MIN_SPREAD_PX", "CopiedView", "copied_view"]

#: Two detections this near (px) are of one picture (a copy's differ by its re-encoding).
COPIED_PX = 1.0
#: The share of pairs that must be that near: a real pair's track crosses a pixel the two
#: cameras share in a frame or two at most.
COPIED_SHARE = 0.9
#: The fewest pairs (both cameras detected the target) the test is made on.
MIN_PAIRS = 10
#: The least spread (px, RMS about their mean) of camera 1's pixels in those pairs: a
#: target held still tells a copy from a real pair's coinciding point no better than one.
MIN_SPREAD_PX = 10.0


@dataclass(frozen=True)
class CopiedView:
    """The test's outcome.

    ``pairs`` tested, ``near`` within :data:`COPIED_PX`, their median distance (px; NaN:
    none), and camera 1's pixels' spread over them (px RMS about their mean).
    """

    pairs: int
    near: int
    median_px: float
    spread_px: float

    @classmethod
    def of(cls, one_px: ArrayLike, two_px: ArrayLike) -> CopiedView:
        """The test on pairs' detections (P, 2) in camera 1 and camera 2 (NaN: not found)."""
        one, two = (np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in (one_px, two_px))
        both = np.isfinite(one).all(axis=1) & np.isfinite(two).all(axis=1)
        one, two = one[both], two[both]
        if not one.shape[0]:
            return cls(pairs=0, near=0, median_px=float("nan"), spread_px=0.0)
        apart = np.linalg.norm(one - two, axis=1)
        spread = float(np.sqrt(((one - one.mean(axis=0)) ** 2).sum(axis=1).mean()))
        return cls(pairs=int(apart.size), near=int((apart <= COPIED_PX).sum()),
                   median_px=float(np.median(apart)), spread_px=spread)  # fmt: skip

    @property
    def copied(self) -> bool:
        """Whether camera 2's frames look like camera 1's (the module docstring)."""
        return (
            self.pairs >= MIN_PAIRS
            and self.near >= COPIED_SHARE * self.pairs
            and self.spread_px >= MIN_SPREAD_PX
        )

    @property
    def coinciding(self) -> bool:
        """Whether the target sat at one pixel in both cameras, moved or not.

        A copy, or a target held still where a real pair's views cross: it cannot tell.
        """
        return self.pairs >= MIN_PAIRS and self.near >= COPIED_SHARE * self.pairs

    def held_words(self) -> str:
        """Where coinciding over a target held still: what cannot be told ("" else)."""
        if not self.coinciding or self.copied:
            return ""
        return (
            f"camera 2 saw the target at camera 1's pixel in {self.near} of {self.pairs} "
            f"pairs over a target held still ({self.spread_px:.1f} px moved): two copies of "
            "one recording, or a target where the cameras' views cross; move it to tell"
        )

    def words(self) -> str:
        """The warning ("" where not copied)."""
        if not self.copied:
            return ""
        return (
            f"camera 2 saw the target at camera 1's pixel in {self.near} of {self.pairs} "
            f"pairs (median {self.median_px:.2f} px apart, where two cameras a baseline "
            "apart see it tens of pixels apart): camera 2's frames look like camera 1's "
            "(two copies of one recording?); what the pair measures of them (points, the "
            "clock offset) means nothing"
        )


def copied_view(
    tracks_px: tuple[ArrayLike, ArrayLike],
    times_ns: tuple[ArrayLike, ArrayLike],
    offset_ns: float = 0.0,
) -> CopiedView:
    """The test (the module docstring) on both cameras' tracks.

    ``tracks_px`` each camera's target pixels (N_i, 2) (NaN: not found), ``times_ns``
    their capture times (N_i,) on its clock; ``offset_ns`` camera 2's clock less camera 1's.
    """
    one, two = (np.asarray(t, dtype=np.float64).reshape(-1, 2) for t in tracks_px)
    t1, t2 = (np.asarray(t, dtype=np.float64).ravel() for t in times_ns)
    found1 = np.isfinite(one).all(axis=1)
    one, t1 = one[found1], t1[found1]
    order = np.argsort(t1, kind="stable")
    one, t1 = one[order], t1[order]
    found2 = np.isfinite(two).all(axis=1)
    two, at = two[found2], t2[found2] - offset_ns
    if t1.size < 2 or not at.size:
        return CopiedView.of(np.zeros((0, 2)), np.zeros((0, 2)))
    half = 0.5 * float(np.median(np.diff(t1)))  # half camera 1's frame interval
    j = np.clip(np.searchsorted(t1, at), 1, t1.size - 1)
    nearest = np.where(np.abs(t1[j - 1] - at) <= np.abs(t1[j] - at), j - 1, j)
    paired = np.abs(t1[nearest] - at) <= half
    return CopiedView.of(one[nearest[paired]], two[paired])
