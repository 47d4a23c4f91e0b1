"""What the page shows and what the server takes are one state (issue 55, 1), in process:
the recorder offers a step with the status that asks for it; an answer is taken only while
it is offered (closing the offer at once) or refused in words; answers are read in the order
given, a decision given while the preview result is computed included; a decision answers
the offer the page showed; quit taken, nothing more is asked for."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest

from recorder.console.driver import WebDriver
from recorder.console.state import DECISIONS, ConsoleSession
from recorder.procedure.driver import Decision
from recorder.setup.rules import PoseTyping

ASKED = "trial 1 pose 2: accept, redo, undo or quit"


def _deciding(tmp_path: Path) -> ConsoleSession:
    """A session recording trial 1, its pose 2 captured and offered for a decision."""
    session = ConsoleSession(tmp_path / "s.mcap")
    session.update(phase="recording", trial=1, pose=2, shortfall="ok")
    session.poses = [
        {"pose": 1, "t": [0.0, 0.0, 0.0], "r_deg": [0.0, 0.0, 0.0], "state": "accepted"},
        {"pose": 2, "t": [1.0, 0.0, 0.0], "r_deg": [0.0, 0.0, 0.0], "state": "awaiting decision"},
    ]
    session.offer("decision", anew=True, offers=["accept", "redo", "undo"], message=ASKED)
    return session


def _decision(choice: str) -> tuple[str, Decision]:
    return choice, DECISIONS[choice]


def test_a_decision_is_taken_only_while_offered_and_the_offer_closes_at_once(
    tmp_path: Path,
) -> None:
    session = _deciding(tmp_path)
    state = session.snapshot()
    assert (state["waiting"], state["offers"], state["message"]) == (
        "decision", ["accept", "redo", "undo"], ASKED,
    )  # fmt: skip
    assert session.take("decision", _decision("accept"), seen=state["offer"]) == ""
    state = session.snapshot()
    assert state["waiting"] == ""  # no second decision for this capture
    assert "trial 1 pose 2 accepted: computing" in state["computing"]
    assert [p["state"] for p in state["poses"]] == ["accepted", "accepted"]
    assert session.take("decision", _decision("redo")) == (
        "not now: accept was taken for trial 1 pose 2"
    )
    assert session.answer(0.0) == ("decision", _decision("accept"))
    assert session.answer(0.0) is None  # the refused one was never queued


def test_what_is_not_offered_is_refused_in_words(tmp_path: Path) -> None:
    session = ConsoleSession(tmp_path / "s.mcap")
    assert session.take("decision", _decision("accept")).startswith("not now: start the session")
    session = _deciding(tmp_path)
    session.update(shortfall="none", offers=["redo", "undo"])
    assert "not found in any frame" in session.take("decision", _decision("accept"))
    session.update(pose=1)
    assert session.take("decision", _decision("undo")).startswith("nothing to undo")
    assert session.take("pose", ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))).startswith("not now:")
    session.update(waiting="", capture={"frame": 3, "n_frames": 40})
    session.frames_of = {"trial": 1, "pose": 1}
    assert session.take("decision", _decision("redo")) == (
        "not now: trial 1 pose 1 is being captured (frame 3 of 40); decide once it is done"
    )
    assert session.take("note", "lamp") == "add a note after a capture (it goes with that trial)"


def test_a_decision_answers_the_offer_the_page_showed(tmp_path: Path) -> None:
    """A key pressed while a pose was captured (the page showed no offer: 0) is not taken
    for the capture that ended meanwhile; nor a click on an earlier capture's offer."""
    session = _deciding(tmp_path)
    offer = session.snapshot()["offer"]
    for seen in (0, offer - 1):
        why = session.take("decision", _decision("accept"), seen=seen)
        assert why.startswith("not now: given before trial 1 pose 2's decision was asked")
    assert session.take("decision", _decision("accept"), seen=offer) == ""


def test_once_quit_is_taken_nothing_is_asked_for(tmp_path: Path) -> None:
    """Issue 55's clicks test: quit taken while a pose was captured, the capture's end then
    said "accept, redo, undo or quit" with every button off."""
    session = ConsoleSession(tmp_path / "s.mcap")
    session.update(phase="recording", trial=1, pose=1)
    assert session.take("quit") == ""
    session.offer(
        "decision", anew=True, offers=["accept", "redo", "undo"], message=ASKED, shortfall="ok"
    )
    state = session.snapshot()
    assert state["waiting"] == ""
    assert state["message"] == "quit: the session is being closed"
    assert state["shortfall"] == "ok"  # the capture's own numbers are still shown
    assert session.take("decision", _decision("accept")).startswith("not now: quit was taken")


def test_a_decision_given_while_the_preview_is_computed_is_the_one_recorded(
    tmp_path: Path,
) -> None:
    """Issue 55: accept was on only once the preview result came (0.5 s after the status
    asked for it); a click in between was lost, and quit then discarded the capture. The
    driver offers the decision as the capture ends and reads what was given meanwhile."""
    session = _deciding(tmp_path)
    driver = WebDriver(session, None, "cam0", (), PoseTyping(poses_per_trial=2))
    given = threading.Event()

    def click() -> None:  # while the recorder computes the preview result
        assert session.take("decision", _decision("accept"), seen=session.offer_id) == ""
        assert session.take("quit") == ""
        given.set()

    threading.Thread(target=click).start()
    assert given.wait(5)
    result: Any = None
    assert driver.decide(1, 2, result) is Decision.ACCEPT  # the accept, not the quit
    assert session.snapshot()["waiting"] == ""  # read as given: not offered again


@pytest.mark.parametrize("kind", ["pose", "decision", "note"])
def test_an_answer_is_never_read_for_another_step(tmp_path: Path, kind: str) -> None:
    """Taken answers are only those offered: what the recorder reads is what it asked."""
    session = _deciding(tmp_path)
    value: Any = {"pose": ((0.0,) * 3, (0.0,) * 3), "decision": _decision("redo"), "note": "x"}
    why = session.take(kind, value[kind])
    assert (why == "") is (kind != "pose")


def test_a_refusal_is_said_only_while_its_step_lasts(tmp_path: Path) -> None:
    """A decision pressed while a pose was captured is refused in words; once the capture
    ends and its decision is asked for, those words (no longer true) are gone. The
    procedure's own refusal of a decision keeps the capture's offer and its words."""
    session = ConsoleSession(tmp_path / "s.mcap")
    session.update(phase="recording", trial=1, pose=1, message="trial 1 pose 1: capturing")
    why = session.take("decision", _decision("accept"), seen=0)
    session.refuse("accept", why)
    assert session.snapshot()["refusal"]["message"] == why
    session.offer("decision", anew=True, offers=["accept", "redo", "undo"], message=ASKED)
    assert session.snapshot()["refusal"] == {}
    offer = session.snapshot()["offer"]
    assert session.take("decision", _decision("accept"), seen=offer) == ""
    assert session.answer(0.0) is not None
    session.refuse("accept", "capture 1 is incomplete; redo it, or quit")
    session.offer("decision")  # asked again, by the driver, after the refusal
    state = session.snapshot()
    assert (state["offer"], state["waiting"]) == (offer, "decision")
    assert state["refusal"]["message"] == "capture 1 is incomplete; redo it, or quit"
