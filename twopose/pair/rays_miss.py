"""A pair file that is not the cameras' own, told by a dot's two rays missing each other.

A dot both cameras see lies on both its rays, so its pixels meet the pair's epipolar
constraint up to the detector's noise and camera 1's interpolation between frames: the
rays' gap (Sampson's distance, :func:`twopose.pair.dot_tracks.epipolar_gap_px`) is a
fraction of a pixel. A pair file of another rig, or of this one before its cameras moved,
puts the rays apart by what the wrong pose makes: over every pair, not in a few. Its points
still solve (the two-ray least squares always has a point) and their regions, which rest
on the pixels' noise, stay small: a new user's r7 K11 saw OpenCV's pair file on the thesis
pair's dot files give points 8 in off at ±0.08 in, ``conditioning: ok``.

The rule: over the pairs whose dot stood still (camera 2's dot moved less than
:data:`STILL_PX` since its frame before: :func:`still_frames`), the median of their
absolute gaps over the larger of :data:`RAYS_MISS_PX` and :data:`RAYS_MISS_SIGMAS` times a
camera's detection noise, over at least :data:`MIN_MISS_PAIRS` of them. Still pairs only: a
moving dot's gap also holds the clock offset's error and camera 1's interpolation times its
speed (a dot at 75 in/s with 5 ms of jitter and a fifth of its frames dropped: a median of
2.8 px with the right pair), which a still one does not, whatever the offset. The median,
not the mean: a wrong detection in a few pairs moves it little. On the r7 files the right
pair gives 0.02 px, OpenCV's 10.9 px; a dot that never stands still is not judged.

What the gap cannot see: a pair file wrong only in a turn about the axis across both
cameras' rays (a toe-in for cameras side by side) moves a dot along its epipolar line, so
its gap hardly (the thesis pair's dot 14 in ahead: 2.2 px for 10 degrees of toe-in): the
depth is then wrong unseen, as it would be with any two-view check.

A target with an image line (the glove) cannot be judged so: its point's place along the
finger is not the same point in both cameras and is fitted per frame, which takes up most
of a wrong pose's gap (the same files' glove: 0.10 px right, 1.2 px with OpenCV's pair,
against 0.8 px for the right pair on another recording). No I/O.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: The least median gap (px) that says the rays miss each other, whatever the noise: a
#: still dot's detection leaves a fraction of a pixel.
RAYS_MISS_PX = 1.5
#: ... or this many times the pixels' 1-sigma (a camera's detection noise and the pair's
#: own fit's RMS together), if larger: a still dot's median gap is about one of them.
RAYS_MISS_SIGMAS = 6.0
#: The fewest still pairs with a gap the median is judged over (half a second at 30 fps).
MIN_MISS_PAIRS = 15
#: A dot that moved less than this (px) since camera 2's frame before stood still.
STILL_PX = 1.0


def still_frames(track_px: ArrayLike) -> NDArray[np.bool_]:
    """(N,) whether each frame's dot stood still.

    Found, as was the frame before, less than :data:`STILL_PX` from it. ``track_px``
    (N, 2) a camera's dot (NaN: not found).
    """
    p = np.asarray(track_px, dtype=np.float64).reshape(-1, 2)
    moved = np.full(p.shape[0], np.inf)
    moved[1:] = np.linalg.norm(np.diff(p, axis=0), axis=1)
    return np.asarray(np.nan_to_num(moved, nan=np.inf) < STILL_PX)


def pixel_sigma(detection_px: float, pair_rms_px: float) -> float:
    """The pixels' 1-sigma the rule scales with.

    The detection's and the pair's fit's RMS in quadrature (a pair whose board corners
    fit to 0.5 px leaves a still dot's gap about that much).
    """
    return float(np.hypot(detection_px, pair_rms_px))


def rays_miss_words(gap_px: ArrayLike, noise_px: float = 0.0) -> str:
    """Why the pair file cannot be the cameras' own, in words ("" where it can be).

    Parameters
    ----------
    gap_px : (N,) array_like
        The still pairs' rays' gaps (px, signed; NaN where a camera did not see the dot).
    noise_px : float
        The pixels' 1-sigma: a camera's detection noise (the larger camera's) and the
        pair's fit's RMS (:attr:`~twopose.pair.calibration.PairCalibration.rms_px`) in
        quadrature (:func:`pixel_sigma`).

    Returns
    -------
    str
    """
    gaps = np.abs(np.asarray(gap_px, dtype=np.float64).reshape(-1))
    gaps = gaps[np.isfinite(gaps)]
    if gaps.size < MIN_MISS_PAIRS:
        return ""
    typical = float(np.median(gaps))
    allowed = max(RAYS_MISS_PX, RAYS_MISS_SIGMAS * float(noise_px))
    if not typical > allowed:
        return ""
    return (
        f"the cameras' rays to the dot miss each other by {typical:.1f} px (the median of "
        f"{gaps.size} pairs with the dot still; the pixels' noise allows {allowed:.1f}): "
        "the pair file is not these cameras' (another rig's, or from before the cameras "
        "moved on their mount), or the cameras are given in the other order: calibrate "
        "this pair (twopose-record calibrate-pair)"
    )
