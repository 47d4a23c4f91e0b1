"""twopose.format.reader directly: what it refuses and how (corrupt, truncated, foreign,
newer or metadata-less files, oversized chunks), and the older and newer versions it reads."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from mcap.writer import Writer as McapWriter
from mcap_protobuf.schema import build_file_descriptor_set
from typer.testing import CliRunner

from tests.twopose.format.full_session import CAM0, write_full_session
from twopose.errors import (
    SessionFormatError,
    SessionVersionError,
)
from twopose.format.entries import (
    Note,
    PlaneEntry,
    SessionInfo,
)
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units


def test_a_corrupt_chunk_is_reported_not_raised_raw(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    write_full_session(path, "png")
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
    write_full_session(path, "jpeg")
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(SessionFormatError, match="recover"), SessionReader(cut):
        pass


def test_not_an_mcap_file(tmp_path: Path) -> None:
    """Text (a pair or calibration TOML given by mistake) is not called an interrupted
    recording: no recover advice (a new user was told to recover their pair.toml)."""
    p = tmp_path / "x.mcap"
    p.write_text("hello")
    with pytest.raises(SessionFormatError, match="not an MCAP file") as caught, SessionReader(p):
        pass
    assert 'it begins "hello"' in str(caught.value)
    assert "recover" not in str(caught.value)


def test_missing_file(tmp_path: Path) -> None:
    with (
        pytest.raises(SessionFormatError, match="cannot open"),
        SessionReader(tmp_path / "nope.mcap"),
    ):
        pass


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
        assert r.ground == PlaneEntry(offset=250.0)
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
