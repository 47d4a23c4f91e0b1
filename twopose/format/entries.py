"""The typed entries of a session, and their JSON bytes checked against the schema both ways.

Each entry is a frozen dataclass, each field declared once (:mod:`twopose.format.declared`:
the JSON Schema written into every file, the encoding and the decoding all come from that
one declaration). Near the 600-line limit because every entry of the format is here, so
that one page of code is the whole format; nested objects of an entry live beside it
(:mod:`twopose.format.guidance_record`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from twopose.camera import SIGMA_KEYS, intrinsics_sigma, rotation_from_angles_deg
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.declared import TypedEntry, entry, from_json, json_field, object_schema
from twopose.format.guidance_record import GuidanceRecord, guidance_schema
from twopose.methods import LINE_TRUTH, METHODS, TRUTH_POINTS, Method, TruthKind, spec_of
from twopose.targets import BoardPlacement
from twopose.units import UNIT_SPECS, UNITS, Units, unit_factor, unit_spec
from twopose.values import CAMERA_ID_PATTERN, Vec3, camera_id, finite, index, numbers, vec3

__all__ = [
    "DEFAULT_ROTATION_RESOLUTION_DEG",
    "DEFAULT_TRANSLATION_RESOLUTION",
    "FORMAT_MAJOR",
    "FORMAT_VERSION",
    "INCHES_PER_UNIT",
    "METHODS",
    "TYPED_ENTRIES",
    "UNITS",
    "CaptureDecision",
    "CaptureWindow",
    "GroundPlane",
    "GroundTruth",
    "GuidanceRecord",
    "Method",
    "Note",
    "PlaneEntry",
    "PoseEntry",
    "SessionInfo",
    "SimulationTruth",
    "TruePose",
    "TruthKind",
    "TypedEntry",
    "Verdict",
    "decode_entry",
    "default_translation_resolution",
    "encode_entry",
]

FORMAT_VERSION = "1.5"
FORMAT_MAJOR = 1

#: Inches in one session unit (the thesis reports in inches): twopose.units' registry.
INCHES_PER_UNIT = {str(u): spec.inches for u, spec in UNIT_SPECS.items()}
CaptureStatus = Literal["complete", "incomplete"]
Verdict = Literal["accept", "discard"]


def _vec3_schema(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "number"},
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


_INDEX_SCHEMA = {"type": "integer", "minimum": 0}
_CAPTURE_SCHEMA = {
    "type": "integer",
    "minimum": 1,
    "description": "the capture's number, unique in the session (format 1.1)",
}
_CAMERA_SCHEMA = {"type": "string", "pattern": CAMERA_ID_PATTERN}
_POINTS_SCHEMA = {"enum": list(TRUTH_POINTS)}

# --------------------------------------------------------------------------- the entries


def _capture_number(value: int | None) -> None:
    if value is not None and (index(value, "capture") < 1):
        raise InputValueError(f"capture numbers start at 1, got {value}")


@entry("/twopose/session", "Session", "One per file, first typed entry: what this session is.")
@dataclass(frozen=True, kw_only=True)
class SessionInfo(TypedEntry):
    """What the session is: method, units, who recorded it, which cameras."""

    format_version: str = json_field(
        "format_version", {"type": "string", "pattern": r"^\d+\.\d+$"}, default=FORMAT_VERSION
    )
    software_version: str = json_field(
        "software_version", {"type": "string"}, required=False, default=""
    )
    method: Method = json_field("method", {"enum": list(METHODS)})
    units: Units = json_field("units", {"enum": list(UNITS)})
    camera_ids: tuple[str, ...] = json_field(
        "camera_ids",
        {"type": "array", "items": _CAMERA_SCHEMA, "minItems": 1, "uniqueItems": True},
        default=("cam0",),
        decode=tuple,
    )
    operator: str = json_field("operator", {"type": "string"}, required=False, default="")
    notes: str = json_field("notes", {"type": "string"}, required=False, default="")
    created_utc: str = json_field(
        "created_utc",
        {"type": "string", "description": "ISO 8601, UTC; may be empty"},
        required=False,
        default="",
    )
    simulated: bool = json_field("simulated", {"type": "boolean"}, required=False, default=False)
    intrinsics_sigma: dict[str, dict[str, float]] | None = json_field(
        "intrinsics_sigma",
        {
            "type": "object",
            "description": "format 1.2: per camera id, the calibration's 1-sigma per intrinsic",
            "additionalProperties": {
                "type": "object",
                "propertyNames": {"enum": list(SIGMA_KEYS)},
                "additionalProperties": {"type": "number", "minimum": 0},
            },
        },
        required=False,
        default=None,
        compare=False,
    )
    board: BoardPlacement | None = json_field(
        "board",
        {
            "type": "object",
            "description": "format 1.2, board sessions: the checkerboard and where it stands",
            "properties": {
                "inner_corners": {
                    "type": "array",
                    "items": {"type": "integer", "minimum": 2},
                    "minItems": 2,
                    "maxItems": 2,
                },
                "square": {"type": "number", "exclusiveMinimum": 0},
                "first_corner": _vec3_schema("the first inner corner, grid frame"),
            },
            "required": ["inner_corners", "square", "first_corner"],
            "additionalProperties": False,
        },
        required=False,
        default=None,
        decode=BoardPlacement.from_json,
    )

    session_id: str | None = json_field(
        "session_id",
        {"type": "string", "pattern": "^[0-9a-f]{16,64}$",
         "description": "1.3: the session's identity; its continuations share it"},
        required=False,
        default=None,
    )  # fmt: skip
    continues_after_trial: int | None = json_field(
        "continues.after_trial",
        {"type": "integer", "minimum": 0,
         "description": "1.3, a continuation: the last trial of the part it continues"},
        required=False,
        default=None,
    )  # fmt: skip
    continues_file: str | None = json_field(
        "continues.file",
        {"type": "string", "description": "1.3, a continuation: the file it continues"},
        required=False,
        default=None,
    )
    continues_sha256: str | None = json_field(
        "continues.sha256",
        {"type": "string", "pattern": "^[0-9a-f]{64}$",
         "description": "1.3, a continuation: the SHA-256 of the file it continues"},
        required=False,
        default=None,
    )  # fmt: skip

    part_id: str | None = json_field(
        "part_id",
        {"type": "string", "pattern": "^[0-9a-f]{16,64}$",
         "description": "1.4: this file's part of the session; a recovered copy keeps it"},
        required=False,
        default=None,
    )  # fmt: skip
    continues_part: str | None = json_field(
        "continues.part",
        {"type": "string", "pattern": "^[0-9a-f]{16,64}$",
         "description": "1.4, a continuation: the part_id of the part it continues"},
        required=False,
        default=None,
    )  # fmt: skip
    continues_branch: str | None = json_field(
        "continues.branch",
        {"type": "string", "pattern": "^[A-Z]{0,8}$",
         "description": "1.4, a continuation: its branch (empty: the part's only "
         "continuation when recorded; B, C, ...: another file already continued that part)"},
        required=False,
        default=None,
    )  # fmt: skip
    guidance: GuidanceRecord | None = json_field(
        "guidance", {**guidance_schema(), "description": "1.5: the guidance recorded with"},
        required=False, default=None, decode=GuidanceRecord.from_json,
    )  # fmt: skip

    @property
    def is_continuation(self) -> bool:
        """Whether the session continues an earlier file (``new --continue``)."""
        return self.continues_after_trial is not None

    def __post_init__(self) -> None:
        """Hold the method and units as their types; check the cameras and the version."""
        # The registries' types (equal to, and serialised as, the names in the file).
        object.__setattr__(self, "method", spec_of(self.method).method)
        object.__setattr__(self, "units", unit_spec(self.units).units)
        if not self.camera_ids:
            raise InputValueError("a session needs at least one camera")
        for cid in self.camera_ids:
            camera_id(cid)
        if len(set(self.camera_ids)) != len(self.camera_ids):
            raise InputValueError(f"camera ids must be unique, got {self.camera_ids}")
        if (self.board is not None) == spec_of(self.method).measures:
            raise InputValueError(
                "a board session needs its board (inner corners, square, first corner), and "
                "only a board session has one"
            )
        if self.intrinsics_sigma is not None:
            unknown = sorted(set(self.intrinsics_sigma) - set(self.camera_ids))
            if unknown:
                raise InputValueError(f"intrinsics_sigma names unknown camera(s) {unknown}")
            sigma = {c: intrinsics_sigma(s) for c, s in self.intrinsics_sigma.items()}
            object.__setattr__(self, "intrinsics_sigma", sigma)


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

    As a session stores it (:class:`twopose.planes.ConstraintPlane`, its offset typed).
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
        """The plane as the solvers take it (:data:`twopose.estimate.GroundSpec`)."""
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


@dataclass(frozen=True, kw_only=True)
class TruePose:
    """The pose the simulated camera really had (the typed one carries the typing error)."""

    pose: int = json_field("pose", _INDEX_SCHEMA)
    camera_id: str = json_field("camera", {"type": "string"})
    t_grid: Vec3 = json_field("translation", _vec3_schema("true camera centre, grid frame"))
    r_deg: Vec3 = json_field("rotation_deg", _vec3_schema("true (rx, ry, rz), degrees"))

    def __post_init__(self) -> None:
        """Check the true pose's six numbers."""
        object.__setattr__(self, "t_grid", vec3(self.t_grid, "true translation"))
        object.__setattr__(self, "r_deg", vec3(self.r_deg, "true rotation"))


@entry(
    "/simulation/truth",
    "SimulationTruth",
    "Simulated sessions only: the true poses (frames were rendered from these) and target.",
)
@dataclass(frozen=True, kw_only=True)
class SimulationTruth(TypedEntry):
    """What a simulated trial really was: true poses and the true point or line."""

    trial: int = json_field("trial", _INDEX_SCHEMA)
    poses: tuple[TruePose, ...] = json_field(
        "poses",
        {"type": "array", "items": object_schema(TruePose)},
        decode=lambda items: tuple(from_json(TruePose, p) for p in items),
    )
    kind: TruthKind = json_field("kind", _POINTS_SCHEMA)
    points_grid: tuple[Vec3, ...] = json_field(
        "points", {"type": "array", "items": _vec3_schema("grid frame"), "minItems": 1}
    )
    rig: tuple[float, ...] | None = json_field(
        "rig",
        {
            "type": "array",
            "items": {"type": "number"},
            "minItems": 11,
            "maxItems": 11,
            "description": "the rig's systematic constants the frames were rendered with "
            "(twopose.rig.RIG_PARAMETERS order); absent: none",
        },
        required=False,
        default=None,
        decode=lambda values: tuple(float(v) for v in values),
    )

    def __post_init__(self) -> None:
        """Check the trial and the truth's points."""
        index(self.trial, "trial")
        object.__setattr__(
            self, "points_grid", tuple(vec3(p, "truth point") for p in self.points_grid)
        )
        if self.rig is not None:
            object.__setattr__(self, "rig", tuple(float(v) for v in numbers(self.rig, 11, "rig")))


TYPED_ENTRIES: tuple[type[TypedEntry], ...] = (
    SessionInfo,
    PoseEntry,
    CaptureWindow,
    PlaneEntry,
    GroundTruth,
    Note,
    SimulationTruth,
    CaptureDecision,  # format 1.1; registered after the 1.0 channels (see channels.py)
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
