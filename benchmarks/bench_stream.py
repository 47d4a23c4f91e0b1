"""Stream estimates of a moving finger from two free-running cameras.

    .venv/bin/python benchmarks/bench_stream.py [--seed 0] [--draws 300]

The thesis' two-camera geometry (``twopose.pair.motion.thesis_pair``: camera 2 six inches
aside and toed in 10 degrees, f = 525 px, the floor 9.625 in below camera 1) and a pointing
finger whose tip circles 14 in ahead at 10 in/s (``FingerMotion``), measured analytically
(no rendering): the tip as a dot, the finger's axis as an image line, with 0.3 px and 0.15
degrees of detector noise. Camera 2 runs at a phase (skew) of 0 to 16.7 ms after camera 1,
its clock 0.4321 s ahead. Four parts (the regions on rendered frames:
``bench_stream_rendered.py``):

1. A still finger: the stream's estimate per pair (``estimate_stream``) against the
   one-camera path with typed poses equal to the pair's pose (``twopose.solve.estimate``'s
   ``measure`` and ``solve_batch``), and against itself at other clock offsets.
2. The moving finger's floor point (method 2) over 10 s per phase: its RMS error with the
   offset measured (``offset_from_ray_gap`` on a 5 s dot segment) and camera 1 interpolated,
   with the true offset, and without interpolation (each camera-2 frame with its nearest
   camera-1 frame). Noise-free, the error without interpolation against its first-order
   prediction (the estimate's derivative by camera 1's measurement times camera 1's motion
   over the skew).
3. The 95% regions' coverage per method, over ``--draws`` seeded draws each with its own
   phase, calibration error (drawn from the pair's extrinsic covariance: 0.05 degrees and
   0.01 in, 1-sigma), offset error (from its 1-sigma) and noise: with the offset measured
   (0.45 ms), with it known only to 5 ms (the skew term dominant), and the 5 ms case with
   the extrinsic and skew terms left out (what they are for).
   Then (3b) each camera's detector also off by a draw of its systematic error (the
   method's ``floor_in_pair``, the same in every frame of the draw), and each camera's
   noise estimated from the draw's own 8 s of frames
   (``twopose.pair.frame_noise.camera_noise``: what ``run`` and the live pointing do).
4. The cost per pair: live (one pair at a time, camera 1's four frames about it) and
   vectorized (a 10 s stream in one call), CPU time on one core.

Targets: a still target equal to the one-camera estimate to 1e-9 and independent of the
offset; floor RMS <= 0.1 in measured and interpolated, <= 0.3 in without, at every phase;
noise-free error within 10% of its prediction; coverage 93-97% per method with the terms;
coverage 93-97% per method with each camera's noise from its own frames; live cost <= 40%
of a frame interval. Exits 1 if one is missed.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from analysis.session.stream import DEFAULT_NOISE
from twopose.methods.specs import METHOD_SPECS, Method
from twopose.pair.board_fit import rotation_matrix
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock import ClockOffset, offset_from_ray_gap
from twopose.pair.frame_noise import camera_noise
from twopose.pair.motion import CameraClock, FingerMotion, Frames, observe, thesis_pair
from twopose.pair.pairing import pair_frames
from twopose.pair.stream import CameraTrack, StreamNoise, StreamSettings, estimate_stream
from twopose.solve.estimate import EstimateOptions, PoseView, ViewBatch, measure, solve_batch
from twopose.uncertainty.propagate import CHI2_95, nees

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "stream.txt"
FPS = 30.0
OFFSET_S = 0.4321
NOISE = (0.3, 0.15)  # detector 1-sigma: centroid px, line angle degrees
PHASES_MS = (0.0, 5.0, 10.0, 16.7)
#: The pair's extrinsic 1-sigma in the coverage draws: rotation (rad), translation (in).
SIGMA_ROTATION = np.radians(0.05)
SIGMA_T = 0.01
METHODS = (Method.POINT, Method.LINE, Method.GROUND)
#: A draw whose noise is estimated from its own frames is this long (s): a session's worth.
OWN_NOISE_S = 8.0
SETTINGS = StreamSettings(noise=StreamNoise(centroid_px=NOISE[0], theta_deg=NOISE[1]))


def pair_with_cov() -> PairCalibration:
    """The thesis' pair with the draws' extrinsic covariance."""
    cov = np.diag([SIGMA_ROTATION**2] * 3 + [SIGMA_T**2] * 3)
    return thesis_pair(cov_extrinsic=cov)


def frames_of(phase_s: float, seconds: float, rng: np.random.Generator) -> tuple[Frames, Frames]:
    """Both cameras' frames: camera 2 ``phase_s`` after camera 1, its clock ahead."""
    return (
        CameraClock(fps=FPS).frames(seconds, rng),
        CameraClock(fps=FPS, phase_s=phase_s, offset_s=OFFSET_S).frames(seconds, rng),
    )


def tracks(
    pair: PairCalibration, frames: tuple[Frames, Frames], *, line: bool,
    noise: tuple[float, float], rng: np.random.Generator, motion: FingerMotion | None = None,
) -> tuple[CameraTrack, CameraTrack]:  # fmt: skip
    """Both cameras' measurements of the finger (the true pair's projection)."""
    m = motion or FingerMotion()
    return (
        observe(pair, m, frames[0], 1, line=line, noise=noise, rng=rng),
        observe(pair, m, frames[1], 2, line=line, noise=noise, rng=rng),
    )


def still_target(rng: np.random.Generator) -> tuple[float, float]:
    """The largest difference from the one-camera path, and across offsets (any method)."""
    pair = thesis_pair()
    still = FingerMotion(speed=0.0)
    worst_one, worst_offsets = 0.0, 0.0
    for method in METHODS:
        line = METHOD_SPECS[method].uses_image_lines
        frames = frames_of(0.01, 1.0, rng)
        one, two = tracks(pair, frames, line=line, noise=(0, 0), rng=rng, motion=still)
        error = rng.normal(0, 0.3, 2), rng.normal(0, 0.3, 2)  # one detection error, every frame
        one = dataclasses.replace(one, centroid_px=one.centroid_px + error[0])
        two = dataclasses.replace(two, centroid_px=two.centroid_px + error[1])
        points = []
        for offset_ms in (-16.7, -5.0, 0.0, 3.3, 16.7):
            offset = ClockOffset(offset_ns=OFFSET_S * 1e9 + offset_ms * 1e6, sigma_ns=0.0,
                                 method="given", n=0)  # fmt: skip
            est = estimate_stream(method, pair, one, two, offset, SETTINGS)
            points.append(est.point[est.ok][0])
        worst_offsets = max(worst_offsets, float(np.ptp(np.array(points), axis=0).max()))
        reference = _one_camera(method, pair, one, two)
        worst_one = max(worst_one, float(np.abs(points[2] - reference).max()))
    return worst_one, worst_offsets


def _one_camera(
    method: Method, pair: PairCalibration, one: CameraTrack, two: CameraTrack
) -> np.ndarray:
    """The one-camera path: two typed poses (the origin, the pair's pose), five frames each."""
    from twopose.camera.model import Intrinsics

    poses = ((np.zeros(3), np.zeros(3)), (pair.t_2_in_1, pair.angles_deg))
    views = []
    for n, (track, (t, r)) in enumerate(zip((one, two), poses, strict=True)):
        i: Intrinsics = pair.intrinsics1 if n == 0 else pair.intrinsics2
        views.append(
            PoseView(
                pose=n + 1,
                intrinsics=np.array([i.fx, i.fy, i.cx, i.cy]),
                width_height=(i.width, i.height),
                t_grid=np.array(t),
                r_deg=np.array(r),
                t_sigma=0.0,
                r_sigma_deg=0.0,
                centroids=track.centroid_px[:5],
                thetas=track.theta_deg[:5],
                found=np.ones(5, dtype=bool),
            )
        )
    options = EstimateOptions()
    measurements, _, _ = measure([views], options)
    batch = ViewBatch.of(measurements, [views])
    ground = thesis_pair().floor
    assert ground is not None
    return solve_batch(method, batch, ground.ground, options).point[0]


def measured_offset(pair: PairCalibration, phase_s: float, rng: np.random.Generator) -> ClockOffset:
    """The offset from a 5 s dot segment (the fingertip), as a session would measure it."""
    frames = frames_of(phase_s, 5.0, rng)
    one, two = tracks(pair, frames, line=False, noise=NOISE, rng=rng)
    return offset_from_ray_gap(pair, one.centroid_px, one.t_ns, two.centroid_px, two.t_ns)


def floor_errors(phase_s: float, rng: np.random.Generator) -> dict[str, float]:
    """The floor point's RMS errors at one phase (part 2) and the first-order check."""
    pair = thesis_pair()
    floor = pair.floor
    assert floor is not None
    frames = frames_of(phase_s, 10.0, rng)
    noisy = tracks(pair, frames, line=True, noise=NOISE, rng=rng)
    exact = tracks(pair, frames, line=True, noise=(0, 0), rng=rng)
    measured = measured_offset(pair, phase_s, rng)
    true = ClockOffset(offset_ns=OFFSET_S * 1e9, sigma_ns=0.0, method="true", n=0)
    truth = FingerMotion().floor_point(frames[1].true_s, floor)
    out: dict[str, float] = {"offset_error_ms": (measured.offset_ns - true.offset_ns) / 1e6}
    for name, (one, two), offset, interpolate in (
        ("measured", noisy, measured, True),
        ("true", noisy, true, True),
        ("exact_interpolated", exact, measured, True),
        ("without", noisy, true, False),
        ("without_exact", exact, true, False),
    ):
        settings = dataclasses.replace(SETTINGS, interpolate=interpolate)
        est = estimate_stream(Method.GROUND, pair, one, two, offset, settings)
        e = np.linalg.norm(est.point - truth[est.i2], axis=1)
        out[name] = float(np.sqrt(np.nanmean(e**2)))
    # The first-order prediction of the error without interpolation: the estimate's
    # derivative by camera 1's measurement times camera 1's motion over the skew.
    one, two = exact
    est = estimate_stream(
        Method.GROUND, pair, one, two, true, dataclasses.replace(SETTINGS, interpolate=False)
    )
    at = two.t_ns[est.i2] - true.offset_ns
    synced = observe(
        pair, FingerMotion(), Frames(true_s=frames[1].true_s[est.i2], stamps_ns=at), 1, line=True
    )
    shift = np.column_stack(
        [
            one.centroid_px[est.i1] - synced.centroid_px,
            _wrapped(one.theta_deg[est.i1] - synced.theta_deg),
        ]
    )
    eps = 1e-3
    base = _synced_estimate(pair, synced, two, est.i2, np.zeros_like(shift))
    moved = _synced_estimate(pair, synced, two, est.i2, eps * shift)
    predicted = (moved - base) / eps
    actual = est.point - truth[est.i2]
    ok = np.isfinite(actual).all(axis=1) & np.isfinite(predicted).all(axis=1)
    out["predicted"] = float(np.sqrt(np.mean(np.sum(predicted[ok] ** 2, axis=1))))
    out["exact_rms"] = float(np.sqrt(np.mean(np.sum(actual[ok] ** 2, axis=1))))
    if phase_s > 0:  # no skew, no error to predict
        difference = np.linalg.norm(actual[ok] - predicted[ok], axis=1)
        out["worst_relative"] = float(np.max(difference / np.linalg.norm(predicted[ok], axis=1)))
    else:
        out["worst_relative"] = float("nan")
    return out


def _share(value: float) -> str:
    """A share as a percentage; no skew, no error to predict: a dash."""
    return "-" if np.isnan(value) else f"{value:.1%}"


def _wrapped(degrees: np.ndarray) -> np.ndarray:
    return (np.asarray(degrees) + 90.0) % 180.0 - 90.0


def _synced_estimate(
    pair: PairCalibration, synced: CameraTrack, two: CameraTrack, i2: np.ndarray, shift: np.ndarray
) -> np.ndarray:
    """The ground estimate from camera 1 measured at camera 2's instants, shifted by ``shift``
    (P, 3: centroid px, angle deg)."""
    one = CameraTrack.of(
        synced.t_ns, synced.centroid_px + shift[:, :2], synced.theta_deg + shift[:, 2]
    )
    two = CameraTrack.of(two.t_ns[i2], two.centroid_px[i2], two.theta_deg[i2])
    offset = ClockOffset(offset_ns=OFFSET_S * 1e9, sigma_ns=0.0, method="true", n=0)
    settings = dataclasses.replace(SETTINGS, interpolate=False)
    return estimate_stream(Method.GROUND, pair, one, two, offset, settings).point


def perturbed(pair: PairCalibration, rng: np.random.Generator) -> PairCalibration:
    """The pair as a calibration would give it: its pose off by a draw of its covariance."""
    d = rng.multivariate_normal(np.zeros(6), pair.cov_extrinsic)
    return dataclasses.replace(
        pair, R_2_to_1=rotation_matrix(d[:3]) @ pair.R_2_to_1, t_2_in_1=pair.t_2_in_1 + d[3:]
    )


def coverage(
    method: Method,
    draws: int,
    offset_sigma_ms: float,
    rng: np.random.Generator,
    *,
    terms: bool = True,
    own_noise: bool = False,
) -> tuple[float, int, float]:
    """The share of ok estimates whose truth is inside their 95% region (part 3), their
    count, and the median share of the skew term in the covariance; ``own_noise``: each
    camera's noise estimated from the draw's own frames (``camera_noise``, the rule of
    ``run`` and the live pointing) instead of the 0.3 px and 0.15 degrees given."""
    truth_pair = pair_with_cov()
    floor = truth_pair.floor
    assert floor is not None
    motion = FingerMotion()
    line = METHOD_SPECS[method].uses_image_lines
    inside, total, shares = 0, 0, []
    for _ in range(draws):
        phase = float(rng.uniform(0, 1 / FPS))
        frames = frames_of(phase, OWN_NOISE_S if own_noise else 2.0, rng)
        one, two = tracks(truth_pair, frames, line=line, noise=NOISE, rng=rng, motion=motion)
        used = perturbed(truth_pair, rng)
        error = rng.normal(0.0, offset_sigma_ms * 1e6)
        offset = ClockOffset(offset_ns=OFFSET_S * 1e9 + error, sigma_ns=offset_sigma_ms * 1e6,
                             method="drawn", n=0)  # fmt: skip
        if not terms:  # the regions without the extrinsic and skew terms
            used = dataclasses.replace(used, cov_extrinsic=np.zeros((6, 6)))
            offset = dataclasses.replace(offset, sigma_ns=0.0)
        t = frames[1].true_s
        pairing = pair_frames(one.t_ns, two.t_ns, offset_ns=offset.offset_ns)
        settings = dataclasses.replace(SETTINGS, ground=floor.ground)
        if own_noise:  # each camera's detector off by its floor's draw, in every frame
            one, two = (biased(method, track, rng) for track in (one, two))
            settings = dataclasses.replace(settings, noise=own(method, one, two))
        if METHOD_SPECS[method].estimates_line:  # nearest the finger's middle, as a trial's
            settings = dataclasses.replace(settings, line_reference=motion.middle(t)[pairing.i2])
        est = estimate_stream(method, used, one, two, offset, settings, pairing=pairing)
        truth = {Method.POINT: motion.tip, Method.LINE: motion.middle}
        true = truth[method](t)[est.i2] if method in truth else motion.floor_point(t, floor)[est.i2]
        score, dof = nees(est.point - true, est.cov)
        ok = np.isfinite(score)
        limit = np.array([CHI2_95.get(int(k), np.nan) for k in dof[ok]])
        inside += int((score[ok] <= limit).sum())
        total += int(ok.sum())
        shares.append(np.nanmedian(est.skew_share))
    return inside / max(total, 1), total, float(np.nanmedian(shares))


def biased(method: Method, track: CameraTrack, rng: np.random.Generator) -> CameraTrack:
    """The track with the detector's systematic error: one draw of its floor (centroid px,
    direction deg; ``MethodSpec.floor_in_pair``), the same in every frame of the camera."""
    px, deg = METHOD_SPECS[method].floor_in_pair
    return dataclasses.replace(
        track,
        centroid_px=track.centroid_px + rng.normal(0.0, px, 2),
        theta_deg=track.theta_deg + rng.normal(0.0, deg) if deg > 0 else track.theta_deg,
    )


def own(method: Method, one: CameraTrack, two: CameraTrack) -> tuple[StreamNoise, StreamNoise]:
    """Each camera's noise from its own frames, by the rule ``run`` and the live pointing
    use: the frames' scatter with the method's detector floor, else the assumed 0.25 px."""
    spec = METHOD_SPECS[method]
    noises = [
        camera_noise([track], lines=spec.uses_image_lines, floor=spec.floor_in_pair,
                     assumed=DEFAULT_NOISE).noise
        for track in (one, two)
    ]  # fmt: skip
    return noises[0], noises[1]


def cost(method: Method, rng: np.random.Generator) -> tuple[float, float, float]:
    """CPU ms per pair: live (median, 95th percentile; one pair a call) and vectorized."""
    pair = pair_with_cov()
    line = METHOD_SPECS[method].uses_image_lines
    frames = frames_of(0.0123, 10.0, rng)
    one, two = tracks(pair, frames, line=line, noise=NOISE, rng=rng)
    offset = ClockOffset(offset_ns=OFFSET_S * 1e9, sigma_ns=0.45e6, method="given", n=0)
    live = []
    for k in range(20, 120):
        near = slice(k - 2, k + 2)
        a = CameraTrack.of(one.t_ns[near], one.centroid_px[near], one.theta_deg[near])
        b = CameraTrack.of(
            two.t_ns[k : k + 1], two.centroid_px[k : k + 1], two.theta_deg[k : k + 1]
        )
        t0 = time.process_time()
        estimate_stream(method, pair, a, b, offset, SETTINGS)
        live.append(time.process_time() - t0)
    t0 = time.process_time()
    est = estimate_stream(method, pair, one, two, offset, SETTINGS)
    whole = (time.process_time() - t0) / max(est.point.shape[0], 1)
    ms = np.array(live[10:]) * 1e3
    return float(np.median(ms)), float(np.percentile(ms, 95)), whole * 1e3


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--draws", type=int, default=300)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    ok = True
    one_camera, across = still_target(rng)
    ok &= one_camera <= 1e-9 and across <= 1e-9
    print(
        f"1. still finger, every method: stream against the one-camera path with the pair's "
        f"pose typed: largest difference {one_camera:.1e}; across clock offsets -16.7..16.7 "
        f"ms: {across:.1e} (target 1e-9)"
    )
    print("2. moving finger at 10 in/s, floor point (method 2), RMS error in inches, 10 s each:")
    print("phase ms | offset error ms | measured + interpolated | noise-free | true offset, "
          "interpolated | without interpolation | noise-free | first-order prediction | worst "
          "relative difference")  # fmt: skip
    for phase in PHASES_MS:
        e = floor_errors(phase / 1e3, rng)
        ok &= e["measured"] <= 0.1 and e["without"] <= 0.3
        if phase > 0:
            ok &= abs(e["exact_rms"] / e["predicted"] - 1) <= 0.1
        print(
            f"{phase:8.1f} | {e['offset_error_ms']:+15.3f} | {e['measured']:22.3f} | "
            f"{e['exact_interpolated']:10.4f} | {e['true']:26.3f} | {e['without']:21.3f} | "
            f"{e['without_exact']:10.3f} | {e['predicted']:22.3f} | "
            f"{_share(e['worst_relative']):>26}"
        )
    print(f"3. 95% region coverage, {args.draws} draws of 2 s per row (phase, calibration "
          f"error, offset error, noise):")  # fmt: skip
    print("method | offset sigma ms | terms | coverage | estimates | median skew share")
    for method in METHODS:
        for sigma_ms, terms in ((0.45, True), (5.0, True), (5.0, False)):
            c, n, share = coverage(method, args.draws, sigma_ms, rng, terms=terms)
            if terms:
                ok &= 0.93 <= c <= 0.97
            print(
                f"{method:6} | {sigma_ms:15.2f} | {'with' if terms else 'none':5} | {c:8.1%} | "
                f"{n:9d} | {share:17.1%}"
            )
    print(
        f"3b. the same ({OWN_NOISE_S:g} s a draw, offset sigma 0.45 ms), each camera's detector "
        "also off by a draw of its floor in every frame, and each camera's noise estimated "
        "from the draw's own frames (their scatter and the detector's floor: run's and the "
        "live pointing's rule):"
    )
    print("method | offset sigma ms | coverage | estimates")
    for method in METHODS:
        c, n, _ = coverage(method, args.draws, 0.45, rng, own_noise=True)
        ok &= 0.93 <= c <= 0.97
        print(f"{method:6} | {0.45:15.2f} | {c:8.1%} | {n:9d}")
    budget = 0.4 * 1e3 / FPS
    print(f"4. CPU per pair (one core), budget {budget:.1f} ms (40% of a frame interval):")
    print("method | live median ms | live p95 ms | vectorized ms")
    for method in METHODS:
        median, p95, whole = cost(method, rng)
        ok &= p95 <= budget
        print(f"{method:6} | {median:14.2f} | {p95:11.2f} | {whole:13.3f}")
    print("targets: " + ("met" if ok else "MISSED"))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
