"""``twopose-record new --rig`` with a rig file's measured placing sigma (issue 46, part
1): the live result's regions take it instead of each pose's typed resolution, and the
recording says which placing sigma it uses as it starts."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.live.trial_result import TrialResult
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from twopose.methods.specs import Method
from twopose.uncertainty.noise import PlacingSigma

PLAN = """
method = "point"
units = "in"
frames = 1
ground_height = 9.625

[camera]
focal = 525.0
principal = [320.0, 240.0]

[[trials]]
ground_truth = [[0.5, 1.5, 11.0]]
poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.5, 0.0, -1.0] }]  # typed to 1/16 in
"""


def _record(tmp_path: Path, name: str, placing: PlacingSigma | None) -> TrialResult:
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN)
    shown: list[TrialResult] = []
    record_plan(
        load_plan(plan_file),
        tmp_path / f"{name}.mcap",
        SyntheticSource(None, Method.POINT, realtime=False),
        on_result=shown.append,
        placing=placing,
    )
    assert len(shown) == 1
    return shown[0]


# Slow: it renders and records two sessions through the procedure (4 frames, a few s).
@pytest.mark.slow
def test_the_live_result_takes_the_measured_placing_sigma(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    typed = _record(tmp_path, "typed", None)
    assert "placing sigma: typed" in capsys.readouterr().err
    measured = PlacingSigma(sigma_in=0.2, sigma_sigma_in=0.03, measured_by="board.mcap", captures=8)
    wider = _record(tmp_path, "measured", measured)
    said = capsys.readouterr().err
    assert "placing sigma 0.2 ± 0.03 in, measured by board.mcap (8 captures)" in said
    assert wider.point == typed.point  # the same frames: only the region changes
    # 3.2x the typed sigma on the term that dominates the region (the pixels' share stays)
    assert wider.semiaxis95 > 1.5 * typed.semiaxis95, (typed.semiaxis95, wider.semiaxis95)


def test_the_console_says_its_notes_at_its_terminal_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Adversary, issue 46: with ``--ui`` the placing sigma the regions assume reached the
    page only; the terminal's log (docs/rig.md: said as the recording starts) missed it."""
    from recorder.console.driver import WebDriver
    from recorder.console.state import ConsoleSession
    from recorder.setup.rules import PoseTyping

    session = ConsoleSession(tmp_path / "c.mcap")
    WebDriver(session, None, "cam0", (), PoseTyping()).notice("placing sigma: typed")
    assert "note: placing sigma: typed" in capsys.readouterr().err
    assert session.snapshot()["notices"] == ["placing sigma: typed"]
