"""The Foxglove (protobuf) side of a session: topics, frames, calibrations, transforms.

A session opens in Foxglove as it is because its images, calibrations and poses are
Foxglove's own message types; this module converts between them and the core types.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from numpy.typing import NDArray

from twopose.camera.model import Camera, Intrinsics, quaternion_xyzw_from_matrix
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.entries import PoseEntry

__all__ = [
    "GRID_FRAME",
    "SESSION_PROTOBUF",
    "TF_TOPIC",
    "Frame",
    "calibration_message",
    "calibration_topic",
    "camera_frame_id",
    "camera_from_message",
    "image_message",
    "image_topic",
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
    given (a frame grabbed and written at once).
    """
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
