"""What one more pose would give a trial: its view predicted, and the trial's 95% region.

The trial's predicted 95% region is the one the analysis will report: its poses' views
solved and propagated by :func:`twopose.solve.session.estimate_session` (pixel scatter,
typed-translation resolution, the calibration's sigma) and reported by the analysis' rule
(:func:`twopose.methods.truth.reported`), the 95% ellipsoid's largest semi-axis (``semiaxis95``).

A candidate pose's view is predicted by projecting the target as the trial's poses locate
it (:func:`target_of`: the point, or the finger's 3-D line by two of its points; with one
pose, a provisional target on the first view's ray, :mod:`twopose.guidance.first_pose`). Its frames
scatter as those of the last pose that saw the target (:func:`template_view`). Each batch
of candidates is one vectorized estimate (:func:`predicted_regions`); candidates may carry
targets of their own (the first pose's depths, predicted in one batch).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from twopose.arrays import F64
from twopose.camera.model import rotation_from_angles_deg
from twopose.detect.detection import wrap_theta_deg
from twopose.guidance.first_pose import assumed_depth, first_depths, first_ray, provisional_target
from twopose.guidance.paper import clear_of_edges, project
from twopose.methods.specs import Method, spec_of
from twopose.methods.truth import reporting_anchor
from twopose.solve.estimate import EstimateOptions, PoseView
from twopose.solve.nview import projection_matrices
from twopose.solve.session import SessionTrials, estimate_session
from twopose.uncertainty.propagate import semiaxis95
from twopose.values.units import DEFAULT_UNITS, Units

__all__ = [
    "located_target",
    "predicted_regions",
    "predicted_view",
    "regions95",
    "target_of",
    "template_view",
]


def regions95(trials: SessionTrials, options: EstimateOptions) -> F64:
    """(T,) each trial's 95% region as the analysis reports it (NaN: not solved).

    The thesis' line's region (no line fits), propagated once where
    :func:`twopose.methods.truth.reported` reports a line
    (:func:`~twopose.methods.truth.reporting_anchor`).
    """
    estimate = estimate_session(
        trials, options, line_fits=False, report_near=reporting_anchor(trials.truth)
    )
    regions = semiaxis95(estimate.estimates.cov)
    return np.where(estimate.estimates.status == "ok", regions, np.nan)


def template_view(views: list[PoseView]) -> PoseView:
    """The view whose frames a predicted view repeats: the last that saw the target."""
    detected = [v for v in views if v.found.any()]
    return detected[-1] if detected else views[-1]


def _shifted_view(template: PoseView, t_grid: F64, px: F64, *, lines: bool) -> PoseView:
    """``template``'s frames moved to the target's pixels ``px`` (2, 2) from ``t_grid``.

    The target is a dot, or two points of the finger's line (the first its centroid); the
    view's frames scatter as ``template``'s.
    """
    used = template.found
    centroids = px[0] + (template.centroids - template.centroids[used].mean(axis=0))
    if lines:
        d = px[1] - px[0]
        theta = math.degrees(math.atan2(d[1], d[0]))
        dev = wrap_theta_deg(template.thetas - template.thetas[used][0])  # lines: no arrow
        thetas = theta + (dev - dev[used].mean())
    else:
        thetas = template.thetas.copy()
    return dataclasses.replace(
        template, t_grid=np.asarray(t_grid, dtype=np.float64), centroids=centroids,
        thetas=thetas, pose=template.pose + 1,
    )  # fmt: skip


def predicted_view(template: PoseView, t_grid: F64, target: F64, *, lines: bool) -> PoseView | None:
    """The view from ``t_grid`` of the target's points, or None if none of its frames saw it.

    Where it keeps the target in view is :func:`twopose.guidance.paper.clear_of_edges`'s question.
    """
    if not template.found.any():
        return None
    px = project(target, template, np.asarray(t_grid, dtype=np.float64)[None])[0]
    return _shifted_view(template, t_grid, px, lines=lines)


def located_target(
    method: Method, views: list[PoseView], point: F64, options: EstimateOptions
) -> F64:
    """(2, 3) the target as two poses or more locate it.

    The estimated point twice, or the finger's 3-D line (the planes' line, for method 2
    too) by two of its points, the first nearest the first view's centroid ray.
    """
    if not spec_of(method).uses_image_lines:
        return np.stack([point, point])
    line = SessionTrials(
        method=Method.LINE, units=DEFAULT_UNITS, trial_ids=(1,), views=[views],
        truth=np.full((1, 2, 3), np.nan),
    )  # fmt: skip
    est = estimate_session(line, options).estimates
    p0, d = est.point[0], est.direction[0]
    centre, ray, _ = first_ray(views[0], options)
    # The line's point nearest the centroid ray: the closest points of two lines.
    w = p0 - centre
    b, dd, e = float(ray @ d), float(d @ d), float(d @ w)
    denom = dd - b * b
    s = (b * float(ray @ w) - e) / denom if denom > 1e-12 else 0.0
    first = p0 + s * d
    scale = float(np.linalg.norm(first - centre)) * 0.02
    return np.stack([first, first + scale * d / np.linalg.norm(d)])


def target_of(
    trial: SessionTrials, options: EstimateOptions, point: F64 | None, *,
    target_distance: float | None = None,
) -> F64:  # fmt: skip
    """(2, 3) the trial's target as guidance uses it.

    With two poses or more and the trial's estimate ``point``: the target they locate
    (:func:`located_target`). With one pose (or no estimate): the provisional target on the
    first view's ray at the depth the suggestion's single figures assume (``predicted95``:
    the taped ``target_distance``, session units, or the middle of the scene's range).
    """
    views = trial.views[0]
    if len(views) < 2 or point is None:
        units = Units(trial.units)
        depths = first_depths(views[0], units, trial.ground, options, target_distance)
        return provisional_target(views[0], units, trial.ground, options, assumed_depth(depths))
    return located_target(trial.method, views, point, options)


def _pixels(targets: F64, view: PoseView, centres: F64) -> F64:
    """(K, 2, 2) each row's target (K, 2, 3) seen from its centre (K, 3) by ``view``'s camera."""
    R = rotation_from_angles_deg(view.r_deg)
    P = projection_matrices(view.intrinsics, R, centres)  # (K, 3, 4)
    h = np.einsum(
        "kij,kmj->kmi", P, np.concatenate([targets, np.ones((*targets.shape[:2], 1))], -1)
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(h[..., :2] / h[..., 2:3])


def predicted_regions(
    trial: SessionTrials, views: list[PoseView], target: F64, centres: F64,
    options: EstimateOptions, *, margin: float = 1.0,
) -> F64:  # fmt: skip
    """(K,) the trial's 95% region with one more view from each of ``centres`` (K, 3).

    ``target``: (2, 3) for every candidate, or (K, 2, 3) one each. NaN where the target
    would not be clear of the image's edges (:func:`twopose.guidance.paper.clear_of_edges`, its
    margins times ``margin``) or the geometry is degenerate.
    """
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    targets = np.broadcast_to(np.asarray(target, dtype=np.float64), (len(centres), 2, 3))
    lines = trial.spec.uses_image_lines
    template = template_view(views)
    out = np.full(len(centres), np.nan)
    if not template.found.any() or not len(centres):
        return out
    units = Units(trial.units)
    clear = np.zeros(len(centres), dtype=bool)
    distinct, which = np.unique(targets.reshape(len(centres), 6), axis=0, return_inverse=True)
    for k, one in enumerate(distinct):  # a few targets (the first pose's depths), or one
        of = np.flatnonzero(which.ravel() == k)
        clear[of] = clear_of_edges(
            template, centres[of], one.reshape(2, 3), units, lines=lines, margin=margin
        )
    where = np.flatnonzero(clear)
    if not where.size:
        return out
    px = _pixels(targets[where], template, centres[where])
    rows = [
        [*views, _shifted_view(template, centres[k], px[n], lines=lines)]
        for n, k in enumerate(where)
    ]
    if options.noise.factor is None and options.noise.test_redundancy:
        # A predicted view has no noise of its own: the batch's candidates never estimate a
        # variance factor (the recorder fixes the session's: recorder.live.result.guidance_options).
        options = dataclasses.replace(
            options, noise=dataclasses.replace(options.noise, test_redundancy=False)
        )
    batch = dataclasses.replace(
        trial, trial_ids=tuple(range(1, len(rows) + 1)), views=rows,
        truth=np.repeat(trial.truth[:1], len(rows), axis=0),
    )  # fmt: skip
    out[where] = regions95(batch, options)
    return out
