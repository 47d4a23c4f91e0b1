"""Calibration from rendered checkerboard views with known intrinsics."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from recorder.calibrate import load_calibration
from recorder.cli import app
from recorder.plan import load_plan
from twopose.camera import rotation_from_angles_deg
from twopose.errors import EXIT_ERROR, InputValueError

runner = CliRunner()
K = np.array([[500.0, 0.0, 322.0], [0.0, 500.0, 236.0], [0.0, 0.0, 1.0]])


def _board_views(folder: Path, n: int = 12) -> Path:
    """Views of a 10x7-square board (9x6 inner corners), 1 unit squares, from known poses."""
    folder.mkdir()
    px = 40  # board-image pixels per square
    board = np.full((9 * px, 12 * px), 255, np.uint8)
    for r in range(7):
        for c in range(10):
            if (r + c) % 2 == 0:
                board[(r + 1) * px : (r + 2) * px, (c + 1) * px : (c + 2) * px] = 0
    scale = np.diag([1.0 / px, 1.0 / px, 1.0])  # board-image pixels -> board units
    rng = np.random.default_rng(3)
    for i in range(n):
        R = rotation_from_angles_deg(rng.uniform([-25, -25, -10], [25, 25, 10]))
        t = np.array([-6.0, -4.5, 0.0]) @ R.T + np.array(
            [rng.uniform(-1, 1), rng.uniform(-1, 1), 20.0]
        )
        H = K @ np.column_stack([R[:, 0], R[:, 1], t]) @ scale
        img = cv2.warpPerspective(board, H, (640, 480), flags=cv2.INTER_AREA, borderValue=160)
        cv2.imwrite(str(folder / f"view{i:02d}.png"), cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    return folder


def test_calibrate_recovers_known_intrinsics(tmp_path: Path) -> None:
    views = _board_views(tmp_path / "views")
    out = tmp_path / "cal.toml"
    result = runner.invoke(
        app,
        ["calibrate", str(out), "--source", f"images:{views}", "--board", "9x6", "--views", "12"],
    )
    assert result.exit_code == 0, result.output
    assert "RMS reprojection error" in result.output
    intr = load_calibration(out)
    assert intr.fx == pytest.approx(500.0, rel=0.01)
    assert intr.fy == pytest.approx(500.0, rel=0.01)
    assert intr.cx == pytest.approx(322.0, abs=3.0)
    assert intr.cy == pytest.approx(236.0, abs=3.0)
    assert (intr.width, intr.height) == (640, 480)
    again = runner.invoke(app, ["calibrate", str(out), "--source", f"images:{views}"])
    assert again.exit_code == EXIT_ERROR
    assert "already exists" in again.output


def test_calibration_is_used_by_plans(tmp_path: Path) -> None:
    cal = tmp_path / "cal.toml"
    cal.write_text(
        "width = 640\nheight = 480\nfx = 510.5\nfy = 509.0\ncx = 321.0\ncy = 239.0\n"
        "distortion = [-0.1, 0.01, 0.0, 0.0, 0.0]\n"
    )
    plan = tmp_path / "plan.toml"
    plan.write_text(
        f'method = "point"\n[camera]\ncalibration = "{cal}"\n'
        "[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n"
    )
    cam = load_plan(plan).cameras[0]
    assert (cam.intrinsics.fx, cam.intrinsics.fy, cam.intrinsics.distortion[0]) == (
        510.5,
        509.0,
        -0.1,
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("width = 640\n", "missing height, fx, fy, cx, cy"),
        ("width = 640\nheight = 480\nfx = -1\nfy = 1\ncx = 0\ncy = 0\n", "fx must be positive"),
    ],
)
def test_bad_calibration_files(tmp_path: Path, text: str, message: str) -> None:
    cal = tmp_path / "cal.toml"
    cal.write_text(text)
    with pytest.raises(InputValueError, match=message):
        load_calibration(cal)


def test_no_board_in_view_is_a_clear_error(tmp_path: Path) -> None:
    folder = tmp_path / "blank"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"{i}.png"), np.full((48, 64, 3), 128, np.uint8))
    result = runner.invoke(
        app, ["calibrate", str(tmp_path / "cal.toml"), "--source", f"images:{folder}"]
    )
    assert result.exit_code == EXIT_ERROR
    assert "board in only 0 frame(s)" in result.output
    assert not (tmp_path / "cal.toml").exists()
