"""The session writer: one MCAP file per session, never overwritten, flushed as it goes."""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Self

import cv2
import numpy as np
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from numpy.typing import NDArray

from twopose import __version__
from twopose.camera.model import Camera
from twopose.errors import InputValueError, SessionExistsError, TwoposeError
from twopose.format.entries import (
    METADATA_NAME,
    CaptureDecision,
    GroundTruth,
    Note,
    PairEntry,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    TypedEntry,
    encode_entry,
    session_metadata,
)
from twopose.format.messages import (
    TF_TOPIC,
    Channels,
    calibration_message,
    calibration_topic,
    image_message,
    image_topic,
    register_session_channels,
    transform_message,
)
from twopose.format.pair_convert import clock_offset_entry, pair_entry
from twopose.format.windows import Capture, Stream
from twopose.values.checks import index

if TYPE_CHECKING:
    from twopose.pair.calibration import PairCalibration
    from twopose.pair.clock import ClockOffset

__all__ = [
    "IMAGE_FORMATS",
    "Capture",
    "SessionWriter",
    "Stream",
]

IMAGE_FORMATS = ("jpeg", "png")


def _pair_entry(pair: PairCalibration, info: SessionInfo, cameras: Sequence[Camera]) -> PairEntry:
    """The pair as the session stores it: its two cameras the session's, in its units.

    Refused in words: a session without exactly two cameras, or whose cameras' intrinsics
    are not the pair's.
    """
    if len(cameras) != 2:
        raise InputValueError(
            f"a pair is two cameras; the session has {len(cameras)} ({', '.join(info.camera_ids)})"
        )
    for k, (camera, intrinsics) in enumerate(
        zip(cameras, (pair.intrinsics1, pair.intrinsics2), strict=True), start=1
    ):
        if camera.intrinsics != intrinsics:
            raise InputValueError(
                f"camera {camera.camera_id}'s intrinsics are not the pair's camera {k}'s: "
                "give the session the pair's cameras (their intrinsics from the pair file)"
            )
    return pair_entry(pair.in_units(info.units), (cameras[0].camera_id, cameras[1].camera_id))


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
    pair : PairCalibration, optional
        Two cameras fixed to each other (format 1.6): the session's two cameras are its
        camera 1 and camera 2 (their intrinsics the pair's), its trials streams
        (:meth:`stream`), the grid frame camera 1's; stored in the session's units, and its
        floor is the ground plane unless ``ground`` is given.
    """

    def __init__(  # noqa: PLR0913 - keyword-only settings of the file, each documented
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
        pair: PairCalibration | None = None,
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
        self.pair = None if pair is None else _pair_entry(pair, self.info, cameras)
        floor = None if pair is None else pair.in_units(self.info.units).floor
        if ground is None and floor is not None:
            ground = PlaneEntry(normal_grid=tuple(floor.normal), offset=floor.height)
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
        self._open_capture: Capture | Stream | None = None
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
        self._channels = register_session_channels(
            self._mcap, self.info.camera_ids, pair=self.pair is not None
        )
        t0 = self._start_ns if self._start_ns is not None else self._clock()
        cameras = list(self.cameras.values())
        self._mcap.add_metadata(
            METADATA_NAME, session_metadata(self.info, cameras, self.ground, t0, self.pair)
        )
        self._write_json(self.info, t0)
        for camera in self.cameras.values():
            self._write_proto(
                calibration_topic(camera.camera_id), calibration_message(camera, t0), t0
            )
        if self.ground is not None:
            self._write_json(self.ground, t0)
        if self.pair is not None:
            self._write_json(self.pair, t0)
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
    def _check_pair(self, what: str, *, pair: bool = True) -> None:
        """Refuse ``what`` in a session of the other kind (one camera, or a pair's)."""
        if (self.pair is not None) != pair:
            raise TwoposeError(
                f"{what} belongs in a two-camera session (SessionWriter(..., pair=...))"
                if pair
                else f"a two-camera session's trials are streams (SessionWriter.stream): "
                f"{what} has no place in it"
            )

    def write_pose(self, entry: PoseEntry, log_time_ns: int | None = None) -> None:
        """Write a typed pose and its ``foxglove.FrameTransform``; flushed at once."""
        self._check_pair("a typed pose", pair=False)
        self._check_camera(entry.camera_id)
        t = self.time(log_time_ns)
        self._write_json(entry, t)
        self._write_proto(TF_TOPIC, transform_message(entry, t), t)
        self.flush()

    def write_entry(self, entry: TypedEntry, log_time_ns: int | None = None) -> None:
        """Write a typed entry; flushed at once."""
        self.write_entries([entry], log_time_ns)

    def write_entries(
        self, entries: Iterable[TypedEntry], log_time_ns: int | None = None, *, sync: bool = False
    ) -> None:
        """Write typed entries at one log time, then flush (and ``fsync`` with ``sync``)."""
        t = self.time(log_time_ns)
        for entry in entries:
            self._write_json(entry, t)
        self.sync() if sync else self.flush()

    def write_clock_offset(self, offset: ClockOffset, log_time_ns: int | None = None) -> None:
        """Write the cameras' measured clock offset (a two-camera session; the last applies)."""
        self._check_pair("a clock offset")
        self.write_entry(clock_offset_entry(offset), log_time_ns)

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
        self._check_pair("a capture at a typed pose", pair=False)
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

    def write_image(
        self, camera_id: str, data: bytes, log_time_ns: int, capture_ns: int | None = None
    ) -> int:
        """One encoded frame on the camera's image topic; its sequence number.

        ``capture_ns`` when it was taken, on the camera's capture clock (the image's
        ``timestamp``, format 1.6); None: when it was written (``log_time_ns``).
        """
        if capture_ns is not None:
            index(capture_ns, "capture time (ns)")
        msg = image_message(camera_id, data, self.image_format, log_time_ns, capture_ns)
        return self._write_proto(image_topic(camera_id), msg, log_time_ns)

    def stream(self, trial: int, *, window_s: float = 1.0, start_ns: int | None = None) -> Stream:
        """Open a stream trial of a two-camera session (:class:`Stream`).

        Both cameras' frames with their capture times, and the touches. Its frames are
        written in windows of ``window_s`` seconds of log time, each closed (and synced to
        disk) when the next begins: a crash loses at most the open window. ``start_ns``
        when it starts (default: the clock's).
        """
        self._check_pair("a stream trial")
        index(trial, "trial")
        if self._open_capture is not None:
            raise TwoposeError("a stream is already open; finish it before starting another")
        return Stream(self, trial, window_s=window_s, start_ns=start_ns)

    def _begin_capture(self, capture: Capture | Stream | None) -> None:
        self._open_capture = capture
