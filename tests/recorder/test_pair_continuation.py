"""A two-camera session continued: ``new S2.mcap --continue S.mcap --source pair:A,B``.

The first part is recorded from a plan (the moving dot's two video files of
tests/recorder/moving_pair.py, camera 2's clock 30 ms behind); it is continued by a plan,
by the keys at the terminal, in the console and killed with -9 (then recovered): each
continuation keeps the stored pair, floor and identity, numbers its stream trials on,
measures its own clock offset, and the analysis reads the parts as one session. Mixed
one/two-camera continuations and another pair are refused in words.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import analysis
from recorder.cli.app import app as record
from recorder.procedure.stream_terminal import KeyReader, record_pair
from recorder.procedure.terminal import Operator
from recorder.setup.continuation import read_continued
from tests.conftest import built_once
from tests.helpers import RECORD
from tests.recorder.moving_pair import (
    PHASE_S,
    ConsoleOf,
    MovingPair,
    killed_while_streaming,
    moving_pair,
    timed_keys,
    write_moving_pair,
)
from twopose.format.pair_convert import pair_entry
from twopose.format.reader import SessionReader
from twopose.format.streams import PairSession, read_pair_session

#: A plan's trial: the dot's first three touch points at their stays' middles (the files
#: play from the pair's start), 4.4 s: the dot moves twice, which fixes the clock offset.
_TRIAL = (
    "[[trials]]\nduration = 4.4\ntouches = [{point = [0.75, 0.5, 11], at = 1.05}, "
    "{point = [2.75, 0.5, 11], at = 2.55}, {point = [2.75, 2.5, 11], at = 4.05}]\n"
)


def _write(folder: Path) -> None:
    write_moving_pair(folder)


@pytest.fixture(scope="module")
def moving(tmp_path_factory: pytest.TempPathFactory) -> MovingPair:
    return moving_pair(built_once(tmp_path_factory, "moving-pair", _write))


def _plan(folder: Path, operator: str = "Ada", body: str = _TRIAL) -> Path:
    path = folder / f"plan_{operator}.toml"
    path.write_text(f'method = "point"\nunits = "in"\noperator = "{operator}"\n{body}')
    return path


def _quiet() -> Operator:
    return Operator(lambda _q, _d: "", lambda _line: None)


@pytest.fixture(scope="module")
def first(moving: MovingPair, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The session's first part: one stream trial of three scheduled touches."""
    folder = tmp_path_factory.mktemp("first")
    out = folder / "s1.mcap"
    summary = record_pair(
        out, moving.pair_file, moving.source, _quiet(), plan_path=_plan(folder),
        keys=KeyReader(lambda: ""),
    )  # fmt: skip
    assert summary.trials[0].complete, summary.line()
    return out


def _session(path: Path) -> PairSession:
    with SessionReader(path) as reader:
        return read_pair_session(reader)


def test_a_plan_continues_a_pair_session_analysed_as_one(
    moving: MovingPair, first: Path, tmp_path: Path
) -> None:
    out = tmp_path / "s2.mcap"
    said: list[str] = []
    summary = record_pair(
        out, None, moving.source, Operator(lambda _q, _d: "", said.append),
        plan_path=_plan(tmp_path, "Bo"), keys=KeyReader(lambda: ""),
        continued=read_continued(first),
    )  # fmt: skip
    assert summary.trials[0].complete, said
    assert "trial 2: streaming; it ends after 4.4 s (e: now); q quits" in said
    one, two = _session(first), _session(out)
    # the same session, a part of its own, its trials numbered on
    assert two.info.session_id == one.info.session_id
    assert two.info.part_id != one.info.part_id
    assert (two.info.continues_after_trial, two.info.continues_file) == (1, first.name)
    assert two.info.operator == "Bo"  # who recorded this part: the plan's operator
    assert [t.trial for t in two.trials] == [2]
    # the stored pair and floor, and the cameras' clocks
    assert pair_entry(two.pair, ("cam1", "cam2")) == pair_entry(one.pair, ("cam1", "cam2"))
    assert two.ground == one.ground
    assert two.clocks == one.clocks == {"cam1": "simulated", "cam2": "simulated"}
    # its own clock offset, measured from its frames as in the first part
    assert two.offset is not None
    assert one.offset is not None
    assert abs(two.offset.offset_ns + PHASE_S * 1e9) < 4 * two.offset.sigma_ns + 1e6
    # one session: the touches of both parts, each trial with its part's offset, and each
    # part's rows what that part gives alone (one long recording, where that applies)
    result = analysis.run([str(out), str(first)])
    both = result.trials.sort_values("trial")
    # the report says each part's own offset, as the analysis uses them (r7 K9)
    offsets_said = result.sessions[0].metadata["clock_offset"]
    assert offsets_said.startswith("by part: ")
    assert offsets_said.count(" ms ± ") == 2
    # two operators' parts of a two-camera session: no placing multiplier to share, so no
    # note that it has one (a new user's r7 K9)
    from analysis.batch.inputs import resolve_inputs

    inputs = resolve_inputs([out, first])
    assert inputs.of_operators == {}
    assert "operators" not in " ".join(inputs.run_notes())
    alone = [analysis.run([str(p)]).trials for p in (first, out)]
    assert list(both["trial"]) == [1, 2, 3, 4, 5, 6]
    assert list(both["touch"]) == [f"trial {t}, touch {k}" for t in (1, 2) for k in (1, 2, 3)]
    assert both["session_id"].nunique() == 1
    assert (both["status"] == "ok").all(), both[["status", "reason"]]
    assert both["part"].tolist() == [one.info.part_id] * 3 + [two.info.part_id] * 3
    offsets = [p.offset.offset_ns / 1e6 for p in (one, two) if p.offset is not None]
    np.testing.assert_allclose(both["clock_offset_ms"], np.repeat(offsets, 3))
    joined = np.concatenate([a.sort_values("trial")["err"].to_numpy() for a in alone])
    np.testing.assert_allclose(both["err"].to_numpy(), joined, rtol=1e-12)
    assert both["err"].max() < 0.05  # inches: the dot still at each touch


def test_the_keys_continue_a_pair_session(moving: MovingPair, first: Path, tmp_path: Path) -> None:
    """At the terminal: Enter starts trial 2, a point typed then Enter is a touch, e ends
    the trial, q the session (the keys timed, in-process)."""
    readline = timed_keys([(0.2, ""), (1.2, "0.75, 0.5, 11"), (0.3, "e"), (0.3, "q")])
    said: list[str] = []
    out = tmp_path / "keys.mcap"
    summary = record_pair(
        out, moving.pair_file, moving.source, Operator(lambda _q, _d: "", said.append),
        keys=KeyReader(readline), continued=read_continued(first, operator="Cy"),
    )  # fmt: skip
    assert "trial 2: Enter starts its stream; q ends the session" in said
    assert summary.trials[0].why == "end"
    session = _session(out)
    (trial,) = session.trials
    assert trial.trial == 2
    assert [(t.how, t.point) for t in trial.touches] == [("key", (0.75, 0.5, 11.0))]
    assert session.info.operator == "Cy"


def _pair_file_moved(moving: MovingPair, folder: Path) -> Path:
    import dataclasses

    from twopose.pair.pair_file import read_pair_file, write_pair_file

    pair = read_pair_file(moving.pair_file)
    other = folder / "OTHER.toml"
    moved = pair.t_2_in_1 + np.array([0.5, 0.0, 0.0])
    write_pair_file(other, dataclasses.replace(pair, t_2_in_1=moved))
    return other


def test_a_continuation_is_refused_in_words_another_pair_or_one_camera(
    moving: MovingPair, first: Path, tmp_path: Path
) -> None:
    from recorder.procedure.stream_terminal import PairSetup

    runner = CliRunner()
    sample = sorted(Path("sessions").glob("thesis_*.mcap"))[0]  # a one-camera session

    def refused(*args: str) -> str:
        done = runner.invoke(record, ["new", str(tmp_path / "x.mcap"), *args])
        assert done.exit_code in (2, 3), done.output
        assert "Traceback" not in done.output
        assert not (tmp_path / "x.mcap").exists()
        return " ".join(done.output.split())

    other = _pair_file_moved(moving, tmp_path)
    said = refused("--continue", str(first), "--pair", str(other), "--source", moving.source)
    assert f"is not the pair {first.name} recorded: camera 2's pose (by 0.5 in" in said
    said = refused("--continue", str(first), "--source", "synthetic")
    assert "a two-camera session (stream trials of a pair): its continuation records both" in said
    said = refused("--continue", str(sample), "--pair", str(moving.pair_file),
                   "--source", moving.source)  # fmt: skip
    assert "a one-camera session (typed poses)" in said
    said = refused("--continue", str(first), "--source", moving.source, "--method", "line")
    assert "a continuation keeps the setup" in said
    line_plan = tmp_path / "line.toml"
    line_plan.write_text(_plan(tmp_path).read_text().replace('"point"', '"line"'))
    said = refused("--continue", str(first), "--source", moving.source, "--plan", str(line_plan))
    assert "a continuation keeps the session's setup" in said
    # the same pair file is the session's pair: taken
    setup = PairSetup.continuing(read_continued(first), moving.pair_file)
    assert setup.first_trial == 2


def test_kill_9_of_a_continuation_loses_at_most_its_open_window(
    moving: MovingPair, first: Path, tmp_path: Path
) -> None:
    from recorder.recover import RECOVERED_REASON, recover_session

    out = tmp_path / "killed.mcap"
    plan = _plan(tmp_path, "Bo", _TRIAL.replace("duration = 4.4\n", ""))
    process = subprocess.Popen(
        [str(RECORD), "new", str(out), "--continue", str(first), "--source", moving.source,
         "--plan", str(plan)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    killed_after = killed_while_streaming(process)
    fixed = tmp_path / "fixed.mcap"
    assert recover_session(out, fixed).closed_windows == 2
    session = _session(fixed)
    assert session.info.continues_after_trial == 1
    assert session.info.session_id == _session(first).info.session_id
    (trial,) = session.trials
    assert trial.trial == 2
    for stream in trial.cameras:
        assert all(w.status == "complete" for w in stream.windows[:-1])
        assert stream.windows[-1].reason == RECOVERED_REASON
        assert len(stream) >= 10 * (killed_after - 1.0) - 3, (len(stream), killed_after)
    assert len(trial.touches) >= 2  # the schedule's, at 1.05 s and 2.55 s
    both = analysis.run([str(first), str(fixed)]).trials
    assert both["session_id"].nunique() == 1
    assert len(both) == 3 + len(trial.touches)


def test_the_console_continues_a_pair_session(
    moving: MovingPair, first: Path, tmp_path: Path
) -> None:
    """``new --continue S.mcap --source pair:A,B --ui``: the page says what it continues,
    offers trial 2, and its touch is recorded in trial 2."""

    out = tmp_path / "console.mcap"
    process = subprocess.Popen(
        [str(RECORD), "new", str(out), "--continue", str(first), "--source", moving.source,
         "--ui"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        console = ConsoleOf.of(process)
        client, state_when = console.client, console.state_when

        offered = state_when("trial")
        assert any(f"Continuing {first.name} after trial 1" in n for n in offered["notices"])  # type: ignore[attr-defined]
        assert "trial 2:" in str(offered["message"])
        # the page shows the trial offered as the one after the stream's last: trial 2
        assert offered["stream"]["trial"] == 1  # type: ignore[index]
        assert client.post("/api/stream", json={"action": "start"}).json() == {"ok": True}
        state_when("streaming")
        time.sleep(1.0)
        touch = {"action": "touch", "x": "0.75", "y": "0.5", "z": "11"}
        assert client.post("/api/stream", json=touch).json() == {"ok": True}
        time.sleep(0.3)
        assert client.post("/api/stream", json={"action": "stop"}).json() == {"ok": True}
        for _ in range(200):
            if client.get("/api/state").json()["phase"] == "done":
                break
            time.sleep(0.025)
        process.terminate()
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    session = _session(out)
    (trial,) = session.trials
    assert trial.trial == 2
    assert [t.how for t in trial.touches] == ["button"]
    assert session.info.continues_after_trial == 1


def test_a_continuation_says_a_camera_clock_other_than_its_sessions(first: Path) -> None:
    """Each part records its own cameras' clocks; one that differs from the part continued
    (a camera's driver stamps there, a video file's clock here) is said in its notes."""
    from types import SimpleNamespace

    from recorder.procedure.stream_source import with_clocks

    continued = read_continued(first)
    info = continued.info_for()
    stills = SimpleNamespace(  # a pair of folders: their clocks without a frame read
        stills=True, cameras=(SimpleNamespace(clock="driver"), SimpleNamespace(clock="simulated"))
    )
    said = with_clocks(info, stills)  # type: ignore[arg-type]
    assert said.clocks == {"cam1": "driver", "cam2": "simulated"}
    assert f"camera cam1's clock is driver here, simulated in {first.name}" in said.notes
    assert "cam2" not in said.notes
    same = with_clocks(info, SimpleNamespace(stills=True, cameras=(stills.cameras[1],) * 2))  # type: ignore[arg-type]
    assert same.notes == info.notes


def test_a_ground_pair_session_keeps_its_floor_a_plan_giving_another_is_refused(
    tmp_path: Path,
) -> None:
    """A ground session whose pair file had a floor: its continuation keeps that floor; a
    plan's ground height must be it; a pair file is the same pair without its floor (the
    typed case), not with another."""
    import dataclasses

    from recorder.procedure.stream_terminal import PairSetup
    from recorder.setup.pair_continuation import pair_differs
    from recorder.setup.stream_plan import StreamPlan
    from tests.twopose.format.pair_examples import calibrated_pair, write_pair_session
    from twopose.errors import InputValueError
    from twopose.methods.specs import Method
    from twopose.values.units import Units

    path = tmp_path / "ground.mcap"
    write_pair_session(path, trials=1, frames=2, pair=calibrated_pair())
    continued = read_continued(path)
    stored = continued.pair
    assert stored is not None
    assert stored.floor is not None
    assert continued.ground is not None
    height = continued.ground.offset
    setup = PairSetup.continuing(continued)
    assert setup.session_pair(None) is stored
    assert setup.ground() == continued.ground
    assert (setup.method, setup.first_trial) == (Method.GROUND, 2)

    def plan(offset: float) -> StreamPlan:
        return StreamPlan(method=Method.GROUND, units=Units.IN, trials=(), plane_offset=offset)

    PairSetup.continuing(continued, plan=plan(height))  # the session's floor: taken
    with pytest.raises(InputValueError, match=r"ground height 1 is not the floor of ground\.mcap"):
        PairSetup.continuing(continued, plan=plan(1.0))
    assert pair_differs(stored, calibrated_pair()) == ""  # the file's, in its own mm
    assert pair_differs(stored, dataclasses.replace(calibrated_pair(), floor=None)) == ""
    lower = dataclasses.replace(stored.floor, height=stored.floor.height - 1.0)
    assert pair_differs(stored, dataclasses.replace(stored, floor=lower)) == "the floor"
