"""sources: camera, video, images and synthetic frame sources."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from recorder.capture import CaptureSettings, capture_frames
from recorder.sources import ImagesSource, SyntheticSource, VideoSource, open_source
from tests.helpers import write_video
from twopose.camera import Camera, Intrinsics
from twopose.errors import SourceError
from twopose.format.entries import CaptureWindow, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.writer import SessionWriter
from twopose.methods import Method
from twopose.units import Units


def test_video_source_reads_in_order_then_says_it_ended(tmp_path: Path) -> None:
    with VideoSource(write_video(tmp_path / "v.avi", 4)) as src:
        assert (src.info.width, src.info.height) == (64, 48)
        means = [src.read().mean() for _ in range(4)]
        assert means == sorted(means)
        with pytest.raises(SourceError, match="no more frames"):
            src.read()


def test_images_source(tmp_path: Path) -> None:
    for i in range(3):
        cv2.imwrite(str(tmp_path / f"{i:02d}.png"), np.full((10, 20, 3), i * 50, np.uint8))
    (tmp_path / "notes.txt").write_text("ignored")
    with ImagesSource(tmp_path) as src:
        assert (src.info.width, src.info.height) == (20, 10)
        assert [int(src.read()[0, 0, 0]) for _ in range(3)] == [0, 50, 100]
        with pytest.raises(SourceError, match="no more images"):
            src.read()


def test_synthetic_source_renders_the_typed_pose() -> None:
    with SyntheticSource(None, Method.POINT, realtime=False) as src:
        src.set_pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        a = src.read()
        src.set_pose((1.5, 0.0, 0.0), (0.0, 0.0, 0.0))
        b = src.read()
    from twopose.detect import detect_dot

    da, db = detect_dot(a), detect_dot(b)
    assert da.found
    assert db.found
    # Moving the camera +1.5 in along x moves the dot left by f * 1.5 / z = 525 * 1.5 / 11 px.
    assert da.centroid_px[0] - db.centroid_px[0] == pytest.approx(525 * 1.5 / 11.0, abs=0.3)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("camera:99", "did not open"),
        ("camera:x", "must be a number"),
        ("video:/nonexistent.avi", "does not exist"),
        ("images:/nonexistent", "does not exist"),
        ("webcam", "unknown source"),
    ],
)
def test_bad_sources_say_what_is_wrong(spec: str, message: str) -> None:
    with pytest.raises(SourceError, match=message):
        open_source(spec).open()


def test_a_late_reader_of_a_paced_source_drops_frames_and_they_are_counted(tmp_path: Path) -> None:
    import time

    out = tmp_path / "s.mcap"
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    with (
        SyntheticSource(None, Method.POINT) as src,
        SessionWriter(out, SessionInfo(method=Method.POINT, units=Units.IN), [cam]) as w,
    ):
        src.read()
        time.sleep(0.2)  # six frame intervals at 30 fps
        src.read()  # a camera would have moved on meanwhile
        assert src.dropped >= 4
        before = src.dropped
        result = capture_frames(
            w,
            src,
            PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, 0.0, 0.0)),
            CaptureSettings(
                frames=3,
                target="dot",
                on_frame=lambda fb: time.sleep(0.1),  # a slow consumer: ~3 intervals a frame
            ),
        )
    assert result.dropped >= 4
    assert src.dropped - before == result.dropped
    assert len(result.overhead_s) == 3
    with SessionReader(out) as r:
        (window,) = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert window.dropped_frames == result.dropped


def test_a_paced_video_skips_the_frames_a_late_reader_missed(tmp_path: Path) -> None:
    import time

    with VideoSource(write_video(tmp_path / "v.avi", 30, step=8), realtime=True) as src:
        first = src.read().mean()
        time.sleep(0.12)  # ~3.6 frame intervals at 30 fps
        second = src.read().mean()
    assert src.dropped >= 2
    assert second - first == pytest.approx(8 * (src.dropped + 1), abs=3)


def test_camera_source_reports_a_device_that_stops_delivering(tmp_path: Path) -> None:
    """The capture thread's end-of-stream path, driven by a real capture that runs dry."""
    from recorder.sources import CameraSource

    with CameraSource(str(write_video(tmp_path / "v.avi", 3))) as cam:
        # A file delivers faster than a camera: the grabber keeps the newest frames, as it
        # does for a camera, so how many arrive depends on timing; none is lost uncounted.
        frames: list[np.ndarray] = []

        def drain() -> None:
            for _ in range(4):
                frames.append(cam.read(timeout_s=2.0))

        with pytest.raises(SourceError, match="stopped delivering"):
            drain()
        assert frames
        assert all(f.shape == (48, 64, 3) for f in frames)
        assert len(frames) + cam.dropped == 3


@pytest.mark.parametrize("kind", ["synthetic", "video", "images"])
def test_a_pause_before_a_redone_capture_is_not_counted_as_dropped(
    tmp_path: Path, kind: str
) -> None:
    import time

    from recorder.capture import CaptureResult
    from recorder.driver import Decision, Driver, Placement
    from recorder.procedure import record

    pause_s = 0.6  # 18 frame intervals at 30 fps

    class Pausing(Driver):
        def __init__(self) -> None:
            self.decisions = [Decision.REDO, Decision.ACCEPT, Decision.ACCEPT]

        def place(self, trial: int, pose: int) -> Placement:
            return Placement(
                entry=PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=(0.0, 0.0, 0.0))
            )  # same pose

        def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
            time.sleep(pause_s)
            return self.decisions.pop(0)

    if kind == "synthetic":
        source: object = SyntheticSource(None, Method.POINT, realtime=True)
        cam = Camera(
            camera_id="cam0",
            intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
        )
    elif kind == "video":
        source = VideoSource(write_video(tmp_path / "v.avi", 90, step=2), realtime=True)
        cam = Camera(
            camera_id="cam0",
            intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
        )
    else:
        for i in range(12):
            cv2.imwrite(str(tmp_path / f"{i:02d}.png"), np.full((48, 64, 3), i, np.uint8))
        source = ImagesSource(tmp_path)
        cam = Camera(
            camera_id="cam0",
            intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
        )
    out = tmp_path / "s.mcap"
    summary = record(
        out,
        SessionInfo(method=Method.POINT, units=Units.IN),
        [cam],
        source,  # type: ignore[arg-type]  # a stand-in source that pauses between captures
        Pausing(),
        capture=CaptureSettings(frames=3),
    )
    with SessionReader(out) as r:
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert len(windows) == 3  # the redone capture, then poses 1 and 2
    # A pause counted as drops would give ~18 per capture; a capture itself may lose one or
    # two frames on a loaded machine.
    assert [w.dropped_frames <= 2 for w in windows] == [True, True, True]
    assert summary.dropped == sum(w.dropped_frames for w in windows)


def test_a_camera_drops_frames_queued_before_the_capture_without_counting_them() -> None:
    from recorder.sources import CameraSource

    cam = CameraSource(0)  # not opened: its queue is all this test uses
    cam._frames.put(np.zeros((2, 2, 3), np.uint8))
    cam._frames.put(np.zeros((2, 2, 3), np.uint8))
    cam.dropped = 7  # dropped while the laptop was being moved
    cam.start_capture()
    assert cam._frames.empty()
    assert cam.dropped == 7  # the capture counts from here


def test_an_images_pattern_takes_only_the_files_it_matches(tmp_path: Path) -> None:
    for side, value in (("left", 10), ("right", 200)):
        for i in range(2):
            cv2.imwrite(str(tmp_path / f"{side}{i:02d}.png"), np.full((10, 20, 3), value, np.uint8))
    with open_source(f"images:{tmp_path / 'left*.png'}") as src:
        assert src.info.description == f"images:{tmp_path / 'left*.png'}"
        assert [int(src.read()[0, 0, 0]) for _ in range(2)] == [10, 10]
        with pytest.raises(SourceError, match="no more images"):
            src.read()
    with pytest.raises(SourceError, match=r"matches centre\*\.png"):
        open_source(f"images:{tmp_path / 'centre*.png'}").open()
