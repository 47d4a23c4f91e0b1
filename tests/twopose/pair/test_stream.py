"""The stream estimate per frame pair (twopose.pair.stream): the one-camera path's answer for
a still target, interpolation to camera 2's time, near-singular pairs flagged, the regions'
terms, the lens undistorted, lines' doubled angles."""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from tests.helpers import load_benchmark
from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError
from twopose.methods.specs import MEASURING_METHODS, METHOD_SPECS, Method
from twopose.pair.clock import ClockOffset
from twopose.pair.motion import CameraClock, FingerMotion, Frames, observe, thesis_pair
from twopose.pair.pairing import pair_frames
from twopose.pair.stream import (
    NEAR_SINGULAR,
    NOT_INTERPOLATED,
    CameraTrack,
    StreamNoise,
    StreamSettings,
    estimate_stream,
)

OFFSET = ClockOffset(offset_ns=0.25e9, sigma_ns=0.5e6, method="given", n=0)
SETTINGS = StreamSettings(noise=StreamNoise(centroid_px=0.3, theta_deg=0.15))


def _frames(phase_s: float, seconds: float = 1.0, seed: int = 0) -> tuple[Frames, Frames]:
    rng = np.random.default_rng(seed)
    return (
        CameraClock().frames(seconds, rng),
        CameraClock(phase_s=phase_s, offset_s=0.25).frames(seconds, rng),
    )


def _tracks(
    method: Method, frames: tuple[Frames, Frames], motion: FingerMotion | None = None
) -> tuple[CameraTrack, CameraTrack]:
    pair, m = thesis_pair(), motion or FingerMotion()
    line = METHOD_SPECS[method].uses_image_lines
    return (
        observe(pair, m, frames[0], 1, line=line),
        observe(pair, m, frames[1], 2, line=line),
    )


def _one_camera(method: Method, one: CameraTrack, two: CameraTrack) -> np.ndarray:
    """The one-camera path (the benchmark's): poses typed at the origin and the pair's."""
    bench = load_benchmark("bench_stream")
    return np.asarray(bench._one_camera(method, thesis_pair(), one, two))


@pytest.mark.parametrize("method", MEASURING_METHODS)
def test_a_still_target_is_the_one_camera_estimate_whatever_the_offset(method: Method) -> None:
    one, two = _tracks(method, _frames(0.011), FingerMotion(speed=0.0))
    rng = np.random.default_rng(1)  # one detection error, the same in every frame
    one = dataclasses.replace(one, centroid_px=one.centroid_px + rng.normal(0, 0.5, 2))
    two = dataclasses.replace(two, centroid_px=two.centroid_px + rng.normal(0, 0.5, 2))
    reference = _one_camera(method, one, two)
    for shift_ms in (-16.7, 0.0, 9.0):
        offset = dataclasses.replace(OFFSET, offset_ns=OFFSET.offset_ns + shift_ms * 1e6)
        est = estimate_stream(method, thesis_pair(), one, two, offset, SETTINGS)
        assert est.ok.sum() >= 25
        assert np.abs(est.point[est.ok] - reference).max() <= 1e-9


def test_a_moving_finger_is_found_at_camera_2s_instant() -> None:
    """At 10 in/s and camera 2 16.7 ms after camera 1, the floor point is 0.25 in off
    without interpolation; camera 1 interpolated to camera 2's time leaves a hundredth."""
    frames = _frames(0.0167, seconds=2.0)
    one, two = _tracks(Method.GROUND, frames)
    floor = thesis_pair().floor
    assert floor is not None
    truth = FingerMotion().floor_point(frames[1].true_s, floor)
    rms = {}
    for interpolate in (True, False):
        settings = dataclasses.replace(SETTINGS, interpolate=interpolate)
        est = estimate_stream(Method.GROUND, thesis_pair(), one, two, OFFSET, settings)
        assert (est.status == "ok").all()
        error = np.linalg.norm(est.point - truth[est.i2], axis=1)
        rms[interpolate] = float(np.sqrt(np.mean(error**2)))
    assert rms[True] < 0.015 < 0.2 < rms[False] < 0.3
    # Without interpolation, the skew is carried as a time error: the region says so.
    assert np.median(est.skew_share) > 0.8


def test_a_line_coplanar_with_the_baseline_is_flagged_never_a_point() -> None:
    """A finger held parallel to the baseline (sideways): its plane in both cameras is
    one plane. Every pair is flagged with its reason and has no point."""
    sideways = FingerMotion(pointing=(1.0, 0.02, 0.0))
    one, two = _tracks(Method.GROUND, _frames(0.01), sideways)
    est = estimate_stream(Method.GROUND, thesis_pair(), one, two, OFFSET, SETTINGS)
    assert not est.ok.any()
    assert set(est.status) <= {"degenerate", NEAR_SINGULAR}
    assert all("coplanar" in r or "plane angle" in r or "parallel" in r for r in est.reason)
    assert np.isnan(est.point).all()
    assert np.isnan(est.semiaxis95).all()


def test_camera_1s_missing_frames_are_not_interpolated_over() -> None:
    frames = _frames(0.01)
    one, two = _tracks(Method.POINT, frames)
    found = one.found.copy()
    found[10:14] = False  # four frames lost: no bracket about camera 2's frames there
    one = dataclasses.replace(one, found=found)
    est = estimate_stream(Method.POINT, thesis_pair(), one, two, OFFSET, SETTINGS)
    late = est.status == NOT_INTERPOLATED
    assert late.sum() >= 2
    assert np.isnan(est.point[late]).all()
    assert "no frames about" in est.reason[late][0]
    assert est.ok.sum() >= 20


def test_an_in_step_frame_of_camera_1_is_used_as_it_is() -> None:
    """Camera 1's frame taken at camera 2's instant (in step; the offset applied) needs no
    neighbour: with every other frame of camera 1 lost, those pairs still have the point
    of camera 1's frame alone, and the lost ones are not interpolated over."""
    one, two = _tracks(Method.POINT, _frames(0.0))
    assert np.abs(one.t_ns - (two.t_ns - OFFSET.offset_ns)).max() < 1.0  # ns
    found = one.found.copy()
    found[1::2] = False
    one = dataclasses.replace(one, found=found)
    est = estimate_stream(Method.POINT, thesis_pair(), one, two, OFFSET, SETTINGS)
    alone = estimate_stream(
        Method.POINT,
        thesis_pair(),
        one,
        two,
        OFFSET,
        dataclasses.replace(SETTINGS, interpolate=False),
    )
    assert (est.ok == found[est.i1]).all()
    assert (est.status[~found[est.i1]] == "no_detection").all()
    np.testing.assert_array_equal(est.point, alone.point)
    # a frame a microsecond off is still in step; a millisecond off is interpolated again
    for shift_ns, in_step in ((900.0, True), (1e6, False)):
        shifted = dataclasses.replace(OFFSET, offset_ns=OFFSET.offset_ns + shift_ns)
        e = estimate_stream(Method.POINT, thesis_pair(), one, two, shifted, SETTINGS)
        assert e.ok.any() == in_step


def test_the_region_carries_the_skew_and_the_extrinsics() -> None:
    frames = _frames(0.01)
    one, two = _tracks(Method.POINT, frames)
    base = estimate_stream(Method.POINT, thesis_pair(), one, two, OFFSET, SETTINGS)
    slow_clock = dataclasses.replace(OFFSET, sigma_ns=10e6)
    skewed = estimate_stream(Method.POINT, thesis_pair(), one, two, slow_clock, SETTINGS)
    assert np.median(skewed.skew_share) > 0.5 > 0.2 > np.median(base.skew_share)
    assert (skewed.semiaxis95 > base.semiaxis95).all()
    cov = np.diag([np.radians(0.1) ** 2] * 3 + [0.02**2] * 3)
    wider = estimate_stream(
        Method.POINT, thesis_pair(cov_extrinsic=cov), one, two, OFFSET, SETTINGS
    )
    assert (wider.semiaxis95 > 1.2 * base.semiaxis95).all()


@pytest.mark.parametrize("method", MEASURING_METHODS)
def test_interpolation_averages_the_scatter_not_the_detectors_floor(method: Method) -> None:
    """Camera 1 interpolated halfway between two frames averages their scatter (half its
    variance), never the detector's systematic error, the same in both (issue 58): a noise
    that is all floor gives the region of a frame used as it is."""
    still = FingerMotion(speed=0.0)
    regions = {}
    for shared in (0.0, 1.0):
        noise = StreamNoise(
            centroid_px=0.3, theta_deg=0.15, shared_px=0.3 * shared, shared_deg=0.15 * shared
        )
        for phase in (0.0, 0.5 / 30):
            one, two = _tracks(method, _frames(phase), still)
            settings = StreamSettings(noise=(noise, StreamNoise(centroid_px=0.05)))
            est = estimate_stream(method, thesis_pair(), one, two, OFFSET, settings)
            regions[shared, phase] = np.median(est.cov[est.ok], axis=0)
    for shared in (0.0, 1.0):
        assert np.isfinite(regions[shared, 0.0]).all()
    assert np.allclose(regions[1.0, 0.5 / 30], regions[1.0, 0.0], rtol=1e-3)
    assert np.trace(regions[0.0, 0.5 / 30]) < 0.8 * np.trace(regions[0.0, 0.0])


def test_the_floors_covariance_widens_method_2s_region() -> None:
    one, two = _tracks(Method.GROUND, _frames(0.01))
    exact = estimate_stream(Method.GROUND, thesis_pair(), one, two, OFFSET, SETTINGS)
    floor_cov = np.diag([1e-4, 0.0, 1e-4, 0.05**2])  # tilt 0.6 deg, height 0.05 in
    loose = thesis_pair(floor_cov=floor_cov)
    est = estimate_stream(Method.GROUND, loose, one, two, OFFSET, SETTINGS)
    assert (est.semiaxis95 > exact.semiaxis95 + 0.02).all()
    # A ground plane given outright is exact: the floor's covariance is not used.
    given = dataclasses.replace(SETTINGS, ground=(np.array([0.0, 1.0, 0.0]), 9.625))
    assert np.allclose(
        estimate_stream(Method.GROUND, loose, one, two, OFFSET, given).semiaxis95,
        exact.semiaxis95,
    )


def test_method_2_without_a_floor_is_refused() -> None:
    one, two = _tracks(Method.GROUND, _frames(0.01))
    bare = dataclasses.replace(thesis_pair(), floor=None)
    with pytest.raises(InputValueError, match="needs the floor"):
        estimate_stream(Method.GROUND, bare, one, two, OFFSET, SETTINGS)


def test_distorted_pixels_are_undistorted_first() -> None:
    """The same finger seen through lenses with distortion: the pixels a real camera gives,
    with the distortion in the pair's intrinsics, estimate what the pinhole pixels do."""
    pair = thesis_pair()
    lens = (-0.25, 0.08, 0.001, -0.0005, 0.0)
    bent = dataclasses.replace(
        pair,
        intrinsics1=dataclasses.replace(pair.intrinsics1, distortion=lens),
        intrinsics2=dataclasses.replace(pair.intrinsics2, distortion=lens),
    )
    one, two = _tracks(Method.LINE, _frames(0.01))
    distorted = [_distort(t, i) for t, i in ((one, bent.intrinsics1), (two, bent.intrinsics2))]
    plain = estimate_stream(Method.LINE, pair, one, two, OFFSET, SETTINGS)
    through = estimate_stream(Method.LINE, bent, distorted[0], distorted[1], OFFSET, SETTINGS)
    assert np.abs(through.point - plain.point).max() < 1e-4
    assert np.abs(through.direction - plain.direction).max() < 1e-5  # type: ignore[operator]
    naive = estimate_stream(Method.LINE, pair, distorted[0], distorted[1], OFFSET, SETTINGS)
    assert np.abs(naive.point - plain.point).max() > 0.05  # what undistortion saves


def _distort(track: CameraTrack, intrinsics: Intrinsics) -> CameraTrack:
    """A pinhole track's pixels as the lens would place them (the line by its tangent)."""
    K, d = intrinsics.K, np.array(intrinsics.distortion)
    t = np.radians(track.theta_deg)
    ahead = track.centroid_px + 0.01 * np.column_stack([np.cos(t), np.sin(t)])

    def bend(px: np.ndarray) -> np.ndarray:
        rays = np.column_stack([(px - K[:2, 2]) / [K[0, 0], K[1, 1]], np.ones(len(px))])
        out, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, d)
        return np.asarray(out).reshape(-1, 2)

    a, b = bend(track.centroid_px), bend(ahead)
    theta = np.degrees(np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0]))
    return CameraTrack.of(track.t_ns, a, theta)


def test_line_directions_are_interpolated_by_their_doubled_angles() -> None:
    """89 and -89 degrees are two degrees apart, through 90, not 178 through 0: a finger
    held vertically and turning interpolates to vertical."""
    t1 = np.array([0.0, 33.3e6])
    one = CameraTrack.of(t1, [[300.0, 200.0], [300.0, 200.0]], [89.0, -89.0])
    two = CameraTrack.of(np.array([16.65e6]) + 0.25e9, [[250.0, 200.0]], [88.0])
    est = estimate_stream(Method.LINE, thesis_pair(), one, two, OFFSET, SETTINGS)
    # The estimate equals the one from camera 1 at exactly 90 degrees.
    at90 = CameraTrack.of(np.array([16.65e6]), [[300.0, 200.0]], [90.0])
    exact = dataclasses.replace(OFFSET, sigma_ns=0.0)
    one_pair = pair_frames(at90.t_ns, two.t_ns, offset_ns=exact.offset_ns, slop_ns=1.0)
    direct = estimate_stream(
        Method.LINE, thesis_pair(), at90, two, exact, SETTINGS, pairing=one_pair
    )
    assert est.status[0] == direct.status[0]
    assert np.allclose(est.direction, direct.direction, atol=1e-9, equal_nan=True)  # type: ignore[arg-type]


def test_a_line_is_reported_nearest_its_reference() -> None:
    frames = _frames(0.01)
    one, two = _tracks(Method.LINE, frames)
    middle = FingerMotion().middle(frames[1].true_s)
    est = estimate_stream(Method.LINE, thesis_pair(), one, two, OFFSET, SETTINGS)
    near = estimate_stream(
        Method.LINE, thesis_pair(), one, two, OFFSET,
        dataclasses.replace(SETTINGS, line_reference=middle[est.i2]),
    )  # fmt: skip
    assert np.abs(near.point - middle[est.i2]).max() < 0.02  # noise-free: on the finger
    assert np.abs(est.point - middle[est.i2]).max() > 1.0  # the solver's: near camera 2
    assert (near.semiaxis95 < est.semiaxis95).all()  # the finger's middle is seen best


@pytest.mark.parametrize("method", [Method.POINT, Method.GROUND])
def test_an_offset_off_by_its_sigma_stays_inside_the_region_at_camera_2s_instant(
    method: Method,
) -> None:
    """The skew term is camera 1's image velocity times the offset's sigma, carried through
    camera 1's measurement (its effect on the estimate is not along the target's motion).
    Noise-free tracks of a dot or finger at 10 in/s, the offset given 2 ms off with a 2 ms
    sigma: against the truth at camera 2's true capture instant, each estimate's NEES is
    at most about 1 for the interpolation's own error (a rank-one term of its measured size)
    plus about 1 for the offset's, inside the 95% region (7.81 on 3 dof); against the truth at the
    estimate's own ``t_ns`` (camera 2's instant through the wrong offset) it is outside, the
    target having moved 0.02 in meanwhile along its motion, where the region is thin (a new
    user's r5 F11 scored at ``t_ns``; docs/two-cameras.md says what a region is of)."""
    frames = _frames(0.01)
    one, two = _tracks(method, frames)
    pair, motion = thesis_pair(), FingerMotion()
    tiny = StreamSettings(noise=StreamNoise(centroid_px=0.002, theta_deg=0.001))

    def truth(t_s: np.ndarray) -> np.ndarray:
        floor = pair.floor
        assert floor is not None
        return motion.floor_point(t_s, floor) if method is Method.GROUND else motion.tip(t_s)

    nees = {}
    for shift_ms in (0.0, 2.0):
        off = dataclasses.replace(OFFSET, offset_ns=OFFSET.offset_ns + shift_ms * 1e6,
                                  sigma_ns=2e6)  # fmt: skip
        est = estimate_stream(method, pair, one, two, off, tiny)
        ok = est.ok
        assert ok.sum() >= 25
        # t_ns is camera 1's clock, whose time 0 is the motion's (_frames' camera 1)
        for at, instants in (
            ("camera 2", frames[1].true_s[est.i2[ok]]),
            ("t_ns", est.t_ns[ok] / 1e9),
        ):
            d = est.point[ok] - truth(instants)
            nees[shift_ms, at] = np.einsum("pi,pij,pj->p", d, np.linalg.pinv(est.cov[ok]), d)
    assert np.median(nees[0.0, "camera 2"]) < 1.2  # the interpolation's error alone
    # the offset's 1 sigma adds about 1 (a dot: 1.35; the finger's floor point: 0.99)
    added = np.median(nees[2.0, "camera 2"]) - np.median(nees[0.0, "camera 2"])
    assert 0.7 < added < 1.6, added
    assert nees[2.0, "camera 2"].max() < 7.81
    assert np.median(nees[2.0, "t_ns"]) > 7.81


def test_a_finger_whose_line_meets_the_floor_behind_the_cameras_points_at_nothing() -> None:
    """A new user's r7 K11: cameras given in the wrong order drew the finger's point 142 in
    behind camera 1 as `conditioning: ok`. A pair has no typed pose to blame: where the
    planes meet the floor behind a camera (here a finger held pointing up, away from the
    floor), the pair is degenerate, said, and has no point; pointing down, every pair is."""
    up = FingerMotion(pointing=(0.0, -0.3, 1.0))
    one, two = _tracks(Method.GROUND, _frames(0.01), up)
    est = estimate_stream(Method.GROUND, thesis_pair(), one, two, OFFSET, SETTINGS)
    assert not est.ok.any()
    (reason,) = set(est.reason)
    assert reason.startswith("point behind a camera: ")
    assert "cameras swapped?" in reason  # what a pair given in the wrong order does
    assert np.isnan(est.point).all()
    one, two = _tracks(Method.GROUND, _frames(0.01))
    assert estimate_stream(Method.GROUND, thesis_pair(), one, two, OFFSET, SETTINGS).ok.all()
    # the pair's own test, either camera
    pair = thesis_pair()
    ahead = np.array([[0.0, 9.0, 30.0]])
    assert not pair.behind(ahead).any()
    assert pair.behind(np.array([[0.0, 9.0, -30.0]])).all()
    behind_2 = pair.t_2_in_1 - 5.0 * pair.R_2_to_1[:, 2]  # 5 in behind camera 2's centre
    assert pair.behind(behind_2[None]).all()
