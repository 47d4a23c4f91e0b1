"""A pair's plan, ``new --pair``'s refusals, the offsets pooled, and a stream's clock from
stills (issue 58 item 4): the parts of stream trials that need no real time."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.procedure.stream import ScheduledTouch, StreamDriver, StreamEvent, record_stream
from recorder.procedure.stream_offset import pooled_offset
from recorder.procedure.stream_terminal import PairSetup, open_pair_source, pair_cameras
from recorder.setup.stream_plan import load_stream_plan
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.methods.specs import Method
from twopose.pair.clock import ClockOffset
from twopose.pair.motion import thesis_pair
from twopose.pair.pair_file import write_pair_file
from twopose.values.units import Units

_TOP = 'method = "point"\nunits = "in"\n'


def _plan(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "plan.toml"
    path.write_text(text)
    return path


def test_a_pair_plan_reads_touches_their_times_and_the_duration(tmp_path: Path) -> None:
    plan = load_stream_plan(_plan(tmp_path, _TOP + (
        "[[trials]]\nduration = 6.5\n"
        'touches = [{point = [1, 2, 3], at = 1.5}, {point = [4, 5, 6]}]\n'
        "[[trials]]\n"
    )))  # fmt: skip
    first, second = plan.trials
    assert first.duration_s == 6.5
    assert [t.at_s for t in first.touches] == [1.5, None]
    assert first.keyed == ((4.0, 5.0, 6.0),)
    assert second.touches == ()
    assert second.duration_s is None


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("[[trials]]\nposes = []\n", "trials[1].poses: not in a pair's plan"),
        ("frames = 5\n[[trials]]\n", "frames: not in a pair's plan"),
        ("[[trials]]\nspeed = 1\n", "unknown key trials[1].speed"),
        (
            "[[trials]]\nduration = 2\ntouches = [{point = [0, 0, 9], at = 3}]\n",
            "after the trial's end",
        ),
        ("[[trials]]\ntouches = [{point = [0, 0, 9], at = -1}]\n", "touches[1].at"),
        ("[[trials]]\ntouches = [{point = [0, 0, 9], at = '1.5'}]\n", "at: touch time must be a"),
        ("[[trials]]\ntouches = [{at = 1}]\n", "touches[1].point is missing"),
        ("[[trials]]\nduration = 0\n", "trials[1].duration"),
        ("ground_height = 9\n[[trials]]\n", "ground_height"),
        ("", "no [[trials]]"),
    ],
)
def test_a_pair_plan_refuses_naming_the_key(tmp_path: Path, text: str, said: str) -> None:
    with pytest.raises(InputValueError, match="plan: ") as err:
        load_stream_plan(_plan(tmp_path, _TOP + text))
    assert said in str(err.value)


def test_a_pair_plan_measures_a_moving_target(tmp_path: Path) -> None:
    with pytest.raises(InputValueError, match="point, line"):
        load_stream_plan(_plan(tmp_path, 'method = "board"\n[[trials]]\n'))
    # none given: said so, not Python's None (a new user's continuation plan)
    with pytest.raises(InputValueError, match="point, line") as err:
        load_stream_plan(_plan(tmp_path, "[[trials]]\n"))
    assert str(err.value).endswith(": it has none")


def _with_floor(folder: Path) -> Path:
    write_pair_file(folder / "PAIR.toml", thesis_pair())
    return folder / "PAIR.toml"


@pytest.fixture
def pair_file(tmp_path: Path) -> Path:
    return _with_floor(tmp_path)


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--frames", "3"], "--frames: not with --pair"),
        (["--calibration", "PAIR.toml"], "gives both cameras"),
        (["--ground-truth", "1,2,3"], "touches' grid points"),
        (["--target-precision", "0.5"], "types no pose"),
        (["--fps", "15"], "--fps: a frame rate is asked of a camera"),
        (["--plan", "plan.toml", "--method", "point"], "the plan sets these itself"),
        (["--plan", "plan.toml", "--ui"], "one"),
        (["--port", "8000"], "--port: where the console listens"),
    ],
)
def test_new_pair_refuses_what_has_no_effect(pair_file: Path, args: list[str], said: str) -> None:
    folder = pair_file.parent
    (folder / "plan.toml").write_text(_TOP + "[[trials]]\n")
    args = [str(folder / a) if a.endswith(".toml") else a for a in args]
    result = CliRunner().invoke(app, [
        "new", str(folder / "s.mcap"), "--pair", str(pair_file),
        "--source", "pair:video:a.avi,video:b.avi", *args,
    ])  # fmt: skip
    assert result.exit_code != 0
    assert said in result.output, result.output
    assert "Traceback" not in result.output
    assert not (folder / "s.mcap").exists()


def test_new_pair_refuses_a_source_that_is_not_a_pair_before_asking(pair_file: Path) -> None:
    result = CliRunner().invoke(app, [
        "new", str(pair_file.parent / "s.mcap"), "--pair", str(pair_file), "--source", "camera:0",
    ])  # fmt: skip
    assert result.exit_code != 0
    assert "--pair records two cameras: give --source pair:A,B" in result.output
    assert "method" not in result.output  # nothing asked


def test_new_without_pair_tells_a_pair_source_where_it_goes(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, [
        "new", str(tmp_path / "s.mcap"), "--source", "pair:camera:0,camera:1",
    ])  # fmt: skip
    assert result.exit_code != 0
    assert "new OUT.mcap --pair PAIR.toml --source pair:camera:0,camera:1" in result.output


def test_offsets_pooled_by_their_weights_and_widened_by_their_scatter() -> None:
    one = ClockOffset(offset_ns=-10e6, sigma_ns=1e6, method="ray gap", n=50)
    two = ClockOffset(offset_ns=-12e6, sigma_ns=2e6, method="ray gap", n=40)
    pooled = pooled_offset([one, two])
    assert pooled.offset_ns == pytest.approx(-10.4e6)  # weights 4 : 1
    assert pooled.sigma_ns == pytest.approx((1 / (1 + 0.25)) ** 0.5 * 1e6)  # chi2/dof < 1
    far = ClockOffset(offset_ns=-20e6, sigma_ns=1e6, method="flash", n=10)
    wide = pooled_offset([one, far])
    birge = np.sqrt(((-10e6 + 15e6) ** 2 + (-20e6 + 15e6) ** 2) / 1e12)  # 5 sigma apart
    assert wide.sigma_ns == pytest.approx(np.sqrt(0.5) * 1e6 * birge)
    assert wide.method == "pooled"
    assert wide.n == 60


class _Script(StreamDriver):
    """A plan's driver in miniature: one trial, a touch at a typed point once camera 1's
    fifth frame is in, a scheduled touch and a duration."""

    def __init__(self) -> None:
        self.frames = 0
        self.touches: list[object] = []

    def schedule(self, trial: int) -> list[ScheduledTouch]:
        return [ScheduledTouch(point=(0.0, 0.0, 20.0), after_s=0.25)]

    def duration_s(self, trial: int) -> float:
        return 0.5

    def events(self) -> list[StreamEvent]:
        self.frames += 1
        if self.frames == 12:  # about camera 1's 6th frame: a key, stamped now
            return [StreamEvent(kind="touch", at_ns=1, point=(1.0, 2.0, 20.0), how="key")]
        return []


def test_stills_a_key_is_camera_1s_last_frame_and_the_schedule_exact(tmp_path: Path) -> None:
    """Stills have no real time: a key's touch is at camera 1's frame last recorded; the
    schedule's at the trial's start plus its time; the duration ends the trial."""
    pair = thesis_pair()
    k = pair.intrinsics1
    for camera in ("a", "b"):
        (tmp_path / camera).mkdir()
        for i in range(30):
            image = np.full((k.height, k.width, 3), 40 + i, np.uint8)
            cv2.imwrite(str(tmp_path / camera / f"{i:03d}.png"), image)
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    spec = f"pair:images:{tmp_path / 'a'},images:{tmp_path / 'b'}"
    source = open_pair_source(spec, pair, setup, fps=None)
    out = tmp_path / "stills.mcap"
    driver = _Script()
    summary = record_stream(out, setup.info(), pair_cameras(pair), pair, source, driver)
    assert summary.kept
    assert not summary.interrupted
    with SessionReader(out) as reader:
        session = read_pair_session(reader)
    (trial,) = session.trials
    start, t1 = trial.camera1.capture_ns[0], trial.camera1.capture_ns
    by_how = {t.how: t for t in trial.touches}
    assert by_how["schedule"].time_ns == start + 250_000_000
    assert by_how["key"].time_ns in set(t1.tolist())  # a frame's own time, not the clock's
    assert by_how["key"].point == (1.0, 2.0, 20.0)
    assert t1[-1] - start >= 500_000_000 > t1[-2] - start  # ended by its duration
    assert session.info.clocks == {"cam1": "simulated", "cam2": "simulated"}


def _stills(folder: Path, levels: list[float], seed: int) -> Path:
    """Uniform grey stills of the pair's size, each at its level, with a little noise."""
    k = thesis_pair().intrinsics1
    rng = np.random.default_rng(seed)
    folder.mkdir()
    for i, level in enumerate(levels):
        image = np.clip(level + rng.normal(0, 1.0, (k.height, k.width, 3)), 0, 255)
        cv2.imwrite(str(folder / f"{i:03d}.png"), image.astype(np.uint8))
    return folder


class _Until(StreamDriver):
    def duration_s(self, trial: int) -> float:
        return 0.8


@pytest.mark.parametrize(
    ("flash", "method"), [(True, "flash"), (False, None)], ids=["a flash", "a slow ramp"]
)
def test_a_flash_both_cameras_see_fixes_the_offset_a_slow_ramp_does_not(
    tmp_path: Path, flash: bool, method: str | None
) -> None:
    """Stills lit at frame 12 in both cameras (their nominal clocks start together): the
    recorder measures the offset by the flash, within a frame interval of 0, and records
    it; brightness creeping up over the same frames (exposure settling) is no flash: none."""
    levels = [60.0 + (120.0 if flash and i >= 12 else 2.0 * i * (not flash)) for i in range(30)]
    a, b = _stills(tmp_path / "a", levels, 1), _stills(tmp_path / "b", levels, 2)
    pair = thesis_pair()
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    source = open_pair_source(f"pair:images:{a},images:{b}", pair, setup, fps=None)
    out = tmp_path / "flash.mcap"
    summary = record_stream(out, setup.info(), pair_cameras(pair), pair, source, _Until())
    with SessionReader(out) as reader:
        offset = read_pair_session(reader).offset
    if method is None:
        assert offset is None
        assert summary.offset is None
        return
    assert offset is not None
    assert offset.method == method
    assert abs(offset.offset_ns) < 1e9 / 30


def test_a_typed_ground_height_is_the_session_pairs_floor_where_the_file_has_none(
    tmp_path: Path,
) -> None:
    """A pair file without a floor, a ground session: the typed height (here the plan's)
    is the session's ground and its pair's floor (exact, as a typed ground is), so the
    stream's estimate has its plane; a pair file with a floor refuses a typed height."""
    import dataclasses

    from recorder.procedure.stream_terminal import KeyReader, record_pair
    from recorder.procedure.terminal import Operator

    write_pair_file(tmp_path / "NOFLOOR.toml", dataclasses.replace(thesis_pair(), floor=None))
    a, b = _stills(tmp_path / "a", [60.0] * 12, 1), _stills(tmp_path / "b", [60.0] * 12, 2)
    plan = _plan(tmp_path, 'method = "ground"\nunits = "in"\noperator = "Ada"\n'
                 "ground_height = 9.0\n[[trials]]\nduration = 0.2\n")  # fmt: skip
    said: list[str] = []
    op = Operator(lambda _q, _d: "", said.append)
    out = tmp_path / "ground.mcap"
    record_pair(
        out, tmp_path / "NOFLOOR.toml", f"pair:images:{a},images:{b}", op, plan_path=plan,
        keys=KeyReader(lambda: ""),
    )  # fmt: skip
    with SessionReader(out) as reader:
        session = read_pair_session(reader)
    assert session.pair.floor is not None
    assert session.pair.floor.height == 9.0
    np.testing.assert_array_equal(session.pair.floor.normal, [0.0, 1.0, 0.0])
    assert session.ground is not None
    assert session.ground.offset == 9.0
    with pytest.raises(InputValueError, match="the pair file gives the floor"):
        record_pair(
            tmp_path / "g2.mcap", _with_floor(tmp_path), f"pair:images:{a},images:{b}", op,
            plan_path=plan, keys=KeyReader(lambda: ""),
        )  # fmt: skip


def test_a_camera_that_never_gives_a_frame_is_said_and_nothing_is_recorded(
    tmp_path: Path,
) -> None:
    """Camera 2 gives nothing (an empty file) while camera 1 streams: refused in words
    after the first frame's wait, no session file left."""
    from recorder.procedure.stream_source import FIRST_FRAME_S
    from tests.helpers import write_video
    from twopose.errors import SourceError

    pair = thesis_pair()
    k = pair.intrinsics1
    one = write_video(tmp_path / "one.avi", int(30 * (FIRST_FRAME_S + 3)), (k.width, k.height), 0)
    empty = tmp_path / "empty.avi"
    cv2.VideoWriter(
        str(empty), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (k.width, k.height)
    ).release()
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    source = open_pair_source(f"pair:video:{one},video:{empty}", pair, setup, fps=None)
    out = tmp_path / "none.mcap"
    with pytest.raises(SourceError, match=r"camera 2 \(video:.*empty.avi\) gave no frame in 5 s"):
        record_stream(out, setup.info(), pair_cameras(pair), pair, source, StreamDriver())
    assert not out.exists()


def test_the_docs_example_pair_plan_reads() -> None:
    plan = load_stream_plan(Path(__file__).resolve().parents[2] / "docs/examples/pair_plan.toml")
    assert plan.method is Method.GROUND
    assert [len(t.touches) for t in plan.trials] == [4, 1]
    assert plan.trials[0].keyed == ((3.455, 9.625, 9.375),)
    assert plan.trials[1].duration_s is None


def test_an_mjpg_cameras_own_jpeg_is_stored_as_it_is(tmp_path: Path) -> None:
    """Two MJPG files (as MJPG webcams give): each frame recorded is the file's own JPEG,
    byte for byte, not decoded and encoded again (a generation of loss, and its CPU)."""
    pair = thesis_pair()
    k = pair.intrinsics1
    rng = np.random.default_rng(3)
    packets: dict[str, list[bytes]] = {}
    for name in ("a", "b"):
        path = tmp_path / f"{name}.avi"
        writer = cv2.VideoWriter(
            str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (k.width, k.height)
        )
        for _ in range(20):
            writer.write(rng.integers(0, 256, (k.height, k.width, 3), dtype=np.uint8))
        writer.release()
        cap = cv2.VideoCapture(str(path))
        cap.set(cv2.CAP_PROP_FORMAT, -1)  # each packet undecoded
        packets[name] = [cap.read()[1].tobytes() for _ in range(20)]
        cap.release()
    setup = PairSetup(method=Method.POINT, units=Units.IN, operator="Ada")
    spec = f"pair:video:{tmp_path / 'a.avi'},video:{tmp_path / 'b.avi'}"
    source = open_pair_source(spec, pair, setup, fps=None)
    out = tmp_path / "mjpg.mcap"
    record_stream(out, setup.info(), pair_cameras(pair), pair, source, _Until())
    with SessionReader(out) as reader:
        (trial,) = read_pair_session(reader).trials
        stored = {
            n: [f.data for f in c.frames()]
            for n, c in zip("ab", (trial.camera1, trial.camera2), strict=True)
        }
    for name, frames in stored.items():  # a run of the file's packets, from where it began
        assert len(frames) >= 6
        first = next((k for k, p in enumerate(packets[name]) if p == frames[0]), None)
        assert first is not None, f"camera {name}: not the file's own JPEG (encoded again)"
        assert frames == packets[name][first : first + len(frames)], "not the file's run"
