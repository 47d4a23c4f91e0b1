"""Format 1.6: a two-camera session written and read back (capture times, the pair, the
clock offset, stream windows, touches), the writer's refusals, and older files read as before
(a one-camera session written now differs from a 1.5 one only by its version)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from recorder.recover import recover_session
from tests.twopose.format.full_session import CAM0, image
from tests.twopose.format.pair_examples import calibrated_pair, pair_cameras, write_pair_session
from twopose.camera.model import Camera
from twopose.errors import InputValueError, TwoposeError
from twopose.format.entries import PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.format.trials import describe_session, iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.pair.motion import thesis_pair
from twopose.values.units import Units


def test_a_pair_session_reads_back_its_capture_times_pair_offset_and_touches(
    tmp_path: Path,
) -> None:
    path = tmp_path / "pair.mcap"
    pair_mm = calibrated_pair()
    wrote = write_pair_session(path, trials=2, frames=12, pair=pair_mm)
    with SessionReader(path) as reader:
        assert reader.format_version == "1.6"
        session = read_pair_session(reader)
        # the pair in the session's units (inches), every part kept
        pair = session.pair
        expected = pair_mm.in_units(Units.IN)
        assert pair.units == Units.IN
        np.testing.assert_allclose(pair.t_2_in_1, expected.t_2_in_1, rtol=1e-15)
        np.testing.assert_array_equal(pair.R_2_to_1, expected.R_2_to_1)
        np.testing.assert_allclose(pair.cov_extrinsic, expected.cov_extrinsic, rtol=1e-15)
        assert pair.floor is not None
        assert expected.floor is not None
        assert pair.floor.height == pytest.approx(expected.floor.height, rel=1e-15)
        assert pair.check is not None
        assert math.isnan(pair.check.jackknife_ratio[5])
        assert pair.sigma1 == {"fx": 0.9, "k1": 0.01}
        assert (pair.rms_px, pair.n_views, pair.cov_factor) == (0.45, 13, 4.2)
        # the floor is the ground plane (camera 1's frame), the offset as written
        assert session.ground is not None
        assert session.ground.offset == pytest.approx(expected.floor.height)
        assert session.offset == wrote["offset"]
        assert session.clocks == {"cam1": "driver", "cam2": "monotonic at grab"}
        assert [t.trial for t in session.trials] == [1, 2]
        for trial in session.trials:
            assert trial.complete
            for stream in trial.cameras:
                want = wrote["captures"][(trial.trial, stream.camera_id)]  # type: ignore[index]
                np.testing.assert_array_equal(stream.capture_ns, want)
                assert (np.diff(stream.log_ns) > 0).all()
                assert len(stream.windows) == 4  # 12 frames at 30 fps in windows of 0.1 s
            assert [(t.touch, t.how, t.point) for t in trial.touches] == [
                (1, "schedule", (1.0, 9.625, 24.0))
            ]
            # images lazily, in order; one by its index equals the same from the iterator
            images = list(trial.camera2.images())
            assert len(images) == 12
            assert images[0].shape == (480, 640, 3)
            np.testing.assert_array_equal(trial.camera2.image(7), images[7])
        frames = list(session.trials[0].camera1.frames())
        assert [f.capture_ns for f in frames] == wrote["captures"][(1, "cam1")]  # type: ignore[index]
        assert session.unassigned == 0
    # a pair session has no typed-pose trials; the overview counts its streams
    with SessionReader(path) as reader:
        assert list(iter_trials(reader)) == []
    overview = describe_session(path)
    assert (overview.n_trials, overview.n_poses, overview.n_frames) == (2, 0, 48)
    assert overview.streams is not None
    assert len(overview.streams.touches) == 2


def test_the_images_are_read_only_while_the_reader_is_open(tmp_path: Path) -> None:
    path = tmp_path / "pair.mcap"
    write_pair_session(path, trials=1, frames=3)
    with SessionReader(path) as reader:
        session = read_pair_session(reader)
    with pytest.raises(TwoposeError, match="context manager"):
        next(session.trials[0].camera1.images())


def test_the_writer_refuses_what_a_pair_session_cannot_hold(tmp_path: Path) -> None:
    pair = thesis_pair()
    cameras = pair_cameras(pair)
    info = SessionInfo(method=Method.GROUND, units=Units.IN, camera_ids=("cam1", "cam2"))
    with SessionWriter(tmp_path / "a.mcap", info, cameras, pair=pair) as writer:
        with pytest.raises(TwoposeError, match="trials are streams"):
            writer.write_pose(PoseEntry(trial=1, pose=1, camera_id="cam1", t_grid=(0, 0, 0)))
        with pytest.raises(TwoposeError, match="trials are streams"):
            writer.capture(1, 1, "cam1")
        with writer.stream(1, start_ns=10**9) as stream:
            stream.add_encoded("cam1", b"x", capture_ns=100, log_time_ns=2 * 10**9)
            with pytest.raises(InputValueError, match="not after its previous frame's"):
                stream.add_encoded("cam1", b"x", capture_ns=100, log_time_ns=3 * 10**9)
            with pytest.raises(InputValueError, match="not after its previous frame"):
                stream.add_encoded("cam1", b"x", capture_ns=200, log_time_ns=2 * 10**9)
            with pytest.raises(InputValueError, match="camera 'cam3' is not in this session"):
                stream.add_encoded("cam3", b"x", capture_ns=300, log_time_ns=4 * 10**9)
            with pytest.raises(InputValueError, match="a touch is marked by key, button"):
                stream.touch((0.0, 0.0, 0.0), 5, "voice")  # type: ignore[arg-type]
    moved = dataclasses.replace(pair.intrinsics2, cx=321.0)
    other = [cameras[0], Camera(camera_id="cam2", intrinsics=moved)]
    with pytest.raises(InputValueError, match="intrinsics are not the pair's camera 2's"):
        SessionWriter(tmp_path / "b.mcap", info, other, pair=pair)
    one = SessionInfo(method=Method.GROUND, units=Units.IN)
    with pytest.raises(InputValueError, match="a pair is two cameras"):
        SessionWriter(tmp_path / "c.mcap", one, [CAM0], pair=pair)
    with (
        SessionWriter(tmp_path / "d.mcap", one, [CAM0]) as writer,
        pytest.raises(TwoposeError, match="belongs in a two-camera session"),
    ):
        writer.stream(1)
    with pytest.raises(InputValueError, match="clocks: camera 'cam9'"):
        SessionInfo(method=Method.POINT, units=Units.IN, clocks={"cam9": "driver"})
    with pytest.raises(InputValueError, match="its clock one of driver"):
        SessionInfo(method=Method.POINT, units=Units.IN, clocks={"cam0": "sundial"})


def test_a_stream_an_error_ends_is_kept_and_its_last_window_marked_incomplete(
    tmp_path: Path,
) -> None:
    pair = thesis_pair()
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"))
    path = tmp_path / "s.mcap"

    def three_frames_then_fail(writer: SessionWriter) -> None:
        with writer.stream(1, window_s=1.0, start_ns=1) as stream:
            for k in range(3):
                stream.add_frame("cam1", image(k), capture_ns=10 + k, log_time_ns=2 + k)
            raise RuntimeError("camera 2 stopped delivering frames")

    with (
        SessionWriter(path, info, pair_cameras(pair), pair=pair, start_ns=0) as writer,
        pytest.raises(RuntimeError),
    ):
        three_frames_then_fail(writer)
    with SessionReader(path) as reader:
        (trial,) = read_pair_session(reader).trials
    assert len(trial.camera1) == 3
    assert len(trial.camera2) == 0
    assert "camera 2 stopped delivering frames" in trial.camera1.reason
    assert not trial.complete


def test_a_window_a_lost_chunk_emptied_is_said_never_passed_over(tmp_path: Path) -> None:
    """A chunk of frames lost to corruption: recover keeps the rest, and the replay says the
    window holds fewer frames than it says (never a silent gap in a stream)."""
    path = tmp_path / "pair.mcap"
    write_pair_session(path, trials=1, frames=12)
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    data = bytearray(path.read_bytes())
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    middle = chunks[len(chunks) // 2]
    data[middle.chunk_start_offset + middle.chunk_length - 40] ^= 0xFF  # its frames' bytes
    broken, fixed = tmp_path / "broken.mcap", tmp_path / "fixed.mcap"
    broken.write_bytes(bytes(data))
    report = recover_session(broken, fixed)
    assert report.chunks_lost == 1
    with SessionReader(fixed) as reader:
        (trial,) = read_pair_session(reader).trials
    said = trial.camera1.reason + trial.camera2.reason
    assert "(a part of the file was lost)" in said
    assert not trial.complete


def _one_camera_session(path: Path, version: str) -> None:
    info = SessionInfo(method=Method.POINT, units=Units.IN, format_version=version)
    with SessionWriter(path, info, [CAM0], start_ns=1) as writer:
        for pose in (1, 2):
            entry = PoseEntry(trial=1, pose=pose, camera_id="cam0", t_grid=(pose, 0, 0))
            writer.write_pose(entry, 10 * pose - 1)
            with writer.capture(1, pose, "cam0") as capture:
                for k in range(2):
                    capture.add_frame(image(k), 10 * pose + k)


def test_a_one_camera_session_differs_from_1_5_only_by_its_version(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same recording written by this writer and by a 1.5 one: every message the same
    but the version; the older file's frames carry no capture time, the new one's their
    grab time (here the write time: given none), and both replay the same trials."""
    new, old = tmp_path / "new.mcap", tmp_path / "old.mcap"
    _one_camera_session(new, "1.6")
    monkeypatch.setattr("twopose.format.entries.FORMAT_VERSION", "1.5")  # a 1.5 writer
    _one_camera_session(old, "1.5")

    def messages(path: Path) -> list[tuple[str, int, bytes]]:
        with path.open("rb") as f:
            return [
                (c.topic, m.log_time, m.data.replace(b'"1.6"', b'"1.5"'))
                for _, c, m in make_reader(f).iter_messages()
            ]

    def channels(path: Path) -> list[tuple[int, str, str]]:
        with path.open("rb") as f:
            summary = make_reader(f).get_summary()
        assert summary is not None
        schemas = {k: s.name for k, s in summary.schemas.items()}
        return [(c.id, c.topic, schemas[c.schema_id]) for c in summary.channels.values()]

    assert messages(new) == messages(old)
    assert channels(new) == channels(old)  # no channel of a two-camera session's
    with SessionReader(new) as a, SessionReader(old) as b:
        assert a.records_capture_times
        assert not b.records_capture_times
        new_trials, old_trials = list(iter_trials(a)), list(iter_trials(b))
        frames_new = [f for t in new_trials for p in t.poses for f in p.frames]
        frames_old = [f for t in old_trials for p in t.poses for f in p.frames]
    assert [f.capture_ns for f in frames_new] == [f.log_time_ns for f in frames_new]
    assert {f.capture_ns for f in frames_old} == {None}
    assert [f.data for f in frames_new] == [f.data for f in frames_old]
    assert [t.poses[1].entry for t in new_trials] == [t.poses[1].entry for t in old_trials]


def test_a_one_camera_frame_carries_the_capture_time_it_is_given(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    with SessionWriter(path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM0]) as w:
        w.write_pose(PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0)), 5)
        with w.capture(1, 1, "cam0") as capture:
            capture.add_frame(image(0), 10, capture_ns=7)
    with SessionReader(path) as reader:
        (frame,) = (f for t in iter_trials(reader) for p in t.poses for f in p.frames)
        with pytest.raises(InputValueError, match="one-camera session"):
            read_pair_session(reader)
    assert (frame.log_time_ns, frame.capture_ns) == (10, 7)


def test_a_pair_that_is_no_calibration_is_refused_by_the_reader(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The entry holds numbers; the calibration they make is checked when it is read."""
    from twopose.errors import SessionFormatError
    from twopose.format.pair_convert import pair_calibration, pair_entry

    pair = thesis_pair()
    bad = dataclasses.replace(
        pair_entry(pair, ("cam1", "cam2")),
        R_2_to_1=((2.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    )
    with pytest.raises(InputValueError, match="rotation"):
        pair_calibration(bad)
    monkeypatch.setattr("twopose.format.writer.pair_entry", lambda *_: bad)
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"))
    path = tmp_path / "bad.mcap"
    with SessionWriter(path, info, pair_cameras(pair), pair=pair):
        pass
    with pytest.raises(SessionFormatError, match=r"its pair on /twopose/pair: .*rotation"):
        SessionReader(path).__enter__()


def test_a_pair_session_written_from_the_spec_with_plain_mcap_is_replayed(tmp_path: Path) -> None:
    """docs/session-format.md is enough to write a two-camera session without our writer:
    the pair, the clocks, capture times in the images' timestamps, stream windows announced
    open and closed, a touch."""
    import json

    import cv2
    from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from mcap.writer import Writer as McapWriter
    from mcap_protobuf.schema import build_file_descriptor_set

    path = tmp_path / "foreign.mcap"
    size, k = (64, 48), [50.0, 0, 32.0, 0, 50.0, 24.0, 0, 0, 1]
    intrinsics = {"width": 64, "height": 48, "fx": 50.0, "fy": 50.0, "cx": 32.0, "cy": 24.0,
                  "distortion": [0, 0, 0, 0, 0]}  # fmt: skip
    with path.open("wb") as f:
        w = McapWriter(f)
        w.start(profile="", library="someone-else")
        w.add_metadata("twopose", {"format_version": "1.6", "software_version": "other"})
        loose = json.dumps({"type": "object"}).encode()
        names = ("Session", "PairCalibration", "StreamWindow", "Touch", "ClockOffset")
        ids = {n: w.register_schema(f"twopose.{n}", "jsonschema", loose) for n in names}
        pb = {
            c.DESCRIPTOR.full_name: w.register_schema(
                c.DESCRIPTOR.full_name, "protobuf", build_file_descriptor_set(c).SerializeToString()
            )
            for c in (CameraCalibration, CompressedImage)
        }
        topics = {"Session": "session", "PairCalibration": "pair", "StreamWindow": "stream",
                  "Touch": "touch", "ClockOffset": "clock_offset"}  # fmt: skip
        ch = {n: w.register_channel(f"/twopose/{t}", "json", ids[n]) for n, t in topics.items()}
        for cam in ("L", "R"):
            ch[f"cal{cam}"] = w.register_channel(
                f"/twopose/camera/{cam}/calibration", "protobuf", pb["foxglove.CameraCalibration"]
            )
            ch[f"img{cam}"] = w.register_channel(
                f"/twopose/camera/{cam}/image", "protobuf", pb["foxglove.CompressedImage"]
            )

        def put(key: str, t: int, payload: dict[str, object] | bytes) -> None:
            data = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
            w.add_message(ch[key], t, data, t)

        put("Session", 0, {"format_version": "1.6", "method": "point", "units": "in",
                           "camera_ids": ["L", "R"],
                           "clocks": {"L": "driver", "R": "monotonic at grab"}})  # fmt: skip
        for cam in ("L", "R"):
            cal = CameraCalibration(frame_id=f"camera_{cam}", width=64, height=48,
                                    distortion_model="plumb_bob", D=[0] * 5, K=k)  # fmt: skip
            put(f"cal{cam}", 0, cal.SerializeToString())
        eye = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
        zeros = [[0.0] * 6 for _ in range(6)]
        put("PairCalibration", 0, {"camera1": "L", "camera2": "R", "units": "in",
                                   "R_2_to_1": eye, "t_2_in_1": [6, 0, 0],
                                   "cov_extrinsic": zeros, "cov_factor": 1.0, "rms_px": 0.3,
                                   "views": 10, "intrinsics1": intrinsics,
                                   "intrinsics2": intrinsics})  # fmt: skip
        put("ClockOffset", 1, {"offset_ns": 5e6, "sigma_ns": 1e5, "method": "flash", "n": 30})
        for cam in ("L", "R"):
            put("StreamWindow", 10, {"trial": 1, "camera": cam, "window": 1, "start_ns": 10,
                                     "end_ns": 10, "n_frames": 0, "status": "open"})  # fmt: skip
        _ok, buf = cv2.imencode(".png", np.zeros((size[1], size[0], 3), np.uint8))
        for n in range(3):
            for cam, capture in (("L", 1000 + 33 * n), ("R", 1005 + 33 * n)):
                image = CompressedImage(frame_id=f"camera_{cam}", format="png", data=bytes(buf))
                image.timestamp.FromNanoseconds(capture)
                put(f"img{cam}", 20 + 10 * n, image.SerializeToString())
        put("Touch", 35, {"trial": 1, "touch": 1, "time_ns": 1040, "point": [1, 2, 14],
                          "how": "key"})  # fmt: skip
        for cam in ("L", "R"):
            closed = {"trial": 1, "camera": cam, "window": 1, "start_ns": 20, "end_ns": 40,
                      "n_frames": 3, "status": "complete"}  # fmt: skip
            put("StreamWindow", 60, closed)
        w.finish()
    with SessionReader(path) as reader:
        session = read_pair_session(reader)
        (trial,) = session.trials
        assert trial.complete, trial.camera1.reason + trial.camera2.reason
        np.testing.assert_array_equal(trial.camera1.capture_ns, [1000, 1033, 1066])
        np.testing.assert_array_equal(trial.camera2.capture_ns, [1005, 1038, 1071])
        np.testing.assert_array_equal(trial.camera2.log_ns, [20, 30, 40])
        assert trial.camera1.image(2).shape == (48, 64, 3)
    np.testing.assert_array_equal(session.pair.t_2_in_1, [6, 0, 0])
    assert session.offset is not None
    assert session.offset.offset_ns == 5e6
    assert session.clocks == {"L": "driver", "R": "monotonic at grab"}
    assert [(t.touch, t.time_ns, t.how) for t in trial.touches] == [(1, 1040, "key")]
