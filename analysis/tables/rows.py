"""Tables: a session's detections, estimates and running averages as tidy DataFrames.

Pure functions from arrays to one row per frame (``frames.csv``), per used pose
(``views.csv``) and per running average (``averaging.csv``) (the trials' table is filled
from its declarations, where they are: :func:`analysis.tables.trials.trial_table`); the
column lists are the documented ones, each column as its declared dtype
(:func:`analysis.tables.columns.typed`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from analysis.tables.columns import AVERAGING_COLUMNS, IDENTITY_COLUMNS, VIEW_COLUMNS, typed
from twopose.arrays import F64
from twopose.camera.model import grid_rays, rotation_from_angles_deg
from twopose.detect.detection import Detection
from twopose.detect.frames import PoseMeasurement
from twopose.methods.truth import line_errors
from twopose.values.units import Units

if TYPE_CHECKING:
    from analysis.batch.inputs import SessionIdentity
    from twopose.format.entries import PoseEntry
    from twopose.format.messages import Frame
    from twopose.solve.estimate import PoseView, Solved

__all__ = [
    "ONE_CAMERA_VIEW",
    "averaging_table",
    "frame_row",
    "view_table",
]

#: A one-camera view's columns that a two-camera session's frame pairs fill.
ONE_CAMERA_VIEW: Mapping[str, Any] = {
    "cameras": 1, "pair": 0, "pair_time_ns": 0, "skew_ms": np.nan, "status": "", "reason": "",
    "conditioning": np.nan,
}  # fmt: skip


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
        "cameras": 1,
        "capture_ns": frame.capture_ns or 0,  # an older file's stamp is its write time
    }


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
                    **ONE_CAMERA_VIEW,
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
            "cameras": 1,
        },
        columns=AVERAGING_COLUMNS,
    )
    return typed(table)


def with_identity(
    trials: pd.DataFrame, identity: SessionIdentity, part_of: Mapping[int, str]
) -> pd.DataFrame:
    """The trials table with what each trial is (:data:`~analysis.tables.columns.IDENTITY_COLUMNS`,
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
