"""``--plane-offset``: the one option of the offset of a method's plane, whatever the
plane, written from the plane table; honoured or refused on every path (issue 57, item 3).

The terminal, the page and a plan's ``plane_offset`` take it as the method's plane's
offset; beside ``--ground-height`` (the ground's own), with ``--plan``, with
``--continue``, or for a method on no plane it is refused, saying why. The wall's (a
plane registered beside the ground) is ``tests/test_wall_method.py``'s.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from recorder.cli.app import app as record
from recorder.procedure.terminal import Operator, ask_setup
from recorder.setup.form import FormRefusedError, form_fields, setup_from_answers
from recorder.setup.plan import load_plan
from twopose.errors import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_USAGE, InputValueError
from twopose.methods.specs import METHOD_SPECS, PLANES, Method
from twopose.values.units import Units

runner = CliRunner()


def _new(tmp: Path, *args: str) -> tuple[int, str]:
    """``new`` with ``args`` and no input: its exit code and what it said, one line."""
    result = runner.invoke(record, ["new", str(tmp / "x.mcap"), "--source", "synthetic", *args],
                           input="")  # fmt: skip
    assert "Traceback" not in result.output
    assert not (tmp / "x.mcap").exists()
    return result.exit_code, " ".join(result.output.split())


def test_the_help_says_each_planes_offset_from_the_plane_table() -> None:
    said = " ".join(runner.invoke(record, ["new", "--help"], env={"COLUMNS": "300"}).output.split())
    assert "--plane-offset" in said
    for plane in PLANES:  # each plane's equation and what is measured, with its methods
        methods = [str(m) for m, s in METHOD_SPECS.items() if s.plane == plane]
        assert f"{'/'.join(methods)}: {plane.name}'s {plane.equation}" in said.replace("│ ", "")


def test_the_terminal_takes_it_as_the_methods_planes_offset_unasked() -> None:
    asked: list[str] = []

    def answer(question: str, default: str) -> str:
        asked.append(question)
        return default

    setup = ask_setup(
        Operator(answer, lambda _s: None), method=Method.GROUND, units=Units.IN,
        intrinsics=None, focal=525.0, principal=(320.0, 240.0), size=(640, 480),
        ground_truth=[(0.0, 9.5, 11.0)], operator="Bo", target_precision=None,
        plane_offset=9.5,
    )  # fmt: skip
    assert setup.plane_offset == 9.5
    entry = setup.ground()
    assert entry is not None
    assert entry.offset == 9.5
    assert not any("ground height" in q for q in asked), asked


@pytest.mark.parametrize(
    ("args", "code", "said"),
    [
        (["--method", "point", "--plane-offset", "9"], EXIT_ERROR,
         "--plane-offset: a point session measures on no plane"),
        (["--method", "ground", "--plane-offset", "9", "--ground-height", "9"], EXIT_ERROR,
         "--ground-height and --plane-offset both give the ground's offset: give one"),
        (["--method", "ground", "--units", "in", "--plane-offset", "-3"], EXIT_USAGE,
         "Invalid value for '--plane-offset': ground height must be more than 0 and at most "
         "200 in, got -3"),  # as --ground-height -3 is
        (["--method", "ground", "--plane-offset", "9"], EXIT_INTERRUPTED, ""),  # taken
        (["--plane-offset", "9"], EXIT_INTERRUPTED, ""),  # the method asked first
    ],
)  # fmt: skip
def test_the_command_line_honours_or_refuses_it(
    tmp_path: Path, args: list[str], code: int, said: str
) -> None:
    got, output = _new(tmp_path, *args)
    assert got == code, output
    assert said in output


def test_with_a_plan_or_a_continuation_it_is_refused(tmp_path: Path) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text('method = "ground"\nground_height = 9.625\n[[trials]]\n'
                    "poses = [{t = [0, 0, 0]}, {t = [2, 0, 0]}]\n")  # fmt: skip
    code, said = _new(tmp_path, "--plan", str(plan), "--plane-offset", "9")
    assert code == EXIT_ERROR
    assert "--plane-offset" in said
    assert "a plan sets these itself" in said
    (tmp_path / "s.mcap").write_bytes(b"")  # refused before it is read
    code, said = _new(tmp_path, "--continue", str(tmp_path / "s.mcap"), "--plane-offset", "9")
    assert code == EXIT_ERROR
    assert "--plane-offset: a continuation keeps the setup of" in said


@pytest.mark.parametrize(
    ("method", "keys", "taken", "refused"),
    [
        ("ground", "plane_offset = 9.5\n", 9.5, ""),
        ("ground", "ground_height = 9.5\n", 9.5, ""),
        ("ground", "ground_height = 9.5\nplane_offset = 9.5\n", None,
         "ground_height and plane_offset both give the ground's offset"),
        ("ground", "", None, "needs ground_height (ground height: camera centre to table, "
         "y = h) or plane_offset"),
        ("ground", "plane_offset = -1\n", None, "ground height must be more than 0"),
        ("point", "plane_offset = 9.5\n", None,
         "plane_offset: a point session measures on no plane"),
    ],
)  # fmt: skip
def test_a_plans_plane_offset(
    tmp_path: Path, method: str, keys: str, taken: float | None, refused: str
) -> None:
    path = tmp_path / "plan.toml"
    path.write_text(f'method = "{method}"\n{keys}[[trials]]\n'
                    "poses = [{t = [0, 0, 0]}, {t = [2, 0, 0]}]\n")  # fmt: skip
    if refused:
        with pytest.raises(InputValueError, match=refused.replace("(", r"\(").replace(")", r"\)")):
            load_plan(path)
    else:
        assert load_plan(path).plane_offset == taken


def test_the_page_fills_the_planes_field_with_it_and_refuses_it_off_any_plane() -> None:
    given = {"plane_offset": 9.5, "size": (640, 480)}
    fields = {f["name"]: f for f in form_fields(given)}
    assert fields["ground_height"]["given"] is True
    assert fields["ground_height"]["value"] == "9.5"
    setup = setup_from_answers({"method": "ground", "units": "in", "truth1": "0, 9.5, 11"}, given)
    assert setup.plane_offset == 9.5
    with pytest.raises(FormRefusedError) as caught:  # the method chosen in the page
        setup_from_answers({"method": "line", "units": "in"}, given)
    assert caught.value.errors["method"].startswith("--plane-offset: a line session measures")


def test_the_terminal_refuses_it_once_a_method_on_no_plane_is_chosen() -> None:
    """``--plane-offset 9`` without ``--method``: the method asked, then the offset refused
    for a point session (nothing would use it), never dropped."""
    asked: list[str] = []

    def answer(question: str, default: str) -> str:
        asked.append(question)
        return "point" if len(asked) == 1 else default

    with pytest.raises(InputValueError, match="--plane-offset: a point session measures on no"):
        ask_setup(
            Operator(answer, lambda _s: None), method=None, units=None,
            intrinsics=None, focal=None, principal=None, size=(640, 480), ground_truth=[],
            operator=None, plane_offset=9.0,
        )  # fmt: skip
