"""The web console's front door (recorder/console/guard.py) over HTTP, in-process: only
the operator's page drives it and sees it (Host, Origin, the session token, the content
type, the body's size, depth and types, the frame headers), and no state of the recorder
gives the page a 500 (a line whose glove is not found, the same pose typed twice)."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from starlette.testclient import TestClient

from recorder.console.guard import (
    MAX_BODY_BYTES,
    SECURITY_HEADERS,
    ConsoleGuard,
    body_refusal,
    text_refusal,
)
from recorder.console.server import ConsoleOptions, console_app
from recorder.console.state import ConsoleSession
from tests.helpers import SMALL_SCENE
from twopose.rig.constants import RigConstants
from twopose.values.text import is_control
from twopose.values.units import Units

ORIGIN = "http://127.0.0.1:8765"
GIVEN: dict[str, Any] = {
    "method": None, "units": None, "intrinsics": None, "intrinsics_sigma": {}, "focal": None,
    "principal": None, "ground_height": None, "ground_truth": [], "operator": None,
}  # fmt: skip
LINE_SETUP = {
    "method": "line", "units": "in", "focal": "262.5", "principal": "160, 120",
    "truth1": "1.91, 9.625, 8.375", "truth2": "0.5, 2, 7", "operator": "Ada",
}  # fmt: skip
JSON = {"Content-Type": "application/json"}


def strict_json(text: str) -> Any:
    """JSON as browsers parse it: NaN and Infinity are errors."""

    def refuse(name: str) -> None:
        raise AssertionError(f"{name} in the console's JSON")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture
def console(tmp_path: Path) -> Iterator[tuple[TestClient, Path]]:
    """The console in-process (Host 127.0.0.1:8765, the page loaded: the token cookie set)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL_SCENE)
    out = tmp_path / "s.mcap"
    options = ConsoleOptions(source=f"synthetic:{scene}", given=GIVEN, frames=2, size=(320, 240))
    session = ConsoleSession(out, dict(GIVEN, size=(320, 240)))
    with TestClient(console_app(session, options), base_url=ORIGIN) as client:
        assert client.get("/").status_code == 200
        yield client, out


def stranger(client: TestClient) -> TestClient:
    """The same app without the page's cookie: what another site's request carries."""
    return TestClient(client.app, base_url=ORIGIN)


def test_a_foreign_host_is_refused_everywhere(console: tuple[TestClient, Path]) -> None:
    client, _ = console
    for path in ("/", "/main.js", "/api/state", "/stream.mjpg"):
        for host in ("rebind.evil.example:8765", "evil.example", "127.0.0.1.nip.io", ""):
            answer = client.get(path, headers={"Host": host})
            assert answer.status_code == 403, (path, host)
            assert strict_json(answer.text)["error"]
    for host in ("127.0.0.1:8765", "localhost:8765", "LOCALHOST", "[::1]:8765", "127.9.9.9"):
        assert client.get("/api/state", headers={"Host": host}).status_code == 200, host


def test_a_foreign_origin_is_refused_null_included(console: tuple[TestClient, Path]) -> None:
    client, out = console
    for origin in (
        "http://evil.example:8765",
        "null",
        "http://127.0.0.1:9999",  # another local server: another origin
        "http://localhost:8765",  # another name: another origin
        "https://127.0.0.1:8765",
        "file://",
    ):
        answer = client.post("/api/setup", json=LINE_SETUP, headers={"Origin": origin})
        assert answer.status_code == 403, origin
        assert client.get("/api/state", headers={"Origin": origin}).status_code == 403
    assert client.get("/api/state").json()["phase"] == "setup"  # nothing started
    assert not out.exists()
    assert client.get("/api/state", headers={"Origin": ORIGIN}).status_code == 200


def test_a_host_or_origin_given_twice_is_refused(console: tuple[TestClient, Path]) -> None:
    client, out = console
    for doubled in (
        [("Origin", ORIGIN), ("Origin", "http://evil.example")],
        [("Host", "127.0.0.1:8765"), ("Host", "evil.example")],
    ):
        answer = client.post("/api/setup", json=LINE_SETUP, headers=httpx2.Headers(doubled))
        assert answer.status_code == 403, doubled
        assert "twice" in strict_json(answer.text)["error"]
    assert not out.exists()


def test_other_sites_fetch_metadata_is_refused(console: tuple[TestClient, Path]) -> None:
    client, _ = console
    for site in ("cross-site", "same-site"):  # same-site: another port of 127.0.0.1
        headers = {"Sec-Fetch-Site": site}
        assert client.get("/api/state", headers=headers).status_code == 403
        assert client.get("/stream.mjpg", headers=headers).status_code == 403
    for site in ("same-origin", "none"):
        assert client.get("/api/state", headers={"Sec-Fetch-Site": site}).status_code == 200


def test_the_token_is_required_and_set_by_the_page(console: tuple[TestClient, Path]) -> None:
    client, out = console
    other = stranger(client)
    assert other.get("/api/state").status_code == 403
    assert other.get("/stream.mjpg").status_code == 403
    assert other.post("/api/setup", json=LINE_SETUP).status_code == 403
    other.cookies.set("twopose_console_8765", "guessed", domain="127.0.0.1")
    assert other.get("/api/state").status_code == 403
    assert not out.exists()
    page = stranger(client).get("/")
    cookie = page.headers["set-cookie"]
    assert "HttpOnly" in cookie
    assert "SameSite=Strict" in cookie
    assert "Path=/" in cookie
    assert cookie.split(";")[0].startswith("twopose_console_8765=")
    assert page.headers["set-cookie"] == client.get("/").headers["set-cookie"]  # one token
    assert "set-cookie" not in client.get("/api/state").headers  # only the page sets it


def test_posts_must_be_json(console: tuple[TestClient, Path]) -> None:
    client, out = console
    body = json.dumps(LINE_SETUP)
    for kind in ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data", ""):
        answer = client.post("/api/setup", content=body, headers={"Content-Type": kind})
        assert answer.status_code == 415, kind
    assert not out.exists()
    answer = client.post(
        "/api/decide",
        content='{"decision": "accept"}',
        headers={"Content-Type": "application/json; charset=utf-8"},
    )
    assert answer.status_code == 400  # accepted as JSON, refused by the state


def test_a_large_body_is_refused_before_it_is_read(console: tuple[TestClient, Path]) -> None:
    client, _ = console
    big = b'{"text": "' + b"a" * MAX_BODY_BYTES + b'"}'
    answer = client.post("/api/note", content=big, headers=JSON)
    assert answer.status_code == 413

    read = 0

    def chunks() -> Iterator[bytes]:  # no Content-Length: counted as it streams
        nonlocal read
        yield b'{"text": "'
        for _ in range(10_000):
            read += 1
            yield b"a" * 1024
        yield b'"}'

    answer = client.post("/api/note", content=chunks(), headers=JSON)
    assert answer.status_code == 413
    assert "content-length" not in answer.request.headers
    assert strict_json(answer.text)["error"].startswith("the request is larger than 64 KB")


def test_deep_or_mistyped_json_is_a_400(console: tuple[TestClient, Path]) -> None:
    client, _ = console
    deep = "[" * 30_000 + "]" * 30_000  # 60 KB: under the size limit, 30,000 deep
    for body in (
        deep,
        '{"text": ' + "[" * 30 + "]" * 30 + "}",
        '{"text": ["a note", "that is a list"]}',
        '{"text": {"a": "b"}}',
        '{"text": null}',
        '{"text": true}',
        '{"x": NaN, "y": "0", "z": "0"}',
        '{"x": Infinity, "y": "0", "z": "0"}',
        '["text"]',
        '"text"',
        "{not json",
        '{"text": "\xff"}'.encode("latin-1").decode("latin-1"),
    ):
        answer = client.post("/api/note", content=body.encode("latin-1"), headers=JSON)
        assert answer.status_code == 400, body[:40]
        assert strict_json(answer.text)["error"]
    answer = client.post("/api/note", json={"text": ["a", "list"]})
    assert strict_json(answer.text)["errors"] == {"text": "must be text, not list"}


def test_notes_and_operators_have_limits_and_no_control_characters(
    console: tuple[TestClient, Path],
) -> None:
    client, out = console
    for operator in ("A" * 81, "Ada\x1b[2J", "Ada\nroot", "Ada\u202emoc.live"):
        answer = client.post("/api/setup", json=LINE_SETUP | {"operator": operator})
        assert answer.status_code == 400, operator
        assert "operator" in answer.json()["errors"]
    assert not out.exists()
    for text in ("n" * 501, "\x07bell", "a\rb"):
        answer = client.post("/api/note", json={"text": text})
        assert answer.status_code == 400
        assert "text" in answer.json()["errors"]
    assert text_refusal("Ada Lovelace, Zoë Ølstad") == ""
    assert "U+001B" in text_refusal("\x1b[31m")


def test_every_response_forbids_framing(console: tuple[TestClient, Path]) -> None:
    client, _ = console
    answers = [
        client.get("/"),
        client.get("/main.js"),
        client.get("/style.css"),
        client.get("/api/state"),
        client.post("/api/note", json={"text": "too early"}),  # 400
        stranger(client).get("/api/state"),  # 403
        client.get("/api/state", headers={"Host": "evil.example"}),  # 403
        client.post("/api/note", content="x", headers={"Content-Type": "text/plain"}),  # 415
        client.get("/nowhere"),  # 404
    ]
    for answer in answers:
        for name, value in SECURITY_HEADERS.items():
            assert answer.headers[name] == value, (answer.request.url, name)
    policy = SECURITY_HEADERS["Content-Security-Policy"]
    assert "frame-ancestors 'none'" in policy
    assert "script-src 'self'" in policy
    assert SECURITY_HEADERS["X-Frame-Options"] == "DENY"


def test_the_host_the_operator_chose_is_served() -> None:
    async def app(scope: Any, receive: Any, send: Any) -> None:
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"ok"})

    def status(guard_host: str, host: str) -> int:
        client = TestClient(ConsoleGuard(app, host=guard_host), base_url=f"http://{host}")
        return int(client.get("/").status_code)

    assert status("192.168.1.20", "192.168.1.20:8000") == 200
    assert status("192.168.1.20", "192.168.1.21:8000") == 403
    assert status("lab-pc.local", "LAB-PC.local:8000") == 200
    assert status("0.0.0.0", "10.0.0.5:8000") == 200  # any address: a rebinding needs a name
    assert status("0.0.0.0", "rebind.evil.example:8000") == 403
    assert status("::", "[fe80::1]:8000") == 200
    assert status("127.0.0.1", "127.0.0.1:8000") == 200


def test_body_refusal_rules() -> None:
    assert body_refusal(b'{"x": "1", "y": 2, "z": 3.5}') == ("", {})
    assert body_refusal(b"") == ("", {})
    assert body_refusal(b'{"a": "[[[[[[[[[["}') == ("", {})  # brackets in text are text
    assert body_refusal(b'{"a": [[[]]]}')[0].startswith("the request is nested deeper")
    # the field's quantity judges 1e999 in the form's words (the guard: the grammar)
    assert body_refusal(b'{"a": 1e999}') == ("", {})
    # judged as sent: 400 digits would overflow the float math.isfinite makes of them
    _, errors = body_refusal(b'{"decision": ' + b"9" * 400 + b"}")
    assert "not a number of sane size" in errors["decision"]
    assert body_refusal(b'{"x": 1e300}') == ("", {})
    assert body_refusal(b'{"x": -0, "y": 1e-300}') == ("", {})
    why, _ = body_refusal(b'{"decision": "redo", "decision": "accept"}')
    assert "given twice" in why


# -- never blind: a line whose glove is not found, the same pose typed twice


def wait_for(client: TestClient, what: str) -> dict[str, Any]:
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        answer = client.get("/api/state")
        assert answer.status_code == 200, answer.text
        state: dict[str, Any] = strict_json(answer.text)
        assert state["phase"] != "failed", state["message"]
        if state["waiting"] == what:
            return state
        time.sleep(0.02)
    raise AssertionError(f"the console never waited for {what}")


def capture(client: TestClient, pose: dict[str, str]) -> dict[str, Any]:
    wait_for(client, "pose")
    assert client.post("/api/pose", json=pose).status_code == 200
    return wait_for(client, "decision")


def _with_preview(client: TestClient) -> dict[str, Any]:
    """The state once the capture's preview result has come."""
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        state: dict[str, Any] = strict_json(client.get("/api/state").text)
        if state["preview"] is not None:
            return state
        time.sleep(0.02)
    raise AssertionError("no preview result came")


def test_a_line_with_no_glove_and_a_pose_typed_twice_never_blinds_the_page(
    console: tuple[TestClient, Path],
) -> None:
    client, _ = console
    assert client.post("/api/setup", json=LINE_SETUP).status_code == 200
    away = capture(client, {"x": "0", "y": "0", "z": "0", "rotation": "0, 180, 0"})
    assert away["shortfall"] != "ok"  # the glove was not found
    assert client.post("/api/decide", json={"decision": "accept"}).status_code == 400
    assert client.post("/api/decide", json={"decision": "redo"}).status_code == 200
    same = {"x": "0", "y": "0", "z": "0", "rotation": "0, 0, 0"}
    capture(client, same)
    assert client.post("/api/decide", json={"decision": "accept"}).status_code == 200
    capture(client, same)  # the same pose again: no baseline, NaN everywhere
    second = _with_preview(client)  # it follows the decision asked for (issue 55)
    assert second["preview"]["direction"] == [None, None, None]  # NaN, sent as null
    assert client.post("/api/decide", json={"decision": "accept"}).status_code == 200
    state = wait_for(client, "pose")
    (result,) = state["results"]
    assert result["status"] != "ok"
    for _ in range(20):  # every poll from then on
        answer = client.get("/api/state")
        assert answer.status_code == 200
        strict_json(answer.text)
    assert client.post("/api/decide", json={"decision": "quit"}).status_code == 200


def test_the_console_refuses_exactly_what_a_terminal_would_obey() -> None:
    """One rule (twopose.values.text): the console refuses the characters info escapes."""
    for code in range(0x3000):
        char = chr(code)
        assert bool(text_refusal(f"a{char}b")) == is_control(char), hex(code)


# -- parse before you judge: any JSON value on any route, never a 5xx, always the headers

_NUMBER_TEXTS = st.sampled_from(
    ["9" * 400, "-0", "0.0", "1e308", "1e-320", "-1e999", "123456789012345678901234567890"]
)
_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**500), max_value=10**500)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=30),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=6,
)
_FIELDS = ["decision", "x", "y", "z", "rotation", "text", "method", "focal", "operator", "\u00e9"]


@st.composite
def _bodies(draw: st.DrawFn) -> bytes:
    """A JSON object text: the routes' fields and others, any values, numbers given as
    raw text too (400 digits, -0), and keys given twice."""
    keys = draw(st.lists(st.sampled_from(_FIELDS) | st.text(max_size=6), max_size=4))
    parts = []
    for key in keys + draw(st.lists(st.sampled_from(keys or ["x"]), max_size=1)):
        raw = draw(_NUMBER_TEXTS) if draw(st.booleans()) else json.dumps(draw(_VALUES))
        parts.append(f"{json.dumps(key)}: {raw}")
    return ("{" + ", ".join(parts) + "}").encode()


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    route=st.sampled_from(["/api/setup", "/api/pose", "/api/decide", "/api/note"]), body=_bodies()
)
def test_any_json_on_any_route_is_answered_with_the_headers(
    console: tuple[TestClient, Path], route: str, body: bytes
) -> None:
    client, _ = console
    answer = client.post(route, content=body, headers=JSON)
    assert answer.status_code < 500, (route, body[:200], answer.text[:300])
    for name, value in SECURITY_HEADERS.items():
        assert answer.headers[name] == value, (route, name)
    strict_json(answer.text)


def test_a_failure_inside_the_console_is_a_500_with_the_headers() -> None:
    """A bug in a route: a 500 that says so in JSON, framing forbidden, never bare."""

    async def broken(scope: Any, receive: Any, send: Any) -> None:
        raise OverflowError("int too large to convert to float")

    client = TestClient(ConsoleGuard(broken), base_url="http://127.0.0.1:8765")
    answer = client.get("/")
    assert answer.status_code == 500
    assert "failed" in answer.json()["error"]
    for name, value in SECURITY_HEADERS.items():
        assert answer.headers[name] == value


@pytest.mark.parametrize(
    ("rig", "method", "said"),
    [
        (RigConstants(principal_offset_px=(300.0, 0.0), units=Units.IN), "point", "implausible"),
        (RigConstants(units=Units.CM), "point", "is in cm, the session in in"),
        (RigConstants(units=Units.IN), "board", "a board session calibrates the rig"),
    ],
)
def test_the_page_refuses_a_rig_at_setup_as_the_terminal_does(
    tmp_path: Path, rig: RigConstants, method: str, said: str
) -> None:
    """The rig is judged with the setup (setup_rules.check_rig, as at the terminal and in a
    plan): a 400 by the rig field, the page still in its setup, nothing recorded."""
    out = tmp_path / "s.mcap"
    options = ConsoleOptions(source="synthetic", given=GIVEN, rig=rig)
    session = ConsoleSession(out, GIVEN)
    with TestClient(console_app(session, options), base_url=ORIGIN) as client:
        client.get("/")
        form = {"method": method, "units": "in", "truth1": "1, 2, 30", "operator": "Ada"}
        if method == "board":
            form = {**form, "board": "9x6", "square": "1", "board_corner": "-3, 8, 24"}
        answer = client.post("/api/setup", json=form)
        assert answer.status_code == 400
        assert said in answer.json()["errors"]["rig"]
        assert client.get("/api/state").json()["phase"] == "setup"
    assert not out.exists()


def test_setup_refusals_come_at_once_a_long_operator_name_among_them(
    console: tuple[TestClient, Path],
) -> None:
    """A name over its limit is refused beside the other fields' refusals, not in a round
    of its own before them."""
    client, out = console
    form = {"method": "point", "focal": "abc", "truth1": "1, 2", "operator": "A" * 200}
    answer = client.post("/api/setup", json=form)
    assert answer.status_code == 400
    assert set(answer.json()["errors"]) == {"focal", "truth1", "operator"}
    assert not out.exists()


def test_a_rig_without_units_is_a_note_not_an_alert(tmp_path: Path) -> None:
    """A rig file from before rig files had units: said once as a neutral note (taken in
    the session's units), never in the live-failure bar."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL_SCENE)
    options = ConsoleOptions(
        source=f"synthetic:{scene}", given=GIVEN, frames=2, size=(320, 240), rig=RigConstants()
    )
    session = ConsoleSession(tmp_path / "s.mcap", dict(GIVEN, size=(320, 240)))
    with TestClient(console_app(session, options), base_url=ORIGIN) as client:
        client.get("/")
        form = {"method": "point", "focal": "262.5", "principal": "160, 120", "operator": "A"}
        assert client.post("/api/setup", json=form).status_code == 200
        state = wait_for(client, "pose")
        assert any("records no units" in n for n in state["notices"]), state["notices"]
        assert state["live_error"] == ""
        assert client.post("/api/decide", json={"decision": "quit"}).status_code == 200
