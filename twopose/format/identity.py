"""What a session is, once, for every command: files -> sessions -> parts -> trials.

A lab's folders hold the same recording many times over: a file named twice or reached
through a symbolic link, a byte copy, a renamed copy, the recovered copy of an interrupted
file beside the original, a continuation (``new --continue``) recorded on another day or
on two laptops at once. Every command (``run``, ``rig``, ``info``, ``check``, ``compare``,
the report, JUnit, the results files) takes what :func:`resolve_session_files` makes of
them, so they agree on what is counted and what is said.

- A **session** is its ``session_id`` (format 1.3). A file with none (before 1.3) is
  known by what opens it (:func:`opening_digest`: the ``twopose`` metadata record its
  writer puts before the first chunk, with the session entry, the cameras, the ground and
  the start time, and its first frame; a cut copy keeps both and ``recover`` copies them),
  so that the file, a byte, renamed, cut or recovered copy of it are one session and one
  part wherever they are given; its continuations record the first 32 hex digits of its
  SHA-256 as their id.
- A **part** is the stretch of a session one file records: its ``part_id`` (format 1.4),
  or before it the session id with where the file continues and when it was created, or
  (no session id) what opens the file. A byte copy, a renamed copy, a copy cut short and a
  recovered copy of one file hold the same part: one is kept (a readable file before an
  interrupted one, then the one holding more poses, then the first given), the others are
  listed with why; a copy cut short beside a complete one is a copy, not a failure.
- A continuation's part links to the part it continues (its ``continues.part``, else the
  SHA-256 of the file it continued, matched against every file given). The parts of a
  session form a tree; a part continued twice (two laptops continuing one file) is a
  **fork**, and each continuation starts a **branch** (``A``, ``B``, ...; a fork within a
  branch ``B`` gives ``BA``, ``BB``). A branch's trials are told apart from the others'.
- A **strand** is what is analysed as one: a root part and the first continuation of each
  part after it, in trial order; every other branch is a strand of its own, holding only
  its own parts, so that every capture is counted once.
- A **trial** is its session, its branch and its number.

(Near 600 lines: one rule (what a session, a part and a copy are) with the words that say
it; cut in two, its cases would be read in two places.)
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import string
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel, Chunk, Message, Metadata
from mcap.stream_reader import StreamReader, breakup_chunk

from twopose.errors import TwoposeError
from twopose.format.entries import METADATA_NAME, PoseEntry, SessionInfo, decode_entry
from twopose.format.reader import SessionReader, max_chunk_bytes, recover_command
from twopose.methods.specs import spec_of

__all__ = [
    "Part",
    "Resolution",
    "SessionFile",
    "Strand",
    "file_digest",
    "identify_file",
    "kept_of_copies",
    "looks_like_backup",
    "opening_digest",
    "path_labels",
    "resolve_session_files",
]

_CHUNK = 1 << 20
#: How many records at a file's start are read for its opening metadata (the writer puts
#: it before the first chunk) and its first frame (in its first captures' chunks, each
#: followed by its message indexes).
_OPENING_RECORDS = 256


def file_digest(path: str | Path) -> str:
    """Return the SHA-256 of a file's bytes.

    An unreadable file gets a name of its own, so that it is never taken for another.
    """
    sha = hashlib.sha256()
    try:
        with open(path, "rb") as stream:
            while chunk := stream.read(_CHUNK):
                sha.update(chunk)
    except OSError as err:
        return f"unreadable:{path}:{err.errno}"
    return sha.hexdigest()


@dataclass(frozen=True, kw_only=True)
class SessionFile:
    """One session file and what it says it is.

    ``info`` is read from the summary of a readable file, or from the opening metadata of
    an interrupted one (so that it can be known as the original of its recovered copy);
    None when neither can be read.
    """

    path: str
    digest: str  # SHA-256 of the file's bytes
    readable: bool
    info: SessionInfo | None = None
    n_poses: int = -1  # poses typed (-1: unknown, the file is not readable)
    pair: bool = False  # a two-camera session (format 1.6: stream trials, no typed pose)
    #: A file with no session id: the digest of what opens it (:func:`opening_digest`),
    #: the same for its cut and recovered copies ("" when it has an id, or none is read).
    opening: str = ""

    @property
    def method(self) -> str:
        """The method it records ("" when unknown)."""
        return str(self.info.method) if self.info is not None else ""

    @property
    def units(self) -> str:
        """The units it records in ("" when unknown)."""
        return str(self.info.units) if self.info is not None else ""

    @property
    def session_id(self) -> str:
        """The session: its recorded id, or (before format 1.3) what opens it."""
        recorded = self.info.session_id if self.info is not None else None
        return recorded or (self.opening or self.digest)[:32]

    @property
    def part_key(self) -> str:
        """The part of its session this file records.

        The same for a byte copy, a renamed copy and a recovered copy (see the module
        docstring).
        """
        info = self.info
        if info is None or not info.session_id:
            return f"opening:{self.opening}" if self.opening else f"file:{self.digest}"
        if info.part_id:
            return f"part:{info.part_id}"
        where = (info.session_id, info.continues_after_trial, info.continues_sha256)
        return "made:" + hashlib.sha256(json.dumps([*where, info.created_utc]).encode()).hexdigest()

    @property
    def part_id(self) -> str:
        """The part's id as the tables name it.

        The recorded ``part_id`` (format 1.4), else 32 hex digits of :attr:`part_key`'s
        hash.
        """
        if self.info is not None and self.info.part_id:
            return self.info.part_id
        return hashlib.sha256(self.part_key.encode()).hexdigest()[:32]

    @property
    def is_board(self) -> bool:
        """Whether it is a readable board session (for ``rig``)."""
        return self.readable and self.info is not None and not spec_of(self.info.method).measures

    @property
    def is_empty(self) -> bool:
        """Whether it is a readable session with no pose recorded."""
        return self.readable and self.n_poses == 0

    @property
    def continues_after(self) -> int | None:
        """The last trial of the part it continues (None: not a continuation)."""
        return self.info.continues_after_trial if self.info is not None else None


def identify_file(path: str | Path, digest: str | None = None) -> SessionFile:
    """Identify the session file ``path``.

    Never raises for a bad file: it is a :class:`SessionFile` that is not readable, whose
    analysis then says why.
    """
    digest = digest or file_digest(path)
    try:
        with SessionReader(path) as reader:
            info: SessionInfo | None = reader.info
            n_poses = reader.message_counts().get(PoseEntry.TOPIC, 0)
            pair = reader.pair is not None
        readable = True
    except (TwoposeError, OSError, AssertionError, ValueError):
        info, n_poses, readable, pair = None, -1, False, False
    opening: str = ""
    if info is None or not info.session_id:  # interrupted, or no id: what opens it
        metadata, first_frame = _opening(path)
        if metadata is not None:
            info = info or _session_entry(metadata)
            opening = _digest_of(metadata, first_frame) if info is not None else ""
    return SessionFile(
        path=str(path), digest=digest, readable=readable, info=info, n_poses=n_poses, pair=pair,
        opening=opening if info is not None and not info.session_id else "",
    )  # fmt: skip


def opening_digest(path: str | Path) -> str:
    """Return the SHA-256 of what opens a session file.

    Its ``twopose`` metadata record (the writer's copy of the session entry, the cameras,
    the ground and the start time, written before the first chunk), as names and values,
    and its first frame (so that two files of identical openings, as another writer may
    make them, are told apart by what they saw): the same for the file, a copy cut short
    anywhere after its first frame and a recovered copy (``recover`` copies both); "" when
    it has no metadata record to read.
    """
    metadata, first_frame = _opening(path)
    return _digest_of(metadata, first_frame) if metadata is not None else ""


def _digest_of(metadata: dict[str, str], first_frame: str) -> str:
    return hashlib.sha256(json.dumps([sorted(metadata.items()), first_frame]).encode()).hexdigest()


def _session_entry(metadata: dict[str, str]) -> SessionInfo | None:
    """The session entry the metadata record holds a copy of (None: unreadable)."""
    try:
        entry = decode_entry(SessionInfo.SCHEMA_NAME, metadata["session"].encode())
    except Exception:  # any damage: no identity beyond its bytes
        return None
    return entry if isinstance(entry, SessionInfo) else None


def _opening(path: str | Path) -> tuple[dict[str, str] | None, str]:
    """Read a file's start front to back: its metadata record and its first frame's digest.

    The ``twopose`` metadata record, and the SHA-256 of its first message on a camera's
    image topic; so also from a file that cannot be read whole (no summary). The metadata
    is None when there is none before the first chunk; the frame's digest "" when none is
    read (a chunk over the size limit, damaged, or none in the first records).
    """
    metadata: dict[str, str] | None = None
    topics: dict[int, str] = {}
    try:
        size = max(os.path.getsize(path), 1)
        with open(path, "rb") as stream:
            records = StreamReader(stream, emit_chunks=True, record_size_limit=size).records
            for _, record in zip(range(_OPENING_RECORDS), records, strict=False):
                if isinstance(record, Metadata) and record.name == METADATA_NAME:
                    metadata = metadata or {str(k): str(v) for k, v in record.metadata.items()}
                elif isinstance(record, Chunk):
                    if metadata is None or record.uncompressed_size > max_chunk_bytes():
                        break
                    for inner in breakup_chunk(record, validate_crc=True):
                        if isinstance(inner, Channel):
                            topics[inner.id] = inner.topic
                        elif isinstance(inner, Message) and topics.get(
                            inner.channel_id, ""
                        ).endswith("/image"):
                            return metadata, hashlib.sha256(inner.data).hexdigest()
    except Exception:  # any damage: no identity beyond what was read
        return metadata, ""
    return metadata, ""


#: A folder or file name a copy is kept under: ``backup``, ``bak``, ``old``, ``copy``,
#: ``archive``, ``usb``, ``trash`` as a word of it, ``Copy of ...``, ``... (1)``, ``...~``.
_BACKUP_NAME = re.compile(
    r"(?:^|[^a-z])(?:backups?|bak|bkp|old|copy|copies|archived?|archives|usb|trash)"
    r"(?:$|[^a-z])|\(\d+\)$|~$",
    re.IGNORECASE,
)


def looks_like_backup(path: str) -> bool:
    """Whether ``path`` lies in a backup-looking folder or has a copy's name."""
    parts = Path(os.path.normpath(path)).parts
    names = [*parts[:-1], Path(parts[-1]).stem, Path(parts[-1]).suffix.lstrip(".")] if parts else []
    return any(_BACKUP_NAME.search(name) for name in names)


def kept_of_copies(paths: Sequence[str]) -> tuple[str, str]:
    """Which of ``paths``, copies of one part that tie on all else, is kept, and why.

    The one outside a backup-looking path (:func:`looks_like_backup`), else the oldest
    (modified first), else the first given: so that a session is named by its original's
    path, never by the backup's.
    """
    given = list(dict.fromkeys(paths))
    outside = [p for p in given if not looks_like_backup(p)]
    if outside and len(outside) < len(given):
        if len(outside) == 1:
            return outside[0], "the copy outside a backup-looking folder"
        given = outside
    ages = {p: _modified(p) for p in given}
    oldest = min(given, key=lambda p: ages[p])  # the first given among equals
    if sum(ages[p] == ages[oldest] for p in given) == 1:
        return oldest, "the oldest copy"
    return oldest, "the first given (the copies are as old)"


def _modified(path: str) -> float:
    try:
        return os.stat(path).st_mtime
    except OSError:
        return float("inf")


@dataclass(frozen=True, kw_only=True)
class Part:
    """A part of a session: the file kept for it, and the other files holding it."""

    file: SessionFile
    others: tuple[tuple[str, str], ...] = ()  # (path, why it is not the one kept)
    parent: str | None = None  # the part key of the part it continues, when given
    branch: str = ""
    #: The path of the part it continues when that is given but interrupted (unreadable,
    #: with no recovered copy): analysed alone until it is recovered.
    interrupted_parent: str = ""


@dataclass(frozen=True, kw_only=True)
class Strand:
    """What is analysed as one (see the module docstring): parts in trial order."""

    session_id: str
    parts: tuple[Part, ...]

    @property
    def head(self) -> str:
        """Its first part's path: what names it in the tables."""
        return self.parts[0].file.path

    @property
    def later(self) -> tuple[str, ...]:
        """The paths of its parts after the first, in trial order."""
        return tuple(p.file.path for p in self.parts[1:])

    @property
    def branches(self) -> dict[str, str]:
        """Each part's path -> its branch ("" on a session that never forked)."""
        return {p.file.path: p.branch for p in self.parts}

    @property
    def branch(self) -> str:
        """The branch its last part is on (its first part's, for a strand of one)."""
        return self.parts[-1].branch


@dataclass(frozen=True, kw_only=True)
class Resolution:
    """Session files resolved: the strands, and what was not taken as given, said."""

    strands: tuple[Strand, ...] = ()
    #: (path, the path of the file kept for the same part, why): copies and twins
    others: tuple[tuple[str, str, str], ...] = ()
    notes: tuple[str, ...] = ()
    forks: tuple[str, ...] = ()  # one sentence per fork found
    #: (the path kept, why it of copies that tie on all else: :func:`kept_of_copies`)
    kept_why: tuple[tuple[str, str], ...] = ()


def resolve_session_files(files: Sequence[SessionFile]) -> Resolution:
    """Resolve measurement session files into strands, in input order.

    Copies and twins are set aside, parts linked to the parts they continue, forks split
    into branches. ``files`` may be readable or not; board sessions are not for this (each
    calibrates on its own).
    """
    parts, others, kept_why = _parts(files)
    # Every copy names its part, by its bytes (continues.sha256) and its id (continues.part).
    by_digest = {f.digest: f.part_key for f in files}
    by_id = {f.part_id: f.part_key for f in files}
    linked = {key: _linked(part, parts, by_digest, by_id) for key, part in parts.items()}
    children: dict[str, list[str]] = {}
    for key, part in linked.items():
        if part.parent is not None:
            children.setdefault(part.parent, []).append(key)
    order = {key: k for k, key in enumerate(parts)}
    strands: list[Strand] = []
    forks: list[str] = []
    pending = [key for key, part in linked.items() if part.parent is None]
    while pending:
        strands_here, new_forks, more = _walk(pending.pop(0), linked, children, order)
        strands += strands_here
        forks += new_forks
        pending = more + pending
    notes = [*_joined_notes(strands, linked), *forks]
    return Resolution(
        strands=tuple(strands),
        others=tuple(others),
        notes=tuple(notes),
        forks=tuple(forks),
        kept_why=tuple(kept_why),
    )


def _parts(
    files: Sequence[SessionFile],
) -> tuple[dict[str, Part], list[tuple[str, str, str]], list[tuple[str, str]]]:
    """Keep one file per part key: the best (readable, more poses).

    Of copies that tie, :func:`kept_of_copies`' choice, with why.
    """
    groups: dict[str, list[SessionFile]] = {}
    for f in files:
        groups.setdefault(f.part_key, []).append(f)
    parts: dict[str, Part] = {}
    others: list[tuple[str, str, str]] = []
    kept_why: list[tuple[str, str]] = []
    for key, group in groups.items():
        best = max((f.readable, f.n_poses) for f in group)
        tied = [f for f in group if (f.readable, f.n_poses) == best]
        kept = tied[0]
        if len(tied) > 1:
            path, reason = kept_of_copies([f.path for f in tied])
            kept = next(f for f in tied if f.path == path)
            kept_why.append((path, reason))
        why = [(f.path, kept.path, _why_not_kept(f, kept)) for f in group if f is not kept]
        others += why
        parts[key] = Part(file=kept, others=tuple((p, w) for p, _, w in why))
    return parts, others, kept_why


def _why_not_kept(f: SessionFile, kept: SessionFile) -> str:
    if f.digest == kept.digest:
        return "a byte copy"
    if not f.readable:
        return "interrupted; the complete or recovered copy of the same part is kept"
    if f.n_poses < kept.n_poses:
        return f"an earlier copy of the same part: {f.n_poses} poses, the one kept {kept.n_poses}"
    return "another copy of the same part"


def _linked(
    part: Part, parts: dict[str, Part], by_digest: dict[str, str], by_id: dict[str, str]
) -> Part:
    """``part`` with the key of the part it continues, when that is among the inputs."""
    info = part.file.info
    if info is None or info.continues_after_trial is None or not part.file.readable:
        return part  # an interrupted continuation fails alone, never with what it continues
    parent: str | None = None
    if info.continues_part and info.continues_part in by_id:
        parent = by_id[info.continues_part]
    elif info.continues_sha256 in by_digest:
        parent = by_digest[info.continues_sha256]
    if parent is not None and not _of_session(parts[parent].file, part.file):
        parent = None  # another session's file: not what it continued
    if parent is not None and not parts[parent].file.readable:
        # Its only copy was interrupted: joined to it, this part would fail with it.
        return dataclasses.replace(part, interrupted_parent=parts[parent].file.path)
    return dataclasses.replace(part, parent=parent)


def _of_session(parent: SessionFile, part: SessionFile) -> bool:
    """Whether the continuation ``part`` is of ``parent``'s session.

    The same id, or, for a parent with no id of its own, the id its continuations record
    (the first 32 hex digits of the SHA-256 of the file they continued).
    """
    if parent.session_id == part.session_id:
        return True
    info, recorded = part.info, parent.info.session_id if parent.info is not None else None
    continued = info.continues_sha256 if info is not None else None
    return not recorded and continued is not None and part.session_id == continued[:32]


def _walk(
    root: str, parts: dict[str, Part], children: dict[str, list[str]], order: dict[str, int]
) -> tuple[list[Strand], list[str], list[str]]:
    """Follow the strand from ``root``: its first continuation after each part.

    Returns the strand, the forks met on the way, and the roots of the branches it leaves
    for strands of their own. Each continuation's branch is set in ``parts`` as it is met.
    """
    keys = [root]
    forks: list[str] = []
    left: list[str] = []
    while kids := children.get(keys[-1], []):
        kids = sorted(kids, key=lambda k: _sibling_order(parts[k], order[k]))
        here = parts[keys[-1]]
        for k, name in zip(kids, _branch_names(here.branch, [parts[k] for k in kids]), strict=True):
            parts[k] = dataclasses.replace(parts[k], branch=name)
        if len(kids) > 1:
            forks.append(_fork_sentence(here, [parts[k] for k in kids]))
        keys.append(kids[0])
        left += kids[1:]
    chain = tuple(parts[k] for k in keys)
    return [Strand(session_id=chain[0].file.session_id, parts=chain)], forks, left


def _sibling_order(part: Part, given: int) -> tuple[str, str, int]:
    info = part.file.info
    assert info is not None
    return (info.continues_branch or "", info.created_utc, given)


def _branch_names(parent: str, kids: list[Part]) -> list[str]:
    """Name each continuation's branch.

    A lone continuation is on its parent's; at a fork each takes a letter after the
    parent's (a letter the recorder wrote is kept, the others take the next free ones
    from A).
    """
    recorded = [(p.file.info.continues_branch or "") if p.file.info else "" for p in kids]
    if len(kids) == 1:
        return [recorded[0] if len(recorded[0]) > len(parent) else parent]
    taken = {r for r in recorded if len(r) > len(parent)}
    free = (parent + c for c in string.ascii_uppercase if parent + c not in taken)
    return [r if r in taken else next(free) for r in recorded]


def _fork_sentence(parent: Part, kids: list[Part]) -> str:
    after = kids[0].file.continues_after
    named = ", ".join(f"{k.file.path} (branch {k.branch})" for k in kids)
    return (
        f"{parent.file.path} is continued after trial {after} by {len(kids)} files: {named}; "
        "each branch's trials are kept, told apart by their branch"
    )


def _joined_notes(strands: Sequence[Strand], parts: dict[str, Part]) -> list[str]:
    """What each continuation is taken as, in words that are true of these inputs."""
    path_of = {key: p.file.path for key, p in parts.items()}
    notes: list[str] = []
    for strand in strands:
        for k, part in enumerate(strand.parts):
            info = part.file.info
            if info is None or info.continues_after_trial is None or not part.file.readable:
                continue  # an interrupted file fails with its own reason: recover it
            after = info.continues_after_trial
            if part.interrupted_parent:
                broken = part.interrupted_parent
                notes.append(
                    f"{part.file.path}: continues {broken} after trial {after}, which was "
                    f"interrupted: analysed alone; `{recover_command(broken)}` salvages it, and "
                    "a run with FIXED.mcap joins them"
                )
            elif part.parent is None:
                notes.append(_missing_parent_note(part, strands))
            elif k == 0:
                notes.append(
                    f"{part.file.path}: branch {part.branch} of the session, continuing "
                    f"{path_of[part.parent]} after trial {after}: its own trials analysed "
                    "on their own"
                )
            else:
                notes.append(
                    f"{part.file.path}: continues {path_of[part.parent]} after trial {after}; "
                    f"one session with {strand.head}"
                )
    return notes


def _missing_parent_note(part: Part, strands: Sequence[Strand]) -> str:
    """Say what a continuation whose continued file is not given is taken as.

    Alone, or, when the session's earlier parts are given, apart from them (one session
    in two rows: the trials of the missing part between them are what the run lacks).
    """
    info = part.file.info
    assert info is not None
    assert info.continues_after_trial is not None
    name, after = info.continues_file or "the file it continues", info.continues_after_trial
    earlier = [  # the session's pieces whose trials come before this part's
        s.head
        for s in strands
        if s.session_id == part.file.session_id
        and part not in s.parts
        and (s.parts[0].file.continues_after or 0) < after
    ]
    if not earlier:
        return (
            f"{part.file.path}: continues {name} after trial {after}; {name} is not among the "
            f"inputs: analysed alone (its trials up to {after} are not in this run)"
        )
    before = ", ".join(earlier)
    return (
        f"{part.file.path}: continues {name} after trial {after}; {name} is not among the "
        f"inputs: the session is analysed in two pieces with one session id ({before}, "
        f"and this file on), and the trials {name} recorded after {before}'s, up to trial "
        f"{after}, are not in this run"
    )


def path_labels(paths: Iterable[str]) -> dict[str, str]:
    """Label each path by its shortest tail of folders that no other path shares.

    ``a/s.mcap`` and ``b/s.mcap`` stay ``a/s.mcap`` and ``b/s.mcap``; a lone ``x/t.mcap``
    is ``t.mcap``. What names a session at the terminal, in the report's tables and
    figures and in the names of a run's output files.
    """
    given = list(dict.fromkeys(str(p) for p in paths))
    split = {p: Path(os.path.normpath(p)).parts for p in given}
    labels: dict[str, str] = {}
    for p in given:
        parts = split[p]
        for n in range(1, len(parts) + 1):
            tail = parts[-n:]
            if all(q == p or split[q][-n:] != tail for q in given):
                break
        labels[p] = str(Path(*tail))
    return labels
