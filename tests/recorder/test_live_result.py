"""The live result: every recording path solves each trial as soon as it has two accepted
poses, with the analysis' own estimation, and shows it; the analysis agrees exactly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.session.pipeline import analyse_session
from recorder.cli.app import app
from recorder.live.trial_result import TrialResult
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from twopose.methods.specs import Method

runner = CliRunner()

PLAN = """
method = "{method}"
units = "in"
frames = 3
ground_height = 9.625

[camera]
focal = 525.0
principal = [320.0, 240.0]

[[trials]]
ground_truth = {truth}
poses = [{{ t = [0.0, 0.0, 0.0] }}, {{ t = [1.5, 0.0, -1.0] }}, {{ t = [-1.0, 0.0, 0.5] }}]

[[trials]]
ground_truth = {truth}
poses = [{{ t = [-1.0, 0.0, 0.0] }}, {{ t = [1.0, 0.0, 0.5] }}]
"""

TRUTH = {
    "point": "[[0.5, 1.5, 11.0]]",
    "ground": "[[1.91, 9.625, 8.375]]",
    "line": "[[-1.0, 1.5, 11.0], [2.0, 1.5, 11.0]]",
}


@pytest.mark.slow
@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_each_trial_is_solved_live_as_the_analysis_solves_it(method: str, tmp_path: Path) -> None:
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.format(method=method, truth=TRUTH[method]))
    shown: list[TrialResult] = []
    out = tmp_path / "s.mcap"
    record_plan(
        load_plan(plan_file),
        out,
        SyntheticSource(None, Method(method), realtime=False),
        on_result=shown.append,
    )
    # Trial 1: after its 2nd pose, updated after its 3rd; trial 2: after its 2nd.
    assert [(r.trial, r.n_views) for r in shown] == [(1, 2), (1, 3), (2, 2)]
    trials = analyse_session(out).trials.set_index("trial")
    for result in (shown[1], shown[2]):  # each trial's final live result
        row = trials.loc[result.trial]
        assert result.status == row["status"] == "ok"
        np.testing.assert_allclose(result.point, row[["x", "y", "z"]].to_numpy(float), atol=1e-9)
        assert result.error == pytest.approx(row["err"], abs=1e-9)
        assert f"x {row['x']:.3f} y {row['y']:.3f} z {row['z']:.3f} in" in result.text()
        assert f"error {row['err']:.3f} in" in result.text()
        assert np.isfinite(result.semiaxis95)
    assert shown[0].point != shown[1].point  # the third pose changed the estimate


@pytest.mark.slow
def test_the_plan_command_prints_each_result(tmp_path: Path) -> None:
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.format(method="ground", truth=TRUTH["ground"]))
    out = tmp_path / "s.mcap"
    result = runner.invoke(
        app, ["new", str(out), "--plan", str(plan_file), "--source", "synthetic"]
    )
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if "result: trial" in line]
    assert [line.split("result: ")[1].split(":")[0] for line in lines] == [
        "trial 1 (2 views)",
        "trial 1 (3 views)",
        "trial 2 (2 views)",
    ]
    assert all("95% within" in line and "error" in line for line in lines)


@pytest.mark.slow
def test_a_calibrated_rig_corrects_the_live_result_as_run_rig_does(tmp_path: Path) -> None:
    """``new --rig``: the live result is corrected by the rig's constants exactly as
    ``twopose-analyze run --rig`` corrects the analysis."""
    from analysis.results import AnalysisOptions
    from twopose.rig.constants import RigConstants
    from twopose.rig.file import load_rig

    rig_file = tmp_path / "rig.toml"
    rig_file.write_text(
        "[rig]\ncamera_offset = [0.3, 0.2, 0.4]\nmount_rotation_deg = [0.8, -0.5, 0.3]\n"
    )
    rig = load_rig(rig_file)
    assert rig == RigConstants(mount_rotation_deg=(0.8, -0.5, 0.3), camera_offset=(0.3, 0.2, 0.4))
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.format(method="point", truth=TRUTH["point"]))
    out = tmp_path / "s.mcap"
    args = ["new", str(out), "--plan", str(plan_file), "--source", "synthetic"]
    result = runner.invoke(app, [*args, "--rig", str(rig_file)])
    assert result.exit_code == 0, result.output
    lines = [x for x in result.output.splitlines() if "result: trial 2" in x]
    assert len(lines) == 1
    corrected = analyse_session(out, AnalysisOptions(rig=rig)).trials.set_index("trial")
    plain = analyse_session(out).trials.set_index("trial")
    row = corrected.loc[2]
    assert f"x {row['x']:.3f} y {row['y']:.3f} z {row['z']:.3f} in" in lines[0]
    assert abs(float(corrected["x"].loc[2]) - float(plain["x"].loc[2])) > 0.1  # the rig did move it


@pytest.mark.slow
def test_a_live_result_that_fails_is_said_and_the_recording_goes_on(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A live solve that raises (a fault injected into the estimation, since every input
    that could make it fail is now refused up front): each trial is still recorded whole,
    and the operator is told why no result is shown."""
    import recorder.live.result

    def broken(*args: object, **kwargs: object) -> object:
        raise np.linalg.LinAlgError("injected")

    monkeypatch.setattr(recorder.live.result, "estimate_session", broken)
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.format(method="point", truth=TRUTH["point"]))
    out = tmp_path / "s.mcap"
    shown: list[TrialResult] = []
    summary = record_plan(
        load_plan(plan_file),
        out,
        SyntheticSource(None, Method.POINT, realtime=False),
        on_result=shown.append,
    )
    assert (summary.n_trials, summary.n_complete_trials, summary.n_accepted) == (2, 2, 5)
    warnings = [x for x in capsys.readouterr().err.splitlines() if "live result failed" in x]
    assert warnings  # said, not silently dropped
    assert shown == []
    trials = analyse_session(out).trials
    assert list(trials["status"]) == ["ok", "ok"]  # the file holds both trials, whole


@pytest.mark.parametrize(
    ("rig_text", "message"),
    [
        ('[rig]\nunits = "in"\nprincipal_offset_px = [1e300, 0.0]\n', "principal_offset_px"),
        ('[rig]\nunits = "mm"\ncamera_offset = [1.0, 0.0, 0.0]\n', "in mm"),
    ],
)
def test_a_rig_that_does_not_apply_is_refused_before_the_file_exists(
    tmp_path: Path, rig_text: str, message: str
) -> None:
    """`new --plan --rig` checks the rig as `run --rig` does (units, plausibility) before
    recording: exit 3 naming the key, and no session file."""
    from typer.testing import CliRunner

    from recorder.cli.app import app
    from twopose.errors import EXIT_ERROR

    rig = tmp_path / "rig.toml"
    rig.write_text(rig_text)
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.format(method="point", truth=TRUTH["point"]))
    out = tmp_path / "s.mcap"
    args = ["new", str(out), "--plan", str(plan_file), "--source", "synthetic", "--rig", str(rig)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == EXIT_ERROR, result.output
    assert message in result.output
    assert "Traceback" not in result.output
    assert not out.exists()


# Slow: it records a guided plan, a suggestion searched after each of its three poses (~3 s).
@pytest.mark.slow
def test_the_advice_carries_the_map_its_suggestion_is_the_best_of_and_the_page_gets_it(
    tmp_path: Path,
) -> None:
    """Issue 46, 55: the advice carries the map of every reachable pose's predicted region,
    whose cells the suggestion's search starts from (its best is the suggestion); the
    console's driver sends it to the page."""
    from recorder.console.driver import WebDriver
    from recorder.console.state import ConsoleSession
    from recorder.setup.rules import PoseTyping
    from twopose.guidance.advice import Advice
    from twopose.values.jsonsafe import dumps

    plan_file = tmp_path / "plan.toml"
    text = PLAN.format(method="point", truth=TRUTH["point"]).split("[[trials]]")
    plan_file.write_text(text[0] + "[guidance]\ntarget_95 = 0.001\n\n[[trials]]" + text[1])
    said: list[Advice] = []
    record_plan(load_plan(plan_file), tmp_path / "s.mcap",
                SyntheticSource(None, Method.POINT, realtime=False),
                on_advice=lambda _, advice: said.append(advice))  # fmt: skip
    assert len(said) == 3  # after each of the three poses
    assert all(a.region_map is not None and not a.complete for a in said)
    for a in said:
        assert a.region_map is not None
        assert a.suggestion is not None
        best = a.region_map.best()
        assert best is not None
        assert best[0].tolist() == list(a.suggestion.t_grid)
    advice = said[1]
    session = ConsoleSession(tmp_path / "c.mcap")
    WebDriver(session, None, "cam0", (), PoseTyping()).advice(1, advice)
    with session.lock:  # the map follows the suggestion
        session.lock.wait_for(lambda: (session.advice or {}).get("map") is not None, timeout=30)
    page = session.snapshot()["advice"]
    drawn = page["map"]
    assert drawn is not None
    assert drawn["units"] == "in"
    assert drawn["taken"] == [[0.0, 0.0], [1.5, -1.0]]
    assert drawn["best"]["value"] <= min(v for row in drawn["values"] for v in row if v is not None)
    assert drawn["best"]["t_grid"] == page["suggestion"]["t_grid"]
    assert "NaN" not in dumps(page)


@pytest.mark.slow  # records a guided plan (9 frames rendered) with a rig, a few s
def test_with_a_rig_the_suggestions_stay_on_the_typed_grid(tmp_path: Path) -> None:
    """Adversary, issue 46: ``new --rig`` suggested poses shifted by the rig's camera
    offset (y -0.0395 for a laptop on the table at y 0). Guidance suggests where the
    operator puts the laptop, as typed, whatever the rig says its camera then is."""
    from twopose.guidance.advice import Advice
    from twopose.rig.constants import RigConstants

    plan_file = tmp_path / "plan.toml"
    text = PLAN.format(method="point", truth=TRUTH["point"]).split("[[trials]]")
    plan_file.write_text(text[0] + "[guidance]\ntarget_95 = 0.001\n\n[[trials]]" + text[1])
    rig = RigConstants(camera_offset=(0.3, -0.04, 0.4), mount_rotation_deg=(0.8, -0.5, 0.3))
    said: list[Advice] = []
    record_plan(load_plan(plan_file), tmp_path / "s.mcap",
                SyntheticSource(None, Method.POINT, realtime=False), rig=rig,
                on_advice=lambda _, advice: said.append(advice))  # fmt: skip
    suggested = [a.suggestion for a in said if a.suggestion is not None]
    assert suggested
    for s in suggested:
        x, y, z = s.t_grid
        assert y == 0.0, s.t_grid  # the typed height, not the camera's
        assert round(x * 2) == x * 2, s.t_grid  # on the 1/2 in grid
        assert round(z * 2) == z * 2, s.t_grid


def test_guidance_keeps_the_target_off_the_blobs_the_last_frames_turned_down() -> None:
    """Issue 55, for a real camera: the candidate blobs the live detector turned down in the
    last frames of the pose that saw the target are the clutter guidance avoids; the
    synthetic camera's scene, where the source knows it, wins."""
    from recorder.live.result import LiveResults
    from recorder.procedure.capture import CaptureResult, _feedback
    from twopose.camera.model import Camera, Intrinsics
    from twopose.detect.clutter import Clutter
    from twopose.detect.detection import Detection, RejectedBlob
    from twopose.format.entries import PoseEntry
    from twopose.values.units import Units

    outline = np.array([[100.0, 190.0], [110.0, 200.0], [100.0, 212.0], [90.0, 200.0]])
    disk = RejectedBlob(outline_px=outline, centroid_px=(100.0, 200.0), reason="eccentricity")
    seen = Detection(found=True, centroid_px=(320.0, 240.0), theta_deg=80.0, n_blobs=2,
                     n_candidates=1, rejected_blobs=(disk,))  # fmt: skip
    frames = tuple(_feedback(k, seen) for k in range(3))
    assert frames[-1].turned_down_px == ((100.0, 200.0, 12.0),)
    intrinsics = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
    camera = Camera(camera_id="cam0", intrinsics=intrinsics)
    live = LiveResults(Method.LINE, Units.IN, [camera], None)
    entry = PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, 0.0, 0.0), capture=1)
    live.captured(entry, CaptureResult(n_frames=3, complete=True, reason="", feedback=frames,
                                       capture=1))  # fmt: skip
    live.update(1, {1: entry})
    clutter = live.clutter_for([1])
    assert clutter is not None
    assert clutter.source == "the last frames"
    assert len(clutter) == 1
    known = Clutter(points=np.zeros((1, 3)), radii=np.ones(1), source="the synthetic scene")
    live.known_clutter = known
    assert live.clutter_for([1]) is known
