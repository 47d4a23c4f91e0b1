"""A session's guidance settings as its session entry records them (format 1.5).

What suggested a recording's poses and ended its trials: the stop rule's precision, a
trial's most poses, the least gain, the suggestions' reach and grid, the taped target
distance. Recorded in ``/twopose/session``'s ``guidance`` object, so that a continuation
(``twopose-record new --continue``) takes every one of them, and says which; each as a
number, and where the operator gave it, beside it the text it was given as (``given``),
so that it is shown back as given (:class:`twopose.values.checks.Given`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from twopose.errors import InputValueError
from twopose.format.declared import from_json, json_field, object_schema
from twopose.values.checks import Given, GivenWhole, finite, given_text

__all__ = ["GUIDANCE_KEYS", "GuidanceRecord", "guidance_schema"]

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
