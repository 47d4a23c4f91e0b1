"""The comparison with the typed ground truth, in one place.

Which point a trial reports, the true point it is compared with, and a line's errors.

Estimation (:mod:`twopose.solve.session`) never reads the truth. A line has no one
point, so the analysis and the live result report it at its point nearest the true
segment's midpoint (with no truth, at the solved point), with that point's covariance;
points and ground points report the estimate itself. :func:`reported` is that rule for
trials.csv, the live result, the rig fit and the scenes alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64


class SessionEstimate(Protocol):
    """What :func:`reported` reads of :class:`twopose.solve.session.SessionEstimate`.

    A protocol, not an import: the session's estimate tests each trial against its truth
    with :func:`reported` (:mod:`twopose.uncertainty.blunders`), and the tables' readers
    need no estimation at import.
    """

    @property
    def estimates(self) -> Any: ...

    @property
    def trials(self) -> Any: ...

    def uncertainty_at(self, reference: F64) -> Any: ...


__all__ = ["Reported", "line_errors", "reported", "reported_line_point", "reporting_anchor"]


@dataclass(frozen=True, kw_only=True)
class Reported:
    """Per trial: the point reported and the true point it is compared with.

    Per trial (T rows): the point reported, the true point it is compared with (NaN: no
    truth), their difference, and the reported point's covariance and dominant input.
    """

    point: F64  # (T, 3)
    reference: F64  # (T, 3)
    error: F64  # (T, 3) point - reference
    cov: F64  # (T, 3, 3)
    dominant: NDArray[np.object_]  # (T,)
    dominant_share: F64  # (T,)


def reported(estimate: SessionEstimate) -> Reported:
    """Each trial's reported point and its comparison with the truth.

    Lines are reported at their point nearest the true segment's midpoint (with no truth,
    the solved point), and their covariance is propagated there, the midpoint held fixed;
    otherwise the estimate is compared with the first true point.
    """
    est, truth = estimate.estimates, estimate.trials.truth
    if not estimate.trials.spec.estimates_line:
        point, reference = est.point, truth[:, 0]
        return Reported(
            point=point,
            reference=reference,
            error=point - reference,
            cov=est.cov,
            dominant=est.dominant,
            dominant_share=est.dominant_share,
        )
    point, mid = reported_line_point(est.point, est.direction, truth)
    anchor = reporting_anchor(truth)
    if np.isfinite(anchor).any():
        uncertainty = estimate.uncertainty_at(np.where(np.isfinite(anchor), anchor, est.point))
        cov, dominant, share = uncertainty.cov, uncertainty.dominant, uncertainty.dominant_share
    else:  # nothing to move to: the solved point's, as estimated
        cov, dominant, share = est.cov, est.dominant, est.dominant_share
    return Reported(
        point=point,
        reference=mid,
        error=point - mid,
        cov=cov,
        dominant=dominant,
        dominant_share=share,
    )


def reporting_anchor(truth: F64) -> F64:
    """(T, 3) where a line's region is reported: its true segment's midpoint (NaN: none).

    ``truth`` (T, 2, 3); the point of the line nearest it is held fixed as the region is
    propagated (:meth:`twopose.solve.session.SessionEstimate.uncertainty_at`).
    """
    return np.asarray(truth.mean(axis=1))


def reported_line_point(point: F64, direction: F64, truth: F64) -> tuple[F64, F64]:
    """Lines: each one's point nearest its true segment's midpoint.

    Lines (T rows): the point each reports, nearest its true segment's midpoint (with no
    truth, ``point``), and that midpoint (NaN: no truth); ``truth`` is (T, 2, 3).
    """
    with np.errstate(invalid="ignore"):
        nearest, mid, _, _ = line_errors(point, direction, truth[:, 0], truth[:, 1])
    return np.where(np.isfinite(mid), nearest, point), mid


def line_errors(
    point_grid: F64, direction_grid: F64, gt_a: F64, gt_b: F64
) -> tuple[F64, F64, F64, F64]:
    """Compare estimated lines with ground-truth lines.

    Parameters
    ----------
    point_grid, direction_grid : (T, 3)
        A point on each estimated line and its unit direction.
    gt_a, gt_b : (T, 3)
        Two points on each true line.

    Returns
    -------
    nearest : (T, 3)
        The estimated line's point nearest the true segment's midpoint.
    midpoint : (T, 3)
        The true segment's midpoint.
    angle_err_deg : (T,)
        Angle between the lines, in [0, 90] degrees (lines have no arrow).
    dist_err : (T,)
        Distance from the true midpoint to the estimated line.
    """
    mid = 0.5 * (gt_a + gt_b)
    s = np.einsum("ti,ti->t", mid - point_grid, direction_grid)
    nearest = point_grid + s[:, None] * direction_grid
    gt_dir = (gt_b - gt_a) / np.linalg.norm(gt_b - gt_a, axis=1, keepdims=True)
    cos = np.clip(np.abs(np.einsum("ti,ti->t", gt_dir, direction_grid)), 0.0, 1.0)
    angle = np.degrees(np.arccos(cos))
    dist = np.linalg.norm(nearest - mid, axis=1)
    return nearest, mid, angle, dist
