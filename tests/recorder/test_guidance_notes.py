"""A guided trial's end in the file, and the terminal while a suggestion is computed
(issue 44): a trial ended at ``max_poses`` gets a ``guidance:`` note as one ended by the
target does; the driver hears "computing the next suggestion…" before each suggestion, and
never after the trial's last pose."""

from __future__ import annotations

from pathlib import Path

from recorder.procedure.capture import CaptureResult, CaptureSettings
from recorder.procedure.driver import Decision, Driver, Placement
from recorder.procedure.recording import record
from recorder.sources.registry import SyntheticSource
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import Note, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.guidance.advice import Advice, Guidance, Reach
from twopose.methods.specs import Method
from twopose.values.units import Units

INFO = SessionInfo(method=Method.POINT, units=Units.IN)
THESIS = Camera(
    camera_id="cam0", intrinsics=Intrinsics(width=640, height=480, fx=525, fy=525, cx=320, cy=240)
)


class _Operator(Driver):
    """Accepts every capture of one trial; places the poses along x; heard what was said."""

    def __init__(self, poses: int) -> None:
        self.poses = poses
        self.heard: list[str] = []

    def next_trial(self, trial: int) -> bool:
        return trial == 1

    def poses_in(self, trial: int) -> int:
        return self.poses

    def place(self, trial: int, pose: int) -> Placement:
        x = (0.0, 2.0, -1.0, 1.0)[pose - 1]  # the dot in view from each
        return Placement(
            entry=PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=(x, 0.0, 0.0))
        )

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        return Decision.ACCEPT

    def computing(self, what: str) -> None:
        self.heard.append(what)

    def advice(self, trial: int, advice: Advice) -> bool:
        self.heard.append(f"advice: {advice.text}")
        return advice.complete


def _notes(path: Path) -> list[str]:
    with SessionReader(path) as r:
        return [e.text for e in r.iter_entries() if isinstance(e, Note)]


def test_a_trial_ended_at_max_poses_is_noted_in_the_file(tmp_path: Path) -> None:
    """Issue 44: the trial ended by max_poses left no note; one ended by the target did."""
    guidance = Guidance(reach=Reach.thesis(Units.IN), target95=1e-4, max_poses=3)
    driver = _Operator(poses=guidance.max_poses)
    capture = CaptureSettings.live_detection(INFO, frames=2, guidance=guidance)
    source = SyntheticSource(None, Method.POINT, realtime=False, bank=2)
    record(tmp_path / "s.mcap", INFO, [THESIS], source, driver, capture=capture)
    notes = _notes(tmp_path / "s.mcap")
    ended = [n for n in notes if n.startswith("guidance: 3 poses, the most for a trial")]
    assert len(ended) == 1, notes
    assert "> 0.0001" in ended[0]
    # Said before each of the two suggestions, then the trial's end (no suggestion).
    said = [h for h in driver.heard if not h.startswith("advice")]
    assert said == ["computing the next suggestion…"] * 2
    assert driver.heard[-1].startswith("advice: 3 poses, the most for a trial")
