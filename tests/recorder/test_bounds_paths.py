"""One grammar and one bound per quantity, on every path (issue 44, part 3): the terminal,
the page's forms, a plan and the command line accept and refuse the same texts with the
same words (twopose.values.bounds), and a board session refuses guidance options with a reason."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.console.server import ConsoleOptions, checked_setup
from recorder.procedure.terminal import Operator, ask_setup, ask_target
from recorder.setup.form import FormRefusedError, form_fields, parse_pose_form, setup_from_answers
from recorder.setup.plan import load_plan
from recorder.setup.rules import GuidanceAsked, parse_vector
from twopose.errors import EXIT_ERROR, EXIT_USAGE, InputValueError
from twopose.methods.specs import Method
from twopose.values.bounds import FOCAL, GROUND_HEIGHT, ROTATION, TARGET_PRECISION, Quantity, shown
from twopose.values.units import UNITS, Units

runner = CliRunner()
JUNK = [
    "1_0",
    "\u0661",
    "\uff15\uff12\uff15",
    "1e309",
    "-1e309",
    "abc",
    "0x10",
    "1e",
    ".",
    "+",
    "-0",
    "inf",
]


class _Script:
    """An operator who answers ``first`` to the question that contains ``topic`` and the
    default (or ``fallback``) otherwise; what is said is kept."""

    def __init__(self, topic: str, first: str, fallback: str) -> None:
        self.topic, self.first, self.fallback = topic, first, fallback
        self.asked = 0
        self.said: list[str] = []
        self.op = Operator(self.ask, self.said.append)

    def ask(self, question: str, default: str) -> str:
        if self.topic in question:
            self.asked += 1
            return self.first if self.asked == 1 else self.fallback
        return default

    def refusal(self) -> str | None:
        refused = [s.removeprefix("  not accepted: ") for s in self.said if "not accepted" in s]
        return refused[0] if refused else None


def _expected(quantity: Quantity, text: str, units: Units) -> str | None:
    try:
        quantity.read(text, units)
    except InputValueError as err:
        return str(err)
    return None


def _terminal(quantity: Quantity, text: str, units: Units) -> str | None:
    """The refusal the terminal says (None: accepted)."""
    if quantity is TARGET_PRECISION:
        script = _Script("stop a trial", text, "none")
        ask_target(script.op, units)
        return script.refusal()
    topic = "focal" if quantity is FOCAL else "ground height"
    script = _Script(topic, text, "1")
    h = quantity.read(text, units) if _expected(quantity, text, units) is None else 1.0
    ask_setup(
        script.op, method=Method.GROUND, units=units, intrinsics=None, focal=None,
        principal=(320.0, 240.0), size=(640, 480),
        ground_height=None if quantity is GROUND_HEIGHT else 1.0,
        ground_truth=[(0.0, h if quantity is GROUND_HEIGHT else 1.0, 1.0)], operator="Bo",
        target_precision=1.0,
    )  # fmt: skip
    return script.refusal()


_FIELD = {FOCAL: "focal", GROUND_HEIGHT: "ground_height", TARGET_PRECISION: "target_precision"}
_OPTION = {
    FOCAL: "--focal",
    GROUND_HEIGHT: "--ground-height",
    TARGET_PRECISION: "--target-precision",
}
_PLAN_KEY = {
    FOCAL: "camera.focal",
    GROUND_HEIGHT: "ground_height",
    TARGET_PRECISION: "guidance.target_95",
}


def _page(quantity: Quantity, text: str, units: Units) -> str | None:
    form = {"method": "ground", "units": units.value, "ground_height": "1", "truth1": ""}
    form[_FIELD[quantity]] = text
    try:
        setup_from_answers(form, {"size": (640, 480)})
    except FormRefusedError as err:
        return err.errors.get(_FIELD[quantity])
    return None


def _command_line(quantity: Quantity, text: str, units: Units, tmp: Path) -> str | None:
    """The refusal of ``new`` (exit 2), or None when the option was read (the run goes on
    to refuse --plan with --ui, exit 3, before anything is asked or recorded)."""
    plan = tmp / "p.toml"
    plan.touch()
    args = ["new", str(tmp / "s.mcap"), "--plan", str(plan), "--ui", "--units", units.value]
    result = runner.invoke(app, [*args, _OPTION[quantity], text])
    if result.exit_code == EXIT_ERROR:
        assert "--plan records unattended" in result.output
        return None
    assert result.exit_code == EXIT_USAGE, result.output
    line = next(li for li in result.output.splitlines() if "Invalid value" in li)
    return line.split(f"Invalid value for '{_OPTION[quantity]}': ", 1)[1]


def _plan(quantity: Quantity, text: str, units: Units, tmp: Path) -> str | None:
    value = {FOCAL: "525", GROUND_HEIGHT: "1", TARGET_PRECISION: "1"} | {quantity: text}
    toml = (
        f'method = "ground"\nunits = "{units.value}"\nground_height = {value[GROUND_HEIGHT]}\n'
        f"[camera]\nfocal = {value[FOCAL]}\n[guidance]\ntarget_95 = {value[TARGET_PRECISION]}\n"
        "[[trials]]\nposes = [{t = [0, 0, 0]}, {t = [1, 0, 0]}]\n"
    )
    path = tmp / "plan.toml"
    path.write_text(toml)
    try:
        load_plan(path)
    except InputValueError as err:
        return str(err).removeprefix(f"plan: {_PLAN_KEY[quantity]}: ")
    return None


_NUMBERS = st.one_of(
    st.floats(min_value=-1e4, max_value=1e6, allow_nan=False).map(shown),
    st.integers(min_value=-10, max_value=300_000).map(str),
    st.sampled_from(["0", "200", "200.0001", "5080", "5.08", "100", "100000", "1e-300"]),
)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    quantity=st.sampled_from([FOCAL, GROUND_HEIGHT, TARGET_PRECISION]),
    text=st.one_of(_NUMBERS, st.sampled_from(JUNK)),
    units=st.sampled_from(UNITS),
)
@example(quantity=GROUND_HEIGHT, text="-3", units=Units.IN)  # asked again at the terminal
@example(quantity=TARGET_PRECISION, text="1_0", units=Units.IN)  # was 10
@example(quantity=FOCAL, text="\uff15\uff12\uff15", units=Units.IN)  # was 525
def test_every_path_accepts_and_refuses_the_same_texts_with_the_same_words(
    tmp_path: Path, quantity: Quantity, text: str, units: Units
) -> None:
    expected = _expected(quantity, text, units)
    said = {
        "terminal": _terminal(quantity, text, units),
        "page": _page(quantity, text, units),
        "command line": _command_line(quantity, text, units, tmp_path),
    }
    if text not in JUNK:  # a plan's numbers are TOML's: only numbers reach the bound
        said["plan"] = _plan(quantity, text, units, tmp_path)
    for path, message in said.items():
        if expected is None:
            assert message is None, (path, message)
        else:  # the same words; the terminal and the page add how to say "no stop rule"
            assert message is not None, path
            assert message.startswith(expected), (path, message)


def test_a_rotation_past_its_bound_is_refused_with_one_message(tmp_path: Path) -> None:
    """The rotation's limit was a literal 180.0 at the terminal, its own in a plan."""
    message = "rotation rz must be from -180 to 180 deg, got 181"
    with pytest.raises(InputValueError, match=message):
        parse_vector("0, 0, 181", Units.IN, quantity=ROTATION)
    with pytest.raises(FormRefusedError) as caught:
        parse_pose_form({"x": "0", "y": "0", "z": "0", "rotation": "0 0 181"}, Units.IN)
    assert caught.value.errors == {"rotation": message}
    plan = tmp_path / "p.toml"
    plan.write_text(
        'method = "point"\n[[trials]]\nposes = [{t=[0,0,0], r_deg=[0,0,181]},{t=[1,0,0]}]\n'
    )
    with pytest.raises(InputValueError, match=f"r_deg: {message}"):
        load_plan(plan)


def test_the_pose_form_says_per_axis_what_the_terminal_says() -> None:
    with pytest.raises(FormRefusedError) as caught:
        parse_pose_form({"x": "1e9", "y": "1_0", "z": "0"}, Units.MM)
    with pytest.raises(InputValueError) as typed:
        parse_vector("1e9, 0, 0", Units.MM)
    assert caught.value.errors["x"] == str(typed.value)
    assert caught.value.errors["x"] == "camera centre x must be from -5080 to 5080 mm, got 1e9"
    assert "'1_0' is not a number" in caught.value.errors["y"]


# --------------------------------------------------------------------------- the findings


def _new(*args: str, tmp: Path, answers: str = "") -> Any:
    return runner.invoke(app, ["new", str(tmp / "s.mcap"), "--source", "synthetic", *args],
                         input=answers)  # fmt: skip


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--reach", "1e309"], "reach must be from 0.0393701 to 100 in (1 to 2540 mm"),
        (["--units", "in", "--reach", "1000"], "reach must be from 0.0393701 to 100 in, got 1000"),
        (["--reach", "1000", "--units", "in"], "reach must be from 0.0393701 to 100 in, got 1000"),
        (["--units", "mm", "--grid", "0.5"], "grid spacing must be from 1 to 2540 mm, got 0.5"),
        (["--reach", "1_0"], "reach: '1_0' is not a number"),
        (["--focal", "\uff15\uff12\uff15"], "focal length: '\uff15\uff12\uff15' is not a number"),
        (["--target-precision", "\u0663"], "target precision: '\u0663' is not a number"),
        (["--ground-height", "-3"], "ground height must be more than 0 and at most 200 in"),
        (["--max-poses", "101"], "max poses must be a whole number from 2 to 100, got 101"),
        (["--frames", "100000"], "frames per pose must be a whole number from 1 to 500"),
        (["--principal", "320, 1e309"], "principal point cy must be from 0 to 10000 px"),
        (["--units", "cm", "--ground-truth", "0, 0, 600"], "ground truth z must be from -508"),
    ],
)
def test_the_command_line_refuses_past_the_bound_before_anything(
    tmp_path: Path, args: list[str], message: str
) -> None:
    result = _new(*args, tmp=tmp_path)
    assert result.exit_code == EXIT_USAGE, result.output
    assert message in " ".join(result.output.split())
    assert not (tmp_path / "s.mcap").exists()


def test_a_length_given_without_units_is_refused_once_they_are_chosen(tmp_path: Path) -> None:
    """``--reach 1000`` is a reach in mm: refused as soon as the operator answers in."""
    result = _new("--reach", "1000", "--method", "point", tmp=tmp_path, answers="in\n")
    assert result.exit_code == EXIT_ERROR, result.output
    assert "reach must be from 0.0393701 to 100 in, got 1000" in result.output
    assert "focal" not in result.output  # refused before the next question


def test_a_ground_height_given_is_refused_never_asked_again() -> None:
    """``--ground-height -3`` was asked again at the terminal (refused by the page and a
    plan): a value given is read by its bound, and refused naming its option."""
    script = _Script("ground height", "9.625", "9.625")
    with pytest.raises(InputValueError) as caught:
        ask_setup(
            script.op, method=Method.GROUND, units=Units.IN, intrinsics=None, focal=525.0,
            principal=(320.0, 240.0), size=(640, 480), ground_height=-3.0,
            ground_truth=[],
            operator="Bo",
        )  # fmt: skip
    assert str(caught.value) == (
        "--ground-height: ground height must be more than 0 and at most 200 in, got -3"
    )
    assert script.asked == 0
    with pytest.raises(FormRefusedError) as form:
        setup_from_answers({"method": "ground", "units": "in"}, {"ground_height": -3.0})
    assert form.value.errors["ground_height"] == (
        "ground height must be more than 0 and at most 200 in, got -3"
    )


def test_a_value_given_is_the_value_shown_and_recorded() -> None:
    """``--focal 1234.56789`` showed 1234.57 in the page and was recorded so."""
    given = {
        "method": "point",
        "units": Units.IN,
        "focal": 1234.56789,
        "principal": (320.5, 240.25),
    }
    fields = {f["name"]: f["value"] for f in form_fields(given)}
    assert fields["focal"] == "1234.56789"
    assert fields["principal"] == "320.5, 240.25"
    setup = setup_from_answers({}, {**given, "size": (640, 480)})
    assert setup.intrinsics.fx == 1234.56789
    assert (setup.intrinsics.cx, setup.intrinsics.cy) == (320.5, 240.25)


# --------------------------------------------------------------------------- a board session


@pytest.mark.parametrize(
    "options",
    [
        ["--adaptive-frames"],
        ["--target-precision", "0.5"],
        ["--reach", "4"],
        ["--grid", "1"],
        ["--max-poses", "4"],
    ],
)
def test_a_board_session_refuses_guidance_options_on_the_command_line(
    tmp_path: Path, options: list[str]
) -> None:
    """They were ignored silently."""
    result = _new("--method", "board", *options, tmp=tmp_path)
    assert result.exit_code == EXIT_ERROR, result.output
    assert f"{options[0]}: a board session has no guidance" in " ".join(result.output.split())


def test_a_board_session_chosen_at_the_terminal_refuses_them_at_once(tmp_path: Path) -> None:
    result = _new("--adaptive-frames", tmp=tmp_path, answers="board\nin\n")
    assert result.exit_code == EXIT_ERROR, result.output
    assert "--adaptive-frames: a board session has no guidance" in result.output
    assert "inner corners" not in result.output  # refused before the board is asked


def test_a_board_session_chosen_in_the_page_refuses_them_by_the_method() -> None:
    options = ConsoleOptions(
        source="synthetic", given={"target_precision": 0.5},
        guidance=GuidanceAsked(given=("--target-precision", "--adaptive-frames")),
    )  # fmt: skip
    form = {"method": "board", "units": "in", "board": "9x6", "square": "1"}
    with pytest.raises(FormRefusedError) as caught:
        checked_setup({**form, "board_corner": "0, 0, 20"}, options)
    assert caught.value.errors["method"].startswith(
        "--target-precision, --adaptive-frames: a board session has no guidance"
    )


@pytest.mark.parametrize("extra", ["adaptive_frames = true\n", "[guidance]\ntarget_95 = 0.5\n"])
def test_a_board_plan_refuses_guidance(tmp_path: Path, extra: str) -> None:
    plan = tmp_path / "p.toml"
    plan.write_text(
        'method = "board"\n' + extra.replace("[guidance]", "\n[guidance]")
        + "\n[board]\ninner_corners = [9, 6]\nsquare = 1\nfirst_corner = [0, 0, 20]\n"
        "[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n"
    )  # fmt: skip
    with pytest.raises(InputValueError, match="a board session has no guidance"):
        load_plan(plan)
