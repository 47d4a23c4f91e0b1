"""Issue 44 (7, and 2's page half), through the real server: a continuation's page says
what it continues and where each value comes from, keeps the session's stop rule unless
one is given, records ``--operator`` as this part's operator, and its summary counts this
file's trials; a file that is no session is called that, not sent to ``recover``; while
the next suggestion is computed the page's state says so."""

from __future__ import annotations

import re
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from typer.testing import CliRunner

from recorder.cli.app import app as record
from recorder.setup.continuation import read_continued
from tests.helpers import small_session, start_console
from twopose.format.entries import Note
from twopose.format.reader import SessionReader

runner = CliRunner()


@pytest.fixture(scope="module")
def continued(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A one-trial session whose stop rule is 95% within 0.8 in (operator Ada); its scene."""
    return small_session(tmp_path_factory.mktemp("continued"))


def _state(client: httpx.Client, until: Any = None, timeout_s: float = 30) -> dict[str, Any]:
    deadline = time.monotonic() + timeout_s
    while True:
        state: dict[str, Any] = client.get("/api/state").json()
        if until is None or until(state):
            return state
        assert time.monotonic() < deadline, state
        time.sleep(0.02)


def test_the_continuation_page_says_what_it_continues_and_where_each_value_comes_from(
    continued: tuple[Path, Path], tmp_path: Path
) -> None:
    session, scene = continued
    assert read_continued(session).target95 == 0.8  # the stop rule S recorded
    out = tmp_path / "S2.mcap"
    process, url, _ = start_console(
        out, "--source", f"synthetic:{scene}", "--continue", str(session), "--operator", "eve"
    )
    try:
        client = httpx.Client(base_url=url, timeout=10)
        client.get("/")
        state = _state(client)
        assert state["message"].startswith("Continuing S.mcap; the next trial is 2")
        assert state["continuing"]["next_trial"] == 2
        fields = {f["name"]: f for f in state["setup_fields"]}
        for name in ("method", "units", "focal", "principal", "ground_height", "truth1"):
            assert (fields[name]["given"], fields[name]["from"]) == (True, "S.mcap"), name
        # The operator given is this file's; the stop rule is S's, the page's to change.
        assert fields["operator"] == {
            **fields["operator"],
            "given": True,
            "from": "the command line",
            "value": "eve",
        }
        assert fields["target_precision"] == {
            **fields["target_precision"],
            "given": False,
            "from": "S.mcap",
            "value": "0.8",
        }
        form = {"target_precision": "0.8", "operator": ""}  # the operator is fixed: ignored
        assert client.post("/api/setup", json=form).status_code == 200
        state = _state(client, lambda s: s["waiting"] == "pose")
        assert state["setup"]["stop_rule"].endswith("within 0.8 in")
        assert state["setup"]["continues"] == "S.mcap after trial 1"
        assert state["setup"]["operator"] == "eve"
        assert state["message"].startswith("trial 2:")
        assert client.post("/api/pose", json={"x": "0", "y": "0", "z": "0"}).status_code == 200
        _state(client, lambda s: s["waiting"] == "decision")
        assert client.post("/api/decide", json={"decision": "accept"}).status_code == 200
        _state(client, lambda s: s["waiting"] == "pose")
        assert client.post("/api/decide", json={"decision": "quit"}).status_code == 200
        state = _state(client, lambda s: s["phase"] == "done")
        # This file's one trial, not the session's two (S's trial 1 is not counted again).
        assert re.search(r": 1 trial \(0 complete\), 1 capture ", state["summary"]), state
    finally:
        process.terminate()
        said, _ = process.communicate(timeout=30)
    assert said.count(f"wrote {out}: 1 trial (0 complete)") == 1, said
    with SessionReader(out) as reader:
        assert reader.info.operator == "eve"
        assert reader.info.continues_after_trial == 1
        notes = [e.text for e in reader.iter_entries() if isinstance(e, Note)]
    assert any("within 0.8 in" in n for n in notes), notes  # the rule kept, recorded


def test_a_plan_or_the_terminal_continues_with_the_operator_given_and_the_files_rule(
    continued: tuple[Path, Path], tmp_path: Path
) -> None:
    session, scene = continued
    plan = session.with_name("plan.toml").read_text()
    (tmp_path / "p.toml").write_text(
        plan.split("[guidance]")[0] + plan.split("target_95 = 0.8\n")[1]
    )
    out = tmp_path / "P.mcap"
    result = runner.invoke(
        record, ["new", str(out), "--plan", str(tmp_path / "p.toml"), "--continue", str(session),
                 "--operator", "eve", "--source", f"synthetic:{scene}"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"wrote {out}: 1 trial (1 complete)" in result.output  # was "2 trials"
    with SessionReader(out) as reader:
        assert reader.info.operator == "eve"
    # At the terminal: what it continues, the next trial, who records, which rule is kept.
    said = runner.invoke(
        record, ["new", str(tmp_path / "T.mcap"), "--continue", str(session), "--source",
                 f"synthetic:{scene}"], input="",
    ).output  # fmt: skip
    assert "after trial 1: the next trial is 2" in said
    assert "operator Ada; stop rule: 95% within 0.8 in (S.mcap's)" in said


def test_a_file_that_is_no_session_is_called_that_not_sent_to_recover(tmp_path: Path) -> None:
    from mcap.writer import Writer

    csv = tmp_path / "trials.csv"
    csv.write_text("session,trial\nS.mcap,1\n")
    results = tmp_path / "results_00_S.mcap"
    with results.open("wb") as sink:  # what `twopose-analyze run` writes: no session in it
        writer = Writer(sink)
        writer.start(profile="", library="twopose tests")
        schema = writer.register_schema("twopose.TrialResult", "jsonschema", b"{}")
        writer.register_channel("/twopose/results/trials", "json", schema)
        writer.finish()
    for path, said in ((csv, "(a CSV file, not MCAP)"), (results, "an analysis results file")):
        result = runner.invoke(record, ["new", str(tmp_path / "x.mcap"), "--continue", str(path)])
        assert result.exit_code == 3, result.output
        assert "not a session file" in result.output
        assert said in result.output
        assert "recover" not in result.output


@pytest.fixture
def served(tmp_path: Path, continued: tuple[Path, Path]) -> Iterator[tuple[httpx.Client, Any]]:
    """The console's app in this process (so a test can hold the guidance), on the small
    scene's camera, the page loaded: a client and the session."""
    import uvicorn

    from recorder.console.server import ConsoleOptions, console_app
    from recorder.console.state import ConsoleSession

    _, scene = continued
    options = ConsoleOptions(source=f"synthetic:{scene}", given={}, frames=2, size=(320, 240))
    session = ConsoleSession(tmp_path / "s.mcap")
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    server = uvicorn.Server(
        uvicorn.Config(console_app(session, options), log_level="warning", lifespan="on")
    )
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    client = httpx.Client(base_url=f"http://127.0.0.1:{sock.getsockname()[1]}", timeout=10)
    while not server.started:
        time.sleep(0.01)
    client.get("/")
    try:
        yield client, session
    finally:
        session.take("quit")
        session.closing.set()
        server.should_exit = True
        thread.join(timeout=20)
        sock.close()


def test_while_the_next_suggestion_is_computed_the_page_is_told(
    served: tuple[httpx.Client, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The guidance held after an accept: the state says it computes (the page showed
    "accept, redo, undo or quit" with every button off, the pose "awaiting decision")."""
    from recorder.live.result import LiveResults

    client, _ = served
    release = threading.Event()
    advise = LiveResults.advise

    def held(self: LiveResults, *args: Any, **kwargs: Any) -> Any:
        release.wait(timeout=30)
        return advise(self, *args, **kwargs)

    monkeypatch.setattr(LiveResults, "advise", held)
    setup = {"method": "ground", "focal": "262.5", "principal": "160, 120",
             "ground_height": "9.625", "truth1": "1.91, 9.625, 8.375", "operator": "Ada",
             "target_precision": "0.8"}  # fmt: skip
    assert client.post("/api/setup", json=setup).status_code == 200
    _state(client, lambda s: s["waiting"] == "pose")
    assert client.post("/api/pose", json={"x": "0", "y": "0", "z": "0"}).status_code == 200
    _state(client, lambda s: s["waiting"] == "decision")
    assert client.post("/api/decide", json={"decision": "accept"}).status_code == 200
    state = _state(client, lambda s: bool(s["computing"]))
    assert state["waiting"] == ""
    assert "computing the trial's result and the next pose to suggest" in state["computing"]
    assert [p["state"] for p in state["poses"]] == ["accepted"]
    release.set()
    state = _state(client, lambda s: s["waiting"] == "pose")
    assert state["computing"] == ""
    assert state["advice"] is not None
