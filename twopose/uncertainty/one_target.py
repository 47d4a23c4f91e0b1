"""Trials of one target: each trial's estimate against the others' (issue 54).

A trial's misclosure (:mod:`twopose.uncertainty.misclosure`) sees only what its own poses
can check of each other. A typed component along a direction its geometry cannot check (a
point's pose moved across its ray where the other rays follow it, a line's pose moved
within the planes the other views' planes absorb) leaves the misclosure as it was and moves
the estimate: in the simulator's geometry about one 1 in blunder in ten is such, and its
estimate lies a dozen sigmas from the truth (``benchmarks/bench_noise.py``). No test of
the trial alone can see it.

A session whose trials measured **one target** (every trial's recorded truth the same
point or line: the thesis' procedure, repeated trials of a target held still) has a
second redundancy: every trial's estimate must agree with the others'. Each trial's
estimate is tested against the weighted mean of the other trials' (their regions'
covariances, the placing sigma the session settled included): ``d^T (C_i + C_rest)^+ d``
on the region's own dimensions (3 for a point, 2 across a line or on the ground), a
chi-square test at :data:`TARGET_LEVEL` (Baarda's 0.1%: a blunder in a blind direction
moves the estimate by many sigmas, and the small level keeps a clean trial's false alarm
beside the misclosure's). The worst trial first, then again without it, while at least
two others remain to say where the target is (three trials of one target at least: with
two, a disagreement cannot say which is off). Only the equality of the recorded truths is
read, never their values: where the truths differ or are missing, nothing is tested.

Shared errors (the calibration's, the rig's constants') move every trial alike and cancel
in the difference; the regions carry them, so the test is conservative there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from twopose.arrays import F64, Bools, Ints

__all__ = ["TARGET_LEVEL", "TargetTests", "one_target", "target_tests"]

#: The test's level (Baarda's global test at 0.1%).
TARGET_LEVEL = 0.001
#: Trials whose truths differ by less than this share of the truths' size are of one target.
_SAME = 1e-9
#: The least other trials that say where the target is.
_REST_LEAST = 2


def one_target(truth: F64) -> Bools:
    """(T,) the trials that measured the session's one target.

    ``truth`` (T, 2, 3): each trial's recorded true point (twice) or line's two points, NaN
    where unknown. All the trials with a truth, when every one of them is the same; none
    otherwise (trials of different targets: no between-trial redundancy).
    """
    t = np.asarray(truth, dtype=np.float64).reshape(len(truth), -1)
    known = np.isfinite(t).all(axis=1)
    if known.sum() < _REST_LEAST + 1:
        return np.zeros(len(t), dtype=bool)
    first = t[np.argmax(known)]
    size = 1.0 + float(np.abs(first).max())
    same = bool(np.abs(t[known] - first).max() <= _SAME * size)
    return np.asarray(known if same else np.zeros(len(t), dtype=bool))


@dataclass(frozen=True, kw_only=True)
class TargetTests:
    """Per trial (T rows): its estimate against the other trials' of the same target.

    ``flagged``: it disagrees (tested and rejected); ``chi2`` on ``dof`` (0: not tested):
    its test's statistic; ``p`` its p-value (NaN: not tested); ``apart``: how far its
    estimate lies from the others' weighted mean (session units; NaN: not tested).
    """

    flagged: Bools
    chi2: F64
    dof: Ints
    p: F64
    apart: F64


def target_tests(
    point: F64, cov: F64, same: Bools, out: Bools, *, level: float = TARGET_LEVEL
) -> TargetTests:
    """Each trial of one target tested against the others (see the module).

    ``point`` (T, 3) and ``cov`` (T, 3, 3): each trial's estimate and its region's
    covariance (NaN where not solved); ``same`` (T,): the trials of the one target
    (:func:`one_target`); ``out`` (T,): trials already kept out of the rest (their poses
    disagree), never tested again here.
    """
    T = len(point)
    usable = same & np.isfinite(point).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
    chi2, dof = np.full(T, np.nan), np.zeros(T, dtype=np.int_)
    p, apart = np.full(T, np.nan), np.full(T, np.nan)
    flagged = np.zeros(T, dtype=bool)
    kept = usable & ~out
    if kept.sum() < _REST_LEAST + 1:
        return TargetTests(flagged=flagged, chi2=chi2, dof=dof, p=p, apart=apart)
    P = _across(cov[kept])
    x = np.einsum("ij,tj->ti", P, point)
    C = np.einsum("ij,tjk,lk->til", P, cov, P)
    W = np.stack([_pinv(c)[0] for c in C])  # each region's weight, once
    while kept.sum() >= _REST_LEAST + 1:
        # every kept trial's rest: the kept sums less its own (one pass a round)
        info = W[kept].sum(axis=0)
        moment = np.einsum("tij,tj->i", W[kept], x[kept])
        for i in np.flatnonzero(kept):
            chi2[i], dof[i], apart[i] = _against(x[i], C[i], info - W[i], moment - W[i] @ x[i])
        with np.errstate(invalid="ignore"):
            p = np.where(dof > 0, special.chdtrc(np.maximum(dof, 1), chi2), np.nan)
        worst = int(np.nanargmin(np.where(kept, p, np.inf)))
        if not p[worst] < level:
            break
        flagged[worst], kept[worst] = True, False
    tested = usable & ~out
    return TargetTests(
        flagged=flagged,
        chi2=np.where(tested, chi2, np.nan),
        dof=np.where(tested, dof, 0),
        p=np.where(tested, p, np.nan),
        apart=np.where(tested, apart, np.nan),
    )


def _across(cov: F64) -> F64:
    """(3, 3) the projector onto the directions the regions hold.

    A region of rank 2 (a ground point, a line's point across the line) has a direction it
    says nothing about: their mean is left out of every difference.
    """
    w, V = np.linalg.eigh(cov)  # ascending
    flat = w[:, 0] <= 1e-9 * w[:, -1]
    if not flat.any():
        return np.eye(3)
    u = V[flat, :, 0]
    u = u * np.where(u @ u[0] < 0, -1.0, 1.0)[:, None]
    n = u.mean(axis=0)
    n /= np.linalg.norm(n)
    return np.eye(3) - np.outer(n, n)


def _pinv(cov: F64) -> tuple[F64, int]:
    """The pseudo-inverse of a covariance over its range, and its rank."""
    w, V = np.linalg.eigh(cov)
    keep = w > 1e-9 * max(float(w[-1]), 1e-300)
    inv = np.where(keep, 1.0 / np.where(keep, w, 1.0), 0.0)
    return (V * inv) @ V.T, int(keep.sum())


def _against(x: F64, C: F64, info: F64, moment: F64) -> tuple[float, int, float]:
    """One estimate against the weighted mean of the others: chi-square, its dof, the distance.

    ``info`` and ``moment``: the others' summed weights and weighted estimates.
    """
    rest_cov, _ = _pinv(info)
    d = x - rest_cov @ moment
    inv, rank = _pinv(C + rest_cov)
    return float(d @ inv @ d), rank, float(np.linalg.norm(d))
