"""analysis.tables.rows directly: a trial table from seeded synthetic views, for each method
(the documented columns, the errors against the truth, the baseline and the margins), and
the views table's rays pointing from each camera at the target."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.tables.columns import (
    IDENTITY_COLUMNS,
    LINE_COLUMNS,
    OPTIMAL_COLUMNS,
    TRIAL_COLUMNS,
    VIEW_COLUMNS,
)
from analysis.tables.rows import view_table
from analysis.tables.trials import trial_table
from twopose.camera.model import Intrinsics, project_points
from twopose.methods.specs import Method, spec_of
from twopose.methods.truth import reported
from twopose.solve.estimate import EstimateOptions, PoseView, measure
from twopose.solve.session import SessionTrials, estimate_session
from twopose.values.units import Units

K = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
H = 9.625


def _project(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    projected: np.ndarray = project_points(p[None], K, np.eye(3), t)
    return projected[0]


def _view(pose: int, t: np.ndarray, px: np.ndarray, theta: float) -> PoseView:
    return PoseView(
        pose=pose,
        intrinsics=np.array([K.fx, K.fy, K.cx, K.cy]),
        width_height=(640, 480),
        t_grid=t,
        r_deg=np.zeros(3),
        t_sigma=0.0625,
        r_sigma_deg=0.5,
        centroids=np.tile(px, (3, 1)),
        thetas=np.full(3, theta),
        found=np.ones(3, dtype=bool),
    )


def _session(method: str) -> tuple[list[list[PoseView]], np.ndarray]:
    """Two exact trials (baselines 1 and 2 in along x)."""
    views, truth = [], []
    for b in (1.0, 2.0):
        t1, t2 = np.zeros(3), np.array([b, 0.0, 0.0])
        if method == "point":
            p = np.array([0.5, 1.5, 11.0])
            views.append(
                [_view(1, t1, _project(p, t1), np.nan), _view(2, t2, _project(p, t2), np.nan)]
            )
            truth.append([p, np.full(3, np.nan)])
            continue
        g, top = np.array([1.9, H, 8.4]), np.array([2.2, H - 6.0, 9.9])
        row = []
        for k, t in enumerate((t1, t2), start=1):
            a, c = _project(top, t), _project(g, t)
            row.append(
                _view(k, t, (a + c) / 2, float(np.degrees(np.arctan2(c[1] - a[1], c[0] - a[0]))))
            )
        views.append(row)
        truth.append([top, g] if method == "line" else [g, np.full(3, np.nan)])
    return views, np.array(truth)


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_a_trial_table_has_the_documented_columns_and_exact_errors(method: str) -> None:
    views, truth = _session(method)
    ground = (np.array([0.0, 1.0, 0.0]), H) if spec_of(method).needs_ground else None
    trials = SessionTrials(
        method=Method(method),
        units=Units.IN,
        trial_ids=(1, 2),
        views=views,
        truth=truth,
        ground=ground,
    )
    estimate = estimate_session(trials, EstimateOptions())
    table = trial_table("s.mcap", estimate, reported(estimate))
    extra = LINE_COLUMNS if method == "line" else OPTIMAL_COLUMNS if method == "point" else []
    # What the trial is (its label, session, part, branch) the pipeline adds: with_identity.
    declared = [c for c in TRIAL_COLUMNS if c not in IDENTITY_COLUMNS] + extra
    assert list(table.columns[: len(declared)]) == declared
    for name in (*spec_of(method).margins, "warning", "baseline", "notes", "within95"):
        assert name in table.columns, name
    assert list(table["status"]) == ["ok", "ok"]
    assert list(table["n_views"]) == [2, 2]
    assert list(table["baseline"]) == [1.0, 2.0]  # the typed centres' distance
    # Exact measurements: the errors vanish, and err is the norm of err_x, err_y, err_z.
    assert (table["err"] < 1e-6).all(), table["err"]
    np.testing.assert_allclose(
        table["err"], np.linalg.norm(table[["err_x", "err_y", "err_z"]], axis=1)
    )
    if method == "line":  # reported at the line's point nearest the true midpoint
        np.testing.assert_allclose(table[["gt_x", "gt_y", "gt_z"]], truth.mean(axis=1), atol=1e-9)
        assert (table["angle_err_deg"] < 1e-4).all()
    else:
        np.testing.assert_allclose(table[["gt_x", "gt_y", "gt_z"]], truth[:, 0])


def test_the_views_table_rays_point_from_each_camera_at_the_target() -> None:
    views, truth = _session("point")
    ms, _, _ = measure(views, EstimateOptions())
    table = view_table("s.mcap", [1, 2], views, ms, units=Units.IN)
    assert list(table.columns) == VIEW_COLUMNS
    assert len(table) == 4
    assert list(table["units"]) == ["in"] * 4
    for row in table.itertuples():
        centre = np.array([row.t_x, row.t_y, row.t_z])
        to_target = truth[0, 0] - centre
        ray = np.array([row.ray_x, row.ray_y, row.ray_z])
        np.testing.assert_allclose(ray, to_target / np.linalg.norm(to_target), atol=1e-9)
