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
near-singular, its reason), ``no_detection`` (no pair there), or ``incomplete`` (the trial
could not be estimated: a camera with no frame, an offset that cannot be measured),
``reason`` saying why. A session with no touch at all has nothing to compare with the
truth: it fails, saying so. A stream cut short (a lost window) is said in ``notes``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.batch.inputs import SessionIdentity
from analysis.results import AnalysisOptions, SessionResult
from analysis.session.stream import (
    DEFAULT_NOISE,
    MAX_TOUCH_GAP_INTERVALS,
    TrialReplay,
    at_touches,
    replay_trial,
)
from analysis.tables.columns import AVERAGING_COLUMNS, FRAME_COLUMNS, typed
from analysis.tables.rows import with_identity
from analysis.tables.trials import columns_of
from twopose.arrays import F64, Bools, Ints
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.streams import PairSession, StreamTrial, read_pair_session
from twopose.methods.specs import spec_of
from twopose.pair.stream import NEAR_SINGULAR, StreamEstimate, StreamSettings, estimate_stream
from twopose.uncertainty.propagate import uncertainty_columns
from twopose.values.units import Units

__all__ = ["analyse_pair_session", "pair_lines", "touch_rows"]

#: The status of a touch whose nearest pair was near-singular or degenerate.
_DEGENERATE = {NEAR_SINGULAR: "degenerate", "degenerate": "degenerate"}


def analyse_pair_session(
    path: str | Path,
    options: AnalysisOptions | None = None,
    *,
    metadata: dict[str, str],
    identity: SessionIdentity | None = None,
    continuations: tuple[str, ...] | list[str] = (),
) -> SessionResult:
    """A two-camera session's tables: one ``trials.csv`` row per touch (module docstring);
    ``metadata`` what the report says of any session (:func:`analysis.session.pipeline.
    session_metadata`, which calls this: :func:`analysis.analyse_session`), the pair's
    added.

    Raises :class:`~twopose.errors.InputValueError` for a session with no touch, one that
    measures nothing, or one continued in later files (not analysed as one yet).
    """
    options = options or AnalysisOptions()
    if continuations:
        raise InputValueError(
            f"{path}: a two-camera session continued in {', '.join(map(str, continuations))}: "
            "its parts are not analysed as one session yet; analyse each part on its own"
        )
    with SessionReader(path) as reader:
        session = read_pair_session(reader)
        if not spec_of(session.info.method).measures:
            raise InputValueError(f"{path}: a {session.info.method} session measures nothing")
        if not session.touches:
            raise InputValueError(
                f"{path}: a two-camera session with no touch marked: nothing to compare with "
                "the truth (mark touches with the key, the console's button or a plan's "
                "schedule while recording)"
            )
        rows = touch_rows(str(path), session, options)
    metadata = metadata | _pair_metadata(session) | {"skew": _skew_said(rows, session.info.units)}
    identity = identity or SessionIdentity.of_files(path)
    part_of = dict.fromkeys(rows["trial"].astype(int), str(path))
    return SessionResult(
        session=str(path),
        label=identity.label,
        metadata=metadata,
        frames=typed(pd.DataFrame(columns=FRAME_COLUMNS)),
        trials=with_identity(rows, identity, part_of),
        averaging=typed(pd.DataFrame(columns=AVERAGING_COLUMNS)),  # no frames per pose
    )


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


def _pair_metadata(session: PairSession) -> dict[str, str]:
    """What the report says of the pair: its cameras, baseline, offset and touches."""
    pair, offset = session.pair, session.offset
    said = (
        "none recorded (measured per trial by the ray gap)"
        if offset is None
        else f"{offset.offset_ns / 1e6:.3f} ms ± {offset.sigma_ns / 1e6:.3f} ms ({offset.method})"
    )
    return {
        "two_cameras": (
            f"{session.cameras[0].camera_id} and {session.cameras[1].camera_id}: baseline "
            f"{float(np.linalg.norm(pair.t_2_in_1)):.3f} {session.info.units}, "
            + (
                f"rms {pair.rms_px:.3f} px over {pair.n_views} views"
                if pair.n_views
                else "its pose given, not fitted to views"
            )
        ),
        "clock_offset": said,
        "touches": f"{len(session.touches)} over {len(session.trials)} stream trial(s)",
    }


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


def touch_rows(session_path: str, session: PairSession, options: AnalysisOptions) -> pd.DataFrame:
    """Every touch's row of ``trials.csv`` (the reader open), in trial and touch order."""
    spec = spec_of(session.info.method)
    settings = StreamSettings(noise=DEFAULT_NOISE, estimate=options.estimate)
    known = (session.offset, "recorded")
    rows: list[dict[str, Any]] = []
    for trial in session.trials:
        if not trial.touches:
            continue
        blind = [s.camera_id for s in trial.cameras if len(s) < 2]
        if blind:  # nothing to pair or interpolate: said per touch
            why = (
                f"camera {' and '.join(blind)} recorded fewer than 2 frames in trial {trial.trial}"
            )
            rows += [_failed_row(trial, k, why) for k in range(len(trial.touches))]
            continue
        try:
            replay = replay_trial(trial, session.pair, spec.method, known, settings)
        except InputValueError as err:
            rows += [_failed_row(trial, k, str(err)) for k in range(len(trial.touches))]
            continue
        rows += _replayed_rows(trial, replay, session, settings)
    for number, row in enumerate(rows, start=1):
        row["trial"] = number
    names = [c.name for c in columns_of(spec)] + _STREAM_NAMES
    table = pd.DataFrame(rows).reindex(columns=[n for n in names if n != "label"])
    table["session"] = session_path
    table["method"] = str(spec.method)
    table["units"] = str(session.info.units)
    table["cameras"] = 2
    table["baseline"] = float(np.linalg.norm(session.pair.t_2_in_1))
    # One pair of views has no redundancy to test: no misclosure's dof, no pose named.
    table["misclosure_dof"] = 0
    table["suspect_pose"] = 0
    table["nees_dof"] = table["nees_dof"].fillna(0)
    return typed(table.drop(columns=[c for c in _IDENTITY if c in table]))


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
    nearest = _nearest(est.t_ns, np.array([t.time_ns for t in touches], dtype=np.float64), ok)
    have = np.isfinite(replay.at_touch).all(axis=1) & (nearest >= 0)
    cov = np.full((len(touches), 3, 3), np.nan)
    cov[have] = est.cov[nearest[have]]
    spread = uncertainty_columns(np.where(have[:, None], error, np.nan), cov)
    margins = spec_of(session.info.method).margins
    rows = []
    for k, touch in enumerate(touches):
        err = float(np.linalg.norm(error[k])) if have[k] else np.nan
        row: dict[str, Any] = {
            "touch": f"trial {trial.trial}, touch {touch.touch}",
            **_status(est, touch.time_ns, have=bool(have[k])),
            "n_views": 2 if have[k] else 0,
            **{a: float(replay.at_touch[k, i]) for i, a in enumerate("xyz")},
            **_truth(truth[k]),
            **{f"err_{a}": float(error[k, i]) for i, a in enumerate("xyz")},
            "err": err,
            **{name: spread[name][k] for name in spread},
            "warning": "",
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


def _skew_share(err: float, err_raw: float) -> float:
    """``max(0, 1 - err / err_uninterpolated)`` (NaN where either is not known or 0)."""
    if not (np.isfinite(err) and np.isfinite(err_raw)) or err_raw <= 0:
        return np.nan
    return max(0.0, 1.0 - err / err_raw)


def _nearest(t_ns: F64, at: F64, ok: Bools) -> Ints:
    """(K,) per time of ``at``, the index of the ok estimate nearest it (-1: none)."""
    index = np.flatnonzero(ok)
    if not index.size:
        return np.full(at.size, -1)
    nearest: Ints = index[np.argmin(np.abs(t_ns[index][None, :] - at[:, None]), axis=1)]
    return nearest


def _status(est: StreamEstimate, time_ns: int, *, have: bool) -> dict[str, str]:
    """A touch's status and reason: ``ok``; else why there is no estimate about it."""
    if have:
        return {"status": "ok", "reason": ""}
    if not est.t_ns.size:
        return {"status": "no_detection", "reason": "no frame pair in the trial"}
    j = int(np.argmin(np.abs(est.t_ns - time_ns)))
    status = str(est.status[j])
    if status == "ok":  # the pairs about it are ok, but none brackets its time
        return {
            "status": "no_detection",
            "reason": "no estimate about the touch: no two ok estimates about its time within "
            f"{MAX_TOUCH_GAP_INTERVALS:g} frame intervals (outside the stream, or pairs lost)",
        }
    why = str(est.reason[j]) or status
    return {
        "status": _DEGENERATE.get(status, "no_detection"),
        "reason": f"no estimate about the touch: the nearest pair's {why}",
    }
