"""Which rig file each session of a run uses (issue 56, item 4): a rig file has a scope.

A file named :data:`RIG_BESIDE` (``rig.toml``) applies to the sessions in its folder and
below, wherever the command line starts: each session takes the nearest one up the tree
from its own folder (the folder it lies in, then its parent, and so on to the file
system's root, by the path as given, ``..`` resolved as written). So ``run lab/`` gives
``lab/a/rig.toml`` to ``lab/a/**`` and ``lab/b/rig.toml`` to ``lab/b/**``; ``run a b``
never gives ``a``'s rig to ``b``'s sessions; and a session given by itself, deep in a
tree, still takes its folder's rig. ``--rig FILE`` applies one file to every session (the
analyst's choice, said), ``--no-rig`` none. A session whose parts (its continuations) lie
under different rig files is refused, naming them: one laptop's recording takes one rig.

Every rig file is read once (:func:`twopose.rig.file.load_rig_file`) and checked against
every session it applies to before anything is analysed (:func:`check_rig_for_sessions`:
units, camera, plausibility), so a run never stops half-way on a rig. Each session's row
says which file it used (``rig_file`` in ``trials.csv`` and ``summary.csv``), and a
session's options carry its rig (:meth:`RigScope.options_for`): its constants correct
its views, its ``[placing]`` is its regions' placing sigma and its covariance is carried
into them; the session cache keys each session on its own options.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from twopose.errors import InputValueError
from twopose.rig.file import RigFile, load_rig_file
from twopose.values.operators import operator_key

if TYPE_CHECKING:
    from analysis.batch.inputs import InputSet
    from analysis.results import AnalysisOptions, RigSource, RunResult
    from twopose.uncertainty.noise import PlacingSigma

__all__ = [
    "RIG_BESIDE",
    "RigScope",
    "RigUse",
    "check_rig_for_sessions",
    "nearest_rig",
    "placing_notes",
    "rig_file_columns",
    "rig_files_json",
    "rig_lines",
    "rig_scope",
    "run_rig_sources",
]

Note = Callable[[str], None]

#: The name of a rig file that applies to the sessions in its folder and below.
RIG_BESIDE = "rig.toml"


@dataclass(frozen=True, kw_only=True)
class RigUse:
    """One rig file as a run applies it: where it is (as found or given), its content's
    SHA-256, what it holds, and how it was chosen (``--rig``, or found up the tree)."""

    path: str
    sha256: str
    file: RigFile
    given: bool = False

    @classmethod
    def read(cls, path: str | Path, *, given: bool = False) -> RigUse:
        """The rig file at ``path``, read and checked (:func:`load_rig_file`)."""
        found = load_rig_file(path)
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        return cls(path=str(path), sha256=digest, file=found, given=given)

    def placing_for(self, operators: tuple[str, ...]) -> PlacingSigma | None:
        """The file's ``[placing]`` for a session of ``operators`` (None: none applies).

        A board's placing is its operators' hand (``operators`` in the table): another
        operator's session starts from its typed resolution. A table that names none (a rig
        file from before they were recorded) applies to every operator, and is said so
        (:func:`placing_notes`).
        """
        placing = self.file.placing
        if placing is None or not placing.operators:
            return placing
        mine = {operator_key(n) for n in operators}  # "ada" is "Ada"
        return placing if mine <= {operator_key(n) for n in placing.operators} else None

    def options(self, options: AnalysisOptions, operators: tuple[str, ...] = ()) -> AnalysisOptions:
        """``options`` with this rig: every view corrected by its constants, every region
        given its placing sigma (when the file records one, and it is the placing of the
        session's ``operators``: :meth:`placing_for`) and carrying its constants'
        covariance (``estimate.noise``)."""
        from analysis.results import RigSource

        noise = dataclasses.replace(
            options.estimate.noise,
            placing=self.placing_for(operators) or options.estimate.noise.placing,
            rig=self.file.constants.covariance,
        )
        estimate = dataclasses.replace(options.estimate, noise=noise)
        source = RigSource(
            path=self.path, sha256=self.sha256, constants=self.file.constants, given=self.given
        )
        return dataclasses.replace(
            options, rig=self.file.constants, rig_source=source, estimate=estimate
        )


@dataclass(frozen=True, kw_only=True)
class RigScope:
    """Which rig file each session (by its first part's path) uses; None: none."""

    by_session: Mapping[str, RigUse | None] = field(default_factory=dict)
    #: each session's operators (its parts' session entries; empty: none named)
    operators: Mapping[str, tuple[str, ...]] = field(default_factory=dict)

    def of(self, session: str) -> RigUse | None:
        """The rig file ``session`` uses (None: none)."""
        return self.by_session.get(session)

    @property
    def uses(self) -> tuple[RigUse, ...]:
        """Every rig file the run uses, each once, in the sessions' order."""
        found = {u.path: u for u in self.by_session.values() if u is not None}
        return tuple(found.values())

    @property
    def paths(self) -> tuple[Path, ...]:
        """The rig files' paths (inputs no output may replace)."""
        return tuple(Path(u.path) for u in self.uses)

    def options_for(self, session: str, options: AnalysisOptions) -> AnalysisOptions:
        """The options ``session`` is analysed with: ``options`` with its rig, if any."""
        use = self.of(session)
        return options if use is None else use.options(options, self.operators.get(session, ()))


def run_rig_sources(
    rigs: RigScope | None, options: AnalysisOptions, files: Sequence[str]
) -> tuple[RigSource | None, tuple[RigSource, ...]]:
    """A run's rig files (:class:`analysis.results.RunResult`'s ``rig_source`` and
    ``rig_files``): the one every session used (None: none did, or several), and every
    one used, each once, in the sessions' order. Without a scope, the options' rig."""
    if rigs is None:
        given = options.rig_source
        return given, (given,) if given is not None else ()
    first: dict[str, str] = {}
    for f in files:
        use = rigs.of(f)
        if use is not None:
            first.setdefault(use.path, f)
    used = tuple(
        s for f in first.values() if (s := rigs.options_for(f, options).rig_source) is not None
    )
    every = len(used) == 1 and all(rigs.of(f) is not None for f in files)
    return (used[0] if every else None), used


def rig_file_columns(options: AnalysisOptions) -> dict[str, str]:
    """``trials.csv``'s ``rig_file`` and ``rig_sha256`` of a session analysed with
    ``options``: its rig file (empty without); constants given in the options alone (a
    notebook's) are said so."""
    source = options.rig_source
    if source is not None:
        return {"rig_file": source.path, "rig_sha256": source.sha256}
    if options.rig is not None:
        return {"rig_file": "(constants given, no file)", "rig_sha256": ""}
    return {"rig_file": "", "rig_sha256": ""}


def nearest_rig(session: str | Path, cache: dict[str, Path | None] | None = None) -> Path | None:
    """The :data:`RIG_BESIDE` file nearest up the tree from ``session``'s folder (None:
    none up to the root); relative to the working folder when ``session`` is given so.
    ``cache`` remembers each folder's answer for a batch."""
    found = _nearest_absolute(session, {} if cache is None else cache)
    if found is None or os.path.isabs(session):
        return found
    return Path(os.path.relpath(found))


def _nearest_absolute(session: str | Path, memo: dict[str, Path | None]) -> Path | None:
    """:func:`nearest_rig`, its answer absolute."""
    folder = os.path.dirname(os.path.normpath(os.path.abspath(session)))
    walked = []
    found: Path | None = None
    while True:
        if folder in memo:
            found = memo[folder]
            break
        walked.append(folder)
        candidate = Path(folder) / RIG_BESIDE
        if candidate.is_file():
            found = candidate
            break
        parent = os.path.dirname(folder)
        if parent == folder:
            break
        folder = parent
    for seen in walked:
        memo[seen] = found
    return found


def rig_scope(
    inputs: InputSet,
    rig: str | Path | None = None,
    *,
    no_rig: bool = False,
    on_note: Note | None = None,
) -> RigScope:
    """The rig file of every session ``run`` analyses (see the module docstring).

    ``rig`` (``--rig``): one file for every session; ``no_rig`` (``--no-rig``): none (both
    refused); otherwise each session's nearest ``rig.toml`` up the tree. Every file is read
    and checked against each session it applies to before anything is analysed (refused:
    exit 3); ``on_note`` hears the notes (a rig file from before units or cameras were
    recorded).
    """
    note = on_note or (lambda _text: None)
    if no_rig and rig is not None:
        raise InputValueError("--rig and --no-rig contradict each other: give one")
    # A two-camera session has no typed pose for a rig to correct: none applies to it.
    pairs = {s.path for s in inputs.measured if s.pair}
    sessions = [f for f in inputs.files if f not in pairs]
    if no_rig or not sessions:
        return RigScope(by_session=dict.fromkeys(inputs.files))
    heads = {f.path: f.info.operator.strip() for f in inputs.found if f.info is not None}
    mixed = inputs.of_operators
    operators = {s: mixed.get(s, tuple(filter(None, [heads.get(s, "")]))) for s in sessions}
    if rig is not None:
        use = RigUse.read(rig, given=True)
        scope = RigScope(by_session=dict.fromkeys(sessions, use), operators=operators)
    else:
        found = _found(sessions, inputs.continuations)
        scope = RigScope(by_session=found, operators=operators)
    for use in scope.uses:
        applies = [s for s, u in scope.by_session.items() if u is not None and u.path == use.path]
        parts = [p for s in applies for p in (s, *inputs.continuations.get(s, ()))]
        for text in check_rig_for_sessions(use.file, parts, f"rig file {use.path}"):
            note(text)
        for text in placing_notes(use, {s: operators[s] for s in applies}):
            note(text)
    return scope


def placing_notes(use: RigUse, operators: Mapping[str, tuple[str, ...]]) -> list[str]:
    """Whose placing a rig file's ``[placing]`` is, beside the sessions it covers
    (``operators``: each one's), in words: the sessions of other operators it is not
    applied to, or, when it names no operator, that it is applied to every one."""
    placing = use.file.placing
    if placing is None or placing.upper_bound:
        return []
    named = sorted({n for names in operators.values() for n in names})
    what = f"rig file {use.path}'s [placing] ({placing.measured_by})"
    if not placing.operators:
        if not named:
            return []
        return [
            f"{what} records no operator: it is applied to every operator's sessions it "
            f"covers ({', '.join(named)}) as their placing sigma; fit it again with "
            "twopose-analyze rig to record whose placing it is"
        ]
    others = [s for s, names in operators.items() if use.placing_for(names) is None]
    if not others:
        return []
    theirs = {operator_key(n) for n in placing.operators}
    names = {n for s in others for n in operators[s] if operator_key(n) not in theirs}
    who = sorted(names) or ["none"]
    shown = ", ".join(Path(s).name for s in others[:4]) + (", ..." if len(others) > 4 else "")
    return [
        f"{what} is operator {', '.join(placing.operators)}'s: not applied to "
        f"{len(others)} session{'s' if len(others) != 1 else ''} of other operators "
        f"({', '.join(who)}: {shown}): their regions start from their typed resolution"
    ]


def _found(
    sessions: Sequence[str], continuations: Mapping[str, Sequence[str]]
) -> dict[str, RigUse | None]:
    """Each session's nearest rig file, read once each; a session whose parts lie under
    different rig files is refused."""
    folders: dict[str, Path | None] = {}
    read: dict[Path, RigUse] = {}
    out: dict[str, RigUse | None] = {}
    for session in sessions:
        found = nearest_rig(session, folders)
        for part in continuations.get(session, ()):
            other = nearest_rig(part, folders)
            if other != found:
                named = " and ".join(str(p) if p else "none" for p in (found, other))
                raise InputValueError(
                    f"{session} and its continuation {part} lie under different rig files "
                    f"({named}): one recording takes one rig; move the files under one "
                    "folder, or choose with --rig FILE or --no-rig"
                )
        if found is not None and found not in read:
            try:
                read[found] = RigUse.read(found)
            except InputValueError as err:  # a rig.toml the analyst may not know is there
                raise InputValueError(
                    f"{err} (found up the tree from {session}: a rig.toml applies to its "
                    "folder and below; fix it, or choose with --rig FILE or --no-rig)"
                ) from None
        out[session] = read[found] if found is not None else None
    return out


def check_rig_for_sessions(rig: RigFile, paths: Sequence[str], what: str) -> list[str]:
    """Refuse the rig (before anything is analysed) for a session in other units than the
    rig's, taken by another camera, or whose ground height or images it is implausible
    for (:func:`twopose.rig.check_applicable`); returns the notes to show, once each. A
    file that is not a readable session is left for the analysis to report."""
    import numpy as np

    from twopose.errors import TwoposeError
    from twopose.format.reader import SessionReader
    from twopose.rig.constants import check_applicable

    notes: list[str] = []
    for path in paths:
        try:
            with SessionReader(path) as reader:
                units, ground = reader.info.units, reader.ground
                cameras = [c.intrinsics for c in reader.cameras.values()]
        except (TwoposeError, OSError):  # not a readable session: the analysis says why
            continue
        spec = (np.array(ground.normal_grid), ground.offset) if ground is not None else None
        try:
            found = check_applicable(rig.constants, units, spec, (), what, cameras=cameras)
        except InputValueError as err:
            raise InputValueError(f"{err} (session {path})") from None
        for text in found:
            if text not in notes:
                notes.append(text)
    return notes


def rig_lines(result: RunResult) -> list[str]:
    """What a run says of its rig files (the terminal and the report): each one, with how
    many of the run's sessions it corrected, and the sessions under none when some were
    (nothing when no session used one)."""
    if not result.rig_files:
        return []
    per_session = _rig_of_sessions(result)
    lines = []
    for source in result.rig_files:
        n = sum(1 for path in per_session.values() if path == source.path)
        how = "given by --rig" if source.given else "found up the tree: its folder and below"
        lines.append(
            f"rig file {source.path} ({how}; sha256 {source.sha256[:16]}...): every view of "
            f"{n} session(s) corrected by its constants, their regions carrying its covariance"
        )
    none = sum(1 for path in per_session.values() if not path)
    if none:
        lines.append(f"{none} session(s) under no rig file: their views as typed")
    return lines


def rig_files_json(result: RunResult) -> list[dict[str, object]]:
    """``summary.json``'s ``rig_files``: each rig file the run used and its sessions."""
    per_session = _rig_of_sessions(result)
    return [
        {
            **source.to_json(),
            "sessions": [s for s, path in per_session.items() if path == source.path],
        }
        for source in result.rig_files
    ]


def _rig_of_sessions(result: RunResult) -> dict[str, str]:
    """Each analysed session's rig file (trials.csv ``rig_file``; "" none)."""
    return {
        s.session: str(s.trials["rig_file"].iloc[0]) if len(s.trials) else ""
        for s in result.sessions
        if "rig_file" in s.trials
    }
