"""A pair source checked and its clocks learned before a session's first stream trial.

Each camera's frames must have the size its calibration was made at; each camera's clock is
decided by its first frame (:func:`with_clocks`), and the session entry says which.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

from recorder.procedure import stops
from twopose.errors import InputValueError, SourceError

if TYPE_CHECKING:
    from recorder.sources.pair import PairSource
    from twopose.camera.model import Intrinsics
    from twopose.format.entries import SessionInfo

__all__ = ["FIRST_FRAME_S", "check_sizes", "first_frames", "with_clocks"]

#: How long a camera may take to give its first frame (a webcam starting up).
FIRST_FRAME_S = 5.0


def with_clocks(info: SessionInfo, source: PairSource) -> SessionInfo:
    """The session entry saying each camera's clock. A camera's clock is decided by its
    first frame (a driver's stamp, or the monotonic clock at grab): those are waited for
    (and dropped) first, except from stills, whose every frame counts. A continuation's
    clocks are its own; where one differs from the part continued's, its notes say so."""
    if not source.stills:
        seen: set[int] = set()
        deadline = time.monotonic() + FIRST_FRAME_S
        while len(seen) < 2:
            stops.check()
            camera = source.read_frame(timeout_s=FIRST_FRAME_S).camera
            seen.add(camera)
            source.unrecorded[camera - 1] += 1  # read for its clock, not recorded
            if len(seen) < 2 and time.monotonic() > deadline:  # the other keeps giving
                _refuse_silent(source, 2 if 1 in seen else 1)
    one, two = source.cameras
    clocks = {info.camera_ids[0]: one.clock, info.camera_ids[1]: two.clock}
    before = (info.clocks or {}) if info.continues_file else {}  # the part continued's
    changed = [
        f"camera {cid}'s clock is {clock} here, {before[cid]} in {info.continues_file}"
        for cid, clock in clocks.items()
        if before.get(cid, clock) != clock
    ]
    notes = "; ".join([info.notes, *changed]) if changed else info.notes
    return dataclasses.replace(info, clocks=clocks, notes=notes)


def first_frames(source: PairSource) -> None:
    """Files replayed whole (every frame counts, none taken here): each camera's first
    frame waited for, at most :data:`FIRST_FRAME_S`; a file or folder that ended without
    one, or a camera silent so long, refused before the session begins."""
    deadline = time.monotonic() + FIRST_FRAME_S
    while not all(source.grabbed_by_camera) and time.monotonic() < deadline:
        stops.check()
        if any(n == 0 and e for n, e in zip(*_counts(source), strict=True)):
            break  # a file or folder that ended without a frame
        time.sleep(0.01)
    grabbed, ended = _counts(source)
    for n in sorted((1, 2), key=lambda n: not ended[n - 1]):  # an empty one first
        if not grabbed[n - 1]:
            _refuse_silent(source, n)


def _counts(source: PairSource) -> tuple[tuple[int, int], tuple[bool, bool]]:
    return source.grabbed_by_camera, source.ended_by_camera


def _refuse_silent(source: PairSource, n: int) -> None:
    raise SourceError(
        f"camera {n} ({source.cameras[n - 1].spec}) gave no frame in {FIRST_FRAME_S:g} s (an "
        "empty file, or a camera not connected or used by another program)"
    )


def check_sizes(source: PairSource, intrinsics: Sequence[Intrinsics]) -> None:
    """Each camera's frames must have its calibration's size (the pair's): a recording's
    and ``point``'s alike (a new user's r7 K2: ``point`` drew 320x240 frames through a
    640x480 pair as green points 2.4 in off, ten times their regions)."""
    for n, (stream, k) in enumerate(zip(source.cameras, intrinsics, strict=True), start=1):
        i = stream.info
        if (i.width, i.height) != (k.width, k.height):
            raise InputValueError(
                f"camera {n} ({stream.spec}) delivers {i.width}x{i.height} frames, but the "
                f"pair's camera {n} is calibrated for {k.width}x{k.height}: calibrate the "
                "pair at this size, or ask the camera for the calibrated one"
            )
