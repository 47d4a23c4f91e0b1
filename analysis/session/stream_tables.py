"""A two-camera session's analysis in ``run``: one row of ``trials.csv`` per touch.

Issue 58 item 6. A two-camera session has no typed poses: its trials are streams of frame
pairs, and the operator marked **touches**, moments the target was at a known grid point.
:func:`analyse_pair_session` replays each stream trial (:func:`analysis.session.stream.
replay_trial`: both cameras' targets detected, the clock offset recorded or measured,
one estimate per frame pair, camera 1's measurement interpolated to camera 2's capture
time) and gives each touch a row of ``trials.csv``, as a one-camera trial has:

- ``trial`` the touch's number in the session (1, 2, ... over its stream trials in order:
  unique, so ``check`` and ``compare`` match rows as they match trials), ``touch`` which
  one it is in words (``trial 2, touch 1``), ``cameras`` 2;
- the estimate at the touch's time (:func:`analysis.session.stream.at_touches`: the two ok
  estimates about it interpolated; a line's nearest estimate's point nearest the touched
  point), the truth the touched point, the error and its axes; the covariance, conditioning
  and margins of the ok estimate nearest in time, and from them the 95% region's columns;
- ``clock_offset_ms``, ``clock_offset_sigma_ms``, ``clock_offset_source`` the offset used;
- ``err_uninterpolated``: the error at the touch when camera 1's paired frame is taken as
  it is (the same pairs and offset, no interpolation to camera 2's capture time), and
  ``skew_share`` = ``max(0, 1 - err / err_uninterpolated)``: the share of that error
  interpolating removed, i.e. what the skew between the paired frames cost.

A touch with no estimate about it is a row all the same: ``degenerate`` (the nearest pair
near-singular, its reason), ``no_detection`` (a camera did not detect the target in the
nearest pair), or ``incomplete`` (the trial could not be estimated: a camera with no frame,
an offset that cannot be measured; a camera with no frame about the touch; or both cameras
saw the target about it but its frames made too few pairs there), ``reason`` saying why
and what to do. A session with no touch at all has nothing to compare with the
truth: it fails, saying so. A stream cut short (a lost window) is said in ``notes``.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.batch.inputs import SessionIdentity
from analysis.results import AnalysisOptions, SessionResult
from analysis.session.results_mcap import results_writer
from analysis.session.stream import (
    MAX_TOUCH_GAP_INTERVALS,
    TrialReplay,
    at_touches,
    detect_trial,
    replay_trial,
    session_noise,
)
from analysis.session.stream_rows import PairOutputs, nearest_ok
from analysis.session.touch_status import seen_about, stream_end_ns, touch_status
from analysis.tables.columns import typed
from analysis.tables.rows import with_branch, with_identity
from analysis.tables.trials import columns_of
from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.streams import PairSession, StreamTrial, read_pair_session
from twopose.methods.specs import spec_of
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock import ClockOffset
from twopose.pair.copied_view import copied_view
from twopose.pair.dot_tracks import epipolar_gap_px
from twopose.pair.holdout import CHECK_SIGMAS
from twopose.pair.rays_miss import inside, pixel_sigma, rays_miss_words, still_frames
from twopose.pair.stream import StreamSettings, estimate_stream
from twopose.uncertainty.propagate import uncertainty_columns
from twopose.values.units import Units

__all__ = ["analyse_pair_session", "pair_lines", "touch_rows"]


def analyse_pair_session(
    path: str | Path,
    options: AnalysisOptions | None = None,
    *,
    metadata: dict[str, str],
    identity: SessionIdentity | None = None,
    continuations: tuple[str, ...] | list[str] = (),
    results_path: str | Path | None = None,
) -> SessionResult:
    """A two-camera session's tables: one ``trials.csv`` row per touch (module docstring),
    and its frames, views and averaging rows (:mod:`analysis.session.stream_rows`);
    ``metadata`` what the report says of any session (:func:`analysis.session.pipeline.
    session_metadata`, which calls this: :func:`analysis.analyse_session`), the pair's
    added. With ``results_path``, its results.mcap is written there (none on a failure).
    ``continuations``: its later parts, in order, replayed after ``path`` as one session
    (each part's stream trials with its own pair and clock offset; a stream trial number a
    later part repeats, as two continuations of one part may, kept from the first).

    Raises :class:`~twopose.errors.InputValueError` for a session with no touch, one that
    measures nothing, or a part that is not a two-camera recording of the same method and
    units.
    """
    options = options or AnalysisOptions()
    with contextlib.ExitStack() as stack:
        readers = [stack.enter_context(SessionReader(p)) for p in (path, *continuations)]
        parts = [_pair_part(reader, str(path)) for reader in readers]
        session = parts[0]
        if not spec_of(session.info.method).measures:
            raise InputValueError(f"{path}: a {session.info.method} session measures nothing")
        kept = _kept_trials(parts)
        if not any(trial.touches for _, trial in kept):
            raise InputValueError(
                f"{path}: a two-camera session with no touch marked: nothing to compare with "
                "the truth (mark touches with the key, the console's button or a plan's "
                "schedule while recording)"
            )
        outputs = PairOutputs(
            session=str(path), method=session.info.method, units=session.info.units,
            pair=session.pair,
            results=None if results_path is None
            else stack.enter_context(results_writer(Path(results_path), readers[0])),
        )  # fmt: skip
        rows = touch_rows(str(path), parts, options, outputs)
    metadata = (
        metadata | _pair_metadata(session, parts) | {"skew": _skew_said(rows, session.info.units)}
    )
    if outputs.noise is not None:  # where each camera's pixel noise came from
        lines = spec_of(session.info.method).uses_image_lines
        metadata["pixel_noise"] = "; ".join(
            f"camera {c}: {n.said(lines=lines)}" for c, n in enumerate(outputs.noise, start=1)
        )
    identity = identity or SessionIdentity.of_files(path, continuations)
    touched = [str(part.path) for part, trial in kept for _ in trial.touches]
    part_of = dict(zip(rows["trial"].astype(int), touched, strict=True))
    stream_part = {trial.trial: str(part.path) for part, trial in kept}
    frames, views, averaging = outputs.tables()
    return SessionResult(
        session=str(path),
        label=identity.label,
        metadata=metadata,
        frames=with_branch(frames, identity, stream_part),
        # No rig file applies to a pair (it corrects typed poses): its columns empty, as
        # documented, and there whatever else the run holds.
        trials=with_identity(rows.assign(rig_file="", rig_sha256=""), identity, part_of),
        averaging=with_branch(averaging, identity, part_of),
        views=with_branch(views, identity, stream_part),
    )


def _pair_part(reader: SessionReader, first: str) -> PairSession:
    """A part of the two-camera session ``first`` (its first part's path), as read; refused
    in words when it records no pair (a one-camera continuation of a two-camera session)."""
    if reader.pair is None and str(reader.path) != first:
        raise InputValueError(
            f"{reader.path} continues the two-camera session {first} but records one camera "
            "(no pair, no stream trials): the two cannot be analysed as one session; move "
            f"{reader.path} out of the run's inputs to analyse {first}, or analyse "
            f"{reader.path} alone"
        )
    return read_pair_session(reader)


def _kept_trials(parts: list[PairSession]) -> list[tuple[PairSession, StreamTrial]]:
    """Every part's stream trials in order, each trial number once (the first part's)."""
    first, seen, kept = parts[0], set[int](), []
    for part in parts:
        if (part.info.method, part.info.units) != (first.info.method, first.info.units):
            raise InputValueError(
                f"{part.path} continues {first.path} with another method or unit "
                f"({part.info.method}, {part.info.units}; the session's: {first.info.method}, "
                f"{first.info.units}): not one session to analyse"
            )
        for trial in part.trials:
            if trial.trial not in seen:
                seen.add(trial.trial)
                kept.append((part, trial))
    return kept


def _skew_said(rows: pd.DataFrame, units: Units) -> str:
    """The skew's share of the error over the ok touches, in words (the report): the
    summary's ``rmse_uninterpolated`` and ``skew_share`` (:func:`analysis.session.metrics.
    skew_summary`), with the RMSE they are set against."""
    from analysis.session.metrics import skew_summary

    ok = rows[(rows["status"] == "ok") & rows["err"].notna() & rows["err_uninterpolated"].notna()]
    skew = skew_summary(ok)
    if not skew:
        return "not measured (no touch with an estimate both ways)"
    rmse = float(np.sqrt(np.mean(ok["err"].to_numpy(dtype=np.float64) ** 2)))
    return (
        f"rmse {rmse:.3g} {units} at the ok touches with camera 1 interpolated to camera 2's "
        f"capture time, {skew['rmse_uninterpolated']:.3g} {units} with its paired frame as it "
        f"is: the skew's share {skew['skew_share']:.0%}"
    )


def _pair_metadata(session: PairSession, parts: list[PairSession] | None = None) -> dict[str, str]:
    """What the report says of the pair: its cameras, baseline, offset and touches (over
    ``parts``, the session's parts, where it has more than one)."""
    pair = session.pair
    parts = parts or [session]
    n_touches = sum(len(p.touches) for p in parts)
    n_trials = sum(len(p.trials) for p in parts)
    in_parts = f" in {len(parts)} parts" if len(parts) > 1 else ""
    said = "; ".join(_offset_said(p.offset) for p in parts)
    if len(parts) > 1:  # each part's own, as the analysis uses them (a new user's r7 K9)
        said = "by part: " + said
    return {
        "two_cameras": (
            f"{session.cameras[0].camera_id} and {session.cameras[1].camera_id}: baseline "
            f"{float(np.linalg.norm(pair.t_2_in_1)):.3f} {session.info.units}, "
            + (
                f"rms {pair.rms_px:.3f} px over {pair.n_views} views"
                if pair.n_views
                else "its pose given, not fitted to views"
            )
            + _check_said(pair)
        ),
        "clock_offset": said,
        "touches": f"{n_touches} over {n_trials} stream trial(s){in_parts}",
    }


def _offset_said(offset: ClockOffset | None) -> str:
    """A part's recorded clock offset in words."""
    if offset is None:
        return (
            "none recorded (measured per trial from its frames: a flash where one was fired, "
            "and the rays' gap)"
        )
    return f"{offset.offset_ns / 1e6:.3f} ms ± {offset.sigma_ns / 1e6:.3f} ms ({offset.method})"


def _check_said(pair: PairCalibration) -> str:
    """The pair's leave-one-out check after its fit, in words ("" without one)."""
    if pair.check is None:
        return ""
    if pair.check.passed:
        return (
            f", its covariance confirmed by leave-one-out (every held-out spacing within "
            f"{CHECK_SIGMAS:g} sigma, the worst {pair.check.worst_sigmas:.1f})"
        )
    return f"; {pair.check.unconfirmed()}"


def pair_lines(session: PairSession) -> list[str]:
    """A two-camera session described (``info``): its cameras and their clocks, the pair,
    the clock offset, its stream trials and touches; what ``run`` would say of none."""
    words = _pair_metadata(session)
    clocks = ", ".join(
        f"{c.camera_id} {session.clocks.get(c.camera_id, 'clock not said')}"
        for c in session.cameras
    )
    per_trial = ", ".join(f"trial {t.trial}: {len(t.touches)}" for t in session.trials)
    lines = [
        f"two cameras in {session.path}: {words['two_cameras']}; capture clocks: {clocks}",
        f"  clock offset: {words['clock_offset']}",
        f"  touches: {words['touches']}" + (f" ({per_trial})" if per_trial else ""),
    ]
    lines += [
        f"  trial {t.trial}, camera {s.camera_id}: {s.reason}"
        for t in session.trials
        for s in t.cameras
        if s.reason
    ]
    if not session.touches:
        lines.append("  no touch marked: `run` has nothing to compare with the truth")
    return lines


def touch_rows(
    session_path: str,
    session: PairSession | list[PairSession],
    options: AnalysisOptions,
    outputs: PairOutputs | None = None,
) -> pd.DataFrame:
    """Every touch's row of ``trials.csv`` (the readers open), in part, trial and touch
    order, over the session's parts (``session`` one, or its parts in order:
    :func:`_kept_trials`); each frame, pair and touch told to ``outputs`` (the other
    tables, results.mcap)."""
    parts = session if isinstance(session, list) else [session]
    spec = spec_of(parts[0].info.method)
    assert spec.target is not None  # a measuring method's
    params = options.thresholds_for(spec.target)
    kept = [(p, t) for p, t in _kept_trials(parts) if t.touches or outputs is not None]
    detected = [  # every trial's frames first: the cameras' noise is the session's
        detect_trial(t, spec.method, params, None if outputs is None else outputs.seen(t.trial))
        for _, t in kept
    ]
    noise = session_noise([d[0] for d in detected], spec.method, None, pair=parts[0].pair)
    if outputs is not None:
        outputs.noise = noise
    settings = StreamSettings(noise=(noise[0].noise, noise[1].noise), estimate=options.estimate)
    rows: list[dict[str, Any]] = []
    for (part, trial), found in zip(kept, detected, strict=True):
        # every row of the part: its baseline, and a failed pair check in its notes (each
        # region carries the pair's covariance)
        same = _part_cells(part.pair)
        blind = [s.camera_id for s in trial.cameras if len(s) < 2]
        if blind:  # nothing to pair or interpolate: said per touch
            why = (
                f"camera {' and '.join(blind)} recorded fewer than 2 frames in trial {trial.trial}"
            )
            rows += [same(_failed_row(trial, k, why)) for k in range(len(trial.touches))]
            continue
        try:
            replay = replay_trial(trial, part.pair, spec.method, (part.offset, "recorded"),
                                  settings, detected=found, noise=noise)  # fmt: skip
        except InputValueError as err:
            rows += [same(_failed_row(trial, k, str(err))) for k in range(len(trial.touches))]
            continue
        if outputs is not None:
            outputs.add_trial(trial, replay, first_touch=len(rows) + 1, pair=part.pair)
        rows += [same(r) for r in _replayed_rows(trial, replay, part, settings)]
    for number, row in enumerate(rows, start=1):
        row["trial"] = number
    names = [c.name for c in columns_of(spec)] + _STREAM_NAMES
    table = pd.DataFrame(rows).reindex(columns=[n for n in names if n != "label"])
    table["session"] = session_path
    table["method"] = str(spec.method)
    table["units"] = str(parts[0].info.units)
    table["cameras"] = 2
    # One pair of views has no redundancy to test: no misclosure's dof, no pose named.
    table["misclosure_dof"] = 0
    table["target_scatter_dof"] = 0  # a pair's touches: no trials of one target compared
    table["suspect_pose"] = 0
    table["nees_dof"] = table["nees_dof"].fillna(0)
    table = _truth_flags(table, parts[0].info.units)
    return typed(table.drop(columns=[c for c in _IDENTITY if c in table]))


def _truth_flags(table: pd.DataFrame, units: Units) -> pd.DataFrame:
    """Each touch against its own truth, as a one-camera trial is
    (:func:`twopose.uncertainty.blunders.scored_truth_tests`: NEES beyond chi-square's 0.1%
    quantile): ``flagged`` (empty where untested: no estimate or no region),
    ``flagged_by`` and the words. A touch marked as the target moved is such a row."""
    from twopose.uncertainty.blunders import FLAGGED_BY, far_from_truth, scored_truth_tests

    error = table[["err_x", "err_y", "err_z"]].to_numpy(dtype=np.float64)
    test = scored_truth_tests(
        error, table["nees"].to_numpy(dtype=np.float64), table["nees_dof"].to_numpy(dtype=int)
    )
    tested = test.dof > 0
    causes = (
        "the moment it was marked (a key pressed as the target moved), the grid point, or "
        "the detection is off: check when and where the touch was marked"
    )
    out = table.copy()
    out["flagged"] = pd.array([bool(f) if t else None for f, t in zip(test.flagged, tested,
                               strict=True)], dtype="boolean")  # fmt: skip
    out["flagged_by"] = np.where(test.flagged, FLAGGED_BY[2], "")
    sigmas = np.sqrt(test.nees)
    out["disagreement"] = [
        far_from_truth(
            test.off[k], sigmas[k], int(test.axis[k]), units, noun="touch", causes=causes
        )
        if test.flagged[k]
        else ""
        for k in range(len(table))
    ]
    return out


def _part_cells(pair: PairCalibration) -> Callable[[dict[str, Any]], dict[str, Any]]:
    """A row of a part with the pair ``pair``: its baseline, and the pair's failed check
    (:meth:`twopose.pair.holdout.HoldoutCheck.unconfirmed`) added to its notes."""
    baseline = float(np.linalg.norm(pair.t_2_in_1))
    unconfirmed = "" if pair.check is None else pair.check.unconfirmed()

    def cells(row: dict[str, Any]) -> dict[str, Any]:
        notes = "; ".join(n for n in (row.get("notes", ""), unconfirmed) if n)
        return row | {"baseline": baseline, "notes": notes}

    return cells


_STREAM_NAMES = [
    "touch", "clock_offset_ms", "clock_offset_sigma_ms", "clock_offset_source",
    "err_uninterpolated", "skew_share",
]  # fmt: skip
_IDENTITY = ("label", "session_id", "part", "branch")


def _failed_row(trial: StreamTrial, k: int, why: str) -> dict[str, Any]:
    """A touch of a trial that could not be estimated: ``incomplete``, saying why."""
    touch = trial.touches[k]
    stream = "; ".join(s.reason for s in trial.cameras if s.reason)
    return {
        "touch": f"trial {trial.trial}, touch {touch.touch}",
        "status": "incomplete",
        "reason": why,
        "n_views": 0,
        **_truth(np.asarray(touch.point, dtype=np.float64)),
        "warning": "",
        "notes": stream,
    }


def _truth(point: F64) -> dict[str, float]:
    return {f"gt_{a}": float(point[i]) for i, a in enumerate("xyz")}


def _replayed_rows(
    trial: StreamTrial, replay: TrialReplay, session: PairSession, settings: StreamSettings
) -> list[dict[str, Any]]:
    """The touches of a replayed trial: the estimate at each, its error, its region, the
    error without interpolation and the skew's share."""
    est, touches, truth = replay.estimate, replay.touches, replay.truth
    raw = estimate_stream(
        session.info.method, session.pair, *replay.tracks, replay.offset,
        dataclasses.replace(settings, interpolate=False),
    )  # fmt: skip
    error = replay.at_touch - truth
    err_raw = np.linalg.norm(at_touches(raw, touches, replay.interval_ns) - truth, axis=1)
    ok = est.ok
    nearest = nearest_ok(est.t_ns, np.array([t.time_ns for t in touches], dtype=np.float64), ok)
    have = np.isfinite(replay.at_touch).all(axis=1) & (nearest >= 0)
    cov = np.full((len(touches), 3, 3), np.nan)
    cov[have] = est.cov[nearest[have]]
    spread = uncertainty_columns(np.where(have[:, None], error, np.nan), cov)
    margins = spec_of(session.info.method).margins
    # Two copies of one recording: every touch warned, whatever offset was recorded or given.
    one, two = replay.tracks
    copy = copied_view((one.centroid_px, two.centroid_px), (one.t_ns, two.t_ns),
                       replay.offset.offset_ns).words()  # fmt: skip
    warning = copy or _rays_missed(replay, session)
    rows = []
    for k, touch in enumerate(touches):
        err = float(np.linalg.norm(error[k])) if have[k] else np.nan
        row: dict[str, Any] = {
            "touch": f"trial {trial.trial}, touch {touch.touch}",
            **touch_status(
                est,
                touch.time_ns,
                have=bool(have[k]),
                missed=replay.missed,
                seen=seen_about(replay, touch.time_ns),
                ended=(replay.reason, stream_end_ns(replay)),
                reach_ns=MAX_TOUCH_GAP_INTERVALS * replay.interval_ns,
            ),
            "n_views": 2 if have[k] else 0,
            **{a: float(replay.at_touch[k, i]) for i, a in enumerate("xyz")},
            **_truth(truth[k]),
            **{f"err_{a}": float(error[k, i]) for i, a in enumerate("xyz")},
            "err": err,
            **{name: spread[name][k] for name in spread},
            "warning": warning,
            "notes": replay.reason,
            "clock_offset_ms": replay.offset.offset_ns / 1e6,
            "clock_offset_sigma_ms": replay.offset.sigma_ns / 1e6,
            "clock_offset_source": replay.offset_from,
            "err_uninterpolated": float(err_raw[k]),
            "skew_share": _skew_share(err, float(err_raw[k])),
        }
        if have[k]:
            j = nearest[k]
            row["conditioning"] = float(est.conditioning[j])
            row |= {name: float(est.margins[name][j]) for name in margins if name in est.margins}
            if est.direction is not None:
                row |= {f"dir_{a}": float(est.direction[j, i]) for i, a in enumerate("xyz")}
                row["dist_err"] = err
        rows.append(row)
    return rows


def _rays_missed(replay: TrialReplay, session: PairSession) -> str:
    """A dot's rays missing each other where it stood still: the pair file not these
    cameras' (:mod:`twopose.pair.rays_miss`; a new user's r7 K11: every touch 41-51 sigma
    off, blamed on the moment it was marked). "" for a target with image lines."""
    if spec_of(session.info.method).uses_image_lines:
        return ""
    est, (i1, i2) = replay.estimate, (session.pair.intrinsics1, session.pair.intrinsics2)
    two = replay.tracks[1].centroid_px
    judged = (still_frames(two) & inside(two, i2.width, i2.height))[est.i2]
    judged &= inside(replay.tracks[0].centroid_px, i1.width, i1.height)[est.i1]
    gaps = epipolar_gap_px(session.pair, est.measured[:, 0, :2], est.measured[:, 1, :2])
    noise = 0.0 if replay.noise is None else max(n.noise.centroid_px for n in replay.noise)
    return rays_miss_words(gaps[judged], pixel_sigma(noise, session.pair.rms_px))


def _skew_share(err: float, err_raw: float) -> float:
    """``max(0, 1 - err / err_uninterpolated)`` (NaN where either is not known or 0)."""
    if not (np.isfinite(err) and np.isfinite(err_raw)) or err_raw <= 0:
        return np.nan
    return max(0.0, 1.0 - err / err_raw)
