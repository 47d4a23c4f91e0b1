"""The laptop-on-grid procedure (thesis sections 3.4.2 and 5.2.5) as code: type a pose,
capture K frames with live detection feedback, next pose, next trial.

:func:`capture_pose` is the one step both the interactive ``twopose-record new`` and plan
mode use; :func:`load_plan` reads a plan file and :func:`record_plan` runs it unattended.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from recorder.camera import Intrinsics
from recorder.errors import InputValueError
from recorder.scene import read_toml
from recorder.session import (
    METHODS,
    UNITS,
    Camera,
    GroundPlane,
    GroundTruth,
    Method,
    Note,
    PoseEntry,
    SessionInfo,
    SessionWriter,
    TruthKind,
    Vec3,
)
from recorder.sources import FrameSource, SourceError

if TYPE_CHECKING:
    from recorder.live import LiveView

__all__ = [
    "CaptureResult",
    "FrameFeedback",
    "Plan",
    "PlannedPose",
    "PlannedTrial",
    "capture_pose",
    "load_plan",
    "parse_vector",
    "record_interactive",
    "record_plan",
]

#: Plausible magnitude of a typed translation (session units); beyond it, a typo is likelier.
MAX_TRANSLATION = {"in": 200.0, "mm": 5000.0, "cm": 500.0, "m": 5.0}


@dataclass(frozen=True)
class FrameFeedback:
    """What the operator sees for each captured frame."""

    index: int
    found: bool
    centroid_px: tuple[float, float]
    theta_deg: float
    n_blobs: int
    reason: str

    def line(self) -> str:
        if not self.found:
            return f"  frame {self.index + 1}: not found ({self.reason})"
        col, row = self.centroid_px
        theta = "" if math.isnan(self.theta_deg) else f", theta {self.theta_deg:+.1f} deg"
        where = f"({col:.1f}, {row:.1f})"
        return f"  frame {self.index + 1}: found at {where}{theta}, {self.n_blobs} blob(s)"


@dataclass(frozen=True)
class CaptureResult:
    """How a capture went."""

    n_frames: int
    complete: bool
    reason: str
    feedback: tuple[FrameFeedback, ...] = ()
    dropped: int = 0
    overhead_s: tuple[float, ...] = ()  # per frame: encode + write + detection

    @property
    def n_found(self) -> int:
        return sum(f.found for f in self.feedback)


def capture_pose(
    writer: SessionWriter,
    source: FrameSource,
    entry: PoseEntry,
    n_frames: int,
    *,
    target: str | None = None,
    on_frame: Callable[[FrameFeedback], None] | None = None,
    timeout_s: float = 2.0,
    live: LiveView | None = None,
) -> CaptureResult:
    """Write the typed pose, then capture ``n_frames`` frames from ``source`` at it.

    ``target`` (``"glove"`` or ``"dot"``) turns on live detection feedback. A source that
    fails mid-capture leaves the capture in the file, marked incomplete with the reason.
    With ``live``, every frame, its detection overlay and the status go to the live view.
    """
    writer.write_pose(entry)
    source.set_pose(entry.t_grid, entry.r_deg)
    from analysis.detect import detect

    feedback: list[FrameFeedback] = []
    overhead: list[float] = []
    reason = ""
    count = 0
    dropped_before = source.dropped
    with writer.capture(entry.trial, entry.pose, entry.camera_id) as cap:
        for k in range(n_frames):
            try:
                image = source.read(timeout_s)
            except SourceError as err:
                reason = str(err)
                cap.mark_incomplete(reason)
                break
            started = time.perf_counter()
            data = writer.encode_image(image)
            cap.add_encoded(data)
            count += 1
            d = None
            if target is not None:
                d = detect(image, target)
                fb = FrameFeedback(k, d.found, d.centroid_px, d.theta_deg, d.n_blobs, d.reason)
                feedback.append(fb)
            if live is not None:
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
            overhead.append(time.perf_counter() - started)
            if target is not None and on_frame is not None:
                on_frame(fb)
            cap.dropped_frames = source.dropped - dropped_before
    return CaptureResult(
        count, not reason, reason, tuple(feedback), source.dropped - dropped_before, tuple(overhead)
    )


# --------------------------------------------------------------------------- plans


@dataclass(frozen=True)
class PlannedPose:
    t_grid: Vec3
    r_deg: Vec3 = (0.0, 0.0, 0.0)
    camera_id: str = "cam0"


@dataclass(frozen=True)
class PlannedTrial:
    poses: tuple[PlannedPose, ...]
    ground_truth: tuple[Vec3, ...] = ()


@dataclass(frozen=True)
class Plan:
    """A whole session to record unattended (scripted rigs, tests)."""

    method: Method
    units: str
    cameras: tuple[Camera, ...]
    trials: tuple[PlannedTrial, ...]
    frames: int = 5
    ground_height: float | None = None
    operator: str = ""
    notes: str = ""
    translation_resolution: float = 0.0625
    rotation_resolution_deg: float = 0.5


def _vec(value: Any, where: str) -> Vec3:
    if not isinstance(value, list) or len(value) != 3:
        raise InputValueError(f"plan: {where} must be a list of 3 numbers, got {value!r}")
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise InputValueError(f"plan: {where} must hold finite numbers, got {value!r}")
        out.append(float(v))
    return (out[0], out[1], out[2])


def _number(table: dict[str, Any], key: str, default: float) -> float:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputValueError(f"plan: camera.{key} must be a finite number, got {value!r}")
    return float(value)


def _camera(table: Any) -> Camera:
    """``[camera]``: ``focal`` (or ``fx``/``fy``), ``principal = [cx, cy]`` (or ``cx``/``cy``),
    ``width``, ``height``, ``distortion``, ``id``."""
    if not isinstance(table, dict):
        raise InputValueError("plan: [camera] must be a table")
    if "calibration" in table:  # a file from `twopose-record calibrate`
        from recorder.calibrate import load_calibration

        return Camera(str(table.get("id", "cam0")), load_calibration(str(table["calibration"])))
    fx = _number(table, "fx", _number(table, "focal", 525.0))
    fy = _number(table, "fy", _number(table, "focal", fx))
    principal = table.get("principal")
    if principal is not None:
        if not isinstance(principal, list) or len(principal) != 2:
            raise InputValueError(f"plan: camera.principal must be [cx, cy], got {principal!r}")
        table = {**table, "cx": principal[0], "cy": principal[1]}
    dist = [_number({"d": d}, "d", 0.0) for d in table.get("distortion", [0.0] * 5)]
    if len(dist) != 5:
        raise InputValueError("plan: camera.distortion needs 5 values (k1, k2, p1, p2, k3)")
    return Camera(
        str(table.get("id", "cam0")),
        Intrinsics(
            int(_number(table, "width", 640)),
            int(_number(table, "height", 480)),
            fx,
            fy,
            _number(table, "cx", 320.0),
            _number(table, "cy", 240.0),
            (dist[0], dist[1], dist[2], dist[3], dist[4]),
        ),
    )


def load_plan(path: str | Path) -> Plan:
    """Read and check a plan file (TOML); every error names the offending key."""
    data = read_toml(path, "plan", InputValueError)
    method = data.get("method")
    if method not in METHODS:
        raise InputValueError(f"plan: method must be one of {', '.join(METHODS)}, got {method!r}")
    units = data.get("units", "in")
    if units not in UNITS:
        raise InputValueError(f"plan: units must be one of {', '.join(UNITS)}, got {units!r}")
    cameras_data = data.get("cameras") or [data.get("camera", {})]
    cameras = tuple(_camera(c) for c in cameras_data)
    frames = data.get("frames", 5)
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise InputValueError(f"plan: frames must be a whole number >= 1, got {frames!r}")
    ground = data.get("ground_height")
    if method == "ground" and ground is None:
        raise InputValueError("plan: a ground session needs ground_height (camera centre to table)")
    trials = []
    limit = MAX_TRANSLATION[units]
    for i, t in enumerate(data.get("trials", []), start=1):
        poses = []
        for j, p in enumerate(t.get("poses", []), start=1):
            where = f"trials[{i}].poses[{j}]"
            tg = _vec(p.get("t"), f"{where}.t")
            if max(abs(v) for v in tg) > limit:
                raise InputValueError(f"plan: {where}.t = {tg} is implausibly large for {units}")
            poses.append(
                PlannedPose(
                    tg,
                    _vec(p.get("r_deg", [0, 0, 0]), f"{where}.r_deg"),
                    str(p.get("camera", cameras[0].camera_id)),
                )
            )
        if len(poses) < 2:
            raise InputValueError(f"plan: trials[{i}] needs at least 2 poses, got {len(poses)}")
        gt = tuple(_vec(g, f"trials[{i}].ground_truth") for g in t.get("ground_truth", []))
        trials.append(PlannedTrial(tuple(poses), gt))
    if not trials:
        raise InputValueError("plan: no [[trials]]")
    res = data.get("resolution", {})
    return Plan(
        method=method,
        units=units,
        cameras=cameras,
        trials=tuple(trials),
        frames=frames,
        ground_height=float(ground) if ground is not None else None,
        operator=str(data.get("operator", "")),
        notes=str(data.get("notes", "")),
        translation_resolution=float(res.get("translation", 0.0625)),
        rotation_resolution_deg=float(res.get("rotation_deg", 0.5)),
    )


@dataclass(frozen=True)
class RecordingSummary:
    path: Path
    n_trials: int
    n_captures: int
    n_incomplete: int
    n_frames: int
    n_found: int
    seconds: float
    dropped: int = 0


def record_plan(
    plan: Plan,
    out: str | Path,
    source: FrameSource,
    *,
    on_frame: Callable[[FrameFeedback], None] | None = None,
    on_capture: Callable[[int, int, CaptureResult], None] | None = None,
    live: LiveView | None = None,
) -> RecordingSummary:
    """Record ``plan`` into the new session ``out`` from an (unopened) ``source``.

    A capture that fails is kept (incomplete) and the recording stops there with a
    :class:`SourceError`; everything written before it is in the file, which is closed.
    """
    target = "dot" if plan.method == "point" else "glove"
    info = SessionInfo(
        method=plan.method,
        units=plan.units,
        camera_ids=tuple(c.camera_id for c in plan.cameras),
        operator=plan.operator,
        notes=plan.notes,
        created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    )
    ground = GroundPlane(plan.ground_height) if plan.ground_height is not None else None
    captures = incomplete = frames = found = dropped = 0
    start = time.monotonic()
    with source, SessionWriter(out, info, plan.cameras, ground=ground) as writer:
        for i, trial in enumerate(plan.trials, start=1):
            if trial.ground_truth:
                kind: TruthKind = "line" if plan.method == "line" else "point"
                writer.write_ground_truth(GroundTruth(i, kind, trial.ground_truth))
            for k, p in enumerate(trial.poses, start=1):
                entry = PoseEntry(
                    i,
                    k,
                    p.camera_id,
                    p.t_grid,
                    p.r_deg,
                    plan.translation_resolution,
                    plan.rotation_resolution_deg,
                )
                result = capture_pose(
                    writer,
                    source,
                    entry,
                    plan.frames,
                    target=target,
                    on_frame=on_frame,
                    live=live,
                )
                captures += 1
                frames += result.n_frames
                found += result.n_found
                dropped += result.dropped
                if on_capture is not None:
                    on_capture(i, k, result)
                if not result.complete:
                    incomplete += 1
                    raise SourceError(
                        f"trial {i} pose {k}: {result.reason}; the session so far is saved in {out}"
                    )
    return RecordingSummary(
        Path(out),
        len(plan.trials),
        captures,
        incomplete,
        frames,
        found,
        time.monotonic() - start,
        dropped,
    )


# --------------------------------------------------------------------------- interactive


def parse_vector(
    text: str, units: str, *, what: str = "translation", limit: float | None = None
) -> Vec3:
    """Three numbers typed as ``x, y, z`` (commas or spaces); raises InputValueError."""
    parts = text.replace(",", " ").split()
    if len(parts) != 3:
        raise InputValueError(f"{what}: type three numbers, e.g. 1.1, 0, 0 (got {text!r})")
    try:
        v = tuple(float(p) for p in parts)
    except ValueError as err:
        raise InputValueError(f"{what}: {text!r} is not three numbers") from err
    if not all(math.isfinite(x) for x in v):
        raise InputValueError(f"{what}: values must be finite (got {text!r})")
    bound = MAX_TRANSLATION[units] if limit is None else limit
    if max(abs(x) for x in v) > bound:
        raise InputValueError(
            f"{what}: {text!r} is implausibly large (over {bound:g} {units}); a typo?"
        )
    return (v[0], v[1], v[2])


class Operator:
    """How the procedure talks to the operator: ``ask`` a question, ``say`` a line."""

    def __init__(self, ask: Callable[[str, str], str], say: Callable[[str], None]) -> None:
        self.ask_raw, self.say = ask, say

    def ask(self, question: str, parse: Callable[[str], Any], default: str = "") -> Any:
        """Ask until the answer parses; say why an answer was refused."""
        while True:
            answer = self.ask_raw(question, default).strip()
            try:
                return parse(answer)
            except InputValueError as err:
                self.say(f"  not accepted: {err}")


@dataclass
class _Tally:
    captures: int = 0
    incomplete: int = 0
    frames: int = 0
    found: int = 0
    dropped: int = 0
    trials: set[int] = field(default_factory=set)


def record_interactive(
    out: str | Path,
    source: FrameSource,
    operator: Operator,
    *,
    info: SessionInfo,
    camera: Camera,
    ground: GroundPlane | None,
    ground_truth: tuple[Vec3, ...],
    frames: int = 5,
    poses_per_trial: int = 2,
    translation_resolution: float = 0.0625,
    rotation_resolution_deg: float = 0.5,
    live: LiveView | None = None,
) -> RecordingSummary:
    """The guided procedure: trial after trial, type each pose, capture, accept or redo.

    After each capture the operator answers ``a`` (accept), ``r`` (redo this pose), ``u``
    (undo: redo the previous pose), ``n`` (add a note) or ``q`` (finish the session). After
    each trial: another trial (``y``) or finish (``n``). Ctrl-C closes the file cleanly.
    """
    target = "dot" if info.method == "point" else "glove"
    units = info.units
    tally = _Tally()
    start = time.monotonic()
    kind: TruthKind = "line" if info.method == "line" else "point"

    def yes_no(text: str) -> bool:
        if text.lower() in ("y", "yes", ""):
            return True
        if text.lower() in ("n", "no"):
            return False
        raise InputValueError("answer y or n")

    def choice(text: str) -> str:
        c = (text or "a")[0].lower()
        if c not in "arunq":
            raise InputValueError("answer a (accept), r (redo), u (undo), n (note) or q (quit)")
        return c

    with source, SessionWriter(out, info, [camera], ground=ground) as writer:
        operator.say(
            f"recording {out} from {source.info.description} "
            f"({source.info.width}x{source.info.height} at {source.info.fps:g} fps)"
        )
        trial = 0
        finished = False
        while not finished:
            trial += 1
            tally.trials.add(trial)
            if ground_truth:
                writer.write_ground_truth(GroundTruth(trial, kind, ground_truth))
            operator.say(f"trial {trial}")
            pose = 1
            while pose <= poses_per_trial:
                t = operator.ask(
                    f"pose {pose} camera centre x, y, z ({units})", lambda s: parse_vector(s, units)
                )
                r = operator.ask(
                    "rotation rx, ry, rz (deg)",
                    lambda s: parse_vector(s, units, what="rotation", limit=180.0),
                    "0, 0, 0",
                )
                entry = PoseEntry(
                    trial,
                    pose,
                    camera.camera_id,
                    t,
                    r,
                    translation_resolution,
                    rotation_resolution_deg,
                )
                result = capture_pose(
                    writer,
                    source,
                    entry,
                    frames,
                    target=target,
                    on_frame=lambda fb: operator.say(fb.line()),
                    live=live,
                )
                tally.captures += 1
                tally.frames += result.n_frames
                tally.found += result.n_found
                tally.dropped += result.dropped
                state = "complete" if result.complete else f"INCOMPLETE ({result.reason})"
                operator.say(
                    f"pose {pose}: {result.n_frames} frames, {result.n_found} detected, {state}, "
                    f"{result.dropped} dropped"
                )
                if not result.complete:
                    tally.incomplete += 1
                while True:
                    c = operator.ask(
                        "[a]ccept, [r]edo, [u]ndo previous, [n]ote, [q]uit", choice, "a"
                    )
                    if c == "n":
                        text = operator.ask("note", str)
                        writer.write_note(Note(text, trial))
                        continue
                    break
                if c == "a":
                    pose += 1
                elif c == "u":
                    pose = max(pose - 1, 1)
                elif c == "q":
                    finished = True
                    break
            if not finished:
                finished = not operator.ask("another trial? [Y/n]", yes_no, "y")
    summary = RecordingSummary(
        Path(out),
        len(tally.trials),
        tally.captures,
        tally.incomplete,
        tally.frames,
        tally.found,
        time.monotonic() - start,
        tally.dropped,
    )
    operator.say(
        f"finished: {summary.n_trials} trial(s), {summary.n_captures} capture(s) "
        f"({summary.n_incomplete} incomplete), {summary.n_frames} frames, "
        f"{summary.n_found} detected, {summary.dropped} dropped"
    )
    return summary
