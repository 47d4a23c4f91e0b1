"""twopose session format v1: typed entries, the session writer and the session reader.

One MCAP file per session. The layout is specified for other implementers in
``docs/session-format.md``; this module is the reference implementation.

Protobuf (Foxglove schemas), so a session opens in Foxglove as it is:

* ``/twopose/camera/<id>/calibration``  ``foxglove.CameraCalibration``, once per camera
* ``/twopose/camera/<id>/image``        ``foxglove.CompressedImage``, one per frame
* ``/tf``                               ``foxglove.FrameTransform`` grid -> camera, per pose

JSON with a ``jsonschema`` schema, our typed entries:

* ``/twopose/session`` :class:`SessionInfo`      ``/twopose/pose`` :class:`PoseEntry`
* ``/twopose/capture`` :class:`CaptureWindow`    ``/twopose/ground`` :class:`GroundPlane`
* ``/twopose/ground_truth`` :class:`GroundTruth` ``/twopose/note`` :class:`Note`
* ``/simulation/truth`` :class:`SimulationTruth` (simulated sessions only)
"""

from __future__ import annotations

import json
import math
import re
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import IO, Any, ClassVar, Literal, Self

import cv2
import numpy as np
from foxglove_schemas_protobuf.CameraCalibration_pb2 import (
    CameraCalibration as PbCameraCalibration,
)
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage as PbCompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform as PbFrameTransform
from jsonschema import Draft202012Validator
from jsonschema.exceptions import ValidationError
from mcap.reader import SeekingReader, make_reader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from mcap_protobuf.schema import build_file_descriptor_set
from numpy.typing import NDArray

from recorder.camera import Intrinsics, quaternion_xyzw_from_matrix, rotation_from_angles_deg
from recorder.errors import (
    InputValueError,
    SessionExistsError,
    SessionFormatError,
    SessionVersionError,
    TwoposeError,
)

__all__ = [
    "FORMAT_VERSION",
    "METHODS",
    "UNITS",
    "Camera",
    "CaptureWindow",
    "Frame",
    "GroundPlane",
    "GroundTruth",
    "Note",
    "PoseEntry",
    "SessionInfo",
    "SessionReader",
    "SessionWriter",
    "SimulationTruth",
    "TruePose",
    "TypedEntry",
]

FORMAT_VERSION = "1.0"
FORMAT_MAJOR = 1
METADATA_NAME = "twopose"
GRID_FRAME = "grid"
TF_TOPIC = "/tf"

Method = Literal["point", "line", "ground"]
METHODS: tuple[Method, ...] = ("point", "line", "ground")
UNITS = ("in", "mm", "cm", "m")
IMAGE_FORMATS = ("jpeg", "png")
_CAMERA_ID = re.compile(r"^[A-Za-z0-9_-]{1,32}$")

Vec3 = tuple[float, float, float]


def camera_frame_id(camera_id: str) -> str:
    """The transform frame of a camera: ``camera_<id>``."""
    return f"camera_{camera_id}"


def image_topic(camera_id: str) -> str:
    return f"/twopose/camera/{camera_id}/image"


def calibration_topic(camera_id: str) -> str:
    return f"/twopose/camera/{camera_id}/calibration"


# --------------------------------------------------------------------------- validation helpers


def _vec3(value: Any, what: str) -> Vec3:
    try:
        v = tuple(float(x) for x in value)
    except (TypeError, ValueError) as err:
        raise InputValueError(f"{what} must be three numbers, got {value!r}") from err
    if len(v) != 3:
        raise InputValueError(f"{what} must be three numbers (x, y, z), got {len(v)}")
    if not all(math.isfinite(x) for x in v):
        raise InputValueError(f"{what} must be finite, got {v}")
    return (v[0], v[1], v[2])


def _finite(value: Any, what: str, *, positive: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as err:
        raise InputValueError(f"{what} must be a number, got {value!r}") from err
    if not math.isfinite(v):
        raise InputValueError(f"{what} must be finite, got {v}")
    if positive and v <= 0:
        raise InputValueError(f"{what} must be positive, got {v}")
    return v


def _index(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise InputValueError(f"{what} must be a whole number >= 0, got {value!r}")
    return int(value)


def _camera_id(value: Any) -> str:
    if not isinstance(value, str) or not _CAMERA_ID.match(value):
        raise InputValueError(f"camera id must be 1-32 letters, digits, '_' or '-', got {value!r}")
    return value


def _vec3_schema(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "number"},
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


_INDEX_SCHEMA = {"type": "integer", "minimum": 0}


def _schema(
    name: str, description: str, props: dict[str, Any], required: list[str]
) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": f"twopose.{name}",
        "title": f"twopose.{name}",
        "description": description,
        "type": "object",
        "properties": props,
        "required": required,
    }


# --------------------------------------------------------------------------- typed entries


class TypedEntry:
    """Base of the JSON-encoded typed entries. Subclasses are frozen dataclasses."""

    TOPIC: ClassVar[str]
    SCHEMA_NAME: ClassVar[str]
    JSON_SCHEMA: ClassVar[dict[str, Any]]

    def to_json(self) -> dict[str, Any]:
        raise NotImplementedError

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        raise NotImplementedError


@dataclass(frozen=True)
class SessionInfo(TypedEntry):
    """What the session is: method, units, who recorded it, which cameras."""

    method: Method
    units: str
    camera_ids: tuple[str, ...] = ("cam0",)
    operator: str = ""
    notes: str = ""
    created_utc: str = ""
    simulated: bool = False
    software_version: str = ""
    format_version: str = FORMAT_VERSION

    TOPIC: ClassVar[str] = "/twopose/session"
    SCHEMA_NAME: ClassVar[str] = "twopose.Session"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "Session",
        "One per file, first typed entry: what this session is.",
        {
            "format_version": {"type": "string", "pattern": r"^\d+\.\d+$"},
            "software_version": {"type": "string"},
            "method": {"enum": list(METHODS)},
            "units": {"enum": list(UNITS)},
            "camera_ids": {
                "type": "array",
                "items": {"type": "string", "pattern": _CAMERA_ID.pattern},
                "minItems": 1,
                "uniqueItems": True,
            },
            "operator": {"type": "string"},
            "notes": {"type": "string"},
            "created_utc": {"type": "string", "description": "ISO 8601, UTC; may be empty"},
            "simulated": {"type": "boolean"},
        },
        ["format_version", "method", "units", "camera_ids"],
    )

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise InputValueError(
                f"method must be one of {', '.join(METHODS)}, got {self.method!r}"
            )
        if self.units not in UNITS:
            raise InputValueError(f"units must be one of {', '.join(UNITS)}, got {self.units!r}")
        if not self.camera_ids:
            raise InputValueError("a session needs at least one camera")
        for cid in self.camera_ids:
            _camera_id(cid)
        if len(set(self.camera_ids)) != len(self.camera_ids):
            raise InputValueError(f"camera ids must be unique, got {self.camera_ids}")

    def to_json(self) -> dict[str, Any]:
        return {
            "format_version": self.format_version,
            "software_version": self.software_version,
            "method": self.method,
            "units": self.units,
            "camera_ids": list(self.camera_ids),
            "operator": self.operator,
            "notes": self.notes,
            "created_utc": self.created_utc,
            "simulated": self.simulated,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        return cls(
            method=data["method"],
            units=data["units"],
            camera_ids=tuple(data["camera_ids"]),
            operator=data.get("operator", ""),
            notes=data.get("notes", ""),
            created_utc=data.get("created_utc", ""),
            simulated=data.get("simulated", False),
            software_version=data.get("software_version", ""),
            format_version=data["format_version"],
        )


@dataclass(frozen=True)
class PoseEntry(TypedEntry):
    """A typed pose: camera centre ``t_grid`` (session units) and angles ``r_deg`` (degrees).

    ``R_cam_to_grid = Rx(rx) Ry(ry) Rz(rz)``; ``p_grid = R_cam_to_grid p_cam + t_grid``.
    The resolutions are the 1-sigma uncertainty of each typed component (what the operator
    can place and measure to with tape and protractor); they are the pose part of every
    estimate's uncertainty.
    """

    trial: int
    pose: int
    camera_id: str
    t_grid: Vec3
    r_deg: Vec3 = (0.0, 0.0, 0.0)
    translation_resolution: float = 0.0625
    rotation_resolution_deg: float = 0.5

    TOPIC: ClassVar[str] = "/twopose/pose"
    SCHEMA_NAME: ClassVar[str] = "twopose.PoseEntry"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "PoseEntry",
        "A typed camera pose: camera centre in the grid frame and R = Rx Ry Rz (camera -> grid).",
        {
            "trial": _INDEX_SCHEMA,
            "pose": _INDEX_SCHEMA,
            "camera": {"type": "string", "pattern": _CAMERA_ID.pattern},
            "translation": _vec3_schema("camera centre in the grid frame, session units"),
            "rotation_deg": _vec3_schema("(rx, ry, rz) in degrees, R = Rx(rx) Ry(ry) Rz(rz)"),
            "resolution": {
                "type": "object",
                "properties": {
                    "translation": {"type": "number", "exclusiveMinimum": 0},
                    "rotation_deg": {"type": "number", "exclusiveMinimum": 0},
                },
                "required": ["translation", "rotation_deg"],
            },
        },
        ["trial", "pose", "camera", "translation", "rotation_deg", "resolution"],
    )

    def __post_init__(self) -> None:
        _index(self.trial, "trial")
        _index(self.pose, "pose")
        _camera_id(self.camera_id)
        object.__setattr__(self, "t_grid", _vec3(self.t_grid, "translation"))
        object.__setattr__(self, "r_deg", _vec3(self.r_deg, "rotation"))
        _finite(self.translation_resolution, "translation resolution", positive=True)
        _finite(self.rotation_resolution_deg, "rotation resolution", positive=True)

    @property
    def R_cam_to_grid(self) -> NDArray[np.float64]:
        return rotation_from_angles_deg(self.r_deg)

    def to_json(self) -> dict[str, Any]:
        return {
            "trial": self.trial,
            "pose": self.pose,
            "camera": self.camera_id,
            "translation": list(self.t_grid),
            "rotation_deg": list(self.r_deg),
            "resolution": {
                "translation": self.translation_resolution,
                "rotation_deg": self.rotation_resolution_deg,
            },
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        return cls(
            trial=data["trial"],
            pose=data["pose"],
            camera_id=data["camera"],
            t_grid=data["translation"],
            r_deg=data["rotation_deg"],
            translation_resolution=data["resolution"]["translation"],
            rotation_resolution_deg=data["resolution"]["rotation_deg"],
        )


CaptureStatus = Literal["complete", "incomplete"]


@dataclass(frozen=True)
class CaptureWindow(TypedEntry):
    """Which frames belong to which trial and pose.

    The frames of a capture are the messages on the camera's image topic with
    ``start_ns <= log_time <= end_ns``; written after the last frame of the capture.
    """

    trial: int
    pose: int
    camera_id: str
    start_ns: int
    end_ns: int
    n_frames: int
    status: CaptureStatus = "complete"
    reason: str = ""
    dropped_frames: int = 0

    TOPIC: ClassVar[str] = "/twopose/capture"
    SCHEMA_NAME: ClassVar[str] = "twopose.CaptureWindow"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "CaptureWindow",
        "The frames of one capture: the camera's images with start_ns <= log_time <= end_ns.",
        {
            "trial": _INDEX_SCHEMA,
            "pose": _INDEX_SCHEMA,
            "camera": {"type": "string", "pattern": _CAMERA_ID.pattern},
            "start_ns": _INDEX_SCHEMA,
            "end_ns": _INDEX_SCHEMA,
            "n_frames": _INDEX_SCHEMA,
            "status": {"enum": ["complete", "incomplete"]},
            "reason": {"type": "string"},
            "dropped_frames": _INDEX_SCHEMA,
        },
        ["trial", "pose", "camera", "start_ns", "end_ns", "n_frames", "status"],
    )

    def __post_init__(self) -> None:
        _index(self.trial, "trial")
        _index(self.pose, "pose")
        _camera_id(self.camera_id)
        _index(self.start_ns, "start_ns")
        _index(self.end_ns, "end_ns")
        _index(self.n_frames, "n_frames")
        _index(self.dropped_frames, "dropped_frames")
        if self.end_ns < self.start_ns:
            raise InputValueError(
                f"capture ends ({self.end_ns}) before it starts ({self.start_ns})"
            )
        if self.status not in ("complete", "incomplete"):
            raise InputValueError(
                f"capture status must be complete or incomplete, got {self.status!r}"
            )

    def to_json(self) -> dict[str, Any]:
        return {
            "trial": self.trial,
            "pose": self.pose,
            "camera": self.camera_id,
            "start_ns": self.start_ns,
            "end_ns": self.end_ns,
            "n_frames": self.n_frames,
            "status": self.status,
            "reason": self.reason,
            "dropped_frames": self.dropped_frames,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        return cls(
            trial=data["trial"],
            pose=data["pose"],
            camera_id=data["camera"],
            start_ns=data["start_ns"],
            end_ns=data["end_ns"],
            n_frames=data["n_frames"],
            status=data["status"],
            reason=data.get("reason", ""),
            dropped_frames=data.get("dropped_frames", 0),
        )


@dataclass(frozen=True)
class GroundPlane(TypedEntry):
    """The ground (table top) plane ``normal_grid . p = offset`` in the grid frame.

    The thesis: normal (0, 1, 0), offset h = 9.625 in (camera centre down to the table).
    """

    offset: float
    normal_grid: Vec3 = (0.0, 1.0, 0.0)

    TOPIC: ClassVar[str] = "/twopose/ground"
    SCHEMA_NAME: ClassVar[str] = "twopose.GroundPlane"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "GroundPlane",
        "The ground plane normal . p = offset in the grid frame (session units).",
        {"normal": _vec3_schema("unit normal in the grid frame"), "offset": {"type": "number"}},
        ["normal", "offset"],
    )

    def __post_init__(self) -> None:
        n = np.array(_vec3(self.normal_grid, "ground normal"))
        norm = float(np.linalg.norm(n))
        if norm < 1e-9:
            raise InputValueError("ground normal must not be zero")
        object.__setattr__(self, "normal_grid", _vec3(n / norm, "ground normal"))
        object.__setattr__(self, "offset", _finite(self.offset, "ground height") / norm)

    def to_json(self) -> dict[str, Any]:
        return {"normal": list(self.normal_grid), "offset": self.offset}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        return cls(offset=data["offset"], normal_grid=data["normal"])


TruthKind = Literal["point", "line"]


@dataclass(frozen=True)
class GroundTruth(TypedEntry):
    """Measured truth of one trial in the grid frame: a point, or two points on the line."""

    trial: int
    kind: TruthKind
    points_grid: tuple[Vec3, ...]

    TOPIC: ClassVar[str] = "/twopose/ground_truth"
    SCHEMA_NAME: ClassVar[str] = "twopose.GroundTruth"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "GroundTruth",
        "Ground truth of one trial: a grid point (point, ground) or two points on the line (line).",
        {
            "trial": _INDEX_SCHEMA,
            "kind": {"enum": ["point", "line"]},
            "points": {
                "type": "array",
                "items": _vec3_schema("a point in the grid frame"),
                "minItems": 1,
                "maxItems": 2,
            },
        },
        ["trial", "kind", "points"],
    )

    def __post_init__(self) -> None:
        _index(self.trial, "trial")
        if self.kind not in ("point", "line"):
            raise InputValueError(f"ground truth kind must be point or line, got {self.kind!r}")
        pts = tuple(_vec3(p, "ground-truth point") for p in self.points_grid)
        want = 1 if self.kind == "point" else 2
        if len(pts) != want:
            raise InputValueError(f"{self.kind} ground truth needs {want} point(s), got {len(pts)}")
        if self.kind == "line" and np.allclose(pts[0], pts[1]):
            raise InputValueError("the two ground-truth points of a line must differ")
        object.__setattr__(self, "points_grid", pts)

    def to_json(self) -> dict[str, Any]:
        return {
            "trial": self.trial,
            "kind": self.kind,
            "points": [list(p) for p in self.points_grid],
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        return cls(trial=data["trial"], kind=data["kind"], points_grid=tuple(data["points"]))


@dataclass(frozen=True)
class Note(TypedEntry):
    """A free-text note by the operator, optionally about one trial."""

    text: str
    trial: int | None = None

    TOPIC: ClassVar[str] = "/twopose/note"
    SCHEMA_NAME: ClassVar[str] = "twopose.Note"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "Note",
        "A free-text operator note.",
        {"text": {"type": "string"}, "trial": {"type": ["integer", "null"], "minimum": 0}},
        ["text"],
    )

    def __post_init__(self) -> None:
        if self.trial is not None:
            _index(self.trial, "trial")

    def to_json(self) -> dict[str, Any]:
        return {"text": self.text, "trial": self.trial}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        return cls(text=data["text"], trial=data.get("trial"))


@dataclass(frozen=True)
class TruePose:
    """The pose the simulated camera really had (the typed one carries the typing error)."""

    pose: int
    camera_id: str
    t_grid: Vec3
    r_deg: Vec3

    def to_json(self) -> dict[str, Any]:
        return {
            "pose": self.pose,
            "camera": self.camera_id,
            "translation": list(self.t_grid),
            "rotation_deg": list(self.r_deg),
        }


@dataclass(frozen=True)
class SimulationTruth(TypedEntry):
    """What a simulated trial really was: true poses and the true point or line."""

    trial: int
    poses: tuple[TruePose, ...]
    kind: TruthKind
    points_grid: tuple[Vec3, ...]

    TOPIC: ClassVar[str] = "/simulation/truth"
    SCHEMA_NAME: ClassVar[str] = "twopose.SimulationTruth"
    JSON_SCHEMA: ClassVar[dict[str, Any]] = _schema(
        "SimulationTruth",
        "Simulated sessions only: the true poses (frames were rendered from these) and target.",
        {
            "trial": _INDEX_SCHEMA,
            "poses": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "pose": _INDEX_SCHEMA,
                        "camera": {"type": "string"},
                        "translation": _vec3_schema("true camera centre, grid frame"),
                        "rotation_deg": _vec3_schema("true (rx, ry, rz), degrees"),
                    },
                    "required": ["pose", "camera", "translation", "rotation_deg"],
                },
            },
            "kind": {"enum": ["point", "line"]},
            "points": {"type": "array", "items": _vec3_schema("grid frame"), "minItems": 1},
        },
        ["trial", "poses", "kind", "points"],
    )

    def __post_init__(self) -> None:
        _index(self.trial, "trial")
        object.__setattr__(
            self, "points_grid", tuple(_vec3(p, "truth point") for p in self.points_grid)
        )

    def to_json(self) -> dict[str, Any]:
        return {
            "trial": self.trial,
            "poses": [p.to_json() for p in self.poses],
            "kind": self.kind,
            "points": [list(p) for p in self.points_grid],
        }

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        poses = tuple(
            TruePose(
                pose=p["pose"],
                camera_id=p["camera"],
                t_grid=_vec3(p["translation"], "true translation"),
                r_deg=_vec3(p["rotation_deg"], "true rotation"),
            )
            for p in data["poses"]
        )
        return cls(
            trial=data["trial"], poses=poses, kind=data["kind"], points_grid=tuple(data["points"])
        )


@dataclass(frozen=True)
class Camera:
    """A camera of the session and its calibration (``foxglove.CameraCalibration``)."""

    camera_id: str
    intrinsics: Intrinsics

    def __post_init__(self) -> None:
        _camera_id(self.camera_id)
        i = self.intrinsics
        for name in ("fx", "fy"):
            _finite(getattr(i, name), name, positive=True)
        _finite(i.cx, "cx")
        _finite(i.cy, "cy")
        if i.width <= 0 or i.height <= 0:
            raise InputValueError(f"image size must be positive, got {i.width}x{i.height}")
        if len(i.distortion) != 5 or not all(math.isfinite(k) for k in i.distortion):
            raise InputValueError(f"distortion must be 5 finite numbers, got {i.distortion}")


@dataclass(frozen=True)
class Frame:
    """One encoded image as stored (decode with :meth:`decode`)."""

    camera_id: str
    log_time_ns: int
    sequence: int
    format: str
    data: bytes = field(repr=False)

    def decode(self) -> NDArray[np.uint8]:
        """The image as an (H, W, 3) BGR uint8 array (OpenCV's order)."""
        img = cv2.imdecode(np.frombuffer(self.data, dtype=np.uint8), cv2.IMREAD_COLOR)
        if img is None:
            raise SessionFormatError(
                f"frame {self.sequence} of camera {self.camera_id} at {self.log_time_ns} ns "
                f"is not a decodable {self.format} image"
            )
        return np.asarray(img, dtype=np.uint8)


TYPED_ENTRIES: tuple[type[TypedEntry], ...] = (
    SessionInfo,
    PoseEntry,
    CaptureWindow,
    GroundPlane,
    GroundTruth,
    Note,
    SimulationTruth,
)
_BY_SCHEMA: dict[str, type[TypedEntry]] = {cls.SCHEMA_NAME: cls for cls in TYPED_ENTRIES}
_VALIDATORS: dict[str, Draft202012Validator] = {
    cls.SCHEMA_NAME: Draft202012Validator(cls.JSON_SCHEMA) for cls in TYPED_ENTRIES
}


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


def _validate(schema_name: str, data: Any) -> None:
    try:
        _VALIDATORS[schema_name].validate(data)
    except ValidationError as err:
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        raise SessionFormatError(f"{schema_name} at {where}: {err.message}") from err


# --------------------------------------------------------------------------- protobuf helpers


def calibration_message(camera: Camera, log_time_ns: int) -> PbCameraCalibration:
    i = camera.intrinsics
    msg = PbCameraCalibration(
        frame_id=camera_frame_id(camera.camera_id),
        width=i.width,
        height=i.height,
        distortion_model="plumb_bob",
        D=list(i.distortion),
        K=[i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0],
        R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        P=[i.fx, 0.0, i.cx, 0.0, 0.0, i.fy, i.cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    )
    msg.timestamp.FromNanoseconds(log_time_ns)
    return msg


def _camera_from_message(msg: Any) -> Camera:
    frame_id: str = msg.frame_id
    if not frame_id.startswith("camera_"):
        raise SessionFormatError(f"camera calibration frame_id {frame_id!r} is not camera_<id>")
    K = list(msg.K)
    if len(K) != 9:
        raise SessionFormatError(f"camera calibration of {frame_id} has {len(K)} K values, not 9")
    D = [*list(msg.D), 0.0, 0.0, 0.0, 0.0, 0.0][:5]
    try:
        return Camera(
            camera_id=frame_id.removeprefix("camera_"),
            intrinsics=Intrinsics(
                width=int(msg.width),
                height=int(msg.height),
                fx=K[0],
                fy=K[4],
                cx=K[2],
                cy=K[5],
                distortion=(D[0], D[1], D[2], D[3], D[4]),
            ),
        )
    except InputValueError as err:
        raise SessionFormatError(f"camera calibration of {frame_id}: {err}") from err


def transform_message(entry: PoseEntry, log_time_ns: int) -> PbFrameTransform:
    qx, qy, qz, qw = quaternion_xyzw_from_matrix(entry.R_cam_to_grid)
    msg = PbFrameTransform(
        parent_frame_id=GRID_FRAME, child_frame_id=camera_frame_id(entry.camera_id)
    )
    msg.timestamp.FromNanoseconds(log_time_ns)
    msg.translation.x, msg.translation.y, msg.translation.z = entry.t_grid
    msg.rotation.x, msg.rotation.y, msg.rotation.z, msg.rotation.w = qx, qy, qz, qw
    return msg


# --------------------------------------------------------------------------- writer


def register_channels(writer: McapWriter, camera_ids: Sequence[str]) -> dict[str, int]:
    """Register every schema and channel of a session, in the order the format fixes.

    The order makes channel ids a function of the camera ids alone, which lets
    ``recover`` rebuild them when the chunk that held the channel records is lost.
    Returns topic -> channel id.
    """
    channels: dict[str, int] = {}
    for cls in TYPED_ENTRIES:
        schema_id = writer.register_schema(
            name=cls.SCHEMA_NAME,
            encoding="jsonschema",
            data=json.dumps(cls.JSON_SCHEMA).encode(),
        )
        channels[cls.TOPIC] = writer.register_channel(cls.TOPIC, "json", schema_id)
    proto_ids: dict[str, int] = {}
    for pb in (PbCameraCalibration, PbCompressedImage, PbFrameTransform):
        proto_ids[pb.DESCRIPTOR.full_name] = writer.register_schema(
            name=pb.DESCRIPTOR.full_name,
            encoding="protobuf",
            data=build_file_descriptor_set(pb).SerializeToString(),
        )
    channels[TF_TOPIC] = writer.register_channel(
        TF_TOPIC, "protobuf", proto_ids["foxglove.FrameTransform"]
    )
    for cid in camera_ids:
        channels[calibration_topic(cid)] = writer.register_channel(
            calibration_topic(cid), "protobuf", proto_ids["foxglove.CameraCalibration"]
        )
        channels[image_topic(cid)] = writer.register_channel(
            image_topic(cid), "protobuf", proto_ids["foxglove.CompressedImage"]
        )
    return channels


def session_metadata(
    info: SessionInfo, cameras: Sequence[Camera], ground: GroundPlane | None, start_ns: int
) -> dict[str, str]:
    """The ``twopose`` metadata record: versions, plus a copy of what opens the session.

    The metadata record is written before the first chunk, so the copy survives the loss
    of that chunk (which holds the schemas, channels and the session entry).
    """
    from recorder import __version__

    return {
        "format_version": FORMAT_VERSION,
        "software_version": __version__,
        "session": encode_entry(info).decode(),
        "cameras": json.dumps(
            [
                {
                    "camera": c.camera_id,
                    "width": c.intrinsics.width,
                    "height": c.intrinsics.height,
                    "fx": c.intrinsics.fx,
                    "fy": c.intrinsics.fy,
                    "cx": c.intrinsics.cx,
                    "cy": c.intrinsics.cy,
                    "distortion": list(c.intrinsics.distortion),
                }
                for c in cameras
            ]
        ),
        "ground": encode_entry(ground).decode() if ground is not None else "",
        "start_ns": str(start_ns),
    }


def _distortion(values: Any) -> tuple[float, float, float, float, float]:
    k = [float(v) for v in values]
    if len(k) != 5:
        raise ValueError(f"distortion needs 5 values, got {len(k)}")
    return (k[0], k[1], k[2], k[3], k[4])


def cameras_from_metadata(text: str) -> list[Camera]:
    """Inverse of the ``cameras`` field of :func:`session_metadata`."""
    try:
        return [
            Camera(
                c["camera"],
                Intrinsics(
                    int(c["width"]),
                    int(c["height"]),
                    float(c["fx"]),
                    float(c["fy"]),
                    float(c["cx"]),
                    float(c["cy"]),
                    _distortion(c["distortion"]),
                ),
            )
            for c in json.loads(text)
        ]
    except (KeyError, TypeError, ValueError, InputValueError) as err:
        raise SessionFormatError(f"the metadata's camera copy is unreadable: {err}") from err


class SessionWriter:
    """Write one session file; a context manager that refuses to overwrite.

    Every typed entry and the end of every capture flush the open chunk to disk, so a
    crash loses at most the capture in progress. All schemas and channels are registered
    and flushed with the session entry at open, in the order of ``docs/session-format.md``.

    Parameters
    ----------
    path : path-like
        The new session file; it must not exist.
    info : SessionInfo
    cameras : sequence of Camera
        One per id in ``info.camera_ids``, in that order.
    ground : GroundPlane, optional
    image_format : {"jpeg", "png"}
    jpeg_quality : int
    clock : callable returning int nanoseconds
        Used wherever a ``log_time_ns`` is not given (simulations pass their own).
    """

    def __init__(
        self,
        path: str | Path,
        info: SessionInfo,
        cameras: Sequence[Camera],
        *,
        ground: GroundPlane | None = None,
        image_format: str = "jpeg",
        jpeg_quality: int = 90,
        clock: Callable[[], int] = time.time_ns,
        start_ns: int | None = None,
    ) -> None:
        if image_format not in IMAGE_FORMATS:
            raise InputValueError(f"image format must be jpeg or png, got {image_format!r}")
        if tuple(c.camera_id for c in cameras) != info.camera_ids:
            raise InputValueError(
                f"cameras {[c.camera_id for c in cameras]} do not match the session's "
                f"camera_ids {list(info.camera_ids)}"
            )
        if not 1 <= jpeg_quality <= 100:
            raise InputValueError(f"JPEG quality must be 1-100, got {jpeg_quality}")
        self.path = Path(path)
        self.info = info
        self.cameras = {c.camera_id: c for c in cameras}
        self.ground = ground
        self.image_format = image_format
        self._encode_params = (
            [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality] if image_format == "jpeg" else []
        )
        self._clock = clock
        self._start_ns = start_ns
        self._stream: IO[bytes] | None = None
        self._mcap: McapWriter | None = None
        self._channels: dict[str, int] = {}
        self._sequence: dict[str, int] = {}
        self._last_ns = 0
        self._capture_open = False
        self.counts: dict[str, int] = {}

    # -- lifecycle
    def __enter__(self) -> Self:
        try:
            self._stream = open(self.path, "xb")
        except FileExistsError as err:
            raise SessionExistsError(
                f"{self.path} already exists; twopose never overwrites a session. "
                "Choose another file name or move the old one away."
            ) from err
        except OSError as err:
            raise TwoposeError(f"cannot create {self.path}: {err.strerror}") from err
        from recorder import __version__

        self._mcap = McapWriter(self._stream, compression=CompressionType.ZSTD)
        self._mcap.start(profile="", library=f"twopose/{__version__}")
        self._channels = register_channels(self._mcap, self.info.camera_ids)
        t0 = self._start_ns if self._start_ns is not None else self._clock()
        self._mcap.add_metadata(
            METADATA_NAME, session_metadata(self.info, list(self.cameras.values()), self.ground, t0)
        )
        self._write_json(self.info, t0)
        for camera in self.cameras.values():
            self._write_proto(
                calibration_topic(camera.camera_id), calibration_message(camera, t0), t0
            )
        if self.ground is not None:
            self._write_json(self.ground, t0)
        self._mcap.flush()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Write the summary and index and close the file (also after an error)."""
        if self._mcap is not None:
            self._mcap.finish()
            self._mcap = None
        if self._stream is not None:
            self._stream.close()
            self._stream = None

    # -- low level
    def _time(self, log_time_ns: int | None) -> int:
        t = self._clock() if log_time_ns is None else int(log_time_ns)
        if t < 0:
            raise InputValueError(f"log time must be >= 0 ns, got {t}")
        self._last_ns = max(self._last_ns, t)
        return t

    def _write(self, topic: str, payload: bytes, log_time_ns: int) -> int:
        if self._mcap is None:
            raise TwoposeError(
                f"{self.path} is not open for writing; use `with SessionWriter(...)`"
            )
        seq = self._sequence.get(topic, 0)
        self._sequence[topic] = seq + 1
        self._mcap.add_message(
            channel_id=self._channels[topic],
            log_time=log_time_ns,
            publish_time=log_time_ns,
            data=payload,
            sequence=seq,
        )
        self.counts[topic] = self.counts.get(topic, 0) + 1
        return seq

    def _write_json(self, entry: TypedEntry, log_time_ns: int) -> None:
        self._write(entry.TOPIC, encode_entry(entry), log_time_ns)

    def _write_proto(self, topic: str, msg: Any, log_time_ns: int) -> int:
        return self._write(topic, msg.SerializeToString(), log_time_ns)

    def _flush(self) -> None:
        assert self._mcap is not None
        self._mcap.flush()

    def _check_camera(self, camera_id: str) -> None:
        if camera_id not in self.cameras:
            raise InputValueError(
                f"camera {camera_id!r} is not in this session (cameras: {', '.join(self.cameras)})"
            )

    # -- typed entries
    def write_pose(self, entry: PoseEntry, log_time_ns: int | None = None) -> None:
        """Write a typed pose and its ``foxglove.FrameTransform``; flushed at once."""
        self._check_camera(entry.camera_id)
        t = self._time(log_time_ns)
        self._write_json(entry, t)
        self._write_proto(TF_TOPIC, transform_message(entry, t), t)
        self._flush()

    def write_ground_truth(self, entry: GroundTruth, log_time_ns: int | None = None) -> None:
        self._write_json(entry, self._time(log_time_ns))
        self._flush()

    def write_note(self, entry: Note, log_time_ns: int | None = None) -> None:
        self._write_json(entry, self._time(log_time_ns))
        self._flush()

    def write_simulation_truth(
        self, entry: SimulationTruth, log_time_ns: int | None = None
    ) -> None:
        self._write_json(entry, self._time(log_time_ns))
        self._flush()

    def capture(self, trial: int, pose: int, camera_id: str) -> Capture:
        """Open a capture window; frames go through :meth:`Capture.add_frame`."""
        self._check_camera(camera_id)
        _index(trial, "trial")
        _index(pose, "pose")
        if self._capture_open:
            raise TwoposeError("a capture is already open; finish it before starting another")
        return Capture(self, trial, pose, camera_id)

    def encode_image(self, image_bgr: NDArray[np.uint8]) -> bytes:
        """Encode an (H, W, 3) BGR uint8 image in the session's image format."""
        ok, buf = cv2.imencode(
            ".jpg" if self.image_format == "jpeg" else ".png", image_bgr, self._encode_params
        )
        if not ok:
            raise InputValueError(f"OpenCV could not encode a {image_bgr.shape} image")
        return bytes(buf)


class Capture:
    """One capture window (see :meth:`SessionWriter.capture`)."""

    def __init__(self, writer: SessionWriter, trial: int, pose: int, camera_id: str) -> None:
        self._writer = writer
        self.trial = trial
        self.pose = pose
        self.camera_id = camera_id
        self.start_ns: int | None = None
        self.end_ns: int | None = None
        self.n_frames = 0
        self.dropped_frames = 0
        self._incomplete_reason = ""

    def __enter__(self) -> Self:
        self._writer._capture_open = True
        return self

    def add_frame(self, image_bgr: NDArray[np.uint8], log_time_ns: int | None = None) -> int:
        """Encode and write one frame; returns its sequence number on the image topic."""
        return self.add_encoded(self._writer.encode_image(image_bgr), log_time_ns)

    def add_encoded(self, data: bytes, log_time_ns: int | None = None) -> int:
        """Write one already-encoded frame in the session's image format."""
        t = self._writer._time(log_time_ns)
        if self.end_ns is not None and t < self.end_ns:
            raise InputValueError(
                f"frame time {t} ns goes back before the previous frame ({self.end_ns} ns)"
            )
        msg = PbCompressedImage(
            frame_id=camera_frame_id(self.camera_id), data=data, format=self._writer.image_format
        )
        msg.timestamp.FromNanoseconds(t)
        seq = self._writer._write_proto(image_topic(self.camera_id), msg, t)
        self.start_ns = t if self.start_ns is None else self.start_ns
        self.end_ns = t
        self.n_frames += 1
        return seq

    def mark_incomplete(self, reason: str) -> None:
        self._incomplete_reason = reason or "incomplete"

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._writer._capture_open = False
        if exc is not None and not self._incomplete_reason:
            self._incomplete_reason = f"{exc_type.__name__ if exc_type else 'error'}: {exc}"
        if self._writer._mcap is None:
            return
        now = self._writer._last_ns
        entry = CaptureWindow(
            trial=self.trial,
            pose=self.pose,
            camera_id=self.camera_id,
            start_ns=self.start_ns if self.start_ns is not None else now,
            end_ns=self.end_ns if self.end_ns is not None else now,
            n_frames=self.n_frames,
            status="incomplete" if self._incomplete_reason else "complete",
            reason=self._incomplete_reason,
            dropped_frames=self.dropped_frames,
        )
        self._writer._write_json(entry, self._writer._last_ns)
        self._writer._flush()


# --------------------------------------------------------------------------- reader

Entry = TypedEntry | Frame | PbFrameTransform | Camera


_FOXGLOVE_CLASSES: dict[str, Any] = {
    cls.DESCRIPTOR.full_name: cls
    for cls in (PbCameraCalibration, PbCompressedImage, PbFrameTransform)
}


class SessionReader:
    """Read a session file (seeking reader: memory stays bounded by one chunk).

    Use as a context manager. Raises :class:`SessionFormatError` for anything that is
    not a readable session and :class:`SessionVersionError` for a newer major version.

    Parameters
    ----------
    path : path-like
    validate_crcs : bool
        Check chunk CRCs while reading (a corrupt chunk raises SessionFormatError).
    """

    def __init__(self, path: str | Path, *, validate_crcs: bool = True) -> None:
        self.path = Path(path)
        self.validate_crcs = validate_crcs
        self._stream: IO[bytes] | None = None
        self._reader: SeekingReader | None = None
        self.format_version = ""
        self.software_version = ""
        self._info: SessionInfo | None = None
        self._cameras: dict[str, Camera] = {}
        self._ground: GroundPlane | None = None

    def __enter__(self) -> Self:
        try:
            self._stream = open(self.path, "rb")
        except OSError as err:
            raise SessionFormatError(f"cannot open {self.path}: {err.strerror}") from err
        try:
            self._open()
        except BaseException:
            self._stream.close()
            raise
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._stream is not None:
            self._stream.close()
            self._stream = None

    def _fail(self, what: str, err: BaseException) -> SessionFormatError:
        return SessionFormatError(
            f"{self.path}: {what} ({type(err).__name__}: {err}). If the recording was "
            f"interrupted, `twopose-record recover {self.path} -o FIXED.mcap` salvages it."
        )

    def _open(self) -> None:
        assert self._stream is not None
        try:
            reader = make_reader(
                self._stream,
                validate_crcs=self.validate_crcs,
            )
            summary = reader.get_summary()
            metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        except TwoposeError:
            raise
        except Exception as err:
            raise self._fail("not a readable MCAP file", err) from err
        assert isinstance(reader, SeekingReader)
        if summary is None:
            raise SessionFormatError(
                f"{self.path}: the file has no summary section, so it was truncated or never "
                f"closed. `twopose-record recover {self.path} -o FIXED.mcap` salvages it."
            )
        if METADATA_NAME not in metadata:
            raise SessionFormatError(
                f"{self.path}: no '{METADATA_NAME}' metadata record; this MCAP file is not a "
                "twopose session"
            )
        self.format_version = metadata[METADATA_NAME].get("format_version", "")
        self.software_version = metadata[METADATA_NAME].get("software_version", "")
        _check_version(self.path, self.format_version)
        self._reader = reader
        for item in self.iter_entries(
            topics=[SessionInfo.TOPIC, GroundPlane.TOPIC]
            + [t for t in _channel_topics(summary) if t.endswith("/calibration")]
        ):
            if isinstance(item, SessionInfo) and self._info is None:
                self._info = item
            elif isinstance(item, GroundPlane):
                self._ground = item
            elif isinstance(item, Camera):
                self._cameras[item.camera_id] = item
        if self._info is None:
            raise SessionFormatError(
                f"{self.path}: no {SessionInfo.TOPIC} message; not a twopose session"
            )
        missing = [c for c in self._info.camera_ids if c not in self._cameras]
        if missing:
            raise SessionFormatError(
                f"{self.path}: no calibration for camera(s) {', '.join(missing)} "
                f"on {calibration_topic(missing[0])}"
            )

    @property
    def info(self) -> SessionInfo:
        assert self._info is not None, "use SessionReader as a context manager"
        return self._info

    @property
    def cameras(self) -> dict[str, Camera]:
        return dict(self._cameras)

    @property
    def ground(self) -> GroundPlane | None:
        return self._ground

    def message_counts(self) -> dict[str, int]:
        """Messages per topic, from the summary statistics."""
        assert self._reader is not None
        summary = self._reader.get_summary()
        assert summary is not None
        assert summary.statistics is not None
        return {
            summary.channels[cid].topic: n
            for cid, n in summary.statistics.channel_message_counts.items()
        }

    def iter_entries(self, topics: Iterable[str] | None = None) -> Iterator[Entry]:
        """Decoded messages in log-time order: typed entries, frames, transforms, cameras.

        Parameters
        ----------
        topics : iterable of str, optional
            Only these topics (all when None).
        """
        if self._reader is None:
            raise TwoposeError("use SessionReader as a context manager")
        topic_list = None if topics is None else list(topics)
        try:
            for schema, channel, message in self._reader.iter_messages(
                topics=topic_list, log_time_order=True
            ):
                entry = self._entry(schema, channel, message)
                if entry is not None:
                    yield entry
        except TwoposeError:
            raise
        except Exception as err:
            raise self._fail("a chunk could not be read", err) from err

    def _entry(self, schema: Any, channel: Any, message: Any) -> Entry | None:
        """Typed entries via their JSON schema name, Foxglove messages via Foxglove's classes."""
        topic: str = channel.topic
        if schema is None:
            raise SessionFormatError(f"{self.path}: channel {topic} has no schema")
        if channel.message_encoding == "json" and schema.name in _BY_SCHEMA:
            return decode_entry(schema.name, message.data)
        pb_class = _FOXGLOVE_CLASSES.get(schema.name)
        if channel.message_encoding != "protobuf" or pb_class is None:
            return None  # a channel this version does not know (format 1.x may add some)
        try:
            decoded = pb_class.FromString(message.data)
        except Exception as err:  # protobuf's DecodeError and friends
            raise self._fail(f"{topic} holds an undecodable {schema.name}", err) from err
        if isinstance(decoded, PbCompressedImage):
            return Frame(
                camera_id=decoded.frame_id.removeprefix("camera_"),
                log_time_ns=message.log_time,
                sequence=message.sequence,
                format=decoded.format,
                data=bytes(decoded.data),
            )
        if isinstance(decoded, PbCameraCalibration):
            return _camera_from_message(decoded)
        return decoded  # type: ignore[no-any-return]


def _channel_topics(summary: Any) -> list[str]:
    return [c.topic for c in summary.channels.values()]


def _check_version(path: Path, version: str) -> None:
    match = re.fullmatch(r"(\d+)\.(\d+)", version)
    if match is None:
        raise SessionFormatError(f"{path}: format version {version!r} is not MAJOR.MINOR")
    if int(match.group(1)) > FORMAT_MAJOR:
        from recorder import __version__

        raise SessionVersionError(
            f"{path} uses twopose session format {version}, but this twopose ({__version__}) "
            f"reads format {FORMAT_MAJOR}.x only. Upgrade twopose to read it."
        )
