"""declared: each field declared once; the schema, encoding and decoding follow from it."""

from __future__ import annotations

import dataclasses

from twopose.format.declared import from_json, json_field, object_schema, to_json


def test_dotted_names_nest_and_required_follows_the_declaration() -> None:
    @dataclasses.dataclass(frozen=True)
    class Probe:
        a: int = json_field("a", {"type": "integer"})
        lo: float = json_field("range.lo", {"type": "number"})
        hi: float = json_field("range.hi", {"type": "number"}, required=False, default=1.0)
        c: str = json_field("c", {"type": "string"}, required=False, default="")

    schema = object_schema(Probe)
    assert schema["required"] == ["a", "range"]
    assert schema["properties"]["range"] == {
        "type": "object",
        "properties": {"lo": {"type": "number"}, "hi": {"type": "number"}},
        "required": ["lo"],
    }


def test_a_declared_dataclass_round_trips_and_nests_its_dotted_names() -> None:
    @dataclasses.dataclass(frozen=True)
    class Probe:
        a: int = json_field("a", {"type": "integer"})
        lo: float = json_field("range.lo", {"type": "number"})
        hi: float = json_field("range.hi", {"type": "number"}, required=False, default=1.0)

    probe = Probe(a=1, lo=2.0, hi=3.0)
    assert to_json(probe) == {"a": 1, "range": {"lo": 2.0, "hi": 3.0}}
    assert from_json(Probe, {"a": 1, "range": {"lo": 2.0, "hi": 3.0}}) == probe
    assert from_json(Probe, {"a": 1, "range": {"lo": 2.0}}).hi == 1.0  # absent: its default
