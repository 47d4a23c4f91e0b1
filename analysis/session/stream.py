"""A two-camera session replayed into one estimate per frame pair and errors at its touches.

Issue 58 item 6, its start: the Python face of a stream's analysis (``run`` does not take
two-camera sessions yet). :func:`replay_pair_session` reads a format 1.6 session
(:func:`twopose.format.streams.read_pair_session`), detects the method's target in every
frame of both cameras (:func:`twopose.detect.detection.detect`: the dot's centroid, or the glove's
centroid and image line), takes the clock offset the session recorded (else measures it
per trial as the recorder does, from a flash both cameras saw and the targets' centroids'
smallest ray gap: :func:`twopose.pair.trial_offset.measure_trial_offset`; or the one
given), takes each camera's pixel noise from the session's own frames
(:func:`session_noise`), and estimates the stream
(:func:`twopose.pair.stream.estimate_stream`: camera 1's measurement interpolated to camera
2's capture time, the method's one solver, each pair's conditioning and 95% region). At each
touch (a moment the target was at a known grid point, on camera 1's clock) the estimate is
read at the touch's time, interpolated linearly between the two ok estimates about it (no
more than :data:`MAX_TOUCH_GAP_INTERVALS` frame intervals apart; else none), a line's from
the estimate nearest in time; its error is its distance to the touched point (a line's:
the point's distance from the line).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twopose.arrays import F64
from twopose.detect.detection import Detection, detect
from twopose.errors import InputValueError
from twopose.format.entries import Touch
from twopose.format.messages import Frame
from twopose.format.reader import SessionReader
from twopose.format.streams import CameraStream, StreamTrial, read_pair_session
from twopose.methods.specs import Method, spec_of
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock import ClockOffset
from twopose.pair.frame_noise import CameraNoise, camera_noise
from twopose.pair.stream import (
    CameraTrack,
    StreamEstimate,
    StreamNoise,
    StreamSettings,
    estimate_stream,
)
from twopose.pair.trial_offset import BrightnessMeter, measure_trial_offset

__all__ = [
    "MAX_TOUCH_GAP_INTERVALS",
    "FrameSeen",
    "PairReplay",
    "TrialReplay",
    "at_touches",
    "camera_track",
    "detect_trial",
    "replay_pair_session",
    "replay_trial",
    "session_noise",
]

#: A touch's estimate is interpolated between two ok estimates no more than this many
#: frame intervals apart (one lost or near-singular pair between them is bridged).
MAX_TOUCH_GAP_INTERVALS = 2.5
#: Each frame's detection noise assumed where the session's own frames are too few to
#: estimate it (:func:`session_noise`; 1-sigma: centroid px, line deg).
DEFAULT_NOISE = StreamNoise(centroid_px=0.25, theta_deg=0.25)

#: A stream trial's detections: both cameras' tracks, their frames' detector reasons and
#: brightness (what a flash's offset is measured from).
Detected = tuple[
    tuple[CameraTrack, CameraTrack],
    tuple[tuple[str, ...], tuple[str, ...]],
    tuple[list[float], list[float]],
]


@dataclass(frozen=True, kw_only=True, eq=False)
class TrialReplay:
    """One stream trial replayed.

    ``tracks`` each camera's detections; ``offset`` the clock offset used and
    ``offset_from`` where it came from (``recorded``, ``measured``, ``given``);
    ``estimate`` one estimate per frame pair; per touch (``touches``, in order)
    ``at_touch`` (K, 3) the estimate at its time (NaN: none) and ``touch_error`` (K,) its
    distance to the touched point (NaN: none); ``reason`` why the trial's streams are
    incomplete ("" when complete).
    """

    trial: int
    tracks: tuple[CameraTrack, CameraTrack]
    offset: ClockOffset
    offset_from: str
    estimate: StreamEstimate
    touches: tuple[Touch, ...]
    at_touch: F64
    touch_error: F64
    reason: str = ""
    #: each camera's detection noise used, and where it came from
    noise: tuple[CameraNoise, CameraNoise] | None = None
    #: camera 1's median frame interval (ns; 0 with fewer than two frames)
    interval_ns: float = 0.0
    #: each camera's frames' detector reasons, in frame order ("" where found)
    missed: tuple[tuple[str, ...], tuple[str, ...]] = ((), ())

    @property
    def truth(self) -> F64:
        """(K, 3) the touched points, in touch order."""
        return np.array([t.point for t in self.touches], dtype=np.float64).reshape(-1, 3)


@dataclass(frozen=True, kw_only=True, eq=False)
class PairReplay:
    """A two-camera session replayed: its method, pair and trials (:class:`TrialReplay`)."""

    path: Path
    method: Method
    pair: PairCalibration
    trials: tuple[TrialReplay, ...]
    #: each camera's detection noise the regions carry, and where it came from
    noise: tuple[CameraNoise, CameraNoise] | None = None


#: Told each frame as it is detected, with its detection (the tables, results.mcap).
FrameSeen = Callable[[Frame, Detection], None]


def camera_track(
    stream: CameraStream,
    method: Method,
    params: object = None,
    seen: FrameSeen | None = None,
    brightness: list[float] | None = None,
) -> CameraTrack:
    """One camera's detections of the method's target, frame by frame (by the detector's
    thresholds ``params``, else its defaults), each told to ``seen``; each frame's
    brightness appended to ``brightness`` (:class:`twopose.pair.trial_offset.
    BrightnessMeter`: a flash's, for the clock offset) when it is given."""
    spec = spec_of(method)
    assert spec.target is not None  # a measuring method's
    found, centroid, theta = [], [], []
    size = (stream.camera.intrinsics.width, stream.camera.intrinsics.height)
    meter = BrightnessMeter()
    for frame in stream.frames():
        image = frame.decode(size)
        if brightness is not None:
            brightness.append(meter(image))
        d = detect(image, spec.target, params)
        if seen is not None:
            seen(frame, d)
        found.append(d.found)
        centroid.append(d.centroid_px if d.found else (np.nan, np.nan))
        theta.append(d.theta_deg if d.found and spec.uses_image_lines else np.nan)
    return CameraTrack.of(
        stream.capture_ns,
        np.array(centroid, dtype=np.float64).reshape(-1, 2),
        np.array(theta, dtype=np.float64) if spec.uses_image_lines else None,
        np.array(found, dtype=bool),
    )


def _offset(
    trial: StreamTrial,
    pair: PairCalibration,
    tracks: tuple[CameraTrack, CameraTrack],
    known: tuple[ClockOffset | None, str],
    brightness: tuple[list[float], list[float]],
    *,
    method: Method,
) -> tuple[ClockOffset, str]:
    """The clock offset: the one known (given, recorded), else measured as the recorder
    measures it (:func:`twopose.pair.trial_offset.measure_trial_offset`: a flash both
    cameras saw, the rays' gap, pooled where both; a target with image lines with its
    point's place along them fitted; the method's detector floor in a pair a term of the
    gap's sigma)."""
    if known[0] is not None:
        return known[0], known[1]
    one, two = tracks
    spec = spec_of(method)
    measured = measure_trial_offset(
        pair, (one.centroid_px, two.centroid_px), (one.t_ns, two.t_ns), brightness,
        (one.theta_deg, two.theta_deg) if spec.uses_image_lines else None, spec.floor_in_pair[0],
    )  # fmt: skip
    if measured.offset is None:
        raise InputValueError(f"trial {trial.trial}: the clock offset: {'; '.join(measured.why)}")
    return measured.offset, "measured"


def at_touches(estimate: StreamEstimate, touches: tuple[Touch, ...], interval: float) -> F64:
    """(K, 3) the estimate at each touch's time (a line's: the nearest estimate's point on
    its line nearest the touched point); NaN where there is none about it."""
    ok = estimate.ok
    t, points = estimate.t_ns[ok], estimate.point[ok]
    out = np.full((len(touches), 3), np.nan)
    if not t.size:
        return out
    for k, touch in enumerate(touches):
        j = int(np.searchsorted(t, touch.time_ns))
        if estimate.direction is not None:  # a line: the estimate nearest in time
            near = int(np.argmin(np.abs(t - touch.time_ns)))
            if abs(t[near] - touch.time_ns) <= MAX_TOUCH_GAP_INTERVALS * interval / 2:
                d = estimate.direction[ok][near]
                p, q = points[near], np.asarray(touch.point)
                out[k] = p + ((q - p) @ d) * d
            continue
        if 0 < j < t.size and t[j] - t[j - 1] <= MAX_TOUCH_GAP_INTERVALS * interval:
            w = (touch.time_ns - t[j - 1]) / (t[j] - t[j - 1])
            out[k] = (1 - w) * points[j - 1] + w * points[j]
    return out


def replay_pair_session(
    path: str | Path,
    *,
    noise: StreamNoise | None = None,
    offset: ClockOffset | None = None,
    interpolate: bool = True,
) -> PairReplay:
    """Replay a two-camera session (the module docstring).

    Parameters
    ----------
    path : path-like
        A format 1.6 two-camera session.
    noise : StreamNoise, optional
        Each frame's detection noise (default: each camera's estimated from the session's
        own frames, :func:`session_noise`; :data:`DEFAULT_NOISE` where they are too few).
    offset : ClockOffset, optional
        The clock offset to use (default: the session's last recorded one, else measured
        per trial).
    interpolate : bool
        Whether camera 1's measurement is interpolated to camera 2's capture time.

    Returns
    -------
    PairReplay
    """
    with SessionReader(path) as reader:
        session = read_pair_session(reader)
        method = session.info.method
        if not spec_of(method).measures:
            raise InputValueError(f"{path}: a {method} session measures nothing to replay")
        known = (offset, "given") if offset is not None else (session.offset, "recorded")
        detected = [detect_trial(trial, method) for trial in session.trials]
        used = session_noise([d[0] for d in detected], method, noise, pair=session.pair)
        settings = StreamSettings(noise=(used[0].noise, used[1].noise), interpolate=interpolate)
        trials = [
            replay_trial(trial, session.pair, method, known, settings, detected=d,
                         noise=used)
            for trial, d in zip(session.trials, detected, strict=True)
        ]  # fmt: skip
    return PairReplay(path=Path(path), method=method, pair=session.pair, trials=tuple(trials),
                      noise=used)  # fmt: skip


def session_noise(
    tracks: list[tuple[CameraTrack, CameraTrack]], method: Method, given: StreamNoise | None,
    pair: PairCalibration | None = None,
) -> tuple[CameraNoise, CameraNoise]:  # fmt: skip
    """Each camera's detection noise per frame: ``given``, else from the session's own
    frames, every stream trial's pooled: their scatter with the detector's floor in a pair
    (:func:`twopose.pair.frame_noise.camera_noise`), or :data:`DEFAULT_NOISE` where they
    are too few, said so; with the ``pair``, each camera's image size too (a floor not
    measured at it said)."""
    if given is not None:
        return CameraNoise.given(given), CameraNoise.given(given)
    spec = spec_of(method)
    sizes = (None, None) if pair is None else tuple(
        (i.width, i.height) for i in (pair.intrinsics1, pair.intrinsics2))  # fmt: skip
    one, two = (
        camera_noise([t[c] for t in tracks], lines=spec.uses_image_lines,
                     floor=spec.floor_in_pair, assumed=DEFAULT_NOISE, size=sizes[c])
        for c in (0, 1)
    )  # fmt: skip
    return one, two


def detect_trial(
    trial: StreamTrial,
    method: Method,
    params: object = None,
    seen: tuple[FrameSeen, FrameSeen] | None = None,
) -> Detected:
    """Both cameras' detections of the method's target in a stream trial (by the detector's
    thresholds ``params``, each frame told to its camera's ``seen``), each frame's
    detector reason ("" where found) and its brightness (for a flash)."""
    outer = seen or (None, None)
    missed: tuple[list[str], list[str]] = ([], [])

    def told(n: int) -> FrameSeen:
        """Keep camera ``n``'s detector's reasons (a touch's row names them), then tell."""

        def keep(frame: Frame, d: Detection) -> None:
            missed[n].append("" if d.found else d.reason)
            if outer[n] is not None:
                outer[n](frame, d)  # type: ignore[misc]

        return keep

    lit: tuple[list[float], list[float]] = ([], [])
    tracks = (
        camera_track(trial.camera1, method, params, told(0), lit[0]),
        camera_track(trial.camera2, method, params, told(1), lit[1]),
    )
    return tracks, (tuple(missed[0]), tuple(missed[1])), lit


def replay_trial(
    trial: StreamTrial,
    pair: PairCalibration,
    method: Method,
    known: tuple[ClockOffset | None, str],
    settings: StreamSettings,
    *,
    detected: Detected | None = None,
    noise: tuple[CameraNoise, CameraNoise] | None = None,
) -> TrialReplay:
    """One stream trial replayed (the reader open): both cameras' targets detected (by the
    detector's default thresholds; or ``detected`` already, :func:`detect_trial`), the
    clock offset ``known`` (``(offset, where from)``; ``(None, _)``: measured by the ray
    gap), the stream estimated (each camera's noise ``settings.noise``, where it came from
    ``noise``: :func:`session_noise`) and read at each touch.

    Raises :class:`~twopose.errors.InputValueError` when the trial cannot be estimated (a
    camera with too few frames, an offset that cannot be measured), saying why.
    """
    tracks, missed, lit = detected or detect_trial(trial, method)
    used, source = _offset(trial, pair, tracks, known, lit, method=method)
    estimate = estimate_stream(method, pair, *tracks, used, settings)
    interval = float(np.median(np.diff(tracks[0].t_ns))) if len(tracks[0].t_ns) > 1 else 0.0
    at = at_touches(estimate, trial.touches, interval)
    replay = TrialReplay(
        trial=trial.trial,
        tracks=tracks,
        offset=used,
        offset_from=source,
        estimate=estimate,
        touches=trial.touches,
        at_touch=at,
        touch_error=np.full(len(trial.touches), np.nan),
        # one reason once (a recovered window closes both cameras alike)
        reason="; ".join(dict.fromkeys(s.reason for s in trial.cameras if s.reason)),
        noise=noise,
        interval_ns=interval,
        missed=missed,
    )
    error = np.linalg.norm(at - replay.truth, axis=1)
    return dataclasses.replace(replay, touch_error=error)
