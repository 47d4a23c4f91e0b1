"""A lab's session files, made fast: what happens to them (record, continue, fork, copy,
rename, recover, a recording killed), through the real writer, the real continuation
(:func:`recorder.setup.continuation.read_continued`) and the real ``recover``.

Frames are tiny blank images: nothing is detected, so every trial is a row of its own
(``no_detection``) whatever happens to it, and a test counts captures and trials by what
they are, not by what they measured. With ``measured=True`` each frame shows the dot target
where the trial's truth projects (a 64x48 drawing, no renderer): every trial is measured,
for the tests that need numbers (errors, intervals, the report's columns, ``compare``).
"""

from __future__ import annotations

import uuid
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from recorder.setup.continuation import read_continued
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import CaptureDecision, GroundTruth, PoseEntry, SessionInfo
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

CAMERA = Camera(
    camera_id="cam0",
    intrinsics=Intrinsics(width=64, height=48, fx=52.5, fy=52.5, cx=32.0, cy=24.0),
)
_BLANK = np.full((48, 64, 3), 200, dtype=np.uint8)


def new_info(
    *, units: Units = Units.IN, created: str = "2026-11-27T00:00:00Z", operator: str = "lab"
) -> SessionInfo:
    """A new session's opening entry, as the recorder writes one (a fresh id and part)."""
    return SessionInfo(
        method=Method.POINT,
        units=units,
        camera_ids=("cam0",),
        operator=operator,
        created_utc=created,
        session_id=uuid.uuid4().hex,
        part_id=uuid.uuid4().hex,
    )


#: Where each trial's truth is (grid frame, inches): trials differ, so errors differ.
def truth_of(trial: int) -> tuple[float, float, float]:
    return (1.0 + 0.1 * (trial % 7), 2.0, 11.0)


def dot_frame(truth: tuple[float, float, float], t_grid: tuple[float, float, float]) -> np.ndarray:
    """A 64x48 frame with the dot target drawn where ``truth`` projects from a camera at
    ``t_grid`` (no rotation), to 1/16 px, radius 3 px."""
    from twopose.camera.model import project_points

    col, row = project_points([truth], CAMERA.intrinsics, np.eye(3), t_grid)[0]
    frame = _BLANK.copy()
    centre = (round(col * 16), round(row * 16))
    cv2.circle(frame, centre, 3 * 16, (0, 0, 0), -1, cv2.LINE_AA, shift=4)
    return frame


def write_part(
    path: Path, info: SessionInfo, trials: Sequence[int], *, measured: bool = False
) -> None:
    """A session file holding ``trials``, each two accepted captures of one frame (blank,
    or with ``measured`` the dot where the trial's truth is)."""
    t = 1_000_000_000
    with SessionWriter(path, info, [CAMERA], start_ns=t) as w:
        for trial in trials:
            w.write_ground_truth(
                GroundTruth(trial=trial, kind="point", points_grid=(truth_of(trial),)), t
            )
            for pose in (1, 2):
                number = w.new_capture_number()
                w.write_pose(
                    PoseEntry(
                        trial=trial,
                        pose=pose,
                        camera_id="cam0",
                        t_grid=(float(pose), 0.0, 0.0),
                        r_deg=(0.0, 0.0, 0.0),
                        capture=number,
                    ),
                    t + 1,
                )
                with w.capture(trial, pose, "cam0", number) as cap:
                    where = (float(pose), 0.0, 0.0)
                    cap.add_frame(dot_frame(truth_of(trial), where) if measured else _BLANK, t + 2)
                w.write_decision(
                    CaptureDecision(
                        capture=number, trial=trial, pose=pose, camera_id="cam0", decision="accept"
                    ),
                    t + 3,
                )
                t += 10


def record(path: Path, n_trials: int, *, measured: bool = False, **info: object) -> SessionInfo:
    """A new session of ``n_trials`` trials (1..n)."""
    opening = new_info(**info)  # type: ignore[arg-type]
    write_part(path, opening, range(1, n_trials + 1), measured=measured)
    return opening


def continue_session(
    of: Path, path: Path, n_trials: int, *, measured: bool = False, operator: str | None = None
) -> SessionInfo:
    """``new path --continue of [--operator NAME]``: ``n_trials`` more, numbered after
    ``of``'s last."""
    continued = read_continued(of)
    opening = continued.info_for(operator=operator)
    first = continued.last_trial + 1
    write_part(path, opening, range(first, first + n_trials), measured=measured)
    return opening


def kill_midway(path: Path, keep: float = 0.6) -> None:
    """What kill -9 leaves of a recording: the file cut before its summary was written."""
    data = path.read_bytes()
    path.write_bytes(data[: max(64, int(len(data) * keep))])
