"""One session, start to end: replay -> detection -> measurement -> estimation -> tables.

:func:`analyse_session` opens the session file once and runs the named steps below;
:mod:`analysis.batch.runner` runs it for many sessions. With ``results_path`` it also streams the
session's results.mcap (:mod:`analysis.session.results_mcap`) as the frames are detected. The
frames' detection is :mod:`analysis.session.detection`; the tables' columns, the results
file and the figures are their own modules. A process that decodes frames tunes its
allocator first (:func:`keep_frame_buffers`: glibc's thresholds), here where the decoding is.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from analysis.batch.inputs import SessionIdentity
from analysis.results import AnalysisOptions, SessionResult
from analysis.rig.scope import rig_file_columns
from analysis.session.detection import Detections, detected, given_detections, trial_views
from analysis.session.results_mcap import ResultsWriter, results_writer
from analysis.tables.columns import FRAME_COLUMNS, RIG_TABLE_COLUMNS, typed
from analysis.tables.rows import averaging_table, view_table, with_branch, with_identity
from analysis.tables.trials import trial_table
from twopose.arrays import F64
from twopose.display.scene import scene_of_views
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.reader import SessionReader
from twopose.format.trials import TrialRecord, iter_trials, read_notes
from twopose.methods.specs import spec_of
from twopose.methods.truth import Reported, reported
from twopose.rig.constants import RigConstants, corrected_ground, corrected_view
from twopose.solve.estimate import GroundSpec
from twopose.solve.session import (
    SessionEstimate,
    SessionTrials,
    estimate_session,
    running_estimates,
)
from twopose.values.bounds import GROUND_TRUTH
from twopose.values.units import UnitSpec, unit_spec

if TYPE_CHECKING:
    from analysis.report.figures.cache import FigureCache

__all__ = [
    "Detections",
    "analyse_session",
    "corrected_trials",
    "keep_frame_buffers",
    "replay_views",
]

_ALLOCATOR_TUNED = False


def keep_frame_buffers() -> None:
    """Let glibc reuse freed frame-sized buffers instead of returning them to the kernel.

    Every frame allocates a few 0.3-1 MB temporaries; above glibc's default 128 KiB mmap
    threshold each is a fresh mmap, page-faulted and zeroed, then unmapped. That costs
    memory bandwidth that two workers on two cores share: with the threshold at 32 MiB,
    a batch with ``jobs=2`` ran ~1.5x faster here. glibc only; a no-op elsewhere.
    """
    global _ALLOCATOR_TUNED
    if _ALLOCATOR_TUNED:
        return
    _ALLOCATOR_TUNED = True
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold = -1, -3  # from glibc's malloc.h
    mallopt(m_mmap_threshold, 32 * 1024 * 1024)
    mallopt(m_trim_threshold, 128 * 1024 * 1024)


@dataclass(frozen=True, kw_only=True)
class _Replay:
    """What a session's replay keeps: its trials as one value, and what only the tables
    and the results file read (per trial its last frame, notes, why it was not measured)."""

    session: str
    trials: SessionTrials
    metadata: dict[str, str]
    last_ns: list[int]  # per trial, its last frame's log time (0 when it has none)
    frame_rows: list[dict[str, Any]]
    notes: list[str]  # per trial, the operator's notes joined with " | "
    unmeasured: list[str]  # per trial, why it has fewer than two usable poses ("" if not)
    rig_truth: RigConstants | None = None  # a simulated session's constants, if it had any
    part_of: list[str] = dataclasses.field(default_factory=list)  # per trial, its part's path


def analyse_session(
    path: str | Path,
    options: AnalysisOptions | None = None,
    *,
    render_images: bool = False,
    results_path: str | Path | None = None,
    figure_cache: FigureCache | None = None,
    continuations: Sequence[str | Path] = (),
    identity: SessionIdentity | None = None,
    detections: Sequence[Sequence[Detections]] | None = None,
) -> SessionResult:
    """Replay one session through detection and the solvers.

    Trials with fewer than two complete captures are ``incomplete``; a pose where no frame
    was detected makes its trial ``no_detection``. Every complete pose of a trial is used
    (N >= 2 views); point trials also get the reprojection-optimal estimate (``*_optimal``).

    With ``results_path``, also writes the session's results.mcap there (images with the
    detections drawn on them, and each trial's geometry as a 3-D scene; see
    :mod:`analysis.session.results_mcap`); a session that fails leaves no half-written file.
    With ``render_images``, its figures as PNGs (``images``), reused from ``figure_cache``
    where a previous run drew the same ones (:mod:`analysis.report.figures.cache`).

    Parameters
    ----------
    path : path-like
        The session file.
    options : AnalysisOptions, optional
        Detection, estimation and rig settings (default: the thesis' procedure).
    render_images : bool
        Also draw the session's figures as PNGs.
    results_path : path-like, optional
        Where to write the session's results.mcap.
    figure_cache : FigureCache, optional
        Figures a previous run drew, reused when their digest matches.
    continuations : sequence of path-like
        The session's continuations (``new --continue``), in trial order: replayed after
        ``path`` into one session, a trial number already seen counted once.
    identity : SessionIdentity, optional
        What the session is in its run (:meth:`analysis.batch.inputs.InputSet.identity`: its
        id, label, parts and branches); default: from the files alone, labelled by the
        file's name.
    detections : sequence, optional
        Per part (the file, then each continuation), per trial, per pose, every frame's
        detection, as a run's first pass found them (:mod:`analysis.batch.noise_pass`): not
        detected again.

    Returns
    -------
    SessionResult
        The session's trials, averaging, frames and views tables and its metadata.

    Raises
    ------
    SessionFormatError
        The file is not a readable session (the batch lists it and goes on).
    """
    options = options or AnalysisOptions()
    keep_frame_buffers()
    pair_metadata = _pair_session_metadata(path)
    if pair_metadata is not None:  # stream trials, no typed pose: one row per touch
        from analysis.session.stream_tables import analyse_pair_session

        return analyse_pair_session(
            path, options, metadata=pair_metadata, identity=identity,
            continuations=[str(p) for p in continuations], results_path=results_path,
        )  # fmt: skip
    for later in continuations:  # a one-camera session's parts are one-camera recordings
        if _pair_session_metadata(later) is not None:
            raise InputValueError(
                f"{later} continues the one-camera session {path} but records two cameras: "
                f"the two cannot be analysed as one session; move {later} out of the run's "
                f"inputs to analyse {path}, or analyse {later} alone"
            )
    with contextlib.ExitStack() as stack:
        reader = stack.enter_context(SessionReader(path))
        results = None
        if results_path is not None:
            results = stack.enter_context(results_writer(Path(results_path), reader))
        known: list[Sequence[Detections] | None] = (
            [None] * (1 + len(continuations)) if detections is None else list(detections)
        )
        parts = [_replay(reader, str(path), options, results, known=known[0])]
        for k, later in enumerate(continuations, start=1):
            with SessionReader(later) as part:
                parts.append(_replay(part, str(path), options, results, part=str(later),
                                     known=known[k]))  # fmt: skip
        replay = _corrected(_joined(parts, [str(p) for p in continuations]), options.rig)
        estimate = estimate_session(replay.trials, options.estimate)
        reported_ = reported(estimate)
        trials = trial_table(replay.session, estimate, reported_, replay.notes, replay.unmeasured)
        if results is not None:
            _write_trial_scenes(results, replay, estimate, reported_)
    rig = typed(pd.DataFrame(columns=RIG_TABLE_COLUMNS))
    if options.rig_calibration == "loo":
        trials, rig = _rig_columns(replay, estimate, reported_, trials)
    keys, solved = running_estimates(estimate)
    ids, truth, units = (
        replay.trials.trial_ids,
        replay.trials.truth,
        unit_spec(replay.trials.units).units,
    )
    averaging = averaging_table(replay.session, ids, keys, solved, truth, units=units)
    views = view_table(replay.session, ids, replay.trials.views, estimate.measurements, units=units)
    frames = typed(pd.DataFrame(replay.frame_rows, columns=FRAME_COLUMNS))
    # What each trial is (its session, part, branch), whoever named the file how.
    identity = identity or SessionIdentity.of_files(path, continuations)
    part_of = dict(zip(ids, replay.part_of, strict=True))
    result = SessionResult(
        session=replay.session,
        label=identity.label,
        metadata=replay.metadata,
        frames=with_branch(frames, identity, part_of),
        trials=with_identity(trials.assign(**rig_file_columns(options)), identity, part_of),
        averaging=with_branch(averaging, identity, part_of),
        views=with_branch(views, identity, part_of),
        rig=rig,
    )
    return _with_figures(result, options, figure_cache) if render_images else result


def _rig_columns(
    replay: _Replay, estimate: SessionEstimate, reported_: Reported, trials: pd.DataFrame
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``--rig-calibration loo``: each trial corrected by constants estimated without it
    (:data:`analysis.rig.RIG_COLUMNS`), and the session's constants (rig.csv rows), from
    the session's one estimate."""
    from analysis.rig.fit import loo_calibration

    columns, rows = loo_calibration(replay.session, estimate, reported_, replay.rig_truth)
    corrected = columns.reindex(trials["trial"].to_numpy()).set_index(trials.index)
    # A session that could not inform the rig has one row, saying why: nothing fitted.
    rig = pd.DataFrame([{"fitted": False} | r for r in rows], columns=RIG_TABLE_COLUMNS)
    rig["units"] = str(replay.trials.units)
    return typed(_systematic_dominance(trials.assign(**corrected))), typed(rig)


def _systematic_dominance(trials: pd.DataFrame) -> pd.DataFrame:
    """``dominant_input`` becomes ``systematic`` where the rig's correction moved the
    estimate by more (squared) than the largest random input's variance; its share is
    then of the systematic plus the random variance."""
    shift = trials[["x", "y", "z"]].to_numpy(dtype=np.float64) - trials[
        ["x_rig", "y_rig", "z_rig"]
    ].to_numpy(dtype=np.float64)
    systematic = np.sum(shift**2, axis=1)
    variance = np.sum(trials[["sigma_x", "sigma_y", "sigma_z"]].to_numpy(dtype=np.float64) ** 2, 1)
    largest = trials["dominant_share"].to_numpy(dtype=np.float64) * variance
    wins = np.isfinite(systematic) & (systematic > np.nan_to_num(largest, nan=np.inf))
    out = trials.copy()
    out.loc[wins, "dominant_input"] = "systematic"
    out.loc[wins, "dominant_share"] = systematic[wins] / (systematic[wins] + variance[wins])
    return out


def _joined(parts: list[_Replay], later: list[str]) -> _Replay:
    """A session's parts as one replay: each trial once (a number a continuation repeats,
    as two continuations of one part may, is kept from the part first given), and the
    metadata saying where the session continued."""
    if len(parts) == 1:
        return parts[0]
    first, seen, keep = parts[0], set[int](), list[tuple[int, list[int]]]()
    for k, part in enumerate(parts):
        rows = [i for i, t in enumerate(part.trials.trial_ids) if t not in seen]
        seen.update(part.trials.trial_ids)
        keep.append((k, rows))
    pick = [(parts[k], i) for k, rows in keep for i in rows]
    trials = dataclasses.replace(
        first.trials,
        trial_ids=tuple(p.trials.trial_ids[i] for p, i in pick),
        views=[p.trials.views[i] for p, i in pick],
        truth=np.array([p.trials.truth[i] for p, i in pick]).reshape(-1, 2, 3),
    )
    dropped = sum(len(p.trials.trial_ids) for p in parts) - len(pick)
    said = f"continued in {', '.join(later)}" + (
        f"; {dropped} trial(s) numbered twice counted once" if dropped else ""
    )
    kept = [{parts[k].trials.trial_ids[i] for i in rows} for k, rows in keep]
    return dataclasses.replace(
        first,
        trials=trials,
        metadata={**first.metadata, "continuations": said, **_operators(parts, kept, later)},
        last_ns=[p.last_ns[i] for p, i in pick],
        frame_rows=[r for k, p in enumerate(parts) for r in p.frame_rows if r["trial"] in kept[k]],
        notes=[p.notes[i] for p, i in pick],
        unmeasured=[p.unmeasured[i] for p, i in pick],
        part_of=[p.part_of[i] for p, i in pick],
    )


def _operators(parts: list[_Replay], kept: list[set[int]], later: list[str]) -> dict[str, str]:
    """The session's operator, each with the part and trials they recorded when the parts
    were recorded by more than one (a continuation by another operator is never shown
    under the first); nothing to change when one recorded them all."""
    who = [p.metadata.get("operator", "") for p in parts]
    if len(set(who)) <= 1:
        return {}
    names = [Path(parts[0].session).name, *(Path(p).name for p in later)]
    said = [
        f"{name or '(none)'} ({file}: {_trial_numbers(sorted(trials))})"
        for name, file, trials in zip(who, names, kept, strict=True)
        if trials
    ]
    return {"operator": "; ".join(said)}


def _trial_numbers(ids: list[int]) -> str:
    """``trial 3``, ``trials 1-2``, ``trials 1, 3, 5``."""
    if len(ids) == 1:
        return f"trial {ids[0]}"
    if ids == list(range(ids[0], ids[-1] + 1)):
        return f"trials {ids[0]}-{ids[-1]}"
    return "trials " + ", ".join(str(i) for i in ids)


def _corrected(replay: _Replay, rig: RigConstants | None) -> _Replay:
    """The replay with every view (and the ground) as the rig really had them."""
    if rig is None or rig.is_identity:
        return replay
    return dataclasses.replace(replay, trials=corrected_trials(replay.trials, rig))


def corrected_trials(trials: SessionTrials, rig: RigConstants | None) -> SessionTrials:
    """The trials with every view (and the ground) as the rig really had them."""
    if rig is None or rig.is_identity:
        return trials
    return dataclasses.replace(
        trials,
        views=[[corrected_view(v, rig) for v in row] for row in trials.views],
        ground=corrected_ground(trials.ground, rig),
    )


def replay_views(
    path: str | Path,
    options: AnalysisOptions | None = None,
    continuations: Sequence[str | Path] = (),
    *,
    keep: list[list[Detections]] | None = None,
) -> SessionTrials:
    """A session's trials as the estimation takes them (ids, truth, usable poses), its
    continuations' after its own: what the rig's constants are fitted on
    (:mod:`analysis.rig.fit`). ``keep``: each part's detections are appended to it."""
    options = options or AnalysisOptions()
    parts = []
    for part in (path, *continuations):
        with SessionReader(part) as reader:
            found: list[Detections] | None = None if keep is None else []
            parts.append(_replay(reader, str(path), options, None, part=str(part), keep=found))
            if keep is not None and found is not None:
                keep.append(found)
    return _joined(parts, [str(p) for p in continuations]).trials


def _replay(
    reader: SessionReader,
    session: str,
    options: AnalysisOptions,
    results: ResultsWriter | None,
    *,
    part: str | None = None,
    known: Sequence[Detections] | None = None,
    keep: list[Detections] | None = None,
) -> _Replay:
    """Stream the session trial by trial, detecting the target in every frame; a trial's
    frames are dropped once detected, so memory does not grow with session length.
    ``part``: the path of the file read (a continuation's; default ``session``);
    ``known``: each trial's detections found before (not detected again); ``keep``: each
    trial's detections are appended to it."""
    info = reader.info
    if not spec_of(info.method).measures:
        raise InputValueError(
            f"{session} is a board session (it calibrates the rig; nothing to reconstruct): "
            "give it to `twopose-analyze rig`"
        )
    ground: GroundSpec | None = None
    if spec_of(info.method).needs_ground:
        if reader.ground is None:
            raise SessionFormatError(f"{session}: a ground session without a /twopose/ground plane")
        ground = (np.array(reader.ground.normal_grid), reader.ground.offset)
    target = spec_of(info.method).target
    assert target is not None  # measures
    rows: list[dict[str, Any]] = []
    trial_ids, truths, views, last_ns = [], [], [], []
    notes, unmeasured = [], []
    rig_truth: RigConstants | None = None
    params = options.thresholds_for(target)
    found = (
        detected(iter_trials(reader), target, params)
        if known is None
        else given_detections(iter_trials(reader), known, session)
    )
    with contextlib.closing(found) as trials:
        for record, detections in trials:
            if keep is not None:
                keep.append(detections)
            if record.simulation_truth is not None and record.simulation_truth.rig is not None:
                rig_truth = RigConstants.from_vector(record.simulation_truth.rig)
            views.append(trial_views(record, detections, session, rows, results))
            trial_ids.append(record.trial)
            truth, why_not_compared = _truth(record, unit_spec(info.units))
            truths.append(truth)
            last_ns.append(
                max((pc.frames[-1].log_time_ns for pc in record.poses if pc.frames), default=0)
            )
            notes.append(" | ".join((*record.notes, *why_not_compared)))
            unmeasured.append(record.why_not_measured())
    trials_value = SessionTrials(
        method=info.method,
        units=info.units,
        trial_ids=tuple(trial_ids),
        views=views,
        truth=np.array(truths).reshape(-1, 2, 3),
        ground=ground,
    )
    return _Replay(
        session=session,
        trials=trials_value,
        metadata=session_metadata(reader),
        last_ns=last_ns,
        frame_rows=rows,
        notes=notes,
        unmeasured=unmeasured,
        rig_truth=rig_truth,
        part_of=[part or session] * len(trial_ids),
    )


def _pair_session_metadata(path: str | Path) -> dict[str, str] | None:
    """A two-camera session's metadata (format 1.6: a pair, stream trials); None for a
    one-camera session."""
    with SessionReader(path) as reader:
        return None if reader.pair is None else session_metadata(reader)


def session_metadata(reader: SessionReader) -> dict[str, str]:
    """What the report says about the session."""
    info = reader.info
    session_notes = read_notes(reader)
    return {
        "method": info.method,
        "units": info.units,
        "operator": info.operator,
        "notes": info.notes,
        "operator_notes": " | ".join(session_notes.session),
        "trial_notes": " | ".join(
            f"trial {t}: {text}"
            for t, texts in sorted(session_notes.by_trial.items())
            for text in texts
        ),
        "cameras": ", ".join(
            f"{c.camera_id} (fx={c.intrinsics.fx:g}, fy={c.intrinsics.fy:g}, "
            f"{c.intrinsics.width}x{c.intrinsics.height})"
            for c in reader.cameras.values()
        ),
        "format_version": reader.format_version,
        "simulated": str(info.simulated),
    }


def _truth(record: TrialRecord, unit: UnitSpec) -> tuple[F64, tuple[str, ...]]:
    """(2, 3): the point twice, or the two line points; NaN when the trial has no truth, or
    one beyond any grid (said in the second value: twopose refuses it when typed, so it
    is another writer's, and compared with it every number would be noise or overflow)."""
    none = np.full((2, 3), np.nan)
    if record.ground_truth is None:
        return none, ()
    points = record.ground_truth.points_grid
    beyond = [why for p in points if (why := GROUND_TRUTH.vector_refusal(p, unit.units))]
    if beyond:
        return none, tuple(f"{why}: not compared" for why in beyond)
    pts = np.array(points)
    return (pts if len(pts) == 2 else np.stack([pts[0], pts[0]])), ()


def _write_trial_scenes(
    results: ResultsWriter, replay: _Replay, estimate: SessionEstimate, reported_: Reported
) -> None:
    """Each trial's geometry into results.mcap, stamped at its last frame."""
    trials, est = replay.trials, estimate.estimates
    line = spec_of(trials.method).estimates_line
    for i, (views, ms) in enumerate(zip(trials.views, estimate.measurements, strict=True)):
        if not views:
            continue
        scene = scene_of_views(
            trials.trial_ids[i],
            trials.method,
            str(est.status[i]),
            views,
            ms,
            reported_.point[i],
            est.direction[i] if line else None,
            trials.truth[i],
            reported_.cov[i],
        )
        results.add_trial(scene, replay.last_ns[i])


def _with_figures(
    result: SessionResult, options: AnalysisOptions, cache: FigureCache | None
) -> SessionResult:
    """The session with its figures as PNGs, drawn here so that a batch renders them in
    parallel, or reused from ``cache`` (a previous run's, when nothing they show changed);
    figures that fail to draw are said, and shown as such, never the session's end."""
    from analysis.report.figures.cache import FigureJob
    from analysis.report.figures.drawer import note, session_pngs

    job = FigureJob.of(result, include_warned=options.include_warned)
    images, why_not, reused = session_pngs(job, cache)
    if why_not:
        note(f"the figures of {result.session} were not drawn ({why_not}); the report says so")
    return dataclasses.replace(result, images=images, figures_reused=reused)
