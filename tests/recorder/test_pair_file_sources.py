"""Two cameras read from files or folders (issue 58, a new user's r5 findings): a folder
that runs out before the other ends the trial at once, said (F7); one source given for both
cameras is refused (F3)."""

from __future__ import annotations

import re
import shutil
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.procedure.stream import ScheduledTouch, StreamDriver, record_stream
from recorder.procedure.stream_terminal import PairSetup, open_pair_source, pair_cameras
from recorder.sources.registry import open_pair
from tests.helpers import write_video
from twopose.errors import SourceError
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.methods.specs import Method
from twopose.pair.motion import thesis_pair
from twopose.pair.pair_file import write_pair_file
from twopose.values.units import Units


def _stills(folder: Path, n: int, seed: int) -> Path:
    """``n`` noisy grey stills of the pair's size (small PNGs: quick to read)."""
    k = thesis_pair().intrinsics1
    rng = np.random.default_rng(seed)
    folder.mkdir()
    for i in range(n):
        image = np.clip(80 + rng.normal(0, 2.0, (k.height, k.width, 3)), 0, 255)
        cv2.imwrite(str(folder / f"{i:03d}.png"), image.astype(np.uint8))
    return folder


class _Lasting(StreamDriver):
    def duration_s(self, trial: int) -> float:
        return 0.9


def test_a_folder_that_runs_out_ends_the_trial_at_once_incomplete(tmp_path: Path) -> None:
    """Camera 2's folder holds 10 stills (0.3 s at 30 fps), camera 1's 40, the trial lasts
    0.9 s: the trial ends on the stream's clock right after camera 2's last still (not
    "complete", not 1 s of wall time later), its window incomplete naming the folder."""
    a, b = _stills(tmp_path / "a", 40, 1), _stills(tmp_path / "b", 10, 2)
    pair = thesis_pair()
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    source = open_pair_source(f"pair:images:{a},images:{b}", pair, setup, fps=None)
    out = tmp_path / "short.mcap"
    summary = record_stream(out, setup.info(), pair_cameras(pair), pair, source, _Lasting())
    assert summary.kept
    assert "camera 2 (images:" in summary.stopped, summary.stopped
    assert "ran out" in summary.stopped, summary.stopped
    assert "(stopped: camera 2" in summary.line(), summary.line()
    (end,) = summary.trials
    assert end.n_frames == (11, 10), end  # camera 1's last frame within 2 intervals of b's
    with SessionReader(out) as reader:
        (trial,) = read_pair_session(reader).trials
    assert "ran out" in trial.camera1.reason, trial.camera1.reason


@pytest.mark.parametrize(
    ("first", "second", "said"),
    [
        ("video:{d}/c1.avi", "video:{d}/./sub/../c1.avi", "both cameras read the same video"),
        ("video:{d}/c1.avi", "video:{d}/link.avi", "both cameras read the same video"),
        ("camera:0", "camera:0", "both cameras read the same camera device (0)"),
        ("images:{d}/a", "images:{d}/a/", "both cameras read the same folder of images"),
        ("images:{d}/a", "images:{d}/a/*.png", "both cameras read the same files"),
        (
            "images:{d}/a/*.png",
            "images:{d}/sub/../a/*.png",
            "both cameras read the same folder of images",
        ),
    ],
)
def test_a_pair_of_one_source_given_twice_is_refused(
    tmp_path: Path, first: str, second: str, said: str
) -> None:
    """The same file, device or folder for both cameras (however spelled), or two copies
    of one recording: refused in words before anything opens (F3: rays of one image through
    two centres 'measured' a clock offset, and the live page said conditioning ok)."""
    video = write_video(tmp_path / "c1.avi", 3)
    (tmp_path / "link.avi").symlink_to(video)
    (tmp_path / "sub").mkdir()
    _stills(tmp_path / "a", 2, 1)
    a, b = (s.format(d=tmp_path) for s in (first, second))
    with pytest.raises(SourceError, match=re.escape(said)):
        open_pair(a, b)


@pytest.mark.parametrize("kind", ["video", "images"])
def test_two_copies_of_one_recording_are_warned_of_with_camera_2(tmp_path: Path, kind: str) -> None:
    """Camera 2's files identical to camera 1's byte for byte: said with camera 2 (as the
    cameras are printed by new --pair, point and calibrate-pair) and in the warnings; two
    cameras' own files are not."""
    if kind == "video":
        one = write_video(tmp_path / "c1.avi", 3)
        copy, other = shutil.copy(one, tmp_path / "copy.avi"), tmp_path / "c2.avi"
        write_video(other, 3, step=21)
    else:
        one = _stills(tmp_path / "a", 2, 1)
        copy, other = shutil.copytree(one, tmp_path / "acopy"), _stills(tmp_path / "b", 2, 2)
    with open_pair(f"{kind}:{one}", f"{kind}:{copy}") as source:
        first, second = source.cameras
        warnings = source.warnings
    assert "byte for byte" in second.text(), second.text()
    assert "warning" not in first.text()
    assert any("byte for byte" in w for w in warnings), warnings
    with open_pair(f"{kind}:{one}", f"{kind}:{other}") as source:
        assert "warning" not in source.cameras[1].text()
        assert not source.warnings


def test_new_pair_refuses_one_video_for_both_cameras_before_asking(tmp_path: Path) -> None:
    write_pair_file(tmp_path / "PAIR.toml", thesis_pair())
    video = write_video(tmp_path / "c1.avi", 3)
    result = CliRunner().invoke(app, [
        "new", str(tmp_path / "s.mcap"), "--pair", str(tmp_path / "PAIR.toml"),
        "--source", f"pair:video:{video},video:{video}",
    ])  # fmt: skip
    assert result.exit_code != 0
    assert "both cameras read the same video" in result.output, result.output
    assert "method" not in result.output  # nothing asked
    assert not (tmp_path / "s.mcap").exists()


class _Late(StreamDriver):
    """One trial of 0.2 s, started ``wait_s`` after the files opened (an operator's or a
    loaded machine's delay)."""

    def __init__(self, wait_s: float) -> None:
        self.wait_s = wait_s

    def next_trial(self, trial: int) -> bool:
        time.sleep(self.wait_s)
        return trial == 1

    def duration_s(self, trial: int) -> float:
        return 0.2


def test_two_video_files_give_the_same_trial_however_late_it_starts(tmp_path: Path) -> None:
    """Files replayed whole (r5 F13): the trial starts at each file's first frame and
    takes every frame in order, so the same files and plan give the same session whether
    the trial starts at once or 0.4 s (12 frames) after the files opened."""
    pair = thesis_pair()
    size = (pair.intrinsics1.width, pair.intrinsics1.height)
    one, two = (write_video(tmp_path / f"c{n}.avi", 12, size, 20 + n) for n in (1, 2))
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    sessions = []
    for wait_s in (0.0, 0.4):
        source = open_pair_source(f"pair:video:{one},video:{two}", pair, setup, fps=None)
        out = tmp_path / f"late{wait_s}.mcap"
        summary = record_stream(out, setup.info(), pair_cameras(pair), pair, source, _Late(wait_s))
        (end,) = summary.trials
        assert end.unrecorded == (0, 0), end  # no frame played before the trial
        assert end.why == "duration", end
        with SessionReader(out) as reader:
            (trial,) = read_pair_session(reader).trials
        first = trial.camera1.capture_ns[0]
        sessions.append([(c.capture_ns - first).tolist() for c in trial.cameras])
    assert sessions[0] == sessions[1]
    assert len(sessions[0][0]) == 7  # 0.2 s at 30 fps from the file's first frame


def test_a_copy_recorded_keeps_its_warning_in_the_session(tmp_path: Path) -> None:
    """Two copies of one folder recorded by new --pair: the start's warning is a note of the
    session file (a second new user's r5 F3d: said at the terminal, gone from the file)."""
    from twopose.format.entries import Note

    a = _stills(tmp_path / "a", 12, 1)
    copy = shutil.copytree(a, tmp_path / "acopy")
    pair = thesis_pair()
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    source = open_pair_source(f"pair:images:{a},images:{copy}", pair, setup, fps=None)
    out = tmp_path / "copy.mcap"
    record_stream(out, setup.info(), pair_cameras(pair), pair, source, _Lasting())
    with SessionReader(out) as reader:
        notes = [e.text for e in reader.iter_entries([Note.TOPIC]) if isinstance(e, Note)]
    assert any(n.startswith("warning: ") and "byte for byte" in n for n in notes), notes


def _dot_stills(folder: Path, pixels: np.ndarray) -> Path:
    """Grey stills with the dot drawn at each of ``pixels`` (N, 2), to 1/16 px."""
    k = thesis_pair().intrinsics1
    folder.mkdir()
    for i, (col, row) in enumerate(pixels):
        image = np.full((k.height, k.width, 3), 200, np.uint8)
        centre = (round(col * 16), round(row * 16))
        cv2.circle(image, centre, 6 * 16, (0, 0, 0), -1, cv2.LINE_AA, shift=4)
        cv2.imwrite(str(folder / f"{i:03d}.png"), image)
    return folder


class _Said(_Lasting):
    """Keeps what the recorder says of each trial's clock offset."""

    def __init__(self) -> None:
        self.said: list[str] = []

    def schedule(self, trial: int) -> list[ScheduledTouch]:
        return [ScheduledTouch(point=(0.0, 0.0, 24.0), after_s=0.4)]

    def offset(self, trial: int, offset: object, said: str) -> None:
        self.said.append(said)


def test_a_copy_whose_bytes_differ_fixes_no_offset_and_its_touches_are_warned(
    tmp_path: Path,
) -> None:
    """Camera 2's folder a copy of camera 1's with one still saved again as other bytes
    (a second new user's r5 F3a: recorded without a word, its offset "measured" 0 +- 0.4
    ms): the recorder says the copy in place of an offset, and `run` warns each touch,
    leaving it out of the statistics. A real pair's stills (the dot where camera 2 sees
    it) record an offset and no warning."""
    from analysis.batch.runner import run
    from twopose.camera.model import project_points

    pair = thesis_pair()
    a = np.linspace(0.0, 2 * np.pi, 30)
    path = np.column_stack([2.5 * np.cos(a), 2.0 * np.sin(a), 24.0 + np.sin(2 * a)])
    k = pair.intrinsics1
    one = project_points(path, k, np.eye(3), np.zeros(3))
    two = project_points(path, pair.intrinsics2, pair.R_2_to_1, pair.t_2_in_1)
    first = _dot_stills(tmp_path / "c1", one)
    copy = shutil.copytree(first, tmp_path / "copy")
    again = _read(copy / "005.png")
    cv2.imwrite(str(copy / "005.png"), again, [cv2.IMWRITE_PNG_COMPRESSION, 9])  # other bytes
    assert (copy / "005.png").read_bytes() != (first / "005.png").read_bytes()
    real = _dot_stills(tmp_path / "c2", two)
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    said = {}
    for name, second in (("copy", copy), ("real", real)):
        source = open_pair_source(f"pair:images:{first},images:{second}", pair, setup, fps=None)
        driver = _Said()
        record_stream(tmp_path / f"{name}.mcap", setup.info(), pair_cameras(pair), pair,
                      source, driver)  # fmt: skip
        said[name] = driver.said
    assert "camera 2's frames look like camera 1's" in said["copy"][0], said
    assert "clock offset" in said["real"][0], said
    assert "look like" not in said["real"][0], said
    # As an older recorder wrote it: the copy's offset "measured" and recorded.
    _with_offset(tmp_path / "older.mcap", [_read(p) for p in sorted(copy.iterdir())])
    sessions = [tmp_path / f"{n}.mcap" for n in ("copy", "older", "real")]
    result = run(sessions, tmp_path / "out")
    rows = result.trials.set_index(result.trials["session"].map(lambda s: Path(s).stem))
    assert rows.loc["copy", "status"] == "incomplete"  # no offset: "I can't"
    assert "camera 2's frames look like camera 1's" in str(rows.loc["copy", "reason"])
    assert rows.loc["older", "status"] == "ok"
    assert "camera 2's frames look like camera 1's" in str(rows.loc["older", "warning"])
    summary = result.summary.set_index(result.summary["session"].map(lambda s: Path(s).stem))
    assert summary.loc["older", "n_warned"] == 1
    assert summary.loc["older", "n_used"] == 0
    assert rows.loc["real", "status"] == "ok"
    assert summary.loc["real", "n_warned"] == 0


def _read(path: Path) -> np.ndarray:
    image = cv2.imread(str(path))
    assert image is not None, path
    return np.asarray(image)


def _with_offset(path: Path, images: list[np.ndarray]) -> None:
    """One stream trial of ``images`` for both cameras at one time each, a touch mid-way,
    and a recorded clock offset of 0 +- 0.4 ms."""
    from twopose.format.entries import SessionInfo
    from twopose.format.writer import SessionWriter
    from twopose.pair.clock import ClockOffset

    pair = thesis_pair()
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"),
                       clocks={"cam1": "simulated", "cam2": "simulated"})  # fmt: skip
    t0 = 1_700_000_000_000_000_000
    with SessionWriter(path, info, pair_cameras(pair), pair=pair, start_ns=t0) as writer:
        writer.write_clock_offset(ClockOffset(offset_ns=0.0, sigma_ns=4e5, method="ray gap",
                                              n=30), t0)  # fmt: skip
        with writer.stream(1, window_s=0.5, start_ns=t0) as stream:
            for k, image in enumerate(images):
                t = 10**9 + k * 33_333_333
                for cid in ("cam1", "cam2"):
                    stream.add_frame(cid, image, t, t0 + t)
                if k == len(images) // 2:
                    stream.touch((0.0, 0.0, 24.0), t, "schedule")
