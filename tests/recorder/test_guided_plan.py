"""A guided plan per method with the synthetic camera (issue 36): the recorder suggests each
next pose, the simulated operator places the laptop there with its placing error, and a
trial stops at the first pose whose 95% region is within the target or at max_poses; the
analysis of the file agrees with what the recorder said."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from analysis.session.pipeline import analyse_session
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from twopose.format.reader import SessionReader
from twopose.guidance.advice import Advice
from twopose.methods.specs import Method
from twopose.sim.layout import finger_axis
from twopose.sim.scene import load_scene

#: The target precision per method (inches) in the default synthetic scene, where two
#: poses give about 1-2 in: some trials reach it before max_poses, some do not.
TARGETS = {Method.POINT: 1.0, Method.LINE: 1.2, Method.GROUND: 1.2}
MAX_POSES = 4


def _truth(method: Method) -> str:
    scene = load_scene()
    if method is Method.POINT:
        points = [scene.point.position]
    elif method is Method.LINE:
        points = [tuple(p) for p in finger_axis(scene)]
    else:
        x, z = scene.finger.ground_point
        points = [(x, scene.ground_height, z)]
    return "[" + ", ".join("[" + ", ".join(f"{v:.6f}" for v in p) + "]" for p in points) + "]"


def _plan(method: Method, tmp: Path) -> Path:
    ground = "ground_height = 9.625\n" if method is Method.GROUND else ""
    trials = "".join(
        f'\n[[trials]]\nground_truth = {_truth(method)}\nposes = "guided"\nstart = [{x}, 0, 0]\n'
        for x in (0.0, -1.0, 1.0)
    )
    text = (
        f'method = "{method}"\nunits = "in"\nframes = 3\n{ground}\n'
        "[camera]\nfocal = 525.0\nprincipal = [320.0, 240.0]\n\n"
        f"[guidance]\ntarget_95 = {TARGETS[method]}\nmax_poses = {MAX_POSES}\nseed = 3\n{trials}"
    )
    path = tmp / f"{method}.toml"
    path.write_text(text)
    return path


@pytest.mark.slow
@pytest.mark.parametrize("method", [Method.POINT, Method.LINE, Method.GROUND])
def test_a_guided_plan_stops_each_trial_as_the_rule_says_and_the_analysis_agrees(
    method: Method, tmp_path: Path
) -> None:
    plan = load_plan(_plan(method, tmp_path))
    advice: dict[int, list[Advice]] = {}
    out = tmp_path / f"{method}.mcap"
    record_plan(
        plan,
        out,
        SyntheticSource(None, method, realtime=False),
        on_advice=lambda trial, a: advice.setdefault(trial, []).append(a),
    )
    target = TARGETS[method]
    trials = analyse_session(out).trials.set_index("trial")
    assert list(trials.index) == [1, 2, 3]
    for trial, said in advice.items():
        # One advice per accepted pose; every one but the last is "go on".
        assert len(said) == trials.loc[trial, "n_views"]
        assert all(not a.complete for a in said[:-1])
        assert said[-1].complete
        for a in said[:-1]:  # it went on only while the region was beyond the target
            assert not (a.region95 <= target)
            assert a.suggestion is not None
        last = said[-1]
        if last.region95 <= target:
            assert "trial complete" in last.text
        else:
            assert len(said) == MAX_POSES
            assert "the most for a trial" in last.text
        # The analysis of the file: the same poses and, within the pooling of the frame
        # scatter over the session's trials (the recorder's at the time, the analysis' over
        # all), the same region.
        row = trials.loc[trial]
        assert row["status"] == "ok"
        assert row["semiaxis95"] == pytest.approx(last.region95, rel=0.1)
    assert any(len(s) < MAX_POSES for s in advice.values()), "no trial reached the target"
    notes = _notes(out)
    assert notes[0].startswith("guidance: a trial is complete once its 95% region is within")
    # Every trial's end is noted: by the target, or at max_poses (issue 44).
    assert sum("trial complete" in n for n in notes) == len(advice)
    at_most = [t for t, s in advice.items() if "the most for a trial" in s[-1].text]
    assert sum("the most for a trial" in n for n in notes) == len(at_most)


def _notes(path: Path) -> list[str]:
    from twopose.format.entries import Note

    with SessionReader(path) as reader:
        return [e.text for e in reader.iter_entries() if isinstance(e, Note)]


def test_a_guided_trial_in_a_board_plan_and_a_bad_guidance_table_are_refused(
    tmp_path: Path,
) -> None:
    from twopose.errors import InputValueError

    bad = tmp_path / "bad.toml"
    bad.write_text(
        'method = "point"\n[camera]\nfocal = 525.0\nprincipal = [320.0, 240.0]\n'
        '[guidance]\ntarget_95 = -1\n[[trials]]\nposes = "guided"\n'
    )
    with pytest.raises(InputValueError, match=r"guidance\.target_95"):
        load_plan(bad)
    bad.write_text(
        'method = "point"\n[camera]\nfocal = 525.0\nprincipal = [320.0, 240.0]\n'
        "[[trials]]\nposes = [{ t = [0, 0, 0] }, { t = [1, 0, 0] }]\nmax_poses = 3\n"
    )
    with pytest.raises(InputValueError, match='max_poses is for poses = "guided" only'):
        load_plan(bad)
    plan = tmp_path / "ok.toml"
    plan.write_text(
        'method = "point"\n[camera]\nfocal = 525.0\nprincipal = [320.0, 240.0]\n'
        '[[trials]]\nposes = "guided"\nmax_poses = 3\n'
    )
    loaded = load_plan(plan)
    assert loaded.guidance is not None  # guided trials without [guidance]: the thesis' reach
    assert loaded.guidance.target95 is None
    assert loaded.trials[0].max_poses == 3
    assert math.isclose(loaded.guidance.reach.spacing, 0.5)
    start = loaded.trials[0].start
    assert start is not None
    assert np.allclose(start.t_grid, 0.0)
