"""Pointing, live (issue 58 item 5): where the finger points, one estimate per frame pair.

:class:`LivePointing` takes a pair source's frames as they come (:meth:`LivePointing.add_frame`;
or the pairs a consumer made itself, :meth:`LivePointing.add_pair`), detects the method's target
in each frame once (:func:`twopose.detect.detection.detect`: the glove's centroid and image
line for the line and ground methods, the dot for the point method), pairs the frames by
capture time (:class:`twopose.pair.live_pairing.LivePairing`, the offline policy) and
estimates each pair through the stream estimate's one path
(:func:`twopose.pair.stream.estimate_stream`: camera 1's measurement interpolated to camera
2's capture time, the method's one solver, the pair's conditioning, its 95% region): no
second solver. A pair is estimated as soon as camera 1's frames about camera 2's capture
time are detected (the frame after it, and the one before or, where that one lost the
target, the one after that: what the offline estimate interpolates and bends by; when camera
1 has a frame taken at that time, in step, that frame and the one before it: no wait), so the
live estimate of a pair equals the offline estimate of the whole stream for that pair;
pairs that become ready together are estimated in one vectorized call.

Each pair gives a :class:`PointingEstimate`: its capture time, the point seen on the floor
(:class:`FloorView`: the pair's floor face on, from camera 1's foot; without a floor, camera
1's x-z plane from above) or None, its 95% region there (an ellipse), the conditioning in
words (a near-singular pair is flagged with its reason and has no point), the last second's
track of points, and the CPU it took (detection of both frames included). No I/O.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from recorder.live.pointing_voids import PointVoids
from twopose.detect.detection import detect
from twopose.errors import InputValueError
from twopose.methods.specs import Method, spec_of
from twopose.pair.clock import ClockOffset
from twopose.pair.frame_noise import CameraNoise, camera_noise
from twopose.pair.live_pairing import LivePairing
from twopose.pair.pairing import Pairing
from twopose.pair.stream import (
    IN_STEP_NS,
    MAX_BRACKET_INTERVALS,
    CameraTrack,
    StreamEstimate,
    StreamNoise,
    StreamSettings,
    estimate_stream,
)
from twopose.solve.estimate import EstimateOptions

if TYPE_CHECKING:
    from recorder.sources.pair import FramePair, TimedFrame
    from twopose.arrays import F64
    from twopose.pair.calibration import PairCalibration

__all__ = [
    "CHI2_2D_95",
    "DEFAULT_NOISE",
    "NOISE_EVERY_S",
    "NOISE_WINDOW_S",
    "TRACK_S",
    "Ellipse95",
    "FloorView",
    "LivePointing",
    "PointingEstimate",
    "PointingSettings",
]

#: The 95% quantile of chi-square with 2 degrees of freedom: an ellipse's scale.
CHI2_2D_95 = 5.991464547107979
#: How far back the track reaches (s).
TRACK_S = 1.0
#: Each frame's detection noise (1-sigma) assumed until the last seconds' frames give an
#: estimate (:func:`twopose.pair.frame_noise.camera_noise`): the analysis' default.
DEFAULT_NOISE = StreamNoise(centroid_px=0.25, theta_deg=0.25)
#: Each camera's noise is estimated from its frames of the last this many seconds ...
NOISE_WINDOW_S = 10.0
#: ... again once a camera has this many seconds of new frames (an estimate costs a few ms;
#: a second's frames change it little), and when the streams end.
NOISE_EVERY_S = 1.0
#: Camera 1's frames kept (detected) before the newest: the interpolation's bracket and
#: the frame interval's median.
HISTORY_FRAMES = 16
#: Pairs waiting for camera 1's next frame, at most (a camera that stalls for longer than
#: this many pairs has its oldest waiting pair estimated with what there is).
MAX_WAITING = 8


@dataclass(frozen=True, kw_only=True)
class Ellipse95:
    """A 95% region in the floor's two axes: semi-axes ``major >= minor`` (session units)
    and the major axis' angle ``angle_deg`` from the ``across`` axis toward ``ahead``."""

    major: float
    minor: float
    angle_deg: float


@dataclass(frozen=True, kw_only=True, eq=False)
class FloorView:
    """The plane the point is seen on, face on: ``origin`` (3,) and two unit axes
    ``across`` and ``ahead`` (3,), camera 1's frame; ``name`` says which plane it is.

    With the pair's floor: its foot under camera 1 (``height * normal``), ``across``
    camera 1's x axis laid on the floor, ``ahead`` the floor's direction away from the
    cameras (camera 1's z laid on it). Without: camera 1's centre, its x and z axes.
    """

    origin: F64
    across: F64
    ahead: F64
    name: str

    @classmethod
    def of(cls, pair: PairCalibration) -> FloorView:
        """The pair's floor, or camera 1's x-z plane when the pair has no floor."""
        x, z = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
        if pair.floor is None:
            return cls(origin=np.zeros(3), across=x, ahead=z, name="camera 1's x-z plane")
        n = pair.floor.normal
        across = x - (x @ n) * n
        across = across / np.linalg.norm(across)
        ahead = np.cross(across, n)
        return cls(origin=pair.floor.height * n, across=across, ahead=ahead, name="the floor")

    def coordinates(self, points: F64) -> F64:
        """(P, 2) points (P, 3) in the plane's ``(across, ahead)``."""
        d = np.asarray(points, dtype=np.float64) - self.origin
        return np.column_stack([d @ self.across, d @ self.ahead])

    def ellipses(self, cov: F64) -> list[Ellipse95 | None]:
        """Each covariance (P, 3, 3) seen on the plane as its 95% ellipse (None: not finite)."""
        axes = np.stack([self.across, self.ahead])  # (2, 3)
        c2 = np.einsum("ik,pkl,jl->pij", axes, np.asarray(cov, dtype=np.float64), axes)
        out: list[Ellipse95 | None] = []
        for c in c2:
            if not np.isfinite(c).all():
                out.append(None)
                continue
            values, vectors = np.linalg.eigh(0.5 * (c + c.T))
            values = np.clip(values, 0.0, None)
            major = vectors[:, 1]
            out.append(
                Ellipse95(
                    major=math.sqrt(CHI2_2D_95 * values[1]),
                    minor=math.sqrt(CHI2_2D_95 * values[0]),
                    angle_deg=math.degrees(math.atan2(major[1], major[0])) % 180.0,
                )
            )
        return out


@dataclass(frozen=True, kw_only=True)
class PointingEstimate:
    """One pair's live estimate.

    ``seq`` the pair's number (from 0); ``t_capture_ns`` camera 2's capture time (its
    clock: the recorder's monotonic clock for every pair source's clock), the instant the
    point describes; ``t_ns`` that instant on camera 1's clock; ``skew_ns`` the pair's;
    ``status`` the stream estimate's (``ok``, ``near_singular``, ``degenerate``,
    ``no_detection``, ``not_interpolated``) and ``words`` the conditioning said ("ok", or
    the reason); ``point`` (across, ahead) on :attr:`LivePointing.view` (None unless ok);
    ``point_3d`` the estimate in camera 1's frame; ``region`` its 95% ellipse there;
    ``track`` the last second's ok points ``(seconds before this pair, across, ahead)``,
    oldest first, this pair's last; ``done_ns`` the monotonic clock when it was made;
    ``cpu_ns`` the CPU this pair took (both frames' detection, its share of the estimate);
    ``noise`` each camera's detection noise its region carries, in words (where it came
    from: :class:`twopose.pair.frame_noise.CameraNoise`); ``warning`` what voids the point
    though it is ok (:class:`~recorder.live.pointing_voids.PointVoids`): camera 2's
    frames looking like camera 1's over the last pairs (:mod:`twopose.pair.copied_view`),
    or a dot's rays missing each other where it stood still (the pair file not these
    cameras': :mod:`twopose.pair.rays_miss`), "" where none.
    """

    seq: int
    t_capture_ns: int
    t_ns: float
    skew_ns: int
    status: str
    words: str
    point: tuple[float, float] | None
    point_3d: tuple[float, float, float] | None
    region: Ellipse95 | None
    track: tuple[tuple[float, float, float], ...]
    done_ns: int
    cpu_ns: int
    noise: tuple[str, str] = ("", "")
    warning: str = ""

    @property
    def ok(self) -> bool:
        """Whether the pair has a point."""
        return self.point is not None


@dataclass(frozen=True, kw_only=True, eq=False)
class PointingSettings:
    """How the live estimate is made: the clock offset (camera 2's clock minus camera 1's,
    with its 1-sigma; 0 by default: every pair source stamps on the monotonic clock), each
    frame's detection noise (None: each camera's from its frames of the last
    :data:`NOISE_WINDOW_S` seconds, every :data:`NOISE_EVERY_S`, by the analysis' rule,
    :func:`twopose.pair.frame_noise.camera_noise`; :data:`DEFAULT_NOISE` until they are
    enough), the solvers' thresholds, the pairing's slop (None: half a frame interval of
    ``fps``) and the cameras' frame rate."""

    offset: ClockOffset = field(
        default_factory=lambda: ClockOffset(offset_ns=0.0, sigma_ns=0.0, method="given", n=0)
    )
    noise: StreamNoise | None = None
    estimate: EstimateOptions = field(default_factory=EstimateOptions)
    slop_ns: int | None = None
    fps: float = 30.0


@dataclass(slots=True)
class _Seen:
    """One frame's detection: capture time (its camera's clock), centroid, angle, found,
    the thread CPU its detection took, and why it was not found."""

    index: int
    t_ns: int
    u: float
    v: float
    theta: float
    found: bool
    cpu_ns: int
    why: str


class LivePointing:
    """Frames in, one :class:`PointingEstimate` per pair out (the module docstring).

    Parameters
    ----------
    method : Method
        The point, line or ground method (the ground needs the pair's floor).
    pair : PairCalibration
        The calibrated pair.
    settings : PointingSettings
        The offset, noise, thresholds and slop.
    """

    def __init__(
        self, method: Method, pair: PairCalibration, settings: PointingSettings | None = None
    ) -> None:
        self.spec = spec_of(method)
        if self.spec.target is None:
            raise InputValueError(
                f"{self.spec.label} measures no target: point with --method ground, line or point"
            )
        self.target = self.spec.target
        self.method, self.pair = self.spec.method, pair
        self.settings = settings or PointingSettings()
        self.view = FloorView.of(pair)
        given = self.settings.noise
        self.noise = (
            (CameraNoise.given(given),) * 2 if given is not None
            else (CameraNoise(noise=DEFAULT_NOISE, source="assumed", why="no frames yet"),) * 2
        )  # fmt: skip
        self.stream = StreamSettings(
            noise=(self.noise[0].noise, self.noise[1].noise), estimate=self.settings.estimate
        )
        self._recent: tuple[deque[_Seen], deque[_Seen]] = (deque(), deque())
        self._noise_at_ns = -math.inf  # the newest frame the noise was estimated with
        slop = self.settings.slop_ns or round(0.5e9 / self.settings.fps)
        offset = round(self.settings.offset.offset_ns)
        self._pairing: LivePairing[_Seen] = LivePairing(slop_ns=slop, offset_ns=offset)
        self._one: deque[_Seen] = deque()  # camera 1's detected frames, oldest first
        self._waiting: deque[tuple[_Seen, _Seen, int]] = deque()  # pairs: first, second, skew
        self._track: deque[tuple[float, float, float]] = deque()  # (t_ns, across, ahead)
        # Copies of one recording, a pair file of another rig (a new user's r7 K1, K11)
        self.voids = PointVoids(pair, dot=not self.spec.uses_image_lines)
        self._ended = False
        self.seq = 0

    def warm_up(self) -> None:
        """Run detection and the estimate once on made-up frames (not kept), so that the
        cameras' first pairs are not late by the first calls' costs (a few hundred ms)."""
        i1 = self.pair.intrinsics1
        detect(np.full((i1.height, i1.width, 3), 128, np.uint8), self.target)
        c = [i1.cx, i1.cy]
        one = CameraTrack.of(
            [0, 1, 2], [c, c, c], [90.0] * 3 if self.spec.uses_image_lines else None
        )
        two = CameraTrack.of([1], [c], [90.0] if self.spec.uses_image_lines else None)
        estimate_stream(self.method, self.pair, one, two, self.settings.offset, self.stream)

    def see(self, frame: TimedFrame) -> _Seen:
        """Detect the method's target in one frame (once); camera 1's is kept."""
        start = time.thread_time_ns()
        d = detect(frame.image, self.target)
        u, v = d.centroid_px if d.found else (math.nan, math.nan)
        theta = d.theta_deg if d.found and self.spec.uses_image_lines else math.nan
        seen = _Seen(frame.index, frame.t_capture_ns, float(u), float(v), float(theta),
                     bool(d.found), time.thread_time_ns() - start, d.reason)  # fmt: skip
        if frame.camera == 1:
            self._one.append(seen)
        recent = self._recent[frame.camera - 1]
        if not recent or seen.t_ns > recent[-1].t_ns:
            recent.append(seen)
        while recent and recent[0].t_ns < seen.t_ns - NOISE_WINDOW_S * 1e9:
            recent.popleft()
        return seen

    def add_frame(self, frame: TimedFrame) -> list[PointingEstimate]:
        """Give the next frame of either camera; the estimates of the pairs now ready."""
        seen = self.see(frame)
        for p in self._pairing.add(frame.camera, frame.t_capture_ns, seen):
            self._waiting.append((p.first, p.second, p.skew_ns))
        return self._ready()

    def add_pair(self, pair: FramePair) -> list[PointingEstimate]:
        """Give a pair made elsewhere (its frames detected here, camera 1's in order);
        the estimates of the pairs now ready (camera 1's next frame may come with the
        next pair: :meth:`add_frame` is a frame interval sooner)."""
        first = next((s for s in self._one if s.index == pair.first.index), None)
        if first is None:
            first = self.see(pair.first)
        self._waiting.append((first, self.see(pair.second), pair.skew_ns))
        return self._ready()

    def end(self) -> list[PointingEstimate]:
        """The streams ended: every waiting pair estimated with what there is."""
        self._ended = True
        for camera in (1, 2):
            for p in self._pairing.end(camera):
                self._waiting.append((p.first, p.second, p.skew_ns))
        return self._ready()

    def _bracketed(self, t2_ns: int) -> bool:
        """Whether camera 1's frames about ``t2_ns`` (its clock) are all detected.

        A frame of camera 1 taken at ``t2_ns`` (in step, :data:`IN_STEP_NS`) is enough with
        the frame before it (its velocity): such a pair waits for no later frame; where that
        one lost the target, for the frame after it (the velocity the offline estimate takes).
        """
        one = self._one
        interval = float(np.median(np.diff([s.t_ns for s in one]))) if len(one) > 2 else 0.0
        reach = MAX_BRACKET_INTERVALS * interval
        step = [k for k, s in enumerate(one) if abs(s.t_ns - t2_ns) <= IN_STEP_NS]
        if step:
            n = step[0]
            back = n >= 1 and one[n - 1].found and one[n].t_ns - one[n - 1].t_ns <= reach
            return not one[n].found or back or n + 1 < len(one)
        after = [k for k, s in enumerate(one) if s.t_ns > t2_ns + IN_STEP_NS]
        if not after:
            return False
        j = after[0]
        if j == 0:  # the frame before fell out of the history: as the offline edge
            return True
        i = j - 1
        before_usable = i >= 1 and one[i - 1].found and one[i].t_ns - one[i - 1].t_ns <= reach
        return before_usable or j + 1 < len(one)

    def _ready(self) -> list[PointingEstimate]:
        offset = self.settings.offset.offset_ns
        ready = 0
        for _first, second, _skew in self._waiting:
            if not (self._ended or self._bracketed(round(second.t_ns - offset))):
                break
            ready += 1
        if ready == 0 and len(self._waiting) > MAX_WAITING:
            ready = 1  # camera 1 stalls: the oldest is estimated with what there is
        if ready == 0:
            return []
        batch = [self._waiting.popleft() for _ in range(ready)]
        out = self._estimate(batch)
        self._forget()
        return out

    def _forget(self) -> None:
        """Keep :data:`HISTORY_FRAMES` of camera 1's frames before the oldest still needed."""
        offset = self.settings.offset.offset_ns
        oldest = min((s.t_ns - offset for _f, s, _k in self._waiting), default=math.inf)
        newer = sum(1 for s in self._one if s.t_ns > oldest)
        while len(self._one) > HISTORY_FRAMES + newer:
            self._one.popleft()

    def noise_now(self) -> tuple[CameraNoise, CameraNoise]:
        """Each camera's detection noise now: the one given, else from its frames of the
        last :data:`NOISE_WINDOW_S` seconds (the analysis' rule, as a session's frames)."""
        if self.settings.noise is not None:
            return self.noise
        lines = self.spec.uses_image_lines
        sizes = [(i.width, i.height) for i in (self.pair.intrinsics1, self.pair.intrinsics2)]
        one, two = (
            camera_noise([_track(list(r), lines=lines)], lines=lines,
                         floor=self.spec.floor_in_pair, assumed=DEFAULT_NOISE, size=size)
            for r, size in zip(self._recent, sizes, strict=True)
        )  # fmt: skip
        return one, two

    def _estimate(self, batch: list[tuple[_Seen, _Seen, int]]) -> list[PointingEstimate]:
        """The batch's pairs through the stream estimate, as one call."""
        start = time.thread_time_ns()
        newest = max((r[-1].t_ns for r in self._recent if r), default=-math.inf)
        if self._ended or newest - self._noise_at_ns >= NOISE_EVERY_S * 1e9:
            self._noise_at_ns = newest
            self.noise = self.noise_now()
            self.stream = dataclasses.replace(
                self.stream, noise=(self.noise[0].noise, self.noise[1].noise)
            )
        one = list(self._one)
        position = {s.index: k for k, s in enumerate(one)}
        firsts = [position.get(f.index, -1) for f, _s, _k in batch]
        if min(firsts) < 0:  # a pair's frame left the history (a stall): its own track
            one, firsts = _own_frames(batch)
        seconds = [s for _f, s, _k in batch]
        lines = self.spec.uses_image_lines
        track1, track2 = _track(one, lines=lines), _track(seconds, lines=lines)
        pairing = Pairing(
            i1=np.asarray(firsts, dtype=np.int64), i2=np.arange(len(batch), dtype=np.int64),
            skew_ns=np.array([k for _f, _s, k in batch], dtype=np.float64),
            slop_ns=float(self._pairing.slop_ns), unpaired1=0, unpaired2=0,
        )  # fmt: skip
        e = estimate_stream(
            self.method, self.pair, track1, track2, self.settings.offset, self.stream,
            pairing=pairing,
        )  # fmt: skip
        share = (time.thread_time_ns() - start) // len(batch)
        return self._said(e, batch, share)

    def _said(
        self, e: StreamEstimate, batch: list[tuple[_Seen, _Seen, int]], share_ns: int
    ) -> list[PointingEstimate]:
        """The stream estimate's pairs as the console shows them."""
        points = self.view.coordinates(e.point)
        regions = self.view.ellipses(e.cov)
        now = time.monotonic_ns()
        lines = self.spec.uses_image_lines
        noise = (self.noise[0].said(lines=lines), self.noise[1].said(lines=lines))
        gaps = self.voids.gaps(e.measured)
        noise_px = max(n.noise.centroid_px for n in self.noise)
        out = []
        for k, (first, second, skew) in enumerate(batch):
            ok = bool(e.ok[k])
            t = float(e.t_ns[k])
            if ok:
                self._track.append((t, float(points[k, 0]), float(points[k, 1])))
            while self._track and self._track[0][0] < t - TRACK_S * 1e9:
                self._track.popleft()
            track = tuple(((t - s) / 1e9, a, b) for s, a, b in self._track if s <= t)
            p3 = e.point[k]
            warning = self.voids.said(
                (first.u, first.v) if first.found else None,
                (second.u, second.v) if second.found else None, float(gaps[k]), noise_px,
            )  # fmt: skip
            out.append(
                PointingEstimate(
                    seq=self.seq,
                    t_capture_ns=second.t_ns,
                    t_ns=t,
                    skew_ns=skew,
                    status=str(e.status[k]),
                    words=_words(e, k, first, second),
                    point=(float(points[k, 0]), float(points[k, 1])) if ok else None,
                    point_3d=(float(p3[0]), float(p3[1]), float(p3[2])) if ok else None,
                    region=regions[k] if ok else None,
                    track=track,
                    done_ns=now,
                    cpu_ns=first.cpu_ns + second.cpu_ns + share_ns,
                    noise=noise,
                    warning=warning,
                )
            )
            self.seq += 1
        return out


def _own_frames(batch: list[tuple[_Seen, _Seen, int]]) -> tuple[list[_Seen], list[int]]:
    """Camera 1's frames of the batch alone (its history lost them): no interpolation."""
    frames = sorted({f.index: f for f, _s, _k in batch}.values(), key=lambda s: s.t_ns)
    position = {s.index: k for k, s in enumerate(frames)}
    return frames, [position[f.index] for f, _s, _k in batch]


def _track(seen: list[_Seen], *, lines: bool) -> CameraTrack:
    """Detected frames as a camera's track (``lines``: with their image lines' angles)."""
    return CameraTrack.of(
        [s.t_ns for s in seen],
        np.array([(s.u, s.v) for s in seen], dtype=np.float64).reshape(-1, 2),
        np.array([s.theta for s in seen], dtype=np.float64) if lines else None,
        np.array([s.found for s in seen], dtype=bool),
    )


#: What each margin under its limit means for the pair, said after the margin (the solver's
#: labels: twopose.solve.estimate.margin_warnings).
_SINGULAR_MEANS = (
    ("ray parallax", "the two cameras' rays to the target are nearly parallel"),
    ("plane angle", "the finger's line is close to the plane through both cameras"),
    ("line-", "the finger's line is nearly parallel to the plane it points at"),
)


def _why_singular(reason: str) -> str:
    """What the margins under their limits in ``reason`` mean, in parentheses ("" if none)."""
    means = [m for label, m in _SINGULAR_MEANS if label in reason]
    return f" ({'; '.join(means)})" if means else ""


def _words(e: StreamEstimate, k: int, first: _Seen, second: _Seen) -> str:
    """A pair's conditioning in words: "ok", or why it has no point."""
    status, reason = str(e.status[k]), str(e.reason[k])
    if status == "ok":
        return "ok"
    if status == "near_singular":
        return f"near-singular: {reason}{_why_singular(reason)}"
    if status == "no_detection":
        lost = [
            f"camera {n} does not see the target ({s.why or 'not found'})"
            for n, s in ((1, first), (2, second))
            if not s.found
        ]
        return "; ".join(lost) or f"no detection: {reason}"
    return f"{status.replace('_', ' ')}: {reason}"
