"""``twopose-analyze rig``: the rig's constants from calibration sessions (sessions with
known targets), in one call: replay them (:mod:`analysis.pipeline`), then estimate
(:mod:`analysis.rig.fit`).

Each session is solved with its own ground plane, intrinsics and units; sessions in
different units are refused (the constants' lengths have one unit, which the rig file
records). A session given twice, by the same path or with the same content (the same
replayed trials: a copy, or a recovered rewrite of the file), is counted once, with a note;
so is a session that informs nothing (no ok trial with ground truth). The sessions are
combined in an order of their content, not of the command line, so naming them in another
order, or twice, gives the same constants.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from analysis.input_set import InputSet
from analysis.pipeline import replay_views
from analysis.rig.data import RigData, combine, prepare_session, require_trusted
from analysis.rig.fit import RigFit, fit_constants, select_constants
from twopose.camera import Intrinsics
from twopose.errors import InputValueError
from twopose.estimate import EstimateOptions
from twopose.noise import PlacingSigma
from twopose.rig.constants import RigConstants, check_applicable
from twopose.rig.file import RigFile
from twopose.session_estimate import SessionTrials, estimate_session

__all__ = [
    "RIG_BESIDE",
    "RigCalibration",
    "calibrate",
    "calibrate_rig",
    "check_rig_for_sessions",
    "rig_beside",
    "rig_for_run",
    "with_rig",
]

if TYPE_CHECKING:
    from analysis.results import AnalysisOptions

Note = Callable[[str], None]


@dataclasses.dataclass(frozen=True, kw_only=True)
class RigCalibration:
    """What ``twopose-analyze rig`` found: the fit, the sessions that informed it (in the
    order given), what it was fitted on (in words) and the fit's warnings."""

    fit: RigFit
    sessions: tuple[str, ...]
    basis: str
    warnings: tuple[str, ...] = ()
    #: The operator's placing sigma a board measured (None: target sessions, which do not).
    placing: PlacingSigma | None = None


def calibrate_rig(
    paths: Sequence[str | Path] | InputSet,
    groups: Sequence[str] | None = None,
    on_note: Note | None = None,
) -> RigCalibration:
    """``twopose-analyze rig``: the rig's constants from board or from target sessions.

    Board sessions are fitted by :func:`analysis.rig.board.calibrate_board`, target
    sessions by :func:`calibrate`; a mix of the two is refused.

    Parameters
    ----------
    paths : sequence of path-like, or InputSet
        Session files and folders, or a set already resolved.
    groups : sequence of str, optional
        The constants to fit (``--constant``); default: those the sessions support.
    on_note : callable, optional
        Hears what the command says about its inputs (copies counted once, ...).

    Returns
    -------
    RigCalibration
        The fit, the sessions it used, its warnings and its basis (board or targets).
    """
    from analysis.input_set import resolve_inputs
    from analysis.rig.board import calibrate_board

    inputs = resolve_inputs(paths)  # once (or as given), as run and info: copies said
    for text in inputs.notes():
        (on_note or (lambda _text: None))(text)
    boards, targets = [s.path for s in inputs.boards], inputs.files
    if boards and targets:
        raise InputValueError(
            f"board sessions ({', '.join(boards)}) and target sessions fit the rig in "
            "different ways: calibrate with one kind (board sessions alone are enough)"
        )
    if boards:
        board = calibrate_board(boards, groups, on_note)
        b = board.board
        basis = f"{b.n_captures} board capture(s), {b.n_corners} corners, RMS {b.rms_px:.3f} px"
        return RigCalibration(
            fit=board.fit,
            sessions=board.sessions,
            basis=basis,
            warnings=b.warnings,
            placing=b.placing,
        )
    fit, data = calibrate(targets, groups, on_note, inputs.continuations)
    basis = f"{len(data.trial_ids)} trial(s) with ground truth"
    return RigCalibration(fit=fit, sessions=data.sessions, basis=basis, warnings=fit.warnings)


def calibrate(
    paths: Sequence[str],
    groups: Sequence[str] | None = None,
    on_note: Note | None = None,
    continuations: Mapping[str, Sequence[str]] | None = None,
) -> tuple[RigFit, RigData]:
    """``twopose-analyze rig``: the constants of the sessions' rig (one method, one unit,
    every trial with ground truth), the groups given or those cross-validation supports.
    ``on_note`` hears what was left out and why (a session given twice, one without
    trials). The data's ``sessions`` are those that informed the fit, in the order given."""
    note = on_note or (lambda _text: None)
    replays = _distinct(paths, note, continuations or {})
    _one_of(replays, "method", "calibrate the rig with sessions of one method")
    _one_of(
        replays,
        "units",
        "a rig's camera offset and ground height error are lengths in one unit: calibrate "
        "it with sessions in one unit",
    )
    parts: list[RigData] = []
    for replay in sorted(replays, key=lambda r: r.fingerprint):  # not the command line's order
        part = prepare_session(estimate_session(replay.trials, EstimateOptions()))
        if part is None:
            note(f"{replay.session}: no ok trial with ground truth; it informs nothing")
            continue
        parts.append(dataclasses.replace(part, sessions=(replay.session,)))
    data = require_trusted(combine(parts) if parts else None)
    used = {s for p in parts for s in p.sessions}
    data = dataclasses.replace(
        data, sessions=tuple(r.session for r in replays if r.session in used)
    )
    fit = select_constants(data) if groups is None else fit_constants(data, groups)
    cameras = _cameras([r.trials for r in replays if r.session in used])
    constants = dataclasses.replace(fit.constants, cameras=cameras)
    return dataclasses.replace(fit, constants=constants), data


def _cameras(sessions: Sequence[SessionTrials]) -> tuple[Intrinsics, ...]:
    """The cameras the sessions' views were taken with, each once (the rig file's
    ``[[camera]]``: a rig is fitted for them and refused for another)."""
    found = []
    for trials in sessions:
        for row in trials.views:
            for v in row:
                fx, fy, cx, cy = (float(k) for k in v.intrinsics)
                w, h = v.width_height
                found.append(Intrinsics(width=w, height=h, fx=fx, fy=fy, cx=cx, cy=cy))
    return tuple(dict.fromkeys(found))


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Distinct:
    """A replayed session and the fingerprint of what the fit reads from it."""

    session: str
    trials: SessionTrials
    fingerprint: str

    @property
    def method(self) -> str:
        """The session's method."""
        return self.trials.method

    @property
    def units(self) -> str:
        """The session's units."""
        return self.trials.units


def _distinct(
    paths: Sequence[str], note: Note, continuations: Mapping[str, Sequence[str]]
) -> list[_Distinct]:
    """Each session once, in the order given (the same file or a byte copy was taken once
    already: :func:`analysis.input_set.resolve_inputs`): a session whose trials are those
    of an earlier one (a rewritten file) is left out, with a note."""
    seen_content: dict[str, str] = {}
    out: list[_Distinct] = []
    for path in paths:
        r = replay_views(path, continuations=continuations.get(path, ()))
        replay = _Distinct(session=path, trials=r, fingerprint=_fingerprint(r))
        if replay.fingerprint in seen_content:
            first = seen_content[replay.fingerprint]
            note(f"{path} holds the same session as {first} (the same trials): counted once")
            continue
        seen_content[replay.fingerprint] = path
        out.append(replay)
    return out


def _fingerprint(replay: SessionTrials) -> str:
    """A hash of what the fit reads from a session: method, units, ground plane, trials,
    truth and every pose's camera, typed pose and detections (the session format has no
    session id, so a copy or a rewritten file is known by its content)."""
    h = hashlib.sha256()

    def add(value: Any) -> None:
        array = np.ascontiguousarray(np.asarray(value))
        h.update(f"{array.dtype.str}{array.shape}".encode())
        h.update(array.tobytes())

    h.update(f"{replay.method}|{replay.units}|".encode())
    if replay.ground is not None:
        add(replay.ground[0])
        add(float(replay.ground[1]))
    add(np.asarray(replay.trial_ids, dtype=np.int64))
    add(np.asarray(replay.truth, dtype=np.float64))
    for row in replay.views:
        h.update(b"|trial")
        for v in row:
            values: tuple[Any, ...] = (v.pose, v.intrinsics, v.width_height, v.t_grid, v.r_deg)
            for value in (*values, v.t_sigma, v.r_sigma_deg, v.centroids, v.thetas, v.found):
                add(value)
    return h.hexdigest()


def _one_of(replays: Sequence[_Distinct], attribute: str, why: str) -> None:
    """Refuse sessions that differ in ``attribute``, naming each with its value."""
    values = {getattr(r, attribute) for r in replays}
    if len(values) > 1:
        named = ", ".join(f"{r.session} ({getattr(r, attribute)})" for r in replays)
        raise InputValueError(f"sessions of different {attribute}: {named}; {why}")


def check_rig_for_sessions(rig: RigConstants, paths: Sequence[str], what: str) -> list[str]:
    """``run --rig``: refuse the rig (before anything is analysed) for a session in other
    units than the rig's, or implausible for the session's ground height or images
    (:func:`twopose.rig.check_applicable`); returns the notes to show, once each. A file
    that is not a readable session is left for the analysis to report."""
    from twopose.errors import TwoposeError
    from twopose.format.reader import SessionReader

    notes: list[str] = []
    for path in paths:
        try:
            with SessionReader(path) as reader:
                units = reader.info.units
                ground = reader.ground
                sizes = [(c.intrinsics.width, c.intrinsics.height) for c in reader.cameras.values()]
        except (TwoposeError, OSError):  # not a readable session: the analysis says why
            continue
        spec = (np.array(ground.normal_grid), ground.offset) if ground is not None else None
        try:
            found = check_applicable(rig, units, spec, sizes, what)
        except InputValueError as err:
            raise InputValueError(f"{err} (session {path})") from None
        for text in found:
            if text not in notes:
                notes.append(text)
    return notes


def rig_for_run(path: str | Path, inputs: InputSet, on_note: Note) -> RigFile:
    """``run --rig``: the rig file (its constants and any measured placing sigma), refused
    (exit 3, before any analysis) if implausible, or for a session under ``inputs`` in
    other units, or whose ground height or image it does not fit; ``on_note`` hears the
    notes (a rig file without units)."""
    from twopose.rig.file import load_rig_file

    found = load_rig_file(path)
    for text in check_rig_for_sessions(found.constants, inputs.files, f"rig file {path}"):
        on_note(text)
    return found


#: A rig file of this name in a folder ``run`` is given, or beside a session file it is
#: given, is used as ``--rig`` would use it, and said; ``--rig FILE`` names another,
#: ``--no-rig`` none.
RIG_BESIDE = "rig.toml"


def rig_beside(paths: Sequence[str | Path]) -> Path | None:
    """The :data:`RIG_BESIDE` file beside the sessions ``run`` is given, if any.

    Looked for in each folder given (not below it) and beside each file given; the same
    content found twice is one file; different files are refused, naming them (which one
    applies is the analyst's choice, never an order's).
    """
    found: dict[str, Path] = {}
    for given in map(Path, paths):
        candidate = (given if given.is_dir() else given.parent) / RIG_BESIDE
        if candidate.is_file():
            found.setdefault(hashlib.sha256(candidate.read_bytes()).hexdigest(), candidate)
    if len(found) > 1:
        named = ", ".join(str(p) for p in found.values())
        raise InputValueError(
            f"different rig files beside the sessions ({named}): name the one to use with "
            "--rig FILE, or --no-rig to use none"
        )
    return next(iter(found.values()), None)


def with_rig(
    options: AnalysisOptions, path: str | Path, inputs: InputSet, on_note: Note
) -> AnalysisOptions:
    """``options`` with the rig file at ``path`` (:func:`rig_for_run`): every view corrected
    by its constants, and every region given its measured placing sigma
    (``estimate.noise.placing``) when the file records one."""
    from analysis.results import RigSource

    found = rig_for_run(path, inputs, on_note)
    estimate = options.estimate
    if found.placing is not None:
        noise = dataclasses.replace(estimate.noise, placing=found.placing)
        estimate = dataclasses.replace(estimate, noise=noise)
    source = RigSource.read(path, found.constants)
    return dataclasses.replace(options, rig=found.constants, rig_source=source, estimate=estimate)
