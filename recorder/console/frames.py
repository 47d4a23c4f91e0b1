"""The camera on the console's page: frames with their detection drawn, live and streamed.

Each frame is drawn with its detection; a live preview shows the camera while the operator
types or decides (shown, not recorded); the MJPEG stream is what the page shows
(``GET /stream.mjpg``, :mod:`recorder.console.server`).
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import AsyncIterator
from typing import TYPE_CHECKING

import cv2
import numpy as np
from starlette.requests import Request

from recorder.console.state import ConsoleSession
from twopose.errors import TwoposeError

if TYPE_CHECKING:
    from recorder.sources.registry import FrameSource
    from twopose.detect.detection import Detection

__all__ = ["BOUNDARY", "draw_detection", "mjpeg", "overlay_jpeg", "preview"]

#: The MJPEG stream's part boundary.
BOUNDARY = "twoposeframe"
_PREVIEW_INTERVAL_S = 0.1


def draw_detection(image: np.ndarray, det: Detection | None) -> np.ndarray:
    """The detection on the image (BGR, in place): candidates turned down in red, the
    blob's outline, centroid and orientation in green, or why nothing was found."""
    if det is None:
        return image
    for blob in det.rejected_blobs:
        if blob.outline_px is not None and len(blob.outline_px) > 1:
            cv2.polylines(
                image, [blob.outline_px.astype(np.int32)], isClosed=True, color=(0, 0, 255)
            )
    if det.found:
        if det.outline_px is not None and len(det.outline_px) > 1:
            cv2.polylines(
                image,
                [det.outline_px.astype(np.int32)],
                isClosed=True,
                color=(0, 200, 0),
                thickness=2,
            )
        c = np.array(det.centroid_px)
        cv2.circle(image, (int(c[0]), int(c[1])), 4, (0, 200, 0), -1)
        if math.isfinite(det.theta_deg):
            t = math.radians(det.theta_deg)
            d = 60 * np.array([math.cos(t), math.sin(t)])
            a, b = (c - d).astype(int), (c + d).astype(int)
            cv2.line(image, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), (0, 200, 0), 2)
    else:
        cv2.putText(
            image, f"not found: {det.reason}"[:70], (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
            (0, 0, 255), 2,
        )  # fmt: skip
    return image


def overlay_jpeg(data: bytes, det: Detection | None) -> bytes:
    """The frame with its detection drawn; the frame as it is if drawing fails (the
    overlay is a courtesy and must never stop the stream)."""
    try:
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            return data
        drawn = draw_detection(image, det)
        ok, encoded = cv2.imencode(".jpg", drawn, [cv2.IMWRITE_JPEG_QUALITY, 80])
    except Exception:
        return data
    return encoded.tobytes() if ok else data


def preview(source: FrameSource, session: ConsoleSession) -> None:
    """One live frame while the operator types or decides (shown, not recorded), at most
    every ``_PREVIEW_INTERVAL_S``, and only while someone watches."""
    from twopose.detect.detection import detect

    now = time.monotonic()
    if session.viewers == 0 or now - session.preview_at < _PREVIEW_INTERVAL_S:
        time.sleep(0.02)
        return
    session.preview_at = now
    try:
        image = source.read(0.5)
    except TwoposeError:
        return
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 80])
    if ok:
        spec = session.method_spec()
        target = spec.target if spec is not None else None
        try:  # nothing to outline on a board session's page (the rig fit finds its corners)
            detection = detect(image, target) if target is not None else None
        except Exception as err:  # the overlay is a courtesy; it must not stop the recording
            session.update(live_error=f"the live detection failed ({type(err).__name__}: {err})")
            detection = None
        session.frame("", encoded.tobytes(), "jpeg", time.time_ns(), detection, "")


async def mjpeg(session: ConsoleSession, request: Request) -> AsyncIterator[bytes]:
    """Every new frame, with its detection drawn, until the page goes away."""
    with session.lock:
        session.viewers += 1
    try:
        seq = 0
        while not session.closing.is_set() and not await request.is_disconnected():
            frame = await asyncio.to_thread(session.next_frame, seq, 0.5)
            if frame is None:
                continue
            seq = frame.seq
            jpeg = await asyncio.to_thread(overlay_jpeg, frame.data, frame.detection)
            yield (
                (
                    f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
                    f"Content-Length: {len(jpeg)}\r\n\r\n"
                ).encode()
                + jpeg
                + b"\r\n"
            )
    finally:
        with session.lock:
            session.viewers -= 1
