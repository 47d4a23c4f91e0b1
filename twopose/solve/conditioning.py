"""How well-posed a trial is: the degeneracy measures every solver reports.

Batched over trials (rows) and views, with no Python loop over views or pairs of views: one
Gram matrix per trial, in blocks of rows that keep memory near 8 MB whatever N.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.arrays import F64
from twopose.camera.model import camera_centres

__all__ = ["flag_no_baseline", "pairwise_max_abs_dot", "pairwise_max_sine", "parallax_sine"]

Status = NDArray[np.str_]


def pairwise_max_sine(u: F64, valid: NDArray[np.bool_]) -> F64:
    """Largest sine of the angle between two valid unit vectors of each row (T, N, 3).

    One Gram matrix per row (``sin^2 = 1 - cos^2`` for unit vectors), in blocks of rows so
    that memory stays near 8 MB whatever N: no Python loop over the N^2 pairs.
    """
    T, N = u.shape[:2]
    best = np.zeros(T)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = u / np.linalg.norm(u, axis=-1, keepdims=True)
    clean = np.where(valid[..., None], np.nan_to_num(unit), 0.0)
    rows = max(1, 1_000_000 // max(N * N, 1))
    for start in range(0, T, rows):
        block = slice(start, start + rows)
        cos = np.einsum("tik,tjk->tij", clean[block], clean[block])
        pair = valid[block, :, None] & valid[block, None, :]
        sine2 = np.where(pair, 1.0 - np.minimum(cos * cos, 1.0), 0.0)
        best[block] = np.sqrt(sine2.reshape(sine2.shape[0], -1).max(axis=1, initial=0.0))
    return best


def pairwise_max_abs_dot(a: F64, b: F64, valid: NDArray[np.bool_]) -> F64:
    """Largest ``|a_i . b_j|`` over pairs of valid views of each row.

    The vectors are (T, N, 3); blocked like :func:`pairwise_max_sine`.
    """
    T, N = a.shape[:2]
    best = np.zeros(T)
    rows = max(1, 1_000_000 // max(N * N, 1))
    for start in range(0, T, rows):
        block = slice(start, start + rows)
        dots = np.abs(np.einsum("tik,tjk->tij", np.nan_to_num(a[block]), np.nan_to_num(b[block])))
        pair = valid[block, :, None] & valid[block, None, :]
        masked = np.where(pair, dots, 0.0)
        best[block] = masked.reshape(masked.shape[0], -1).max(axis=1, initial=0.0)
    return best


def parallax_sine(P: ArrayLike, valid: ArrayLike, point_grid: ArrayLike) -> F64:
    """The largest sine (T,) of the angle two camera centres subtend at the point.

    (T,) the largest sine of the angle two valid camera centres subtend at each trial's
    point: the baseline as seen from the target, for every method (NaN without a point).

    For a point it is the ray parallax; for a line or a ground point it says what the plane
    angles cannot: planes through (nearly) one camera centre meet, but anywhere.
    """
    p = np.asarray(P, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool)
    x = np.asarray(point_grid, dtype=np.float64)
    sine = pairwise_max_sine(camera_centres(p) - x[:, None, :], ok)
    return np.where(np.isfinite(x).all(axis=1), sine, np.nan)


def flag_no_baseline(centres: F64, ok: NDArray[np.bool_], status: Status, reason: Status) -> None:
    """Whether each trial's valid views have more than one camera centre.

    Every method, one rule: views that all share one camera centre have no baseline, so
    nothing can be triangulated from them, whatever the solver would return.
    """
    spread = np.abs(np.nan_to_num(np.where(ok[..., None], centres - centres[:, :1], 0.0)))
    scale = 1.0 + np.abs(np.nan_to_num(centres[:, :1])).max(axis=(1, 2))
    # One centre, up to the rounding of recovering it from P.
    none = (status != "no_detection") & ~(spread.max(axis=(1, 2)) > 1e-9 * scale)
    status[none] = "degenerate"
    reason[none] = "no baseline: the poses share a camera centre"
