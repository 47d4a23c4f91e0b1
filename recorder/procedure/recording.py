"""A recording, start to end: the procedure's machine (:mod:`recorder.procedure.machine`) driven
trial by trial, pose by pose, from a frame source, with the live result, guidance and
preview steps between; who decides is a :class:`recorder.procedure.driver.Driver`: the operator at
the terminal (:mod:`recorder.procedure.terminal`), the console, a plan file
(:mod:`recorder.setup.plan`)
or the simulator (:mod:`recorder.simulate.one_camera`)."""

from __future__ import annotations

import contextlib
import errno
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from recorder.live.result import LiveResults, live_results
from recorder.procedure import stops
from recorder.procedure.capture import (
    CaptureResult,
    CaptureSettings,
)
from recorder.procedure.driver import (
    Decision,
    Driver,
    ProcedureRefusedError,
    QuitRecording,
)
from recorder.procedure.machine import Procedure, State, refuse_existing
from recorder.procedure.summary import RecordingSummary, Tally
from recorder.setup.rules import with_guidance
from recorder.sources.registry import FrameSource, SourceInfo
from twopose.camera.model import Camera
from twopose.errors import InputValueError, TwoposeError
from twopose.format.entries import (
    Note,
    PlaneEntry,
    SessionInfo,
)
from twopose.format.reader import recover_command
from twopose.format.writer import SessionWriter
from twopose.values.checks import Vec3

if TYPE_CHECKING:
    from twopose.methods.targets import BoardPlacement

__all__ = ["board_progress", "record"]


@dataclass(frozen=True, kw_only=True)
class _CaptureOptions:
    settings: CaptureSettings
    results: LiveResults | None = None  # with live detection: each trial's live result


def _announce(
    w: SessionWriter,
    info: SessionInfo,
    settings: CaptureSettings,
    results: LiveResults | None,
    driver: Driver,
) -> None:
    """What a recording says as it begins: its stop rule, as a note in the file (recorded,
    not typed: a session ended before its first pose still leaves no file), and the live
    result's notes to the operator."""
    guidance = settings.guidance
    if guidance is not None and guidance.target95 is not None and results is not None:
        w.write_note(Note(text=guidance.describe(info.units)))
    for note in getattr(results, "notes", ()):
        driver.notice(note)


def record(  # noqa: PLR0913 - keyword-only settings of a recording
    path: str | Path,
    info: SessionInfo,
    cameras: Sequence[Camera],
    source: FrameSource,
    driver: Driver,
    *,
    ground: PlaneEntry | None = None,
    capture: CaptureSettings | None = None,
    writer_options: dict[str, Any] | None = None,
    after_trial: int = 0,
) -> RecordingSummary:
    """Record a new session at ``path`` from the (unopened) ``source``, as ``driver`` says.

    Every pose is captured as ``capture`` says (5 frames, no live detection, by default);
    its ``target`` turns on live detection feedback and the live result. Whatever stops
    the recording (the driver, an error, Ctrl-C) leaves a closed, valid session holding
    everything captured so far, with an undecided capture discarded. Ctrl-C returns the
    summary with ``interrupted`` set; any other error propagates after the file is closed.
    A recording that ends before the first pose is typed leaves no file (``kept`` False).
    ``after_trial``: a continuation's trials are numbered after the session's it continues.
    """
    out = Path(path)
    refuse_existing(out)
    tally = Tally(after_trial=after_trial)  # the summary counts this file's trials
    settings = capture or CaptureSettings()
    results = None
    if settings.target is not None:  # the live result needs the live detection
        results = live_results(info, cameras, ground, settings)
    options = _CaptureOptions(settings=settings, results=results)
    info = with_guidance(info, settings.guidance)  # format 1.5: recorded, for continuations
    interrupted = False
    proc: Procedure | None = None
    try:
        with contextlib.ExitStack() as stack:
            stack.enter_context(source)  # a stop while it opens: nothing recorded, below
            if results is not None:  # the scene's clutter, where the source knows it
                results.known_clutter = source.clutter()
            _check_frame_size(source.info, cameras)  # before the file exists
            w = stack.enter_context(
                SessionWriter(out, info, cameras, ground=ground, **(writer_options or {}))
            )
            proc = Procedure(w, tally)
            proc.trial, driver.first_trial = after_trial, after_trial + 1
            driver.start(source.info, out)
            _announce(w, info, settings, results, driver)
            try:
                _run(proc, source, driver, options)
                stops.check()  # a stop asked as the last step ended: still an interrupt
                proc.close("quit")
            except QuitRecording:
                proc.close("quit")
            except KeyboardInterrupt:
                interrupted = True
                proc.close(f"interrupted ({stops.describe()})")
            except BaseException as err:
                proc.close(f"the recording stopped: {type(err).__name__}: {err}")
                raise
    except OSError as err:  # the disk filled up, or the file system failed under us
        full = err.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
        raise TwoposeError(
            f"writing {out} failed: {'the disk is full' if full else err.strerror or err}. "
            f"What reached the disk can be salvaged: {recover_command(out)}"
        ) from err
    except KeyboardInterrupt:  # a stop before the procedure began (a source opening)
        if proc is not None:
            raise
        interrupted = True
    kept = proc is not None and proc.n_operator_entries > 0
    if kept and results is not None:  # what it says of the operator's placing, kept
        results.remember(info, out, driver.notice)
    if not kept and proc is not None:  # an empty session would only block the name
        out.unlink(missing_ok=True)
    counts = proc if proc is not None else _NothingBegun(trial=after_trial)
    summary = tally.summary(out, counts, interrupted=interrupted, kept=kept)
    driver.finish(summary)
    return summary


@dataclass(kw_only=True)  # mutable, as the procedure's counts (TrialCounts)
class _NothingBegun:
    """The counts of a recording stopped before its procedure began."""

    trial: int
    n_complete_trials: int = 0


def _check_frame_size(source: SourceInfo, cameras: Sequence[Camera]) -> None:
    """Refuse a source whose frames do not have the calibrated size: every frame would be
    rejected by the analysis (the calibration would not apply to them)."""
    sizes = {(c.intrinsics.width, c.intrinsics.height) for c in cameras}
    if (source.width, source.height) not in sizes:
        want = " or ".join(f"{w}x{h}" for w, h in sorted(sizes))
        raise InputValueError(
            f"{source.description} delivers {source.width}x{source.height} frames, but the "
            f"camera calibration is for {want}: calibrate this camera mode, or request "
            "the calibrated size (--width/--height)"
        )


def _run(proc: Procedure, source: FrameSource, driver: Driver, opts: _CaptureOptions) -> None:
    """Trial after trial, as long as the driver wants one and does not quit."""
    while not stops.requested() and driver.next_trial(proc.trial + 1):
        trial = proc.trial + 1
        entries = driver.trial_entries(trial)
        proc.begin_trial(trial, driver.poses_in(trial), entries)
        if opts.results is not None:
            opts.results.begin(trial, entries)
        if not _record_trial(proc, source, driver, opts):
            return
        for entry in driver.end_trial(trial):
            proc.write(entry)


def _record_trial(
    proc: Procedure, source: FrameSource, driver: Driver, opts: _CaptureOptions
) -> bool:
    """Pose after pose until the trial's last is accepted; False when the driver quits."""
    while proc.state is not State.READY:
        stops.check()  # a stop asked between steps (recorder/procedure/stops.py)
        placed = driver.place(proc.trial, proc.pose)
        proc.type_pose(placed.entry)
        result = proc.capture(source, opts.settings, true_pose=placed.true_pose)
        driver.captured(proc.trial, proc.pose, result)
        trial = proc.trial
        if opts.results is not None and proc.entry is not None:
            _live(driver, _preview_step, opts.results, proc, driver, result)
        stops.check()  # a capture the stop cut short is never accepted
        if not _decide(proc, driver, result):
            return False
        if opts.settings.board is not None:
            driver.board_progress(*board_progress(proc, opts.settings.board))
        if opts.results is not None:
            _live(driver, _result_step, trial, proc, driver, opts)
            if opts.settings.guidance is not None:
                if proc.state is State.TYPING and proc.accepted:  # a next pose to suggest
                    driver.computing("computing the next suggestion…")
                _live(driver, _guidance_step, trial, proc, driver, opts)
    return True


def board_progress(proc: Procedure, board: BoardPlacement) -> tuple[list[Vec3], str]:
    """The accepted captures that saw the board (their typed camera centres), and why they
    cannot determine the rig yet ("": they can): the rule the rig calibration applies."""
    from twopose.rig.board import check_identifiable

    seen = [entry.t_grid for entry, result in proc.kept.values() if result.n_found > 0]
    try:
        check_identifiable(np.array(seen, dtype=np.float64).reshape(-1, 3), board.first_corner[2])
    except InputValueError as err:
        return seen, str(err)
    return seen, ""


def _live(driver: Driver, step: Callable[..., None], *args: Any) -> None:
    """A step of the live result: whatever fails in it (a rig that makes the geometry
    singular, a bug) is shown to the operator and never stops the recording."""
    try:
        step(*args)
    except Exception as err:  # the file is the record; the live result only a courtesy
        driver.live_failed(
            f"the live result failed ({type(err).__name__}: {err}); the recording goes "
            "on and the analysis will solve the file"
        )


def _preview_step(
    results: LiveResults, proc: Procedure, driver: Driver, result: CaptureResult
) -> None:
    """After a capture: keep its detections, and from the trial's second pose on show the
    result the trial would have if it were accepted (so a degenerate one can be redone)."""
    assert proc.entry is not None
    results.captured(proc.entry, result)
    if result.complete and proc.accepted:
        # Only informs (the trial re-solved): abandoned at once if a stop comes meanwhile.
        accepted = {**proc.accepted, proc.pose: proc.entry}
        preview = stops.abandonable(results.preview, proc.trial, accepted)
        if preview is not None:
            driver.preview_result(preview)


def _result_step(trial: int, proc: Procedure, driver: Driver, opts: _CaptureOptions) -> None:
    """After a decision: the trial's live result if its accepted poses changed (a second
    pose gives one, a third updates it), to the driver and the live view."""
    assert opts.results is not None
    # What is kept for the live result, never for the file: abandoned at once if a stop
    # comes while the session's trials are re-solved (recorder/procedure/stops.py).
    result = stops.abandonable(opts.results.update, trial, dict(proc.accepted))
    if result is None:
        if trial not in opts.results.results:
            driver.result_withdrawn(trial)
        return
    driver.trial_result(result)
    if opts.settings.live is not None:
        scene = stops.abandonable(opts.results.scene, trial)
        opts.settings.live.trial_result(result, scene, time.time_ns())


def _guidance_step(trial: int, proc: Procedure, driver: Driver, opts: _CaptureOptions) -> None:
    """After a decision: the driver hears the trial's guidance and decides whether the stop
    rule ends it; the file records a trial ended so, or ended at ``max_poses`` (a note,
    for the analyst)."""
    assert opts.results is not None
    assert opts.settings.guidance is not None
    # Abandoned at once if the recording is asked to stop meanwhile (Ctrl-C, SIGTERM).
    advice = (
        stops.abandonable(opts.results.advise, trial, opts.settings.guidance)
        if proc.accepted
        else None
    )
    if advice is None:  # an undo left the trial no accepted pose: no advice stands
        driver.advice_withdrawn(trial)
        return
    stop = driver.advice(trial, advice)
    rule = opts.settings.guidance.target95 is not None  # else --poses ends every trial
    if rule and advice.complete and proc.state is State.READY:  # its last pose: max_poses
        proc.note(f"guidance: {advice.text}")
    elif stop and advice.complete and proc.state is State.TYPING:
        proc.note(f"guidance: {advice.text}")
        proc.complete_trial()


def _decide(proc: Procedure, driver: Driver, result: CaptureResult) -> bool:
    """Ask until a decision is taken; False for quit."""
    while True:
        decision = driver.decide(proc.trial, proc.pose, result)
        if decision is Decision.QUIT:
            proc.close("quit before accepting")
            return False
        try:
            if decision is Decision.NOTE:
                proc.note(driver.note(proc.trial).text)
                continue
            if decision in (Decision.ACCEPT, Decision.ACCEPT_ANYWAY):
                anyway = decision is Decision.ACCEPT_ANYWAY
                proc.accept(anyway=anyway, unattended=driver.unattended)
            else:
                {Decision.REDO: proc.redo, Decision.UNDO: proc.undo}[decision]()
            return True
        except ProcedureRefusedError as err:
            driver.refused(err)
