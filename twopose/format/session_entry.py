"""The session entry (``/twopose/session``): what a session is, the first typed entry.

Its method, units and cameras, who recorded it, its identity (format 1.3, 1.4), the
calibrations' sigma (1.2), a board session's board (1.2), the guidance it ran with (1.5)
and where each camera's capture times come from (1.6). Declared as every entry is
(:mod:`twopose.format.declared`); :mod:`twopose.format.entries` registers it first.
"""

from __future__ import annotations

from dataclasses import dataclass

from twopose.camera.model import SIGMA_KEYS, intrinsics_sigma
from twopose.errors import InputValueError
from twopose.format.declared import CAMERA_SCHEMA, TypedEntry, entry, json_field, vec3_schema
from twopose.format.guidance_record import GuidanceRecord, guidance_schema
from twopose.format.stream_entries import CLOCK_SOURCES
from twopose.methods.specs import METHOD_SPECS, Method, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.values.checks import camera_id
from twopose.values.units import UNITS, Units, unit_spec

__all__ = ["FORMAT_MAJOR", "FORMAT_VERSION", "SessionInfo"]

#: The session format this twopose writes (docs/session-format.md); it reads every
#: version of its major.
FORMAT_VERSION = "1.6"
FORMAT_MAJOR = 1
_CAMERA_SCHEMA = CAMERA_SCHEMA
_vec3_schema = vec3_schema


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
    method: Method = json_field("method", {"enum": METHOD_SPECS.names})  # kept current
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
    clocks: dict[str, str] | None = json_field(
        "clocks",
        {"type": "object", "additionalProperties": {"enum": list(CLOCK_SOURCES)},
         "description": "1.6: per camera id, where its frames' capture times come from"},
        required=False, default=None, compare=False,
    )  # fmt: skip

    @property
    def is_continuation(self) -> bool:
        """Whether the session continues an earlier file (``new --continue``)."""
        return self.continues_after_trial is not None

    def __post_init__(self) -> None:
        """Hold the method and units as their types; check the cameras and the version."""
        # The registries' types (equal to, and serialised as, the names in the file).
        spec = spec_of(self.method)  # the name as the file gives it: looked up once
        object.__setattr__(self, "method", spec.method)
        object.__setattr__(self, "units", unit_spec(self.units).units)
        if not self.camera_ids:
            raise InputValueError("a session needs at least one camera")
        for cid in self.camera_ids:
            camera_id(cid)
        if len(set(self.camera_ids)) != len(self.camera_ids):
            raise InputValueError(f"camera ids must be unique, got {self.camera_ids}")
        if (self.board is not None) == spec.measures:
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
        for cid, source in (self.clocks or {}).items():
            if cid not in self.camera_ids or source not in CLOCK_SOURCES:
                raise InputValueError(
                    f"clocks: camera {cid!r} with clock {source!r}; each must be one of the "
                    f"session's cameras {list(self.camera_ids)}, its clock one of "
                    f"{', '.join(CLOCK_SOURCES)}"
                )
