"""A batch's inputs, resolved once into one value every command takes.

``run``, ``rig`` and ``info`` are given paths: files and folders, named twice, holding
copies, sessions in several units, board sessions beside target ones, empty sessions and
results files of an earlier run. :func:`resolve_inputs` turns them, once, into an
:class:`InputSet`:

- every session file found (folders searched as :func:`twopose.format.reader.find_sessions`
  searches them), in the order given;
- identified by content (the SHA-256 of its bytes): a session named twice, by another path,
  a symlink or a copy, is counted once, and the copy is noted;
- sorted by kind: measurement sessions (what ``run`` analyses), board sessions (for
  ``rig``), empty sessions (no pose recorded: nothing to analyse, noted), results files of
  an earlier run (skipped), and files that cannot be read as sessions (analysed all the
  same, so that the analysis says why they fail, by session);
- grouped by units, so that no statistic pools two units.

Each command reads what applies to it from the one value, and the notes it gives are the
same words wherever they are printed (terminal, report, JUnit).
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from twopose.errors import TwoposeError
from twopose.format.entries import PoseEntry
from twopose.format.reader import SessionReader, find_sessions, is_results_file
from twopose.methods import spec_of

__all__ = ["FoundSession", "InputSet", "resolve_inputs"]

_CHUNK = 1 << 20


@dataclass(frozen=True, kw_only=True)
class FoundSession:
    """One session file found, what it is and what it holds (``method`` and ``units``
    empty when the file cannot be read as a session: the analysis says why)."""

    path: str
    digest: str  # SHA-256 of the file's bytes: its identity
    method: str = ""
    units: str = ""
    n_poses: int = 0  # poses typed (0: an empty session)
    readable: bool = True
    #: The session it belongs to: its id, or (before format 1.3) its content's; a
    #: continuation (``new --continue``) shares its first part's.
    session_key: str = ""
    after_trial: int | None = None  # a continuation: the last trial of the part it continues
    continues: str = ""  # a continuation: the file name it continues

    @property
    def is_board(self) -> bool:
        return self.readable and bool(self.method) and not spec_of(self.method).measures

    @property
    def is_empty(self) -> bool:
        return self.readable and self.n_poses == 0


@dataclass(frozen=True, kw_only=True)
class InputSet:
    """A batch's inputs, resolved once (see the module docstring)."""

    found: tuple[FoundSession, ...] = ()  # every session once (its first path), in order
    copies: tuple[tuple[str, str], ...] = ()  # (path, the path it is a copy of)
    skipped: tuple[str, ...] = ()  # results files of an earlier run
    #: (path, the path first naming the same file): a file named twice, directly, by a
    #: folder holding it, or by a symbolic link to it
    repeats: tuple[tuple[str, str], ...] = ()

    @property
    def measured(self) -> tuple[FoundSession, ...]:
        """What ``run`` analyses: every session but board and empty ones (unreadable files
        included: the analysis says why they fail)."""
        return tuple(s for s in self.found if not (s.is_board or s.is_empty))

    @property
    def boards(self) -> tuple[FoundSession, ...]:
        """Board sessions: for ``rig``."""
        return tuple(s for s in self.found if s.is_board)

    @property
    def empty(self) -> tuple[FoundSession, ...]:
        """Sessions with no pose recorded."""
        return tuple(s for s in self.found if s.is_empty)

    @property
    def files(self) -> list[str]:
        """The measurement sessions' paths, in input order (what ``run`` analyses): each
        session once, by its first part (its continuations: :attr:`continuations`)."""
        later = {p for parts in self.continuations.values() for p in parts}
        return [s.path for s in self.measured if s.path not in later]

    @property
    def continuations(self) -> dict[str, tuple[str, ...]]:
        """Per session's first part given, its continuations given, in trial order: one
        session. A continuation whose first part is not given is a session of its own."""
        groups: dict[str, list[FoundSession]] = {}
        for s in self.measured:
            if s.session_key:
                groups.setdefault(s.session_key, []).append(s)
        out: dict[str, tuple[str, ...]] = {}
        for parts in groups.values():
            first = [s for s in parts if s.after_trial is None]
            if len(parts) < 2 or len(first) != 1:
                continue
            later = sorted((s for s in parts if s.after_trial is not None),
                           key=lambda s: (s.after_trial or 0, s.path))  # fmt: skip
            out[first[0].path] = tuple(s.path for s in later)
        return out

    @property
    def paths(self) -> tuple[str, ...]:
        """Every session path it read (copies and repeats too): what no output may replace."""
        return (
            *(s.path for s in self.found),
            *(path for path, _ in self.copies),
            *(path for path, _ in self.repeats),
        )

    @property
    def units(self) -> tuple[str, ...]:
        """The units of the measurement sessions, in order of first appearance."""
        return tuple(dict.fromkeys(s.units for s in self.measured if s.units))

    def notes(self) -> list[str]:
        """What any command says about inputs it does not take as given: copies counted
        once, empty sessions."""
        repeats = [
            f"{path}: named more than once (the same file as {first}); counted once"
            for path, first in self.repeats
        ]
        copies = [
            f"{path}: the same session as {first}; counted once" for path, first in self.copies
        ]
        empty = [
            f"{s.path}: an empty session (no pose was recorded): nothing to analyse"
            for s in self.empty
        ]
        joined = {p: first for first, parts in self.continuations.items() for p in parts}
        continued = [
            f"{s.path}: continues {s.continues} after trial {s.after_trial}; "
            + (f"one session with {joined[s.path]}" if s.path in joined
               else f"{s.continues} is not among the inputs: analysed alone")
            for s in self.measured
            if s.after_trial is not None
        ]  # fmt: skip
        return repeats + copies + empty + continued

    def run_notes(self) -> list[str]:
        """What ``run`` says: :meth:`notes`, and the board sessions it leaves to ``rig``."""
        return self.notes() + [
            f"{s.path}: a board session (it calibrates the rig): for `twopose-analyze rig`, "
            "not analysed here"
            for s in self.boards
        ]


def resolve_inputs(paths: Sequence[str | Path] | InputSet) -> InputSet:
    """The one resolution of a batch's paths (see the module docstring); raises
    :class:`~twopose.errors.InputValueError` for a path that does not exist. An
    :class:`InputSet` is already resolved: returned as it is, so a command resolves once
    and hands the set to each step."""
    if isinstance(paths, InputSet):
        return paths
    found: list[FoundSession] = []
    copies: list[tuple[str, str]] = []
    skipped: list[str] = []
    first_of: dict[str, str] = {}
    repeats: list[tuple[str, str]] = []
    named: dict[Path, str] = {}  # each file (resolved) -> the path first naming it
    for path in find_sessions(paths, unique=False):
        key = path.resolve()
        if key in named:
            repeats.append((str(path), named[key]))
            continue
        named[key] = str(path)
        if is_results_file(path):
            skipped.append(str(path))
            continue
        session = _found(path)
        if session.digest in first_of:
            copies.append((session.path, first_of[session.digest]))
            continue
        first_of[session.digest] = session.path
        found.append(session)
    return InputSet(
        found=tuple(found), copies=tuple(copies), skipped=tuple(skipped), repeats=tuple(repeats)
    )


def _found(path: Path) -> FoundSession:
    digest = _digest(path)
    try:
        with SessionReader(path) as reader:
            info = reader.info
            n_poses = reader.message_counts().get(PoseEntry.TOPIC, 0)
    except (TwoposeError, OSError, AssertionError, ValueError):
        # Not readable as a session: the analysis fails it with its own words.
        return FoundSession(path=str(path), digest=digest, readable=False)
    return FoundSession(
        path=str(path),
        digest=digest,
        method=str(info.method),
        units=str(info.units),
        n_poses=int(n_poses),
        session_key=info.session_id or digest[:32],
        after_trial=info.continues_after_trial,
        continues=info.continues_file or "",
    )


def _digest(path: Path) -> str:
    sha = hashlib.sha256()
    try:
        with open(path, "rb") as stream:
            while chunk := stream.read(_CHUNK):
                sha.update(chunk)
    except OSError as err:  # unreadable: its own identity, the analysis says why
        return f"unreadable:{path}:{err.errno}"
    return sha.hexdigest()
