"""``--source pair:A,B``: any two one-camera sources read at once, each on its reader thread
with a bounded queue, each frame with its capture time and its clock said; frames a slow
reader loses are counted, never silent; a camera that fails, stops or falls silent is said
in words; a one-camera command refuses a pair in words."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.sources.base import FrameSource, SourceInfo
from recorder.sources.pair_feeds import (
    CLOCK_DRIVER,
    CLOCK_GRAB,
    MAX_DRIVER_LAG_NS,
    DriverStamps,
    Feed,
    Grabbed,
    StillsFeed,
)
from recorder.sources.registry import (
    SOURCE_KINDS,
    open_pair,
    open_source,
    pair_spec,
    parse_pair,
    register_feed,
)
from twopose.errors import SourceError

runner = CliRunner()
W, H = 64, 48


def _video(path: Path, frames: int, fps: float, shade: int = 0) -> Path:
    """An MJPG file whose frame k is a flat grey of level ``shade + 8 k``."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), fps, (W, H))
    for k in range(frames):
        writer.write(np.full((H, W, 3), (shade + 8 * k) % 256, np.uint8))
    writer.release()
    return path


def _level(image: np.ndarray) -> int:
    return round(float(image.mean()))


# ------------------------------------------------------------------------------ the text


_TEXT = st.text(st.characters(exclude_categories=["Cs"], exclude_characters="\r\n\0"), min_size=1)


@settings(max_examples=60, deadline=None)
@given(first=_TEXT, second=_TEXT)
def test_any_two_sources_written_as_a_pair_are_read_back(first: str, second: str) -> None:
    a, b = f"video:{first}", f"images:{second}"
    assert parse_pair(pair_spec(a, b).removeprefix("pair:"), SOURCE_KINDS) == (a, b)


@pytest.mark.parametrize(
    ("arg", "words"),
    [
        ("synthetic", "give two sources, camera 1's and camera 2's"),
        ("synthetic,synthetic,synthetic", "give two sources"),
        (",synthetic", "camera 1's source is empty"),
        ("synthetic,", "camera 2's source is empty"),
        ('"synthetic,synthetic', "a quoted source ends with its quote"),
        ("foo,synthetic", "camera 1's source 'foo' is unknown; use camera:N, video:PATH"),
        (
            'synthetic,"pair:synthetic,synthetic"',
            "camera 2's source pair:synthetic,synthetic is not",
        ),
    ],
)
def test_a_wrong_pair_is_refused_in_words(arg: str, words: str) -> None:
    with pytest.raises(SourceError, match=words):
        parse_pair(arg, SOURCE_KINDS)


def test_one_camera_commands_refuse_a_pair_in_words(tmp_path: Path) -> None:
    with pytest.raises(SourceError, match="gives 2 cameras' frames and this takes one camera's"):
        open_source("pair:synthetic,synthetic")
    for args in (
        ["new", str(tmp_path / "s.mcap"), "--source", "pair:synthetic,synthetic",
         "--method", "point", "--units", "in", "--ground-truth", "0,0,10"],
        ["calibrate", str(tmp_path / "c.toml"), "--source", "pair:camera:0,camera:1"],
    ):  # fmt: skip
        result = runner.invoke(app, args)
        assert result.exit_code != 0
        assert "this takes one camera's" in result.output, result.output
        assert "Traceback" not in result.output
        assert not list(tmp_path.iterdir())


# --------------------------------------------------------------------- frames and times


def test_two_files_give_every_frame_paired_at_their_own_times(tmp_path: Path) -> None:
    one = _video(tmp_path / "a.avi", 240, 60.0)  # 4 s
    two = _video(tmp_path / "b.avi", 9, 60.0, shade=4)  # camera 2's file ends first
    with open_pair(f"video:{one}", f"video:{two}") as source:
        cams = source.cameras
        started = time.monotonic()
        pairs = list(source.pairs())
        took = time.monotonic() - started  # no pair can come after camera 2's end: said
        said = source.ended_by()
    assert took < 1.5, f"{took:.2f} s: camera 1's file was played on"
    assert source.ended_early == f"camera 2 (video:{two}) ended: no more pairs"
    assert [c.clock for c in cams] == ["simulated", "simulated"]
    assert "the file's own timestamps" in cams[0].clock_note
    assert cams[0].fourcc == "MJPG"
    assert source.info.description == f"pair:video:{one},video:{two}"
    assert said == []  # files end without a word to say
    assert len(pairs) == 9
    t0 = pairs[0].first.t_capture_ns
    for k, p in enumerate(pairs):
        assert (p.first.index, p.second.index) == (k, k)
        assert p.first.t_capture_ns - t0 == pytest.approx(k * 1e9 / 60, abs=2e6)
        assert p.skew_ns == p.second.t_capture_ns - p.first.t_capture_ns == 0
        assert p.first.t_grab_ns >= p.first.t_capture_ns - 1_000_000  # played at its rate
        assert (_level(p.first.image), _level(p.second.image)) == pytest.approx(
            (8 * k, 8 * k + 4), abs=2
        )
        assert p.first.image.shape == (H, W, 3)
    assert source.dropped_by_camera == (0, 0)


def test_a_slow_reader_loses_frames_counted_never_silently(tmp_path: Path) -> None:
    """A queue of one frame and a reader at a third of the files' rate: every frame of
    each file is either given or counted dropped."""
    files = [_video(tmp_path / f"{c}.avi", 30, 60.0, shade=c) for c in (1, 2)]
    given = [0, 0]
    with open_pair(f"video:{files[0]}", f"video:{files[1]}", queue_frames=1) as source:
        for frame in source.frames():
            given[frame.camera - 1] += 1
            time.sleep(0.05)
        dropped = source.dropped_by_camera
    assert min(dropped) > 0
    assert [g + d for g, d in zip(given, dropped, strict=True)] == [30, 30]
    said = source.drops_said()  # each overflow said, never silent
    assert said
    assert {line.split(" ")[1] for line in said} == {"1", "2"}
    assert "the consumer fell" in said[0]
    assert "past the queue's bound (1 frames" in said[0]


def test_a_consumer_stalled_for_seconds_loses_nothing(tmp_path: Path) -> None:
    """The default bound (10 s, 256 MiB a camera): a consumer that takes one frame, then
    stalls for 2.5 s while both files play on at 60 fps, still gets every frame paired,
    none dropped, nothing said; a bound of ~0.2 s in bytes drops in the same stall, counted
    and said."""
    from recorder.sources.pair import QUEUE_S, QueueBound

    assert QUEUE_S >= 5  # a few seconds of any camera's frames
    files = [_video(tmp_path / f"{c}.avi", 180, 60.0, shade=c) for c in (1, 2)]  # 3 s
    with open_pair(f"video:{files[0]}", f"video:{files[1]}") as source:
        pairs = source.pairs()
        first = next(pairs)
        time.sleep(2.5)
        rest = list(pairs)
        assert source.dropped_by_camera == (0, 0)
        assert source.drops_said() == []
        deepest = [n for n, _ in source.deepest_by_camera]
        assert min(deepest) >= 120  # the stall held 2 s or more of 60 fps frames
    assert [p.first.index for p in (first, *rest)] == list(range(180))
    small = QueueBound(bytes=3000)  # these frames' JPEGs are ~220 bytes: ~0.2 s of them
    with open_pair(f"video:{files[0]}", f"video:{files[1]}", bound=small) as source:
        kept_up = list(source.frames())  # 360 frames, ~80 kB: a consumer that keeps up
        assert source.dropped_by_camera == (0, 0)  # what it took frees the bound
        assert max(size for _, size in source.deepest_by_camera) <= 3000
    assert len(kept_up) == 360
    with open_pair(f"video:{files[0]}", f"video:{files[1]}", bound=small) as source:
        given = [0, 0]
        for frame in source.frames():
            given[frame.camera - 1] += 1
            if sum(given) == 1:
                time.sleep(2.0)
        dropped = source.dropped_by_camera
        said = source.drops_said()
    assert min(dropped) > 0
    assert [g + d for g, d in zip(given, dropped, strict=True)] == [180, 180]
    assert any("MB queued of" in line for line in said)


def test_stills_are_never_dropped_and_keep_their_names(tmp_path: Path) -> None:
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        for k in range(4):
            level = 40 * k + (0 if side == "left" else 10)
            cv2.imwrite(
                str(tmp_path / side / f"{side}{k}.png"), np.full((H, W, 3), level, np.uint8)
            )
    with open_pair(
        f"images:{tmp_path / 'left'}", f"images:{tmp_path / 'right'}", queue_frames=1
    ) as source:
        assert source.stills
        pairs = []
        for p in source.pairs():
            time.sleep(0.05)
            pairs.append(p)
        said = source.ended_by()
        with pytest.raises(SourceError, match=r"has no more frames \(camera 1 .*no more images"):
            source.read_frame()
    assert [(p.first.name, p.second.name) for p in pairs] == [
        (f"left{k}.png", f"right{k}.png") for k in range(4)
    ]
    assert [(_level(p.first.image), _level(p.second.image)) for p in pairs] == [
        (40 * k, 40 * k + 10) for k in range(4)
    ]
    assert source.dropped_by_camera == (0, 0)
    assert len(said) == 2
    assert "no more images" in said[0]


# --------------------------------------------------------------------------- the clocks


def test_a_drivers_stamps_are_the_capture_times_where_sane() -> None:
    s = DriverStamps()
    grab = 10_000_000_000
    assert s.time(grab / 1e6 - 20, grab) == grab - 20_000_000  # 20 ms in the driver's ring
    assert (s.clock, s.faults) == (CLOCK_DRIVER, 0)
    assert "buffer stamp" in s.note
    # A stamp that goes back, or off the clock, is replaced by the grab less the last lag.
    assert s.time(grab / 1e6 - 30, grab + 33_000_000) == grab + 13_000_000
    assert s.time(5.0, grab + 66_000_000) == grab + 46_000_000
    assert s.faults == 2
    assert s.time(grab / 1e6 + 80, grab + 99_000_000) == grab + 80_000_000  # sane again


@pytest.mark.parametrize(
    ("stamp_ms", "why"),
    [
        (0.0, "the backend gives no buffer stamp"),
        (float("nan"), "the backend gives no buffer stamp"),
        (1234.5, "not on the monotonic clock"),  # a stream position, not a clock
        (10_000.0 + 5, "not on the monotonic clock"),  # after the grab
        (10_000.0 - (MAX_DRIVER_LAG_NS / 1e6) - 1, "not on the monotonic clock"),
    ],
)
def test_no_stamp_or_an_insane_first_one_makes_the_grab_the_clock(
    stamp_ms: float, why: str
) -> None:
    s = DriverStamps()
    grab = 10_000_000_000
    assert s.time(stamp_ms, grab) == grab
    assert s.clock == CLOCK_GRAB
    assert why in s.note
    assert "right after grab()" in s.note
    assert s.time(grab / 1e6 + 10, grab + 33_000_000) == grab + 33_000_000  # stays the grab


# ------------------------------------------------------------------- cameras that fail


def test_a_camera_of_the_pair_that_does_not_open_is_said(tmp_path: Path) -> None:
    one = _video(tmp_path / "a.avi", 3, 30.0)
    source = open_pair(f"video:{one}", "camera:97")
    with pytest.raises(SourceError, match="camera 97 did not open"), source:
        pass
    with (
        pytest.raises(SourceError, match=r"video .*missing.avi does not exist"),
        open_pair(f"video:{tmp_path / 'missing.avi'}", f"video:{one}"),
    ):
        pass


class _Unplugged(FrameSource):
    """A camera that gives ``frames`` frames, then stops (unplugged), or hangs (silent)."""

    def __init__(self, frames: int, *, hang: bool) -> None:
        self.frames, self.hang = frames, hang

    def open(self) -> SourceInfo:
        self.info = SourceInfo(description="unplugged", width=W, height=H, fps=100.0)
        return self.info

    def read(self, timeout_s: float = 2.0) -> np.ndarray:
        return np.zeros((H, W, 3), np.uint8)


class _UnpluggedFeed(Feed):
    finite = False  # a camera: its end is a failure

    def __init__(self, source: _Unplugged) -> None:
        super().__init__()
        self.source, self.k = source, 0

    def open(self) -> SourceInfo:
        self.info = self.source.open()
        return self.info

    def grab(self, stop: threading.Event) -> Grabbed | None:
        if self.k >= self.source.frames:
            if self.source.hang:
                stop.wait(30)
            return None
        self.k += 1
        time.sleep(0.01)
        return Grabbed(self.source.read(), time.monotonic_ns(), time.monotonic_ns())


@pytest.mark.parametrize(
    ("hang", "words"),
    [
        (False, "camera 2 .* stopped delivering frames"),
        (True, "camera 2 .* sent no frame for 0.3 s"),
    ],
)
def test_a_camera_that_stops_or_falls_silent_is_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, hang: bool, words: str
) -> None:
    from recorder.sources import registry as sources

    monkeypatch.setattr(sources, "FEEDS", dict(sources.FEEDS))
    register_feed(_Unplugged, _UnpluggedFeed)
    real = sources.open_from
    monkeypatch.setattr(
        sources, "open_from",
        lambda kinds, spec, o: _Unplugged(5, hang=hang) if spec == "x" else real(kinds, spec, o),
    )  # fmt: skip
    one = _video(tmp_path / "a.avi", 200, 100.0)
    seen: list[int] = []
    started = time.monotonic()
    with open_pair(f"video:{one}", "x") as source:
        frames = source.frames(timeout_s=0.3)
        with pytest.raises(SourceError, match=words):
            seen.extend(frame.camera for frame in frames)
    assert seen.count(2) == 5  # what came before the stop was given
    assert time.monotonic() - started < 2.0


class _SlowStills(StillsFeed):
    """A folder of stills read slowly (a loaded machine's reader thread)."""

    def grab(self, stop: threading.Event) -> Grabbed | None:
        time.sleep(0.005)
        return super().grab(stop)


def test_two_folders_of_stills_come_in_capture_order_however_fast_each_is_read(
    tmp_path: Path,
) -> None:
    """Camera 2's folder read slowly: its frames still come in turn with camera 1's (a
    trial ended by camera 1's clock then holds both cameras' frames up to its end; a flash
    at frame 12 was lost on a loaded machine when camera 1's thread ran ahead)."""
    from recorder.sources.pair import PairSource
    from recorder.sources.registry import SourceOptions, open_from

    for side in ("a", "b"):
        (tmp_path / side).mkdir()
        for k in range(12):
            cv2.imwrite(str(tmp_path / side / f"{k:02d}.png"), np.full((H, W, 3), k, np.uint8))
    specs = (f"images:{tmp_path / 'a'}", f"images:{tmp_path / 'b'}")
    a, b = (open_from(SOURCE_KINDS, s, SourceOptions()) for s in specs)
    with PairSource((StillsFeed(a), _SlowStills(b)), specs) as source:
        frames = list(source.frames())
    assert [(f.camera, f.index) for f in frames] == [(c, k) for k in range(12) for c in (1, 2)]
    times = [f.t_capture_ns for f in frames]
    assert times == sorted(times)
