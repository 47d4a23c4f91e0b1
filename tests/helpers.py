"""Helpers shared by test modules (real files, written with OpenCV)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from twopose.format.entries import CaptureDecision, PoseEntry
from twopose.format.writer import SessionWriter


def write_video(path: Path, n: int, size: tuple[int, int] = (64, 48), step: int = 20) -> Path:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, size)
    assert w.isOpened()
    for i in range(n):
        w.write(np.full((size[1], size[0], 3), step * i, np.uint8))
    w.release()
    return path


def write_accepted_capture(
    writer: SessionWriter,
    entry: PoseEntry,
    images: Sequence[NDArray[np.uint8] | bytes],
    t0_ns: int,
) -> int:
    """One accepted format 1.1 capture as the recorder writes it: the pose entry bound to a
    new capture number, its frames (arrays, or already-encoded bytes) and window at
    ``t0_ns + 1, + 2, ...``, then the accept decision. Returns the next free time."""
    number = writer.new_capture_number()
    bound = dataclasses.replace(entry, capture=number)
    writer.write_pose(bound, t0_ns)
    t = t0_ns
    with writer.capture(entry.trial, entry.pose, entry.camera_id, number) as cap:
        for image in images:
            t += 1
            if isinstance(image, bytes):
                cap.add_encoded(image, t)
            else:
                cap.add_frame(image, t)
    writer.write_decision(
        CaptureDecision(number, entry.trial, entry.pose, entry.camera_id, "accept"), t + 1
    )
    return t + 2
