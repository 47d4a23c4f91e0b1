"""The noise model's test and what the regions took, in words: the one home of them.

sigma0's chi-square test (:class:`twopose.uncertainty.noise.VarianceFactor`) said by its own
rule, "contradict" in its upper tail, "scatter less" in its lower, "agree" otherwise on
enough degrees of freedom, with what the test could have missed; where flagged trials
turned it, both; the board's placing sigma contradicted; the multiplier taken and where
its information came from; what to do. Read by the terminal, the report (from
``summary.csv``'s row), the live result and ``check``. No I/O.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from twopose.uncertainty.noise import (
    ANCHOR_CONFLICT_LEVEL,
    FACTOR_TEST_LEVEL,
    MIN_PLACING_DOF,
    OPERATOR_DATA,
    chi2_tails,
    p_words,
)

if TYPE_CHECKING:
    from twopose.uncertainty.noise import VarianceFactor
    from twopose.values.units import Units

__all__ = ["POWER", "POWER_SAID_FROM", "describe", "noise_words", "off_truth_words"]


def noise_words(  # noqa: PLR0913
    sigma0: float,
    dof: int,
    region_widening: float = math.nan,
    factor: VarianceFactor | None = None,
    *,
    placing_scale: float = math.nan,
    placing_dof: float = math.inf,
    flagged: int = 0,
    sources: str = "",
    with_flagged: tuple[float, int] = (math.nan, 0),
    against: str = "typed",
    board_contradicted: bool = False,
    by_operator: bool = False,
    placing_share: float = 1.0,
    off_truth: int = 0,
) -> str:
    """The noise model's test and what the regions took, in words: the one home of them.

    ``sigma0`` on ``dof``: the unflagged trials' a-posteriori factor under the typed model,
    said by its own chi-square test (5%): "contradict" in its upper tail, "scatter less" in
    its lower tail, "agree" otherwise on at least :data:`MIN_PLACING_DOF` degrees of
    freedom, "too few degrees of freedom" below. Then the multiplier the regions took, with
    the degrees of freedom it rests on (``factor``'s, or ``placing_scale`` on
    ``placing_dof``), ``region_widening`` (the largest semi-axis against the typed
    placing's; NaN: not said) and the ``flagged`` trials; ``sources`` where the multiplier's
    information came from (``factor``'s when given), so that a session whose own data
    scatter less is not left to read as contradicted by the multiplier its operator's
    other sessions raised. ``with_flagged``: sigma0 on its dof with the flagged trials'
    misclosures (``factor``'s when given): where it rejects and sigma0 does not, flagging
    turned the test, and the words say both, never "agree" unqualified. ``against``: what
    sigma0 tests (``typed``, or ``the board's sigma``); ``board_contradicted``: the data
    contradicted the board's placing sigma (:attr:`NoiseModel.anchor_contradicted`), said
    loudly (``factor``'s when given), ``by_operator`` over all the operator's sessions.
    ``placing_share``: the placing's mean share of sigma0's directions (its power's words);
    ``off_truth``: trials flagged by their truth (two or more say what a rig's constants
    would do).
    """
    if factor is not None:
        placing_scale = factor.placing_scale if factor.estimated else math.nan
        placing_dof, flagged = factor.variance_dof, factor.flagged
        sources = factor.sources
        all_sq = factor.sigma0_sq_all
        with_flagged = (math.sqrt(all_sq) if factor.dof_all else math.nan, factor.dof_all)
    if factor is not None:
        against = factor.against
        board_contradicted = math.isfinite(factor.anchor_conflict)
        by_operator = f"(contradicted by the data {OPERATOR_DATA})" in factor.sources
        placing_share = factor.placing_share
    over_words = " over all this operator's sessions" if by_operator else ""
    # advice already followed is not given (a new user's r6 G2): pooled with the operator's
    # other sessions, only a board is left to measure the placing with
    advice = _BOARD if _OPERATORS_POOLED in sources else f"{_BESIDE}, or {_BOARD}"
    turned = _turned_words(sigma0, dof, flagged, *with_flagged, advice=advice)
    words = [turned or _test_words(sigma0, dof, flagged, against, placing_share)]
    if board_contradicted:
        words.append(
            f"the data contradict the board's placing sigma (F test{over_words}, p < "
            f"{ANCHOR_CONFLICT_LEVEL:g}): regions likely too small with it, so it weighs as a "
            "guess here and the trials set the placing sigma"
        )
    if math.isfinite(placing_scale) and math.isfinite(placing_dof):
        took = (
            f"placing sigma taken {placing_scale:.2g}x the one assumed, from {placing_dof:.0f} dof"
        )
        if sources:
            took += f" ({sources})"
        if factor is not None and factor.at_limit:
            took += ", at the limit of what is searched: check the typed resolution and units"
        words.append(took)
    elif dof > 0 and math.isfinite(sigma0):
        said = "not enough data to estimate the placing sigma: the regions assume the one typed"
        if chi2_tails(dof * sigma0**2, dof)[0] < FACTOR_TEST_LEVEL:  # and the test rejects it
            said += f", which the data contradict, so they are likely too small: {advice}"
        words.append(said)
    elif not (dof > 0 and math.isfinite(sigma0)) and against == "typed":
        words.append(_UNTESTED)
    if math.isfinite(region_widening) and not math.isclose(region_widening, 1.0, abs_tol=5e-3):
        words.append(f"regions' largest semi-axis x{region_widening:.2f}")
    return "; ".join(words + _flag_words(flagged, off_truth))


def _flag_words(flagged: int, off_truth: int) -> list[str]:
    """The flagged trials in words, and what two or more off their truths mean."""
    words = []
    if flagged:
        trials = "trial" if flagged == 1 else "trials"
        words.append(f"{flagged} {trials} flagged: kept out of the pool")
    if off_truth >= _OFF_TRUTH_SAID:
        words.append(off_truth_words(off_truth))
    return words


#: Trials off their truth (each 1 in 1000 by chance) from which the session says what they
#: mean: the poses agreeing among themselves is then no "ok" (a new user's r6 G10).
_OFF_TRUTH_SAID = 2


def off_truth_words(count: int, of: int = 0) -> str:
    """What ``count`` trials off their truths beyond their regions say of the session.

    A rig whose constants no rig file carries (the camera's offset from the laptop's typed
    point, its principal point) moves every pose alike: the poses still agree with each
    other (sigma0 "agree"), while their estimates miss the truths (regions covering 35%).
    ``of``: among how many trials (0: not said).
    """
    among = f" of {of}" if of else ""
    return (
        f"{count}{among} trials lie off their truths beyond their regions (by chance 1 in 1000 "
        "each): something every pose shares is off, which the poses cannot check in each "
        "other (a rig's constants: measure them with a board, `twopose-analyze rig`), or "
        "the truths or several typed poses are"
    )


#: Said where nothing tested the typed placing sigma and nothing estimated the multiplier
#: (two poses a trial and no trials of one target to compare: the thesis' own procedure).
_UNTESTED = (
    "the regions rest on the typed placing sigma, untested: if the operator places worse "
    "than typed they are too small (record three or more trials of one target, analyse the "
    "session beside its operator's others, or measure the placing with a board)"
)
#: What a session whose data contradict its regions' placing sigma can do, in words ...
_BESIDE = "analyse the session beside its operator's others"
_BOARD = "measure the placing with a board"
#: ... the first done where the multiplier's sources name the operator's other sessions
#: (:func:`twopose.uncertainty.operator_pool.operator_priors`' words).
_OPERATORS_POOLED = " of operator "


def _turned_words(
    sigma0: float, dof: int, flagged: int, sigma0_all: float, dof_all: int, *, advice: str
) -> str:
    """sigma0's test where flagging turned it ("": it did not).

    It rejects the typed model with the flagged trials' misclosures and not without them:
    the data left agree only if the flagged trials are blunders, and if they are not, the
    operator places worse than typed. Which, the session's own trials cannot always tell (a
    typo can shrink its trial's misclosure, a clean trial can be noisy): never "agree"
    unqualified.
    """
    known = dof <= 0 or math.isfinite(sigma0)
    if not (flagged and dof_all > dof and math.isfinite(sigma0_all) and known):
        return ""
    upper_all = chi2_tails(dof_all * sigma0_all**2, dof_all)[0]
    upper = chi2_tails(dof * sigma0**2, dof)[0] if dof > 0 else math.nan
    if not upper_all < FACTOR_TEST_LEVEL or upper < FACTOR_TEST_LEVEL:
        return ""
    trials = "trial" if flagged == 1 else "trials"
    said = f"{sigma0_all:.2f} on {dof_all} dof ({p_words(upper_all)}) with the flagged {trials}"
    left = "the data contradict the noise model, and no trial is left unflagged to test"
    if dof > 0:
        said = f"{sigma0:.2f} on {dof} dof ({p_words(upper)}) without the {flagged} flagged "
        said += f"{trials}, {sigma0_all:.2f} on {dof_all} dof ({p_words(upper_all)}) with "
        said += "it" if flagged == 1 else "them"
        # the data left said by the rule sigma0 alone is said by (a new user's r6 G6)
        left = f"the data left {_left_words(sigma0, dof)}, with the flagged {trials} the "
        left += "data contradict it"
    return (
        f"sigma0 {said}: {left}: if "
        f"{'it is not a blunder' if flagged == 1 else 'they are not blunders'}, the operator "
        f"places worse than typed and every region is too small: {advice}"
    )


def _left_words(sigma0: float, dof: int) -> str:
    """What the unflagged trials' sigma0 says where the flagged ones turned the test.

    Its upper tail does not reject there: "agree" only on :data:`MIN_PLACING_DOF` dof or
    more and outside the lower tail, as :func:`_test_words` says it.
    """
    if chi2_tails(dof * sigma0**2, dof)[1] < FACTOR_TEST_LEVEL:
        return "scatter less than the noise model says"
    if dof < MIN_PLACING_DOF:
        return "are too few to judge the noise model"
    return "agree with the noise model"


def _test_words(
    sigma0: float, dof: int, flagged: int = 0, against: str = "typed", share: float = 1.0
) -> str:
    """sigma0's chi-square test said: never "agree" when it rejects or cannot tell.

    ``share``: the placing's mean share of its directions (:func:`_power_words`).
    """
    if (dof <= 0 or not math.isfinite(sigma0)) and flagged:
        return "sigma0 not tested (no unflagged trial has redundant poses)"
    if dof <= 0 or not math.isfinite(sigma0):
        return "sigma0 not tested (no trial with redundant poses, or --no-sigma0)"
    upper, lower = chi2_tails(dof * sigma0**2, dof)
    head = f"sigma0 {sigma0:.2f} on {dof} dof ({p_words(upper)})"
    if upper < FACTOR_TEST_LEVEL:
        return f"{head}: the data contradict the noise model (they scatter more than {against})"
    if lower < FACTOR_TEST_LEVEL:
        return f"{head}: the data scatter less than the noise model says{_LESS_WHY}"
    if dof < MIN_PLACING_DOF:
        return f"{head}: too few degrees of freedom to judge the noise model"
    return f"{head}: the data agree with the noise model{_power_words(dof, share)}"


#: Why data scatter less, said beside it: besides an operator who places better than typed,
#: the one-camera detector floor is a bound (the glove's about twice its measured RMS, so
#: method 2's and the line's misclosures average about 0.55 of their dof typed right: a new
#: user's r6 G9), so "less" there says the regions may be wide, never that they are small.
_LESS_WHY = (
    " (the operator places better than typed, or the detector's floor, a bound on one "
    "camera, is wider than its error: regions may be wider than needed)"
)


#: The test's power said: the placing sigma (over the one assumed) it detects this often.
POWER = 0.8
#: Below this sigma ratio detected at :data:`POWER`, "agree" needs no qualifier.
POWER_SAID_FROM = 1.25


def _power_words(dof: int, share: float = 1.0) -> str:
    """What a test that did not reject could have missed, in words ("" where it is small).

    The placing sigma, over the one assumed, that sigma0's test at 5% on ``dof`` detects
    only :data:`POWER` of the time, said where it is :data:`POWER_SAID_FROM` or more. Each
    of its directions has the variance ``1 + (r^2 - 1) beta`` at a placing sigma ``r``
    times the one assumed, ``beta`` the placing's share of it; at their mean ``share``
    the statistic is that times a chi-square on ``dof``, so ``r^2 = 1 + (q95 / q20 - 1) /
    share``. All placing (``share`` 1) it is ``sqrt(q95 / q20)``; a line's or the finger's
    misclosure, mostly the pixels' noise, tells far less (said as the 1.8x of all placing
    on 8 dof, it caught a 1.6x operator's line sessions 0 times in 20: a new user's r6
    G7). "Agree" on a small session's few dof is what the test says, not that the operator
    places as typed.
    """
    from scipy import special

    q = float(special.chdtri(dof, FACTOR_TEST_LEVEL)) / float(special.chdtri(dof, POWER))
    share = min(share, 1.0) if math.isfinite(share) else 1.0
    if share < _SEES_PLACING:
        return f" (on {dof} dof, the pixels' noise nearly all of it: it barely sees the placing)"
    ratio = math.sqrt(1.0 + (q - 1.0) / share)
    if ratio < POWER_SAID_FROM:
        return ""
    return (
        f" (on {dof} dof it tells a placing sigma {ratio:.1f}x the one assumed only "
        f"{POWER:.0%} of the time)"
    )


#: A test whose directions hold less placing than this share (mean) barely sees it.
_SEES_PLACING = 0.02


def describe(factor: VarianceFactor, placing: float = math.nan, units: Units | None = None) -> str:
    """A session's factor in words: its test and the multiplier applied (:func:`noise_words`).

    ``placing``: the placing sigma the regions start from, in ``units``.
    """
    s0 = math.sqrt(factor.sigma0_sq) if factor.tested else math.nan
    said = noise_words(s0, factor.dof, math.nan, factor)
    if math.isfinite(placing) and units is not None and factor.estimated:
        assumed = placing * factor.placing_scale
        said += f"; the regions assume a placing sigma of {assumed:.2g} {units}"
    return said
