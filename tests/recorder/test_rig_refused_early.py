"""``twopose-record new --rig`` (issue 55, item 6): a rig file knows its camera and its
units, and the recorder refuses one that does not fit as soon as it can tell: before the
first setup question for what the command line gave (the image size, the units), right
after the answer that decides otherwise, never after the whole setup was typed; in a plan
before anything is recorded. The live result's regions carry the rig's covariance."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.procedure.capture import CaptureSettings
from twopose.errors import EXIT_ERROR
from twopose.rig.file import load_rig

#: A rig fitted for the thesis' webcam (640x480, f 525), in inches, with its covariance.
RIG = """format = 2
[rig]
units = "{units}"
camera_offset = [0.3, 0.2, 0.4]

[sigma]
offset_x = 0.02
principal_dx_px = 0.5

[covariance]
names = ["offset_x", "principal_dx_px"]
matrix = [[0.0004, 0.009], [0.009, 0.25]]

[[camera]]
width = 640
height = 480
fx = 525.0
fy = 525.0
cx = 320.0
cy = 240.0
"""


@pytest.fixture
def rig(tmp_path: Path) -> Path:
    path = tmp_path / "rig.toml"
    path.write_text(RIG.format(units="in"))
    return path


def _new(tmp_path: Path, *args: str, answers: str = "") -> tuple[int, str]:
    out = tmp_path / "s.mcap"
    result = CliRunner().invoke(
        app, ["new", str(out), "--source", "synthetic", *args], input=answers
    )
    assert "Traceback" not in result.output
    assert not out.exists()  # refused before anything is recorded
    return result.exit_code, result.output


def test_a_rig_for_another_camera_is_refused_before_the_first_question(
    tmp_path: Path, rig: Path
) -> None:
    code, said = _new(
        tmp_path, "--rig", str(rig), "--width", "1280", "--height", "720", "--focal", "900"
    )
    assert code == EXIT_ERROR, said
    assert "fitted for the camera 640x480, f 525 px" in said
    assert "1280x720" in said
    assert "method (" not in said  # nothing was asked


def test_the_camera_is_checked_once_its_focal_length_is_typed(tmp_path: Path, rig: Path) -> None:
    code, said = _new(tmp_path, "--rig", str(rig), answers="point\nin\n900\n320, 240\n")
    assert code == EXIT_ERROR, said
    assert "not for this session's 640x480, f 900 px" in said
    assert "operator" not in said  # refused there, not after the rest of the setup


def test_a_rig_in_other_units_is_refused_as_soon_as_the_units_are_known(
    tmp_path: Path,
) -> None:
    cm = tmp_path / "cm.toml"
    cm.write_text(RIG.format(units="cm"))
    code, said = _new(tmp_path, "--rig", str(cm), "--units", "in")
    assert code == EXIT_ERROR, said
    assert "is in cm, the session in in" in said
    assert "method (" not in said  # before the first question
    code, said = _new(tmp_path, "--rig", str(cm), answers="point\nin\n")
    assert code == EXIT_ERROR, said
    assert "is in cm, the session in in" in said
    assert "focal" not in said  # right after the units, not after the whole setup


def test_the_live_result_carries_the_rigs_covariance(rig: Path) -> None:
    constants = load_rig(rig)
    noise = CaptureSettings(rig=constants).estimate_options().noise
    assert noise.rig is not None
    assert noise.rig == constants.covariance
    assert CaptureSettings().estimate_options().noise.rig is None


def test_the_console_is_not_served_for_a_rig_the_command_line_already_refuses(
    tmp_path: Path, rig: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import recorder.console.server

    served: list[object] = []  # were the page served, the test ends there instead of waiting
    monkeypatch.setattr(recorder.console.server, "serve_console", lambda *a, **k: served.append(a))
    code, said = _new(tmp_path, "--ui", "--rig", str(rig), "--width", "1280", "--height", "720")
    assert served == []
    assert code == EXIT_ERROR, said
    assert "not for 1280x720 images" in said
