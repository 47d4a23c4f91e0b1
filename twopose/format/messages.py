"""A session's MCAP side: its topics, the Foxglove messages on them, the channels they are on.

A session opens in Foxglove as it is because its images, calibrations and poses are
Foxglove's own message types; this module converts between them and the core types.

And the one way to register schemas and channels on an MCAP writer and write to them: every
MCAP file twopose writes (sessions, recovered sessions, results.mcap) goes through
:class:`Channels`: a schema is registered once, channels are looked up by topic, and
message counts per topic are kept. :func:`register_session_channels` fixes the order of a
session's records on the topics above, which makes channel ids a function of the camera
ids alone (``recover`` relies on it when the chunk that held the channel records is lost).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from mcap.writer import Writer as McapWriter
from mcap_protobuf.schema import build_file_descriptor_set
from numpy.typing import NDArray

from twopose.camera.jpeg_tables import with_huffman_tables
from twopose.camera.model import Camera, Intrinsics, quaternion_xyzw_from_matrix
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.entries import (
    ENTRIES_1_0,
    FORMAT_VERSION,
    PAIR_SESSION_ENTRIES,
    CaptureDecision,
    PoseEntry,
    TypedEntry,
)

__all__ = [
    "GRID_FRAME",
    "SESSION_PROTOBUF",
    "TF_TOPIC",
    "Channels",
    "Frame",
    "calibration_message",
    "calibration_topic",
    "camera_frame_id",
    "camera_from_message",
    "image_message",
    "image_topic",
    "register_session_channels",
    "transform_message",
]

GRID_FRAME = "grid"
TF_TOPIC = "/tf"
#: Every topic of an analysis results file (``results_<n>_<session>.mcap``) starts so.
RESULTS_TOPIC_PREFIX = "/twopose/results/"
#: The Foxglove message types of a session, in the order their schemas are registered.
SESSION_PROTOBUF = (CameraCalibration, CompressedImage, FrameTransform)


def camera_frame_id(camera_id: str) -> str:
    """The transform frame of a camera: ``camera_<id>``."""
    return f"camera_{camera_id}"


def image_topic(camera_id: str) -> str:
    """The MCAP topic of a camera's images."""
    return f"/twopose/camera/{camera_id}/image"


def calibration_topic(camera_id: str) -> str:
    """The MCAP topic of a camera's calibration."""
    return f"/twopose/camera/{camera_id}/calibration"


@dataclass(frozen=True, kw_only=True)
class Frame:
    """One encoded image as stored (decode with :meth:`decode`).

    ``log_time_ns`` when it was written; ``capture_ns`` when it was taken, on its camera's
    capture clock (format 1.6: the image's ``timestamp``; None in an older file, whose
    timestamp is the write time).
    """

    camera_id: str
    log_time_ns: int
    sequence: int
    format: str
    data: bytes = field(repr=False)
    capture_ns: int | None = None

    def decode(self, expected_size: tuple[int, int] | None = None) -> NDArray[np.uint8]:
        """The image as an (H, W, 3) BGR uint8 array, its header checked first.

        OpenCV's channel order. The header is checked against ``expected_size`` (the camera's
        calibrated width, height) and the pixel limit (:mod:`twopose.camera.images`) before
        decoding, so a
        bad frame costs no memory.
        """
        from twopose.camera.images import decode_image

        what = f"frame {self.sequence} of camera {self.camera_id} at {self.log_time_ns} ns"
        try:
            return decode_image(self.data, what, expected_size)
        except InputValueError as err:
            raise SessionFormatError(str(err)) from err


def image_message(
    camera_id: str,
    data: bytes,
    image_format: str,
    log_time_ns: int,
    capture_ns: int | None = None,
) -> Any:
    """A ``foxglove.CompressedImage`` of an encoded frame.

    Its ``timestamp`` is the frame's capture time (format 1.6), the log time when none is
    given (a frame grabbed and written at once). A JPEG is stored with its Huffman tables:
    a webcam's MJPG frame without them gets the standard ones inserted, losslessly
    (:func:`twopose.camera.jpeg_tables.with_huffman_tables`), so that every reader of the
    session's images (Foxglove, any decoder) reads a standard JPEG.
    """
    if image_format == "jpeg":
        data = with_huffman_tables(data)
    msg = CompressedImage(frame_id=camera_frame_id(camera_id), data=data, format=image_format)
    msg.timestamp.FromNanoseconds(log_time_ns if capture_ns is None else capture_ns)
    return msg


def calibration_message(camera: Camera, log_time_ns: int) -> Any:
    """The ``foxglove.CameraCalibration`` of a camera (plumb_bob, identity R)."""
    i = camera.intrinsics
    msg = CameraCalibration(
        frame_id=camera_frame_id(camera.camera_id),
        width=i.width,
        height=i.height,
        distortion_model="plumb_bob",
        D=list(i.distortion),
        K=[i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0],
        R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        P=[i.fx, 0.0, i.cx, 0.0, 0.0, i.fy, i.cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    )
    msg.timestamp.FromNanoseconds(log_time_ns)
    return msg


def camera_from_message(msg: Any) -> Camera:
    """The camera of a ``foxglove.CameraCalibration`` (fx, fy, cx, cy from K; D padded)."""
    frame_id: str = msg.frame_id
    if not frame_id.startswith("camera_"):
        raise SessionFormatError(f"camera calibration frame_id {frame_id!r} is not camera_<id>")
    K = list(msg.K)
    if len(K) != 9:
        raise SessionFormatError(f"camera calibration of {frame_id} has {len(K)} K values, not 9")
    D = [*list(msg.D), 0.0, 0.0, 0.0, 0.0, 0.0][:5]
    try:
        return Camera(
            camera_id=frame_id.removeprefix("camera_"),
            intrinsics=Intrinsics(
                width=int(msg.width),
                height=int(msg.height),
                fx=K[0],
                fy=K[4],
                cx=K[2],
                cy=K[5],
                distortion=(D[0], D[1], D[2], D[3], D[4]),
            ),
        )
    except InputValueError as err:
        raise SessionFormatError(f"camera calibration of {frame_id}: {err}") from err


def transform_message(entry: PoseEntry, log_time_ns: int) -> Any:
    """The ``foxglove.FrameTransform`` grid -> camera of a typed pose."""
    qx, qy, qz, qw = quaternion_xyzw_from_matrix(entry.R_cam_to_grid)
    msg = FrameTransform(
        parent_frame_id=GRID_FRAME, child_frame_id=camera_frame_id(entry.camera_id)
    )
    msg.timestamp.FromNanoseconds(log_time_ns)
    msg.translation.x, msg.translation.y, msg.translation.z = entry.t_grid
    msg.rotation.x, msg.rotation.y, msg.rotation.z, msg.rotation.w = qx, qy, qz, qw
    return msg


class Channels:
    """The schemas and channels of one MCAP writer, by topic."""

    def __init__(self, writer: McapWriter) -> None:
        self.writer = writer
        self.ids: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self._schemas: dict[str, int] = {}

    def protobuf_schemas(self, *classes: Any) -> None:
        """Register these Foxglove message types' schemas now, in this order."""
        for pb in classes:
            name = pb.DESCRIPTOR.full_name
            if name not in self._schemas:
                self._schemas[name] = self.writer.register_schema(
                    name=name,
                    encoding="protobuf",
                    data=build_file_descriptor_set(pb).SerializeToString(),
                )

    def protobuf(self, topic: str, message_class: Any) -> int:
        """A protobuf channel on ``topic`` (its schema registered on first use)."""
        self.protobuf_schemas(message_class)
        schema_id = self._schemas[message_class.DESCRIPTOR.full_name]
        self.ids[topic] = self.writer.register_channel(topic, "protobuf", schema_id)
        return self.ids[topic]

    def json_entry(self, cls: type[TypedEntry]) -> int:
        """The JSON channel of a typed entry, with its JSON Schema."""
        if cls.SCHEMA_NAME not in self._schemas:
            self._schemas[cls.SCHEMA_NAME] = self.writer.register_schema(
                name=cls.SCHEMA_NAME,
                encoding="jsonschema",
                data=json.dumps(cls.JSON_SCHEMA).encode(),
            )
        self.ids[cls.TOPIC] = self.writer.register_channel(
            cls.TOPIC, "json", self._schemas[cls.SCHEMA_NAME]
        )
        return self.ids[cls.TOPIC]

    def write(self, topic: str, data: bytes, log_time_ns: int, sequence: int) -> None:
        """One message (publish time = log time)."""
        self.writer.add_message(
            channel_id=self.ids[topic],
            log_time=log_time_ns,
            publish_time=log_time_ns,
            data=data,
            sequence=sequence,
        )
        self.counts[topic] = self.counts.get(topic, 0) + 1


def register_session_channels(
    writer: McapWriter,
    camera_ids: Sequence[str],
    format_version: str = FORMAT_VERSION,
    *,
    pair: bool = False,
) -> Channels:
    """Every schema and channel of a session, in the documented order.

    The order ``docs/session-format.md`` fixes: the format 1.0 typed entries, the Foxglove schemas,
    ``/tf``, per camera its calibration and image channels, then (format 1.1)
    ``/twopose/decision``, then in a two-camera session (``pair``, format 1.6) its entries'
    (:data:`~twopose.format.entries.PAIR_SESSION_ENTRIES`). Appending each version's channels
    keeps the earlier ids, so ``recover`` rebuilds files of every version, and a one-camera
    session registers the channels it did before.
    """
    channels = Channels(writer)
    for cls in ENTRIES_1_0:
        channels.json_entry(cls)
    channels.protobuf_schemas(*SESSION_PROTOBUF)
    calibration, image, transform = SESSION_PROTOBUF
    channels.protobuf(TF_TOPIC, transform)
    for cid in camera_ids:
        channels.protobuf(calibration_topic(cid), calibration)
        channels.protobuf(image_topic(cid), image)
    if format_version != "1.0":
        channels.json_entry(CaptureDecision)
    if pair:
        for cls in PAIR_SESSION_ENTRIES:
            channels.json_entry(cls)
    return channels
