"""A one-camera session whose camera's image size the detector's floor was not measured at
(issue 58's floor, ``twopose.methods.specs.FLOOR_MEASURED_SIZES``): its noise model says
so where it is said (``trials.csv`` and ``summary.csv``'s ``floor_unmeasured``, the
terminal's session line, the report's noise section, the recorder's live notes), and a
640x480 one says nothing of it (a new user's r5: a pair said it, one camera did not)."""

from __future__ import annotations

import html
from pathlib import Path

import pandas as pd
import pytest

from analysis.report.answer import noise_section
from analysis.report.terminal import summary_lines
from analysis.session.metrics import summarize
from analysis.session.pipeline import analyse_session
from recorder.live.result import live_results
from recorder.procedure.capture import CaptureSettings
from recorder.simulate.one_camera import simulate_session
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import SessionInfo
from twopose.methods.specs import Method, floor_unmeasured, spec_of
from twopose.sim.scene import load_scene
from twopose.values.units import Units

HALF = {"id": "cam0", "width": 320, "height": 240, "fx": 262.5, "fy": 262.5, "cx": 160.0,
        "cy": 120.0}  # fmt: skip
SAID = floor_unmeasured(320, 240)


@pytest.fixture(scope="module")
def half_size(tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    """A small point session from a 320x240 camera (the thesis' field of view), analysed."""
    path = tmp_path_factory.mktemp("half") / "half.mcap"
    scene = load_scene(None, cameras=[HALF])
    simulate_session(path, method=Method.POINT, trials=2, frames=1, poses=3, seed=3, scene=scene)
    trials: pd.DataFrame = analyse_session(path).trials
    return trials


def test_a_one_camera_session_at_another_size_says_its_floor_is_unmeasured(
    half_size: pd.DataFrame,
) -> None:
    assert "640x480 only, not at this camera's 320x240" in SAID
    assert (half_size["floor_unmeasured"] == SAID).all()
    summary = summarize(half_size)
    assert summary["floor_unmeasured"].tolist() == [SAID]
    line = " ".join(summary_lines(half_size, summary, width=None))
    assert SAID in line
    assert any(html.escape(SAID) in item for item in noise_section(summary, half_size))


def test_a_640x480_session_says_nothing_of_the_floor(point_session: Path) -> None:
    trials = analyse_session(point_session).trials
    assert (trials["floor_unmeasured"] == "").all()
    summary = summarize(trials)
    assert summary["floor_unmeasured"].tolist() == [""]
    assert "floor holds" not in " ".join(summary_lines(trials, summary, width=None))


@pytest.mark.parametrize(("size", "said"), [((320, 240), True), ((640, 480), False),
                                            ((1280, 720), True)])  # fmt: skip
def test_the_live_result_says_a_floor_unmeasured_at_its_camera_size(
    size: tuple[int, int], said: bool
) -> None:
    w, h = size
    camera = Camera(camera_id="cam0", intrinsics=Intrinsics(
        width=w, height=h, fx=525.0 * w / 640, fy=525.0 * w / 640, cx=w / 2, cy=h / 2))  # fmt: skip
    info = SessionInfo(method=Method.POINT, units=Units.IN)
    settings = CaptureSettings(target=spec_of(Method.POINT).target)
    notes = live_results(info, [camera], None, settings).notes
    assert any("floor holds" in n for n in notes) is said
    assert (floor_unmeasured(w, h) in notes) is said
