"""One way to register schemas and channels on an MCAP writer and write to them.

Every MCAP file twopose writes (sessions, recovered sessions, results.mcap) goes through
:class:`Channels`: a schema is registered once, channels are looked up by topic, and
message counts per topic are kept. :func:`register_session_channels` fixes the order of a
session's records, which makes channel ids a function of the camera ids alone (``recover``
relies on it when the chunk that held the channel records is lost).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from mcap.writer import Writer as McapWriter
from mcap_protobuf.schema import build_file_descriptor_set

from twopose.format.entries import (
    ENTRIES_1_0,
    FORMAT_VERSION,
    PAIR_SESSION_ENTRIES,
    CaptureDecision,
    TypedEntry,
)
from twopose.format.messages import (
    SESSION_PROTOBUF,
    TF_TOPIC,
    calibration_topic,
    image_topic,
)

__all__ = ["Channels", "register_session_channels"]


class Channels:
    """The schemas and channels of one MCAP writer, by topic."""

    def __init__(self, writer: McapWriter) -> None:
        self.writer = writer
        self.ids: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self._schemas: dict[str, int] = {}

    def protobuf_schemas(self, *classes: Any) -> None:
        """Register these Foxglove message types' schemas now, in this order."""
        for pb in classes:
            name = pb.DESCRIPTOR.full_name
            if name not in self._schemas:
                self._schemas[name] = self.writer.register_schema(
                    name=name,
                    encoding="protobuf",
                    data=build_file_descriptor_set(pb).SerializeToString(),
                )

    def protobuf(self, topic: str, message_class: Any) -> int:
        """A protobuf channel on ``topic`` (its schema registered on first use)."""
        self.protobuf_schemas(message_class)
        schema_id = self._schemas[message_class.DESCRIPTOR.full_name]
        self.ids[topic] = self.writer.register_channel(topic, "protobuf", schema_id)
        return self.ids[topic]

    def json_entry(self, cls: type[TypedEntry]) -> int:
        """The JSON channel of a typed entry, with its JSON Schema."""
        if cls.SCHEMA_NAME not in self._schemas:
            self._schemas[cls.SCHEMA_NAME] = self.writer.register_schema(
                name=cls.SCHEMA_NAME,
                encoding="jsonschema",
                data=json.dumps(cls.JSON_SCHEMA).encode(),
            )
        self.ids[cls.TOPIC] = self.writer.register_channel(
            cls.TOPIC, "json", self._schemas[cls.SCHEMA_NAME]
        )
        return self.ids[cls.TOPIC]

    def write(self, topic: str, data: bytes, log_time_ns: int, sequence: int) -> None:
        """One message (publish time = log time)."""
        self.writer.add_message(
            channel_id=self.ids[topic],
            log_time=log_time_ns,
            publish_time=log_time_ns,
            data=data,
            sequence=sequence,
        )
        self.counts[topic] = self.counts.get(topic, 0) + 1


def register_session_channels(
    writer: McapWriter,
    camera_ids: Sequence[str],
    format_version: str = FORMAT_VERSION,
    *,
    pair: bool = False,
) -> Channels:
    """Every schema and channel of a session, in the documented order.

    The order ``docs/session-format.md`` fixes: the format 1.0 typed entries, the Foxglove schemas,
    ``/tf``, per camera its calibration and image channels, then (format 1.1)
    ``/twopose/decision``, then in a two-camera session (``pair``, format 1.6) its entries'
    (:data:`~twopose.format.entries.PAIR_SESSION_ENTRIES`). Appending each version's channels
    keeps the earlier ids, so ``recover`` rebuilds files of every version, and a one-camera
    session registers the channels it did before.
    """
    channels = Channels(writer)
    for cls in ENTRIES_1_0:
        channels.json_entry(cls)
    channels.protobuf_schemas(*SESSION_PROTOBUF)
    calibration, image, transform = SESSION_PROTOBUF
    channels.protobuf(TF_TOPIC, transform)
    for cid in camera_ids:
        channels.protobuf(calibration_topic(cid), calibration)
        channels.protobuf(image_topic(cid), image)
    if format_version != "1.0":
        channels.json_entry(CaptureDecision)
    if pair:
        for cls in PAIR_SESSION_ENTRIES:
            channels.json_entry(cls)
    return channels
