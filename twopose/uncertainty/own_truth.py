"""A trial tested against its own recorded truth (issue 54).

A session records each trial's ground-truth grid point (typed by the operator). A typed
pose's component its trial's poses cannot check of each other (a point's pose moved
across its ray where the other rays follow it) leaves the misclosure as it was and moves
the estimate: with each trial its own target, neither the misclosure nor the other trials
can see it, and its estimate lies many sigmas from its truth
(``benchmarks/bench_noise.py``). The truth sees it.

Each trial's reported point is tested against its truth in the region it reports (after
the session's placing multiplier, :func:`twopose.methods.truth.reported`): its NEES
``e^T C^+ e`` on the region's dimensions (3 for a point, 2 across a line or on the ground)
against the chi-square's upper :data:`TRUTH_LEVEL` quantile (Baarda's 0.1%). Beyond it,
one of its typed poses, the typed grid point, or the detection is off: the trial is
flagged, kept out of the session's placing multiplier pool as any flagged trial (not out of
the operator's: :func:`twopose.uncertainty.session_noise.session_statistics` says why), and
said so.

Its region is **not** widened for it: a region sized by the truth it is tested against
would cover that truth by construction. Its error stays in every error statistic (a flag
never makes the accuracy look better). A trial with no truth is not tested here; only its
misclosure and the other trials' test apply.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.propagate import nees

__all__ = ["TRUTH_LEVEL", "TruthTests", "truth_tests"]

#: The test's level (Baarda's global test at 0.1%).
TRUTH_LEVEL = 0.001
#: The error's share (squared) along one axis from which the words name that axis.
AXIS_SHARE = 0.8


@dataclass(frozen=True, kw_only=True)
class TruthTests:
    """Per trial (T rows): its reported point against its own recorded truth.

    ``flagged``: beyond the test's quantile; ``nees`` on ``dof`` (0: not tested, no truth
    or no region); ``p`` its p-value (NaN: not tested); ``off``: the distance from the
    truth (session units; NaN: not tested); ``axis``: the grid axis (0, 1, 2) holding at
    least :data:`AXIS_SHARE` of the squared error (-1: none does).
    """

    flagged: Bools
    nees: F64
    dof: Ints
    p: F64
    off: F64
    axis: Ints


def truth_tests(error: F64, cov: F64, *, level: float = TRUTH_LEVEL) -> TruthTests:
    """Each trial's reported point tested against its truth (see the module).

    ``error`` (T, 3): the reported point less its truth (NaN: no truth); ``cov`` (T, 3, 3):
    its region.
    """
    e = np.asarray(error, dtype=np.float64)
    score, dof = nees(e, np.asarray(cov, dtype=np.float64))
    tested = (dof > 0) & np.isfinite(score)
    with np.errstate(invalid="ignore"):
        p = np.where(tested, special.chdtrc(np.maximum(dof, 1), np.nan_to_num(score)), np.nan)
        off = np.where(tested, np.linalg.norm(np.nan_to_num(e), axis=1), np.nan)
        sq = np.nan_to_num(e) ** 2
        share = sq / np.maximum(sq.sum(axis=1, keepdims=True), 1e-300)
    axis = np.where(tested & (share.max(axis=1) >= AXIS_SHARE), share.argmax(axis=1), -1)
    return TruthTests(
        flagged=tested & (p < level),
        nees=np.where(tested, score, np.nan),
        dof=np.where(tested, dof, 0),
        p=p,
        off=off,
        axis=axis,
    )
