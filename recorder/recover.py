"""Recover a session cut short (kill -9, power loss, full disk) into a valid, indexed session.

A session file is written as it goes: every typed entry and the end of every capture flush
a chunk. A file that was never closed has no summary, and the seeking reader sees nothing
in it. ``recover_session`` reads it front to back with the streaming reader, keeps every
chunk that decompresses and passes its CRC, skips corrupt ones, stops at the truncation,
and writes what it found into a new file with the session's channels rebuilt from the
``twopose`` metadata record (written before the first chunk, so it survives the loss of
the chunk that held the schema and channel records).

Frames that follow the last capture window (the capture in progress at the crash) are
kept and closed with an ``incomplete`` capture window, so nothing recorded is dropped. In
a two-camera session (format 1.6) each camera's frames after its last closed stream
window are closed as an ``incomplete`` window of the window announced open when they were
written (its trial and number), so a crash loses at most what never reached the disk of
the open window.
"""

from __future__ import annotations

import dataclasses
import struct
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.exceptions import EndOfFile, InvalidMagic, McapError, RecordLengthLimitExceeded
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from twopose.camera.model import Camera
from twopose.errors import InputValueError, SessionExistsError, SessionFormatError, TwoposeError
from twopose.format.entries import (
    METADATA_NAME,
    CaptureWindow,
    PairEntry,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    StreamWindow,
    cameras_from_metadata,
    decode_entry,
    encode_entry,
)
from twopose.format.messages import (
    Channels,
    calibration_message,
    calibration_topic,
    register_session_channels,
)
from twopose.format.pair_convert import pair_calibration
from twopose.format.reader import check_version, max_chunk_bytes

__all__ = ["RecoveryReport", "recover_session"]

RECOVERED_REASON = "recording interrupted; closed by twopose-record recover"


@dataclass(frozen=True, kw_only=True)
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
    closed_windows: int = 0  # a two-camera session's stream windows in progress, closed
    complete_windows: int = 0  # a two-camera session's stream windows closed complete

    def summary(self) -> str:
        frames = sum(n for t, n in self.messages.items() if t.endswith("/image"))
        lines = [
            f"recovered {self.source} -> {self.output}",
            f"  chunks kept {self.chunks_kept}, lost to corruption {self.chunks_lost}",
            f"  messages {sum(self.messages.values())}, frames {frames}, "
            + (
                f"complete stream windows {self.complete_windows}"
                if self.complete_windows
                else f"complete captures {self.complete_captures}"
            ),
        ]
        if self.closed_captures:
            lines.append(
                f"  {self.closed_captures} capture(s) in progress kept and marked incomplete"
            )
        if self.closed_windows:
            lines.append(
                f"  {self.closed_windows} stream window(s) in progress kept and marked incomplete"
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
        self.closed_windows: set[tuple[int, int, str] | int] = set()
        self.open_stream: dict[str, StreamWindow] = {}  # camera -> its window announced open
        self.complete_windows = 0

    @staticmethod
    def key(entry: PoseEntry | CaptureWindow) -> tuple[int, int, str] | int:
        """Format 1.1 binds a window to its pose by capture number; 1.0 by (trial, pose)."""
        if entry.capture is not None:
            return entry.capture
        return (entry.trial, entry.pose, entry.camera_id)


@dataclass(kw_only=True)
class _Salvage:
    """What the pass over a broken file has found so far."""

    out: _Output | None = None
    counts: Counter[str] = field(default_factory=Counter)
    kept: int = 0
    lost: int = 0
    truncated: bool = False
    stop_reason: str = ""
    pending: _Pending = field(default_factory=lambda: _Pending())
    complete: int = 0
    topics_by_id: dict[int, str] = field(default_factory=dict)
    session_seen: bool = False
    bad_entries: int = 0


def recover_session(broken: str | Path, output: str | Path) -> RecoveryReport:
    """Salvage every complete chunk of ``broken`` into the new session file ``output``.

    Parameters
    ----------
    broken : path-like
        An interrupted or damaged session file (read only).
    output : path-like
        The new session file written from what survived.

    Returns
    -------
    RecoveryReport
        What was kept and what was lost, by channel.

    Raises
    ------
    SessionExistsError
        ``output`` exists (never overwritten).
    SessionFormatError
        ``broken`` is not a twopose session (no ``twopose`` metadata record at its start).
    """
    src, dst = Path(broken), Path(output)
    if dst.exists() or dst.is_symlink():
        raise SessionExistsError(f"{dst} already exists; choose another output file")
    if src.resolve() == dst.resolve():
        raise TwoposeError("recover writes a new file; give an output path other than the input")
    if not src.is_file():  # a FIFO or a device would block the read forever
        raise SessionFormatError(f"{src} is not a regular file")
    try:
        stream = open(src, "rb")  # noqa: SIM115 - closed below
    except OSError as err:
        raise SessionFormatError(f"cannot open {src}: {err.strerror}") from err
    state = _Salvage()
    done = False
    try:
        _salvage(stream, src, dst, state)
        if state.out is None:
            raise SessionFormatError(
                f"{src}: no '{METADATA_NAME}' metadata record; no twopose session to recover"
            )
        if not state.session_seen:  # no chunk survived: the opening entries from metadata
            state.out.write_opening(state.counts)
        windows = _close_streams(state.out, state.pending, state.counts)
        closed, unassigned = _close_pending(state.out, state.pending, state.counts)
        done = True
        return RecoveryReport(
            source=src,
            output=dst,
            chunks_kept=state.kept,
            chunks_lost=state.lost,
            truncated=state.truncated,
            stop_reason=state.stop_reason,
            messages=dict(state.counts),
            complete_captures=state.complete,
            closed_captures=closed,
            unassigned_frames=unassigned,
            closed_windows=windows,
            complete_windows=state.pending.complete_windows,
        )
    finally:
        stream.close()
        if state.out is not None:
            state.out.close()
            if not done:  # no half-written output to block a re-run
                dst.unlink(missing_ok=True)


def _salvage(stream: IO[bytes], src: Path, dst: Path, state: _Salvage) -> None:
    """Read ``stream`` front to back, copying every readable chunk's messages to the output
    (opened at the ``twopose`` metadata record); stop at the first unreadable record."""
    # No record can be longer than the file: a garbled length is refused, not allocated.
    limit = max(src.stat().st_size, 1)
    records = StreamReader(stream, emit_chunks=True, record_size_limit=limit).records
    while True:
        start = stream.tell()  # where the next record begins: where a cut one is said to be
        try:
            record = next(records)
        except StopIteration:
            return
        except (McapError, ValueError, EOFError, OSError, struct.error, MemoryError) as err:
            state.truncated, state.stop_reason = True, _stop_reason(err, start, limit)
            return  # cut or garbled here: keep everything before
        if isinstance(record, Metadata) and record.name == METADATA_NAME and state.out is None:
            state.out = _open_output(dst, record.metadata)
            # The writer registers channels in a fixed order, so the broken file used
            # these ids; channel records recovered from its chunks override them.
            state.topics_by_id = {cid: topic for topic, cid in state.out.channel_ids.items()}
        elif isinstance(record, DataEnd | Footer):
            return
        elif isinstance(record, Chunk):
            if state.out is None:
                raise SessionFormatError(
                    f"{src}: no '{METADATA_NAME}' metadata record before the first chunk; "
                    "this is not a session written by twopose, or its start is damaged"
                )
            _copy_chunk(record, state.out, state)


def _stop_reason(err: Exception, start: int, size: int) -> str:
    """Where and why the read stopped, in words (an exception's own message may be empty:
    the reader's ``EndOfFile`` has none)."""
    cut = (
        ": the recording was not closed (killed, a power cut, a full disk) or the file was "
        "cut short in a copy"
    )
    if isinstance(err, EndOfFile | EOFError | struct.error) and start >= size:
        # Every record whole, the closing ones (data end, summary, footer) never written.
        what = (
            f"the file ends after its last whole record, at byte {size:,}, without the "
            f"records that close it{cut}"
        )
    elif isinstance(err, EndOfFile | EOFError | struct.error | RecordLengthLimitExceeded):
        # A record longer than what is left of the file: where a cut file ends.
        what = (
            f"its last record, from byte {start:,}, runs past the end of the file "
            f"({size:,} bytes){cut}"
        )
    elif isinstance(err, InvalidMagic):
        what = f"the bytes at {start:,} of {size:,} are not an MCAP record (garbled there)"
    else:
        said = str(err).strip() or type(err).__name__
        what = f"the record at byte {start:,} of {size:,} cannot be read ({said})"
    return f"{what}; everything before it is kept"


def _copy_chunk(chunk: Chunk, out: _Output, state: _Salvage) -> None:
    """A chunk's messages into the output, or count it lost if it is corrupt or larger
    than :func:`max_chunk_bytes` (never decompressed then)."""
    if chunk.uncompressed_size > max_chunk_bytes() or _zstd_declares_more(chunk):
        state.lost += 1
        return
    try:
        inner = breakup_chunk(chunk, validate_crc=True)
    except Exception:  # corrupt compressed data or CRC mismatch: skip this chunk
        state.lost += 1
        return
    state.kept += 1
    for r in inner:
        if isinstance(r, Channel):
            state.topics_by_id[r.id] = r.topic
        elif isinstance(r, Message):
            topic = state.topics_by_id.get(r.channel_id)
            if topic is None or topic not in out.channel_ids:
                continue
            state.session_seen |= topic == SessionInfo.TOPIC
            out.channels.writer.add_message(
                out.channel_ids[topic], r.log_time, r.data, r.publish_time, r.sequence
            )
            state.counts[topic] += 1
            try:
                state.complete += _track(topic, r, state.pending)
            except SessionFormatError:  # a malformed entry is copied, not followed
                state.bad_entries += 1
    if not state.session_seen:  # the first chunk was lost: restore its opening entries
        out.write_opening(state.counts)
        state.session_seen = True


def _zstd_declares_more(chunk: Chunk) -> bool:
    """A zstd frame whose own header declares more than the chunk's limit."""
    if chunk.compression != "zstd":
        return False
    import zstandard

    try:
        declared = zstandard.frame_content_size(chunk.data)
    except zstandard.ZstdError:
        return True
    return declared > max_chunk_bytes()


@dataclass(kw_only=True)
class _Output:
    """The new session file and what is needed to restore its opening entries."""

    channels: Channels
    stream: IO[bytes]
    info: SessionInfo
    cameras: list[Camera]
    ground: PlaneEntry | None
    start_ns: int
    pair: str = ""  # a two-camera session's /twopose/pair JSON (format 1.6), from metadata

    @property
    def channel_ids(self) -> dict[str, int]:
        return self.channels.ids

    def put(self, topic: str, log_time: int, data: bytes, counts: Counter[str]) -> None:
        self.channels.write(topic, data, log_time, 0)
        counts[topic] += 1

    def write_opening(self, counts: Counter[str]) -> None:
        """The session entry, calibrations and ground plane, from the metadata copy."""
        t0 = self.start_ns
        self.put(SessionInfo.TOPIC, t0, encode_entry(self.info), counts)
        for cam in self.cameras:
            msg = calibration_message(cam, t0)
            self.put(calibration_topic(cam.camera_id), t0, msg.SerializeToString(), counts)
        if self.ground is not None:
            self.put(PlaneEntry.TOPIC, t0, encode_entry(self.ground), counts)
        if self.pair:
            self.put(PairEntry.TOPIC, t0, self.pair.encode(), counts)

    def close(self) -> None:
        self.channels.writer.finish()
        self.stream.close()


def _open_output(dst: Path, metadata: dict[str, str]) -> _Output:
    check_version(dst, metadata.get("format_version", ""))
    try:
        info = decode_entry(SessionInfo.SCHEMA_NAME, metadata["session"].encode())
        ground_text = metadata.get("ground", "")
        ground = decode_entry(PlaneEntry.SCHEMA_NAME, ground_text.encode()) if ground_text else None
        start_ns = int(metadata.get("start_ns", "0"))
    except KeyError as err:
        raise SessionFormatError(
            f"the '{METADATA_NAME}' metadata lacks {err}; cannot rebuild the session"
        ) from err
    assert isinstance(info, SessionInfo)
    assert ground is None or isinstance(ground, PlaneEntry)
    cameras = cameras_from_metadata(metadata.get("cameras", "[]"))
    try:
        stream = open(dst, "xb")  # noqa: SIM115 - closed by _Output.close
    except FileExistsError as err:
        raise SessionExistsError(f"{dst} already exists; choose another output file") from err
    except OSError as err:
        raise TwoposeError(f"cannot create {dst}: {err.strerror}") from err
    writer = McapWriter(stream, compression=CompressionType.ZSTD)
    writer.start(profile="", library=f"twopose recover ({metadata.get('software_version', '?')})")
    pair = metadata.get("pair", "")
    if pair:  # checked before it is copied: a pair that does not decode is no session's
        decoded = decode_entry(PairEntry.SCHEMA_NAME, pair.encode())
        assert isinstance(decoded, PairEntry)
        try:
            pair_calibration(decoded)
        except InputValueError as err:
            raise SessionFormatError(
                f"the metadata's pair: {err}; cannot rebuild the session"
            ) from err
    channels = register_session_channels(
        writer, info.camera_ids, metadata.get("format_version", "1.0"), pair=bool(pair)
    )
    writer.add_metadata(METADATA_NAME, dict(metadata))
    return _Output(
        channels=channels,
        stream=stream,
        info=info,
        cameras=cameras,
        ground=ground,
        start_ns=start_ns,
        pair=pair,
    )


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
        pending.closed_windows.add(pending.key(window))
        return int(window.status == "complete")
    elif topic == StreamWindow.TOPIC:
        stream = decode_entry(StreamWindow.SCHEMA_NAME, message.data)
        assert isinstance(stream, StreamWindow)
        if stream.status == "open":
            pending.open_stream[stream.camera_id] = stream
            return 0
        pending.open_stream.pop(stream.camera_id, None)
        pending.complete_windows += stream.status == "complete"
        pending.frames[stream.camera_id] = [
            t for t in pending.frames.get(stream.camera_id, []) if t > stream.end_ns
        ]
    return 0


def _close_streams(out: _Output, pending: _Pending, counts: Counter[str]) -> int:
    """Close each camera's stream window in progress as incomplete, with its frames."""
    closed = 0
    for camera, opened in pending.open_stream.items():
        times = pending.frames.pop(camera, [])
        window = dataclasses.replace(
            opened,
            start_ns=min(times, default=opened.start_ns),
            end_ns=max(times, default=opened.start_ns),
            n_frames=len(times),
            status="incomplete",
            reason=RECOVERED_REASON,
        )
        out.put(StreamWindow.TOPIC, window.end_ns, encode_entry(window), counts)
        closed += 1
    return closed


def _close_pending(out: _Output, pending: _Pending, counts: Counter[str]) -> tuple[int, int]:
    """Close the capture in progress (frames after the last window) as incomplete."""
    closed = unassigned = 0
    pose = pending.last_pose
    for camera, times in pending.frames.items():
        if not times:
            continue
        if pose is None or pose.camera_id != camera or pending.key(pose) in pending.closed_windows:
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
            capture=pose.capture,
        )
        out.put(CaptureWindow.TOPIC, max(times), encode_entry(window), counts)
        closed += 1
    return closed, unassigned
