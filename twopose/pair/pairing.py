"""Two cameras' frames paired by capture time.

The policy is that of ROS ``message_filters``' ApproximateTime synchronizer, for two
streams: each frame is used at most once, pairs never cross (both cameras' frames are used
in order), and no pair spans more than the slop (ApproximateTime's
``max_interval_duration``), here half a frame interval by default; frames of one camera
that have no partner (a dropped frame of the other, the slip of two free-running cameras
whose rates differ by a few hundred ppm) are left unpaired, never forced onto a neighbour.
Among the pairs these rules allow, a frame pairs with the other camera's frame nearest in
time when that frame's nearest is it too (mutual nearest neighbours): the choice
ApproximateTime's pivot makes for two regular streams, stated without a queue, so the
whole stream pairs in one vectorized pass (``searchsorted``), the same whichever camera's
frame arrives first.

Times are each camera's capture times in nanoseconds; camera 2's are brought onto camera
1's clock with the clock offset, ``t1 = t2 - offset_ns`` (:mod:`twopose.pair.clock`
measures it), a constant or one per camera-2 frame (a drifting clock's offset).

A stream's frames are paired on each camera's fitted clock, not on its stamps
(:func:`pair_captures`): the stamps jitter (the host stamps them), the frames do not (the
camera's crystal times them), so pairing on the stamps loses pairs whose skew the jitter
pushes past the slop and makes some whose true skew is beyond it. Each frame's fitted time
comes from its camera's frames up to it (:class:`twopose.pair.clock_fit.CausalClock`), so
the live pairing (:mod:`twopose.pair.live_pairing`), which has no later frame, gives the
pairs ``run`` gives. No I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64, Ints
from twopose.errors import InputValueError
from twopose.pair.clock_fit import causal_times

__all__ = ["Pairing", "half_interval_ns", "pair_captures", "pair_frames"]


@dataclass(frozen=True, kw_only=True, eq=False)
class Pairing:
    """Which frames of the two cameras make pairs (:func:`pair_frames`).

    ``i1``, ``i2`` (P,) the paired frames' indices, both increasing (each frame at most
    once); ``skew_ns`` (P,) each pair's camera-2 time on camera 1's clock minus camera 1's
    time; ``slop_ns`` the largest |skew| allowed; ``unpaired1``, ``unpaired2`` how many of
    each camera's frames found no partner.
    """

    i1: Ints
    i2: Ints
    skew_ns: F64
    slop_ns: float
    unpaired1: int
    unpaired2: int

    @property
    def n_pairs(self) -> int:
        """How many pairs."""
        return int(self.i1.size)


def half_interval_ns(t1_ns: ArrayLike, t2_ns: ArrayLike) -> float:
    """Half the shorter of the two cameras' median frame intervals (the default slop)."""
    intervals = [
        float(np.median(np.diff(np.asarray(t, dtype=np.float64))))
        for t in (t1_ns, t2_ns)
        if np.asarray(t).size >= 2
    ]
    if not intervals:
        raise InputValueError(
            "a frame interval needs two frames of a camera at least: give the slop"
        )
    return 0.5 * min(intervals)


def pair_frames(
    t1_ns: ArrayLike,
    t2_ns: ArrayLike,
    *,
    offset_ns: float | ArrayLike = 0.0,
    slop_ns: float | None = None,
) -> Pairing:
    """Pair camera 1's and camera 2's frames by capture time (the module docstring).

    Parameters
    ----------
    t1_ns, t2_ns : (N1,), (N2,) array_like
        Each camera's capture times, nanoseconds on its own clock, strictly increasing.
    offset_ns : float or (N2,) array_like
        Camera 2's clock minus camera 1's: ``t1 = t2 - offset_ns``.
    slop_ns : float, optional
        The largest |skew| of a pair (default: half the shorter median frame interval).

    Returns
    -------
    Pairing
    """
    t1, t2 = _from_common_origin(t1_ns, t2_ns)
    offset = np.asarray(offset_ns, dtype=np.float64)
    if offset.ndim not in (0, 1) or (offset.ndim == 1 and offset.shape != t2.shape):
        raise InputValueError(
            f"the clock offset must be one number or one per camera-2 frame ({t2.size}), "
            f"got shape {offset.shape}"
        )
    t2 = t2 - offset
    for name, t in (("camera 1", t1), ("camera 2", t2)):
        if not np.isfinite(t).all():
            raise InputValueError(f"{name}'s capture times must be finite numbers")
        if (np.diff(t) <= 0).any():
            raise InputValueError(
                f"{name}'s capture times must increase strictly (on camera 1's clock): "
                f"frame {int(np.argmax(np.diff(t) <= 0)) + 2} is not after the one before"
            )
    if t1.size == 0 or t2.size == 0:  # nothing to pair (the slop as given, if at all)
        empty = np.zeros(0, dtype=np.intp)
        return Pairing(
            i1=empty, i2=empty, skew_ns=np.zeros(0),
            slop_ns=math.nan if slop_ns is None else float(slop_ns),
            unpaired1=int(t1.size), unpaired2=int(t2.size),
        )  # fmt: skip
    slop = half_interval_ns(t1, t2) if slop_ns is None else float(slop_ns)
    if not (np.isfinite(slop) and slop >= 0):
        raise InputValueError(f"the slop must be a duration >= 0, got {slop_ns}")
    near2 = _nearest(t2, t1)  # each camera-1 frame's nearest camera-2 frame
    near1 = _nearest(t1, t2)
    i1 = np.flatnonzero(near1[near2] == np.arange(t1.size))  # mutual nearest
    i2 = near2[i1]
    skew = t2[i2] - t1[i1]
    keep = np.abs(skew) <= slop
    i1, i2, skew = i1[keep], i2[keep], skew[keep]
    return Pairing(
        i1=i1.astype(np.intp),
        i2=i2.astype(np.intp),
        skew_ns=skew,
        slop_ns=slop,
        unpaired1=int(t1.size - i1.size),
        unpaired2=int(t2.size - i2.size),
    )


def pair_captures(
    t1_ns: ArrayLike,
    t2_ns: ArrayLike,
    *,
    offset_ns: float | ArrayLike = 0.0,
    slop_ns: float | None = None,
) -> Pairing:
    """Pair two cameras' frames on their fitted clocks (the module docstring).

    :func:`pair_frames` on each camera's :func:`~twopose.pair.clock_fit.causal_times` (its
    stamps fitted frame by frame, as the live pairing fits them); the parameters are
    :func:`pair_frames`'. The pairs' ``skew_ns`` are the fitted clocks'.
    """
    one, two = (np.asarray(t).reshape(-1) for t in (t1_ns, t2_ns))
    for name, t in (("camera 1", one), ("camera 2", two)):
        if t.size and not np.isfinite(t).all():
            raise InputValueError(f"{name}'s capture times must be finite numbers")
        if (np.diff(t) <= 0).any():
            raise InputValueError(
                f"{name}'s capture times must increase strictly: frame "
                f"{int(np.argmax(np.diff(t) <= 0)) + 2} is not after the one before"
            )
    return pair_frames(causal_times(one), causal_times(two), offset_ns=offset_ns, slop_ns=slop_ns)


def _from_common_origin(t1_ns: ArrayLike, t2_ns: ArrayLike) -> tuple[F64, F64]:
    """Both cameras' times as floats from their earliest one.

    Subtracted in the times' own type first, so that integer nanoseconds of a clock far
    from its epoch (1.7e18 ns since 1970) keep every nanosecond.
    """
    a = np.asarray(t1_ns).reshape(-1)
    b = np.asarray(t2_ns).reshape(-1)
    if a.size == 0 or b.size == 0 or not (np.isfinite(a).all() and np.isfinite(b).all()):
        return a.astype(np.float64), b.astype(np.float64)
    origin = min(a.min(), b.min())
    return (a - origin).astype(np.float64), (b - origin).astype(np.float64)


def _nearest(sorted_times: F64, at: F64) -> Ints:
    """For each of ``at``, the index of the nearest of ``sorted_times`` (ties: the earlier)."""
    right = np.clip(np.searchsorted(sorted_times, at, side="left"), 1, sorted_times.size - 1)
    if sorted_times.size == 1:
        return np.zeros(at.size, dtype=np.intp)
    left = right - 1
    take_left = (at - sorted_times[left]) <= (sorted_times[right] - at)
    return np.where(take_left, left, right).astype(np.intp)
