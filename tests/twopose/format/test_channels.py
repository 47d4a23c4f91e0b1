"""The channels of twopose.format.messages directly: a session's channel ids depend on its
camera ids alone (recover rebuilds lost channel records from them), 1.1 appends its channel
after the 1.0 ones, and each schema is registered once."""

from __future__ import annotations

import io

from mcap.reader import make_reader
from mcap.writer import Writer as McapWriter

from twopose.format.entries import CaptureDecision
from twopose.format.messages import register_session_channels


def _write(camera_ids: list[str], version: str) -> tuple[dict[str, int], bytes]:
    buffer = io.BytesIO()
    writer = McapWriter(buffer)
    writer.start()
    channels = register_session_channels(writer, camera_ids, version)
    channels.write("/tf", b"", 1, 0)
    channels.write("/tf", b"", 2, 1)
    assert channels.counts == {"/tf": 2}
    writer.finish()
    return channels.ids, buffer.getvalue()


def test_channel_ids_are_a_function_of_the_camera_ids() -> None:
    first, _ = _write(["cam0", "right"], "1.1")
    again, _ = _write(["cam0", "right"], "1.1")
    assert first == again
    per_camera = [t for t in first if t.startswith("/twopose/camera/")]
    assert per_camera == [
        "/twopose/camera/cam0/calibration",
        "/twopose/camera/cam0/image",
        "/twopose/camera/right/calibration",
        "/twopose/camera/right/image",
    ]


def test_format_1_1_appends_the_decision_channel_and_keeps_the_1_0_ids() -> None:
    old, _ = _write(["cam0"], "1.0")
    new, _ = _write(["cam0"], "1.1")
    assert CaptureDecision.TOPIC not in old
    assert {t: new[t] for t in old} == old
    assert new[CaptureDecision.TOPIC] == max(new.values())


def test_each_schema_is_registered_once_and_the_file_reads_back() -> None:
    ids, data = _write(["a", "b", "c"], "1.1")
    summary = make_reader(io.BytesIO(data)).get_summary()
    assert summary is not None
    names = [s.name for s in summary.schemas.values()]
    assert len(names) == len(set(names))
    assert "foxglove.CompressedImage" in names
    assert {c.topic for c in summary.channels.values()} == set(ids)
    assert summary.statistics is not None
    assert summary.statistics.message_count == 2
