"""A batch's inputs, resolved once into one value every command takes.

``run``, ``rig``, ``info`` (and, through the tables a run writes, ``check`` and
``compare``) are given paths: files and folders, named twice, holding copies, recovered
copies, continuations and forks, sessions in several units, board sessions beside target
ones, empty sessions and results files of an earlier run. :func:`resolve_inputs` turns
them, once, into an :class:`InputSet` by the one definition of what a session is
(:mod:`twopose.format.identity`):

- every session file found (folders searched as :func:`twopose.format.reader.find_sessions`
  searches them: links followed, ``.mcap`` in any case), in the order given;
- a file named twice, by another path or a symlink, read once; a byte copy, a renamed copy
  or a recovered copy of one part counted once, the others said with why;
- sorted by kind: measurement sessions (what ``run`` analyses), board sessions (for
  ``rig``), empty sessions (no pose recorded: nothing to analyse, noted), results files of
  an earlier run (skipped), two-camera sessions (their stream trials: analysed, one row
  a touch), and files that cannot be read as sessions (analysed all the
  same, so that the analysis says why they fail, by session);
- the measurement sessions as strands (a session's parts in trial order, a fork's other
  branches on their own), each with its session id, its parts' branches and a label that
  tells it from every other input;
- grouped by units, so that no statistic pools two units.

Each command reads what applies to it from the one value, and the notes it gives are the
same words wherever they are printed (terminal, report, JUnit).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Self

from twopose.format.identity import (
    SessionFile,
    Strand,
    file_digest,
    identify_file,
    kept_of_copies,
    path_labels,
    resolve_session_files,
)
from twopose.format.reader import find_sessions, is_results_file
from twopose.values.operators import operators_of, spelled_apart

__all__ = ["FoundSession", "InputSet", "SessionIdentity", "resolve_inputs", "sessions_said"]

#: One session file found (:class:`twopose.format.identity.SessionFile`).
FoundSession = SessionFile


@dataclass(frozen=True, kw_only=True)
class SessionIdentity:
    """What names one strand in a run's tables: its session, its label, and each part's id
    and branch (what tells a trial from every other: its session, its part, its number)."""

    session_id: str
    label: str
    parts: tuple[tuple[str, str, str], ...] = ()  # (part's path, part id, branch), in order

    def part(self, path: str) -> tuple[str, str]:
        """The part id and branch of the part at ``path`` (unknown: ``("", "")``)."""
        return next(((p, b) for q, p, b in self.parts if q == str(path)), ("", ""))

    @property
    def branch(self) -> str:
        """The branch the strand ends on."""
        return self.parts[-1][2] if self.parts else ""

    @classmethod
    def of_files(cls, path: str | Path, continuations: Sequence[str | Path] = ()) -> Self:
        """The identity of ``path`` and its continuations analysed on their own (a notebook's
        ``analyse_session``): ids from the files, no other input to tell them from."""
        files = [identify_file(p) for p in (path, *continuations)]
        parts = tuple((f.path, f.part_id, "") for f in files)
        return cls(session_id=files[0].session_id, label=Path(path).name, parts=parts)


@dataclass(frozen=True, kw_only=True)
class InputSet:
    """A batch's inputs, resolved once (see the module docstring)."""

    found: tuple[FoundSession, ...] = ()  # every file once (its first path), in order
    #: (path, the path kept for the same part, why): byte copies, renamed and recovered
    #: copies, interrupted originals beside their recovered twin
    others: tuple[tuple[str, str, str], ...] = ()
    skipped: tuple[str, ...] = ()  # results files of an earlier run
    #: (path, the path first naming the same file): a file named twice, directly, by a
    #: folder holding it, or by a symbolic link to it
    repeats: tuple[tuple[str, str], ...] = ()
    strands: tuple[Strand, ...] = ()  # what ``run`` analyses, one strand each
    strand_notes: tuple[str, ...] = ()  # continuations and forks, in words
    #: the path kept of copies that tie on all else -> why it
    #: (:func:`twopose.format.identity.kept_of_copies`: outside a backup folder, the oldest)
    kept_why: tuple[tuple[str, str], ...] = ()

    @property
    def copies(self) -> tuple[tuple[str, str], ...]:
        """(path, the path kept for it): every file not analysed for another holds it."""
        return tuple((path, kept) for path, kept, _ in self.others)

    @property
    def measured(self) -> tuple[FoundSession, ...]:
        """Every measurement file analysed (unreadable ones included: the analysis says why
        they fail), copies and twins left out."""
        return tuple(part.file for strand in self.strands for part in strand.parts)

    @property
    def boards(self) -> tuple[FoundSession, ...]:
        """Board sessions: for ``rig``."""
        return tuple(s for s in self.found if s.is_board and s.path not in self._set_aside)

    @property
    def empty(self) -> tuple[FoundSession, ...]:
        """Sessions with no pose recorded (in a strand with none either)."""
        kept = {s.path for strand in self._analysed for s in (p.file for p in strand.parts)}
        return tuple(
            s
            for s in self.found
            if s.is_empty
            and not s.is_board
            and s.path not in kept
            and s.path not in self._set_aside
        )

    @property
    def _set_aside(self) -> set[str]:
        return {path for path, _, _ in self.others}

    @property
    def _analysed(self) -> tuple[Strand, ...]:
        """The strands with at least one pose, two-camera ones (their stream trials), or
        unreadable ones (the analysis says why)."""
        return tuple(
            s
            for s in self.strands
            if any(not p.file.readable or p.file.n_poses or p.file.pair for p in s.parts)
        )

    @property
    def files(self) -> list[str]:
        """What ``run`` analyses, in input order: each strand once, by its first part's
        path (its later parts: :attr:`continuations`)."""
        return [s.head for s in self._analysed]

    @property
    def continuations(self) -> dict[str, tuple[str, ...]]:
        """Per strand's first part, its later parts in trial order: one session."""
        return {s.head: s.later for s in self._analysed if s.later}

    @functools.cached_property
    def labels(self) -> dict[str, str]:
        """Every input's label: its shortest tail of folders no other input shares."""
        return path_labels([*(s.path for s in self.found), *(p for p, _, _ in self.others)])

    def identity(self, head: str) -> SessionIdentity:
        """The identity of the strand whose first part is ``head``."""
        strand = next(s for s in self.strands if s.head == head)
        return SessionIdentity(
            session_id=strand.session_id,
            label=self.labels.get(head, Path(head).name),
            parts=tuple((p.file.path, p.file.part_id, p.branch) for p in strand.parts),
        )

    @property
    def identities(self) -> dict[str, SessionIdentity]:
        """:meth:`identity` of every strand ``run`` analyses, by its first part's path."""
        return {head: self.identity(head) for head in self.files}

    @property
    def paths(self) -> tuple[str, ...]:
        """Every session path it read (copies and repeats too): what no output may replace."""
        return (
            *(s.path for s in self.found),
            *(path for path, _, _ in self.others),
            *(path for path, _ in self.repeats),
        )

    @property
    def set_aside(self) -> tuple[str, ...]:
        """Every input not analysed as given: a file named twice, a copy or twin counted
        once, an empty session, a board session (for ``rig``). Continuations and forks'
        branches are not among them: they are analysed, joined or apart."""
        return tuple(
            dict.fromkeys(
                [
                    *(path for path, _ in self.repeats),
                    *(path for path, _, _ in self.others),
                    *(s.path for s in self.empty),
                    *(s.path for s in self.boards),
                ]
            )
        )

    @property
    def units(self) -> tuple[str, ...]:
        """The units of the measurement sessions, in order of first appearance."""
        return tuple(dict.fromkeys(s.units for s in self.measured if s.units))

    def notes(self) -> list[str]:
        """What any command says about inputs it does not take as given: repeats, copies
        and twins counted once, empty sessions, continuations and forks."""
        repeats = [
            f"{path}: named more than once"
            + ("" if path == first else f" (the same file as {first})")
            + "; counted once"
            for path, first in dict.fromkeys(self.repeats)
        ]
        chosen = dict(self.kept_why)
        copies = [
            f"{path}: the same session as {kept} ({why}); counted once"
            + (f", {kept} kept: {chosen[kept]}" if kept in chosen else "")
            for path, kept, why in self.others
        ]
        empty = [
            f"{s.path}: an empty session (no pose was recorded): nothing to analyse"
            for s in self.empty
        ]
        return repeats + copies + empty + list(self.strand_notes) + self.operator_notes()

    @property
    def of_operators(self) -> dict[str, tuple[str, ...]]:
        """The sessions ``run`` analyses whose parts two or more operators recorded (a
        ``--continue --operator``), by their first part's path: their operators."""
        # a two-camera session has no typed poses, so no placing multiplier to share (a new
        # user's r7 K9: the note was said of one)
        named = {
            s.head: _operators(s) for s in self._analysed if not any(p.file.pair for p in s.parts)
        }
        return {head: names for head, names in named.items() if len(names) > 1}

    def operator_notes(self) -> list[str]:
        """A session of two operators, said: one placing multiplier for both parts' trials
        (the session's), pooled with neither operator's other sessions."""
        return [
            f"{head}: its parts were recorded by {len(names)} operators ({', '.join(names)}): "
            "its trials are analysed as one session, one placing multiplier for all of them, "
            "pooled with neither operator's other sessions; to give each operator's trials "
            "their own, analyse each part's file in a run without the other"
            for head, names in self.of_operators.items()
        ] + self.case_notes()

    def case_notes(self) -> list[str]:
        """Operator names of the run that differ only in case (or spaces around them),
        said: they are taken as one operator (pooled, a rig file's ``operators``)."""
        named = (f.info.operator for f in self.found if f.info is not None)
        return [
            f"operator names {', '.join(names)} differ only in case: taken as one operator "
            f"({names[0]})"
            for names in spelled_apart(named)
        ]

    def run_notes(self) -> list[str]:
        """What ``run`` says: :meth:`notes`, and the board sessions it leaves to ``rig``."""
        return self.notes() + [
            f"{s.path}: a board session (it calibrates the rig): for `twopose-analyze rig`, "
            "not analysed here"
            for s in self.boards
        ]


def _operators(strand: Strand) -> tuple[str, ...]:
    """The operators a strand's parts name (each part's session entry: a continuation's
    ``--operator`` is who recorded it), once each (case folded), in order; unnamed ones
    left out."""
    return operators_of(p.file.info.operator for p in strand.parts if p.file.info is not None)


def sessions_said(strands: Iterable[tuple[str, str]], verb: str = "") -> str:
    """How many sessions ``strands`` are, ``(session id, branch)`` each: ``3 session(s)``,
    and when some session is in more than one strand (analysed apart), how: a fork's
    branches, or the parts before and after a part not among the inputs (``verb`` after
    the count: ``3 session(s) analysed, taken as 5 (...)``). Counts of
    sessions count sessions (``info``, ``run``, the report), never files or strands."""
    groups: dict[str, list[str]] = {}
    for session_id, branch in strands:
        groups.setdefault(session_id, []).append(branch)
    n_strands = sum(len(g) for g in groups.values())
    said = f"{len(groups)} session(s)" + (f" {verb}" if verb else "")
    if n_strands == len(groups):
        return said
    forked = [g for g in groups.values() if len(set(g)) > 1]
    # Two strands on one branch: a part between them is missing (its later part can only
    # start a strand of its own).
    broken = [g for g in groups.values() if len(g) > len(set(g))]
    how = []
    if forked:
        n = sum(len(set(g)) for g in forked)
        how.append(f"{len(forked)} forked into {n} branches")
    if broken:
        how.append(f"{len(broken)} split by a missing part")
    return f"{said}, taken as {n_strands} ({'; '.join(how)})"


def resolve_inputs(paths: str | Path | Sequence[str | Path] | InputSet) -> InputSet:
    """The one resolution of a batch's paths (see the module docstring).

    ``paths`` is a path, a sequence of paths (files and folders), or an :class:`InputSet`
    already resolved (returned as it is, so a command resolves once and hands the set to
    each step). Raises :class:`~twopose.errors.InputValueError` for a path that does not
    exist.
    """
    if isinstance(paths, InputSet):
        return paths
    if isinstance(paths, str | Path):
        paths = [paths]
    skipped: list[str] = []
    by_digest: dict[str, list[str]] = {}  # each content -> its paths, in the order given
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
        by_digest.setdefault(file_digest(path), []).append(str(path))
    found: list[FoundSession] = []
    others: list[tuple[str, str, str]] = []
    kept_why: list[tuple[str, str]] = []
    for digest, copies in by_digest.items():  # byte copies: one read, the others said
        kept = copies[0]
        if len(copies) > 1:
            kept, why = kept_of_copies(copies)
            kept_why.append((kept, why))
            others += [(p, kept, "a byte copy") for p in copies if p != kept]
        found.append(identify_file(kept, digest))
    measuring = [s for s in found if not s.is_board]
    resolution = resolve_session_files(measuring)
    return InputSet(
        found=tuple(found),
        others=(*others, *resolution.others),
        skipped=tuple(skipped),
        repeats=tuple(repeats),
        strands=resolution.strands,
        strand_notes=resolution.notes,
        kept_why=(*kept_why, *resolution.kept_why),
    )
