"""One pose's K frame detections combined into one measurement.

The mean as the thesis (section 5.2.4: five frames a pose, averaged), or the median, or the
mean after outlier rejection; orientations averaged as line directions (doubled angles).
No I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from twopose.detect.detection import wrap_theta_deg
from twopose.values.choices import CombineRule

__all__ = ["PoseMeasurement", "combine_frames"]


@dataclass(frozen=True, kw_only=True)
class PoseMeasurement:
    """One pose's combined measurement from its K frames.

    ``centroid_std_px`` and ``theta_std_deg`` are the frame-to-frame scatter of the frames
    used; ``rejected`` lists the indices of found frames dropped as outliers.
    """

    found: bool
    centroid_px: tuple[float, float]
    theta_deg: float
    n_used: int
    n_frames: int
    centroid_std_px: tuple[float, float]
    theta_std_deg: float
    rejected: tuple[int, ...] = ()


def _doubled_angle_mean(theta_deg: NDArray[np.float64]) -> float:
    """Mean line direction: average (cos 2t, sin 2t), never raw angles (docs/method.md)."""
    t2 = np.deg2rad(2.0 * theta_deg)
    return float(wrap_theta_deg(np.rad2deg(0.5 * math.atan2(np.sin(t2).mean(), np.cos(t2).mean()))))


def _angle_deviation(theta_deg: NDArray[np.float64], ref_deg: float) -> NDArray[np.float64]:
    return wrap_theta_deg(theta_deg - ref_deg)


def combine_frames(
    centroids_px: NDArray[np.float64],
    thetas_deg: NDArray[np.float64],
    found: NDArray[np.bool_],
    method: CombineRule = "mean",
    *,
    outlier_sigmas: float = 3.5,
) -> PoseMeasurement:
    """Combine K frame detections of one pose.

    Parameters
    ----------
    centroids_px : (K, 2) ndarray
        (col, row) per frame; rows of frames not found are ignored.
    thetas_deg : (K,) ndarray
        Orientation per frame (NaN for the dot).
    found : (K,) bool ndarray
    method : {"mean", "median", "robust"}
        ``mean`` is the thesis' five-frame average; ``median`` the component-wise median
        (orientation: median of doubled-angle deviations); ``robust`` drops frames more than
        ``outlier_sigmas`` robust standard deviations (1.4826 MAD) from the median, then
        averages.
    """
    c = np.asarray(centroids_px, dtype=np.float64).reshape(-1, 2)
    th = np.asarray(thetas_deg, dtype=np.float64).reshape(-1)
    ok = np.asarray(found, dtype=bool).reshape(-1)
    k = ok.size
    idx = np.flatnonzero(ok)
    nan2 = (math.nan, math.nan)
    if idx.size == 0:
        return PoseMeasurement(
            found=False,
            centroid_px=nan2,
            theta_deg=math.nan,
            n_used=0,
            n_frames=k,
            centroid_std_px=nan2,
            theta_std_deg=math.nan,
        )
    has_theta = bool(np.isfinite(th[idx]).all())
    rejected: tuple[int, ...] = ()
    if method == "robust" and idx.size >= 3:
        med = np.median(c[idx], axis=0)
        dist = np.linalg.norm(c[idx] - med, axis=1)
        scale = max(1.4826 * float(np.median(dist)), 0.05)
        bad = dist > outlier_sigmas * scale
        if has_theta:
            dev = np.abs(_angle_deviation(th[idx], _doubled_angle_mean(th[idx])))
            tscale = max(1.4826 * float(np.median(dev)), 0.05)
            bad |= dev > outlier_sigmas * tscale
        if bad.any() and (~bad).sum() >= 2:
            rejected = tuple(int(i) for i in idx[bad])
            idx = idx[~bad]
    used_c, used_t = c[idx], th[idx]
    if method == "median":
        centroid = np.median(used_c, axis=0)
        if has_theta:
            ref = _doubled_angle_mean(used_t)
            theta = float(wrap_theta_deg(ref + float(np.median(_angle_deviation(used_t, ref)))))
        else:
            theta = math.nan
    else:
        centroid = used_c.mean(axis=0)
        theta = _doubled_angle_mean(used_t) if has_theta else math.nan
    std = used_c.std(axis=0, ddof=1) if idx.size > 1 else np.array([math.nan, math.nan])
    if has_theta and idx.size > 1:
        theta_std = float(np.std(_angle_deviation(used_t, theta), ddof=1))
    else:
        theta_std = math.nan
    return PoseMeasurement(
        found=True,
        centroid_px=(float(centroid[0]), float(centroid[1])),
        theta_deg=theta,
        n_used=int(idx.size),
        n_frames=k,
        centroid_std_px=(float(std[0]), float(std[1])),
        theta_std_deg=theta_std,
        rejected=rejected,
    )
