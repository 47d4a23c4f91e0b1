"""Seeded synthetic trials for the estimation tests: a true point, line or ground point
projected into typed poses of the thesis' camera, with 0.3 px frame noise, and their
session estimate."""

from __future__ import annotations

import numpy as np

from twopose.camera.model import Intrinsics, project_points, rotation_from_angles_deg
from twopose.methods.specs import Method, spec_of
from twopose.solve.estimate import EstimateOptions, PoseView
from twopose.solve.session import (
    SessionEstimate,
    SessionTrials,
    estimate_session,
)
from twopose.values.units import Units

INTRINSICS = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
H = 9.625  # the thesis' ground height: the ground plane y = h (y down)
GROUND = (np.array([0.0, 1.0, 0.0]), H)
FRAMES = 5


def view(
    pose: int, t: np.ndarray, px: np.ndarray, theta: float, rng: np.random.Generator
) -> PoseView:
    """A pose seeing ``px`` (the target's centroid) with image orientation ``theta`` over
    FRAMES frames of 0.3 px noise."""
    return PoseView(
        pose=pose,
        intrinsics=np.array([INTRINSICS.fx, INTRINSICS.fy, INTRINSICS.cx, INTRINSICS.cy]),
        width_height=(640, 480),
        t_grid=t,
        r_deg=np.zeros(3),
        t_sigma=0.0625,
        r_sigma_deg=0.5,
        centroids=px + 0.3 * rng.standard_normal((FRAMES, 2)),
        thetas=np.full(FRAMES, theta) + 0.1 * rng.standard_normal(FRAMES),
        found=np.ones(FRAMES, dtype=bool),
    )


def project(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    projected: np.ndarray = project_points(
        p[None], INTRINSICS, rotation_from_angles_deg([0, 0, 0]), t
    )
    return projected[0]


def _lineview(
    pose: int, t: np.ndarray, a: np.ndarray, b: np.ndarray, rng: np.random.Generator
) -> PoseView:
    """A pose seeing the 3-D segment a-b: its midpoint's image and the image direction."""
    pa, pb = project(a, t), project(b, t)
    theta = float(np.degrees(np.arctan2(pb[1] - pa[1], pb[0] - pa[0])))
    return view(pose, t, (pa + pb) / 2, theta, rng)


def trials(
    method: str, rng: np.random.Generator, baselines: list[float]
) -> tuple[list[list[PoseView]], np.ndarray]:
    """One trial per baseline (the second camera's x, in inches; 0: no baseline)."""
    views, truth = [], []
    for b in baselines:
        t1, t2 = np.zeros(3), np.array([b, 0.0, 0.0])
        if method == "point":
            p = np.array([0.5, 1.5, 11.0]) + rng.uniform(-0.5, 0.5, 3)
            row = [
                view(1, t1, project(p, t1), np.nan, rng),
                view(2, t2, project(p, t2), np.nan, rng),
            ]
            truth.append([p, [np.nan] * 3])
        else:
            g = np.array([1.9, H, 8.4]) + np.array(
                [rng.uniform(-0.5, 0.5), 0, rng.uniform(-0.5, 0.5)]
            )
            top = g + np.array([0.3, -6.0, 1.5])  # the finger, leaning towards the camera
            row = [_lineview(1, t1, top, g, rng), _lineview(2, t2, top, g, rng)]
            truth.append([top, g] if method == "line" else [g, [np.nan] * 3])
        views.append(row)
    return views, np.array(truth, dtype=np.float64)


def estimate(method: str, views: list[list[PoseView]], truth: np.ndarray) -> SessionEstimate:
    trials = SessionTrials(
        method=Method(method),
        units=Units.IN,
        trial_ids=tuple(range(1, len(views) + 1)),
        views=views,
        truth=truth,
        ground=GROUND if spec_of(method).needs_ground else None,
    )
    return estimate_session(trials, EstimateOptions())
