"""Tables: a session's detections, estimates and running averages as tidy DataFrames.

Pure functions from arrays to one row per frame (``frames.csv``), per trial
(``trials.csv``), per used pose (``views.csv``) and per running average
(``averaging.csv``); the column lists are the documented ones, each column as its
declared dtype (:func:`analysis.columns.typed`).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from analysis.columns import (
    AVERAGING_COLUMNS,
    IDENTITY_COLUMNS,
    TRIAL_COLUMNS,
    VIEW_COLUMNS,
    typed,
)
from twopose.arrays import F64
from twopose.camera import grid_rays, rotation_from_angles_deg
from twopose.detect import Detection
from twopose.frames import PoseMeasurement
from twopose.methods import Method, spec_of
from twopose.truth import Reported, line_errors
from twopose.uncertainty import uncertainty_columns
from twopose.units import Units

if TYPE_CHECKING:
    from analysis.input_set import SessionIdentity
    from twopose.estimate import PoseView, Solved
    from twopose.format.entries import PoseEntry
    from twopose.format.messages import Frame
    from twopose.session_estimate import Estimates, SessionEstimate

__all__ = [
    "averaging_table",
    "frame_row",
    "trial_table",
    "view_table",
]


def frame_row(
    session: str, trial: int, entry: PoseEntry, index: int, frame: Frame, det: Detection
) -> dict[str, Any]:
    """One frame's detection, a row of ``frames.csv``."""
    return {
        "session": session,
        "trial": trial,
        "pose": entry.pose,
        "camera": entry.camera_id,
        "frame": index,
        "log_time_ns": frame.log_time_ns,
        "found": det.found,
        "col": det.centroid_px[0],
        "row": det.centroid_px[1],
        "theta_deg": det.theta_deg,
        "area_px": det.area_px,
        "eccentricity": det.eccentricity,
        "pi_estimate": det.pi_estimate,
        "n_blobs": det.n_blobs,
        "n_candidates": det.n_candidates,
        "reason": det.reason,
    }


def _method_columns(method: Method, est: Estimates, truth: F64) -> dict[str, Any]:
    """The method's extra columns: a line's direction and errors; a point's
    reprojection-optimal estimate beside the thesis' one."""
    if spec_of(method).estimates_line:
        with np.errstate(invalid="ignore"):
            _, _, angle, dist = line_errors(est.point, est.direction, truth[:, 0], truth[:, 1])
        extra = {f"dir_{a}": est.direction[:, i] for i, a in enumerate("xyz")}
        return extra | {"angle_err_deg": angle, "dist_err": dist}
    if "optimal" in spec_of(method).estimators and not spec_of(method).estimates_line:
        # the point's estimators side by side
        opt_err = est.optimal - truth[:, 0]
        extra = {f"{a}_optimal": est.optimal[:, i] for i, a in enumerate("xyz")}
        return extra | {"err_optimal": np.linalg.norm(opt_err, axis=1)}
    return {}


def _other_line_columns(est: Estimates, truth: F64) -> dict[str, Any]:
    """Line trials: the weighted/robust fit (``*_weighted``) and the reprojection-optimal
    line (``*_optimal``), each compared with the truth as the thesis' line."""
    columns: dict[str, Any] = {}
    for name, line in (("weighted", est.weighted_line), ("optimal", est.optimal_line)):
        with np.errstate(invalid="ignore"):
            point, mid, angle, dist = line_errors(line[:, 0], line[:, 1], truth[:, 0], truth[:, 1])
        point = np.where(np.isfinite(mid), point, line[:, 0])
        columns |= {f"{a}_{name}": point[:, i] for i, a in enumerate("xyz")}
        if name == "optimal":
            columns["err_optimal"] = np.linalg.norm(point - mid, axis=1)
        columns |= {f"angle_err_{name}_deg": angle, f"dist_err_{name}": dist}
    return columns


def trial_table(
    session: str,
    estimate: SessionEstimate,
    reported_: Reported,
    notes: Sequence[str] | None = None,
    unmeasured: Sequence[str] | None = None,
) -> pd.DataFrame:
    """One row per trial (``trials.csv``): estimate, truth, error, margins, uncertainty,
    the operator's ``notes``; ``unmeasured`` (per trial, why its captures do not make two
    usable poses) replaces the generic reason of an ``incomplete`` trial."""
    trials, est = estimate.trials, estimate.estimates
    method, T = trials.method, len(trials)
    point, reference, err = reported_.point, reported_.reference, reported_.error
    table = pd.DataFrame(
        {
            "session": [session] * T,
            "trial": list(trials.trial_ids),
            "method": [str(method)] * T,
            "units": [str(trials.units)] * T,
            "status": est.status,
            "reason": _reasons(est, unmeasured),
            "n_views": [len(v) if len(v) >= 2 else 0 for v in trials.views],
            "conditioning": est.conditioning,
            **{a: point[:, i] for i, a in enumerate("xyz")},
            **{f"gt_{a}": reference[:, i] for i, a in enumerate("xyz")},
            **{f"err_{a}": err[:, i] for i, a in enumerate("xyz")},
            "err": np.linalg.norm(err, axis=1),
            **_method_columns(method, est, trials.truth),
        }
    )
    declared = [c for c in TRIAL_COLUMNS if c not in IDENTITY_COLUMNS]  # with_identity's
    table = table[[*declared, *spec_of(method).extra_columns]]
    for name, values in est.margins.items():
        table[name] = values
    table["warning"] = estimate.warnings
    table["baseline"] = [_baseline(v) for v in trials.views]
    if spec_of(method).estimates_line:
        for name, values in _other_line_columns(est, trials.truth).items():
            table[name] = values
    for name, values in uncertainty_columns(err, reported_.cov).items():
        table[name] = values
    table["dominant_input"] = reported_.dominant
    table["dominant_share"] = reported_.dominant_share
    table["rejected_frames"] = [
        _rejected(ms, vs) if ms else ""
        for ms, vs in zip(estimate.measurements, trials.views, strict=True)
    ]
    table["notes"] = list(notes) if notes is not None else [""] * T
    return typed(table)


def _reasons(est: Estimates, unmeasured: Sequence[str] | None) -> list[str]:
    """Each trial's reason; an incomplete trial's says which captures were set aside."""
    reasons = [str(r) for r in est.reason]
    if unmeasured is None:
        return reasons
    return [
        why if status == "incomplete" and why else reason
        for reason, status, why in zip(reasons, est.status, unmeasured, strict=True)
    ]


def _baseline(views: list[PoseView]) -> float:
    """The longest distance between two typed camera centres of a trial (NaN: one pose)."""
    return max(
        (float(np.linalg.norm(a.t_grid - b.t_grid)) for a, b in itertools.combinations(views, 2)),
        default=np.nan,
    )


def _rejected(measurements: list[PoseMeasurement], views: list[PoseView]) -> str:
    """Frames dropped as outliers, per pose: ``"pose 2: 3, 4"`` (frame indices as in
    frames.csv; empty when none)."""
    return "; ".join(
        f"pose {v.pose}: {', '.join(str(i) for i in m.rejected)}"
        for m, v in zip(measurements, views, strict=True)
        if m.rejected
    )


def view_table(
    session: str,
    trial_ids: Sequence[int],
    views: list[list[PoseView]],
    measurements: list[list[PoseMeasurement]],
    *,
    units: Units,
) -> pd.DataFrame:
    """One row per measured pose (``views.csv``): camera centre (in the session's
    ``units``), pixel and grid-frame ray."""
    rows = []
    for trial, row_views, ms in zip(trial_ids, views, measurements, strict=True):
        for v, m in zip(row_views, ms, strict=False):  # incomplete trials have none
            ray = grid_rays(m.centroid_px, v.intrinsics, rotation_from_angles_deg(v.r_deg))
            rows.append(
                {
                    "session": session,
                    "trial": trial,
                    "pose": v.pose,
                    "units": units,
                    **{f"t_{a}": v.t_grid[i] for i, a in enumerate("xyz")},
                    "col": m.centroid_px[0],
                    "row": m.centroid_px[1],
                    "theta_deg": m.theta_deg,
                    **{f"ray_{a}": ray[i] for i, a in enumerate("xyz")},
                    **dict(zip(("fx", "fy", "cx", "cy"), map(float, v.intrinsics), strict=True)),
                    **{f"r_{a}_deg": float(v.r_deg[i]) for i, a in enumerate("xyz")},
                }
            )
    return typed(pd.DataFrame(rows, columns=VIEW_COLUMNS))


def averaging_table(
    session: str,
    trial_ids: Sequence[int],
    keys: list[tuple[int, int]],
    solved: Solved | None,
    truth: F64,
    *,
    units: Units,
) -> pd.DataFrame:
    """``averaging.csv``: the estimate from the first ``n_frames`` frames of each pose, in
    the session's ``units``."""
    if solved is None:
        return typed(pd.DataFrame(columns=AVERAGING_COLUMNS))
    idx = np.array([i for i, _ in keys])
    point = solved.point
    if solved.direction is not None:
        with np.errstate(invalid="ignore"):
            point, reference, _, _ = line_errors(
                point, solved.direction, truth[idx, 0], truth[idx, 1]
            )
    else:
        reference = truth[idx, 0]
    table = pd.DataFrame(
        {
            "session": session,
            "trial": [trial_ids[i] for i in idx],
            "n_frames": [n for _, n in keys],
            "units": units,
            "x": point[:, 0],
            "y": point[:, 1],
            "z": point[:, 2],
            "err": np.linalg.norm(point - reference, axis=1),
        },
        columns=AVERAGING_COLUMNS,
    )
    return typed(table)


def with_identity(
    trials: pd.DataFrame, identity: SessionIdentity, part_of: Mapping[int, str]
) -> pd.DataFrame:
    """The trials table with what each trial is (:data:`~analysis.columns.IDENTITY_COLUMNS`,
    after ``session``): its label, its session, its part and its branch. ``part_of``: each
    trial's part's path."""
    parts = [identity.part(part_of.get(int(t), "")) for t in trials["trial"]]
    values = {
        "label": [identity.label] * len(trials),
        "session_id": [identity.session_id] * len(trials),
        "part": [p for p, _ in parts],
        "branch": [b for _, b in parts],
    }
    out = trials.copy()
    for k, column in enumerate(IDENTITY_COLUMNS):
        out.insert(1 + k, column, values[column])
    return typed(out)


def with_branch(
    table: pd.DataFrame, identity: SessionIdentity, part_of: Mapping[int, str]
) -> pd.DataFrame:
    """A per-trial table (views, frames, averaging) with each row's trial's ``branch``."""
    branches = [identity.part(part_of.get(int(t), ""))[1] for t in table["trial"]]
    return typed(table.assign(branch=branches))
