"""A session two operators recorded (a `--continue --operator Bob` part of Ada's session;
a new user's r5 F10): it was analysed as Ada's, one multiplier for both hands, pooled with
Ada's other sessions, and nothing said. Each operator's parts are now a session of their
own (their multiplier, their pool), and the run says so."""

from __future__ import annotations

from pathlib import Path

from analysis.batch.inputs import resolve_inputs
from analysis.batch.noise_pass import operator_heads
from tests.lab import continue_session, record


def test_each_operators_parts_are_a_session_of_their_own(tmp_path: Path) -> None:
    s, bob, more = tmp_path / "s.mcap", tmp_path / "s_bob.mcap", tmp_path / "s_more.mcap"
    other = tmp_path / "t.mcap"
    record(s, 2)  # the lab's operator "lab"
    continue_session(s, bob, 1, operator="Bob")
    continue_session(bob, more, 1, operator="Bob")
    record(other, 2)
    inputs = resolve_inputs([s, bob, more, other])
    assert inputs.of_operators == {str(s): ("lab", "Bob")}
    strands = {st.head: st.later for st in inputs.strands}
    assert strands[str(s)] == ()
    assert strands[str(bob)] == (str(more),)  # Bob's two parts: one session
    said = " ".join(inputs.run_notes())
    assert (
        f"{s}: its parts were recorded by 2 operators (lab, Bob): each operator's parts are "
        f"analysed as a session of their own ({s}, {bob})"
    ) in said
    assert f"{bob}: continues" not in said  # not "one session with" it any more
    heads = operator_heads(inputs, inputs.files)
    assert heads[str(s)][0] == "lab"
    assert heads[str(bob)][0] == "Bob"
    assert heads[str(other)][0] == "lab"


def test_a_continuation_by_the_same_operator_is_one_operators_session(tmp_path: Path) -> None:
    s, more = tmp_path / "s.mcap", tmp_path / "s2.mcap"
    record(s, 2)
    continue_session(s, more, 1, operator=" lab ")
    inputs = resolve_inputs([s, more])
    assert inputs.of_operators == {}
    assert [(st.head, st.later) for st in inputs.strands] == [(str(s), (str(more),))]
    assert "operators" not in " ".join(inputs.run_notes())
