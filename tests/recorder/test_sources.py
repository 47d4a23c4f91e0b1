"""sources: camera, video, images and synthetic frame sources."""

from __future__ import annotations

import ast
from pathlib import Path

import cv2
import numpy as np
import pytest

from recorder.procedure.capture import CaptureSettings, capture_frames
from recorder.sources.registry import (
    CameraSource,
    FrameSource,
    ImagesSource,
    SyntheticSource,
    VideoSource,
    open_source,
)
from tests.helpers import write_video
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import SourceError
from twopose.format.entries import CaptureWindow, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.choices import Target
from twopose.values.units import Units


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
    from twopose.detect.detection import detect_dot

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
                target=Target.DOT.spec,
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
    from recorder.sources.registry import CameraSource

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

    from recorder.procedure.capture import CaptureResult
    from recorder.procedure.driver import Decision, Driver, Placement
    from recorder.procedure.recording import record

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
    from recorder.sources.registry import CameraSource

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


def test_a_kind_added_to_the_registry_is_opened_and_listed() -> None:
    """A new kind is one entry: ``open_from`` opens it and the help lists it, no other code."""
    from dataclasses import replace

    from recorder.sources.registry import (
        SOURCE_KINDS,
        SourceInfo,
        SourceKind,
        SourceOptions,
        open_from,
        source_help,
        source_kinds_table,
    )

    class Blank(FrameSource):
        def __init__(self, arg: str, options: SourceOptions) -> None:
            self.arg, self.options = arg, options

        def open(self) -> SourceInfo:
            self.info = SourceInfo(description=f"blank:{self.arg}", width=4, height=2, fps=1.0)
            return self.info

        def read(self, timeout_s: float = 2.0) -> np.ndarray:
            return np.zeros((2, 4, 3), np.uint8)

    blank = SourceKind(
        name="blank", syntax="blank:LABEL", help="black frames", opener=Blank, needs_arg=True
    )
    kinds = (*SOURCE_KINDS, blank)
    options = SourceOptions(fps=12.0)
    with open_from(kinds, "blank:x", options) as src:
        assert isinstance(src, Blank)
        assert (src.arg, src.options.fps, src.info.description) == ("x", 12.0, "blank:x")
        assert src.read().shape == (2, 4, 3)
    assert isinstance(open_from(kinds, "video:a.avi", options), VideoSource)  # the others stay
    with pytest.raises(SourceError, match=r"unknown source 'blank'; use .* or blank:LABEL$"):
        open_from(kinds, "blank", options)  # its argument is required
    with pytest.raises(SourceError, match="unknown source"):
        open_from(SOURCE_KINDS, "blank:x", options)  # the registry itself is untouched
    assert source_help(kinds).endswith("synthetic[:SCENE.toml] or blank:LABEL.")
    assert "blank:LABEL" in source_help(kinds, calibration=True)
    no_calibration = (*SOURCE_KINDS, replace(blank, calibrates=False))
    assert "blank" not in source_help(no_calibration, calibration=True)
    assert source_kinds_table(kinds).splitlines()[-1].split() == ["blank:LABEL", "black", "frames"]


def test_the_command_line_help_and_errors_list_the_registry() -> None:
    """The CLI's ``--source`` help and the unknown-source message read the registry (the
    spellings the tests and docs have always shown)."""
    from recorder.sources.registry import SOURCE_KINDS, source_help

    assert [k.syntax for k in SOURCE_KINDS] == [
        "camera:N",
        "video:PATH",
        "images:DIR[/PATTERN]",
        "synthetic[:SCENE.toml]",
        "pair:A,B",  # two cameras: only the pair's commands take it (not in their help)
    ]
    assert source_help() == "camera:N, video:PATH, images:DIR[/PATTERN] or synthetic[:SCENE.toml]."
    assert source_help(calibration=True) == (
        "camera:N, video:PATH or images:DIR[/PATTERN] (e.g. images:photos/left*.jpg)."
    )
    with pytest.raises(SourceError) as err:
        open_source("video")
    assert str(err.value) == (
        "unknown source 'video'; use camera:N, video:PATH, images:DIR[/PATTERN] or "
        "synthetic[:SCENE.toml]"
    )
    assert isinstance(open_source("camera"), CameraSource)  # the device defaults to 0
    camera = open_source("camera:")
    assert isinstance(camera, CameraSource)
    assert camera.device == 0


_NAME_TESTS = {"startswith", "endswith", "removeprefix", "removesuffix", "partition"}


def _source_name_comparisons(tree: ast.AST, names: set[str], skip: set[int]) -> list[int]:
    """Lines comparing a string with a source name (``== "synthetic"``, ``in ("camera",
    ...)``, ``.startswith("video:")``), outside the nodes in ``skip``."""

    def named(node: ast.AST) -> bool:
        values = node.elts if isinstance(node, ast.Tuple | ast.List | ast.Set) else [node]
        return any(
            isinstance(v, ast.Constant)
            and isinstance(v.value, str)
            and (v.value in names or (v.value.partition(":")[0] in names and ":" in v.value))
            for v in values
        )

    found = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in _NAME_TESTS
        ):
            operands = list(node.args)
        else:
            continue
        if any(named(o) for o in operands):
            found.append(node.lineno)
    return found


def test_no_source_name_is_compared_outside_the_registry() -> None:
    """Which kind a source text is, is decided by its registry entry alone: no module of the
    recorder compares a text with a source name (the registry's entries are skipped)."""
    from recorder.sources.registry import SOURCE_KINDS

    names = {k.name for k in SOURCE_KINDS}
    recorder = Path(__file__).resolve().parents[2] / "recorder"
    found = []
    for path in sorted(recorder.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        skip: set[int] = set()
        for node in ast.walk(tree):
            target = node.target if isinstance(node, ast.AnnAssign) else None
            if isinstance(target, ast.Name) and target.id == "SOURCE_KINDS":
                skip |= {id(n) for n in ast.walk(node)}
        found += [f"{path.name}:{line}" for line in _source_name_comparisons(tree, names, skip)]
    assert found == []
    # The scan sees what it looks for.
    code = 'a == "synthetic"\nb.startswith("video:")\nc in ("camera", "x")\nd == "cam"\n'
    assert _source_name_comparisons(ast.parse(code), names, set()) == [1, 2, 3]
