"""One grammar for every number a person or a file gives (issue 55, item 5): the command
lines' options, a plan, a rig file, a scene file and the page's API accept and refuse the
same texts, in the same words (twopose.values.checks.read_number, then each quantity's bound),
and say a value as it was written (``1e309``, never ``inf``)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import tomlkit
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from starlette.testclient import TestClient
from typer.testing import CliRunner

from analysis.cli import app as analyze
from recorder.cli.app import app as record
from recorder.console.server import ConsoleOptions, console_app
from recorder.console.state import ConsoleSession
from recorder.setup.plan import load_plan
from tests.helpers import SMALL_SCENE
from twopose.errors import EXIT_ERROR, EXIT_USAGE, InputValueError, SceneError
from twopose.rig.file import load_rig_file
from twopose.sim.scene import load_scene
from twopose.values.bounds import GROUND_HEIGHT, POSE_TRANSLATION
from twopose.values.checks import NUMBER_WORDS, WHOLE_WORDS, read_number
from twopose.values.units import Units

runner = CliRunner()
ORIGIN = "http://127.0.0.1:8765"
PLAN = (
    'method = "ground"\nunits = "in"\nground_height = {h}\nframes = {frames}\n'
    "[[trials]]\nground_truth = [[1.91, 9.625, 8.375]]\nkeep_off_ground = true\n"
    "poses = [{{t = [0, 0, 0]}}, {{t = [1, 0, 0]}}]\n"
)


def _plan(tmp: Path, h: str = "9.625", frames: str = "2") -> Path:
    path = tmp / "plan.toml"
    path.write_text(PLAN.format(h=h, frames=frames))
    return path


def _refusal(call: Any) -> str | None:
    try:
        call()
    except (InputValueError, SceneError) as err:
        return str(err)
    return None


# --------------------------------------------------------------------------- each path


def _option(text: str, tmp: Path) -> str | None:
    """``new --ground-height TEXT``: None when read (the run goes on to refuse --plan with
    --ui, exit 3, before anything is asked or recorded), else the refusal."""
    plan = tmp / "empty.toml"
    plan.touch()
    result = runner.invoke(record, ["new", str(tmp / "s.mcap"), "--units", "in", "--plan",
                                    str(plan), "--ui", f"--ground-height={text}"])  # fmt: skip
    if result.exit_code == EXIT_ERROR:
        assert "--plan records unattended" in result.output
        return None
    assert result.exit_code == EXIT_USAGE, result.output
    return result.output.split("Invalid value for '--ground-height': ")[1].removesuffix("\n")


def _in_plan(text: str, tmp: Path) -> str | None:
    return _refusal(lambda: load_plan(_plan(tmp, h=text)))


def _in_rig(text: str, tmp: Path) -> str | None:
    path = tmp / "rig.toml"
    path.write_text(f'[rig]\nunits = "in"\nfocal_scale = 1.01\n[placing]\nsigma = {text}\n')
    return _refusal(lambda: load_rig_file(path))


def _in_scene(text: str, tmp: Path) -> str | None:
    path = tmp / "scene.toml"
    path.write_text(f"[finger]\ntilt_deg = {text}\n")
    return _refusal(lambda: load_scene(path))


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[TestClient, ConsoleSession]]:
    """The console in-process, recording and offering a pose in inches."""
    folder = tmp_path_factory.mktemp("page")
    scene = folder / "scene.toml"
    scene.write_text(SMALL_SCENE)
    given = {"size": (320, 240)}
    session = ConsoleSession(folder / "s.mcap", given)
    options = ConsoleOptions(source=f"synthetic:{scene}", given={}, size=(320, 240))
    with TestClient(console_app(session, options), base_url=ORIGIN) as client:
        assert client.get("/").status_code == 200
        session.update(phase="recording", units=Units.IN)
        yield client, session


def _api(page: tuple[TestClient, ConsoleSession], body: bytes) -> str | None:
    """``/api/pose``'s refusal of x (None: taken), the pose offered afresh each time (a pose
    taken closes the offer until the recorder offers the next)."""
    client, session = page
    while session.answer(0) is not None:  # what the last call's pose left for the recorder
        pass
    session.offer("pose")
    answer = client.post("/api/pose", content=body, headers={"Content-Type": "application/json"})
    if answer.status_code == 200:
        return None
    assert answer.status_code == 400, answer.text
    errors = answer.json()["errors"]
    return str(errors.get("x", answer.json()["error"]))


# --------------------------------------------------------------------------- the property


def _toml_reads(text: str) -> bool:
    """Whether TOML reads ``text`` as a value at all (``.5`` and ``05`` are not TOML)."""
    try:
        return isinstance(tomlkit.parse(f"v = {text}")["v"], int | float)
    except Exception:  # tomlkit raises several kinds for text it cannot read
        return False


_ATOMS = ["0", "1", "5", "9", "25", "_", ".", "e", "E", "+", "-", "0x", "0o", "0b", "inf",
          "nan", "\uff13", "\u0663", " ", "e309", "e-400", "1_000"]  # fmt: skip
TEXTS = st.one_of(
    st.lists(st.sampled_from(_ATOMS), min_size=1, max_size=6).map("".join),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**30), max_value=10**30).map(lambda n: f"{n:_}"),
    st.integers(min_value=0, max_value=255).map(lambda n: f"{n:#x}"),
    st.decimals(allow_nan=False, allow_infinity=False, places=4).map(str),
    st.sampled_from(["  7.5 ", "+5", "-0", "1e309", "-1e309", "9_625e-3", "0o5", "0b101"]),
)


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(text=TEXTS)
@example(text="1_0")  # the plan read it as 10
@example(text="0x5")  # ... as 5
@example(text="1e309")  # ... said "got inf"
@example(text="\uff13\uff10")  # Python's float reads full-width digits
def test_every_path_accepts_and_refuses_the_same_texts_in_the_same_words(
    tmp_path: Path, page: tuple[TestClient, ConsoleSession], text: str
) -> None:
    try:
        value: float | None = read_number(text, "q")
        grammar = ""
    except InputValueError as err:
        value, grammar = None, str(err).removeprefix("q: ")
    said = {
        "option": _option(text, tmp_path),
        "plan": _in_plan(text, tmp_path),
        "rig file": _in_rig(text, tmp_path),
        "scene file": _in_scene(text, tmp_path),
        "page form": _api(page, json.dumps({"x": text, "y": "0", "z": "0"}).encode()),
    }
    try:  # the raw API: a JSON number, when the text is one
        sent = json.loads(text, parse_constant=lambda c: 1 / 0)
        if isinstance(sent, int | float) and not isinstance(sent, bool):
            said["page API"] = _api(page, b'{"x": ' + text.encode() + b', "y": 0, "z": 0}')
    except (ValueError, ZeroDivisionError):
        pass
    files = ("plan", "rig file", "scene file")
    for path, message in said.items():
        if path in files and not _toml_reads(text):
            assert "is not valid TOML" in (message or ""), (path, message)
        elif value is None:  # refused by the grammar: in its words, on every path
            assert grammar in (message or "<accepted>"), (path, message, grammar)
        elif message is not None:  # refused by a bound: a value said is said as written
            shown = message.rsplit("got ", 1)[-1] if "got " in message else text.strip()
            assert shown == text.strip() or f"sigma = {text.strip()} in" in message, (
                path, message)  # fmt: skip
    # The paths with one quantity's bound say exactly the same thing.
    expected = _refusal(lambda: GROUND_HEIGHT.read(text, Units.IN))
    assert said["option"] == expected
    if _toml_reads(text):
        assert said["plan"] == (None if expected is None else f"plan: ground_height: {expected}")
    expected_x = _refusal(lambda: POSE_TRANSLATION.read(text, Units.IN, axis="x"))
    assert said["page form"] == expected_x
    assert said.get("page API", expected_x) == expected_x


# --------------------------------------------------------------------------- the findings


@pytest.mark.parametrize(
    ("frames", "said"),
    [
        ("1_0", "'1_0' is not a whole number"),  # recorded 10 frames
        ("0x5", "'0x5' is not a whole number"),  # 5
        ("0o5", "'0o5' is not a whole number"),
        ("0b101", "'0b101' is not a whole number"),
        ("1e1", "'1e1' is not a whole number"),
        ("inf", "'inf' is not a whole number"),
    ],
)
def test_a_plans_whole_numbers_follow_the_one_grammar(
    tmp_path: Path, frames: str, said: str
) -> None:
    with pytest.raises(InputValueError) as caught:
        load_plan(_plan(tmp_path, frames=frames))
    assert str(caught.value) == f"plan: frames: frames per pose: {said} ({WHOLE_WORDS})"


def test_a_plans_numbers_follow_the_one_grammar_and_are_said_as_written(tmp_path: Path) -> None:
    assert load_plan(_plan(tmp_path, frames="+5")).frames == 5  # a sign is the grammar's
    with pytest.raises(InputValueError) as caught:
        load_plan(_plan(tmp_path, h="9_625e-3"))  # was 9.625
    assert str(caught.value) == (
        f"plan: ground_height: ground height: '9_625e-3' is not a number ({NUMBER_WORDS})"
    )
    with pytest.raises(InputValueError) as caught:
        load_plan(_plan(tmp_path, h="1e309"))
    assert str(caught.value).endswith("got 1e309")  # was "got inf"
    path = tmp_path / "res.toml"
    path.write_text(_plan(tmp_path).read_text() + "[resolution]\ntranslation = 0x1\n")
    with pytest.raises(InputValueError, match=r"translation: '0x1' is not a number \(digits"):
        load_plan(path)


@pytest.mark.parametrize("sigma", ["0x1", "0.0_5", "1_0", "nan"])
def test_a_rig_files_placing_sigma_follows_the_one_grammar(tmp_path: Path, sigma: str) -> None:
    """``sigma = 0x1`` was read as 1 in, ``0.0_5`` as 0.05 in."""
    said = _in_rig(sigma, tmp_path)
    assert said is not None
    assert said.endswith(f"[placing]: sigma: {sigma!r} is not a number ({NUMBER_WORDS})")
    said = _in_rig("1e309", tmp_path)
    assert "sigma = 1e309 in is not a placing error" in (said or "")


@pytest.mark.parametrize(
    "body",
    ["[finger]\ntilt_deg = 0x5\n", "[poses]\nnoise_sigma = 1_0\n", "[finger]\ntilt_deg = 1e309\n"],
)
def test_a_scene_files_numbers_follow_the_one_grammar(tmp_path: Path, body: str) -> None:
    path = tmp_path / "scene.toml"
    path.write_text(body)
    with pytest.raises(SceneError) as caught:
        load_scene(path)
    text = body.split("= ")[1].strip()
    assert f"{text!r} is not a number" in str(caught.value) or f"got {text}" in str(caught.value)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["new", "s.mcap", "--fps", "1_0"], "frame rate: '1_0' is not a number"),
        (["new", "s.mcap", "--fps", "inf"], "frame rate: 'inf' is not a number"),
        (["new", "s.mcap", "--fps", "1e309"], "frame rate must be from 1 to 1000 fps, got 1e309"),
        (["new", "s.mcap", "--fps", "\uff13\uff10"], "frame rate: '\uff13\uff10' is not a number"),
        (["new", "s.mcap", "--port", "8_081"], "port: '8_081' is not a whole number"),
        (["new", "s.mcap", "--live-port", "0x10"], "port: '0x10' is not a whole number"),
        (["simulate", "s.mcap", "--method", "point", "--trials", "1_0"], "trials: '1_0'"),
        (["simulate", "s.mcap", "--method", "point", "--seed", "1_0"], "seed: '1_0'"),
        (["simulate", "s.mcap", "--method", "point", "--seed", "0x10"], "seed: '0x10'"),
        (["simulate", "s.mcap", "--method", "point", "--pose-noise", "1_0"], "pose noise: '1_0'"),
        (["calibrate", "c.toml", "--views", "1e1"], "views: '1e1' is not a whole number"),
    ],
)
def test_the_recorders_options_follow_the_one_grammar(
    tmp_path: Path, args: list[str], said: str
) -> None:
    """``--fps 1_0``, ``inf``, ``1e309`` and ``--port 8_081`` were taken (as 10, inf, inf,
    8081), ``--fps ３０`` and ``--seed 0x10`` refused in click's words."""
    result = runner.invoke(record, [args[0], str(tmp_path / args[1]), *args[2:]])
    assert result.exit_code == EXIT_USAGE, result.output
    assert said in " ".join(result.output.split())
    assert "is not a valid" not in result.output  # click's words
    assert not (tmp_path / args[1]).exists()


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["run", "x", "--jobs", "1_0"], "jobs: '1_0' is not a whole number"),
        (["run", "x", "--min-parallax", "inf"], "warning angle: 'inf' is not a number"),
        (["run", "x", "--session-timeout", "1e309"], "session timeout must be from 0 to 86400"),
        (["sensitivity", "--seed", "0x10"], "seed: '0x10' is not a whole number"),
        (["sensitivity", "--samples", "1_000"], "samples: '1_000' is not a whole number"),
    ],
)
def test_the_analysis_options_follow_the_one_grammar(args: list[str], said: str) -> None:
    result = runner.invoke(analyze, args)
    assert result.exit_code == EXIT_USAGE, result.output
    assert said in " ".join(result.output.split())


def test_the_page_api_says_a_number_in_the_forms_words(
    page: tuple[TestClient, ConsoleSession],
) -> None:
    """``{"x": 1e309}`` was answered "must be a finite number" by the guard; the form said
    the camera centre's bound."""
    raw = _api(page, b'{"x": 1e309, "y": 0, "z": 0}')
    form = _api(page, b'{"x": "1e309", "y": "0", "z": "0"}')
    assert raw == form == "camera centre x must be from -200 to 200 in, got 1e309"
    assert _api(page, b'{"x": 1e300, "y": 0, "z": 0}') == (
        "camera centre x must be from -200 to 200 in, got 1e300"
    )
    assert math.isinf(float("1e309"))  # what Python's json would have made of it
