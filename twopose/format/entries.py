"""The typed entries of a session, and their JSON bytes checked against the schema both ways.

Each entry is a frozen dataclass, each field declared once (:mod:`twopose.format.declared`:
the JSON Schema written into every file, the encoding and the decoding all come from that
one declaration). The one-camera procedure's entries are here; a two-camera session's
(format 1.6) are in :mod:`twopose.format.stream_entries`, the simulator's truth in
:mod:`twopose.format.simulation`, the session's own with its guidance in
:mod:`twopose.format.session_entry`; :data:`TYPED_ENTRIES` registers them all. The
file's metadata record (:func:`session_metadata`, a copy of what opens the session, and its
cameras read back, :func:`cameras_from_metadata`) is encoded here by the same entries.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from twopose import __version__
from twopose.camera.model import Camera, Intrinsics, rotation_from_angles_deg
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.declared import (
    CAMERA_SCHEMA,
    INDEX_SCHEMA,
    TypedEntry,
    entry,
    json_field,
    vec3_schema,
)
from twopose.format.session_entry import FORMAT_MAJOR, FORMAT_VERSION, GuidanceRecord, SessionInfo
from twopose.format.simulation import SimTrajectory, SimulationTruth, TruePose
from twopose.format.stream_entries import (
    CLOCK_SOURCES,
    STREAM_ENTRIES,
    ClockOffsetEntry,
    PairEntry,
    StreamWindow,
    Touch,
)
from twopose.methods.specs import LINE_TRUTH, METHODS, TRUTH_POINTS, Method, TruthKind
from twopose.values.checks import Vec3, camera_id, finite, index, vec3
from twopose.values.units import UNIT_SPECS, UNITS, Units, unit_factor

__all__ = [
    "CLOCK_SOURCES",
    "DEFAULT_ROTATION_RESOLUTION_DEG",
    "DEFAULT_TRANSLATION_RESOLUTION",
    "ENTRIES_1_0",
    "FORMAT_MAJOR",
    "FORMAT_VERSION",
    "INCHES_PER_UNIT",
    "METADATA_NAME",
    "METHODS",
    "PAIR_SESSION_ENTRIES",
    "TYPED_ENTRIES",
    "UNITS",
    "CaptureDecision",
    "CaptureWindow",
    "ClockOffsetEntry",
    "GroundPlane",
    "GroundTruth",
    "GuidanceRecord",
    "Method",
    "Note",
    "PairEntry",
    "PlaneEntry",
    "PoseEntry",
    "SessionInfo",
    "SimTrajectory",
    "SimulationTruth",
    "StreamWindow",
    "Touch",
    "TruePose",
    "TruthKind",
    "TypedEntry",
    "Verdict",
    "cameras_from_metadata",
    "decode_entry",
    "default_translation_resolution",
    "encode_entry",
    "session_metadata",
]


#: Inches in one session unit (the thesis reports in inches): twopose.values.units' registry.
INCHES_PER_UNIT = {str(u): spec.inches for u, spec in UNIT_SPECS.items()}
CaptureStatus = Literal["complete", "incomplete"]
Verdict = Literal["accept", "discard"]


_vec3_schema = vec3_schema
_INDEX_SCHEMA = INDEX_SCHEMA
_CAPTURE_SCHEMA = {
    "type": "integer",
    "minimum": 1,
    "description": "the capture's number, unique in the session (format 1.1)",
}
_CAMERA_SCHEMA = CAMERA_SCHEMA
_POINTS_SCHEMA = {"enum": list(TRUTH_POINTS)}

# --------------------------------------------------------------------------- the entries


def _capture_number(value: int | None) -> None:
    if value is not None and (index(value, "capture") < 1):
        raise InputValueError(f"capture numbers start at 1, got {value}")


#: What a typed pose's components are good to when nothing else is said (1-sigma): the
#: thesis' operator read the grid paper to 1/16 in and turned the laptop to 0.5 degree.
#: The translation's is in inches: a recording in other units takes it converted
#: (:func:`default_translation_resolution`; 1/16 mm in a mm session would make every
#: region too small). A pose entry without its resolution (none is written so) reads it
#: as given here, in the session's units.
DEFAULT_TRANSLATION_RESOLUTION = 0.0625
DEFAULT_ROTATION_RESOLUTION_DEG = 0.5


def default_translation_resolution(units: Units) -> float:
    """The typed translation's 1-sigma when nothing else is said: 1/16 in, in ``units``."""
    return DEFAULT_TRANSLATION_RESOLUTION * unit_factor(Units.IN, units)


@entry(
    "/twopose/pose",
    "PoseEntry",
    "A typed camera pose: camera centre in the grid frame and R = Rx Ry Rz (camera -> grid).",
)
@dataclass(frozen=True, kw_only=True)
class PoseEntry(TypedEntry):
    """A typed pose: camera centre ``t_grid`` (session units) and angles ``r_deg`` (degrees).

    ``R_cam_to_grid = Rx(rx) Ry(ry) Rz(rz)``; ``p_grid = R_cam_to_grid p_cam + t_grid``.
    The resolutions are the 1-sigma uncertainty of each typed component (what the operator
    can place and measure to with tape and protractor); they are the pose part of every
    estimate's uncertainty.
    """

    trial: int = json_field("trial", _INDEX_SCHEMA)
    pose: int = json_field("pose", _INDEX_SCHEMA)
    camera_id: str = json_field("camera", _CAMERA_SCHEMA)
    t_grid: Vec3 = json_field(
        "translation", _vec3_schema("camera centre in the grid frame, session units")
    )
    r_deg: Vec3 = json_field(
        "rotation_deg",
        _vec3_schema("(rx, ry, rz) in degrees, R = Rx(rx) Ry(ry) Rz(rz)"),
        default=(0.0, 0.0, 0.0),
    )
    translation_resolution: float = json_field(
        "resolution.translation",
        {"type": "number", "exclusiveMinimum": 0},
        default=DEFAULT_TRANSLATION_RESOLUTION,
    )
    rotation_resolution_deg: float = json_field(
        "resolution.rotation_deg",
        {"type": "number", "exclusiveMinimum": 0},
        default=DEFAULT_ROTATION_RESOLUTION_DEG,
    )
    capture: int | None = json_field("capture", _CAPTURE_SCHEMA, required=False, default=None)

    def __post_init__(self) -> None:
        """Check the trial, pose, capture and camera, and the pose's six numbers."""
        index(self.trial, "trial")
        index(self.pose, "pose")
        _capture_number(self.capture)
        camera_id(self.camera_id)
        object.__setattr__(self, "t_grid", vec3(self.t_grid, "translation"))
        object.__setattr__(self, "r_deg", vec3(self.r_deg, "rotation"))
        finite(self.translation_resolution, "translation resolution", positive=True)
        finite(self.rotation_resolution_deg, "rotation resolution", positive=True)

    @property
    def R_cam_to_grid(self) -> NDArray[np.float64]:
        """The typed rotation, camera to grid (``Rx Ry Rz`` of ``r_deg``)."""
        return rotation_from_angles_deg(self.r_deg)


@entry(
    "/twopose/capture",
    "CaptureWindow",
    "The frames of one capture: the camera's images with start_ns <= log_time <= end_ns.",
)
@dataclass(frozen=True, kw_only=True)
class CaptureWindow(TypedEntry):
    """Which frames belong to which trial and pose.

    The frames of a capture are the messages on the camera's image topic with
    ``start_ns <= log_time <= end_ns``; written after the last frame of the capture.
    """

    trial: int = json_field("trial", _INDEX_SCHEMA)
    pose: int = json_field("pose", _INDEX_SCHEMA)
    camera_id: str = json_field("camera", _CAMERA_SCHEMA)
    start_ns: int = json_field("start_ns", _INDEX_SCHEMA)
    end_ns: int = json_field("end_ns", _INDEX_SCHEMA)
    n_frames: int = json_field("n_frames", _INDEX_SCHEMA)
    status: CaptureStatus = json_field(
        "status", {"enum": ["complete", "incomplete"]}, default="complete"
    )
    reason: str = json_field("reason", {"type": "string"}, required=False, default="")
    dropped_frames: int = json_field("dropped_frames", _INDEX_SCHEMA, required=False, default=0)
    capture: int | None = json_field("capture", _CAPTURE_SCHEMA, required=False, default=None)

    def __post_init__(self) -> None:
        """Check the window's indices, times, capture and camera."""
        for name in ("trial", "pose", "start_ns", "end_ns", "n_frames", "dropped_frames"):
            index(getattr(self, name), name)
        _capture_number(self.capture)
        camera_id(self.camera_id)
        if self.end_ns < self.start_ns:
            raise InputValueError(
                f"capture ends ({self.end_ns}) before it starts ({self.start_ns})"
            )
        if self.status not in ("complete", "incomplete"):
            raise InputValueError(
                f"capture status must be complete or incomplete, got {self.status!r}"
            )


@entry(
    "/twopose/decision",
    "CaptureDecision",
    "The operator's decision on one capture: accept it, or discard it (kept, never analysed).",
)
@dataclass(frozen=True, kw_only=True)
class CaptureDecision(TypedEntry):
    """What the operator decided about capture ``capture`` (format 1.1).

    A capture is measured only if the last decision naming it is ``accept``. ``discard``
    keeps its frames in the file but out of the analysis; ``reason`` says why (``redo``,
    ``undo``, ``undone``, ``quit``, ``interrupted``, ``source failure``).
    """

    capture: int = json_field("capture", _CAPTURE_SCHEMA)
    trial: int = json_field("trial", _INDEX_SCHEMA)
    pose: int = json_field("pose", _INDEX_SCHEMA)
    camera_id: str = json_field("camera", _CAMERA_SCHEMA)
    decision: Verdict = json_field("decision", {"enum": ["accept", "discard"]})
    reason: str = json_field("reason", {"type": "string"}, required=False, default="")

    def __post_init__(self) -> None:
        """Check the capture, trial, pose and camera."""
        _capture_number(self.capture)
        index(self.trial, "trial")
        index(self.pose, "pose")
        camera_id(self.camera_id)
        if self.decision not in ("accept", "discard"):
            raise InputValueError(f"decision must be accept or discard, got {self.decision!r}")

    @property
    def accepted(self) -> bool:
        """Whether the operator accepted the capture."""
        return self.decision == "accept"


@entry(
    "/twopose/ground",
    "GroundPlane",  # the schema's name in the files, kept
    "The ground plane normal . p = offset in the grid frame (session units).",
)
@dataclass(frozen=True, kw_only=True)
class PlaneEntry(TypedEntry):
    """The method's constraint plane ``normal_grid . p = offset`` in the grid frame.

    As a session stores it (:class:`twopose.methods.planes.ConstraintPlane`, its offset typed).
    The thesis' ground: normal (0, 1, 0), offset h = 9.625 in (camera centre down to the
    table); a wall ``x = c``: normal (1, 0, 0), offset c. The file's topic and JSON keys
    keep the ground's names (``ground``, ``normal``, ``offset``). Its old name,
    ``GroundPlane``, is kept for one release (an alias).
    """

    normal_grid: Vec3 = json_field(
        "normal", _vec3_schema("unit normal in the grid frame"), default=(0.0, 1.0, 0.0)
    )
    offset: float = json_field("offset", {"type": "number"})

    def __post_init__(self) -> None:
        """Check the normal (non-zero, normalised) and the offset."""
        n = np.array(vec3(self.normal_grid, "ground normal"))
        norm = float(np.linalg.norm(n))
        if norm < 1e-9:
            raise InputValueError("ground normal must not be zero")
        object.__setattr__(self, "normal_grid", vec3(n / norm, "ground normal"))
        object.__setattr__(self, "offset", finite(self.offset, "ground height") / norm)

    def spec(self) -> tuple[np.ndarray, float]:
        """The plane as the solvers take it (:data:`twopose.solve.estimate.GroundSpec`)."""
        return np.array(self.normal_grid, dtype=np.float64), self.offset


#: :class:`PlaneEntry`'s old name, kept for one release (it is any method's plane).
GroundPlane = PlaneEntry


@entry(
    "/twopose/ground_truth",
    "GroundTruth",
    "Ground truth of one trial: a grid point (point, ground) or two points on the line (line).",
)
@dataclass(frozen=True, kw_only=True)
class GroundTruth(TypedEntry):
    """Measured truth of one trial in the grid frame: a point, or two points on the line."""

    trial: int = json_field("trial", _INDEX_SCHEMA)
    kind: TruthKind = json_field("kind", _POINTS_SCHEMA)
    points_grid: tuple[Vec3, ...] = json_field(
        "points",
        {
            "type": "array",
            "items": _vec3_schema("a point in the grid frame"),
            "minItems": 1,
            "maxItems": 2,
        },
        decode=tuple,
    )

    def __post_init__(self) -> None:
        """Check the trial, the kind and its number of points."""
        index(self.trial, "trial")
        want = TRUTH_POINTS.get(self.kind)
        if want is None:
            raise InputValueError(f"ground truth kind must be point or line, got {self.kind!r}")
        pts = tuple(vec3(p, "ground-truth point") for p in self.points_grid)
        if len(pts) != want:
            raise InputValueError(f"{self.kind} ground truth needs {want} point(s), got {len(pts)}")
        if self.kind == LINE_TRUTH and np.allclose(pts[0], pts[1]):
            raise InputValueError("the two ground-truth points of a line must differ")
        object.__setattr__(self, "points_grid", pts)


@entry("/twopose/note", "Note", "A free-text operator note.")
@dataclass(frozen=True, kw_only=True)
class Note(TypedEntry):
    """A free-text note by the operator, optionally about one trial."""

    text: str = json_field("text", {"type": "string"})
    trial: int | None = json_field(
        "trial", {"type": ["integer", "null"], "minimum": 0}, required=False, default=None
    )

    def __post_init__(self) -> None:
        """Check the trial the note is about, if any."""
        if self.trial is not None:
            index(self.trial, "trial")


#: The format 1.0 entries, in the order a session registers their channels.
ENTRIES_1_0: tuple[type[TypedEntry], ...] = (
    SessionInfo,
    PoseEntry,
    CaptureWindow,
    PlaneEntry,
    GroundTruth,
    Note,
    SimulationTruth,
)
#: Format 1.6's, a two-camera session's only, registered after the 1.1 decision's.
PAIR_SESSION_ENTRIES: tuple[type[TypedEntry], ...] = (*STREAM_ENTRIES, SimTrajectory)
TYPED_ENTRIES: tuple[type[TypedEntry], ...] = (
    *ENTRIES_1_0,
    CaptureDecision,  # format 1.1; registered after the 1.0 channels (see channels.py)
    *PAIR_SESSION_ENTRIES,
)

# --------------------------------------------------------------------------- JSON bytes

_BY_SCHEMA: dict[str, type[TypedEntry]] = {cls.SCHEMA_NAME: cls for cls in TYPED_ENTRIES}
_VALIDATORS: dict[str, Any] = {}


def _validator(schema_name: str) -> Any:
    """The compiled JSON Schema validator, built on first use (jsonschema is slow to load)."""
    if schema_name not in _VALIDATORS:
        from jsonschema import Draft202012Validator

        _VALIDATORS[schema_name] = Draft202012Validator(_BY_SCHEMA[schema_name].JSON_SCHEMA)
    return _VALIDATORS[schema_name]


def _validate(schema_name: str, data: Any) -> None:
    err = next(_validator(schema_name).iter_errors(data), None)
    if err is not None:
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        raise SessionFormatError(f"{schema_name} at {where}: {err.message}")


def encode_entry(entry: TypedEntry) -> bytes:
    """JSON bytes of a typed entry, checked against its schema."""
    data = entry.to_json()
    _validate(entry.SCHEMA_NAME, data)
    try:
        return json.dumps(data, allow_nan=False, separators=(",", ":")).encode()
    except ValueError as err:
        raise InputValueError(f"{entry.SCHEMA_NAME}: {err}") from err


def decode_entry(schema_name: str, payload: bytes) -> TypedEntry:
    """Parse, validate and build the typed entry of a JSON message."""
    cls = _BY_SCHEMA.get(schema_name)
    if cls is None:
        raise SessionFormatError(f"unknown typed entry schema {schema_name!r}")
    try:
        data = json.loads(payload)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise SessionFormatError(f"{schema_name} message is not valid JSON: {err}") from err
    _validate(schema_name, data)
    try:
        return cls.from_json(data)
    except InputValueError as err:
        raise SessionFormatError(f"{schema_name} message has an invalid value: {err}") from err


#: The MCAP metadata record's name: a copy of what opens the session, both ways.
METADATA_NAME = "twopose"


def session_metadata(
    info: SessionInfo,
    cameras: Sequence[Camera],
    ground: PlaneEntry | None,
    start_ns: int,
    pair: PairEntry | None = None,
) -> dict[str, str]:
    """The ``twopose`` metadata record: versions, plus a copy of what opens the session.

    The metadata record is written before the first chunk, so the copy survives the loss
    of that chunk (which holds the schemas, channels and the session entry); a two-camera
    session's copy holds its pair too (format 1.6).
    """
    record = {
        "format_version": FORMAT_VERSION,
        "software_version": __version__,
        "session": encode_entry(info).decode(),
        "cameras": json.dumps([{"camera": c.camera_id, **c.intrinsics.to_dict()} for c in cameras]),
        "ground": encode_entry(ground).decode() if ground is not None else "",
        "start_ns": str(start_ns),
    }
    if pair is not None:
        record["pair"] = encode_entry(pair).decode()
    return record


def cameras_from_metadata(text: str) -> list[Camera]:
    """Inverse of the ``cameras`` field of :func:`session_metadata`."""
    try:
        return [
            Camera(
                camera_id=c["camera"],
                intrinsics=Intrinsics.from_dict(c, "the metadata's camera copy"),
            )
            for c in json.loads(text)
        ]
    except (KeyError, TypeError, ValueError, InputValueError) as err:
        raise SessionFormatError(f"the metadata's camera copy is unreadable: {err}") from err
