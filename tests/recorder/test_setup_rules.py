"""The setup's rules, called directly (the terminal, plans and the web console share them):
every refusal at once, by field; what the command line gave wins and is shown read-only;
the thesis' defaults; the fields that apply to each method."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from recorder.setup.form import (
    SETUP_FIELDS,
    FormRefusedError,
    form_fields,
    parse_pose_form,
    setup_from_answers,
)
from tests.helpers import install_extension
from twopose.camera.model import Intrinsics
from twopose.values.units import Units

NOTHING_GIVEN: dict[str, Any] = {
    "method": None,
    "units": None,
    "intrinsics": None,
    "focal": None,
    "principal": None,
    "size": (640, 480),
    "ground_height": None,
    "ground_truth": [],
    "operator": None,
}


def test_a_good_form_with_the_thesis_defaults() -> None:
    setup = setup_from_answers(
        {"method": "ground", "ground_height": "9.625", "truth1": "1.91, 9.625, 8.375"},
        NOTHING_GIVEN,
    )
    assert setup.method == "ground"
    assert (setup.intrinsics.fx, setup.intrinsics.cx, setup.intrinsics.cy) == (525, 320, 240)
    assert setup.units == "in"
    assert setup.ground_truth == ((1.91, 9.625, 8.375),)


def test_every_refusal_at_once_by_field_in_the_operators_words() -> None:
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers(
            {"method": "ground", "focal": "-3", "principal": "1", "ground_height": ""},
            NOTHING_GIVEN,
        )
    errors = caught.value.errors
    assert set(errors) == {"focal", "principal", "ground_height"}
    assert "height of the camera centre above the table" in errors["ground_height"]
    assert "ground_height" not in str(caught.value)  # labels, not internal keys
    assert "ground height" in str(caught.value)
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers({"method": "line", "truth1": "1,2,3", "truth2": "1,2,3"}, NOTHING_GIVEN)
    assert set(caught.value.errors) == {"truth2"}
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers({"method": "line", "truth1": "1,2,3"}, NOTHING_GIVEN)
    assert "two points" in caught.value.errors["truth2"]
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers({}, NOTHING_GIVEN)
    assert set(caught.value.errors) == {"method"}


def test_a_ground_truth_off_the_ground_is_kept_only_when_ticked() -> None:
    form = {"method": "ground", "ground_height": "9.6", "truth1": "1, 5, 8"}
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers(form, NOTHING_GIVEN)
    label = next(f.label for f in SETUP_FIELDS if f.name == "keep_off_ground")
    assert f"tick '{label}'" in caught.value.errors["truth1"]  # the box's own words
    kept = setup_from_answers({**form, "keep_off_ground": "y"}, NOTHING_GIVEN)
    assert kept.ground_truth == ((1.0, 5.0, 8.0),)


def test_what_the_command_line_gave_wins_and_is_shown_read_only() -> None:
    given = {**NOTHING_GIVEN, "method": "ground", "ground_height": 9.625, "units": "in"}
    fields = {f["name"]: f for f in form_fields(given)}
    assert fields["method"] == {**fields["method"], "given": True, "value": "ground"}
    assert fields["ground_height"]["given"]
    assert fields["ground_height"]["value"] == "9.625"
    assert not fields["focal"]["given"]
    assert fields["focal"]["value"] == "525"
    # The form cannot override it: a different method typed there is not used.
    setup = setup_from_answers({"method": "point", "ground_height": "3"}, given)
    assert (setup.method, setup.plane_offset) == ("ground", 9.625)
    calibrated = {
        **NOTHING_GIVEN,
        "intrinsics": Intrinsics(width=640, height=480, fx=530, fy=531, cx=321, cy=239),
    }
    fields = {f["name"]: f for f in form_fields(calibrated)}
    assert fields["focal"]["given"]
    assert fields["principal"]["value"] == "321, 239"


def test_the_thesis_ground_height_is_the_default_in_inches_only() -> None:
    inches = {f["name"]: f for f in form_fields({**NOTHING_GIVEN, "units": "in"})}
    mm = {f["name"]: f for f in form_fields({**NOTHING_GIVEN, "units": "mm"})}
    assert inches["ground_height"]["value"] == "9.625"
    assert mm["ground_height"]["value"] == ""


def test_fields_say_which_methods_they_apply_to() -> None:
    applies = {f.name: f.methods for f in SETUP_FIELDS}
    assert applies["ground_height"] == ("ground",)
    assert applies["truth2"] == ("line",)
    assert applies["keep_off_ground"] == ("ground",)
    assert set(applies["truth1"]) == {"point", "line", "ground"}
    assert applies["board"] == applies["square"] == applies["board_corner"] == ("board",)


def test_a_board_session_is_set_up_with_its_board_and_no_truth() -> None:
    setup = setup_from_answers(
        {"method": "board", "board": "9x6", "square": "0.75", "board_corner": "-3, 8.125, 24"},
        NOTHING_GIVEN,
    )
    assert setup.board is not None
    assert (setup.board.inner_corners, setup.board.square) == ((9, 6), 0.75)
    assert setup.board.first_corner == (-3.0, 8.125, 24.0)
    assert setup.ground_truth == ()
    assert setup.info().board == setup.board  # into the session entry
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers(
            {"method": "board", "board": "9by6", "board_corner": "1,2"}, NOTHING_GIVEN
        )
    assert set(caught.value.errors) == {"board", "square", "board_corner"}
    assert "COLSxROWS" in caught.value.errors["board"]
    board = setup_from_answers(
        {"method": "board", "board": "9x6", "square": "1", "board_corner": "0,0,20"}, NOTHING_GIVEN
    ).board
    fields = {
        f["name"]: f for f in form_fields({**NOTHING_GIVEN, "method": "board", "board": board})
    }
    assert (fields["board"]["value"], fields["square"]["value"]) == ("9x6", "1")
    assert fields["board_corner"] == {**fields["board_corner"], "given": True, "value": "0, 0, 20"}
    point = setup_from_answers({"method": "point", "board": "9x6"}, NOTHING_GIVEN)
    assert point.board is None  # a field of another method is not read


def test_the_pose_form_refuses_each_field() -> None:
    assert parse_pose_form({"x": "1", "y": "0", "z": "-2"}, Units.IN) == ((1, 0, -2), (0, 0, 0))
    with pytest.raises(FormRefusedError) as caught:
        parse_pose_form({"x": "a", "y": "", "z": "1e9", "rotation": "1, 2"}, Units.IN)
    assert set(caught.value.errors) == {"x", "y", "z", "rotation"}
    assert "rx, ry, rz" in caught.value.errors["rotation"]  # a rotation's axes are a rotation's


@given(st.dictionaries(st.sampled_from([f.name for f in SETUP_FIELDS]), st.text(max_size=12)))
def test_any_form_is_a_setup_or_a_refusal_by_known_field(form: dict[str, str]) -> None:
    errors: dict[str, str] = {}
    try:
        setup_from_answers(form, NOTHING_GIVEN)
    except FormRefusedError as err:
        errors = err.errors
        if not errors:
            raise
    assert set(errors) <= {f.name for f in SETUP_FIELDS}


@pytest.mark.parametrize(
    ("principal", "why"),
    [
        ("900, 900", "outside the 640x480 image"),
        ("-1, 240", "principal point cx must be from 0 to 10000 px, got -1"),
        ("320, 481", "outside the 640x480 image"),
    ],
)
def test_a_principal_point_outside_the_image_is_refused(principal: str, why: str) -> None:
    with pytest.raises(FormRefusedError) as caught:
        setup_from_answers({"method": "point", "principal": principal}, NOTHING_GIVEN)
    assert set(caught.value.errors) == {"principal"}
    assert why in caught.value.errors["principal"]
    setup = setup_from_answers({"method": "point", "principal": "0, 480"}, NOTHING_GIVEN)
    assert (setup.intrinsics.cx, setup.intrinsics.cy) == (0, 480)  # the edge is inside


# --------------------------------------------------------------------------- the registry decides

REPO = Path(__file__).resolve().parents[2]
WALL_EXTENSION = """
import dataclasses

from twopose.methods.specs import METHOD_SPECS, Method, register_method

register_method(
    dataclasses.replace(
        METHOD_SPECS[Method.GROUND], method=Method.declare("wall"), label="wall (a test's)"
    )
)
"""
#: Run with the extension installed: the page's fields for the new method and for ground,
#: and the setup a form for the new method gives.
PROBE = """
import json
from recorder.setup.form import form_fields, setup_from_answers
given = {"method": None, "units": None, "intrinsics": None, "size": (640, 480),
         "ground_height": None, "ground_truth": []}
fields = form_fields(given)
asked = {m: sorted(f["name"] for f in fields if m in f["methods"]) for m in ("wall", "ground")}
setup = setup_from_answers(
    {"method": "wall", "ground_height": "9.625", "truth1": "1.91, 9.625, 8.375"}, given
)
print(json.dumps({"asked": asked, "method": setup.method, "height": setup.plane_offset}))
"""


def test_a_method_added_to_the_registry_alone_is_asked_what_its_spec_says(
    tmp_path: Path,
) -> None:
    """A fourth method, a copy of ground registered by an extension alone: the page
    shows it the ground height (the fields are the ground's) and a form with it is a setup.
    Before, the fields named their methods, the page hid the height and the form demanded
    it."""
    install_extension(tmp_path, "wall_ext", WALL_EXTENSION)
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    done = subprocess.run(
        [sys.executable, "-c", PROBE], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.splitlines()[-1])
    assert "ground_height" in found["asked"]["wall"]
    assert found["asked"]["wall"] == found["asked"]["ground"]
    assert (found["method"], found["height"]) == ("wall", 9.625)


METHOD_NAMES = {"point", "line", "ground", "board"}
#: The modules that describe a session's setup: none names a method to decide by it.
SETUP_MODULES = (
    "recorder/setup/rules.py",
    "recorder/setup/form.py",
    "recorder/procedure/terminal.py",
    "recorder/setup/plan.py",
    "recorder/setup/plan_file.py",
)


def _method_names(node: ast.AST) -> set[str]:
    """The method names ``node`` spells: a string, or a tuple or list of strings."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return {node.value} & METHOD_NAMES
    if isinstance(node, ast.Tuple | ast.List):
        return set().union(*(_method_names(e) for e in node.elts))
    return set()


@pytest.mark.parametrize("module", SETUP_MODULES)
def test_the_setup_names_no_method(module: str) -> None:
    tree = ast.parse((REPO / module).read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            names = set().union(*(_method_names(n) for n in [node.left, *node.comparators]))
        elif isinstance(node, ast.Tuple | ast.List):
            names = _method_names(node)
        else:
            continue
        if names:
            found.append(f"{module}:{node.lineno}: {ast.unparse(node)}")
    assert not found, "decided by naming methods (read the method's spec):\n" + "\n".join(found)
