"""A pair file that is not the cameras' own, told by a dot's two rays missing each other.

A dot both cameras see lies on both its rays, so its pixels meet the pair's epipolar
constraint up to the detector's noise and camera 1's interpolation between frames: the
rays' gap (Sampson's distance, :func:`twopose.pair.dot_tracks.epipolar_gap_px`) is a
fraction of a pixel. A pair file of another rig, or of this one before its cameras moved,
puts the rays apart by what the wrong pose makes: over every pair, not in a few. Its points
still solve (the two-ray least squares always has a point) and their regions, which rest
on the pixels' noise, stay small: a new user's r7 K11 saw OpenCV's pair file on the thesis
pair's dot files give points 8 in off at ±0.08 in, ``conditioning: ok``.

The rule: over the pairs whose dot stood still (camera 2's dot within :data:`STILL_PX` of
where it was in each of its :data:`STILL_FRAMES` frames before: :func:`still_frames`) and
whole (at least :data:`EDGE_PX` inside both cameras' images: :func:`inside`), the median of their
absolute gaps over the larger of :data:`RAYS_MISS_PX` and :data:`RAYS_MISS_SIGMAS` times a
camera's detection noise, over at least :data:`MIN_MISS_PAIRS` of them. Still pairs only: a
moving dot's gap also holds the clock offset's error and camera 1's interpolation times its
speed (a dot at 75 in/s with 5 ms of jitter and a fifth of its frames dropped: a median of
2.8 px with the right pair), which a still one does not, whatever the offset. The median,
not the mean: a wrong detection in a few pairs moves it little. On the r7 files the right
pair gives 0.02 px, OpenCV's 10.9 px; a dot that never stands still is not judged. Still
over a third of a second, not one frame: a slow dot (0.4 in/s, under a pixel a frame) with
the cameras' clocks 300 ms apart moved between the two frames of a pair, and its gap read
as a wrong pair's (a new user's r8 F7). Whole: a resting dot half cut off by an image's
edge has its centroid moved by the cut (1.7-2.0 px of gap with the right pair, the r8
F6).

What the gap cannot tell from a wrong pair: a target vibrating at a multiple of the frame
rate, which each camera samples at its own phase, so that each sees it still, at another
place of its path (a test's 60 Hz vibration at 30 fps: 42.5 px with the right pair). The
words say both.

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

from twopose.detect.thresholds import DotParams

#: The least median gap (px) that says the rays miss each other, whatever the noise: a
#: still dot's detection leaves a fraction of a pixel.
RAYS_MISS_PX = 1.5
#: ... or this many times the pixels' 1-sigma (a camera's detection noise and the pair's
#: own fit's RMS together), if larger: a still dot's median gap is about one of them.
RAYS_MISS_SIGMAS = 6.0
#: The fewest still pairs with a gap the median is judged over (half a second at 30 fps).
MIN_MISS_PAIRS = 15
#: A dot within this (px) of where it was in each of camera 2's frames before ...
STILL_PX = 1.0
#: ... this many of them (a third of a second at 30 fps) stood still.
STILL_FRAMES = 10
#: A dot whose centre is nearer an image's edge than this (px: the dot detector's largest
#: radius) may be cut off by it, its centroid moved: not judged.
EDGE_PX = float(DotParams().max_radius_px)


def still_frames(track_px: ArrayLike) -> NDArray[np.bool_]:
    """(N,) whether each frame's dot stood still.

    Found, as in each of the :data:`STILL_FRAMES` frames before, within :data:`STILL_PX`
    of each. ``track_px`` (N, 2) a camera's dot (NaN: not found).
    """
    p = np.asarray(track_px, dtype=np.float64).reshape(-1, 2)
    still = np.zeros(p.shape[0], dtype=bool)
    still[STILL_FRAMES:] = True
    for k in range(1, STILL_FRAMES + 1):
        moved = np.linalg.norm(p[k:] - p[:-k], axis=1)
        still[k:] &= np.nan_to_num(moved, nan=np.inf) < STILL_PX
    return still


def inside(points_px: ArrayLike, width: int, height: int) -> NDArray[np.bool_]:
    """(N,) whether each dot is whole: nowhere cut by an image's edge.

    Its centre ``points_px`` (N, 2) at least :data:`EDGE_PX` inside a ``width`` x
    ``height`` image (False where NaN).
    """
    p = np.asarray(points_px, dtype=np.float64).reshape(-1, 2)
    with np.errstate(invalid="ignore"):
        ok = (p[:, 0] >= EDGE_PX) & (p[:, 0] <= width - 1 - EDGE_PX)
        ok &= (p[:, 1] >= EDGE_PX) & (p[:, 1] <= height - 1 - EDGE_PX)
    return np.asarray(ok)


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
        "this pair (twopose-record calibrate-pair); or a target vibrating at a multiple of "
        "the frame rate looks still to each camera, each at another place of its path: "
        "move it by hand, or measure the offset by a flash"
    )
