"""Session format v1: round trips through real MCAP files, CRCs, Foxglove decoding, refusals."""

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
from mcap.writer import Writer as McapWriter
from mcap_protobuf.schema import build_file_descriptor_set
from typer.testing import CliRunner

from twopose.camera import Camera, Intrinsics, rotation_from_angles_deg
from twopose.errors import (
    InputValueError,
    SessionExistsError,
    SessionFormatError,
    SessionVersionError,
)
from twopose.format.entries import (
    CaptureWindow,
    GroundPlane,
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
    TruePose,
)
from twopose.format.messages import Frame
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods import Method
from twopose.units import Units

CAM0 = Camera(
    camera_id="cam0",
    intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
)
CAM1 = Camera(
    camera_id="right",
    intrinsics=Intrinsics(
        width=320,
        height=240,
        fx=300.0,
        fy=301.0,
        cx=161.0,
        cy=119.5,
        distortion=(-0.1, 0.01, 0.0, 0.0, 0.0),
    ),
)


def _image(seed: int, shape: tuple[int, int] = (480, 640)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    # Smooth content so JPEG round trips stay close.
    small = rng.integers(0, 255, size=(shape[0] // 16, shape[1] // 16, 3), dtype=np.uint8)
    import cv2

    return np.asarray(cv2.resize(small, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR))


def _write_full_session(path: Path, image_format: str) -> dict[str, object]:
    """A two-camera session with every typed entry; returns what went in."""
    info = SessionInfo(
        method=Method.GROUND,
        units=Units.IN,
        camera_ids=("cam0", "right"),
        operator="Ada",
        notes="round trip",
        created_utc="2026-11-22T00:00:00+00:00",
    )
    ground = GroundPlane(offset=9.625)
    poses = [
        PoseEntry(
            trial=1,
            pose=1,
            camera_id="cam0",
            t_grid=(0.0, 0.0, 0.0),
            r_deg=(0.0, 0.0, 0.0),
            translation_resolution=0.0625,
            rotation_resolution_deg=0.5,
        ),
        PoseEntry(
            trial=1,
            pose=2,
            camera_id="right",
            t_grid=(1.1, 0.0, -0.5),
            r_deg=(0.0, 5.0, -2.0),
            translation_resolution=0.125,
            rotation_resolution_deg=1.0,
        ),
    ]
    gt = GroundTruth(trial=1, kind="point", points_grid=((1.91, 9.625, 8.375),))
    note = Note(text="glove slipped a little", trial=1)
    truth = SimulationTruth(
        trial=1,
        poses=(
            TruePose(pose=1, camera_id="cam0", t_grid=(0.01, 0.0, -0.02), r_deg=(0.0, 0.0, 0.0)),
            TruePose(pose=2, camera_id="right", t_grid=(1.12, 0.0, -0.45), r_deg=(0.0, 5.0, -2.0)),
        ),
        kind="point",
        points_grid=((1.91, 9.625, 8.375),),
    )
    images = {"cam0": [_image(1), _image(2)], "right": [_image(3, (240, 320))]}
    t = 1_000_000_000
    with SessionWriter(
        path, info, [CAM0, CAM1], ground=ground, image_format=image_format, start_ns=t
    ) as w:
        w.write_ground_truth(gt, t + 1)
        for k, pose in enumerate(poses):
            w.write_pose(pose, t + 10 + 100 * k)
            with w.capture(1, pose.pose, pose.camera_id) as cap:
                for j, img in enumerate(images[pose.camera_id]):
                    cap.add_frame(img, t + 20 + 100 * k + j)
        w.write_note(note, t + 500)
        w.write_simulation_truth(truth, t + 600)
    return {
        "info": info,
        "ground": ground,
        "poses": poses,
        "gt": gt,
        "note": note,
        "truth": truth,
        "images": images,
    }


@pytest.mark.parametrize("image_format", ["jpeg", "png"])
def test_every_entry_round_trips(tmp_path: Path, image_format: str) -> None:
    path = tmp_path / "s.mcap"
    sent = _write_full_session(path, image_format)
    with SessionReader(path) as r:
        assert r.info == sent["info"]
        assert r.ground == sent["ground"]
        assert r.cameras == {"cam0": CAM0, "right": CAM1}
        assert r.format_version == "1.2"
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
    _write_full_session(path, "jpeg")
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        by_topic: dict[str, list[bytes]] = {}
        for _, channel, message in reader.iter_messages():
            by_topic.setdefault(channel.topic, []).append(message.data)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert metadata["twopose"]["format_version"] == "1.2"
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


def test_a_corrupt_chunk_is_reported_not_raised_raw(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    _write_full_session(path, "png")
    data = bytearray(path.read_bytes())
    # Flip bytes in the middle of the file: inside a chunk's image payload.
    mid = len(data) // 2
    data[mid : mid + 16] = bytes(b ^ 0xFF for b in data[mid : mid + 16])
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(SessionFormatError, match="recover"), SessionReader(bad) as r:
        list(r.iter_entries())


def test_truncated_file_is_refused_with_a_recover_hint(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    _write_full_session(path, "jpeg")
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(SessionFormatError, match="recover"), SessionReader(cut):
        pass


def test_not_an_mcap_file(tmp_path: Path) -> None:
    p = tmp_path / "x.mcap"
    p.write_text("hello")
    with pytest.raises(SessionFormatError, match="not a readable MCAP"), SessionReader(p):
        pass


def test_missing_file(tmp_path: Path) -> None:
    with (
        pytest.raises(SessionFormatError, match="cannot open"),
        SessionReader(tmp_path / "nope.mcap"),
    ):
        pass


def test_writer_refuses_to_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    path.write_bytes(b"precious data")
    with (
        pytest.raises(SessionExistsError, match="never overwrites"),
        SessionWriter(path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM0]),
    ):
        pass
    assert path.read_bytes() == b"precious data"


def _raw_session(path: Path, format_version: str) -> None:
    """A session-like MCAP file written with the mcap library alone."""
    with open(path, "wb") as f:
        w = McapWriter(f)
        w.start()
        w.add_metadata("twopose", {"format_version": format_version, "software_version": "9.0"})
        sid = w.register_schema(
            "twopose.Session", "jsonschema", json.dumps(SessionInfo.JSON_SCHEMA).encode()
        )
        cid = w.register_channel("/twopose/session", "json", sid)
        w.add_message(
            cid,
            0,
            json.dumps(
                {
                    **SessionInfo(method=Method.POINT, units=Units.IN).to_json(),
                    "format_version": format_version,
                }
            ).encode(),
            0,
        )
        pid = w.register_schema(
            "foxglove.CameraCalibration",
            "protobuf",
            build_file_descriptor_set(CameraCalibration).SerializeToString(),
        )
        cal = CameraCalibration(
            frame_id="camera_cam0", width=640, height=480, K=[525, 0, 320, 0, 525, 240, 0, 0, 1]
        )
        w.add_message(
            w.register_channel("/twopose/camera/cam0/calibration", "protobuf", pid),
            0,
            cal.SerializeToString(),
            0,
        )
        # A channel this version does not know about: skipped, not fatal.
        xid = w.register_channel(
            "/someone/else", "json", w.register_schema("x.Y", "jsonschema", b"{}")
        )
        w.add_message(xid, 1, b"{}", 1)
        w.finish()


def test_newer_minor_version_is_read_and_unknown_channels_skipped(tmp_path: Path) -> None:
    path = tmp_path / "newer.mcap"
    _raw_session(path, "1.7")
    with SessionReader(path) as r:
        assert r.format_version == "1.7"
        entries = list(r.iter_entries())
    assert [type(e).__name__ for e in entries] == ["SessionInfo", "Camera"]


@pytest.mark.parametrize("version", ["1.0", "1.1"])
def test_older_minor_versions_read_as_before_without_sigma(tmp_path: Path, version: str) -> None:
    path = tmp_path / "older.mcap"
    _raw_session(path, version)
    with SessionReader(path) as r:
        assert r.format_version == version
        assert r.info.intrinsics_sigma is None
        assert r.cameras["cam0"].intrinsics_sigma == {}


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
        assert r.format_version == "1.2"
        assert r.info.intrinsics_sigma == {"cam0": sigma}
        assert r.cameras["cam0"].intrinsics_sigma == sigma
        assert r.cameras["right"].intrinsics_sigma == {}
    with pytest.raises(InputValueError, match="unknown intrinsic 'f'"):
        Camera(camera_id="cam0", intrinsics=CAM0.intrinsics, intrinsics_sigma={"f": 1.0})
    with pytest.raises(InputValueError, match="must be >= 0"):
        Camera(camera_id="cam0", intrinsics=CAM0.intrinsics, intrinsics_sigma={"fx": -1.0})


def test_newer_major_version_is_refused_clearly(tmp_path: Path) -> None:
    path = tmp_path / "future.mcap"
    _raw_session(path, "2.0")
    with (
        pytest.raises(SessionVersionError, match=r"format 2\.0.*reads format 1\.x only"),
        SessionReader(path),
    ):
        pass


def test_mcap_without_twopose_metadata_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "other.mcap"
    with open(path, "wb") as f:
        w = McapWriter(f)
        w.start()
        w.finish()
    with pytest.raises(SessionFormatError, match="not a twopose session"), SessionReader(path):
        pass


def _capture_then_fail(w: SessionWriter) -> None:
    with w.capture(1, 1, "cam0") as cap:
        cap.add_frame(_image(1), 2)
        raise RuntimeError("camera stopped delivering frames")


def test_capture_interrupted_by_an_error_is_kept_and_marked_incomplete(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    with SessionWriter(
        path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM0], start_ns=0
    ) as w:
        w.write_pose(PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0)), 1)
        with pytest.raises(RuntimeError):
            _capture_then_fail(w)
    with SessionReader(path) as r:
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert len(windows) == 1
    assert windows[0].status == "incomplete"
    assert "camera stopped delivering frames" in windows[0].reason
    assert windows[0].n_frames == 1


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, math.nan, 0.0)),
            "finite",
        ),
        (lambda: PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, 1.0)), "3 numbers"),  # type: ignore[arg-type]
        (lambda: PoseEntry(trial=-1, pose=1, camera_id="cam0", t_grid=(0.0, 0.0, 0.0)), "trial"),
        (
            lambda: PoseEntry(trial=1, pose=1, camera_id="cam 0", t_grid=(0.0, 0.0, 0.0)),
            "camera id",
        ),
        (
            lambda: PoseEntry(
                trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0), translation_resolution=0.0
            ),
            "positive",
        ),
        (lambda: SessionInfo(method="triangle", units=Units.IN), "method"),  # type: ignore[arg-type]
        (lambda: SessionInfo(method=Method.POINT, units="furlong"), "units"),  # type: ignore[arg-type]
        (lambda: GroundTruth(trial=1, kind="line", points_grid=((0, 0, 0),)), "needs 2"),
        (
            lambda: GroundTruth(trial=1, kind="line", points_grid=((1, 2, 3), (1, 2, 3))),
            "must differ",
        ),
        (lambda: GroundPlane(offset=math.inf), "finite"),
        (lambda: GroundPlane(offset=1.0, normal_grid=(0, 0, 0)), "zero"),
        (
            lambda: CaptureWindow(
                trial=1, pose=1, camera_id="cam0", start_ns=10, end_ns=5, n_frames=0
            ),
            "before it starts",
        ),
    ],
)
def test_invalid_typed_values_never_reach_a_file(make: object, message: str) -> None:
    with pytest.raises(InputValueError, match=message):
        make()  # type: ignore[operator]


def test_writer_rejects_unknown_camera(tmp_path: Path) -> None:
    with (
        SessionWriter(
            tmp_path / "s.mcap", SessionInfo(method=Method.POINT, units=Units.IN), [CAM0]
        ) as w,
        pytest.raises(InputValueError, match="not in this session"),
    ):
        w.write_pose(PoseEntry(trial=1, pose=1, camera_id="right", t_grid=(0, 0, 0)))


def test_ground_plane_is_normalised() -> None:
    g = GroundPlane(offset=19.25, normal_grid=(0.0, 2.0, 0.0))
    assert g.normal_grid == (0.0, 1.0, 0.0)
    assert g.offset == pytest.approx(9.625)


def test_session_written_from_the_spec_with_plain_mcap_is_readable(tmp_path: Path) -> None:
    """docs/session-format.md is enough to write a session without our writer."""
    path = tmp_path / "foreign.mcap"
    with open(path, "wb") as f:
        w = McapWriter(f)
        w.start(profile="", library="someone-else")
        w.add_metadata("twopose", {"format_version": "1.3", "software_version": "other"})
        loose = {"type": "object"}  # any valid JSON Schema; readers validate with their own
        ids = {
            name: w.register_schema(f"twopose.{name}", "jsonschema", json.dumps(loose).encode())
            for name in ("Session", "PoseEntry", "CaptureWindow", "GroundPlane", "GroundTruth")
        }
        pb = {
            cls.DESCRIPTOR.full_name: w.register_schema(
                cls.DESCRIPTOR.full_name,
                "protobuf",
                build_file_descriptor_set(cls).SerializeToString(),
            )
            for cls in (CameraCalibration, CompressedImage, FrameTransform)
        }
        ch = {
            "session": w.register_channel("/twopose/session", "json", ids["Session"]),
            "pose": w.register_channel("/twopose/pose", "json", ids["PoseEntry"]),
            "capture": w.register_channel("/twopose/capture", "json", ids["CaptureWindow"]),
            "ground": w.register_channel("/twopose/ground", "json", ids["GroundPlane"]),
            "gt": w.register_channel("/twopose/ground_truth", "json", ids["GroundTruth"]),
            "cal": w.register_channel(
                "/twopose/camera/A/calibration", "protobuf", pb["foxglove.CameraCalibration"]
            ),
            "img": w.register_channel(
                "/twopose/camera/A/image", "protobuf", pb["foxglove.CompressedImage"]
            ),
        }

        def put(key: str, t: int, payload: dict[str, object] | bytes) -> None:
            data = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
            w.add_message(ch[key], t, data, t)

        put(
            "session",
            0,
            {
                "format_version": "1.3",
                "method": "point",
                "units": "mm",
                "camera_ids": ["A"],
                "extra": 1,
            },
        )
        cal = CameraCalibration(
            frame_id="camera_A",
            width=64,
            height=48,
            distortion_model="plumb_bob",
            D=[0, 0, 0, 0, 0],
            K=[50, 0, 32, 0, 50, 24, 0, 0, 1],
        )
        put("cal", 0, cal.SerializeToString())
        put("ground", 0, {"normal": [0, 1, 0], "offset": 250.0})
        put("gt", 1, {"trial": 3, "kind": "point", "points": [[1, 2, 3]]})
        put(
            "pose",
            2,
            {
                "trial": 3,
                "pose": 0,
                "camera": "A",
                "translation": [0, 0, 0],
                "rotation_deg": [0, 0, 0],
                "resolution": {"translation": 1, "rotation_deg": 1},
            },
        )
        import cv2

        _ok, buf = cv2.imencode(".png", np.zeros((48, 64, 3), np.uint8))
        put(
            "img",
            3,
            CompressedImage(frame_id="camera_A", format="png", data=bytes(buf)).SerializeToString(),
        )
        put(
            "capture",
            4,
            {
                "trial": 3,
                "pose": 0,
                "camera": "A",
                "start_ns": 3,
                "end_ns": 3,
                "n_frames": 1,
                "status": "complete",
            },
        )
        w.finish()
    with SessionReader(path) as r:
        assert r.info.units == "mm"
        assert r.ground == GroundPlane(offset=250.0)
        assert r.cameras["A"].intrinsics.fx == 50
        (trial,) = list(iter_trials(r))
    assert trial.trial == 3
    assert trial.ground_truth is not None
    assert len(trial.poses[0].frames) == 1
    assert trial.poses[0].frames[0].decode().shape == (48, 64, 3)


def test_invalid_json_entry_in_a_foreign_file_is_a_format_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.mcap"
    with open(path, "wb") as f:
        w = McapWriter(f)
        w.start()
        w.add_metadata("twopose", {"format_version": "1.0"})
        sid = w.register_schema("twopose.Session", "jsonschema", b"{}")
        cid = w.register_channel("/twopose/session", "json", sid)
        w.add_message(
            cid,
            0,
            json.dumps({"format_version": "1.0", "method": "point", "units": "in"}).encode(),
            0,
        )
        w.finish()
    with pytest.raises(SessionFormatError, match="camera_ids"), SessionReader(path):
        pass


def test_a_chunk_over_the_size_limit_is_refused_before_it_is_decompressed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """8 MB of one note compresses to a few kB: with a 1 MB limit, info refuses the file
    naming the limit, and recover skips that chunk and keeps the rest."""
    from analysis.cli import app as analyze
    from recorder.recover import recover_session
    from twopose.format.entries import Note

    path = tmp_path / "bomb.mcap"
    with SessionWriter(
        path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM0], start_ns=0
    ) as w:
        w.write_note(Note(text="x" * 8_000_000), 1)
    assert path.stat().st_size < 100_000
    monkeypatch.setenv("TWOPOSE_MAX_CHUNK_MB", "1")
    with pytest.raises(SessionFormatError, match=r"over the limit of 1 MB.*decompression bomb"):
        SessionReader(path).__enter__()
    result = CliRunner().invoke(analyze, ["info", str(path)])
    assert result.exit_code == 1
    assert "TWOPOSE_MAX_CHUNK_MB" in result.output
    report = recover_session(path, tmp_path / "fixed.mcap")
    assert report.chunks_lost == 1
    with SessionReader(tmp_path / "fixed.mcap") as r:
        assert r.info.method == "point"
