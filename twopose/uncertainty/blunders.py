"""A trial whose poses disagree, and which of them, where its redundancy can tell (issue 54).

A trial is **flagged** when its misclosure rejects both the typed model and the model the
rest of its session (and the operator's prior) measures (Baarda's global test at 0.5%,
:func:`twopose.uncertainty.robust_flags.flag_trials`). Then each typed translation component of
each pose is tested alone (Baarda's w-test, :func:`twopose.uncertainty.misclosure.pose_tests`): the
share of the misclosure an error in that one component explains, and how large it would
be. A pose **explains** the trial when, its best component corrected, what is left of
the chi-square no longer rejects (5%, on one degree of freedom fewer). The pose is
**named** only when it alone explains the trial: with three poses a point's misclosure
has three degrees of freedom, and a mistyped component of any pose can usually be made to
fit it (the trial can be flagged, its pose not named: "typed x of one of them looks about
1 in off"); a fourth pose leaves one pose alone able to explain it. The component is said
when every explaining pose's best is the same one (none, when no pose explains it).

A flagged trial is kept out of the pool; its own region is widened by its own misfit, its
chi-square over its degrees of freedom (at least 1), with Fisher's F on them
(:attr:`TrialTests.own`).

A trial of a session whose trials measured one target is flagged too when its estimate
lies off the others' (below: trials of one target): a typed value its own poses
cannot check (:attr:`TrialTests.apart`, its own words); and when its reported point lies
far outside its own region from the grid point typed as its truth
(below: a trial against its own truth, :attr:`TrialTests.truth_off`): kept out of the pool,
its region not widened. :meth:`TrialTests.by` says which test flagged it.

**Trials of one target, against each other.**

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

**A trial against its own recorded truth.**

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

The three tests are one concern (what flags a trial, and why), so they share one module.
(Near 600 lines for that reason: which pose and component explain a flagged trial, and the
words each test says, read the same fields; split, they would import each other's privates,
as :mod:`twopose.uncertainty.target_scatter` already reads ``_across``.)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import special

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.misclosure import Misclosure, pose_tests
from twopose.uncertainty.propagate import nees
from twopose.values.units import Units

__all__ = [
    "AXES",
    "EXPLAINS_LEVEL",
    "FLAGGED_BY",
    "NAMED_FROM_POSES",
    "TARGET_LEVEL",
    "TRUTH_LEVEL",
    "TargetTests",
    "TrialTests",
    "TruthTests",
    "far_from_truth",
    "one_target",
    "scored_truth_tests",
    "target_tests",
    "trial_tests",
    "truth_tests",
]


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
    W = np.zeros_like(C)  # each region's weight, once; none for a trial not solved (NaN)
    for i in np.flatnonzero(usable):
        W[i] = _pinv(C[i])[0]
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
    return scored_truth_tests(e, score, dof, level=level)


def scored_truth_tests(
    error: F64, score: F64, dof: Ints, *, level: float = TRUTH_LEVEL
) -> TruthTests:
    """:func:`truth_tests` of errors whose NEES ``score`` (T,) on ``dof`` (T,) is known."""
    e = np.asarray(error, dtype=np.float64)
    score = np.asarray(score, dtype=np.float64)
    dof = np.asarray(dof, dtype=np.int_)
    tested = (dof > 0) & np.isfinite(score) & np.isfinite(e).all(axis=1)
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


#: The typed translation's components, as the words say them.
AXES = ("x", "y", "z")
#: What is left of a flagged trial's chi-square once one pose's component is corrected
#: no longer rejects at this level: that pose explains the trial.
EXPLAINS_LEVEL = 0.05
#: Which test flagged a trial, as the analysis says it (trials.csv's ``flagged_by``).
FLAGGED_BY = ("misclosure", "other trials", "truth")


@dataclass(frozen=True, kw_only=True)
class TrialTests:
    """Per trial (T rows): whether its poses disagree, and which pose, if it can tell.

    ``flagged``; ``p``: its misclosure's p-value against the rest of the session (the
    typed model's where the rest says too little; NaN: no redundancy); ``pose``: the pose
    named (1-based; 0: none); ``axis``: the typed component that looks off (``""``: not
    said); ``offset``: by how much the named pose's component is off, typed minus where
    the laptop stood (session units; NaN: no pose named); ``spread`` (T, 2): the least and the most
    that the poses explaining it would be off (their sizes differ with their leverage);
    ``explaining``: how many poses alone explain it; ``own``: the flagged
    trial's own variance multiplier (1 else), ``own_dof`` the dof its F quantile takes;
    ``apart``: a trial flagged because its estimate disagrees with the session's other
    trials of the same target (:mod:`twopose.uncertainty.blunders`), how far from theirs
    (session units; NaN else); ``truth_off``: a trial flagged because its reported point
    lies far outside its region from its own recorded truth
    (:mod:`twopose.uncertainty.blunders`), how far (session units; NaN else), with
    ``truth_sigmas`` (the NEES' square root) and ``truth_axis`` (the grid axis holding
    most of that error, -1: none).
    """

    flagged: Bools
    p: F64
    pose: Ints
    axis: NDArray[np.str_]
    offset: F64
    spread: F64
    explaining: Ints
    own: F64
    own_dof: Ints
    apart: F64 | None = None
    truth_off: F64 | None = None
    truth_sigmas: F64 | None = None
    truth_axis: Ints | None = None

    @classmethod
    def none(cls, T: int) -> TrialTests:
        """No trial tested."""
        return cls(
            flagged=np.zeros(T, dtype=bool),
            p=np.full(T, np.nan),
            pose=np.zeros(T, dtype=np.int_),
            axis=np.full(T, "", dtype="<U1"),
            offset=np.full(T, np.nan),
            spread=np.full((T, 2), np.nan),
            explaining=np.zeros(T, dtype=np.int_),
            own=np.ones(T),
            own_dof=np.zeros(T, dtype=np.int_),
            apart=np.full(T, np.nan),
        )

    def by(self, i: int) -> str:
        """Which test flagged trial ``i`` (:data:`FLAGGED_BY`; "" when not flagged)."""
        if not self.flagged[i]:
            return ""
        if self.apart is not None and np.isfinite(self.apart[i]):
            return FLAGGED_BY[1]
        if self.truth_off is not None and np.isfinite(self.truth_off[i]):
            return FLAGGED_BY[2]
        return FLAGGED_BY[0]

    def with_truth(self, truth: TruthTests) -> TrialTests:
        """These tests with the trials far off their own recorded truth flagged too.

        ``truth``: :func:`twopose.uncertainty.blunders.truth_tests`. Their regions are not
        widened (``own`` stays 1: a region sized by its truth would cover it by
        construction); they are kept out of the session's pool as any flagged trial.
        """
        new = truth.flagged & ~self.flagged
        if not new.any():
            return self
        T = len(new)
        off = np.full(T, np.nan) if self.truth_off is None else self.truth_off.copy()
        sig = np.full(T, np.nan) if self.truth_sigmas is None else self.truth_sigmas.copy()
        axis = np.full(T, -1, dtype=np.int_) if self.truth_axis is None else self.truth_axis.copy()
        off[new], sig[new], axis[new] = truth.off[new], np.sqrt(truth.nees[new]), truth.axis[new]
        return dataclasses.replace(
            self, flagged=self.flagged | new, truth_off=off, truth_sigmas=sig, truth_axis=axis
        )

    def with_target(self, target: TargetTests) -> TrialTests:
        """These tests with the trials whose estimate disagrees with the others' flagged too.

        ``target``: :func:`twopose.uncertainty.blunders.target_tests`; a trial it flags is
        widened by its own misfit there (its chi-square over its dimensions, F on them).
        """
        new = target.flagged & ~self.flagged
        if not new.any():
            return self
        apart = np.full(len(new), np.nan) if self.apart is None else self.apart.copy()
        apart[new] = target.apart[new]
        own = np.where(new, np.maximum(target.chi2 / np.maximum(target.dof, 1), 1.0), self.own)
        return dataclasses.replace(
            self,
            flagged=self.flagged | new,
            own=own,
            own_dof=np.where(new, target.dof, self.own_dof),
            apart=apart,
        )

    def words(self, i: int, units: Units, poses: int) -> str:
        """Trial ``i``'s disagreement in the operator's words ("" when not flagged).

        ``poses``: how many it has (what to add to name the pose).
        """
        if not self.flagged[i]:
            return ""
        if self.by(i) == FLAGGED_BY[2]:
            return self._truth_words(i, units)
        if self.apart is not None and np.isfinite(self.apart[i]):
            # Two poses cannot check each other; three or more did and agreed (a new
            # user's r8 F5: "cannot" was said of three-pose trials too).
            check = "its poses cannot check each other" if poses < 3 else "its poses agree"
            return (
                "this trial's estimate lies about "
                f"{_about(float(self.apart[i]))} {units} from the session's other trials of "
                f"the same target, where {check}: check what you typed for its poses"
            )
        low, high = self.spread[i]
        size = " looks off"
        if np.isfinite(low) and _about(low) == _about(high):
            size = f" looks about {_about(low)} {units} off"
        elif np.isfinite(low):
            size = f" looks about {_about(low)} to {_about(high)} {units} off"
        axis = str(self.axis[i])
        if self.pose[i]:
            pose = int(self.pose[i])
            what = f"typed {axis} of pose {pose}" if axis else f"pose {pose}'s typed position"
            return (
                f"this trial's poses disagree ({what}{size}): check what you typed for pose {pose}"
            )
        if not self.explaining[i]:
            return (
                "this trial's poses disagree (no single typed value explains it): check what "
                "you typed, and that the target did not move"
            )
        more = "a fourth pose" if poses <= 3 else "another pose"
        if not axis:
            # the poses that explain it each by another component: their sizes are of
            # different things, from 1 to 1000 times the slip (a new user's ground trials,
            # 1 in off, read "about 1 to 1062 in"): no size is said
            return (
                "this trial's poses disagree (one typed value looks off, but which, and by how "
                f"much, {poses} poses cannot tell): check what you typed, or add {more}"
            )
        return (
            f"this trial's poses disagree (typed {axis} of one of them{size}): check what you "
            f"typed, or add {more}"
        )

    def _truth_words(self, i: int, units: Units) -> str:
        """A trial far off its own recorded truth, in words (:meth:`words`)."""
        off = np.full(len(self.flagged), np.nan) if self.truth_off is None else self.truth_off
        sigmas = self.truth_sigmas if self.truth_sigmas is not None else off
        axis = -1 if self.truth_axis is None else int(self.truth_axis[i])
        return far_from_truth(float(off[i]), float(sigmas[i]), axis, units)


def far_from_truth(
    off: float, sigmas: float, axis: int, units: Units, *, noun: str = "trial",
    causes: str = "one of its typed poses, the grid point, or the detection is off: check "
    "what you typed",
) -> str:  # fmt: skip
    """A row ``off`` from its truth (``sigmas``, mostly along ``axis``; -1: none) in words."""
    along = f", mostly in {AXES[axis]}" if axis >= 0 else ""
    return (
        f"this {noun}'s estimate lies {off:.3g} {units} ({sigmas:.0f} sigma){along} from "
        f"the grid point typed as its truth: {causes}"
    )


def _about(value: float) -> str:
    """A length as the words round it: one significant digit (about 0.3 in), whole from 10 on.

    (About 16 in, never "2e+01".)
    """
    return f"{abs(value):.1g}" if abs(value) < 9.5 else f"{abs(value):.0f}"


def trial_tests(m: Misclosure, flagged: Bools, p: F64, lam: float) -> TrialTests:
    """The flagged trials' poses tested one by one (see the module).

    ``lam``: the session's placing variance multiplier.
    """
    T = len(m.chi2)
    out = TrialTests.none(T)
    out_p = np.where(np.isfinite(p), p, np.nan)
    rows = np.flatnonzero(flagged & (m.dof > 0))
    if not rows.size:
        return TrialTests(**{**out.__dict__, "p": out_p})
    mine = m.rows(rows)
    tests = pose_tests(mine, lam)
    d = 1.0 + (lam - 1.0) * mine.placing_share
    chi2 = (mine.z2 / np.where(d > 0, d, np.inf)).sum(axis=1)  # under the session's lambda
    dof = mine.dof
    # each pose's best component: of those that alone explain the misclosure, the one
    # needing the smallest error (a typo of 1 in over one of 51 in along the camera's axis
    # that explains it as well: a new user's r6 G12), else the one explaining the most
    each = _explaining(chi2[:, None, None], tests.w2, dof[:, None, None]) & (tests.w2 > 0)
    size = np.where(each, np.abs(np.nan_to_num(tests.offset, nan=np.inf)), np.inf)
    best_c = np.where(each.any(axis=2), np.argmin(size, axis=2), np.argmax(tests.w2, axis=2))
    best_w2 = np.take_along_axis(tests.w2, best_c[..., None], axis=2)[..., 0]
    explains = np.take_along_axis(each, best_c[..., None], axis=2)[..., 0]
    count = explains.sum(axis=1)
    # the best of the poses that explain it (of all, when none does)
    score = np.where((count > 0)[:, None], np.where(explains, best_w2, -1.0), best_w2)
    top = np.argmax(score, axis=1)
    R = len(rows)
    top_c = best_c[np.arange(R), top]
    same = np.array([(best_c[r][explains[r]] == top_c[r]).all() for r in range(R)])
    # named from a fourth pose on (issue 54 item 6): from three, one pose alone explaining
    # it is what the placing's noise makes as often as a typo (a new user's r6 G14: a clean
    # first trial's best-typed pose named), and a typo's pose ranks first in 68% of cases
    poses = (np.abs(mine.bias).sum(axis=(2, 3)) > 0).sum(axis=1)
    pose = np.where((count == 1) & (poses >= NAMED_FROM_POSES), top + 1, 0)
    # said only where a pose explains it (all() of none is True: a trial nothing explains
    # named the best component of all beside "no single typed value explains it": r5 F5)
    axis = np.where((count > 0) & same, np.array(AXES)[top_c], "")
    offset = tests.offset[np.arange(R), top, top_c]
    sizes = np.abs(np.take_along_axis(tests.offset, best_c[..., None], axis=2)[..., 0])
    among = np.where((count > 0)[:, None], explains, np.arange(sizes.shape[1]) == top[:, None])
    low = np.where(among, sizes, np.inf).min(axis=1)
    high = np.where(among, sizes, -np.inf).max(axis=1)
    own = np.maximum(chi2 / np.maximum(dof, 1), 1.0)
    return TrialTests(
        flagged=out.flagged | flagged,
        p=out_p,
        pose=_put(out.pose, rows, pose),
        axis=_put(out.axis, rows, axis.astype("<U1")),
        offset=_put(out.offset, rows, np.where(pose > 0, offset, np.nan)),
        spread=_put(out.spread, rows, np.stack([low, high], axis=1)),
        explaining=_put(out.explaining, rows, count),
        own=_put(out.own, rows, own),
        own_dof=_put(out.own_dof, rows, dof),
        apart=out.apart,
    )


#: A flagged trial's pose is named from this many poses on (with fewer, "one of them").
NAMED_FROM_POSES = 4


def _explaining(chi2: F64, w2: F64, dof: Ints) -> Bools:
    """Whether one component's error alone explains the misclosure.

    What it leaves of ``chi2`` (its ``w2`` taken: chi-square on ``dof - 1``) is no more
    than noise (:data:`EXPLAINS_LEVEL`).
    """
    left = np.clip(chi2 - w2, 0.0, None)
    fewer = np.broadcast_to(np.maximum(dof - 1, 0), left.shape)
    closed = left < 1e-6 * (1.0 + chi2)  # one dof: all or none
    with np.errstate(invalid="ignore"):
        p_left = np.where(fewer > 0, special.chdtrc(np.maximum(fewer, 1), left), closed)
    return np.asarray(p_left >= EXPLAINS_LEVEL)


def _put(base: NDArray[Any], rows: Ints, values: NDArray[Any]) -> NDArray[Any]:
    out = base.copy()
    out[rows] = values
    return out
