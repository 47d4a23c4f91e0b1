"""Declaring a typed entry once: each field's JSON name and JSON Schema in the dataclass.

Every JSON-encoded entry is a frozen dataclass whose fields carry their JSON name and
JSON Schema (:func:`json_field`); the entry's JSON Schema (written into every file), its
encoding and its decoding are all derived from that one declaration, in declaration
order, so the three can never disagree. A dotted JSON name (``resolution.translation``)
nests a field inside a JSON object.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import MISSING
from typing import Any, ClassVar, Self, TypeVar

from twopose.methods.targets import BoardPlacement
from twopose.values.checks import CAMERA_ID_PATTERN

__all__ = [
    "CAMERA_SCHEMA",
    "INDEX_SCHEMA",
    "TypedEntry",
    "entry",
    "from_json",
    "json_field",
    "object_schema",
    "to_json",
    "vec3_schema",
]

#: A whole number >= 0 (a trial, a pose, a count, a log time).
INDEX_SCHEMA: dict[str, Any] = {"type": "integer", "minimum": 0}


def vec3_schema(description: str) -> dict[str, Any]:
    """Three numbers: a point or a direction, with what it is."""
    return {
        "type": "array",
        "items": {"type": "number"},
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


#: A camera id (1-32 characters of ``[A-Za-z0-9_-]``).
CAMERA_SCHEMA: dict[str, Any] = {"type": "string", "pattern": CAMERA_ID_PATTERN}


def json_field(
    key: str,
    schema: dict[str, Any],
    *,
    required: bool = True,
    default: Any = MISSING,
    decode: Callable[[Any], Any] | None = None,
    compare: bool = True,
) -> Any:
    """A dataclass field with its JSON name, its JSON Schema and its decoding.

    Its JSON name may nest (dots); the field also says whether the schema requires it and how a
    JSON value becomes the attribute (``decode``); ``compare=False`` for a mutable value (kept out
    of equality and the hash).
    """
    meta = {"json": key, "schema": schema, "required": required, "decode": decode}
    return dataclasses.field(default=default, metadata=meta, compare=compare)


def _json_fields(cls: type[Any]) -> list[dataclasses.Field[Any]]:
    return [f for f in dataclasses.fields(cls) if "json" in f.metadata]


def object_schema(cls: type[Any]) -> dict[str, Any]:
    """``{"type": "object", "properties": ..., "required": ...}`` of a declared class."""
    props: dict[str, Any] = {}
    required: dict[str, list[str]] = {"": []}
    for f in _json_fields(cls):
        *parents, leaf = f.metadata["json"].split(".")
        target, where = props, ""
        for name in parents:  # a nested object, created where its first field is declared
            if name not in target:
                target[name] = {"type": "object", "properties": {}, "required": []}
                required[where + name] = target[name]["required"]
            if f.metadata["required"] and name not in required[where]:
                required[where].append(name)
            where += name + "."
            target = target[name]["properties"]
        target[leaf] = f.metadata["schema"]
        if f.metadata["required"]:
            required[where.rstrip(".")].append(leaf)
    return {"type": "object", "properties": props, "required": required[""]}


def _encode(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_encode(v) for v in value]
    if isinstance(value, BoardPlacement):
        return value.to_json()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_json(value)
    return value


def to_json(obj: Any) -> dict[str, Any]:
    """The JSON object of a declared dataclass instance, keys in declaration order."""
    out: dict[str, Any] = {}
    for f in _json_fields(type(obj)):
        if getattr(obj, f.name) is None and not _allows_null(f):
            continue  # an optional field left out (e.g. format 1.1's capture in 1.0 use)
        *parents, leaf = f.metadata["json"].split(".")
        target = out
        for name in parents:
            target = target.setdefault(name, {})
        target[leaf] = _encode(getattr(obj, f.name))
    return out


def _allows_null(f: dataclasses.Field[Any]) -> bool:
    kind = f.metadata["schema"].get("type")
    return bool(f.metadata["required"]) or kind == "null" or "null" in (kind or [])


T = TypeVar("T")


def from_json(cls: type[T], data: dict[str, Any]) -> T:
    """Build a declared dataclass from its (schema-valid) JSON object.

    Absent optional fields take their defaults, unknown fields are ignored (a newer minor
    may add some).
    """
    kwargs: dict[str, Any] = {}
    for f in _json_fields(cls):
        value: Any = data
        for name in f.metadata["json"].split("."):
            if not isinstance(value, dict) or name not in value:
                break
            value = value[name]
        else:
            decode = f.metadata["decode"]
            kwargs[f.name] = decode(value) if decode is not None else value
    return cls(**kwargs)


class TypedEntry:
    """Base of the JSON-encoded typed entries (frozen dataclasses made with :func:`entry`)."""

    TOPIC: ClassVar[str]
    SCHEMA_NAME: ClassVar[str]
    JSON_SCHEMA: ClassVar[dict[str, Any]]

    def to_json(self) -> dict[str, Any]:
        """The entry as its JSON object."""
        return to_json(self)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Self:
        """The entry from its JSON object, checked against the schema."""
        return from_json(cls, data)


E = TypeVar("E", bound=type[TypedEntry])


def entry(topic: str, name: str, description: str) -> Callable[[E], E]:
    """Class decorator (over ``@dataclass``): the topic, schema name and JSON Schema."""

    def decorate(cls: E) -> E:
        cls.TOPIC = topic
        cls.SCHEMA_NAME = f"twopose.{name}"
        body = object_schema(cls)
        cls.JSON_SCHEMA = {
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "$id": f"twopose.{name}",
            "title": f"twopose.{name}",
            "description": description,
            **body,
        }
        return cls

    return decorate
