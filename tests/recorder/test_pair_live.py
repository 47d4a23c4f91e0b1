"""``twopose-record calibrate-pair PAIR.toml --source pair:A,B``: two cameras read live (here
two lossless videos and two folders of OpenCV's own left/right photographs) give the pair file
the stills give; a stop fits what was kept; too few pairs, a camera that does not open and
wrong combinations are refused in words, nothing written. Real signals to a real process: a
stop within 2 s, exit 130, no traceback, nothing written."""

from __future__ import annotations

import random
import re
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from recorder.calibration.pair import PairRequest, calibrate_pair
from recorder.cli.app import app
from recorder.procedure import stops
from tests.helpers import RECORD, SMALL_SCENE
from twopose.errors import EXIT_ERROR, InputValueError
from twopose.pair.pair_file import read_pair_file
from twopose.values.units import Units

DATA = Path(__file__).resolve().parents[2] / "data" / "opencv-chessboard"
# 13 and 14 are 26 and 33 px apart: the video kept 4 of the 5 at the old 5% of the diagonal
NUMBERS = ("01", "03", "05", "13", "14")
runner = CliRunner()


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Five of OpenCV's pairs: a folder a camera, and each camera's video (FFV1, lossless)
    holding each photograph for 4 frames at 10 fps (0.4 s: the board search keeps up with
    it on a loaded machine)."""
    root = tmp_path_factory.mktemp("live")
    for side in ("left", "right"):
        (root / side).mkdir()
        writer = cv2.VideoWriter(
            str(root / f"{side}.avi"), cv2.VideoWriter.fourcc(*"FFV1"), 10.0, (640, 480)
        )
        for n in NUMBERS:
            image = np.asarray(cv2.imread(str(DATA / f"{side}{n}.jpg")), np.uint8)
            cv2.imwrite(str(root / side / f"{side}{n}.png"), image)
            for _ in range(4):
                writer.write(image)
        writer.release()
    return root


def _request(out: Path, **given: object) -> PairRequest:
    return PairRequest(out=out, board=(9, 6), square=25.0, units=Units.MM, **given)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def from_stills(folders: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("stills") / "PAIR.toml"
    calibrate_pair(
        _request(out, left=str(folders / "left" / "*.png"), right=str(folders / "right" / "*.png"))
    )
    return out


def test_two_folders_give_the_pair_file_the_stills_give(
    folders: Path, from_stills: Path, tmp_path: Path
) -> None:
    out = tmp_path / "PAIR.toml"
    spec = f"pair:images:{folders / 'left'},images:{folders / 'right'}"
    run = calibrate_pair(_request(out, source=spec))
    assert run.live is not None
    assert run.live.stills
    _same_pair(out, from_stills)
    assert read_pair_file(out).view_names == read_pair_file(from_stills).view_names


def test_two_videos_played_live_give_the_stills_pair(
    folders: Path, from_stills: Path, tmp_path: Path
) -> None:
    out = tmp_path / "PAIR.toml"
    said: list[str] = []
    spec = f"pair:video:{folders / 'left.avi'},video:{folders / 'right.avi'}"
    run = calibrate_pair(_request(out, source=spec), say=said.append)
    assert run.live is not None
    assert run.live.dropped == (0, 0)
    text = "\n".join(said)
    assert "kept pair 5 of 15: camera 1 frame 17 & camera 2 frame 17 (skew +0.0 ms)" in text
    assert "the board has not moved since the last pair kept (0 px, less than 20)" in text
    assert said[-1] == "both cameras ended: 5 pair(s) kept of 20 examined"
    _same_pair(out, from_stills)


def _same_pair(path: Path, stills: Path) -> None:
    """The same pair as the stills' (the fit repeats itself to ~1e-8 relative, not bit for
    bit: OpenCV's threads sum in their own order)."""
    a, b = read_pair_file(path), read_pair_file(stills)
    assert a.n_views == b.n_views == 5
    assert a.units == b.units
    np.testing.assert_allclose(a.R_2_to_1, b.R_2_to_1, atol=1e-7)
    np.testing.assert_allclose(a.t_2_in_1, b.t_2_in_1, atol=1e-5)
    np.testing.assert_allclose(a.cov_extrinsic, b.cov_extrinsic, rtol=1e-3, atol=1e-12)
    assert a.rms_px == pytest.approx(b.rms_px, rel=1e-6)


def test_a_stop_fits_the_pairs_kept_so_far(folders: Path, tmp_path: Path) -> None:
    out = tmp_path / "PAIR.toml"
    spec = f"pair:video:{folders / 'left.avi'},video:{folders / 'right.avi'}"

    def say(line: str) -> None:
        stop = stops.active()  # the collection's own (it handles the signals)
        if line.startswith("kept pair 3 of") and stop is not None:
            stop.request(signal.SIGINT)

    before = {s: signal.getsignal(s) for s in stops.STOP_SIGNALS}
    try:
        run = calibrate_pair(_request(out, source=spec), say=say)
    finally:  # a stopped recording leaves the signals ignored: this process goes on
        for s, handler in before.items():
            signal.signal(s, handler)
    assert run.live is not None
    assert run.live.stopped
    assert run.live.ended.startswith("Ctrl-C: 3 pair(s) kept of")
    assert read_pair_file(out).n_views == 3


def test_too_few_pairs_when_the_files_end_are_refused_nothing_written(
    folders: Path, tmp_path: Path
) -> None:
    out = tmp_path / "PAIR.toml"
    spec = f"pair:video:{folders / 'left.avi'},video:{folders / 'right.avi'}"
    with pytest.raises(InputValueError, match=r"2 pair\(s\) kept .* needs 3 pairs or more"):
        calibrate_pair(_request(out, source=spec, views=2))
    assert not out.exists()
    result = runner.invoke(
        app,
        ["calibrate-pair", str(out), "--source", spec.replace("left.avi", "right.avi"),
         "--square", "25", "--units", "mm"],
    )  # fmt: skip
    assert result.exit_code == EXIT_ERROR
    assert "both cameras read the same video" in result.output, result.output  # one file twice
    assert "Traceback" not in result.output
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--source", "pair:synthetic,camera:97"], "camera 97 did not open"),
        (["--source", "synthetic"], "calibrate-pair takes two cameras"),
        (["--source", "pair:synthetic,synthetic", "--left", "l*.jpg"], "one of them"),
        ([], "give the stills (--left and --right) or a pair of cameras"),
        (["--left", "l*.jpg", "--right", "r*.jpg", "--views", "5"], "--views counts the pairs"),
    ],
)
def test_a_wrong_live_command_is_refused_in_words(
    tmp_path: Path, args: list[str], words: str
) -> None:
    out = tmp_path / "PAIR.toml"
    result = runner.invoke(
        app, ["calibrate-pair", str(out), "--square", "25", "--units", "mm", *args]
    )
    assert result.exit_code != 0
    assert words in result.output, result.output
    assert "Traceback" not in result.output
    assert not out.exists()


# ----------------------------------------------------------------- real signals, real process


@pytest.mark.parametrize(
    ("sig", "small"),
    [
        (signal.SIGINT, False),  # the default scene: the stop lands in a view being cast
        (signal.SIGTERM, True),  # the small one: between frames
    ],
)
def test_a_signal_stops_a_live_calibration_within_2_s(
    tmp_path: Path, sig: signal.Signals, small: bool
) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL_SCENE)
    camera = f"synthetic:{scene}" if small else "synthetic"
    out = tmp_path / "PAIR.toml"
    process = subprocess.Popen(
        [str(RECORD), "calibrate-pair", str(out), "--source", f"pair:{camera},{camera}",
         "--square", "25", "--units", "mm"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    lines: list[str] = []
    reading = threading.Thread(target=lambda: lines.extend(process.stdout or []), daemon=True)
    reading.start()
    deadline = time.monotonic() + 60
    while not any("camera 2:" in line for line in lines) and time.monotonic() < deadline:
        time.sleep(0.02)  # the cameras are open and running
    time.sleep(random.Random(sig).uniform(0.0, 0.5))
    process.send_signal(sig)
    sent = time.monotonic()
    process.wait(30)
    took = time.monotonic() - sent
    reading.join(5)
    text = "".join(lines)
    assert process.returncode == 130, text
    assert took < 2.0, f"{took:.2f} s from the signal to the end"
    assert "Traceback" not in text
    assert "nothing written" in text
    assert not out.exists()


def test_a_live_board_search_keeps_a_second_of_each_cameras_frames(tmp_path: Path) -> None:
    """A recording's queue holds 10 s; a live board search wants the latest frames: its
    source's queues hold a second (at 60 fps, 60 frames), so a slow search drops, never lags."""
    from recorder.calibration.pair_live import LIVE_BOUND, LiveOutcome, LiveRules, live_pairs
    from recorder.sources.registry import open_pair

    paths = []
    for c in (1, 2):
        path = tmp_path / f"{c}.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 60.0, (64, 48))
        for _ in range(6):
            writer.write(np.full((48, 64, 3), 40 * c, np.uint8))
        writer.release()
        paths.append(path)
    source = open_pair(f"video:{paths[0]}", f"video:{paths[1]}")
    assert source.bound.seconds == 10.0
    outcome = LiveOutcome()
    assert list(live_pairs(source, (9, 6), LiveRules(), outcome, lambda _: None)) == []
    assert source.bound == LIVE_BOUND
    assert LIVE_BOUND.seconds == 1.0
    assert [r.limit for r in source._readers] == [60, 60]
    assert outcome.examined == 6  # every pair searched, none with a board


@pytest.mark.parametrize(
    ("drop", "words"),
    [
        # left01-13 with right03-14: every pair's numbers differ (it was fitted, RMS 32 px)
        (("left/left14.png", "right/right01.png"), "left01.png & right03.png is paired"),
        # right14 missing: four pairs agree, camera 1's fifth still has no partner
        (("right/right14.png",), "camera 1's folder has 5 stills, camera 2's 4"),
    ],
)
def test_folders_are_paired_as_left_and_right_are(
    folders: Path, tmp_path: Path, drop: tuple[str, ...], words: str
) -> None:
    for side in ("left", "right"):
        shutil.copytree(folders / side, tmp_path / side)
    for name in drop:
        (tmp_path / name).unlink()
    out = tmp_path / "PAIR.toml"
    spec = f"pair:images:{tmp_path / 'left'},images:{tmp_path / 'right'}"
    with pytest.raises(InputValueError, match=re.escape(words)):
        calibrate_pair(_request(out, source=spec))
    assert not out.exists()


def test_a_place_not_kept_is_said_with_its_motion(folders: Path) -> None:
    # the 5th still, 33 px from the 4th, was dropped without a word: "not moved" was said
    # for the 4th still's second frame, and the same reason was not said again
    from recorder.calibration.pair_live import LiveOutcome, LiveRules, live_pairs
    from recorder.sources.pair import PairSource
    from recorder.sources.registry import SOURCE_KINDS, SourceOptions, open_from

    spec = f"pair:video:{folders / 'left.avi'},video:{folders / 'right.avi'}"
    source = open_from(SOURCE_KINDS, spec, SourceOptions())
    assert isinstance(source, PairSource)
    said: list[str] = []
    rules = LiveRules(min_motion_px=40.0)
    kept = [name for name, _, _ in live_pairs(source, (9, 6), rules, LiveOutcome(), said.append)]
    assert len(kept) == 4
    assert (
        "camera 1 frame 17 & camera 2 frame 17: the board has not moved since the last pair "
        "kept (33 px, less than 40): move it to a new place" in said
    )
