"""A blunder caught at the trial, live (issue 54): after the third pose the recorder's
terminal says the trial's poses disagree and which typed component looks off; with a
fourth pose it names the pose. The page shows the same words (``result.to_json()``'s
``text``, what the console lists). The operator's noise file keeps the session for the
next one's prior."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from typing_extensions import override

from recorder.live.operator_noise import NoiseFile
from recorder.procedure.capture import CaptureSettings
from recorder.procedure.terminal import Operator, record_interactive
from recorder.setup.rules import PoseTyping, Setup
from recorder.sources.registry import FrameSource, SourceInfo
from twopose.camera.model import Intrinsics, project_points
from twopose.methods.specs import Method
from twopose.values.units import Units

K = Intrinsics(width=320, height=240, fx=262.5, fy=262.5, cx=160.0, cy=120.0)
POINT = np.array([1.5, 1.0, 9.0])
#: trial 1's poses as typed; the laptop really stood at pose 2 one inch to the left
TYPED = ("0 0 0", "2.5 0 0", "3 0 -1", "1 0 -2")
OFF = np.array([1.0, 0.0, 0.0])


class _DotSource(FrameSource):
    """A black dot on white, seen from where the laptop really stands: where typed, but
    for the second capture, 1 in to the left of its typed x."""

    def __init__(self) -> None:
        self._captures, self._where = 0, np.zeros(3)
        self._rng = np.random.default_rng(0)

    def open(self) -> SourceInfo:
        self.info = SourceInfo(description="a dot", width=K.width, height=K.height, fps=30.0)
        return self.info

    @override
    def set_pose(
        self, t_grid: tuple[float, float, float], r_deg: tuple[float, float, float]
    ) -> None:
        self._captures += 1
        self._where = np.asarray(t_grid) - (OFF if self._captures == 2 else 0.0)

    def read(self, timeout_s: float = 2.0) -> np.ndarray:
        image = np.full((K.height, K.width, 3), 235, np.uint8)
        col, row = project_points(POINT[None], K, np.eye(3), self._where)[0]
        centre = (round(col * 16), round(row * 16))  # a sixteenth of a pixel
        cv2.circle(image, centre, 6 * 16, (10, 10, 10), -1, cv2.LINE_AA, shift=4)
        noisy = image.astype(float) + self._rng.normal(0.0, 2.0, image.shape)
        return np.clip(noisy, 0, 255).astype(np.uint8)


def _record(out: Path, answers: list[str]) -> list[str]:
    said: list[str] = []
    replies = iter(answers)
    op = Operator(lambda q, d: next(replies) or d, said.append)
    record_interactive(
        out, _DotSource(), op,
        setup=Setup(method=Method.POINT, units=Units.IN, intrinsics=K, plane_offset=None,
                    ground_truth=((1.5, 1.0, 9.0),), operator="Ada"),
        capture=CaptureSettings(frames=2),
        typing=PoseTyping(poses_per_trial=4),
    )  # fmt: skip
    assert next(replies, None) is None  # every answer used
    return said


def test_the_terminal_says_a_mistyped_pose_after_the_third_and_names_it_after_the_fourth(
    tmp_path: Path,
) -> None:
    answers = [a for pose in TYPED for a in (pose, "", "a")] + ["n"]
    said = _record(tmp_path / "s.mcap", answers)
    previews = [line for line in said if "result if accepted" in line]
    assert len(previews) == 3  # after poses 2, 3 and 4
    two, three, four = previews
    assert "disagree" not in two  # two poses: no redundancy
    # three poses: any of them, its x typed wrong, could explain it, each by its own size
    assert (
        "WARNING this trial's poses disagree (typed x of one of them looks about 1 to 4 in "
        "off): check what you typed, or add a fourth pose" in three
    )
    assert (
        "WARNING this trial's poses disagree (typed x of pose 2 looks about 1 in off): "
        "check what you typed for pose 2" in four
    )
    # the operator's noise file keeps the session for the next one's prior
    kept = NoiseFile("Ada").sessions()
    assert len(kept) == 1
    assert kept[0]["method"] == "point"
    assert kept[0]["reference"] == "typed"


def test_the_page_shows_the_terminals_words(tmp_path: Path) -> None:
    """The console lists each result's ``text`` (recorder/console/page/main.js); it is the line the
    terminal prints, with the same warning."""
    from recorder.live.trial_result import trial_results
    from tests.helpers import load_benchmark
    from twopose.solve.session import SessionTrials

    bench = load_benchmark("bench_noise")
    trials: SessionTrials = bench.session(Method.POINT, 3, 1, 1.0, 4)
    views = trials.views[0]
    moved = [v if k != 1 else type(v)(**{**v.__dict__, "t_grid": v.t_grid + 4 * OFF})
             for k, v in enumerate(views)]  # fmt: skip
    import dataclasses

    result = trial_results(dataclasses.replace(trials, views=[moved]))[0]
    page = result.to_json()
    assert page["flagged"] is True
    assert page["text"] == result.text()
    assert "WARNING this trial's poses disagree (" in str(page["text"])
    assert str(page["disagreement"]) in str(page["text"])


class _TrueDotSource(_DotSource):
    """The dot seen from every pose where it was typed (no pose off)."""

    @override
    def set_pose(
        self, t_grid: tuple[float, float, float], r_deg: tuple[float, float, float]
    ) -> None:
        self._where = np.asarray(t_grid, dtype=float)


def test_the_terminal_says_a_trial_far_off_the_grid_point_typed_as_its_truth(
    tmp_path: Path,
) -> None:
    """Every pose typed right, the grid point typed 1 in off in x: the poses agree (no
    misclosure sees it), the truth does, after the third pose."""
    answers = [a for pose in TYPED[:3] for a in (pose, "", "a")] + ["n"]
    said: list[str] = []
    replies = iter(answers)
    op = Operator(lambda q, d: next(replies) or d, said.append)
    record_interactive(
        tmp_path / "s.mcap", _TrueDotSource(), op,
        setup=Setup(method=Method.POINT, units=Units.IN, intrinsics=K, plane_offset=None,
                    ground_truth=((2.5, 1.0, 9.0),), operator=""),
        capture=CaptureSettings(frames=2),
        typing=PoseTyping(poses_per_trial=3),
    )  # fmt: skip
    three = [line for line in said if "result if accepted" in line][-1]
    assert "poses disagree" not in three
    assert "WARNING this trial's estimate lies 1 in (" in three
    assert (
        "sigma), mostly in x from the grid point typed as its truth: one of its typed poses, "
        "the grid point, or the detection is off: check what you typed" in three
    )


def test_a_flag_that_lapses_with_a_later_trial_is_said_not_dropped() -> None:
    """Trial 1 flagged after its poses; a later trial's pose makes the session scatter
    more, and trial 1 passes beside it: the later trial's line says so, with what was said
    of trial 1 (a new user's r6 G1: the live flag on pose 2 vanished without a word)."""
    import dataclasses

    from recorder.live.result import _lapsed
    from recorder.live.trial_result import trial_results
    from tests.helpers import load_benchmark
    from twopose.solve.session import SessionTrials

    bench = load_benchmark("bench_noise")
    trials: SessionTrials = bench.session(Method.POINT, 3, 2, 1.0, 4)
    views = trials.views[0]
    moved = [v if k != 1 else type(v)(**{**v.__dict__, "t_grid": v.t_grid + 4 * OFF})
             for k, v in enumerate(views)]  # fmt: skip
    before = dict(
        enumerate(trial_results(dataclasses.replace(trials, views=[moved, trials.views[1]])), 1)
    )
    assert before[1].flagged
    now = {**before, 1: dataclasses.replace(before[1], flagged=False)}
    said = _lapsed(before, now, trial=2)
    assert said.startswith("trial 1 no longer flagged: beside trial 2 ")
    assert before[1].disagreement in said
    assert _lapsed(before, before, trial=2) == ""  # still flagged: nothing lapsed
    assert _lapsed(before, now, trial=1) == ""  # its own new pose: its own line says it
    line = dataclasses.replace(now[2], lapsed=said).text()
    assert line.endswith(f"NOTE {said}")
