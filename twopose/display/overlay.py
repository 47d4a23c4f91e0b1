"""A detection drawn on its image as ``foxglove.ImageAnnotations``.

Used live by the recorder and offline in results.mcap: the detected blob's outline, centroid and
orientation in green, candidates the filters turned down in red with the reason, and the verdict.
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.PointsAnnotation_pb2 import PointsAnnotation

from twopose.arrays import F64
from twopose.detect.detection import Detection

__all__ = ["BLACK", "GREEN", "RED", "image_annotations", "set_color", "set_xy"]

RGBA = tuple[float, float, float, float]
GREEN: RGBA = (0.1, 0.85, 0.2, 1.0)
RED: RGBA = (0.95, 0.15, 0.1, 1.0)
BLACK: RGBA = (0.0, 0.0, 0.0, 0.6)


def set_color(msg: Any, rgba: RGBA) -> None:
    """Fill a ``foxglove.Color``."""
    msg.r, msg.g, msg.b, msg.a = rgba


def set_xy(msg: Any, x: float, y: float) -> None:
    """Fill a ``foxglove.Point2``."""
    msg.x, msg.y = float(x), float(y)


def image_annotations(det: Detection, log_time_ns: int, label: str) -> ImageAnnotations:
    """One frame's overlay: the detection, the candidates turned down, a label.

    One frame's overlay: outline, centroid and orientation of the detection (green), the
    candidates turned down (red, with why), and ``label`` with the verdict.
    """
    msg = ImageAnnotations()

    def outline(points: F64 | None, rgba: tuple[float, float, float, float]) -> None:
        if points is None or len(points) < 2:
            return
        # Within a pixel of the boundary: a drawing needs no more, and fewer points
        # keep the overlay cheap (it is built for every frame).
        simple = cv2.approxPolyDP(points.astype(np.float32)[:, None, :], 1.0, closed=True)
        a = msg.points.add(type=PointsAnnotation.Type.LINE_LOOP, thickness=2.0)
        a.timestamp.FromNanoseconds(log_time_ns)
        set_color(a.outline_color, rgba)
        for x, y in simple[:, 0, :].tolist():
            a.points.add(x=x, y=y)

    def text(x: float, y: float, words: str, rgba: tuple[float, float, float, float]) -> None:
        t = msg.texts.add(text=words, font_size=14.0)
        t.timestamp.FromNanoseconds(log_time_ns)
        set_xy(t.position, x, y)
        set_color(t.text_color, rgba)
        set_color(t.background_color, BLACK)

    for blob in det.rejected_blobs:
        outline(blob.outline_px, RED)
        text(blob.centroid_px[0], blob.centroid_px[1], blob.reason, RED)
    if det.found:
        outline(det.outline_px, GREEN)
        col, row = det.centroid_px
        c = msg.circles.add(diameter=8.0, thickness=2.0)
        c.timestamp.FromNanoseconds(log_time_ns)
        set_xy(c.position, col, row)
        set_color(c.outline_color, GREEN)
        if math.isfinite(det.theta_deg):
            t = math.radians(det.theta_deg)
            d = np.array([math.cos(t), math.sin(t)]) * 80.0
            a = msg.points.add(type=PointsAnnotation.Type.LINE_LIST, thickness=2.0)
            a.timestamp.FromNanoseconds(log_time_ns)
            set_color(a.outline_color, GREEN)
            set_xy(a.points.add(), col - d[0], row - d[1])
            set_xy(a.points.add(), col + d[0], row + d[1])
    verdict = "found" if det.found else f"rejected: {det.reason}"
    text(10.0, 20.0, f"{label}: {verdict}", GREEN if det.found else RED)
    return msg
