"""The capture step: K frames from a source into the session, with live detection feedback.

:func:`capture_frames` is called by the procedure (:mod:`recorder.procedure.machine`) once the
typed pose is written and bound to a capture number; it never writes the pose itself.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from recorder.procedure import stops
from recorder.sources.registry import FrameSource
from twopose.detect.detection import detection_json
from twopose.errors import SourceError
from twopose.format.entries import PoseEntry
from twopose.format.writer import Capture, SessionWriter
from twopose.methods.specs import Method, spec_of
from twopose.values.choices import TargetSpec

if TYPE_CHECKING:
    from recorder.live.trial_result import TrialResult
    from twopose.detect.detection import Detection, RejectedBlob
    from twopose.detect.frames import PoseMeasurement
    from twopose.display.scene import TrialScene
    from twopose.format.entries import SessionInfo
    from twopose.guidance.advice import Guidance
    from twopose.methods.targets import BoardPlacement
    from twopose.rig.constants import RigConstants
    from twopose.solve.margins import EstimateOptions
    from twopose.uncertainty.noise import PlacingSigma
    from twopose.values.units import Units

__all__ = [
    "AdaptiveFrames",
    "CaptureInterrupted",
    "CaptureResult",
    "CaptureSettings",
    "FrameFeedback",
    "LiveSink",
    "Shortfall",
    "capture_frames",
    "detection_shortfall",
]


class LiveSink(Protocol):
    """Where the recorder shows what it captures as it happens: the Foxglove live view
    (:class:`recorder.live.view.LiveSink`) or the web console (:mod:`recorder.console.state`)."""

    def frame(
        self,
        camera_id: str,
        data: bytes,
        image_format: str,
        log_time_ns: int,
        detection: Detection | None,
        label: str,
    ) -> None: ...

    def status(
        self,
        log_time_ns: int,
        *,
        trial: int,
        pose: int,
        frame: int,
        n_frames: int,
        message: str,
        found: bool | None = None,
    ) -> None: ...

    def trial_result(
        self, result: TrialResult, scene: TrialScene | None, log_time_ns: int
    ) -> None: ...


class LiveSinks(LiveSink):
    """Several live sinks as one: the web console and the Foxglove live view at once
    (``new --ui --live``)."""

    def __init__(self, *sinks: LiveSink) -> None:
        self.sinks = sinks

    def frame(
        self,
        camera_id: str,
        data: bytes,
        image_format: str,
        log_time_ns: int,
        detection: Detection | None,
        label: str,
    ) -> None:
        for sink in self.sinks:
            sink.frame(camera_id, data, image_format, log_time_ns, detection, label)

    def status(
        self,
        log_time_ns: int,
        *,
        trial: int,
        pose: int,
        frame: int,
        n_frames: int,
        message: str,
        found: bool | None = None,
    ) -> None:
        for sink in self.sinks:
            sink.status(
                log_time_ns,
                trial=trial,
                pose=pose,
                frame=frame,
                n_frames=n_frames,
                message=message,
                found=found,
            )

    def trial_result(self, result: TrialResult, scene: TrialScene | None, log_time_ns: int) -> None:
        for sink in self.sinks:
            sink.trial_result(result, scene, log_time_ns)


@dataclass(frozen=True, kw_only=True)
class FrameFeedback:
    """What the operator sees for each captured frame."""

    index: int
    found: bool
    centroid_px: tuple[float, float]
    theta_deg: float
    n_blobs: int  # objects after the colour/contrast stage (the thesis GUI's count)
    reason: str
    area_px: float = math.nan
    eccentricity: float = math.nan
    is_board: bool = False  # a board session's frame: the board's corners were sought
    board_corners: int = 0  # a board session: the inner corners found (all, or none)
    board_coverage: float = math.nan  # the share of the image the corners span
    #: The blobs a filter turned down, each ``(u, v, radius)`` in pixels: what guidance
    #: keeps the target from being seen over (:func:`twopose.detect.clutter.seen_clutter`).
    turned_down_px: tuple[tuple[float, float, float], ...] = ()

    def line(self) -> str:
        """What the thesis' GUI showed per frame (section 5.2.4): centroid, orientation
        and the image line through them, area, eccentricity, object count; for a board,
        its corners and the share of the image they cover."""
        if not self.found:
            return f"  frame {self.index + 1}: not found ({self.reason})"
        if self.board_corners:
            return (
                f"  frame {self.index + 1}: board found, {self.board_corners} corners, "
                f"covering {self.board_coverage:.0%} of the image"
            )
        col, row = self.centroid_px
        parts = [f"  frame {self.index + 1}: found at ({col:.1f}, {row:.1f})"]
        if math.isfinite(self.theta_deg):
            parts.append(f"theta {self.theta_deg:+.1f} deg")
            parts.append(image_line_equation(self.centroid_px, self.theta_deg))
        if math.isfinite(self.area_px):
            parts.append(f"area {self.area_px:.0f} px")
        if math.isfinite(self.eccentricity):
            parts.append(f"eccentricity {self.eccentricity:.2f}")
        parts.append(f"{self.n_blobs} object(s)")
        return ", ".join(parts)

    def to_json(self) -> dict[str, object]:
        """The frame's numbers for the web console (NaN stays NaN: the one JSON encoder
        turns it into null)."""
        line = ""
        if self.found and math.isfinite(self.theta_deg):
            line = image_line_equation(self.centroid_px, self.theta_deg)
        return {
            "frame": self.index + 1,
            **detection_json(self),
            "line": line,
            "is_board": self.is_board,
            "board_corners": self.board_corners,
            "board_coverage": self.board_coverage,
        }


def image_line_equation(centroid_px: tuple[float, float], theta_deg: float) -> str:
    """The image line through the centroid at the orientation, ``a u + b v = c`` with
    (a, b) its unit normal (thesis eq. 3.15's line in pixels)."""
    t = math.radians(theta_deg)
    a, b = -math.sin(t), math.cos(t)
    c = a * centroid_px[0] + b * centroid_px[1]
    return f"line {a:+.3f} u {b:+.3f} v = {c:.1f}"


@dataclass(frozen=True, kw_only=True)
class CaptureResult:
    """How a capture went."""

    n_frames: int
    complete: bool
    reason: str
    feedback: tuple[FrameFeedback, ...] = ()
    dropped: int = 0
    overhead_s: tuple[float, ...] = ()  # per frame: encode + write + detection
    capture: int | None = None  # its number in the session (format 1.1)
    enough: bool = False  # adaptive frames: it stopped early, more would not have helped

    @property
    def state(self) -> str:
        """How it ended, in the operator's words (the terminal, a plan's log, the page)."""
        if not self.complete:
            return f"INCOMPLETE ({self.reason})"
        if self.enough:
            return "complete (frames enough: another would not shrink the region)"
        return "complete"

    @property
    def n_found(self) -> int:
        return sum(f.found for f in self.feedback)

    @property
    def sought(self) -> str:
        """What the live detection looked for, in the operator's words."""
        return "the board" if any(f.is_board for f in self.feedback) else "the target"

    def pose_average(self) -> PoseMeasurement | None:
        """The pose's frames combined as the analysis combines them by default (the
        thesis' mean, section 5.2.5); None without live detection."""
        from twopose.detect.frames import combine_frames

        if not self.feedback or any(f.is_board for f in self.feedback):
            return None  # a board's corners are averaged by the rig calibration
        fb = self.feedback
        return combine_frames(
            np.array([f.centroid_px for f in fb], dtype=np.float64),
            np.array([f.theta_deg for f in fb], dtype=np.float64),
            np.array([f.found for f in fb], dtype=bool),
        )


class CaptureInterrupted(KeyboardInterrupt):
    """A stop (Ctrl-C, SIGTERM, ...) cut a capture short: its window is in the file, marked
    incomplete, and ``result`` says how far it went (its frames are in the file too)."""

    def __init__(self, result: CaptureResult) -> None:
        super().__init__(result.reason)
        self.result = result


class Shortfall(StrEnum):
    """How a capture's live detection falls short of a measurement."""

    OK = "ok"  # found in at least half the frames (or no live detection to judge by)
    FEW_FOUND = "few"  # found, but in fewer than half the frames
    NONE_FOUND = "none"  # found in no frame


def detection_shortfall(result: CaptureResult) -> Shortfall:
    """The one rule for a capture's detections: fewer than half found needs the
    operator's confirmation, none found is nothing to measure."""
    if not result.feedback:
        return Shortfall.OK
    if result.n_found == 0:
        return Shortfall.NONE_FOUND
    return Shortfall.FEW_FOUND if 2 * result.n_found < len(result.feedback) else Shortfall.OK


@dataclass(frozen=True, kw_only=True)
class CaptureSettings:
    """How every capture of a recording is taken: the same for each pose.

    ``target`` (a :class:`~twopose.values.choices.TargetSpec`: the glove's, the dot's) turns on
    live detection: each frame's feedback to ``on_frame``, the detection drawn on ``live``,
    and the trial's live result (corrected by ``rig``, a calibrated rig, if given);
    ``on_progress`` is called after every frame written, detected or not.
    """

    frames: int = 5
    target: TargetSpec[Any] | None = None
    live: LiveSink | None = None
    on_frame: Callable[[FrameFeedback], None] | None = None
    on_progress: Callable[[], None] | None = None
    rig: RigConstants | None = None
    #: The operator's placing sigma a board session measured (the rig file's
    #: ``[placing]``): every live region and guidance's predictions take it instead of
    #: each pose's typed resolution (None: typed).
    placing: PlacingSigma | None = None
    timeout_s: float = 2.0  # a frame later than this: the source has stopped
    #: A board session's board: each frame's corners are looked for, live (the rig
    #: calibration finds them again in the file); a pose that never saw it is refused.
    board: BoardPlacement | None = None
    #: With live detection: after each decision the next pose is suggested and, with a
    #: target precision, the driver is told when the trial is precise enough (issue 36).
    guidance: Guidance | None = None
    #: Adaptive frames (``--adaptive-frames``): ``frames`` is then the most, and a capture
    #: stops once another frame would not shrink the pose's measurement (the detector's
    #: floor, with whether the method reads an orientation: :meth:`live_detection` sets it).
    adaptive: AdaptiveFrames | None = None

    def estimate_options(self) -> EstimateOptions:
        """The live result's estimation: its regions (and guidance's predictions) take the
        measured placing sigma (:attr:`placing`), else each pose's typed resolution, and
        carry the rig's constants' covariance (``J C J^T``, :mod:`twopose.rig.carried`)."""
        from twopose.solve.margins import EstimateOptions
        from twopose.uncertainty.noise import NoiseModel

        covariance = self.rig.covariance if self.rig is not None else None
        return EstimateOptions(noise=NoiseModel(placing=self.placing, rig=covariance))

    def placing_words(self, units: Units) -> str:
        """Which placing sigma the live result uses, in words (the recording says it)."""
        if self.placing is None:
            return "placing sigma: typed (each pose's recorded resolution)"
        return self.placing.describe(units)

    @classmethod
    def live_detection(
        cls, info: SessionInfo, *, adaptive_frames: bool = False, **settings: Any
    ) -> CaptureSettings:
        """Settings that detect, live, what the session's method looks for: its target
        (:class:`twopose.methods.specs.MethodSpec`), or the board of a board session; with
        ``adaptive_frames``, the method's :class:`AdaptiveFrames`."""
        adaptive = AdaptiveFrames.asked(info.method, asked=adaptive_frames)
        return cls(
            target=spec_of(info.method).target, board=info.board, adaptive=adaptive, **settings
        )


@dataclass(frozen=True, kw_only=True)
class AdaptiveFrames:
    """When a pose has frames enough (:func:`twopose.uncertainty.propagate.enough_frames`)."""

    floor: tuple[float, float]  # the detector's systematic error: px, degrees
    orientation: bool  # whether the method reads the frames' orientation (the glove's line)

    @classmethod
    def asked(cls, method: Method, *, asked: bool) -> AdaptiveFrames | None:
        """The method's rule, from the registry, when asked (a board session has none: it
        measures no target)."""
        spec = spec_of(method)
        if not (asked and spec.measures):
            return None
        return cls(floor=spec.detector_floor, orientation=spec.uses_image_lines)

    def enough(self, feedback: Sequence[FrameFeedback]) -> bool:
        """Whether the capture's found frames so far are enough."""
        from twopose.uncertainty.propagate import enough_frames

        found = [f for f in feedback if f.found]
        if not found:
            return False
        centroids = np.array([f.centroid_px for f in found], dtype=np.float64)
        thetas = np.array([f.theta_deg for f in found]) if self.orientation else None
        return enough_frames(centroids, thetas, self.floor)


def capture_frames(
    writer: SessionWriter, source: FrameSource, entry: PoseEntry, settings: CaptureSettings
) -> CaptureResult:
    """Capture ``settings.frames`` frames for the already written pose ``entry`` (the source
    is already placed there); with ``settings.adaptive``, fewer once they are enough.

    Dropped frames are counted from the start of this capture only: the source restarts
    its clock here (:meth:`FrameSource.start_capture`), so the operator's pause before a
    capture is never counted. A source that fails mid-capture leaves the capture in the
    file, marked incomplete with the reason; an interrupt (Ctrl-C, a stop) does the same,
    then propagates as :class:`CaptureInterrupted`, which carries how the capture went (its
    window is in the file: the summary counts it).
    """
    from twopose.camera.images import decode_image

    n_frames, target, live = settings.frames, settings.target, settings.live
    source.start_capture()
    dropped_before = source.dropped
    feedback: list[FrameFeedback] = []
    overhead: list[float] = []
    reason, enough = "", False
    cap = writer.capture(entry.trial, entry.pose, entry.camera_id, entry.capture)
    try:
        with cap:
            for k in range(n_frames):
                # a stop: this capture is kept, incomplete (recorder/procedure/stops.py)
                stops.check()
                try:
                    image = source.read(settings.timeout_s)
                except SourceError as err:
                    reason = str(err)
                    cap.mark_incomplete(reason)
                    break
                started = time.perf_counter()
                data = writer.encode_image(image)
                cap.add_encoded(data)
                # Detected on the frame as stored (decoded), as the analysis will: the live
                # result is then the analysis' own, to the last digit.
                decoded = (
                    None
                    if target is None and settings.board is None
                    else decode_image(data, "the frame")
                )
                d = None if target is None or decoded is None else target.detect(decoded)
                fb = None if d is None else _feedback(k, d)
                if settings.board is not None and decoded is not None:
                    fb = board_feedback(k, decoded, settings.board)
                if fb is not None:
                    feedback.append(fb)
                if live is not None:
                    _show_live(live, writer, cap, entry, data, (k, n_frames), d)
                overhead.append(time.perf_counter() - started)
                if fb is not None and settings.on_frame is not None:
                    settings.on_frame(fb)
                if settings.on_progress is not None:
                    settings.on_progress()
                cap.dropped_frames = source.dropped - dropped_before
                enough = settings.adaptive is not None and settings.adaptive.enough(feedback)
                if enough and k + 1 < n_frames:
                    break  # more frames would not shrink the pose's region: the floor rules
    except KeyboardInterrupt as stop:
        if not writer.is_open:  # no window was written: nothing to count
            raise
        raise CaptureInterrupted(
            CaptureResult(
                n_frames=cap.n_frames,
                complete=False,
                reason=cap.incomplete_reason,
                feedback=tuple(feedback),
                dropped=cap.dropped_frames,  # as its window says
                overhead_s=tuple(overhead),
                capture=entry.capture,
            )
        ) from stop
    return CaptureResult(
        n_frames=cap.n_frames,
        complete=not reason,
        reason=reason,
        feedback=tuple(feedback),
        dropped=source.dropped - dropped_before,
        overhead_s=tuple(overhead),
        capture=entry.capture,
        enough=enough and cap.n_frames < n_frames,
    )


def _feedback(k: int, d: Detection) -> FrameFeedback:
    return FrameFeedback(
        index=k,
        found=d.found,
        centroid_px=d.centroid_px,
        theta_deg=d.theta_deg,
        n_blobs=d.n_blobs,
        reason=d.reason,
        area_px=d.area_px,
        eccentricity=d.eccentricity,
        turned_down_px=tuple(_extent(b) for b in d.rejected_blobs),
    )


def _extent(blob: RejectedBlob) -> tuple[float, float, float]:
    """A turned-down blob's centroid and radius (its outline's farthest point, pixels)."""
    u, v = blob.centroid_px
    if blob.outline_px is None or not len(blob.outline_px):
        return float(u), float(v), 0.0
    radius = float(np.linalg.norm(np.asarray(blob.outline_px) - (u, v), axis=1).max())
    return float(u), float(v), radius


def board_feedback(k: int, image: Any, board: BoardPlacement) -> FrameFeedback:
    """Frame ``k``'s board: its inner corners found (all of them, or none: OpenCV finds a
    board whole) and the share of the image their bounding box covers.

    Found as ``twopose-analyze rig`` finds it (:func:`twopose.detect.checkerboard.find_board_live`:
    the
    rig's full search, bounded in time, behind OpenCV's fast check)."""
    from twopose.detect.checkerboard import LIVE_BOARD_BUDGET_S, find_board_live

    cols, rows = board.inner_corners
    search = find_board_live(image, (cols, rows))
    corners = search.corners
    if corners is None:
        reason = f"the {cols}x{rows} board was not found whole (is all of it in view?)"
        if search.timed_out:
            reason = (
                f"the {cols}x{rows} board was not found within {LIVE_BOARD_BUDGET_S:g} s "
                "(is all of it in view?)"
            )
        return FrameFeedback(
            index=k, found=False, centroid_px=(math.nan, math.nan), theta_deg=math.nan,
            n_blobs=0, reason=reason, is_board=True,
        )  # fmt: skip
    px = corners.reshape(-1, 2).astype(np.float64)
    span = np.ptp(px, axis=0)
    height, width = image.shape[:2]
    centre = px.mean(axis=0)
    return FrameFeedback(
        index=k, found=True, centroid_px=(float(centre[0]), float(centre[1])),
        theta_deg=math.nan, n_blobs=1, reason="", is_board=True, board_corners=len(px),
        board_coverage=float(span[0] * span[1] / (width * height)),
    )  # fmt: skip


def _show_live(
    live: LiveSink,
    writer: SessionWriter,
    cap: Capture,
    entry: PoseEntry,
    data: bytes,
    frame: tuple[int, int],
    d: Detection | None,
) -> None:
    """The frame, its detection overlay and the status line to the live view."""
    k, n_frames = frame
    where = f"trial {entry.trial} pose {entry.pose} frame {k + 1}/{n_frames}"
    t = cap.end_ns or 0
    live.frame(entry.camera_id, data, writer.image_format, t, d, where)
    live.status(
        t,
        trial=entry.trial,
        pose=entry.pose,
        frame=k + 1,
        n_frames=n_frames,
        found=None if d is None else d.found,
        message=where + ("" if d is None else ": " + (d.reason or "found")),
    )
