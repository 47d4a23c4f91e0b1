"""recorder.console directly: the web console's driver types as many poses a trial as the
command line asked (``--poses``), like the terminal's."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.console import ConsoleSession, WebDriver
from recorder.interactive import _OperatorDriver
from recorder.setup_rules import PoseTyping
from recorder.sources import SyntheticSource
from twopose.camera import Camera, Intrinsics
from twopose.format.entries import SessionInfo
from twopose.methods import Method


@pytest.mark.parametrize("poses", [2, 3, 8])
def test_both_drivers_type_the_poses_a_trial_was_asked_for(tmp_path: Path, poses: int) -> None:
    typing = PoseTyping(poses_per_trial=poses)
    source = SyntheticSource(None, Method.POINT, realtime=False)
    web = WebDriver(ConsoleSession(tmp_path / "s.mcap"), source, "cam0", (), typing)
    camera = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525, fy=525, cx=320, cy=240),
    )
    terminal = _OperatorDriver(None, SessionInfo(method="point", units="in"), camera, (), typing)  # type: ignore[arg-type]
    assert web.poses_in(1) == poses
    assert terminal.poses_in(1) == poses
