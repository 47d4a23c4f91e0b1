"""The pairs ``calibrate-pair --source pair:A,B`` keeps from two live cameras.

As ``calibrate`` does for one camera (:mod:`recorder.calibration.camera`), a moment is kept
when the board is found in both cameras and has moved since the last kept pair (the mean
corner displacement in either camera at least ``min_motion_px``, by default
:data:`MIN_MOTION_SHARE` of the image diagonal: OpenCV's last two pairs of photographs are
26 and 33 px apart at 640x480, and 5% dropped one), not after a fixed count of frames. Two
cameras add one rule: both must see the
board at (nearly) the same instant. Frames are paired by capture time
(:meth:`recorder.sources.pair.PairSource.pairs`, within half a frame interval), and a pair is
kept only when the board moved at most ``max_skew_px`` (0.5 px) in the time between its two
frames, the board's speed measured from the pair before; where a camera's clock is its
arrival time (``monotonic at grab``) that time is uncertain by a frame interval, which is
added. Hold the board still at each place for a moment.

Collecting stops when ``views`` pairs are kept, when the source ends (two videos, two
folders), or at Ctrl-C or SIGTERM (:mod:`recorder.procedure.stops`): the pairs kept so far are then
fitted. A folder of stills has no capture time: ``pair:images:...,images:...`` pairs the
folders' images in file-name order and keeps every pair, as ``--left``/``--right`` do.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from recorder.procedure import stops
from recorder.sources.pair import QueueBound
from recorder.sources.pair_feeds import CLOCK_GRAB
from twopose.errors import InputValueError, SourceError

#: The board search wants the cameras' latest frames: each camera's queue holds a second of
#: them (a recording's holds 10 s, :data:`recorder.sources.pair.QUEUE_S`), so that a search
#: slower than the cameras drops frames, counted and said, rather than lag behind the board.
LIVE_BOUND = QueueBound(seconds=1.0)

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from recorder.sources.pair import CameraStream, FramePair, PairSource
    from twopose.arrays import F32

    #: A pair to fit: its name, camera 1's image, camera 2's (as pair_calibration's).
    StillPair = tuple[str, NDArray[np.uint8], NDArray[np.uint8]]

__all__ = [
    "LIVE_VIEWS",
    "MIN_MOTION_SHARE",
    "LiveOutcome",
    "LiveRules",
    "live_pairs",
    "numbers_differ",
]

#: How many pairs a live source's calibration keeps unless told (``--views``).
LIVE_VIEWS = 15
#: How long a pair's board speed is measured over at most (the pair before, if this recent).
#: The board's least motion between kept pairs unless told, a share of the image diagonal.
MIN_MOTION_SHARE = 0.025
_SPEED_SPAN_NS = 250_000_000


@dataclass(frozen=True, kw_only=True)
class LiveRules:
    """When a live pair is kept: ``views`` to keep (None: :data:`LIVE_VIEWS` from cameras
    and videos, every pair from folders of stills); ``min_motion_px`` the board's mean
    corner motion since the last kept pair (None: :data:`MIN_MOTION_SHARE` of the image diagonal);
    ``max_skew_px`` the board's motion allowed between the pair's two capture times.
    """

    views: int | None = None
    min_motion_px: float | None = None
    max_skew_px: float = 0.5


@dataclass(kw_only=True)
class LiveOutcome:
    """How the collection went (filled as it goes): the cameras, the pairs examined and
    kept, each camera's dropped frames, and how it ended, in words."""

    cameras: tuple[CameraStream, CameraStream] | None = None
    examined: int = 0
    kept: int = 0
    dropped: tuple[int, int] = (0, 0)
    ended: str = ""
    stopped: bool = False  # by Ctrl-C or SIGTERM
    stills: bool = False
    warnings: list[str] = field(default_factory=list)


@dataclass(kw_only=True)
class _Seen:
    """The last pair the board was found in both (for its speed) and the last kept."""

    t_ns: int = 0
    corners: tuple[F32, F32] | None = None
    kept: tuple[F32, F32] | None = None
    said: str = ""
    said_at: F32 | None = None  # camera 1's corners when a reason was last said


def live_pairs(
    source: PairSource,
    board: tuple[int, int],
    rules: LiveRules,
    outcome: LiveOutcome,
    say: Callable[[str], None],
) -> Iterator[StillPair]:
    """The pairs to fit, from ``source`` (opened here): every pair of a folder of stills;
    from cameras and videos, the pairs the rules keep (the module docstring); each camera's
    queue bounded by :data:`LIVE_BOUND`."""
    source.bound_to(LIVE_BOUND)
    with stops.handled() as stop, source:
        outcome.cameras, outcome.stills = source.cameras, source.stills
        outcome.warnings = list(source.warnings)
        for n, camera in enumerate(source.cameras, start=1):
            say(f"camera {n}: {camera.text()}")
        for warning in source.warnings:
            say(f"warning: {warning}")
        try:
            yield from _kept(source, board, rules, outcome, say)
        except KeyboardInterrupt:
            if not stop.requested:
                raise
            outcome.stopped = True
            outcome.ended = f"{stop.describe()}: {_count(outcome)}"
        except SourceError as err:
            if outcome.examined == 0:
                raise
            outcome.ended = f"{err}: {_count(outcome)}"  # the pairs kept are fitted
        finally:
            outcome.dropped = source.dropped_by_camera
            for line in source.drops_said():
                say(f"warning: {line}")
    if not outcome.ended:
        ended = "; ".join(source.ended_by()) or source.ended_early or "both cameras ended"
        outcome.ended = f"{ended}: {_count(outcome)}"


def numbers_differ(first: str, second: str) -> bool:
    """Whether two stills paired by file-name order carry different numbers
    (``left01.jpg`` with ``right03.jpg``): a still missing on one side."""
    a, b = re.findall(r"\d+", Path(first).stem), re.findall(r"\d+", Path(second).stem)
    return bool(a and b) and [int(x) for x in a] != [int(x) for x in b]


def _unpaired(name: str) -> InputValueError:
    return InputValueError(
        f"{name} is paired (file-name order) but their numbers differ: a still is missing "
        "in one folder, or the names do not match; each still of camera 1 needs camera 2's "
        "of the same moment, as --left/--right pair them"
    )


def _count(outcome: LiveOutcome) -> str:
    return f"{outcome.kept} pair(s) kept of {outcome.examined} examined"


def _kept(
    source: PairSource,
    board: tuple[int, int],
    rules: LiveRules,
    outcome: LiveOutcome,
    say: Callable[[str], None],
) -> Iterator[StillPair]:
    info = source.cameras[0].info
    min_motion = rules.min_motion_px
    if min_motion is None:
        min_motion = MIN_MOTION_SHARE * math.hypot(info.width, info.height)
    uncertain_ns = max(
        round(1e9 / c.info.fps) if c.clock == CLOCK_GRAB else 0 for c in source.cameras
    )
    views = rules.views or (None if source.stills else LIVE_VIEWS)
    seen = _Seen()
    for pair in source.pairs():
        outcome.examined += 1
        name = f"{pair.first.name} & {pair.second.name}"
        if source.stills and numbers_differ(pair.first.name, pair.second.name):
            raise _unpaired(name)
        if not source.stills:  # a folder's stills: no motion to wait for, every pair fitted
            why = _why_not(pair, board, seen, min_motion, rules.max_skew_px, uncertain_ns)
            if why:
                if _news(why, seen, min_motion):  # said when it changes, not for every frame
                    say(f"{name}: {why}")
                continue
            seen.said, seen.said_at = "", None
            skew = f"skew {pair.skew_ns / 1e6:+.1f} ms"
            say(f"kept pair {outcome.kept + 1} of {views}: {name} ({skew})")
        outcome.kept += 1
        yield name, pair.first.image, pair.second.image
        if views is not None and outcome.kept >= views:
            outcome.ended = f"{_count(outcome)}, as asked"
            return
    if source.stills and len(set(counts := source.grabbed_by_camera)) > 1:
        raise InputValueError(  # a still of one folder has no partner in the other
            f"camera 1's folder has {counts[0]} stills, camera 2's {counts[1]}: each still of "
            "camera 1 needs camera 2's of the same moment, as --left/--right pair them"
        )


def _why_not(
    pair: FramePair,
    board: tuple[int, int],
    seen: _Seen,
    min_motion_px: float,
    max_skew_px: float,
    uncertain_ns: int,
) -> str:
    """Why this pair is not kept ("": it is); ``seen`` updated with its board."""
    from twopose.detect.checkerboard import find_board

    one = find_board(pair.first.image, board)
    two = find_board(pair.second.image, board) if one is not None else None
    if one is None or two is None:
        seen.corners = None
        missing = "camera 1" if one is None else "camera 2"
        return f"no board in {missing}"
    t = pair.first.t_capture_ns
    before, span = seen.corners, t - seen.t_ns
    seen.t_ns, seen.corners = t, (one, two)
    moved = 0.0 if seen.kept is None else max(_shift(one, seen.kept[0]), _shift(two, seen.kept[1]))
    if seen.kept is not None and moved < min_motion_px:
        return (
            f"the board has not moved since the last pair kept ({moved:.0f} px, less than "
            f"{min_motion_px:.0f}): move it to a new place"
        )
    skew = abs(pair.skew_ns) + uncertain_ns
    if skew > 0:
        if before is None or not 0 < span <= _SPEED_SPAN_NS:
            return "the board just appeared: hold it still"
        speed = max(_shift(one, before[0]), _shift(two, before[1])) / span
        if speed * skew > max_skew_px:
            return (
                f"the board moved {speed * skew:.1f} px between the two cameras' frames: "
                "hold it still"
            )
    seen.kept = (one, two)
    return ""


def _news(why: str, seen: _Seen, min_motion_px: float) -> bool:
    """Whether ``why`` is worth saying: another reason than the last said (its numbers
    aside), or the same where the board stands at a new place (a quarter of the least
    motion from where it was last said), so that no place goes unmentioned."""
    kind = re.sub(r"[\d.]+", "#", why)
    at = None if seen.corners is None else seen.corners[0]
    new_place = (
        at is not None
        and seen.said_at is not None
        and _shift(at, seen.said_at) >= min_motion_px / 4
    )
    if kind == seen.said and not new_place:
        return False
    seen.said, seen.said_at = kind, at
    return True


def _shift(a: F32, b: F32) -> float:
    """Mean corner displacement between two views of the board, pixels."""
    import numpy as np

    return float(np.linalg.norm(a.reshape(-1, 2) - b.reshape(-1, 2), axis=1).mean())
