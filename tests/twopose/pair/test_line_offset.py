"""The clock offset from a target with an image line (the glove): each camera's detected
point lies at its own place along the finger (a blob's extent differs per camera), so the
rays' gap fits the point's slide along camera 1's image line beside the offset
(twopose.pair.dot_tracks) instead of taking the two points for one."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import ArrayLike

from twopose.errors import InputValueError
from twopose.methods.specs import Method, spec_of
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock import offset_from_ray_gap
from twopose.pair.motion import CameraClock, FingerMotion, Frames, _project, thesis_pair
from twopose.pair.stream import CameraTrack
from twopose.pair.trial_offset import measure_trial_offset

OFFSET_S = 0.0125
DURATION_S = 3.0
#: The fingertip's path (in, camera 1's frame): from touch to touch, as the simulator's.
CORNERS = ((-2.0, 0.0, 13.0), (2.0, 1.0, 15.0), (-1.0, 2.5, 14.0), (1.5, 3.5, 15.5))


@dataclass(frozen=True, kw_only=True)
class PathMotion(FingerMotion):
    """A pointing finger whose tip goes along straight lines through :data:`CORNERS` at
    ``speed``, pausing 0.3 s at each."""

    def tip(self, t_s: ArrayLike) -> np.ndarray:
        corners = np.array(CORNERS)
        legs = np.linalg.norm(np.diff(corners, axis=0), axis=1) / self.speed
        knots = [0.0]
        for leg in legs:  # a pause, then the leg
            knots += [knots[-1] + 0.3, knots[-1] + 0.3 + leg]
        at = np.repeat(corners, 2, axis=0)[: len(knots)]
        t = np.asarray(t_s, dtype=np.float64).reshape(-1)
        return np.column_stack([np.interp(t, knots, at[:, k]) for k in range(3)])


def _seen(
    pair: PairCalibration,
    motion: FingerMotion,
    frames: Frames,
    camera: int,
    slide_in: float,
    rng: np.random.Generator,
    noise: float = 0.1,
) -> CameraTrack:
    """The finger's image line, its point ``slide_in`` along the finger from its middle
    (toward the tip), ``noise`` px and degrees of detector noise."""
    t = frames.true_s
    point = _project(pair, motion.middle(t) + slide_in * motion.direction, camera)
    d = _project(pair, motion.tip(t), camera) - _project(pair, motion.middle(t), camera)
    theta = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    theta = (theta + 90.0) % 180.0 - 90.0  # a detector's (-90, 90]: its sense flips
    return CameraTrack.of(
        frames.stamps_ns,
        point + rng.normal(0.0, noise, point.shape),
        theta + rng.normal(0.0, noise, theta.shape),
    )


def _tracks(
    slides_in: tuple[float, float],
    seed: int,
    pointing: tuple[float, float, float] = (0.0, 0.6, 0.8),
) -> tuple[PairCalibration, CameraTrack, CameraTrack]:
    rng = np.random.default_rng(seed)
    pair = thesis_pair()
    motion = PathMotion(pointing=pointing)
    one = CameraClock(phase_s=rng.uniform(0, 1 / 30)).frames(DURATION_S, rng)
    two = CameraClock(phase_s=rng.uniform(0, 1 / 30), offset_s=OFFSET_S).frames(DURATION_S, rng)
    return (
        pair,
        _seen(pair, motion, one, 1, slides_in[0], rng),
        _seen(pair, motion, two, 2, slides_in[1], rng),
    )


def _measured(pair: PairCalibration, one: CameraTrack, two: CameraTrack, *, lines: bool) -> float:
    """The offset's error in its sigmas."""
    o = offset_from_ray_gap(
        pair, one.centroid_px, one.t_ns, two.centroid_px, two.t_ns,
        angles_deg=(one.theta_deg, two.theta_deg) if lines else None,
    )  # fmt: skip
    return (o.offset_ns - OFFSET_S * 1e9) / o.sigma_ns


def test_a_point_sliding_along_the_finger_is_no_longer_taken_for_one_point() -> None:
    # Both blobs centred some 0.15 in toward the tip from the finger's middle, camera 1's
    # 0.03 in further (the rendered glove's: 0.12 to 0.18 in, 0.01 in apart, a 0.2 px gap).
    pair, one, two = _tracks((0.18, 0.15), seed=3)
    assert abs(_measured(pair, one, two, lines=False)) > 5  # the old wrong "ok"
    assert abs(_measured(pair, one, two, lines=True)) < 3
    # The one path the recorder and run take passes the angles the same way.
    said = measure_trial_offset(
        pair, (one.centroid_px, two.centroid_px), (one.t_ns, two.t_ns),
        angles_deg=(one.theta_deg, two.theta_deg),
    )  # fmt: skip
    assert said.offset is not None
    assert abs(said.offset.offset_ns - OFFSET_S * 1e9) < 3 * said.offset.sigma_ns


def test_a_steady_sweep_fixes_little_and_its_sigma_says_so() -> None:
    # A constant gap is a slide: what a straight, steady sweep fixes rests on perspective
    # alone. The old path took 0.05 in along the finger for 13 ms of offset, 19 sigma.
    rng = np.random.default_rng(0)
    pair = thesis_pair()
    t1 = CameraClock().frames(2.0, rng)
    t2 = CameraClock(phase_s=0.01, offset_s=OFFSET_S).frames(2.0, rng)

    def sweep(frames: Frames, camera: int, slide_in: float) -> CameraTrack:
        t = frames.true_s
        middle = np.column_stack([-1.0 + 2.0 * t, -1.0 + 2.0 * t, np.full_like(t, 14.0)])
        d = np.array([0.0, 0.6, 0.8])
        point, tip = (
            _project(pair, middle + slide_in * d, camera),
            _project(pair, middle + d, camera),
        )
        theta = np.degrees(np.arctan2(*(tip - point).T[::-1]))
        return CameraTrack.of(frames.stamps_ns, point + rng.normal(0, 0.1, point.shape), theta)

    one, two = sweep(t1, 1, 0.05), sweep(t2, 2, 0.0)
    assert abs(_measured(pair, one, two, lines=False)) > 10
    o = offset_from_ray_gap(
        pair, one.centroid_px, one.t_ns, two.centroid_px, two.t_ns,
        angles_deg=(one.theta_deg, two.theta_deg),
    )  # fmt: skip
    assert abs(o.offset_ns - OFFSET_S * 1e9) < 3 * o.sigma_ns
    assert o.sigma_ns > 1e6  # ms: the dot's on the same sweep is 0.26


@settings(max_examples=8, deadline=None)
@given(
    slide1=st.floats(-0.3, 0.3),
    slide2=st.floats(-0.3, 0.3),
    turn_deg=st.floats(-40.0, 40.0),
    seed=st.integers(0, 2**16),
)
def test_the_offset_of_a_sliding_line_is_within_its_sigmas(
    slide1: float, slide2: float, turn_deg: float, seed: int
) -> None:
    # Each camera's point anywhere within 0.3 in of the finger's middle, the finger turned
    # either way: within 3 of its sigmas (40 seeded draws: 0.49 of them RMS, none refused).
    a = np.radians(turn_deg)  # the finger turned about the vertical
    pointing = (0.8 * np.sin(a), 0.6, 0.8 * np.cos(a))
    pair, one, two = _tracks((slide1, slide2), seed, pointing)
    assert abs(_measured(pair, one, two, lines=True)) < 3


def test_a_line_whose_path_repeats_is_still_refused() -> None:
    # The slide is held at the best's when other offsets are judged (a repeating path
    # repeats the finger's pose, and its slide): a circle every 0.63 s fits both periods.
    rng = np.random.default_rng(5)
    pair = thesis_pair()
    motion = FingerMotion(radius=1.0, speed=10.0)
    one = CameraClock(phase_s=0.004).frames(DURATION_S, rng)
    two = CameraClock(phase_s=0.02, offset_s=OFFSET_S).frames(DURATION_S, rng)
    tracks = (_seen(pair, motion, one, 1, 0.18, rng), _seen(pair, motion, two, 2, 0.15, rng))
    with pytest.raises(InputValueError, match=r"repeats|nearly as well|at the edge"):
        _measured(pair, *tracks, lines=True)


def _drifting(track: CameraTrack, floor_px: float, rng: np.random.Generator) -> CameraTrack:
    """The track with a detector error that changes with the target's place (a blob's
    outline and shading against the pixels: the same about one place, another 15 px on),
    each component the floor's size."""
    u = track.centroid_px
    phase = rng.uniform(0.0, 2 * np.pi, 2)
    error = floor_px * np.column_stack(
        [np.sin(u[:, 1] / 15.0 + phase[0]), np.sin(u[:, 0] / 15.0 + phase[1])]
    )
    return dataclasses.replace(track, centroid_px=u + error)


def _with_floor(speed: float, seed: int, floor_px: float) -> tuple[float, float]:
    """A path at ``speed`` (in/s) seen with a drifting detector error of the ground's floor:
    the offset's error in its sigmas with the floor passed as ``floor_px``, and its sigma (ms)."""
    rng = np.random.default_rng(seed)
    pair = thesis_pair()
    motion = PathMotion(speed=speed)
    one = CameraClock(phase_s=rng.uniform(0, 1 / 30)).frames(DURATION_S, rng)
    two = CameraClock(phase_s=rng.uniform(0, 1 / 30), offset_s=OFFSET_S).frames(DURATION_S, rng)
    floor = spec_of(Method.GROUND).floor_in_pair[0]
    seen = [
        _drifting(_seen(pair, motion, f, c, 0.0, rng, noise=0.015), floor, rng)
        for c, f in ((1, one), (2, two))
    ]
    o = offset_from_ray_gap(
        pair, seen[0].centroid_px, seen[0].t_ns, seen[1].centroid_px, seen[1].t_ns,
        angles_deg=(seen[0].theta_deg, seen[1].theta_deg), floor_px=floor_px,
    )  # fmt: skip
    return (o.offset_ns - OFFSET_S * 1e9) / o.sigma_ns, o.sigma_ns / 1e6


def test_a_slow_fingers_offset_carries_the_detectors_drifting_error() -> None:
    """A new user's r7 K3: a rendered glove at 2 in/s was 14 ms off at 35 of its sigmas (the
    centroid's place drifting 0.1 px as the finger came down, which no jackknife sees).
    The method's floor in a pair, as run and the recorder pass it, is a term of the sigma:
    a slow finger whose detector errs by the floor, differently at each place, is within 3
    of its sigmas; without the term it was not."""
    floor = spec_of(Method.GROUND).floor_in_pair[0]
    assert all(abs(_with_floor(2.0, seed, floor)[0]) < 3 for seed in range(5))
    assert max(abs(_with_floor(2.0, seed, 0.0)[0]) for seed in range(5)) > 3  # the old sigma


def test_a_fast_fingers_sigma_stays_small_with_the_floor() -> None:
    # At 10 in/s the same error moves the offset five times less: its sigma stays under
    # 1.5 ms (under 5% of a frame interval; 0.5 ms without the term), the error within 3.
    floor = spec_of(Method.GROUND).floor_in_pair[0]
    for seed in range(3):
        z, sigma_ms = _with_floor(10.0, seed, floor)
        assert sigma_ms < 1.5
        assert abs(z) < 3
