"""recorder.console.state directly: the page's state before and after the setup (the method and
units from the registry's types, the setup form's defaults from the setup rules), refusals,
captured frames against previews, and the web driver typing as many poses a trial as the
command line asked (``--poses``), like the terminal's."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.console.driver import WebDriver
from recorder.console.state import ConsoleSession
from recorder.procedure.terminal import _OperatorDriver
from recorder.setup.form import FormRefusedError, setup_from_answers
from recorder.setup.rules import (
    THESIS_FOCAL_PX,
    THESIS_IMAGE_SIZE,
    GuidanceAsked,
    PoseTyping,
    Setup,
    default_principal,
)
from recorder.sources.registry import SyntheticSource
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import SessionInfo
from twopose.methods.specs import Method, spec_of
from twopose.values.units import Units


@pytest.mark.parametrize("poses", [2, 3, 8])
def test_both_drivers_type_the_poses_a_trial_was_asked_for(tmp_path: Path, poses: int) -> None:
    typing = PoseTyping(poses_per_trial=poses)
    source = SyntheticSource(None, Method.POINT, realtime=False)
    web = WebDriver(ConsoleSession(tmp_path / "s.mcap"), source, "cam0", (), typing)
    camera = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525, fy=525, cx=320, cy=240),
    )
    terminal = _OperatorDriver(None, SessionInfo(method="point", units="in"), camera, (), typing)  # type: ignore[arg-type]
    assert web.poses_in(1) == poses
    assert terminal.poses_in(1) == poses


def _setup(method: Method, units: Units) -> Setup:
    return Setup(
        method=method,
        units=units,
        intrinsics=Intrinsics(width=640, height=480, fx=525, fy=525, cx=320, cy=240),
        plane_offset=9.625 if spec_of(method).needs_ground else None,
        ground_truth=(),
        operator="t",
    )


def test_the_page_knows_no_method_before_the_setup_and_the_registrys_after(tmp_path: Path) -> None:
    session = ConsoleSession(tmp_path / "s.mcap")
    before = session.snapshot()
    assert (before["phase"], before["method"], before["units"]) == ("setup", "", "")
    assert session.method_spec() is None
    assert [f["name"] for f in before["setup_fields"]][:2] == ["method", "units"]
    session.begin(_setup(Method.LINE, Units.CM), None)
    after = session.snapshot()
    assert (after["phase"], after["method"], after["units"]) == ("recording", "line", "cm")
    assert after["setup_fields"] == []  # the form is gone once the setup is accepted
    assert session.method_spec() == spec_of(Method.LINE)
    assert after["setup"]["camera"].startswith("f 525 px")


def test_the_setup_form_shows_the_thesis_defaults_from_the_setup_rules(tmp_path: Path) -> None:
    fields = {f["name"]: f for f in ConsoleSession(tmp_path / "s.mcap").snapshot()["setup_fields"]}
    assert fields["focal"]["value"] == f"{THESIS_FOCAL_PX:g}"
    cx, cy = default_principal(THESIS_IMAGE_SIZE)
    assert fields["principal"]["value"] == f"{cx:g}, {cy:g}"
    given = ConsoleSession(tmp_path / "t.mcap", {"units": Units.MM, "focal": 600.0})
    shown = {f["name"]: f for f in given.snapshot()["setup_fields"]}
    assert shown["focal"] == {**shown["focal"], "given": True, "value": "600"}
    assert shown["units"]["value"] == "mm"


def test_the_stop_rule_is_a_setup_field_checked_like_the_terminals(tmp_path: Path) -> None:
    """Empty: no stop rule; a length: the setup's target; anything else refused under its
    field; given on the command line: shown read-only and taken over the form's."""
    fields = {f["name"]: f for f in ConsoleSession(tmp_path / "s.mcap").snapshot()["setup_fields"]}
    assert fields["target_precision"]["value"] == ""
    assert "board" not in fields["target_precision"]["methods"]
    form = {"method": "point", "truth1": "0.5, 1.5, 11", "operator": "Ada"}
    assert setup_from_answers(form, {}).target95 is None
    assert setup_from_answers(form | {"target_precision": "0.5"}, {}).target95 == 0.5
    with pytest.raises(FormRefusedError) as refused:
        setup_from_answers(form | {"target_precision": "-1"}, {})
    assert set(refused.value.errors) == {"target_precision"}
    given = {"target_precision": 0.25}
    shown = {
        f["name"]: f for f in ConsoleSession(tmp_path / "t.mcap", given).snapshot()["setup_fields"]
    }
    assert shown["target_precision"] == {
        **shown["target_precision"],
        "given": True,
        "value": "0.25",
    }
    assert setup_from_answers(form | {"target_precision": "9"}, given).target95 == 0.25
    board = {"method": "board", "board": "9x6", "square": "1", "board_corner": "0, 9.625, 20"}
    assert setup_from_answers(board | {"target_precision": "junk"}, {}).target95 is None
    guidance = GuidanceAsked().guidance(Units.IN, 2, 0.5)
    assert (guidance.target95, guidance.max_poses) == (0.5, 6)
    assert GuidanceAsked().guidance(Units.IN, 2, None).max_poses == 2


def test_refusals_are_numbered_so_the_page_shows_each_once(tmp_path: Path) -> None:
    session = ConsoleSession(tmp_path / "s.mcap")
    session.refuse("pose", "x: not a number")
    first = session.snapshot()["refusal"]
    session.refuse("pose", "x: not a number")
    second = session.snapshot()["refusal"]
    assert first["message"] == second["message"] == "x: not a number"
    assert second["seq"] == first["seq"] + 1


def test_a_captured_frame_is_listed_a_preview_is_not(tmp_path: Path) -> None:
    session = ConsoleSession(tmp_path / "s.mcap")
    session.frame("cam0", b"jpeg", "jpeg", 0, None, "")  # a preview
    session.frame("cam0", b"jpeg", "jpeg", 1, None, "trial 1 pose 1 frame 1")
    frames = session.snapshot()["frames"]
    assert len(frames) == 1
    assert frames[0]["found"] is None  # no detector ran (as on a board session): not "not found"
    latest = session.next_frame(after=0, timeout_s=0.1)
    assert latest is not None
    assert latest.seq == 2
    assert session.next_frame(after=2, timeout_s=0.05) is None  # nothing newer: no wait forever


def test_values_given_are_shown_back_as_given_while_recording(tmp_path: Path) -> None:
    """A value shown back is the value given (issue 44): the page's setup line, the stop
    rule, a suggestion the operator types and info's cameras never round to six digits
    (``--focal 1234.56789`` was shown as 1234.57 once recording started)."""
    import dataclasses

    from twopose.guidance.advice import Suggestion

    k = Intrinsics(width=640, height=480, fx=1234.56789, fy=1234.56789, cx=320.25, cy=240.125)
    setup = dataclasses.replace(_setup(Method.POINT, Units.MM), intrinsics=k, target95=0.123456789)
    session = ConsoleSession(tmp_path / "s.mcap")
    session.begin(setup, None)
    line = session.snapshot()["setup"]
    assert line["camera"].startswith("f 1234.56789 px, principal point (320.25, 240.125) px")
    assert line["stop_rule"].endswith("within 0.123456789 mm")
    suggestion = Suggestion(
        t_grid=(123.5625, 0.0, -1001.0625), r_deg=(0.0, 0.0, 0.0), predicted95=1.0,
        thesis_t_grid=(1.2, 0.0, 0.0), thesis95=2.0, provisional=False, n_candidates=1,
    )  # fmt: skip
    text = suggestion.text(Units.MM)
    assert "x 123.5625, y 0, z -1001.0625 mm" in text
    assert "the thesis' move to 1.2, 0, 0 would" in text
