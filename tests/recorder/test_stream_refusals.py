"""What a pair's recording refuses or says, and where (issue 58, the adversarial user's
findings on recording and plans): a ground touch off the floor (the terminal, the console's
``/api/stream``, a plan), a plan's keyed touch with nobody at a terminal, a plan that would
have to ask the ground height, scheduled touches out of order or at one moment, a trial with
nothing to measure, and the command help's bounds and choices."""

from __future__ import annotations

import dataclasses
import re
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner, Result

from recorder.cli.app import app
from recorder.procedure.stream import (
    StreamDriver,
    StreamEvent,
    StreamSummary,
    TrialEnd,
    record_stream,
)
from recorder.procedure.stream_terminal import (
    KeyReader,
    PairSetup,
    open_pair_source,
    pair_cameras,
    record_pair,
)
from recorder.procedure.terminal import Operator
from recorder.setup.stream_plan import load_stream_plan, touch_refusal
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.methods.specs import Method
from twopose.pair.motion import thesis_pair
from twopose.pair.pair_file import write_pair_file
from twopose.values.units import Units

_GROUND = 'method = "ground"\nunits = "in"\noperator = "Ada"\n'


def _stills(folder: Path, n: int = 12) -> Path:
    k = thesis_pair().intrinsics1
    folder.mkdir()
    for i in range(n):
        cv2.imwrite(str(folder / f"{i:03d}.png"), np.full((k.height, k.width, 3), 60, np.uint8))
    return folder


@pytest.fixture
def stills(tmp_path: Path) -> str:
    return f"pair:images:{_stills(tmp_path / 'a')},images:{_stills(tmp_path / 'b')}"


def _no_floor(folder: Path) -> Path:
    path = folder / "NOFLOOR.toml"
    if not path.exists():
        write_pair_file(path, dataclasses.replace(thesis_pair(), floor=None))
    return path


def _never_asked(question: str, _default: str) -> str:
    raise AssertionError(f"asked {question!r}")


def _plan(tmp_path: Path, text: str) -> Path:
    (tmp_path / "plan.toml").write_text(text)
    return tmp_path / "plan.toml"


def _new_with_plan(out: Path, pair: Path, stills: str, plan: Path) -> Result:
    """``new OUT --pair PAIR --source STILLS --plan PLAN < /dev/null``."""
    args = ["new", str(out), "--pair", str(pair), "--source", stills, "--plan", str(plan)]
    return CliRunner().invoke(app, args, input="")


def test_a_ground_touch_must_lie_on_the_floor_the_others_anywhere() -> None:
    """The ground's touch is on the floor (``y = h`` for a typed height) within the
    units' ground tolerance; point and line take any grid point."""
    typed = PairSetup(method=Method.GROUND, units=Units.IN, plane_offset=9.625)
    pair = typed.session_pair(dataclasses.replace(thesis_pair(), floor=None))
    assert touch_refusal(Method.GROUND, pair, Units.IN, (3.455, 9.625, 7.375)) == ""
    assert touch_refusal(Method.GROUND, pair, Units.IN, (3.455, 9.625 + 1 / 40, 7.375)) == ""
    off = touch_refusal(Method.GROUND, pair, Units.IN, (3.455, 0.0, 7.375))
    assert "is -9.625 in off the ground (y = 9.625 in" in off
    assert "its grid point must lie on it" in off
    # the same floor in mm: the tolerance is the unit's (0.5 mm)
    assert touch_refusal(Method.GROUND, pair, Units.MM, (10.0, 244.5, 300.0)) == ""
    assert touch_refusal(Method.GROUND, pair, Units.MM, (10.0, 245.0, 300.0)) != ""
    for method in (Method.POINT, Method.LINE):
        assert touch_refusal(method, pair, Units.IN, (3.455, 0.0, 7.375)) == ""
    # behind a camera, whatever the method: a sign typed wrong (a new user's r7 K4: a
    # ground touch at z -7.375, on the floor, 7 in behind camera 1, was taken)
    for method in Method.GROUND, Method.POINT, Method.LINE:
        behind = touch_refusal(method, pair, Units.IN, (3.455, 9.625, -7.375))
        assert "lies 7.375 in behind camera 1" in behind, method
        assert "check its signs" in behind
    # a calibrated floor, tilted 10 deg: normal . p = height, widened by its height's sigma
    from twopose.pair.calibration import FloorPlane

    a = np.radians(10.0)
    cov = np.diag([0.0, 0.0, 0.0, 0.01**2])
    floor = FloorPlane(normal=np.array([0.0, np.cos(a), np.sin(a)]), height=9.0, cov=cov)
    tilted = dataclasses.replace(thesis_pair(), floor=floor)
    on = (1.0, 9.0 / np.cos(a) - 20.0 * np.tan(a), 20.0)
    assert touch_refusal(Method.GROUND, tilted, Units.IN, on) == ""
    assert touch_refusal(Method.GROUND, tilted, Units.IN, (on[0], on[1] + 0.06, on[2])) == ""
    said = touch_refusal(Method.GROUND, tilted, Units.IN, (on[0], on[1] + 0.08, on[2]))
    assert "normal . p = 9 in, normal (0.0000, 0.9848, 0.1736)" in said


class _Typed(StreamDriver):
    """The operator types a point off the floor, then one on it, then ends the trial."""

    def __init__(self) -> None:
        self.calls = 0
        self.said: list[str] = []

    def events(self) -> list[StreamEvent]:
        self.calls += 1
        if self.calls == 6:
            return [
                StreamEvent(kind="touch", at_ns=1, point=(3.455, 0.0, 7.375)),
                StreamEvent(kind="touch", at_ns=1, point=(3.455, 9.625, 7.375)),
            ]
        return [StreamEvent(kind="end")] if self.calls == 10 else []

    def refused(self, message: str) -> None:
        self.said.append(message)


def test_a_typed_ground_touch_off_the_floor_is_refused_in_words(
    tmp_path: Path, stills: str
) -> None:
    setup = PairSetup(method=Method.GROUND, units=Units.IN, operator="Ada", plane_offset=9.625)
    pair = setup.session_pair(dataclasses.replace(thesis_pair(), floor=None))
    source = open_pair_source(stills, pair, setup, fps=None)
    driver, out = _Typed(), tmp_path / "typed.mcap"
    ground = setup.ground()
    record_stream(out, setup.info(), pair_cameras(pair), pair, source, driver, ground=ground)
    assert len(driver.said) == 1
    assert "-9.625 in off the ground" in driver.said[0]
    with SessionReader(out) as reader:
        (trial,) = read_pair_session(reader).trials
    assert [t.point for t in trial.touches] == [(3.455, 9.625, 7.375)]


def test_the_console_refuses_a_ground_touch_off_the_floor(tmp_path: Path) -> None:
    from recorder.console.state import ConsoleSession
    from recorder.console.stream_driver import begin_pair, stream_answer

    session = ConsoleSession(tmp_path / "s.mcap")
    setup = PairSetup(method=Method.GROUND, units=Units.IN, operator="Ada", plane_offset=9.625)
    begin_pair(session, setup, setup.session_pair(dataclasses.replace(thesis_pair(), floor=None)))
    session.update(waiting="streaming")
    why, errors = stream_answer(session, {"action": "touch", "x": "3", "y": "0", "z": "7"}, 5)
    assert "off the ground (y = 9.625 in" in why
    assert errors == {"touch": why}
    assert stream_answer(session, {"action": "touch", "x": "3", "y": "9.625", "z": "7"}, 5) == (
        "",
        {},
    )


def test_a_plans_ground_touch_off_the_floor_is_refused_before_recording(
    tmp_path: Path, stills: str
) -> None:
    plan = _plan(tmp_path, _GROUND + "ground_height = 9.625\n[[trials]]\nduration = 0.2\n"
                 "touches = [{point = [1.455, 0.0, 7.375], at = 0.1}]\n")  # fmt: skip
    out = tmp_path / "off.mcap"
    with pytest.raises(InputValueError, match=r"trials\[1\]\.touches\[1\]\.point: .* off the"):
        record_pair(out, _no_floor(tmp_path), stills, Operator(_never_asked, print),
                    plan_path=plan, keys=KeyReader(lambda: ""))  # fmt: skip
    assert not out.exists()


def test_a_plans_keyed_touch_with_nobody_at_the_input_is_said_from_the_command_line(
    tmp_path: Path, stills: str
) -> None:
    """``new --plan`` with a keyed touch and the input closed (``< /dev/null``): said, the
    trial incomplete, what was recorded kept (it was "0 touches", said as complete)."""
    plan = _plan(tmp_path, _GROUND + "ground_height = 9.625\n[[trials]]\nduration = 0.2\n"
                 "touches = [{point = [1.455, 9.625, 7.375]}]\n")  # fmt: skip
    out = tmp_path / "keyed.mcap"
    result = _new_with_plan(out, _no_floor(tmp_path), stills, plan)
    assert result.exit_code == 0, result.output
    assert "the input ended: 1 keyed touch(es) of this trial cannot be marked" in result.output
    assert "incomplete: no touches (nothing to measure)" in result.output
    assert "1 stream trial (0 complete)" in result.output
    assert out.exists()


def test_a_plan_without_the_ground_height_it_needs_is_refused_before_asking(
    tmp_path: Path, stills: str
) -> None:
    plan = _plan(tmp_path, _GROUND + "[[trials]]\nduration = 0.2\n")
    out = tmp_path / "nofloor.mcap"
    with pytest.raises(InputValueError, match=r"plan: ground_height is missing: .* add ground_h"):
        record_pair(out, _no_floor(tmp_path), stills, Operator(_never_asked, print),
                    plan_path=plan, keys=KeyReader(lambda: ""))  # fmt: skip
    assert not out.exists()
    result = _new_with_plan(out, _no_floor(tmp_path), stills, plan)
    assert result.exit_code == 3, result.output
    assert "ground_height is missing" in result.output
    assert "interrupted" not in result.output


@pytest.mark.parametrize(
    ("touches", "said"),
    [
        ("{point = [1, 2, 9], at = 1}, {point = [3, 2, 9], at = 1}",
         r"touches\[2\]\.at 1 s is the same moment as trials\[1\]\.touches\[1\]\.at 1 s"),
        ("{point = [1, 2, 9], at = 2}, {point = [4, 5, 9]}, {point = [3, 2, 9], at = 1}",
         r"touches\[3\]\.at 1 s is before trials\[1\]\.touches\[1\]\.at 2 s"),
    ],
)  # fmt: skip
def test_scheduled_touches_out_of_order_or_at_one_moment_are_refused(
    tmp_path: Path, touches: str, said: str
) -> None:
    with pytest.raises(InputValueError, match=said):
        load_stream_plan(_plan(tmp_path, f'method = "point"\n[[trials]]\ntouches = [{touches}]\n'))


def test_a_trial_with_nothing_to_measure_is_incomplete() -> None:
    empty = TrialEnd(trial=1, why="end", n_frames=(0, 0), touches=())
    assert not empty.complete
    assert empty.line().endswith("incomplete: no frames from camera 1 or camera 2")
    summary = StreamSummary(path=Path("s.mcap"), trials=[empty])
    assert "1 stream trial (0 complete)" in summary.line()
    cut = TrialEnd(trial=1, why="camera 2 stopped", n_frames=(5, 0), touches=())
    assert cut.line().endswith("incomplete: camera 2 stopped")


def test_the_help_shows_the_bounds_and_choices_taken() -> None:
    def helped(*command: str) -> str:
        return " ".join(CliRunner().invoke(app, [*command, "--help"]).output.split())

    assert "--speed <(0-100] in/s>" in helped("simulate")
    assert re.search(r"--method <point\|line\|ground>", helped("point"))
    assert "with --pair: pair:A,B" in helped("new")


def test_the_keys_after_an_end_are_the_next_trials_and_the_input_end_ends_the_session() -> None:
    """Lines typed ahead (a pipe: touch, e, then the end of the input) are taken in turn:
    the trial ends at ``e`` and the end of the input, read after it, ends the session (it
    was lost with the trial's events, and the session waited for a key for ever)."""
    import threading
    import time

    from recorder.procedure.stream_terminal import TerminalStreamDriver

    lines = iter(["1, 2, 3\n", "e\n"])
    keys = KeyReader(lambda: next(lines, ""))
    keys.start()
    while keys.lines.qsize() < 3:  # both lines and the end of the input are queued
        time.sleep(0.005)
    driver = TerminalStreamDriver(lambda _line: None, keys, Units.IN)
    assert [e.kind for e in driver.events()] == ["touch", "end"]
    answer: list[bool] = []
    waits = threading.Thread(target=lambda: answer.append(driver.next_trial(2)), daemon=True)
    waits.start()
    waits.join(timeout=5)
    assert answer == [False]


def test_an_enter_read_with_the_input_end_still_takes_its_keyed_point(tmp_path: Path) -> None:
    """A script's Enter and then the input's end, read in one go: the Enter touches the
    plan's keyed point; only the keyed touches left after it are said lost."""
    import time

    from recorder.procedure.stream_terminal import TerminalStreamDriver

    text = 'method = "point"\n[[trials]]\ntouches = [{point = [1, 2, 9]}, {point = [3, 2, 9]}]\n'
    plan = load_stream_plan(_plan(tmp_path, text))
    lines = iter(["\n"])
    keys = KeyReader(lambda: next(lines, ""))
    keys.start()
    while keys.lines.qsize() < 2:
        time.sleep(0.005)
    said: list[str] = []
    driver = TerminalStreamDriver(said.append, keys, Units.IN, plan)
    driver.streaming(1)
    events = driver.events()
    # the Enter's touch first; then, the trial having no duration, the end of it all
    assert [(e.kind, e.point) for e in events] == [("touch", None), ("quit", None)]
    assert driver.next_point(1) == (1.0, 2.0, 9.0)
    assert any("the input ended: 1 keyed touch(es)" in line for line in said), said
    assert any("the trial and the session end here" in line for line in said), said


def test_a_pair_whose_check_failed_records_with_a_warning_said_first(
    tmp_path: Path, stills: str
) -> None:
    """A new user's finding: a pair file whose leave-one-out check failed recorded without a
    word; the regions of everything it records carry that covariance."""
    from twopose.pair.holdout import HoldoutCheck

    failed = HoldoutCheck(
        folds=13, spacings=624, worst_sigmas=9.5, beyond=40, median_error=0.01,
        median_sigma=0.02, jackknife_ratio=(1.0,) * 6,
    )  # fmt: skip
    pair = tmp_path / "FAILED.toml"
    write_pair_file(pair, dataclasses.replace(thesis_pair(), floor=None, check=failed))
    plan = _plan(tmp_path, _GROUND + "ground_height = 9.625\n[[trials]]\nduration = 0.2\n"
                 "touches = [{point = [1.455, 9.625, 7.375], at = 0.1}]\n")  # fmt: skip
    result = _new_with_plan(tmp_path / "s.mcap", pair, stills, plan)
    assert result.exit_code == 0, result.output
    said = " ".join(result.output.split())
    assert "warning: the pair's covariance is not confirmed (its leave-one-out check" in said
    assert said.index("not confirmed") < said.index("trial 1")


@pytest.mark.parametrize("scheduled", [False, True])
def test_a_plan_trial_without_duration_and_nobody_at_the_input_ends(
    tmp_path: Path, scheduled: bool
) -> None:
    """A new user's finding: a plan trial with a keyed touch and no ``duration`` under
    ``< /dev/null`` said the touch could not be marked, then streamed until killed (0.8 MB
    a second); nothing could end it. It ends (after its last scheduled touch, if any), and
    with it the session."""
    touches = "{point = [1.455, 9.625, 7.375]}"
    if scheduled:
        touches += ", {point = [1.0, 9.625, 7.375], at = 0.5}"
    plan = _plan(tmp_path, _GROUND + f"ground_height = 9.625\n[[trials]]\ntouches = [{touches}]\n")
    out = tmp_path / "endless.mcap"
    started = time.monotonic()
    result = _new_with_plan(out, _no_floor(tmp_path), "pair:synthetic,synthetic", plan)
    assert time.monotonic() - started < 30
    assert result.exit_code == 0, result.output
    said = " ".join(result.output.split())
    when = "after its last scheduled touch" if scheduled else "here"
    assert f"the trial and the session end {when}" in said
    assert ("1 touch (1 by schedule)" in said) is scheduled
    assert out.exists()


def test_the_console_says_a_trial_is_closing_while_its_offset_is_measured(tmp_path: Path) -> None:
    """A new user's finding: a start pressed in the second after end (the trial's offset
    being measured) was refused with the last trial's summary as its reason."""
    from recorder.console.state import ConsoleSession
    from recorder.console.stream_driver import WebStreamDriver, begin_pair, stream_answer
    from recorder.procedure.stream import TrialEnd

    session = ConsoleSession(tmp_path / "s.mcap")
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    begin_pair(session, setup, setup.session_pair(thesis_pair()))
    driver = WebStreamDriver(session)
    driver.streaming(1)
    session.update(waiting="")  # the recorder took the end: it offers nothing now
    driver.trial_ended(TrialEnd(trial=1, why="end", n_frames=(184, 183), touches=()))
    why, _ = stream_answer(session, {"action": "start"}, 5)
    assert why.startswith("not now: trial 1 is closing (the clocks' offset is being measured")
    assert "frames 184 + 183" not in why
    driver.offset(1, None, "")
    why, _ = stream_answer(session, {"action": "start"}, 5)
    assert "is closing" not in why
