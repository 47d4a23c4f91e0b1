"""A session two operators recorded (a `--continue --operator Bob` part of Ada's session;
a new user's r5 F10): it was analysed as Ada's, one multiplier for both hands, pooled with
Ada's other sessions, and nothing said. Now it is said, and pooled with neither."""

from __future__ import annotations

from pathlib import Path

from analysis.batch.inputs import resolve_inputs
from analysis.batch.noise_pass import operator_heads
from tests.lab import continue_session, record


def test_a_session_of_two_operators_is_said_and_pooled_with_neither(tmp_path: Path) -> None:
    s, bob, other = tmp_path / "s.mcap", tmp_path / "s_bob.mcap", tmp_path / "t.mcap"
    record(s, 2)  # the lab's operator "lab"
    continue_session(s, bob, 1, operator="Bob")
    record(other, 2)
    inputs = resolve_inputs([s, bob, other])
    assert inputs.of_operators == {str(s): ("lab", "Bob")}
    said = " ".join(inputs.run_notes())
    assert f"{s}: its parts were recorded by 2 operators (lab, Bob)" in said
    assert "pooled with neither operator's other sessions" in said
    heads = operator_heads(inputs, inputs.files)
    assert str(s) not in heads
    assert heads[str(other)][0] == "lab"


def test_a_continuation_by_the_same_operator_is_one_operators_session(tmp_path: Path) -> None:
    s, more = tmp_path / "s.mcap", tmp_path / "s2.mcap"
    record(s, 2)
    continue_session(s, more, 1, operator=" lab ")
    inputs = resolve_inputs([s, more])
    assert inputs.of_operators == {}
    assert "operators" not in " ".join(inputs.run_notes())
    assert str(s) in operator_heads(inputs, inputs.files)
