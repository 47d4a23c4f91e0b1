"""``twopose-analyze rig``: the rig's constants from calibration sessions (sessions with
known targets), in one call: replay them (:mod:`analysis.session.pipeline`), then estimate
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
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from analysis.batch.inputs import InputSet
from analysis.rig.data import RigData, combine, prepare_session, require_trusted
from analysis.rig.fit import RigFit, fit_constants, select_constants
from analysis.session.pipeline import replay_views
from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError
from twopose.solve.estimate import EstimateOptions
from twopose.solve.session import SessionTrials, estimate_session
from twopose.uncertainty.noise import PlacingSigma
from twopose.values.units import Units

__all__ = ["RigCalibration", "calibrate", "calibrate_rig", "placing_against_truth", "with_rig"]

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
    #: Simulated board sessions: the placing the simulator drew, the RMS of every used
    #: capture's three true placing errors (session units; ``/simulation/truth``), to set
    #: ``placing`` against. None: a session without its truth (every recorded one).
    true_placing: float | None = None


def placing_against_truth(placing: PlacingSigma, true_rms: float, units: Units) -> str:
    """The measured placing sigma set against the placing a simulator drew, in words.

    ``true_rms`` (session ``units``) is :attr:`RigCalibration.true_placing`: the issue's
    target, the board's placing sigma within 25% of the truth, judged on the draw itself
    (a draw's RMS scatters about the ``--pose-noise`` it was drawn with).
    """
    measured = placing.sigma(units)
    head = (
        f"the placing the simulator drew (/simulation/truth): RMS {true_rms:.3g} {units} "
        f"over the {placing.captures} captures' components"
    )
    if true_rms < 1e-9:  # no placing drawn (its rig undone to rounding)
        return f"{head}: none drawn"
    if placing.upper_bound:
        return f"{head}; the upper bound is {measured / true_rms:.2f}x it"
    ratio = f"{head}; the measured sigma is {measured / true_rms:.2f}x it"
    spread = placing.sigma_sigma_in / placing.sigma_in * measured / true_rms
    return f"{ratio} (± {spread:.2f}x)" if math.isfinite(spread) else ratio


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
    from analysis.batch.inputs import resolve_inputs
    from analysis.rig.board import calibrate_board

    inputs = resolve_inputs(paths)  # once (or as given), as run and info: copies said
    for text in inputs.notes():
        (on_note or (lambda _text: None))(text)
    pairs = {s.path for s in inputs.measured if s.pair}  # stream trials: no typed pose
    for path in sorted(pairs):
        (on_note or (lambda _text: None))(
            f"{path}: a two-camera session (no typed pose): the rig's constants are not "
            "fitted from it"
        )
    boards, targets = [s.path for s in inputs.boards], [f for f in inputs.files if f not in pairs]
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
            true_placing=board.true_placing,
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
    def units(self) -> Units:
        """The session's units."""
        return self.trials.units


def _distinct(
    paths: Sequence[str], note: Note, continuations: Mapping[str, Sequence[str]]
) -> list[_Distinct]:
    """Each session once, in the order given (the same file or a byte copy was taken once
    already: :func:`analysis.batch.inputs.resolve_inputs`): a session whose trials are those
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


def with_rig(
    options: AnalysisOptions, path: str | Path, inputs: InputSet, on_note: Note
) -> AnalysisOptions:
    """``options`` with the rig file at ``path`` for every session under ``inputs``
    (``run --rig``, :func:`analysis.rig.scope.rig_scope`): read, checked against each
    session (refused before any analysis), its constants, placing sigma and covariance in
    the options (:meth:`analysis.rig.scope.RigUse.options`)."""
    from analysis.rig.scope import rig_scope

    scope = rig_scope(inputs, path, on_note=on_note)
    return scope.uses[0].options(options) if scope.uses else options
