"""The session reader: a checked, seeking view of one session file, and session discovery."""

from __future__ import annotations

import re
import shlex
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any, Self

from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from mcap.reader import make_reader
from mcap.writer import MCAP0_MAGIC as MCAP_MAGIC

from twopose.camera.model import Camera
from twopose.errors import InputValueError, SessionFormatError, SessionVersionError, TwoposeError
from twopose.format.entries import (
    FORMAT_MAJOR,
    METADATA_NAME,
    TYPED_ENTRIES,
    PairEntry,
    PlaneEntry,
    SessionInfo,
    TypedEntry,
    decode_entry,
)
from twopose.format.messages import (
    RESULTS_TOPIC_PREFIX,
    SESSION_PROTOBUF,
    Frame,
    calibration_topic,
    camera_from_message,
)
from twopose.format.pair_convert import pair_calibration

if TYPE_CHECKING:
    from twopose.pair.calibration import PairCalibration

__all__ = [
    "STAGING_FOLDER",
    "Entry",
    "SessionReader",
    "check_version",
    "find_sessions",
    "is_results_file",
    "max_chunk_bytes",
    "records_capture_times",
    "recover_command",
]


def max_chunk_bytes() -> int:
    """The largest chunk (uncompressed) a reader decompresses.

    256 MB, or ``TWOPOSE_MAX_CHUNK_MB`` (:data:`twopose.values.environment.MAX_CHUNK_MB`, in the
    analysis cache's key). twopose writes chunks of one capture (a few MB); a larger
    declared size is a damaged file or a decompression bomb.
    """
    from twopose.values.environment import MAX_CHUNK_MB

    megabytes = MAX_CHUNK_MB.read()
    assert megabytes is not None  # a number with a default
    return int(megabytes * 1_000_000)


Entry = TypedEntry | Frame | Camera | Any  # Any: a decoded foxglove.FrameTransform

_FOXGLOVE_CLASSES: dict[str, Any] = {cls.DESCRIPTOR.full_name: cls for cls in SESSION_PROTOBUF}
_JSON_SCHEMAS = {cls.SCHEMA_NAME for cls in TYPED_ENTRIES}


def recover_command(path: str | Path) -> str:
    """The command that salvages an interrupted session, ready to paste into a shell."""
    return f"twopose-record recover {shlex.quote(str(path))} -o FIXED.mcap"


def records_capture_times(version: str) -> bool:
    """Whether a file of format ``version`` records its frames' capture times (1.6 on)."""
    match = re.fullmatch(r"(\d{1,9})\.(\d{1,9})", version)
    return match is not None and (int(match.group(1)), int(match.group(2))) >= (1, 6)


def check_version(path: Path, version: str) -> None:
    """Refuse a format version that is not MAJOR.MINOR, or whose MAJOR is newer than ours."""
    from twopose import __version__

    match = re.fullmatch(r"(\d{1,9})\.(\d{1,9})", version)
    if match is None:
        raise SessionFormatError(f"{path}: format version {version!r} is not MAJOR.MINOR")
    if int(match.group(1)) > FORMAT_MAJOR:
        raise SessionVersionError(
            f"{path} uses twopose session format {version}, but this twopose ({__version__}) "
            f"reads format {FORMAT_MAJOR}.x only. Upgrade twopose to read it."
        )


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
        self._reader: Any = None
        self.format_version = ""
        self.software_version = ""
        self._info: SessionInfo | None = None
        self._cameras: dict[str, Camera] = {}
        self._ground: PlaneEntry | None = None
        self._pair: PairEntry | None = None
        self._pair_calibration: PairCalibration | None = None
        self._capture_times = False

    def __enter__(self) -> Self:
        """Open the file and read its summary, metadata and typed entries."""
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
        """Close the file."""
        if self._stream is not None:
            self._stream.close()
            self._stream = None

    def _fail(self, what: str, err: BaseException) -> SessionFormatError:
        return SessionFormatError(
            f"{self.path}: {what} ({type(err).__name__}: {err}). If the recording was "
            f"interrupted, `{recover_command(self.path)}` salvages it."
        )

    def _starts_as_mcap(self) -> bool:
        """Whether the file begins with MCAP's magic (a cut or garbled MCAP file does)."""
        assert self._stream is not None
        self._stream.seek(0)
        head = self._stream.read(len(MCAP_MAGIC))
        self._stream.seek(0)
        return bool(head == MCAP_MAGIC)

    def _begins(self) -> str:
        """``; it begins "format = 1"``: the first bytes, where they are text."""
        assert self._stream is not None
        self._stream.seek(0)
        head = self._stream.read(24)
        self._stream.seek(0)
        text = head.decode("utf-8", errors="replace").split("\n")[0]
        return f'; it begins "{text}"' if text.isprintable() and text.strip() else ""

    def _open(self) -> None:
        """Read the summary and metadata, check the version, then the opening entries."""
        assert self._stream is not None
        try:
            reader = make_reader(self._stream, validate_crcs=self.validate_crcs)
            summary = reader.get_summary()
            metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        except TwoposeError:
            raise
        except Exception as err:
            if not self._starts_as_mcap():  # a TOML, an image: nothing to recover
                raise SessionFormatError(
                    f"{self.path}: not an MCAP file (it does not begin with MCAP's magic "
                    f"bytes{self._begins()}): give a session file recorded by twopose"
                ) from err
            raise self._fail("not a readable MCAP file", err) from err
        if summary is None:
            raise SessionFormatError(
                f"{self.path}: the file has no summary section, so it was truncated or never "
                f"closed. `{recover_command(self.path)}` salvages it."
            )
        self._check_chunk_sizes(summary)
        if METADATA_NAME not in metadata:
            raise SessionFormatError(
                f"{self.path}: no '{METADATA_NAME}' metadata record; this MCAP file is not a "
                "twopose session"
            )
        self.format_version = metadata[METADATA_NAME].get("format_version", "")
        self.software_version = metadata[METADATA_NAME].get("software_version", "")
        check_version(self.path, self.format_version)
        self._capture_times = records_capture_times(self.format_version)
        self._reader = reader
        self._read_opening([c.topic for c in summary.channels.values()])

    def _check_chunk_sizes(self, summary: Any) -> None:
        """Refuse a file whose index declares a chunk over the limit.

        The limit is :func:`max_chunk_bytes`; the check runs before anything is decompressed.
        """
        limit = max_chunk_bytes()
        for index in summary.chunk_indexes:
            if index.uncompressed_size > limit:
                raise SessionFormatError(
                    f"{self.path}: a chunk at byte {index.chunk_start_offset} declares "
                    f"{index.uncompressed_size / 1e6:.0f} MB uncompressed, over the limit of "
                    f"{limit / 1e6:g} MB; a damaged file or a decompression bomb "
                    "(TWOPOSE_MAX_CHUNK_MB raises the limit)"
                )

    def _read_opening(self, topics: list[str]) -> None:
        """The session entry, the ground plane and every camera's calibration."""
        wanted = [SessionInfo.TOPIC, PlaneEntry.TOPIC, PairEntry.TOPIC]
        wanted += [t for t in topics if t.endswith("/calibration")]
        for item in self.iter_entries(topics=[t for t in wanted if t in topics]):
            if isinstance(item, SessionInfo) and self._info is None:
                self._info = item
            elif isinstance(item, PlaneEntry):
                self._ground = item
            elif isinstance(item, PairEntry) and self._pair is None:
                self._pair = item
            elif isinstance(item, Camera):
                self._cameras[item.camera_id] = item
        if self._info is None:
            raise SessionFormatError(
                f"{self.path}: no {SessionInfo.TOPIC} message; not a twopose session"
            )
        if self._info.format_version != self.format_version:
            raise SessionFormatError(
                f"{self.path}: the session entry says format {self._info.format_version} but "
                f"the twopose metadata says {self.format_version}; the file was not written "
                "consistently (was it edited?)"
            )
        for cid, sigma in (self._info.intrinsics_sigma or {}).items():
            if cid in self._cameras:  # format 1.2: the calibration's sigma with its camera
                camera = self._cameras[cid]
                self._cameras[cid] = Camera(
                    camera_id=cid, intrinsics=camera.intrinsics, intrinsics_sigma=sigma
                )
        missing = [c for c in self._info.camera_ids if c not in self._cameras]
        if missing:
            raise SessionFormatError(
                f"{self.path}: no calibration for camera(s) {', '.join(missing)} "
                f"on {calibration_topic(missing[0])}"
            )
        if self._pair is not None:
            self._check_pair(self._pair)

    def _check_pair(self, pair: PairEntry) -> None:
        """A two-camera session's pair: of its two cameras, their intrinsics its own."""
        ids = (pair.camera1, pair.camera2)
        if self.info.camera_ids != ids:
            raise SessionFormatError(
                f"{self.path}: the pair's cameras {list(ids)} are not the session's "
                f"{list(self.info.camera_ids)}; the file was not written consistently"
            )
        try:
            calibration = pair_calibration(pair)
        except InputValueError as err:
            raise SessionFormatError(f"{self.path}: its pair on /twopose/pair: {err}") from err
        for cid, intrinsics in zip(ids, (calibration.intrinsics1, calibration.intrinsics2),
                                   strict=True):  # fmt: skip
            if self._cameras[cid].intrinsics != intrinsics:
                raise SessionFormatError(
                    f"{self.path}: camera {cid}'s calibration differs from the pair's "
                    "intrinsics; the file was not written consistently"
                )
        if calibration.units != self.info.units:
            raise SessionFormatError(
                f"{self.path}: the pair is in {calibration.units}, the session in "
                f"{self.info.units}; the file was not written consistently"
            )
        self._pair_calibration = calibration

    @property
    def info(self) -> SessionInfo:
        """What the session is (method, units, cameras)."""
        assert self._info is not None, "use SessionReader as a context manager"
        return self._info

    @property
    def cameras(self) -> dict[str, Camera]:
        """The session's cameras by id."""
        return dict(self._cameras)

    @property
    def ground(self) -> PlaneEntry | None:
        """The ground plane, if the session has one."""
        return self._ground

    @property
    def pair(self) -> PairCalibration | None:
        """A two-camera session's pair (format 1.6), in the session's units; else None."""
        return self._pair_calibration

    @property
    def records_capture_times(self) -> bool:
        """Whether its frames carry their capture times (format 1.6 on)."""
        return self._capture_times

    def message_counts(self) -> dict[str, int]:
        """Messages per topic, from the summary statistics."""
        assert self._reader is not None
        summary = self._reader.get_summary()
        assert summary is not None
        assert summary.statistics is not None
        return {  # a count for a channel the summary does not declare is not ours to name
            summary.channels[cid].topic: n
            for cid, n in summary.statistics.channel_message_counts.items()
            if cid in summary.channels
        }

    def iter_entries(
        self,
        topics: Iterable[str] | None = None,
        *,
        start_ns: int | None = None,
        end_ns: int | None = None,
    ) -> Iterator[Entry]:
        """Decoded messages in log-time order: typed entries, frames, transforms, cameras.

        Parameters
        ----------
        topics : iterable of str, optional
            Only these topics (all when None).
        start_ns, end_ns : int, optional
            Only messages with ``start_ns <= log_time <= end_ns`` (the index skips the
            chunks outside).
        """
        if self._reader is None or self._stream is None:
            raise TwoposeError("use SessionReader as a context manager (the file is closed)")
        topic_list = None if topics is None else list(topics)
        try:
            for schema, channel, message in self._reader.iter_messages(
                topics=topic_list,
                starting_at=start_ns,
                ending_at=end_ns,
                log_time_order=True,
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
        if channel.message_encoding == "json" and schema.name in _JSON_SCHEMAS:
            return decode_entry(schema.name, message.data)
        pb_class = _FOXGLOVE_CLASSES.get(schema.name)
        if channel.message_encoding != "protobuf" or pb_class is None:
            return None  # a channel this version does not know (format 1.x may add some)
        try:
            decoded = pb_class.FromString(message.data)
        except Exception as err:  # protobuf's DecodeError and friends
            raise self._fail(f"{topic} holds an undecodable {schema.name}", err) from err
        if isinstance(decoded, CompressedImage):
            # The topic says whose frame it is (a frame_id naming another camera must not
            # silently move the frame out of its camera's captures).
            parts = topic.split("/")
            camera = parts[3] if len(parts) == 5 and parts[4] == "image" else ""
            return Frame(
                camera_id=camera or decoded.frame_id.removeprefix("camera_"),
                log_time_ns=message.log_time,
                sequence=message.sequence,
                format=decoded.format,
                data=bytes(decoded.data),
                capture_ns=decoded.timestamp.ToNanoseconds() if self._capture_times else None,
            )
        if isinstance(decoded, CameraCalibration):
            return camera_from_message(decoded)
        return decoded


#: Where an analysis run writes until it commits (inside its --out folder): never searched
#: for sessions (a run killed there leaves half-written results files).
STAGING_FOLDER = ".twopose-staging"


def find_sessions(paths: Iterable[Path | str], *, unique: bool = True) -> list[Path]:
    """Session files named by ``paths``: files as given, folders searched recursively.

    A folder yields every regular file whose name ends in ``.mcap`` in any case, through
    symbolic links to folders too (each real folder once, so a link cycle ends); a run's
    staging folder (:data:`STAGING_FOLDER`) is not searched. Sorted within each folder
    so that results do not depend on directory order. A file named twice (by two paths, a
    folder and a file in it, a symbolic link) is listed once, unless ``unique`` is False
    (the caller says so: :func:`analysis.batch.inputs.resolve_inputs`).
    Raises :class:`~twopose.errors.InputValueError` for a path that does not exist.
    """
    found: list[Path] = []
    for raw in paths:
        p = Path(raw)
        if p.is_dir():
            found += _search(p)
        elif p.is_file():
            found.append(p)
        elif p.exists():  # a FIFO or a device would block the reader forever
            raise InputValueError(f"{p} is not a regular file")
        else:
            raise InputValueError(f"{p} does not exist")
    if not unique:
        return found
    seen: set[Path] = set()
    distinct = []
    for p in found:
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            distinct.append(p)
    return distinct


def _search(folder: Path) -> list[Path]:
    """Every ``*.mcap`` (any case) below ``folder``, following links to folders once each."""
    import os

    found: list[Path] = []
    visited: set[tuple[int, int]] = set()
    for here, dirs, files in os.walk(folder, followlinks=True):
        try:
            stat = os.stat(here)
        except OSError:  # vanished or unreadable while walking: nothing of it to list
            dirs[:] = []
            continue
        if (stat.st_dev, stat.st_ino) in visited:  # reached again through a link: a cycle
            dirs[:] = []
            continue
        visited.add((stat.st_dev, stat.st_ino))
        dirs[:] = sorted(d for d in dirs if d != STAGING_FOLDER)
        for name in files:
            q = Path(here) / name
            if name.lower().endswith(".mcap") and q.is_file():
                found.append(q)
    return sorted(found)


def is_results_file(path: str | Path) -> bool:
    """Whether ``path`` is an analysis results file of ours.

    Its channels are all under ``/twopose/results/``, ``/tf`` and the camera topics, with no
    ``twopose`` metadata: such files are not sessions, and a run over a folder skips them.
    """
    try:
        with open(path, "rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            if summary is None:
                return False
            topics = [c.topic for c in summary.channels.values()]
            if not any(t.startswith(RESULTS_TOPIC_PREFIX) for t in topics):
                return False
            return all(m.name != METADATA_NAME for m in reader.iter_metadata())
    except Exception:  # unreadable: not ours to skip; the analysis reports it as failed
        return False
