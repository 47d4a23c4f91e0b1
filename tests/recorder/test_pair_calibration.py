"""``twopose-record calibrate-pair`` on OpenCV's own left/right photographs (a subset, to
stay fast): the calibration said and written, from stills or any iterator of pairs, with
fitted or given intrinsics and a floor; and every way a user can get it wrong refused in
words, never a traceback, never a file overwritten."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from recorder.calibration.camera import fit_views, save_calibration
from recorder.calibration.pair import (
    PairRequest,
    calibrate_pair,
    calibrate_pair_views,
    read_still_pairs,
    still_pairs,
)
from recorder.cli.app import app
from twopose.detect.checkerboard import board_pattern, find_board
from twopose.errors import EXIT_ERROR, EXIT_USAGE
from twopose.pair.pair_file import read_pair_file
from twopose.values.units import Units

DATA = Path(__file__).resolve().parents[2] / "data" / "opencv-chessboard"
NUMBERS = ("01", "03", "05", "07", "09")
runner = CliRunner()


@pytest.fixture(scope="module")
def stills(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Five of OpenCV's left/right pairs, copied into a folder of their own."""
    folder = tmp_path_factory.mktemp("stills")
    for n in NUMBERS:
        for side in ("left", "right"):
            shutil.copy(DATA / f"{side}{n}.jpg", folder / f"{side}{n}.jpg")
    return folder


def _image(path: Path) -> np.ndarray:
    return np.asarray(cv2.imread(str(path)), np.uint8)


def _args(stills: Path, out: Path, *extra: str) -> list[str]:
    return [
        "calibrate-pair", str(out), "--left", str(stills / "left*.jpg"),
        "--right", str(stills / "right*.jpg"), "--square", "25", "--units", "mm", *extra,
    ]  # fmt: skip


def test_a_real_calibration_is_said_and_written(stills: Path, tmp_path: Path) -> None:
    out = tmp_path / "PAIR.toml"
    floor = [
        "--floor-left",
        str(stills / "left01.jpg"),
        "--floor-right",
        str(stills / "right01.jpg"),
    ]
    result = runner.invoke(app, _args(stills, out, *floor))
    assert result.exit_code == 0, result.output
    pc = read_pair_file(out)
    text = result.output
    assert "left01.jpg & right01.jpg: board found in camera 1, found in camera 2" in text
    a, sa = pc.angles_deg, pc.sigma_angles_deg
    assert f"angles rx {a[0]:+.3f} ± {sa[0]:.3f}, ry {a[1]:+.3f} ± {sa[1]:.3f}" in text
    assert f"baseline {pc.baseline:.4g} mm" in text
    assert f"RMS reprojection error {pc.rms_px:.3f} px over 5 pairs of stills" in text
    assert "intrinsics: fitted on each camera's own stills (5 and 5 views" in text
    assert "leave-one-out: 465 held-out corner spacings over 5 folds" in text
    assert ": passed" in text
    assert "the covariance is widened by a variance factor of" in text
    assert "floor: normal" in text
    # five moments, each camera's intrinsics fitted on them: what the sigmas leave out is
    # said (a new user's r7 K7: 3-4 stills printed a pose 4-14 sigmas off, `passed`)
    assert "warning: 5 pairs: ten to twenty moments are advised" in text
    assert "each camera's intrinsics were fitted here on 5 and 5 views" in text
    assert "--calibration-left and --calibration-right" in text
    assert pc.floor is not None
    assert 80 < pc.baseline < 90
    assert pc.view_names[0] == "left01.jpg & right01.jpg"


def test_the_same_from_any_iterator_of_pairs_and_given_intrinsics(
    stills: Path, tmp_path: Path
) -> None:
    """One call from Python over a generator of decoded pairs (a live pair: source's frames
    later), with calibration files: their intrinsics used as given, and said."""
    obj = board_pattern((9, 6), 25.0)
    for side in ("left", "right"):
        views = [find_board(_image(stills / f"{side}{n}.jpg"), (9, 6)) for n in NUMBERS]
        calibration = fit_views([v for v in views if v is not None], list(NUMBERS), (640, 480), obj)
        save_calibration(calibration, tmp_path / f"{side}.toml")

    def frames() -> Iterator[tuple[str, np.ndarray, np.ndarray]]:
        for n in NUMBERS:
            yield (
                n,
                _image(stills / f"left{n}.jpg"),
                _image(stills / f"right{n}.jpg"),
            )

    from recorder.calibration.camera import load_calibration, load_calibration_sigma

    given = tuple(
        (load_calibration(tmp_path / f"{s}.toml"), load_calibration_sigma(tmp_path / f"{s}.toml"))
        for s in ("left", "right")
    )
    run = calibrate_pair_views(frames(), (9, 6), 25.0, Units.MM, calibrations=given)  # type: ignore[arg-type]
    assert run.used == NUMBERS
    assert run.own == (None, None)
    assert run.pair.intrinsics1 == given[0][0]
    assert run.pair.sigma1 == given[0][1]
    out = tmp_path / "PAIR.toml"
    result = runner.invoke(
        app,
        _args(stills, out, "--calibration-left", str(tmp_path / "left.toml"),
              "--calibration-right", str(tmp_path / "right.toml")),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert f"intrinsics: calibration files {tmp_path / 'left.toml'} and" in result.output
    assert "intrinsics were fitted here" not in result.output  # given: nothing left out
    assert np.allclose(read_pair_file(out).R_2_to_1, run.pair.R_2_to_1, atol=1e-12)
    # The files swapped (a new user's: the pair 30 sigma off, "passed"): refused, none written.
    swapped = tmp_path / "SWAPPED.toml"
    result = runner.invoke(
        app,
        _args(stills, swapped, "--calibration-left", str(tmp_path / "right.toml"),
              "--calibration-right", str(tmp_path / "left.toml")),
    )  # fmt: skip
    assert result.exit_code == EXIT_ERROR, result.output
    said = " ".join(result.output.split())
    assert "the stills fit the calibration files swapped" in said
    assert "10 of 10 views fit better the other way" in said
    assert not swapped.exists()


def test_an_existing_pair_file_is_refused_before_any_work(stills: Path, tmp_path: Path) -> None:
    out = tmp_path / "PAIR.toml"
    out.write_text("kept", "utf-8")
    result = runner.invoke(app, _args(stills, out))
    assert result.exit_code == EXIT_ERROR
    assert "already exists; choose another pair file" in result.output
    assert "board found" not in result.output  # refused before reading a still
    assert out.read_text("utf-8") == "kept"


def test_an_output_in_a_missing_folder_is_refused_before_any_work(
    stills: Path, tmp_path: Path
) -> None:
    out = tmp_path / "nodir" / "P.toml"
    result = runner.invoke(app, _args(stills, out))
    assert result.exit_code == EXIT_ERROR, result.output
    assert f"cannot create {out}: the folder {out.parent} does not exist" in result.output
    assert "board found" not in result.output  # said before reading a still, not a traceback


def test_calibrate_refuses_a_board_opencv_cannot_search(stills: Path, tmp_path: Path) -> None:
    out = tmp_path / "cal.toml"
    args = ["calibrate", str(out), "--source", f"images:{stills}", "--board", "2x5"]
    result = runner.invoke(app, [*args, "--square", "25"])
    assert result.exit_code == EXIT_ERROR, result.output
    assert "--board: inner corners cols must be a whole number from 3 to 100, got 2" in (
        result.output
    )
    assert not out.exists()


@pytest.fixture
def uneven(stills: Path, tmp_path: Path) -> Path:
    """The five pairs, but camera 2's third still is missing."""
    folder = tmp_path / "uneven"
    shutil.copytree(stills, folder)
    (folder / "right05.jpg").unlink()
    return folder


def test_mismatched_stills_are_refused(uneven: Path, tmp_path: Path) -> None:
    result = runner.invoke(app, _args(uneven, tmp_path / "P.toml"))
    assert result.exit_code == EXIT_ERROR
    assert "--left matches 5 images, --right 4" in result.output
    (uneven / "left05.jpg").unlink()
    (uneven / "left09.jpg").rename(uneven / "left11.jpg")  # now left11 pairs with right09
    result = runner.invoke(app, _args(uneven, tmp_path / "P.toml"))
    assert result.exit_code == EXIT_ERROR
    assert "left11.jpg is paired with right09.jpg (sorted names) but their numbers differ" in (
        result.output
    )
    assert not (tmp_path / "P.toml").exists()


def test_pairs_without_the_board_in_both_are_said_and_too_few_refused(
    stills: Path, tmp_path: Path
) -> None:
    folder = tmp_path / "blank"
    shutil.copytree(stills, folder)
    blank = np.full((480, 640, 3), 128, np.uint8)
    for n in ("05", "07", "09"):
        cv2.imwrite(str(folder / f"right{n}.jpg"), blank)
    result = runner.invoke(app, _args(folder, tmp_path / "P.toml"))
    assert result.exit_code == EXIT_ERROR
    assert "left05.jpg & right05.jpg: board found in camera 1, not found in camera 2" in (
        result.output
    )
    assert "found in both cameras in 2 pair(s) of 5; the pair's calibration needs 3" in (
        result.output
    )
    assert "left07.jpg & right07.jpg (no board in camera 2)" in result.output
    assert not (tmp_path / "P.toml").exists()


@pytest.mark.parametrize(
    ("change", "code", "words"),
    [
        (["--right", "LEFT"], EXIT_ERROR, "is both cameras' still: --left and --right must differ"),
        (["--left", "NOWHERE/left*.jpg"], EXIT_ERROR, "matches no image"),
        (["--calibration-left", "CAL"], EXIT_ERROR, "give both cameras' calibration files"),
        (["--floor-right", "RIGHT01"], EXIT_ERROR, "--floor-right needs --floor-left"),
        # a thickness with no floor still was dropped without a word (a new user's r7 K9)
        (["--board-thickness", "3"], EXIT_ERROR, "--board-thickness needs --floor-left"),
        (["--board", "9x"], EXIT_ERROR, "--board: inner corners rows: type a"),
        (["--board", "nine"], EXIT_ERROR, "--board: type the board's inner corners as COLSxROWS"),
        # OpenCV's board search needs 3 or more each way (it raised cv2.error on 2x5)
        (
            ["--board", "2x5"],
            EXIT_ERROR,
            "--board: inner corners cols must be a whole number from 3",
        ),
        # a board size found in no still: the size named as the likelier cause
        (["--board", "9x5"], EXIT_ERROR, "a 9x5 board is in none of them: is --board right"),
        (["--square", "0"], EXIT_USAGE, "--square"),
        (["--square", "1_0"], EXIT_USAGE, "--square"),
        (["--units", "ft"], EXIT_USAGE, "--units"),
        (["--board-thickness", "-1"], EXIT_USAGE, "a length >= 0"),
        (["--board-thickness", "inf"], EXIT_USAGE, "--board-thickness"),
        (["EXTRA.jpg", "MORE.jpg"], EXIT_ERROR, "quote the file patterns"),
    ],
)
def test_each_wrong_command_line_is_refused_in_words(
    stills: Path, tmp_path: Path, change: list[str], code: int, words: str
) -> None:
    cal = tmp_path / "cal.toml"
    cal.write_text("width = 640\nheight = 480\nfx = 500.0\nfy = 500.0\ncx = 320.0\ncy = 240.0\n")
    names = {
        "LEFT": str(stills / "left*.jpg"), "CAL": str(cal),
        "RIGHT01": str(stills / "right01.jpg"), "NOWHERE/left*.jpg": str(tmp_path / "no/left*.jpg"),
    }  # fmt: skip
    args = _args(stills, tmp_path / "P.toml")
    for option, value in zip(change[::2], change[1::2], strict=False):
        if option in args:
            args[args.index(option) + 1] = names.get(value, value)
        else:
            args += [option, names.get(value, value)]
    if change[0] == "EXTRA.jpg":
        args += change
    result = runner.invoke(app, args)
    assert result.exit_code == code, result.output
    assert words in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "P.toml").exists()


def test_intrinsics_of_another_size_and_a_floor_without_its_board_are_refused(
    stills: Path, tmp_path: Path
) -> None:
    small = tmp_path / "small.toml"
    small.write_text("width = 320\nheight = 240\nfx = 250.0\nfy = 250.0\ncx = 160.0\ncy = 120.0\n")
    request = PairRequest(
        out=tmp_path / "P.toml", left=str(stills / "left*.jpg"), right=str(stills / "right*.jpg"),
        board=(9, 6), square=25.0, units=Units.MM, calibration_left=small,
        calibration_right=small,
    )  # fmt: skip
    from twopose.errors import InputValueError

    with pytest.raises(
        InputValueError, match="camera 1's stills are 640x480, its calibration 320x240"
    ):
        calibrate_pair(request)
    blank = tmp_path / "blank.jpg"
    cv2.imwrite(str(blank), np.full((480, 640, 3), 128, np.uint8))
    floorless = PairRequest(
        out=tmp_path / "P.toml", left=str(stills / "left*.jpg"), right=str(stills / "right*.jpg"),
        board=(9, 6), square=25.0, units=Units.MM, floor_left=blank,
    )  # fmt: skip
    with pytest.raises(InputValueError, match="floor board was not found in camera 1's still"):
        calibrate_pair(floorless)
    assert not (tmp_path / "P.toml").exists()


def test_stills_are_paired_by_their_sorted_names(stills: Path) -> None:
    files = still_pairs(str(stills / "left*.jpg"), str(stills / "right*.jpg"))
    assert [name for name, _, _ in files][:2] == [
        "left01.jpg & right01.jpg",
        "left03.jpg & right03.jpg",
    ]
    first = next(read_still_pairs(files))
    assert first[1].shape == (480, 640, 3)


def test_stills_of_different_moments_are_refused_by_their_rms(stills: Path) -> None:
    # camera 2's stills shifted by one moment: the fit said "passed" at RMS 32 px
    from twopose.errors import InputValueError

    lefts = [_image(stills / f"left{n}.jpg") for n in NUMBERS]
    rights = [_image(stills / f"right{n}.jpg") for n in NUMBERS]
    shifted = [
        (f"pair {k}", a, b)
        for k, (a, b) in enumerate(zip(lefts, rights[1:] + rights[:1], strict=True))
    ]
    with pytest.raises(
        InputValueError, match=r"RMS reprojection error is \d+\.\d px over 5 views, above the 2 px"
    ):
        calibrate_pair_views(shifted, (9, 6), 25.0, Units.MM)


def test_a_board_smaller_than_the_stills_show_is_refused(stills: Path, tmp_path: Path) -> None:
    # OpenCV finds an 8x6 grid inside the 9x6 board: the fit "passed" with tz +0.27 (not -1.03)
    out = tmp_path / "P.toml"
    result = runner.invoke(app, [*_args(stills, out), "--board", "8x6"])
    assert result.exit_code == EXIT_ERROR, result.output
    assert (
        "the board has more corners than --board says: left03.jpg & right03.jpg (camera 1) "
        "shows 9x6 inner corners, --board 8x6" in result.output
    )
    args = ["calibrate", str(out), "--source", f"images:{stills}", "--board", "8x6"]
    result = runner.invoke(app, [*args, "--square", "25"])
    assert result.exit_code == EXIT_ERROR, result.output
    assert "the board has more corners than --board says: " in result.output
    assert "shows 9x6 inner corners, --board 8x6" in result.output
    assert not out.exists()


def test_a_grid_ending_on_the_printed_border_is_not_a_larger_board() -> None:
    from recorder.calibration.board_size import larger_board

    image = _image(DATA / "left13.jpg")  # OpenCV finds a 10x6 grid here, half a square out
    assert find_board(image, (10, 6)) is not None
    corners = find_board(image, (9, 6))
    assert corners is not None
    assert larger_board(image, (9, 6), corners) is None


def test_floor_stills_of_two_moments_are_refused(stills: Path, tmp_path: Path) -> None:
    # left03 with right05 gave "height 335 +- 12 mm" (the same moment's: 265 +- 0.1 mm)
    out = tmp_path / "P.toml"
    floor = ["--floor-left", str(DATA / "left03.jpg"), "--floor-right", str(DATA / "right05.jpg")]
    result = runner.invoke(app, [*_args(stills, out), *floor])
    assert result.exit_code == EXIT_ERROR, result.output
    assert "the floor board's pose from camera 1 and from camera 2 disagree" in result.output
    assert "are --floor-left and --floor-right of the same moment" in result.output
    assert not out.exists()
