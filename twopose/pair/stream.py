"""The stream estimate: one estimate per frame pair of a moving target.

Per pair (:func:`twopose.pair.pairing.pair_captures`), camera 1's measurement is brought to
camera 2's capture time: with the clock offset, camera 2's time on camera 1's clock is
``t2 - offset``, and camera 1's measurement there is interpolated linearly between the two
frames about it (its centroid; an image line's direction as the doubled-angle unit vector
``(cos 2 theta, sin 2 theta)``, never the raw angle: docs/method.md; the line's offset
follows from the two), unless camera 1 has a frame taken at that time (within
:data:`IN_STEP_NS`: in-step or synced cameras), which is then used as it is. Both
measurements are first undistorted by their camera's lens, so the solvers' pinhole model
holds. Then the method's one solver path solves the pair, as a one-camera trial's two
typed poses would be solved (:func:`twopose.solve.estimate.solve_batch`):
camera 1 is the pose at the origin, camera 2 the pose ``(t_2_in_1, angles of R_2_to_1)``:
a still target gives exactly the one-camera estimate with those poses, whatever the offset.

Each pair's conditioning is judged (the solvers' statuses, and the margins of
:func:`twopose.solve.estimate.margin_warnings`): a near-singular pair (a line coplanar with the
baseline: a fixed pair cannot step off it) is flagged with its reason and has no point.
Each estimate's covariance is propagated to first order (:func:`twopose.uncertainty.propagate.
propagate`) from: each frame's pixel noise (camera 1's interpolated from two frames: the
frames' scatter averaged, the detector's systematic error, the same in both, whole);
the pair's extrinsic covariance, as camera 2's typed pose's (one error shared by every
estimate of the session); the intrinsics' 1-sigma where the pair file has them; the
floor's covariance (method 2); the skew term, the offset's 1-sigma times camera 1's
measured image velocity (without interpolation, the whole skew); and linear
interpolation's own error, ``a w (1 - w) dt^2 / 2`` from camera 1's measured acceleration
``a`` (a fingertip circling at 10 in/s bends its track by up to 0.2 px between frames).
Vectorized over pairs; no I/O. (Near 600 lines: the stream estimate is one path, pairs to
regions, each step feeding the next's arrays; its pairing, clocks and tracks live apart.)
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.arrays import F64, Bools, Ints
from twopose.detect.detection import wrap_theta_deg
from twopose.errors import InputValueError
from twopose.methods.specs import Method, spec_of
from twopose.pair.board_fit import LensModel
from twopose.pair.calibration import PairCalibration, typed_pose_cov
from twopose.pair.clock import ClockOffset
from twopose.pair.pairing import Pairing, pair_captures
from twopose.solve.estimate import (
    EstimateOptions,
    GroundSpec,
    ViewBatch,
    margin_warnings,
    nearest_on_line,
    solve_batch,
    thesis_estimate,
)
from twopose.uncertainty.propagate import SHARED_INPUTS, Shared, propagate, semiaxis95

__all__ = [
    "IN_STEP_NS", "NEAR_SINGULAR", "NOT_INTERPOLATED", "CameraTrack", "StreamEstimate",
    "StreamNoise", "StreamSettings", "estimate_stream",
]  # fmt: skip

#: The status of an ok solve whose degeneracy margin is under its threshold: no point.
NEAR_SINGULAR = "near_singular"
#: The status of a pair whose camera-1 measurement could not be brought to its time.
NOT_INTERPOLATED = "not_interpolated"
#: Camera 1's two frames about camera 2's time are interpolated between when no more than
#: this many frame intervals apart (one dropped frame between them).
MAX_BRACKET_INTERVALS = 2.5
#: Camera 1's frame is taken as it is, not interpolated, when its capture time (on camera 1's
#: clock) is within this of camera 2's (ns): exactly equal stamps (in-step or hardware-synced
#: cameras, video files played at their rate) or the driver's microsecond. At 2,500 px/s (an
#: image width in a quarter second, far beyond a pointing hand) 1 us moves the target 0.0025
#: px, 1% of a 0.25 px detection noise; what skew there is still enters the skew term.
#: Such a pair needs no later frame of camera 1, so live it is estimated at once.
IN_STEP_NS = 1_000
#: The pixel step that carries a line's direction (its tangent at the centroid: the image
#: of a straight line is bent by the lens) through the undistortion.
_LINE_STEP_PX = 0.01  # a bent line departs its tangent by ~ step^2 / (2 radius)


@dataclass(frozen=True, kw_only=True, eq=False)
class CameraTrack:
    """One camera's measurements, frame by frame.

    ``t_ns`` (N,) capture times (its clock, increasing); ``centroid_px`` (N, 2) the
    target's centroid as detected (distorted pixels); ``theta_deg`` (N,) the image line's
    direction (NaN for a dot); ``found`` (N,) whether the target was detected.
    """

    t_ns: F64
    centroid_px: F64
    theta_deg: F64
    found: Bools

    @classmethod
    def of(
        cls, t_ns: ArrayLike, centroid_px: ArrayLike, theta_deg: ArrayLike | None = None,
        found: ArrayLike | None = None,
    ) -> CameraTrack:  # fmt: skip
        """A checked track (``theta_deg`` None: a dot's; ``found`` None: where finite)."""
        t = np.asarray(t_ns, dtype=np.float64).reshape(-1)
        c = np.asarray(centroid_px, dtype=np.float64).reshape(-1, 2)
        th = np.full(t.size, np.nan) if theta_deg is None else np.asarray(theta_deg, np.float64)
        f = np.isfinite(c).all(axis=1) if found is None else np.asarray(found, dtype=bool)
        if not (c.shape[0] == th.size == f.size == t.size):
            raise InputValueError(
                f"a camera's track needs one time, centroid, angle and found flag per frame; "
                f"got {t.size}, {c.shape[0]}, {th.size}, {f.size}"
            )
        if not np.isfinite(t).all() or (np.diff(t) <= 0).any():
            raise InputValueError("a camera's capture times must be finite and increase")
        return cls(t_ns=t, centroid_px=c, theta_deg=th.reshape(-1), found=f.reshape(-1))


@dataclass(frozen=True, kw_only=True)
class StreamNoise:
    """Each frame's detection noise, 1-sigma: centroid (px), image line direction (deg).

    Of it, ``shared_*`` is the same in every frame (the detector's floor: ``camera_noise``).
    """

    centroid_px: float
    theta_deg: float = 0.0
    shared_px: float = 0.0
    shared_deg: float = 0.0


@dataclass(frozen=True, kw_only=True, eq=False)
class StreamSettings:
    """How a stream is estimated.

    ``noise`` each frame's detection noise, both cameras' or each's (``noises``: camera 1's,
    camera 2's); ``interpolate`` whether camera 1's measurement is interpolated to camera 2's
    time (False: the paired frame's, its skew carried as a time error); ``ground`` the
    ground plane ``(normal (3,), offset)`` in camera 1's frame, exact (None: the pair's
    floor, with its covariance); ``estimate`` the solvers' thresholds (the margins that flag
    a near-singular pair); ``line_reference`` (3,) or (P, 3), camera 1's frame: a line is
    reported at its point nearest it (None: nearest camera 2's centre, the solver's point),
    as a one-camera line trial is reported nearest its true segment's midpoint.
    """

    noise: StreamNoise | tuple[StreamNoise, StreamNoise]
    interpolate: bool = True
    ground: GroundSpec | None = None
    estimate: EstimateOptions = field(default_factory=EstimateOptions)
    line_reference: F64 | None = None

    @property
    def noises(self) -> tuple[StreamNoise, StreamNoise]:  # noqa: D102 - the docstring's
        return self.noise if isinstance(self.noise, tuple) else (self.noise, self.noise)


@dataclass(frozen=True, kw_only=True, eq=False)
class StreamEstimate:
    """One estimate per frame pair (:func:`estimate_stream`), in camera 1's frame.

    ``i1``, ``i2``, ``skew_ns`` the pairing's; ``t_ns`` (P,) each estimate's time (camera
    2's capture on camera 1's clock); ``point`` (P, 3) (NaN unless ``status`` is ``ok``);
    ``direction`` (P, 3) a line's; ``cov`` (P, 3, 3) and ``semiaxis95`` (P,) its 95%
    region; ``status``/``reason`` the solvers' (``ok``, ``degenerate``, ``no_detection``)
    or :data:`NEAR_SINGULAR`, :data:`NOT_INTERPOLATED`; ``conditioning`` and ``margins``
    the solvers'; ``skew_share`` (P,) the skew term's share of the covariance's trace;
    ``interpolated`` whether camera 1's measurement was interpolated.
    """

    i1: Ints
    i2: Ints
    skew_ns: F64
    t_ns: F64
    point: F64
    direction: F64 | None
    cov: F64
    semiaxis95: F64
    status: NDArray[np.str_]
    reason: NDArray[np.str_]
    conditioning: F64
    margins: dict[str, F64] = field(default_factory=dict)
    skew_share: F64 = field(default_factory=lambda: np.zeros(0))
    interpolated: Bools = field(default_factory=lambda: np.zeros(0, dtype=bool))
    #: (P, 2, 3) what the solver was given per pair and camera: the centroid (col, row)
    #: with the lens' distortion removed and the line's direction (deg; NaN for a dot);
    #: camera 1's brought to the pair's time (NaN where it could not be).
    measured: F64 = field(default_factory=lambda: np.zeros((0, 2, 3)))

    @property
    def ok(self) -> Bools:
        """(P,) which pairs have a point."""
        return np.asarray(self.status == "ok")


@functools.lru_cache(maxsize=8)
def _pair_constants(pair: PairCalibration) -> tuple[F64, F64, F64]:
    """Camera 2's typed pose (t, angles) and its covariance (6, 6), computed once a pair."""
    return pair.t_2_in_1, pair.angles_deg, typed_pose_cov(pair)


def _undistorted(track: CameraTrack, lens: LensModel) -> tuple[F64, F64]:
    """A track's centroids (N, 2) and line directions (N,) with the lens' distortion removed.

    A direction is carried by a second point along the line, :data:`_LINE_STEP_PX` away.
    """
    c = np.where(track.found[:, None], track.centroid_px, 0.0)
    th = track.theta_deg
    if not np.any(lens.distortion):
        return np.where(track.found[:, None], c, np.nan), th
    t = np.deg2rad(np.nan_to_num(th))
    ahead = c + _LINE_STEP_PX * np.stack([np.cos(t), np.sin(t)], axis=1)
    u = lens.undistort(np.concatenate([c, ahead]))
    uc, ua = u[: c.shape[0]], u[c.shape[0] :]
    d = ua - uc
    theta = np.where(np.isfinite(th), np.degrees(np.arctan2(d[:, 1], d[:, 0])), np.nan)
    return np.where(track.found[:, None], uc, np.nan), wrap_theta_deg(theta)


@dataclass(frozen=True, kw_only=True, eq=False)
class _Camera1:
    """Camera 1's measurement at each pair's time, its velocity and its noise weight."""

    centroid: F64  # (P, 2)
    theta: F64  # (P,)
    velocity: F64  # (P, 3): centroid px/ns, theta deg/ns
    time_error_ns: F64  # (P,) the time error whose velocity the skew term carries
    weight: F64  # (P,) the variance factor of interpolating two frames: w^2 + (1 - w)^2
    interpolation_error: F64  # (P, 3) linear interpolation's error (measured acceleration)
    ok: Bools  # (P,)
    in_step: Bools | None = None  # (P,) taken at the pair's time: lost only if not found


def _camera1_at(
    track: CameraTrack, measured: tuple[F64, F64], at: F64, paired: Ints, offset: ClockOffset,
    *, interpolate: bool,
) -> _Camera1:  # fmt: skip
    """Camera 1's measurement at times ``at`` (P,) on its clock (the module docstring).

    ``measured``: its undistorted centroids (N, 2) and directions (N,).
    """
    c, th = measured
    t = track.t_ns
    if t.size < 2:
        return _unbracketed(track, c, th, paired, offset, interpolate=interpolate, at=at)
    interval = float(np.median(np.diff(t)))
    j = np.clip(np.searchsorted(t, at, side="right"), 1, t.size - 1)
    i = j - 1
    span = t[j] - t[i]
    w = (at - t[i]) / span
    both = track.found[i] & track.found[j] & (span <= MAX_BRACKET_INTERVALS * interval)
    velocity = np.column_stack([c[j] - c[i], wrap_theta_deg(th[j] - th[i])]) / span[:, None]
    curve = _curvature(track, (c, th), i, j, interval)  # per ns^2
    # Linear interpolation's own error, from the measured acceleration: a w (1 - w) dt^2 / 2.
    error = 0.5 * curve * (w * (1 - w) * span**2)[:, None]
    if not interpolate:  # the paired frame as it is: its whole skew is a time error
        return _Camera1(
            centroid=c[paired], theta=wrap_theta_deg(th[paired]),
            velocity=np.where(np.isfinite(velocity), velocity, 0.0),
            time_error_ns=np.hypot(at - t[paired], offset.sigma_ns), weight=np.ones(at.size),
            interpolation_error=np.zeros((at.size, 3)), ok=np.asarray(track.found[paired]),
        )  # fmt: skip
    wc = np.clip(w, 0.0, 1.0)
    d2 = np.deg2rad(2 * th)  # doubled angles: a line has no arrow
    s = np.sin(d2[i]) * (1 - wc) + np.sin(d2[j]) * wc
    co = np.cos(d2[i]) * (1 - wc) + np.cos(d2[j]) * wc
    interpolated = _Camera1(
        centroid=c[i] * (1 - wc)[:, None] + c[j] * wc[:, None],
        theta=wrap_theta_deg(np.degrees(0.5 * np.arctan2(s, co))),
        velocity=np.where(np.isfinite(velocity), velocity, 0.0),
        time_error_ns=np.full(at.size, offset.sigma_ns),
        weight=wc**2 + (1 - wc) ** 2,
        interpolation_error=np.where(np.isfinite(error), error, 0.0),
        ok=np.asarray(both & (w >= 0) & (w <= 1)),
    )  # fmt: skip
    return _in_step(track, measured, at, offset, interpolated, interval)


def _in_step(
    track: CameraTrack, measured: tuple[F64, F64], at: F64, offset: ClockOffset,
    interpolated: _Camera1, interval: float,
) -> _Camera1:  # fmt: skip
    """Where camera 1 has a frame within :data:`IN_STEP_NS` of ``at``, that frame as it is.

    Its velocity (the skew term's) is the backward difference from the frame before (found,
    within :data:`MAX_BRACKET_INTERVALS`), else the forward one, else 0: a live estimate has
    the frame before at once, so it need not wait for the frame after.
    """
    c, th = measured
    t, found = track.t_ns, track.found
    n = np.clip(np.searchsorted(t, at - IN_STEP_NS, side="left"), 0, t.size - 1)
    step = np.abs(t[n] - at) <= IN_STEP_NS
    if not step.any():
        return interpolated
    m = np.column_stack([c, th])
    before, after = np.clip(n - 1, 0, t.size - 1), np.clip(n + 1, 0, t.size - 1)
    reach = MAX_BRACKET_INTERVALS * interval
    back = (n >= 1) & found[before] & found[n] & (t[n] - t[before] <= reach)
    ahead = ~back & (n + 1 < t.size) & found[after] & found[n] & (t[after] - t[n] <= reach)
    a, b = np.where(back, before, n), np.where(back, n, after)
    with np.errstate(invalid="ignore", divide="ignore"):
        v = _difference(m[b], m[a]) / (t[b] - t[a])[:, None]
    v = np.where((back | ahead)[:, None] & np.isfinite(v), v, 0.0)
    pick = step[:, None]
    return _Camera1(
        centroid=np.where(pick, c[n], interpolated.centroid),
        theta=np.where(step, wrap_theta_deg(th[n]), interpolated.theta),
        velocity=np.where(pick, v, interpolated.velocity),
        time_error_ns=np.where(
            step, np.hypot(at - t[n], offset.sigma_ns), interpolated.time_error_ns
        ),
        weight=np.where(step, 1.0, interpolated.weight),
        interpolation_error=np.where(pick, 0.0, interpolated.interpolation_error),
        ok=np.where(step, found[n], interpolated.ok),
        in_step=step,
    )  # fmt: skip


def _curvature(
    track: CameraTrack, measured: tuple[F64, F64], i: Ints, j: Ints, interval: float
) -> F64:
    """(P, 3) camera 1's measured second derivative about each bracket ``(i, j)``.

    From the frame before ``i`` (else the one after ``j``), both found and within a frame
    or two; 0 where there is none (the interpolation's error is then not known: none).
    """
    c, th = measured
    t, found = track.t_ns, track.found
    m = np.column_stack([c, th])
    n = t.size
    before = np.clip(i - 1, 0, n - 1)
    after = np.clip(j + 1, 0, n - 1)
    use_before = (i >= 1) & found[before] & (t[i] - t[before] <= MAX_BRACKET_INTERVALS * interval)
    k = np.where(use_before, before, after)
    usable = (use_before | ((j + 1 < n) & found[after])) & found[i] & found[j]
    # Three frames a < b < c: the second divided difference, twice.
    a = np.where(use_before, k, i)
    b = np.where(use_before, i, j)
    cc = np.where(use_before, j, k)
    with np.errstate(invalid="ignore", divide="ignore"):
        d1 = _difference(m[b], m[a]) / (t[b] - t[a])[:, None]
        d2 = _difference(m[cc], m[b]) / (t[cc] - t[b])[:, None]
        curve = 2 * (d2 - d1) / (t[cc] - t[a])[:, None]
    return np.where(usable[:, None] & np.isfinite(curve), curve, 0.0)


def _difference(later: F64, earlier: F64) -> F64:
    """Measurements' differences (P, 3): centroid, and the direction's wrapped."""
    d = later - earlier
    d[:, 2] = wrap_theta_deg(d[:, 2])
    return d


def _unbracketed(
    track: CameraTrack, c: F64, th: F64, paired: Ints, offset: ClockOffset, *,
    interpolate: bool, at: F64,
) -> _Camera1:  # fmt: skip
    """Camera 1 with a single frame: nothing to interpolate between (or the frame as is)."""
    P = at.size
    ok = np.zeros(P, dtype=bool) if interpolate else track.found[paired]
    if interpolate:  # a frame taken at camera 2's time (in step) needs no neighbour
        ok = track.found[paired] & (np.abs(track.t_ns[paired] - at) <= IN_STEP_NS)
    return _Camera1(
        centroid=c[paired], theta=th[paired], velocity=np.zeros((P, 3)),
        time_error_ns=np.hypot(at - track.t_ns[paired], offset.sigma_ns), weight=np.ones(P),
        interpolation_error=np.zeros((P, 3)), ok=np.asarray(ok),
    )  # fmt: skip


def estimate_stream(
    method: Method,
    pair: PairCalibration,
    camera1: CameraTrack,
    camera2: CameraTrack,
    offset: ClockOffset,
    settings: StreamSettings,
    *,
    pairing: Pairing | None = None,
) -> StreamEstimate:
    """One estimate per frame pair (the module docstring).

    Parameters
    ----------
    method : Method
        The point, line or ground method.
    pair : PairCalibration
        The calibrated pair; its floor is the ground plane unless the settings give one.
    camera1, camera2 : CameraTrack
        Each camera's measurements.
    offset : ClockOffset
        Camera 2's clock minus camera 1's, with its 1-sigma.
    settings : StreamSettings
        The detection noise, interpolation, ground plane and the solvers' thresholds.
    pairing : Pairing, optional
        The frames' pairs (default: :func:`~twopose.pair.pairing.pair_captures` with the
        offset).

    Returns
    -------
    StreamEstimate
    """
    spec = spec_of(method)
    ground, ground_cov = settings.ground, None
    if spec.needs_ground and ground is None:
        if pair.floor is None:
            raise InputValueError(
                f"{spec.label} needs the floor: calibrate the pair with a board on the floor, "
                "or give the ground plane"
            )
        ground, ground_cov = pair.floor.ground, pair.floor.cov
    settings = dataclasses.replace(settings, ground=ground if spec.needs_ground else None)
    pairs = pairing or pair_captures(camera1.t_ns, camera2.t_ns, offset_ns=offset.offset_ns)
    lenses = (LensModel.of(pair.intrinsics1), LensModel.of(pair.intrinsics2))
    c1, th1 = _undistorted(camera1, lenses[0])
    c2, th2 = _undistorted(camera2, lenses[1])
    at = camera2.t_ns[pairs.i2] - offset.offset_ns
    one = _camera1_at(camera1, (c1, th1), at, pairs.i1, offset, interpolate=settings.interpolate)
    batch = _batch(pair, one, c2[pairs.i2], th2[pairs.i2], lines=spec.uses_image_lines)
    solved = solve_batch(spec.method, batch, settings.ground, settings.estimate)
    status, reason = solved.status.astype("<U24"), solved.reason.astype("<U96")
    behind = (status == "ok") & (spec.plane is not None) & pair.behind(solved.point)  # r7 K11
    status[behind] = "degenerate"  # a plane's cut behind a camera: no typed pose to blame
    reason[behind] = "point behind a camera: the plane's cut lies behind them (cameras swapped?)"
    late = ~one.ok & camera2.found[pairs.i2]  # camera 2 saw it; camera 1 not about then
    if one.in_step is not None:  # camera 1's frame at that time lost it: no detection
        late &= ~one.in_step
    status[late], reason[late] = NOT_INTERPOLATED, "camera 1 has no frames about camera 2's time"
    judged = np.where(
        np.char.startswith(reason, "point behind"), "ok", status
    )  # near-singular first
    warned = np.array(margin_warnings(judged, solved.margins, settings.estimate, spec.seen_on))
    near = (judged == "ok") & (warned != "")
    status[near], reason[near] = NEAR_SINGULAR, warned[near]
    ok = status == "ok"
    point = np.where(ok[:, None], solved.point, np.nan)
    direction = solved.direction
    if direction is not None and settings.line_reference is not None:
        reference = np.broadcast_to(np.asarray(settings.line_reference, np.float64), point.shape)
        point = nearest_on_line(point, direction, reference)
    cov, skew_share = _covariance(spec.method, pair, batch, point, one, settings, ground_cov)
    return StreamEstimate(
        i1=pairs.i1, i2=pairs.i2, skew_ns=pairs.skew_ns, t_ns=at, point=point,
        direction=None if direction is None else np.where(ok[:, None], direction, np.nan),
        cov=cov, semiaxis95=semiaxis95(cov), status=status, reason=reason,
        conditioning=solved.conditioning, margins=solved.margins, skew_share=skew_share,
        interpolated=np.full(at.size, settings.interpolate) & one.ok,
        measured=batch.inputs[:, :, :3].copy(),
    )  # fmt: skip


def _batch(pair: PairCalibration, one: _Camera1, c2: F64, th2: F64, *, lines: bool) -> ViewBatch:
    """The pairs as a two-view batch, in the one-camera path's layout.

    Camera 1 is the typed pose at the origin, camera 2 the typed pose of the pair's
    relative pose.
    """
    t21, angles, _ = _pair_constants(pair)
    P = c2.shape[0]
    x = np.zeros((P, 2, 9))
    x[:, 0, :2], x[:, 0, 2] = one.centroid, one.theta
    x[:, 1, :2], x[:, 1, 2] = c2, th2
    x[:, 1, 3:6], x[:, 1, 6:9] = t21, angles
    if not lines:  # a dot has no direction (the one-camera path's NaN)
        x[:, :, 2] = np.nan
    x[~one.ok, 0, :2] = np.nan
    i1, i2 = pair.intrinsics1, pair.intrinsics2
    intr = np.empty((P, 2, 4))
    intr[:, 0], intr[:, 1] = (i1.fx, i1.fy, i1.cx, i1.cy), (i2.fx, i2.fy, i2.cx, i2.cy)
    return ViewBatch(inputs=x, intrinsics=intr, valid=np.ones((P, 2), dtype=bool))


def _covariance(
    method: Method, pair: PairCalibration, batch: ViewBatch, point: F64, one: _Camera1,
    settings: StreamSettings, ground_cov: F64 | None,
) -> tuple[F64, F64]:  # fmt: skip
    """(P, 3, 3) each estimate's covariance and (P,) the skew term's share of its trace."""
    P = point.shape[0]
    noises, ground, options = settings.noises, settings.ground, settings.estimate
    ok = np.asarray(np.isfinite(point).all(axis=1))
    cov = np.full((P, 3, 3), np.nan)
    share = np.full(P, np.nan)
    if not ok.any():
        return cov, share
    b = batch.rows(ok)
    pixel = [np.diag([n.centroid_px**2, n.centroid_px**2, n.theta_deg**2]) for n in noises]
    # Interpolation averages the frames' scatter, not the floor they share: that enters whole.
    n1 = noises[0]
    shared = np.diag([n1.shared_px**2, n1.shared_px**2, n1.shared_deg**2])
    C = np.zeros((int(ok.sum()), 2, 9, 9))
    C[:, 0, :3, :3] = (pixel[0] - shared) * one.weight[ok, None, None] + shared
    v = one.velocity[ok]
    skew = np.einsum("pi,pj->pij", v, v) * (one.time_error_ns[ok] ** 2)[:, None, None]
    C[:, 0, :3, :3] += skew
    bias = one.interpolation_error[ok]
    C[:, 0, :3, :3] += np.einsum("pi,pj->pij", bias, bias)
    C[:, 1, :3, :3] = pixel[1]
    C[:, 1, 3:9, 3:9] = _pair_constants(pair)[2]
    if not np.isfinite(b.inputs[..., 2]).all():  # a dot: its direction is no input
        C[:, :, 2, :] = C[:, :, :, 2] = 0.0
    estimate = thesis_estimate(method, b, ground, options, point[ok])
    propagated = propagate(estimate, b.inputs, C, shared=_shared(pair, b))
    total = propagated.cov_grid
    J0 = propagated.jacobian[:, :, 0, :3]  # d estimate / d camera 1's measurement
    skew_cov = np.einsum("pik,pkl,pjl->pij", J0, skew, J0)
    if ground is not None and ground_cov is not None:
        total = total + _ground_term(method, b, (ground, ground_cov), options, point[ok])
    cov[ok] = total
    with np.errstate(invalid="ignore", divide="ignore"):
        share[ok] = np.trace(skew_cov, axis1=1, axis2=2) / np.trace(total, axis1=1, axis2=2)
    return cov, share


def _shared(pair: PairCalibration, batch: ViewBatch) -> Shared | None:
    """Each camera's intrinsics as inputs shared by every pair (None: no 1-sigma known)."""
    if not (pair.sigma1 or pair.sigma2):
        return None
    T = batch.inputs.shape[0]
    cov = np.zeros((T, 2, len(SHARED_INPUTS), len(SHARED_INPUTS)))
    for g, sigma in enumerate((pair.sigma1, pair.sigma2)):
        cov[:, g] = np.diag([float(sigma.get(k, 0.0)) ** 2 for k in SHARED_INPUTS])
    group = np.tile(np.array([0, 1]), (T, 1))
    return Shared(values=batch.intrinsics.copy(), group=group, cov=cov)


def _ground_term(
    method: Method, batch: ViewBatch, ground: tuple[GroundSpec, F64],
    options: EstimateOptions, reference: F64, rel_step: float = 1e-3,
) -> F64:  # fmt: skip
    """(P, 3, 3) the floor's covariance carried to each estimate (central differences).

    ``ground``: the plane ``(normal, offset)`` and its covariance (4, 4).
    """
    (normal, offset), ground_cov = ground
    n0, h0 = np.asarray(normal, dtype=np.float64), float(offset)
    sigma = np.sqrt(np.clip(np.diag(ground_cov), 0.0, None))
    J = np.zeros((batch.inputs.shape[0], 3, 4))
    for k in range(4):
        if sigma[k] == 0:
            continue
        h = rel_step * sigma[k]
        ends = []
        for sign in (1.0, -1.0):
            g = np.r_[n0, h0]
            g[k] += sign * h
            spec = (g[:3], float(g[3]))
            ends.append(thesis_estimate(method, batch, spec, options, reference)(batch.inputs))
        J[:, :, k] = (ends[0] - ends[1]) / (2 * h)
    return np.asarray(np.einsum("pik,kl,pjl->pij", J, ground_cov, J))
