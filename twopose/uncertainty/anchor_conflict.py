"""The prior-data conflict test of a board's placing sigma (issue 54).

A board's measured ``[placing]`` anchors the placing variance's multiplier on its own
degrees of freedom (:meth:`twopose.uncertainty.noise.NoiseModel.anchor`); where the
operator's trials contradict it (Fisher's F of their sigma0 squared against the board's
1, on both dofs, below :data:`~twopose.uncertainty.noise.ANCHOR_CONFLICT_LEVEL`) it is not
this operator's hand and weighs as a guess: the trials set the placing sigma.

**One answer per operator, before the flags.** An operator's sessions pool as one hand
(:func:`~twopose.uncertainty.operator_pool.operator_priors`), so the board is tested
once over all of them (every trial of the operator's sessions of one method under one rig
file in the run, or of the recorder's noise file) and every session gets that answer
(:attr:`~twopose.uncertainty.noise.PlacingPrior.anchor_p`, carried by its prior) before
any of its trials is flagged. Tested per session on the trials left unflagged, a board
sigma too small for its operator (0.11 in where the hand is 0.16) made clean trials look
like blunders against it; flagged first, they were left out of the test that would have
rejected the board, which was kept in 3 of one operator's 4 sessions, clean trials named
typos, and 9 of those sessions' 12 trials inside their regions (a new user's r5 F2a).
Over the operator's pooled trials the trials the test leaves out are those that disagree
with the *other trials*, not with the board: Baarda's test of
:func:`~twopose.uncertainty.robust_flags.flag_trials` with the board weighed as the
typed word is (:func:`as_guess`), so each trial's rest is the others' multiplier. A 1 in
blunder disagrees with the other trials whatever the board says and is left out (it must
not make a board the clean trials agree with give way), while a clean trial of a hand the
board understates agrees with the others and stays in the test that can reject the board.
Where about half an operator's trials are blunders, the trials alone cannot tell them
apart and a right board may give way (the trials then set the placing sigma).

**A session alone** (no other session of its operator in the run or in the noise file)
cannot tell a blunder from a board too small: with two trials, one 60 on 3 dof beside one
of 6, the trials' own test cannot flag the blunder, which then made a good board give
way and went unflagged (half of such blunders in the same draws). Its board is tested on
its trials the board leaves unflagged, the operator's prior added as data
(:func:`alone_checked`), as before: analyse it beside its operator's others.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from twopose.uncertainty.noise import (
    ANCHOR_CONFLICT_LEVEL,
    MIN_PLACING_DOF,
    TYPED_PRIOR_DOF,
    NoiseModel,
    PlacingPrior,
)

if TYPE_CHECKING:
    from twopose.arrays import F64, Bools, Ints
    from twopose.uncertainty.misclosure import Misclosure

__all__ = [
    "alone_checked",
    "as_guess",
    "conflict_p",
    "group_anchor",
    "operator_decided",
]


def conflict_p(
    chi2: F64, dof: Ints, use: Bools, anchor: PlacingPrior, prior: PlacingPrior | None = None
) -> float:
    """Fisher's F p-value of the trials ``use`` keeps against ``anchor`` (NaN: none).

    Their sigma0 squared (``prior``, the operator's other sessions, added as data:
    ``(sum chi2 + s0 F) / (dof + F)`` on ``dof + F``) against the board's 1 on its own
    degrees of freedom. NaN where the anchor is exact (typed or stated) or fewer than
    :data:`MIN_PLACING_DOF` degrees of freedom test it.
    """
    from scipy import special

    if not math.isfinite(anchor.dof):
        return math.nan
    use = use & (dof > 0) & np.isfinite(chi2)
    total, n = float(chi2[use].sum()), float(dof[use].sum())
    if prior is not None and math.isfinite(prior.dof):
        total, n = total + prior.scale * prior.dof, n + prior.dof
    if n < MIN_PLACING_DOF:
        return math.nan
    return float(special.fdtrc(n, anchor.dof, total / n))


def as_guess(anchor: PlacingPrior) -> PlacingPrior:
    """The board weighed as the typed word is: the trials' own multiplier decides."""
    return PlacingPrior(scale=1.0, dof=TYPED_PRIOR_DOF, source=f"{anchor.source} as a guess")


def operator_decided(noise: NoiseModel) -> NoiseModel:
    """``noise`` with its operator's pooled sessions' answer, where it rejects the board.

    :attr:`PlacingPrior.anchor_p`: the board kept or not, for every session of the operator
    alike; unchanged where its prior carries none or the test did not reject.
    """
    prior = noise.prior
    p = math.nan if prior is None else prior.anchor_p
    if not (_tested(noise) and p < ANCHOR_CONFLICT_LEVEL):
        return noise
    return dataclasses.replace(noise, anchor_contradicted=p)


def alone_checked(noise: NoiseModel, m: Misclosure, flagged: Bools) -> NoiseModel:
    """``noise`` with its board contradicted by a session with no operator's answer.

    Its trials not ``flagged`` (against the board: one session's trials cannot
    tell a blunder from a board too small for its operator, and a blunder wrongly kept in
    the test makes a good board give way and goes unflagged), its operator's prior from
    the noise file added as data. Unchanged where the operator's sessions answered
    (:func:`operator_decided`), nothing was measured, or nothing contradicts it.
    """
    prior = noise.prior
    if not _tested(noise) or (prior is not None and math.isfinite(prior.anchor_p)):
        return noise
    p = conflict_p(m.chi2, m.dof, ~flagged, noise.anchor(), prior)
    if not p < ANCHOR_CONFLICT_LEVEL:
        return noise
    return dataclasses.replace(noise, anchor_contradicted=p)


def _tested(noise: NoiseModel) -> bool:
    """Whether ``noise`` holds a board's measured placing sigma (on finite dof) to test."""
    placing = noise.placing
    return placing is not None and not placing.upper_bound and math.isfinite(placing.dof)


def group_anchor(
    chi2: F64, dof: Ints, flagged: Bools, anchor: PlacingPrior
) -> tuple[PlacingPrior, float]:
    """The anchor an operator's pooled trials pool under, and the board's test over them.

    ``chi2``, ``dof`` (T,): every trial of the operator's sessions; ``flagged``: those the
    trials' own multiplier flags (the board weighed as a guess, :func:`as_guess`: see the
    module). ``anchor`` itself where it holds (or nothing tests it: p NaN), else the board
    as a guess, said "contradicted by the data": the operator's priors are then the
    trials', not the board's.
    """
    p = conflict_p(chi2, dof, ~flagged, anchor)
    if not p < ANCHOR_CONFLICT_LEVEL:
        return anchor, p
    source = f"{anchor.source} (contradicted by the data)"
    return PlacingPrior(scale=1.0, dof=TYPED_PRIOR_DOF, source=source), p
