"""Helpers shared by test modules (real files, written with OpenCV)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np


def write_video(path: Path, n: int, size: tuple[int, int] = (64, 48), step: int = 20) -> Path:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, size)
    assert w.isOpened()
    for i in range(n):
        w.write(np.full((size[1], size[0], 3), step * i, np.uint8))
    w.release()
    return path
