"""A two-camera session's touch without an estimate: its status and its reason, in words.

A touch of ``trials.csv`` (:mod:`analysis.session.stream_tables`) with no estimate about
it is ``degenerate`` (the nearest pair near-singular, its reason), ``no_detection`` (a
camera did not detect the target in the nearest pair, its detector's reason named) or
``incomplete``: a camera has no frame about the touch (outside the stream, or dropped), or
both cameras saw the target about it but its frames made too few pairs there (the stamps'
jitter, dropped frames): each camera's frames about it, how many saw the target, the
nearest one's distance, the pairs before and after it, and what to do. Never
``no_detection`` where the target was detected.
"""

from __future__ import annotations

import numpy as np

from analysis.session.stream import MAX_TOUCH_GAP_INTERVALS, TrialReplay
from twopose.pair.stream import NEAR_SINGULAR, NOT_INTERPOLATED, StreamEstimate

__all__ = ["seen_about", "stream_end_ns", "touch_status"]

#: The status of a touch whose nearest pair was near-singular or degenerate.
_DEGENERATE = {NEAR_SINGULAR: "degenerate", "degenerate": "degenerate"}


#: What to do about a touch whose frames saw the target but made too few pairs.
_UNPAIRED_DO = (
    "frames pair within half a frame interval on each camera's fitted clock (docs/"
    "two-cameras.md, Pairing frames), so pairs are lost where a camera dropped frames or "
    "its stamps jitter; lighten the machine's load (or use cameras whose driver stamps "
    "their frames), and hold the target on each touch for a few frames"
)


def seen_about(replay: TrialReplay, time_ns: int) -> tuple[tuple[int, int, float], ...]:
    """Per camera, its frames within :data:`MAX_TOUCH_GAP_INTERVALS` frame intervals of the
    touch (camera 2's on camera 1's clock): how many, how many detected the target, and
    the nearest one's distance from the touch (ms)."""
    reach = MAX_TOUCH_GAP_INTERVALS * replay.interval_ns
    out = []
    for track, shift in zip(replay.tracks, (0.0, replay.offset.offset_ns), strict=True):
        away = np.abs(track.t_ns - shift - time_ns)
        near = away <= reach
        nearest = float(away.min()) / 1e6 if away.size else np.inf
        out.append((int(near.sum()), int((near & track.found).sum()), nearest))
    return tuple(out)


def _unpaired(
    est: StreamEstimate, time_ns: int, seen: tuple[tuple[int, int, float], ...] | None
) -> str:
    """Why a touch has no estimate when no detection is to blame: a camera with no frame
    about it, or frames in both cameras that saw the target but made too few pairs there
    ("" when a camera did not see it, a pair there failed for a reason of its own, or the
    frames are not known)."""
    if seen is None:
        return ""
    away = [f"camera {c} ({nearest:.0f} ms)" for c, (n, _, nearest) in enumerate(seen, 1) if not n]
    if away:
        return (
            f"no estimate about the touch: no frame of {' nor of '.join(away)} within "
            f"{MAX_TOUCH_GAP_INTERVALS:g} frame intervals of it; the touch lies outside "
            "the trial's stream (mark touches while the trial streams), or the camera "
            "dropped its frames there"
        )
    if not all(found for _, found, _ in seen):
        return ""
    reach = MAX_TOUCH_GAP_INTERVALS * (
        float(np.median(np.diff(est.t_ns))) if est.t_ns.size > 2 else np.inf
    )
    near = np.abs(est.t_ns - time_ns) <= reach
    lone = near & (est.status == NOT_INTERPOLATED)  # camera 1 had no frames about it
    if (near & ~est.ok & ~lone).any():
        return ""  # a pair about it failed for its own reason: said by that pair
    ok = near & est.ok
    before, after = int((ok & (est.t_ns < time_ns)).sum()), int((ok & (est.t_ns >= time_ns)).sum())
    frames = "; ".join(
        f"camera {c} in {found} of {n} frames, its nearest {nearest:.1f} ms from the touch"
        for c, (n, found, nearest) in enumerate(seen, start=1)
    )
    lost = (
        f", {int(lone.sum())} more with no frame of camera 1 about camera 2's time"
        if lone.any() else ""
    )  # fmt: skip
    return (
        f"no estimate about the touch, though both cameras saw the target about it "
        f"({frames}; within {MAX_TOUCH_GAP_INTERVALS:g} frame intervals): those frames made "
        f"{before + after} ok pair(s) there ({before} before it, {after} after it{lost}), "
        f"and a touch is read between two ok pairs about its time within "
        f"{MAX_TOUCH_GAP_INTERVALS:g} frame intervals of each other: {_UNPAIRED_DO}"
    )


def stream_end_ns(replay: TrialReplay) -> float:
    """Where the trial's stream ends on camera 1's clock: the earlier of its cameras' last
    frames (camera 2's through the offset; -inf when a camera has none)."""
    ends = [
        float(track.t_ns[-1]) - shift if track.t_ns.size else -np.inf
        for track, shift in zip(replay.tracks, (0.0, replay.offset.offset_ns), strict=True)
    ]
    return min(ends)


def _cut_short(time_ns: int, ended: tuple[str, float], reach_ns: float) -> str:
    """Why a touch has no estimate when the trial's stream ended about it, its trial
    incomplete (a recovered file's open window, a camera that stopped): "" otherwise."""
    reason, end_ns = ended
    if not reason or time_ns + reach_ns <= end_ns:
        return ""
    when = (
        f"{(end_ns - time_ns) / 1e6:.0f} ms after it" if end_ns >= time_ns
        else f"{(time_ns - end_ns) / 1e6:.0f} ms before it"
    )  # fmt: skip
    return f"no estimate about the touch: the trial's stream ends there, {when} ({reason})"


def touch_status(
    est: StreamEstimate,
    time_ns: int,
    *,
    have: bool,
    missed: tuple[tuple[str, ...], tuple[str, ...]] = ((), ()),
    seen: tuple[tuple[int, int, float], ...] | None = None,
    ended: tuple[str, float] = ("", np.inf),
    reach_ns: float = 0.0,
) -> dict[str, str]:
    """A touch's status and reason: ``ok``; else why there is no estimate about it (a
    camera that did not detect the target in the nearest pair named, with its detector's
    reason from ``missed``, each camera's frames' reasons). ``seen``: each camera's frames
    about the touch and those that detected the target (:func:`seen_about`); where both
    cameras saw it there but no pairs estimate it, the touch is ``incomplete`` (pairs
    lost), never ``no_detection``. ``ended``: why the trial is incomplete ("" when it is
    not) and where its stream ends (:func:`stream_end_ns`): a touch within ``reach_ns`` of
    that end is ``incomplete`` for it, not for load or jitter."""
    if have:
        return {"status": "ok", "reason": ""}
    cut = _cut_short(time_ns, ended, reach_ns)
    if cut:
        return {"status": "incomplete", "reason": cut}
    unpaired = _unpaired(est, time_ns, seen)
    if unpaired:
        return {"status": "incomplete", "reason": unpaired}
    if not est.t_ns.size:
        return {"status": "no_detection", "reason": "no frame pair in the trial"}
    j = int(np.argmin(np.abs(est.t_ns - time_ns)))
    status = str(est.status[j])
    if status == "ok":  # the pairs about it are ok, but none brackets its time
        return {
            "status": "no_detection",
            "reason": "no estimate about the touch: no two ok estimates about its time within "
            f"{MAX_TOUCH_GAP_INTERVALS:g} frame intervals (outside the stream, or pairs lost)",
        }
    frames = (int(est.i1[j]), int(est.i2[j]))
    lost = [
        f"camera {n + 1}: {reasons[i]}"
        for n, (reasons, i) in enumerate(zip(missed, frames, strict=True))
        if i < len(reasons) and reasons[i]
    ]
    why = str(est.reason[j]) or status
    if lost:  # the detector's reason, not the solver's "fewer than two views"
        why = "target not detected by " + "; by ".join(lost)
    return {
        "status": _DEGENERATE.get(status, "no_detection"),
        "reason": f"no estimate about the touch: the nearest pair's {why}",
    }
