"""twopose.region_map at a known geometry (seeded frame scatter): the map's best is at least
as good as every cell, a cell without a region says why (out of view, taken, unsolved) and
is never given one, its count stays bounded on the finest paper and widest reach, the three
best are apart, and its JSON is what the console draws."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from twopose.estimate import EstimateOptions, PoseView
from twopose.guidance import Reach, predicted_regions, suggest, target_of
from twopose.jsonsafe import dumps
from twopose.methods import Method
from twopose.paper_search import EDGE, TAKEN, clear_of_edges
from twopose.region_map import MAP_POSES, REASONS, RegionMap, region_map
from twopose.session_estimate import SessionTrials, estimate_session
from twopose.solve import projection_matrices
from twopose.units import Units

K = np.array([525.0, 525.0, 320.0, 240.0])
POINT = np.array([0.5, 2.0, 11.0])  # a dot ahead of the first pose (inches)
FINGER = (np.array([1.0, 2.5, 12.0]), np.array([0.5, 0.0, 13.5]))  # tip, base
GROUND_H = 9.625


def _view(t: tuple[float, float, float], points: np.ndarray, pose: int, lines: bool,
          rng: np.random.Generator) -> PoseView:  # fmt: skip
    P = projection_matrices(K, np.eye(3), np.asarray(t))
    h = np.column_stack([points, np.ones(len(points))]) @ P.T
    px = h[:, :2] / h[:, 2:3]
    theta = math.degrees(math.atan2(*(px[1] - px[0])[::-1])) if lines else math.nan
    return PoseView(
        pose=pose, intrinsics=K, width_height=(640, 480), t_grid=np.asarray(t, dtype=float),
        r_deg=np.zeros(3), t_sigma=0.03, r_sigma_deg=0.0,
        centroids=px[0] + 0.2 * rng.standard_normal((5, 2)),
        thetas=theta + 0.1 * rng.standard_normal(5) if lines else np.full(5, np.nan),
        found=np.ones(5, dtype=bool), camera_id="cam0", intrinsics_sigma=np.full(4, 2.0),
    )  # fmt: skip


def _trial(method: Method, centres: list[tuple[float, float, float]]) -> SessionTrials:
    rng = np.random.default_rng(46)
    lines = method is not Method.POINT
    points = np.stack(FINGER) if lines else np.stack([POINT, POINT])
    views = [_view(t, points, i + 1, lines, rng) for i, t in enumerate(centres)]
    truth = np.full((1, 2, 3), np.nan)
    ground = (np.array([0.0, 1.0, 0.0]), GROUND_H) if method is Method.GROUND else None
    return SessionTrials(
        method=method, units="in", trial_ids=(1,), views=[views], truth=truth, ground=ground
    )


def _map(method: Method, poses: int, reach: Reach) -> tuple[SessionTrials, RegionMap, object]:
    centres = [(0.0, 0.0, 0.0), (-1.5, 0.0, 0.5), (1.0, 0.0, 1.0)][:poses]
    trial = _trial(method, centres)
    point = None
    if poses >= 2:
        point = estimate_session(trial, EstimateOptions()).estimates.point[0]
    found = suggest(trial, reach, point=point)
    return trial, region_map(trial, reach, point=point, suggestion=found), point


@pytest.mark.parametrize("method", [Method.POINT, Method.LINE, Method.GROUND])
def test_the_best_is_at_least_as_good_as_every_cell_and_cells_are_the_prediction(
    method: Method,
) -> None:
    reach = Reach(radius=2.0, spacing=0.5)
    trial, m, point = _map(method, 2, reach)
    best = m.best()
    assert best is not None
    finite = m.region95[np.isfinite(m.region95)]
    assert finite.size > 20
    assert best[1] <= finite.min() + 1e-12
    assert best[1] <= m.suggested95 + 1e-12
    # A cell's region is the trial's with one more pose at the cell's pose, as guidance
    # predicts it (a few cells, predicted alone).
    located = None if point is None else np.asarray(point)
    target = target_of(trial, EstimateOptions(), located)
    jj, ii = np.nonzero(np.isfinite(m.region95))
    pick = np.linspace(0, len(jj) - 1, 4).astype(int)
    alone = predicted_regions(
        trial, trial.views[0], target, m.poses[jj[pick], ii[pick]], EstimateOptions()
    )
    np.testing.assert_allclose(alone, m.region95[jj[pick], ii[pick]], rtol=1e-9)


def test_a_cell_without_a_region_says_why_and_out_of_view_is_nan() -> None:
    reach = Reach(radius=6.0, spacing=0.5)  # wide: part of the reach loses the target
    trial, m, point = _map(Method.POINT, 2, reach)
    reason = np.asarray(REASONS, dtype=object)[m.reason]
    assert np.isnan(m.region95[reason != ""]).all()
    assert np.isfinite(m.region95[reason == ""]).all()
    edge = reason == EDGE
    assert edge.any()
    # A blank cell's centre would put the target near the image's edge.
    target = target_of(trial, EstimateOptions(), np.asarray(point))
    centres = np.column_stack([
        np.broadcast_to(m.x[None, :], m.reason.shape)[edge], np.zeros(int(edge.sum())),
        np.broadcast_to(m.z[:, None], m.reason.shape)[edge],
    ])  # fmt: skip
    assert not clear_of_edges(trial.views[0][-1], centres, target, Units.IN, lines=False).any()
    # The poses taken are hatched, never predicted (the first lies on the map's lines).
    assert (reason == TAKEN).sum() >= 1
    first = np.argwhere((m.poses[..., 0] == 0.0) & (m.poses[..., 2] == 0.0))
    assert reason[tuple(first[0])] == TAKEN


def test_the_map_is_bounded_on_fine_paper_and_a_wide_reach() -> None:
    """1 mm paper and a 30 in reach hold about 2.3 million poses: the map predicts at most
    MAP_POSES in one batch, its cells at most a few times that."""
    reach = Reach(radius=30.0, spacing=1 / 25.4)
    trial = _trial(Method.POINT, [(0.0, 0.0, 0.0), (-1.5, 0.0, 0.5)])
    point = estimate_session(trial, EstimateOptions()).estimates.point[0]
    started = time.process_time()
    m = region_map(trial, reach, point=point)
    spent = time.process_time() - started
    assert m.n_reach > 2_000_000
    predicted = int(np.isin(m.reason, [0, 3]).sum())
    assert 0.5 * MAP_POSES <= predicted <= MAP_POSES
    assert m.reason.size <= 4 * MAP_POSES
    assert m.step > 1
    assert spent < 1.5  # one batch of MAP_POSES (about 0.2 s here)


def test_one_pose_has_a_map_and_the_three_best_are_apart() -> None:
    reach = Reach(radius=3.0, spacing=0.5)
    _, m, _ = _map(Method.LINE, 1, reach)
    top = m.n_best(3)
    assert len(top) == 3
    regions = [r for _, r in top]
    assert regions == sorted(regions)
    for a in range(3):
        for b in range(a + 1, 3):
            gap = np.abs(top[a][0] - top[b][0])[[0, 2]].max()
            assert gap > 1.5 * m.cell  # not neighbours
    lines = m.best_lines(3)
    # One pose: the map says where along the first view's ray it assumes the target.
    assert math.isfinite(m.assumed_depth)
    assumed = f"the target assumed {m.assumed_depth:.3g} in along the first ray"
    assert lines[0] == f"the 3 best poses of the map (predicted 95% region, {assumed}):"
    best = m.best()
    assert best is not None
    assert best[1] == regions[0]
    assert all(f"within {r:.3g} in" in line for r, line in zip(regions, lines[1:], strict=True))


def test_the_json_is_what_the_page_draws() -> None:
    reach = Reach(radius=3.0, spacing=0.5)
    _, m, _ = _map(Method.GROUND, 2, reach)
    page = json.loads(dumps(m.to_json()))
    assert page["units"] == "in"
    assert len(page["region95"]) == len(page["z"]) == len(page["reason"])
    assert all(len(row) == len(page["x"]) for row in page["region95"])
    assert page["reasons"][0] == ""
    cells = [(v, r) for vs, rs in zip(page["region95"], page["reason"], strict=True)
             for v, r in zip(vs, rs, strict=True)]  # fmt: skip
    assert all((v is None) == (r != 0) for v, r in cells)
    lo, hi = page["scale"]
    assert lo == page["best"]["region95"] == page["top"][0]["region95"]
    assert lo <= hi <= 2 * lo * 1.001  # four digits each
    assert min(v for v, _ in cells if v is not None) >= lo
    assert len(page["top"]) == 3
    assert page["taken"] == [[0.0, 0.0], [-1.5, 0.5]]
    assert page["assumed_depth"] is None  # two poses locate the target
