"""Recover a session cut short (kill -9, power loss, full disk) into a valid, indexed session.

A session file is written as it goes: every typed entry and the end of every capture flush
a chunk. A file that was never closed has no summary, and the seeking reader sees nothing
in it. ``recover_session`` reads it front to back with the streaming reader, keeps every
chunk that decompresses and passes its CRC, skips corrupt ones, stops at the truncation,
and writes what it found into a new file with the session's channels rebuilt from the
``twopose`` metadata record (written before the first chunk, so it survives the loss of
the chunk that held the schema and channel records).

Frames that follow the last capture window (the capture in progress at the crash) are
kept and closed with an ``incomplete`` capture window, so nothing recorded is dropped.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from recorder.errors import SessionExistsError, SessionFormatError, TwoposeError
from recorder.session import (
    METADATA_NAME,
    Camera,
    CaptureWindow,
    GroundPlane,
    PoseEntry,
    SessionInfo,
    _check_version,
    calibration_message,
    calibration_topic,
    cameras_from_metadata,
    decode_entry,
    encode_entry,
    register_channels,
)

__all__ = ["RecoveryReport", "recover_session"]

RECOVERED_REASON = "recording interrupted; closed by twopose-record recover"


@dataclass(frozen=True)
class RecoveryReport:
    """What ``recover_session`` kept and what it could not."""

    source: Path
    output: Path
    chunks_kept: int
    chunks_lost: int
    truncated: bool
    stop_reason: str
    messages: dict[str, int] = field(default_factory=dict)
    complete_captures: int = 0
    closed_captures: int = 0  # captures in progress, kept and marked incomplete
    unassigned_frames: int = 0  # frames with no pose to attach them to (kept on their topic)

    def summary(self) -> str:
        frames = sum(n for t, n in self.messages.items() if t.endswith("/image"))
        lines = [
            f"recovered {self.source} -> {self.output}",
            f"  chunks kept {self.chunks_kept}, lost to corruption {self.chunks_lost}",
            f"  messages {sum(self.messages.values())}, frames {frames}, "
            f"complete captures {self.complete_captures}",
        ]
        if self.closed_captures:
            lines.append(
                f"  {self.closed_captures} capture(s) in progress kept and marked incomplete"
            )
        if self.unassigned_frames:
            lines.append(
                f"  {self.unassigned_frames} frame(s) with no pose entry, kept as they are"
            )
        lines.append(
            f"  the file ended early: {self.stop_reason}"
            if self.truncated
            else "  the file ended cleanly"
        )
        return "\n".join(lines)


class _Pending:
    """Frames seen since the last capture window, per camera, and the last pose entry."""

    def __init__(self) -> None:
        self.frames: dict[str, list[int]] = {}  # camera -> log times
        self.last_pose: PoseEntry | None = None
        self.closed_windows: set[tuple[int, int, str]] = set()


def recover_session(broken: str | Path, output: str | Path) -> RecoveryReport:
    """Salvage every complete chunk of ``broken`` into the new session file ``output``.

    Raises
    ------
    SessionExistsError
        ``output`` exists (never overwritten).
    SessionFormatError
        ``broken`` is not a twopose session (no ``twopose`` metadata record at its start).
    """
    src, dst = Path(broken), Path(output)
    if dst.exists():
        raise SessionExistsError(f"{dst} already exists; choose another output file")
    if src.resolve() == dst.resolve():
        raise TwoposeError("recover writes a new file; give an output path other than the input")
    try:
        stream = open(src, "rb")  # noqa: SIM115 - closed below
    except OSError as err:
        raise SessionFormatError(f"cannot open {src}: {err.strerror}") from err
    out: _Output | None = None
    counts: Counter[str] = Counter()
    kept = lost = 0
    truncated, stop_reason = False, ""
    pending = _Pending()
    complete = closed = 0
    try:
        records = StreamReader(stream, emit_chunks=True, record_size_limit=1 << 30).records
        topics_by_id: dict[int, str] = {}
        session_seen = False
        while True:
            try:
                record = next(records)
            except StopIteration:
                break
            except (McapError, ValueError, EOFError, OSError) as err:  # cut or garbled
                truncated, stop_reason = True, f"{type(err).__name__}: {err}"
                break
            if isinstance(record, Metadata) and record.name == METADATA_NAME and out is None:
                out = _open_output(dst, record.metadata)
                # The writer registers channels in a fixed order, so the broken file used
                # these ids; channel records recovered from its chunks override them.
                topics_by_id = {cid: topic for topic, cid in out.channel_ids.items()}
                continue
            if isinstance(record, DataEnd | Footer):
                break
            if not isinstance(record, Chunk):
                continue
            if out is None:
                raise SessionFormatError(
                    f"{src}: no '{METADATA_NAME}' metadata record before the first chunk; "
                    "this is not a session written by twopose, or its start is damaged"
                )
            try:
                inner = breakup_chunk(record, validate_crc=True)
            except Exception:  # corrupt compressed data or CRC mismatch: skip this chunk
                lost += 1
                continue
            kept += 1
            for r in inner:
                if isinstance(r, Channel):
                    topics_by_id[r.id] = r.topic
                elif isinstance(r, Message):
                    topic = topics_by_id.get(r.channel_id)
                    if topic is None or topic not in out.channel_ids:
                        continue
                    session_seen |= topic == SessionInfo.TOPIC
                    out.writer.add_message(
                        out.channel_ids[topic], r.log_time, r.data, r.publish_time, r.sequence
                    )
                    counts[topic] += 1
                    complete += _track(topic, r, pending)
            if not session_seen:  # the first chunk was lost: restore its opening entries
                out.write_opening(counts)
                session_seen = True
        if out is None:
            raise SessionFormatError(
                f"{src}: no '{METADATA_NAME}' metadata record; no twopose session to recover"
            )
        closed, unassigned = _close_pending(out, pending, counts)
        return RecoveryReport(
            src, dst, kept, lost, truncated, stop_reason, dict(counts), complete, closed, unassigned
        )
    finally:
        stream.close()
        if out is not None:
            out.close()


@dataclass
class _Output:
    """The new session file and what is needed to restore its opening entries."""

    writer: McapWriter
    stream: IO[bytes]
    channel_ids: dict[str, int]
    info: SessionInfo
    cameras: list[Camera]
    ground: GroundPlane | None
    start_ns: int

    def put(self, topic: str, log_time: int, data: bytes, counts: Counter[str]) -> None:
        self.writer.add_message(self.channel_ids[topic], log_time, data, log_time, 0)
        counts[topic] += 1

    def write_opening(self, counts: Counter[str]) -> None:
        """The session entry, calibrations and ground plane, from the metadata copy."""
        t0 = self.start_ns
        self.put(SessionInfo.TOPIC, t0, encode_entry(self.info), counts)
        for cam in self.cameras:
            msg = calibration_message(cam, t0)
            self.put(calibration_topic(cam.camera_id), t0, msg.SerializeToString(), counts)
        if self.ground is not None:
            self.put(GroundPlane.TOPIC, t0, encode_entry(self.ground), counts)

    def close(self) -> None:
        self.writer.finish()
        self.stream.close()


def _open_output(dst: Path, metadata: dict[str, str]) -> _Output:
    _check_version(dst, metadata.get("format_version", ""))
    try:
        info = decode_entry(SessionInfo.SCHEMA_NAME, metadata["session"].encode())
        ground_text = metadata.get("ground", "")
        ground = (
            decode_entry(GroundPlane.SCHEMA_NAME, ground_text.encode()) if ground_text else None
        )
        start_ns = int(metadata.get("start_ns", "0"))
    except KeyError as err:
        raise SessionFormatError(
            f"the '{METADATA_NAME}' metadata lacks {err}; cannot rebuild the session"
        ) from err
    assert isinstance(info, SessionInfo)
    assert ground is None or isinstance(ground, GroundPlane)
    cameras = cameras_from_metadata(metadata.get("cameras", "[]"))
    try:
        stream = open(dst, "xb")  # noqa: SIM115 - closed by _Output.close
    except FileExistsError as err:
        raise SessionExistsError(f"{dst} already exists; choose another output file") from err
    writer = McapWriter(stream, compression=CompressionType.ZSTD)
    writer.start(profile="", library=f"twopose recover ({metadata.get('software_version', '?')})")
    channel_ids = register_channels(writer, info.camera_ids)
    writer.add_metadata(METADATA_NAME, dict(metadata))
    return _Output(writer, stream, channel_ids, info, cameras, ground, start_ns)


def _track(topic: str, message: Message, pending: _Pending) -> int:
    """Follow poses, frames and windows; returns 1 for a complete capture window."""
    if topic == PoseEntry.TOPIC:
        entry = decode_entry(PoseEntry.SCHEMA_NAME, message.data)
        assert isinstance(entry, PoseEntry)
        pending.last_pose = entry
    elif topic.endswith("/image"):
        camera = topic.split("/")[3]
        pending.frames.setdefault(camera, []).append(message.log_time)
    elif topic == CaptureWindow.TOPIC:
        window = decode_entry(CaptureWindow.SCHEMA_NAME, message.data)
        assert isinstance(window, CaptureWindow)
        pending.frames[window.camera_id] = [
            t for t in pending.frames.get(window.camera_id, []) if t > window.end_ns
        ]
        pending.closed_windows.add((window.trial, window.pose, window.camera_id))
        return int(window.status == "complete")
    return 0


def _close_pending(out: _Output, pending: _Pending, counts: Counter[str]) -> tuple[int, int]:
    """Close the capture in progress (frames after the last window) as incomplete."""
    closed = unassigned = 0
    pose = pending.last_pose
    for camera, times in pending.frames.items():
        if not times:
            continue
        if (
            pose is None
            or pose.camera_id != camera
            or (pose.trial, pose.pose, camera) in pending.closed_windows
        ):
            unassigned += len(times)
            continue
        window = CaptureWindow(
            trial=pose.trial,
            pose=pose.pose,
            camera_id=camera,
            start_ns=min(times),
            end_ns=max(times),
            n_frames=len(times),
            status="incomplete",
            reason=RECOVERED_REASON,
        )
        out.put(CaptureWindow.TOPIC, max(times), encode_entry(window), counts)
        closed += 1
    return closed, unassigned
