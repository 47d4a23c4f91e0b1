"""recorder.procedure.capture directly: a capture that the source stops short is kept and marked
incomplete, the one rule for a capture's detections (half the frames), the pose's live
average, and each frame's line as the thesis' GUI showed it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from recorder.procedure.capture import (
    CaptureResult,
    CaptureSettings,
    FrameFeedback,
    Shortfall,
    capture_frames,
    detection_shortfall,
)
from recorder.sources.registry import VideoSource
from tests.helpers import write_video
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import CaptureWindow, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.choices import Target
from twopose.values.units import Units

INFO = SessionInfo(method=Method.POINT, units=Units.IN)


def _fb(
    index: int, found: bool, centroid: tuple[float, float] = (10.0, 20.0), theta: float = 30.0
) -> FrameFeedback:
    return FrameFeedback(
        index=index, found=found, centroid_px=centroid, theta_deg=theta, n_blobs=int(found),
        reason="" if found else "no dark blob", area_px=120.0, eccentricity=0.9,
    )  # fmt: skip


def test_a_source_that_stops_mid_capture_leaves_an_incomplete_capture(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
    )
    with (
        VideoSource(write_video(tmp_path / "v.avi", 3)) as src,
        SessionWriter(out, INFO, [cam]) as w,
    ):
        entry = PoseEntry(
            trial=1,
            pose=1,
            camera_id="cam0",
            t_grid=(0.0, 0.0, 0.0),
            capture=w.new_capture_number(),
        )
        result = capture_frames(w, src, entry, CaptureSettings(frames=5, target=Target.DOT.spec))
    assert not result.complete
    assert result.n_frames == 3
    assert "no more frames" in result.reason
    assert len(result.feedback) == 3
    with SessionReader(out) as r:  # the session stays valid
        (window,) = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert (window.status, window.n_frames, window.capture) == ("incomplete", 3, 1)
    assert "no more frames" in window.reason


@pytest.mark.parametrize(
    ("found", "shortfall"),
    [
        ([], Shortfall.OK),  # no live detection: nothing to judge by
        ([True] * 5, Shortfall.OK),
        ([True, True, True, False, False], Shortfall.OK),  # 3 of 5: at least half
        ([True, True, False, False, False], Shortfall.FEW_FOUND),
        ([True, False], Shortfall.OK),  # exactly half
        ([False] * 5, Shortfall.NONE_FOUND),
    ],
)
def test_the_one_rule_for_a_captures_detections(found: list[bool], shortfall: Shortfall) -> None:
    feedback = tuple(_fb(k, f) for k, f in enumerate(found))
    result = CaptureResult(n_frames=len(found), complete=True, reason="", feedback=feedback)
    assert detection_shortfall(result) is shortfall


def test_the_pose_average_is_the_mean_of_the_frames_found() -> None:
    feedback = (_fb(0, True, (10.0, 20.0), 30.0), _fb(1, True, (12.0, 22.0), 32.0), _fb(2, False))
    result = CaptureResult(n_frames=3, complete=True, reason="", feedback=feedback)
    average = result.pose_average()
    assert average is not None
    assert average.centroid_px == pytest.approx((11.0, 21.0))
    assert average.theta_deg == pytest.approx(31.0)
    assert (average.n_used, average.n_frames) == (2, 3)
    assert CaptureResult(n_frames=3, complete=True, reason="").pose_average() is None


def test_a_frames_line_is_what_the_thesis_gui_showed() -> None:
    line = _fb(0, True, (100.0, 50.0), 0.0).line()
    assert line.startswith("  frame 1: found at (100.0, 50.0), theta +0.0 deg, ")
    assert "line -0.000 u +1.000 v = 50.0" in line  # horizontal: the row through the centroid
    assert line.endswith("area 120 px, eccentricity 0.90, 1 object(s)")
    assert _fb(2, False).line() == "  frame 3: not found (no dark blob)"
    dot = FrameFeedback(
        index=0, found=True, centroid_px=(1.0, 2.0), theta_deg=math.nan, n_blobs=1, reason=""
    )
    assert dot.line() == "  frame 1: found at (1.0, 2.0), 1 object(s)"  # a dot has no orientation
    payload = dot.to_json()
    assert payload["line"] == ""
    assert math.isnan(float(payload["theta_deg"]))  # type: ignore[arg-type]


def test_the_live_board_check_finds_the_far_board_rig_finds(tmp_path: Path) -> None:
    """Issue 44 (6): at every pose docs/rig.md recommends (BOARD_POSES), the three far ones
    at z = -34 in among them, the live check finds the rendered board in every frame, as
    the rig's search (``find_board``) does on the stored frame, so the page's accept stays
    on. OpenCV's fast check alone (the live check before) turned down every frame of the
    far poses; the full search behind it finds each, in time."""
    from recorder.sources.registry import SyntheticSource
    from twopose.camera.images import decode_image
    from twopose.detect.checkerboard import LIVE_BOARD_BUDGET_S, find_board, find_board_live
    from twopose.methods.targets import BoardPlacement
    from twopose.sim.layout import BOARD_POSES

    board = BoardPlacement(inner_corners=(9, 6), square=1.0, first_corner=(-4.0, 7.625, 24.0))
    info = SessionInfo(method=Method.BOARD, units=Units.IN, board=board)
    settings = CaptureSettings.live_detection(info, frames=2)
    scene = tmp_path / "scene.toml"  # the default scene; one ray per pixel (the board's
    scene.write_text("[sensor]\nsupersample = 1\n")  # squares are box-filtered exactly)
    source = SyntheticSource(scene, Method.BOARD, realtime=False, bank=1)
    out = tmp_path / "board.mcap"
    full_s: list[float] = []
    with source:
        camera = Camera(camera_id="cam0", intrinsics=source.scene.cameras[0].intrinsics)
        with SessionWriter(out, info, [camera]) as w:
            for pose, t in enumerate(BOARD_POSES, start=1):
                source.set_pose(t, (0.0, 0.0, 0.0))
                entry = PoseEntry(
                    trial=1, pose=pose, camera_id="cam0", t_grid=t, capture=w.new_capture_number()
                )
                w.write_pose(entry)
                result = capture_frames(w, source, entry, settings)
                assert result.n_found == 2, (t, [fb.reason for fb in result.feedback])
                assert detection_shortfall(result) is Shortfall.OK
                stored = decode_image(w.encode_image(source.read()), "frame")
                live = find_board_live(stored, (9, 6))
                assert live.corners is not None
                np.testing.assert_array_equal(
                    live.corners, find_board(stored, (9, 6), window_px=None)
                )
                if t[2] == -34.0:  # far: the fast check fails, the full search finds it
                    assert not live.fast
                    full_s.append(live.full_s)
    assert len(full_s) == 3
    assert max(full_s) < LIVE_BOARD_BUDGET_S
