"""Calibration from rendered checkerboard views with known intrinsics."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from recorder.calibration.camera import (
    OUTER_THIRD,
    calibrate,
    fit_views,
    load_calibration,
    load_calibration_sigma,
)
from recorder.cli.app import app
from recorder.setup.plan import load_plan
from recorder.sources.registry import ImagesSource, VideoSource
from twopose.camera.model import rotation_from_angles_deg
from twopose.detect.checkerboard import find_board
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
    assert "board in only 0 view(s)" in result.output
    assert not (tmp_path / "cal.toml").exists()


REAL = Path(__file__).resolve().parents[2] / "data" / "opencv-chessboard"


def test_real_photographs_use_every_view_and_agree_with_opencv(tmp_path: Path) -> None:
    """OpenCV's 13 real photographs (left camera): every view is used, and the intrinsics
    are within 2 sigma of OpenCV's own fit of all 13, computed here with OpenCV directly. The
    folder holds the right camera's 13 too: the source's pattern picks the left ones."""
    left = sorted(REAL.glob("left*.jpg"))
    assert len(left) == 13
    pattern = np.zeros((54, 3), np.float32)
    pattern[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 25.0
    corners = []
    for photo in left:
        gray = cv2.imread(str(photo), cv2.IMREAD_GRAYSCALE)
        assert gray is not None, photo
        found, c = cv2.findChessboardCorners(gray, (9, 6))
        assert found, photo
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
        corners.append(cv2.cornerSubPix(gray, c, (11, 11), (-1, -1), criteria))
    assert len(corners) == 13
    _, K, _, _, _, std, _, _ = cv2.calibrateCameraExtended(
        [pattern] * 13, corners, (640, 480), np.eye(3), np.zeros(5)
    )
    reference = {"fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2]}
    sigma = dict(zip(("fx", "fy", "cx", "cy"), np.ravel(std)[:4], strict=True))

    out = tmp_path / "cal.toml"
    args = ["calibrate", str(out), "--source", f"images:{REAL}/left*.jpg", "--board", "9x6"]
    result = runner.invoke(app, [*args, "--square", "25"])
    assert result.exit_code == 0, result.output
    assert "over 13 views" in result.output
    intr = load_calibration(out)
    ours = {"fx": intr.fx, "fy": intr.fy, "cx": intr.cx, "cy": intr.cy}
    for key, value in ours.items():
        assert abs(value - reference[key]) <= 2 * sigma[key], (key, value, reference[key])
    kept = load_calibration_sigma(out)
    assert set(kept) >= {"fx", "fy", "cx", "cy", "k1", "k2", "k3"}
    assert kept["fx"] == pytest.approx(sigma["fx"], rel=0.05)
    assert "families" not in result.output


def test_a_folder_of_two_cameras_photographs_is_warned_about(tmp_path: Path) -> None:
    """The shared folder holds the left and the right camera's 13 each: fitted as one camera
    (what the operator asked), with a warning that names the two families and the way out."""
    out = tmp_path / "cal.toml"
    args = ["calibrate", str(out), "--source", f"images:{REAL}", "--board", "9x6"]
    result = runner.invoke(app, [*args, "--square", "25"])
    assert result.exit_code == 0, result.output
    assert "over 26 views" in result.output
    assert "2 families (left*, right*)" in result.output
    assert "images:DIR/left*" in result.output
    assert "families" in out.read_text()  # and in the file's warnings


@pytest.mark.parametrize(
    ("names", "families"),
    [
        (["left01.jpg", "left02.jpg", "right01.jpg", "right02.jpg"], 2),
        (["IMG_0001.jpg", "IMG_0002.jpg", "IMG_0003.jpg"], 0),
        (["frame 1", "frame 2", "frame 12"], 0),
        (["a.png", "b.png", "c1.png", "c2.png"], 0),  # one family of two and single names
    ],
)
def test_only_several_families_of_view_names_are_warned_about(
    tmp_path: Path, names: list[str], families: int
) -> None:
    corners, _ = _rendered_corners(tmp_path)
    pattern = np.zeros((54, 3), np.float32)
    pattern[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2)
    fit = fit_views(corners[: len(names)], names, (640, 480), pattern)
    said = [w for w in fit.warnings if "families" in w]
    assert len(said) == (1 if families else 0), fit.warnings
    if families:
        assert f"{families} families" in said[0]


def _rendered_corners(tmp_path: Path) -> tuple[list[np.ndarray], list[str]]:
    views = _board_views(tmp_path / "views")
    corners, names = [], []
    for image in sorted(views.iterdir()):
        bgr = cv2.imread(str(image))
        assert bgr is not None, image
        c = find_board(np.asarray(bgr, dtype=np.uint8), (9, 6))
        assert c is not None
        corners.append(c)
        names.append(image.name)
    return corners, names


def test_a_view_far_worse_than_the_others_is_dropped_and_named(tmp_path: Path) -> None:
    corners, names = _rendered_corners(tmp_path)
    pattern = np.zeros((54, 3), np.float32)
    pattern[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2)
    rng = np.random.default_rng(0)
    corners[4] = (corners[4] + rng.normal(0, 6.0, corners[4].shape)).astype(np.float32)
    fit = fit_views(corners, names, (640, 480), pattern)
    assert fit.n_views == len(names) - 1
    assert len(fit.dropped) == 1
    assert fit.dropped[0].startswith(names[4])
    assert names[4] not in fit.view_names
    assert fit.intrinsics.fx == pytest.approx(500.0, rel=0.01)  # the truth, once it is gone
    assert len(fit.view_rms_px) == fit.n_views
    assert set(fit.sigma) >= {"fx", "fy", "cx", "cy"}


def test_corners_kept_near_the_centre_are_warned_about(tmp_path: Path) -> None:
    corners, names = _rendered_corners(tmp_path)
    pattern = np.zeros((54, 3), np.float32)
    pattern[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2)
    fit = fit_views(corners, names, (640, 480), pattern)
    assert fit.reach < OUTER_THIRD  # the rendered boards stay near the middle
    assert any("outer third" in w for w in fit.warnings)
    assert 0 < fit.coverage < 1


def test_a_camera_keeps_a_frame_only_when_the_board_moved(tmp_path: Path) -> None:
    """A video holding each of 12 views 4 times: 12 views, not 48 (nor every 4th frame)."""
    views = sorted(_board_views(tmp_path / "views").iterdir())
    video = tmp_path / "board.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), 30, (640, 480))
    for image in views:
        frame = cv2.imread(str(image))
        assert frame is not None, image
        for _ in range(4):
            writer.write(frame)
    writer.release()
    fit = calibrate(VideoSource(video, realtime=False), (9, 6), 1.0, min_motion_px=5.0, views=40)
    assert fit.n_views == len(views)
    stills = calibrate(ImagesSource(tmp_path / "views"), (9, 6), 1.0)
    assert stills.n_views == len(views)  # every still, whatever --views would say for a camera
