"""``simulate --cameras 2``: two synthetic cameras, a moving target, each camera's clock.

Small scenes (320x240) keep it quick; the frames are checked against the recorded truth
(the dot where the true trajectory projects it, in both cameras), the clocks against the
settings, the fast rendering against a whole ray-cast frame, and every option's refusal.
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.simulate.pair import (
    POINT_SAMPLED_WORDS,
    PairTiming,
    frame_caveats,
    simulate_pair_session,
    simulated_pair,
    simulation_size,
)
from tests.helpers import SMALL_SCENE
from tests.recorder.test_simulate import _dark_centroid
from twopose.camera.model import project_points
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.streams import PairSession, read_pair_session
from twopose.methods.specs import Method, floor_unmeasured
from twopose.sim.layout import Layout
from twopose.sim.moving import ClockSettings, PairScene, Trajectory, camera_frames, touch_points
from twopose.sim.render import render_radiance, render_sprite
from twopose.sim.scene import CameraParams, Scene, load_scene

#: Supersampled, with clutter: the composite against a whole ray-cast frame.
SMALL = Scene(
    cameras=(CameraParams(width=320, height=240, fx=262.5, fy=262.5, cx=160.0, cy=120.0),)
)
TIMING = PairTiming(speed=40.0, clock_offset_ms=12.5, drift_ppm=300.0, flash=False)


def _session(path: Path) -> PairSession:
    with SessionReader(path) as reader:
        return read_pair_session(reader)


@pytest.fixture(scope="module")
def small_scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("scene") / "small.toml"
    path.write_text(SMALL_SCENE)
    return path


@pytest.fixture(scope="module")
def point_pair(tmp_path_factory: pytest.TempPathFactory, small_scene: Path) -> Path:
    path = tmp_path_factory.mktemp("pair") / "point.mcap"
    scene = load_scene(small_scene)
    simulate_pair_session(path, method=Method.POINT, timing=TIMING, trials=1, seed=2, scene=scene)
    return path


def test_the_dot_moves_where_the_true_trajectory_projects_it_in_both_cameras(
    point_pair: Path,
) -> None:
    with SessionReader(point_pair) as reader:
        session = read_pair_session(reader)
        (trial,) = session.trials
        truth = trial.trajectory
        assert truth is not None
        at = dict(zip(truth.t_ns, truth.points, strict=True))
        poses = ((np.eye(3), np.zeros(3)), (session.pair.R_2_to_1, session.pair.t_2_in_1))
        for stream, frames, (R, t) in zip(trial.cameras, truth.frames, poses, strict=True):
            assert len(stream) == len(frames.true_ns) >= 5
            dots = np.array([at[n] for n in frames.true_ns])
            expected = project_points(dots, stream.camera.intrinsics, R, t)
            moved = np.linalg.norm(expected[-1] - expected[0])
            assert moved > 20  # the dot moved across the image
            for image, want in zip(stream.images(), expected, strict=True):
                got = _dark_centroid(image, want, half=7)
                assert np.linalg.norm(got - want) < 0.3, (got, want)


def test_the_session_holds_the_pair_the_touches_and_each_cameras_clock(
    point_pair: Path, small_scene: Path
) -> None:
    session = _session(point_pair)
    pair = simulated_pair(Scene())
    np.testing.assert_array_equal(session.pair.R_2_to_1, pair.R_2_to_1)
    np.testing.assert_array_equal(session.pair.t_2_in_1, pair.t_2_in_1)
    assert session.clocks == {"cam1": "simulated", "cam2": "simulated"}
    assert session.offset is None  # measured by the analysis, never written
    assert session.info.simulated
    (trial,) = session.trials
    assert trial.complete
    truth = trial.trajectory
    assert truth is not None
    # four touches at the grid points, in time order, each on the true path at its time
    expected = {tuple(p) for p in touch_points(load_scene(small_scene), Method.POINT, pair)}
    assert {t.point for t in trial.touches} == expected
    assert [t.how for t in trial.touches] == ["schedule"] * 4
    times = [t.time_ns for t in trial.touches]
    assert times == sorted(times)
    at = dict(zip(truth.t_ns, truth.points, strict=True))
    for touch in trial.touches:
        np.testing.assert_allclose(at[touch.time_ns], touch.point, atol=1e-9)
    # capture times: camera 1's clock is the true clock, camera 2's ahead by the offset
    one, two = trial.camera1, trial.camera2
    f1, f2 = truth.frames
    np.testing.assert_allclose(one.capture_ns, f1.true_ns, atol=1)
    np.testing.assert_allclose(two.capture_ns - np.array(f2.true_ns), 12_500_000, atol=1)
    # camera 2's interval longer by the drift; each written 40 / 45 ms after its capture
    interval = np.diff(f2.true_ns) / (1e9 / 30)
    np.testing.assert_allclose(interval, 1 + 300e-6, atol=1e-8)
    np.testing.assert_allclose(one.log_ns - one.capture_ns, one.log_ns[0] - one.capture_ns[0])
    assert (two.log_ns - (np.array(f2.true_ns) - f2.true_ns[0]))[0] > one.log_ns[0] - f1.true_ns[0]
    assert [c.latency_ns for c in truth.clocks] == [40e6, 45e6]
    assert [c.offset_ns for c in truth.clocks] == [0.0, 12.5e6]


def test_the_same_settings_write_the_same_bytes_from_the_command_line(
    point_pair: Path, small_scene: Path, tmp_path: Path
) -> None:
    scene = small_scene
    out = tmp_path / "cli.mcap"
    args = ["simulate", str(out), "--method", "point", "--cameras", "2", "--trials", "1"]
    args += ["--seed", "2", "--speed", "40.0", "--clock-offset-ms", "12.5", "--drift-ppm", "300.0"]
    args += ["--no-flash"]
    result = CliRunner().invoke(app, [*args, "--scene", str(scene)])
    assert result.exit_code == 0, result.output
    assert "two cameras, 1 stream trial" in result.output
    # the half-size test scene renders point-sampled: its regions are said to be too small
    assert f"note: {POINT_SAMPLED_WORDS}" in result.output.replace("\n", " ").replace("  ", " ")
    digest = hashlib.sha256
    assert digest(out.read_bytes()).digest() == digest(point_pair.read_bytes()).digest()
    # The session's size said before a frame is rendered, and right to a few frames.
    said = re.search(r"rendering 1 stream trial of [\d.]+ s: about ([\d,]+) frames", result.output)
    assert said is not None, result.output
    with SessionReader(out) as reader:
        n_frames = sum(len(c) for c in read_pair_session(reader).trials[0].cameras)
    assert abs(int(said.group(1).replace(",", "")) - n_frames) <= 4


def test_a_slow_target_is_said_to_be_minutes_of_frames_before_any_is_rendered() -> None:
    fast = simulation_size(Method.GROUND, 2, SMALL, dataclasses.replace(TIMING, speed=10.0))
    # one trial: two of these would pass the 18,000 frames a camera a session may render
    slow = simulation_size(Method.GROUND, 1, SMALL, dataclasses.replace(TIMING, speed=0.02))
    assert slow.trial_s > 250 * fast.trial_s  # the path's length over the speed
    assert slow.frames > 2 * 30 * 400  # within the 600 s a simulated trial may last
    assert "rendering 1 stream trial of" in slow.words()
    assert "Ctrl-C" in slow.words()


PAIR = ["--cameras", "2", "--speed", "1", "--clock-offset-ms", "1"]


@pytest.mark.parametrize(
    ("options", "words"),
    [
        (["--speed", "10"], "--speed applies only with --cameras 2"),
        (["--drop", "0.1", "--jitter-ms", "1"], "--jitter-ms, --drop apply only with --cameras 2"),
        (["--clock-offset-ms", "3"], "--clock-offset-ms applies only with --cameras 2"),
        (["--drift-ppm", "20"], "--drift-ppm applies only with --cameras 2"),
        (["--no-flash"], "--no-flash applies only with --cameras 2"),
        (["--cameras", "2", "--speed", "10"], "--cameras 2 needs --clock-offset-ms D"),
        (["--cameras", "2", "--clock-offset-ms", "0"], "--cameras 2 needs --speed V"),
        (["--cameras", "2"], "needs --speed V .* and --clock-offset-ms D"),
        ([*PAIR, "--frames", "3"], "--frames has no effect with --cameras 2"),
        ([*PAIR, "--poses", "3", "--pose-noise", "0"], "--poses, --pose-noise have no effect"),
        ([*PAIR, "--typed-resolution", "0.1"], "--typed-resolution has no effect"),
        (["--cameras", "3"], "cameras must be a whole number from 1 to 2, got 3"),
        (["--cameras", "2", "--speed", "0", "--clock-offset-ms", "0"], "speed must be more than 0"),
        (["--cameras", "2", "--speed", "1", "--clock-offset-ms", "2e3"], "clock offset must be"),
        ([*PAIR, "--drop", "0.6"], "dropped share must be from 0 to 0.5"),
        ([*PAIR, "--jitter-ms", "-1"], "jitter must be from 0 to 10 ms"),
        ([*PAIR, "--drift-ppm", "1e5"], "drift must be from -1000 to 1000 ppm"),
        (["--cameras", "2", "--speed", "fast", "--clock-offset-ms", "1"], "'fast' is not a number"),
        (  # r5 F12: a 300-digit frame count, then "unexpected ValueError"
            ["--cameras", "2", "--speed", "1e-300", "--clock-offset-ms", "1"],
            r"length must be more than 0 and at most 600 s, got 8e\+300 .* at most 600 s "
            r"\(10 minutes: 18,000 frames a camera .* give --speed 0.014 or more",
        ),
        (["--cameras", "2", "--speed", "5e-324", "--clock-offset-ms", "1"], "600 s, got inf"),
        (["--cameras", "2", "--speed", "1e-6", "--clock-offset-ms", "1"], "got 8,000,00"),
        (  # a second new user's r5 F12a': each trial within 600 s, 10,000 of them
            [*PAIR, "--trials", "10000"],
            r"frames a camera of a simulated two-camera session must be a whole number from 1 "
            r"to 18000, got [\d,]+ \(10,000 trial\(s\) of .* give fewer --trials",
        ),
    ],
)
def test_every_option_is_refused_in_words_when_malformed_or_without_its_partner(
    tmp_path: Path, options: list[str], words: str
) -> None:
    out = tmp_path / "x.mcap"
    result = CliRunner().invoke(app, ["simulate", str(out), "--method", "point", *options])
    assert result.exit_code != 0
    assert "Traceback" not in result.output
    assert re.search(words, " ".join(result.output.split())), result.output
    assert not out.exists()


def test_a_board_session_or_a_bad_value_from_python_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "x.mcap"
    with pytest.raises(InputValueError, match="board session"):
        simulate_pair_session(out, method=Method.BOARD, timing=TIMING, trials=1, scene=SMALL)
    bad = dataclasses.replace(TIMING, jitter_ms=float("nan"))
    with pytest.raises(InputValueError, match="jitter must be from 0 to 10 ms"):
        simulate_pair_session(out, method=Method.POINT, timing=bad, trials=1, scene=SMALL)
    assert not out.exists()


def test_a_frame_composited_over_the_background_equals_one_ray_cast_whole() -> None:
    """The fast path (the background once, the target's rays per frame) renders what
    ray casting the whole frame with the target there renders."""
    for method in (Method.POINT, Method.GROUND):
        pair = simulated_pair(SMALL)
        scene = PairScene(SMALL, method, pair, np.random.default_rng(0))
        path = Trajectory(touches=touch_points(SMALL, method, pair), speed=10.0, lead=1.0)
        reference = path.at(np.array([0.37 * path.duration_s]))[0]
        for camera, (R, t) in ((1, (np.eye(3), np.zeros(3))), (2, (pair.R_2_to_1, pair.t_2_in_1))):
            fast = scene.radiance(camera, reference)
            moved = scene._moved(reference)
            whole = render_radiance(
                SMALL,
                Layout(primitives=(moved, *scene._static.primitives), decals=scene._static.decals),
                pair.intrinsics1,
                R,
                t,
            )
            differs = np.abs(fast - whole).max(axis=2) > 1e-6
            rows, cols = scene._box(moved, pair.intrinsics1, R, t)
            _, cover = render_sprite(SMALL, moved, pair.intrinsics1, R, t, rows, cols)
            edge = np.zeros_like(differs)
            edge[rows[0] : rows[1], cols[0] : cols[1]] = (cover > 0) & (cover < 1)
            assert not (differs & ~edge).any()  # the same but where the target's edge mixes
            assert (np.abs(fast - scene._background[camera - 1]).max(axis=2) > 0.05).sum() > 50


@settings(max_examples=40, deadline=None)
@given(
    fps=st.floats(5.0, 120.0),
    drift=st.floats(-1000.0, 1000.0),
    jitter_ms=st.floats(0.0, 10.0),
    drop=st.floats(0.0, 0.5),
    offset_ms=st.floats(-1000.0, 1000.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_a_cameras_stamps_keep_their_frames_order_and_clock(
    fps: float, drift: float, jitter_ms: float, drop: float, offset_ms: float, seed: int
) -> None:
    clock = ClockSettings(
        fps=fps, drift_ppm=drift, jitter_s=jitter_ms * 1e-3, drop=drop, offset_s=offset_ms * 1e-3
    )
    frames = camera_frames(clock, 2.0, np.random.default_rng(seed))
    interval = (1 + drift * 1e-6) / fps
    assert 0 <= frames.phase_s < interval
    assert (np.diff(frames.true_s) > 0).all()
    assert (np.diff(frames.stamp_s) > 0).all()  # never two frames swapped by the jitter
    off = frames.stamp_s - frames.true_s - clock.offset_s
    assert (np.abs(off) < 0.45 * interval + 1e-12).all()
    steps = np.round(np.diff(frames.true_s) / interval)
    np.testing.assert_allclose(np.diff(frames.true_s), steps * interval, rtol=1e-9)
    assert frames.true_s.size <= np.floor((2.0 - frames.phase_s) / interval) + 1


def test_a_target_leaving_a_cameras_view_is_said_as_a_point(tmp_path: Path) -> None:
    """A new user's finding: the refusal printed numpy's array, "[-0.25  0.5  11.  ]"."""
    from twopose.errors import SceneError

    narrow = CameraParams(
        id="cam9", width=320, height=240, fx=2000.0, fy=2000.0, cx=160.0, cy=120.0
    )
    scene = Scene(cameras=(SMALL.cameras[0], narrow))
    with pytest.raises(
        SceneError, match=r"leaves camera 2's view at \(-?[\d.]+, -?[\d.]+, -?[\d.]+\)"
    ):
        simulate_pair_session(tmp_path / "x.mcap", method=Method.POINT, timing=TIMING, trials=1,
                              scene=scene)  # fmt: skip
    assert not (tmp_path / "x.mcap").exists()


def test_frames_whose_regions_cannot_be_trusted_are_said_before_rendering(
    small_scene: Path,
) -> None:
    """Point-sampled frames (sensor.supersample = 1: the dot's centroid errs about twice its
    floor, docs/figures/detector_floor.txt) and an image size the floor was not measured at
    are said; the default scene's frames (640x480, supersampled) are not."""
    assert frame_caveats(Scene()) == ()
    assert frame_caveats(load_scene(small_scene)) == (
        POINT_SAMPLED_WORDS,
        floor_unmeasured(320, 240),
    )
    wide = CameraParams(width=1280, height=720, fx=1050.0, fy=1050.0, cx=640.0, cy=360.0)
    said = frame_caveats(dataclasses.replace(Scene(), cameras=(wide,)))
    assert len(said) == 1
    assert "holds at 640x480 only, not at this camera's 1280x720" in said[0]
