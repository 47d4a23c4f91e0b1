"""twopose.format.messages directly: Foxglove messages built and read back field by field,
a typed pose's transform as a quaternion, and bad calibrations and frames refused as format
errors."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration

from twopose.camera.model import Camera, Intrinsics
from twopose.errors import SessionFormatError
from twopose.format.entries import PoseEntry
from twopose.format.messages import (
    Frame,
    calibration_message,
    calibration_topic,
    camera_from_message,
    image_message,
    image_topic,
    transform_message,
)

CAMERA = Camera(
    camera_id="left",
    intrinsics=Intrinsics(
        width=320, height=240, fx=300.0, fy=301.0, cx=161.0, cy=119.5,
        distortion=(-0.1, 0.01, 0.001, -0.002, 0.003),
    ),
)  # fmt: skip


def test_a_calibration_reads_back_as_its_camera() -> None:
    msg = calibration_message(CAMERA, 5)
    assert msg.frame_id == "camera_left"
    assert list(msg.K) == [300.0, 0.0, 161.0, 0.0, 301.0, 119.5, 0.0, 0.0, 1.0]
    assert msg.timestamp.ToNanoseconds() == 5
    wire = CameraCalibration.FromString(msg.SerializeToString())
    assert camera_from_message(wire) == CAMERA
    assert image_topic("left") == "/twopose/camera/left/image"
    assert calibration_topic("left") == "/twopose/camera/left/calibration"


def test_a_short_distortion_is_padded_with_zeros() -> None:
    msg = calibration_message(CAMERA, 0)
    del msg.D[2:]
    assert camera_from_message(msg).intrinsics.distortion == (-0.1, 0.01, 0.0, 0.0, 0.0)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda m: setattr(m, "frame_id", "left"), "is not camera_<id>"),
        (lambda m: m.K.pop(), "has 8 K values, not 9"),
        (lambda m: setattr(m, "width", 0), "camera calibration of camera_left: "),
    ],
)
def test_a_bad_calibration_is_a_format_error(change: object, message: str) -> None:
    msg = calibration_message(CAMERA, 0)
    change(msg)  # type: ignore[operator]
    with pytest.raises(SessionFormatError, match=message):
        camera_from_message(msg)


def test_a_typed_pose_becomes_its_transform() -> None:
    entry = PoseEntry(
        trial=1, pose=2, camera_id="left", t_grid=(1.0, 2.0, 3.0), r_deg=(0.0, 90.0, 0.0)
    )
    msg = transform_message(entry, 7)
    assert (msg.parent_frame_id, msg.child_frame_id) == ("grid", "camera_left")
    assert (msg.translation.x, msg.translation.y, msg.translation.z) == (1.0, 2.0, 3.0)
    # 90 degrees about y: (x, y, z, w) = (0, sin 45, 0, cos 45), up to the quaternion's sign
    q = np.array([msg.rotation.x, msg.rotation.y, msg.rotation.z, msg.rotation.w])
    np.testing.assert_allclose(np.abs(q), [0.0, np.sqrt(0.5), 0.0, np.sqrt(0.5)], atol=1e-12)


def test_a_frame_decodes_checks_its_size_and_says_which_frame_is_bad() -> None:
    image = np.full((240, 320, 3), 90, np.uint8)
    ok, jpeg = cv2.imencode(".jpg", image)
    assert ok
    msg = image_message("left", jpeg.tobytes(), "jpeg", 9)
    assert msg.frame_id == "camera_left"
    frame = Frame(camera_id="left", log_time_ns=9, sequence=3, format="jpeg", data=bytes(msg.data))
    assert frame.decode((320, 240)).shape == (240, 320, 3)
    with pytest.raises(SessionFormatError, match="frame 3 of camera left at 9 ns"):
        frame.decode((640, 480))
    broken = Frame(camera_id="left", log_time_ns=9, sequence=4, format="jpeg", data=b"\xff\xd8no")
    with pytest.raises(SessionFormatError, match="frame 4 of camera left"):
        broken.decode()
