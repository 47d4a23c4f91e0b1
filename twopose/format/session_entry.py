"""The session entry (``/twopose/session``): what a session is, the first typed entry.

Its method, units and cameras, who recorded it, its identity (format 1.3, 1.4), the
calibrations' sigma (1.2), a board session's board (1.2), the guidance it ran with (1.5)
and where each camera's capture times come from (1.6). Declared as every entry is
(:mod:`twopose.format.declared`); :mod:`twopose.format.entries` registers it first.

Its ``guidance`` object (:class:`GuidanceRecord`, format 1.5) is here with it: what
suggested a recording's poses and ended its trials (the stop rule's precision, a trial's
most poses, the least gain, the suggestions' reach and grid, the taped target distance),
so that a continuation (``twopose-record new --continue``) takes every one of them, and
says which; each as a number, and where the operator gave it, beside it the text it was
given as (``given``), so that it is shown back as given
(:class:`twopose.values.checks.Given`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from twopose.camera.model import SIGMA_KEYS, intrinsics_sigma
from twopose.errors import InputValueError
from twopose.format.declared import (
    CAMERA_SCHEMA,
    TypedEntry,
    entry,
    from_json,
    json_field,
    object_schema,
    vec3_schema,
)
from twopose.format.stream_entries import CLOCK_SOURCES
from twopose.methods.specs import METHOD_SPECS, Method, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.values.checks import Given, GivenWhole, camera_id, finite, given_text
from twopose.values.units import UNITS, Units, unit_spec

__all__ = [
    "FORMAT_MAJOR",
    "FORMAT_VERSION",
    "GUIDANCE_KEYS",
    "GuidanceRecord",
    "SessionInfo",
    "guidance_schema",
]

#: The session format this twopose writes (docs/session-format.md); it reads every
#: version of its major.
FORMAT_VERSION = "1.6"
FORMAT_MAJOR = 1
_CAMERA_SCHEMA = CAMERA_SCHEMA
_vec3_schema = vec3_schema


_LENGTH = {"type": "number", "exclusiveMinimum": 0}
_POSES = {"type": "integer", "minimum": 2}

#: The keys of the ``guidance`` object that hold a setting (``given`` names some of them).
GUIDANCE_KEYS = ("target_95", "max_poses", "min_gain", "reach", "spacing", "target_distance")


@dataclass(frozen=True, kw_only=True)
class GuidanceRecord:
    """The guidance a recording ran with, in the session's units.

    ``target95`` None: no stop rule (every trial had ``max_poses`` poses); ``min_gain`` 0:
    no information-gain stop. ``given``: the text of each setting the operator gave, by
    its key (the others were the recorder's defaults).
    """

    target95: float | None = json_field(
        "target_95", {**_LENGTH, "description": "the stop rule's 95% target; absent: none"},
        required=False, default=None,
    )  # fmt: skip
    max_poses: int = json_field(
        "max_poses", {**_POSES, "description": "a trial's most (no stop rule: its) poses"}
    )  # fmt: skip
    min_gain: float = json_field(
        "min_gain", {"type": "number", "minimum": 0, "maximum": 1,
                     "description": "the information-gain stop's least share; 0: none"},
    )  # fmt: skip
    reach: float = json_field(
        "reach", {**_LENGTH, "description": "suggestions' |dx|, |dz| at most"}
    )
    spacing: float = json_field("spacing", {**_LENGTH, "description": "the grid paper's lines"})
    target_distance: float | None = json_field(
        "target_distance", {**_LENGTH, "description": "taped from the first pose; absent: none"},
        required=False, default=None,
    )  # fmt: skip
    given: dict[str, str] | None = json_field(
        "given",
        {"type": "object", "propertyNames": {"enum": list(GUIDANCE_KEYS)},
         "additionalProperties": {"type": "string"},
         "description": "the text each setting the operator gave was given as"},
        required=False, default=None, compare=False, decode=dict,
    )  # fmt: skip

    def __post_init__(self) -> None:
        """Check the settings; each given one carries its text again."""
        for key, text in (self.given or {}).items():
            value = getattr(self, _ATTR[key])
            if value is None or float(text) != float(value):
                raise InputValueError(f"guidance.given.{key} {text!r} is not its value {value}")
            kind = GivenWhole if isinstance(value, int) else Given
            object.__setattr__(self, _ATTR[key], kind(value, text))
        if self.max_poses < 2 or not 0 <= self.min_gain <= 1:
            raise InputValueError("guidance: max_poses must be >= 2, min_gain a share")
        for key in ("target95", "reach", "spacing", "target_distance"):
            value = getattr(self, key)
            if value is not None:
                finite(value, f"guidance {key}", positive=True)

    @classmethod
    def of(
        cls, *, target95: float | None, max_poses: int, min_gain: float | None, reach: float,
        spacing: float, target_distance: float | None,
    ) -> GuidanceRecord:  # fmt: skip
        """The record of these settings, each given one's text kept (``min_gain`` None: 0)."""
        values = {"target95": target95, "max_poses": max_poses, "min_gain": min_gain or 0.0,
                  "reach": reach, "spacing": spacing,
                  "target_distance": target_distance}  # fmt: skip
        given = {k: t for k, a in _ATTR.items() if (t := given_text(values[a])) is not None}
        plain = {a: _plain(v) for a, v in values.items()}
        return cls(**plain, given=given or None)

    @classmethod
    def from_json(cls, data: Any) -> GuidanceRecord:
        """The record from its (schema-valid) JSON object."""
        return from_json(cls, data)


def _plain(value: Any) -> Any:
    if isinstance(value, Given):
        return float(value)
    return int(value) if isinstance(value, GivenWhole) else value


#: Each JSON key's attribute.
_ATTR = {"target_95": "target95", "max_poses": "max_poses", "min_gain": "min_gain",
         "reach": "reach", "spacing": "spacing", "target_distance": "target_distance"}  # fmt: skip


def guidance_schema() -> dict[str, Any]:
    """The JSON Schema of the session entry's ``guidance`` object."""
    return {**object_schema(GuidanceRecord), "additionalProperties": True}


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
