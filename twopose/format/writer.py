"""The session writer: one MCAP file per session, never overwritten, flushed as it goes."""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, Self

import cv2
import numpy as np
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from numpy.typing import NDArray

from twopose import __version__
from twopose.camera import Camera, Intrinsics
from twopose.errors import InputValueError, SessionExistsError, SessionFormatError, TwoposeError
from twopose.format.channels import Channels, register_session_channels
from twopose.format.entries import (
    FORMAT_VERSION,
    CaptureDecision,
    CaptureWindow,
    GroundTruth,
    Note,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    TypedEntry,
    encode_entry,
)
from twopose.format.messages import (
    TF_TOPIC,
    calibration_message,
    calibration_topic,
    image_message,
    image_topic,
    transform_message,
)
from twopose.values import index

__all__ = [
    "IMAGE_FORMATS",
    "METADATA_NAME",
    "Capture",
    "SessionWriter",
    "cameras_from_metadata",
    "session_metadata",
]

METADATA_NAME = "twopose"
IMAGE_FORMATS = ("jpeg", "png")


def session_metadata(
    info: SessionInfo, cameras: Sequence[Camera], ground: PlaneEntry | None, start_ns: int
) -> dict[str, str]:
    """The ``twopose`` metadata record: versions, plus a copy of what opens the session.

    The metadata record is written before the first chunk, so the copy survives the loss
    of that chunk (which holds the schemas, channels and the session entry).
    """
    return {
        "format_version": FORMAT_VERSION,
        "software_version": __version__,
        "session": encode_entry(info).decode(),
        "cameras": json.dumps([{"camera": c.camera_id, **c.intrinsics.to_dict()} for c in cameras]),
        "ground": encode_entry(ground).decode() if ground is not None else "",
        "start_ns": str(start_ns),
    }


def cameras_from_metadata(text: str) -> list[Camera]:
    """Inverse of the ``cameras`` field of :func:`session_metadata`."""
    try:
        return [
            Camera(
                camera_id=c["camera"],
                intrinsics=Intrinsics.from_dict(c, "the metadata's camera copy"),
            )
            for c in json.loads(text)
        ]
    except (KeyError, TypeError, ValueError, InputValueError) as err:
        raise SessionFormatError(f"the metadata's camera copy is unreadable: {err}") from err


def _with_sigma(info: SessionInfo, cameras: Sequence[Camera]) -> SessionInfo:
    """The session entry carrying the cameras' calibration sigmas (format 1.2).

    The sigmas are added where the cameras know them and the entry does not say otherwise.
    """
    known = {c.camera_id: dict(c.intrinsics_sigma) for c in cameras if c.intrinsics_sigma}
    if not known or info.intrinsics_sigma is not None:
        return info
    return dataclasses.replace(info, intrinsics_sigma=known)


class SessionWriter:
    """Write one session file; a context manager that refuses to overwrite.

    Every typed entry and the end of every capture flush the open chunk to disk, so a
    crash loses at most the capture in progress. All schemas and channels are registered
    and flushed with the session entry at open, in the order of ``docs/session-format.md``.

    Parameters
    ----------
    path : path-like
        The new session file; it must not exist.
    info : SessionInfo
    cameras : sequence of Camera
        One per id in ``info.camera_ids``, in that order.
    ground : PlaneEntry, optional
    image_format : {"jpeg", "png"}
    jpeg_quality : int
    clock : callable returning int nanoseconds
        Used wherever a ``log_time_ns`` is not given (simulations pass their own).
    start_ns : int, optional
        Time of the opening entries (default: the clock's).
    """

    def __init__(
        self,
        path: str | Path,
        info: SessionInfo,
        cameras: Sequence[Camera],
        *,
        ground: PlaneEntry | None = None,
        image_format: str = "jpeg",
        jpeg_quality: int = 90,
        clock: Callable[[], int] = time.time_ns,
        start_ns: int | None = None,
    ) -> None:
        if image_format not in IMAGE_FORMATS:
            raise InputValueError(f"image format must be jpeg or png, got {image_format!r}")
        if tuple(c.camera_id for c in cameras) != info.camera_ids:
            raise InputValueError(
                f"cameras {[c.camera_id for c in cameras]} do not match the session's "
                f"camera_ids {list(info.camera_ids)}"
            )
        if not 1 <= jpeg_quality <= 100:
            raise InputValueError(f"JPEG quality must be 1-100, got {jpeg_quality}")
        self.path = Path(path)
        self.info = _with_sigma(info, cameras)
        self.cameras = {c.camera_id: c for c in cameras}
        self.ground = ground
        self.image_format = image_format
        self._encode_params = (
            [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality] if image_format == "jpeg" else []
        )
        self._clock = clock
        self._start_ns = start_ns
        self._stream: IO[bytes] | None = None
        self._mcap: McapWriter | None = None
        self._channels: Channels | None = None
        self._sequence: dict[str, int] = {}
        self._last_ns = 0
        self._open_capture: Capture | None = None
        self._captures = 0

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return dict(self._channels.counts) if self._channels is not None else {}

    # -- lifecycle
    def __enter__(self) -> Self:
        """Create the file (never over an existing one) and write its header."""
        try:
            self._stream = open(self.path, "xb")
        except FileExistsError as err:
            raise SessionExistsError(
                f"{self.path} already exists; twopose never overwrites a session. "
                "Choose another file name or move the old one away."
            ) from err
        except OSError as err:
            raise TwoposeError(f"cannot create {self.path}: {err.strerror}") from err
        self._mcap = McapWriter(self._stream, compression=CompressionType.ZSTD)
        self._mcap.start(profile="", library=f"twopose/{__version__}")
        self._channels = register_session_channels(self._mcap, self.info.camera_ids)
        t0 = self._start_ns if self._start_ns is not None else self._clock()
        self._mcap.add_metadata(
            METADATA_NAME, session_metadata(self.info, list(self.cameras.values()), self.ground, t0)
        )
        self._write_json(self.info, t0)
        for camera in self.cameras.values():
            self._write_proto(
                calibration_topic(camera.camera_id), calibration_message(camera, t0), t0
            )
        if self.ground is not None:
            self._write_json(self.ground, t0)
        self._mcap.flush()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Finish the file: summary, index and footer, even after an error."""
        self.close()

    def close(self) -> None:
        """Write the summary and index, sync and close the file (also after an error)."""
        try:
            if self._mcap is not None:
                self._mcap.finish()
                self._mcap = None
            self.sync()
        finally:
            if self._stream is not None:
                self._stream.close()
                self._stream = None

    def sync(self) -> None:
        """Flush the open chunk and ``fsync`` the file.

        What is written so far survives a power cut, not only a crash of this process
        (called when a capture is accepted).
        """
        if self._stream is None:
            return
        if self._mcap is not None:
            self._mcap.flush()
        self._stream.flush()
        try:
            os.fsync(self._stream.fileno())
        except OSError as err:
            raise TwoposeError(f"cannot sync {self.path} to disk: {err.strerror}") from err

    @property
    def is_open(self) -> bool:
        """Whether the file is still being written."""
        return self._mcap is not None

    # -- low level
    def time(self, log_time_ns: int | None) -> int:
        """``log_time_ns``, or the clock's time when None; remembered as the latest."""
        t = self._clock() if log_time_ns is None else int(log_time_ns)
        if t < 0:
            raise InputValueError(f"log time must be >= 0 ns, got {t}")
        self._last_ns = max(self._last_ns, t)
        return t

    @property
    def last_ns(self) -> int:
        """The latest log time written so far."""
        return self._last_ns

    def _write(self, topic: str, payload: bytes, log_time_ns: int) -> int:
        if self._channels is None or self._mcap is None:
            raise TwoposeError(
                f"{self.path} is not open for writing; use `with SessionWriter(...)`"
            )
        seq = self._sequence.get(topic, 0)
        self._sequence[topic] = seq + 1
        self._channels.write(topic, payload, log_time_ns, seq)
        return seq

    def _write_json(self, entry: TypedEntry, log_time_ns: int) -> None:
        self._write(entry.TOPIC, encode_entry(entry), log_time_ns)

    def _write_proto(self, topic: str, msg: object, log_time_ns: int) -> int:
        return self._write(topic, msg.SerializeToString(), log_time_ns)  # type: ignore[attr-defined]

    def flush(self) -> None:
        """End the open chunk so that everything so far is in the file."""
        if self._mcap is not None:
            self._mcap.flush()

    def _check_camera(self, camera_id: str) -> None:
        if camera_id not in self.cameras:
            raise InputValueError(
                f"camera {camera_id!r} is not in this session (cameras: {', '.join(self.cameras)})"
            )

    # -- typed entries
    def write_pose(self, entry: PoseEntry, log_time_ns: int | None = None) -> None:
        """Write a typed pose and its ``foxglove.FrameTransform``; flushed at once."""
        self._check_camera(entry.camera_id)
        t = self.time(log_time_ns)
        self._write_json(entry, t)
        self._write_proto(TF_TOPIC, transform_message(entry, t), t)
        self.flush()

    def write_entry(self, entry: TypedEntry, log_time_ns: int | None = None) -> None:
        """Write a typed entry; flushed at once."""
        self._write_json(entry, self.time(log_time_ns))
        self.flush()

    def write_ground_truth(self, entry: GroundTruth, log_time_ns: int | None = None) -> None:
        """Write a trial's ground truth."""
        self.write_entry(entry, log_time_ns)

    def write_note(self, entry: Note, log_time_ns: int | None = None) -> None:
        """Write an operator's note."""
        self.write_entry(entry, log_time_ns)

    def write_decision(self, entry: CaptureDecision, log_time_ns: int | None = None) -> None:
        """Write the operator's decision on a capture."""
        self.write_entry(entry, log_time_ns)

    def new_capture_number(self) -> int:
        """The next capture number (1, 2, ...).

        Binds a pose entry, its capture window and the decisions about it (format 1.1).
        """
        self._captures += 1
        return self._captures

    def capture(self, trial: int, pose: int, camera_id: str, capture: int | None = None) -> Capture:
        """Open a capture window; frames go through :meth:`Capture.add_frame`.

        ``capture`` is the number its pose entry was written with (format 1.1).
        """
        self._check_camera(camera_id)
        index(trial, "trial")
        index(pose, "pose")
        if self._open_capture is not None:
            raise TwoposeError("a capture is already open; finish it before starting another")
        return Capture(self, trial, pose, camera_id, capture)

    def encode_image(self, image_bgr: NDArray[np.uint8]) -> bytes:
        """Encode an (H, W, 3) BGR uint8 image in the session's image format."""
        ok, buf = cv2.imencode(
            ".jpg" if self.image_format == "jpeg" else ".png", image_bgr, self._encode_params
        )
        if not ok:
            raise InputValueError(f"OpenCV could not encode a {image_bgr.shape} image")
        return bytes(buf)

    def write_image(self, camera_id: str, data: bytes, log_time_ns: int) -> int:
        """One encoded frame on the camera's image topic; its sequence number."""
        msg = image_message(camera_id, data, self.image_format, log_time_ns)
        return self._write_proto(image_topic(camera_id), msg, log_time_ns)

    def _begin_capture(self, capture: Capture | None) -> None:
        self._open_capture = capture


class Capture:
    """One capture window: its frames, then its :class:`CaptureWindow` entry.

    One capture window (see :meth:`SessionWriter.capture`): its frames, then on exit its
    :class:`CaptureWindow` entry (``incomplete`` with the reason after an error).
    """

    def __init__(
        self,
        writer: SessionWriter,
        trial: int,
        pose: int,
        camera_id: str,
        capture: int | None = None,
    ) -> None:
        self._writer = writer
        self.trial = trial
        self.pose = pose
        self.camera_id = camera_id
        self.number = capture
        self.start_ns: int | None = None
        self.end_ns: int | None = None
        self.n_frames = 0
        self.dropped_frames = 0
        self._incomplete_reason = ""

    def __enter__(self) -> Self:
        """Begin the capture (one at a time per writer)."""
        self._writer._begin_capture(self)
        return self

    def add_frame(self, image_bgr: NDArray[np.uint8], log_time_ns: int | None = None) -> int:
        """Encode and write one frame; returns its sequence number on the image topic."""
        return self.add_encoded(self._writer.encode_image(image_bgr), log_time_ns)

    def add_encoded(self, data: bytes, log_time_ns: int | None = None) -> int:
        """Write one already-encoded frame in the session's image format."""
        t = self._writer.time(log_time_ns)
        if self.end_ns is not None and t < self.end_ns:
            raise InputValueError(
                f"frame time {t} ns goes back before the previous frame ({self.end_ns} ns)"
            )
        seq = self._writer.write_image(self.camera_id, data, t)
        self.start_ns = t if self.start_ns is None else self.start_ns
        self.end_ns = t
        self.n_frames += 1
        return seq

    def mark_incomplete(self, reason: str) -> None:
        """Mark the capture incomplete, with the reason."""
        self._incomplete_reason = reason or "incomplete"

    @property
    def incomplete_reason(self) -> str:
        """Why the capture is incomplete ("": complete so far); after the exit, its window's."""
        return self._incomplete_reason

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """End the capture: write its window, incomplete if an error ended it."""
        self._writer._begin_capture(None)
        if isinstance(exc, KeyboardInterrupt) and not self._incomplete_reason:
            self._incomplete_reason = "interrupted (Ctrl-C) during the capture"
        elif exc is not None and not self._incomplete_reason:
            self._incomplete_reason = f"{exc_type.__name__ if exc_type else 'error'}: {exc}"
        if not self._writer.is_open:
            return
        now = self._writer.last_ns
        window = CaptureWindow(
            trial=self.trial,
            pose=self.pose,
            camera_id=self.camera_id,
            start_ns=self.start_ns if self.start_ns is not None else now,
            end_ns=self.end_ns if self.end_ns is not None else now,
            n_frames=self.n_frames,
            status="incomplete" if self._incomplete_reason else "complete",
            reason=self._incomplete_reason,
            dropped_frames=self.dropped_frames,
            capture=self.number,
        )
        self._writer.write_entry(window, now)
