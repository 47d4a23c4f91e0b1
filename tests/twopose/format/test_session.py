"""A session through the writer and back through the reader: every entry round trips, the
file is valid MCAP that Foxglove's schemas decode, and a calibration's sigma travels with it."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from mcap.reader import make_reader

from tests.twopose.format.full_session import CAM0, CAM1, write_full_session
from twopose.camera.model import Camera, rotation_from_angles_deg
from twopose.errors import (
    InputValueError,
)
from twopose.format.entries import (
    FORMAT_VERSION,
    CaptureWindow,
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
)
from twopose.format.messages import Frame
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units


@pytest.mark.parametrize("image_format", ["jpeg", "png"])
def test_every_entry_round_trips(tmp_path: Path, image_format: str) -> None:
    path = tmp_path / "s.mcap"
    sent = write_full_session(path, image_format)
    with SessionReader(path) as r:
        assert r.info == sent["info"]
        assert r.ground == sent["ground"]
        assert r.cameras == {"cam0": CAM0, "right": CAM1}
        assert r.format_version == FORMAT_VERSION
        items = list(r.iter_entries())
        typed = [i for i in items if not isinstance(i, Frame | FrameTransform | Camera)]
        assert [p for p in typed if isinstance(p, PoseEntry)] == sent["poses"]
        assert [g for g in typed if isinstance(g, GroundTruth)] == [sent["gt"]]
        assert [n for n in typed if isinstance(n, Note)] == [sent["note"]]
        assert [s for s in typed if isinstance(s, SimulationTruth)] == [sent["truth"]]
        windows = [c for c in typed if isinstance(c, CaptureWindow)]
        assert [(c.pose, c.camera_id, c.n_frames, c.status) for c in windows] == [
            (1, "cam0", 2, "complete"),
            (2, "right", 1, "complete"),
        ]
        frames = [f for f in items if isinstance(f, Frame)]
        assert [f.camera_id for f in frames] == ["cam0", "cam0", "right"]
        assert all(f.format == image_format for f in frames)
        images = sent["images"]
        assert isinstance(images, dict)
        decoded = [f.decode() for f in frames]
        expected = [*images["cam0"], *images["right"]]
        for got, want in zip(decoded, expected, strict=True):
            assert got.shape == want.shape
            if image_format == "png":
                np.testing.assert_array_equal(got, want)
            else:
                assert np.abs(got.astype(int) - want).mean() < 3.0
        transforms = [x for x in items if isinstance(x, FrameTransform)]
        assert [x.child_frame_id for x in transforms] == ["camera_cam0", "camera_right"]
        assert transforms[1].translation.x == pytest.approx(1.1)

        trials = list(iter_trials(r))
        assert len(trials) == 1
        assert [len(p.frames) for p in trials[0].poses] == [2, 1]
        assert trials[0].notes == ("glove slipped a little",)


def test_file_passes_mcap_crc_validation_and_foxglove_decoding(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    write_full_session(path, "jpeg")
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        by_topic: dict[str, list[bytes]] = {}
        for _, channel, message in reader.iter_messages():
            by_topic.setdefault(channel.topic, []).append(message.data)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert metadata["twopose"]["format_version"] == FORMAT_VERSION
    # Foxglove's own protobuf classes parse what we wrote.
    cal = CameraCalibration.FromString(by_topic["/twopose/camera/right/calibration"][0])
    assert (cal.width, cal.height, cal.distortion_model) == (320, 240, "plumb_bob")
    assert list(cal.K) == [300.0, 0.0, 161.0, 0.0, 301.0, 119.5, 0.0, 0.0, 1.0]
    assert list(cal.D)[:2] == [-0.1, 0.01]
    img = CompressedImage.FromString(by_topic["/twopose/camera/cam0/image"][0])
    assert img.format == "jpeg"
    assert img.frame_id == "camera_cam0"
    assert img.data[:2] == b"\xff\xd8"
    tf = FrameTransform.FromString(by_topic["/tf"][1])
    assert (tf.parent_frame_id, tf.child_frame_id) == ("grid", "camera_right")
    q = np.array([tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w])
    # The quaternion rotates camera axes into the grid frame like R = Rx Ry Rz.
    R = rotation_from_angles_deg([0.0, 5.0, -2.0])
    angle = 2 * math.degrees(math.acos(min(1.0, abs(q[3]))))
    assert angle == pytest.approx(math.degrees(math.acos((np.trace(R) - 1) / 2)), abs=1e-6)
    # JSON entries are plain JSON.
    pose = json.loads(by_topic["/twopose/pose"][0])
    assert pose["translation"] == [0.0, 0.0, 0.0]


def test_the_calibrations_sigma_travels_with_its_camera(tmp_path: Path) -> None:
    """Format 1.2: a camera's calibration sigma is written into the session entry and
    read back with the camera; a camera without one has none."""
    sigma = {"fx": 0.93, "fy": 0.97, "cx": 0.97, "cy": 1.07, "k1": 0.012}
    cams = [
        Camera(camera_id="cam0", intrinsics=CAM0.intrinsics, intrinsics_sigma=sigma),
        Camera(camera_id="right", intrinsics=CAM1.intrinsics),
    ]
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam0", "right"))
    path = tmp_path / "s.mcap"
    with SessionWriter(path, info, cams):
        pass
    with SessionReader(path) as r:
        assert r.format_version == FORMAT_VERSION
        assert r.info.intrinsics_sigma == {"cam0": sigma}
        assert r.cameras["cam0"].intrinsics_sigma == sigma
        assert r.cameras["right"].intrinsics_sigma == {}
    with pytest.raises(InputValueError, match="unknown intrinsic 'f'"):
        Camera(camera_id="cam0", intrinsics=CAM0.intrinsics, intrinsics_sigma={"f": 1.0})
    with pytest.raises(InputValueError, match="must be >= 0"):
        Camera(camera_id="cam0", intrinsics=CAM0.intrinsics, intrinsics_sigma={"fx": -1.0})
