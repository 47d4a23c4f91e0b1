"""The noise a trial's 95% region assumes, defined once (issues 46, 54).

Every region (the analysis' ``trials.csv``, the recorder's live result, guidance's
predictions) propagates three inputs (:mod:`twopose.uncertainty.propagate`): each pose's frame
scatter, the calibration's 1-sigma and the operator's **placing error**, the 1-sigma of each
typed translation component. That last one dominates a trial's region, and it is the one
nobody measured: it was the resolution the operator typed. Here it is

* :class:`PlacingSigma`: the placing error, typed (each pose's recorded resolution) or
  **measured** by a board session (:func:`twopose.rig.board.fit_board_rig`), with its own
  1-sigma and where it came from;
* :class:`PlacingPrior`: what is known of the placing variance's multiplier ``lambda``
  before a session's own trials (the typed resolution's weak word, a board's measurement,
  the same operator's other sessions), a scaled inverse chi-square;
* :class:`VarianceFactor`: the session's noise as its trials' misclosures
  (:mod:`twopose.uncertainty.misclosure`) and the prior settle it
  (:mod:`twopose.uncertainty.placing_variance`):
  sigma0, the a-posteriori variance factor of photogrammetry under the typed model, with
  its chi-square test; the multiplier ``lambda`` every region is propagated with (always
  estimated, never a pretest) and the degrees of freedom it rests on (the regions' Fisher
  F); the trials flagged (their poses disagree);
* :func:`noise_words`: the one place a test is said in words, so that the words never say
  more than the numbers: "agree" only when sigma0's own chi-square test does not reject on
  enough degrees of freedom, "contradict" only when it rejects, "scatter less" only in its
  lower tail;
* :class:`NoiseModel`: all of it as the estimation's options carry it
  (:attr:`twopose.solve.margins.EstimateOptions.noise`).

Light: the command lines read it; NumPy and SciPy are imported where a number is computed.

(Near 600 lines: the noise's types and the one home of their words are read together by
every side; split, the words would import the types' privates.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from twopose.rig.covariance import RigCovariance
    from twopose.values.units import Units

__all__ = [
    "ANCHOR_CONFLICT_LEVEL",
    "FACTOR_TEST_LEVEL",
    "MIN_PLACING_DOF",
    "TYPED_PRIOR_DOF",
    "NoiseModel",
    "PlacingPrior",
    "PlacingSigma",
    "VarianceFactor",
    "noise_words",
    "p_words",
    "region_quantile",
]

#: The variance factor's test: the model is contradicted when ``dof * sigma0^2`` lies in
#: the chi-square's upper 5% tail (and the data scatter less in its lower 5% tail).
FACTOR_TEST_LEVEL = 0.05
#: The least degrees of freedom an estimate of the placing variance may rest on (a board's
#: measured sigma, a session's multiplier beyond its anchor), and the least on which
#: sigma0's test may say the data agree: below, its F quantile explodes and its test
#: cannot tell.
MIN_PLACING_DOF = 3
#: The typed resolution's weight as a prior: a scaled inverse chi-square at 1 on this many
#: degrees of freedom (what an operator's word is worth against their data: weak).
TYPED_PRIOR_DOF = 2.0
#: The typed resolution's weight once the operator's own sessions measured what it guesses
#: (an operator's prior, :attr:`NoiseModel.prior`): next to none. Multiplied in on
#: :data:`TYPED_PRIOR_DOF` beside them, it pulled the multiplier of an operator who places
#: worse than typed toward 1 by about ``2 / (F + 2 + n)`` of the difference: 6.5% at 3x
#: typed over 20 sessions of two method-2 trials (their regions covered 92.5%, 94.4%
#: without; benchmarks/bench_noise.py). Not zero: a prior's dof must be positive.
SUPERSEDED_PRIOR_DOF = 1e-6
#: A board's placing sigma gives way where the data contradict it this strongly (Fisher's F
#: on both dofs): 1%, as a board wrongly kept makes regions too small, one wrongly dropped
#: only lets the trials decide (r5 F2's sessions, 1.5x the board's, stood at p = 0.001-0.002).
ANCHOR_CONFLICT_LEVEL = 0.01
#: How a board contradicted by its operator's pooled sessions is named, not by one session's.
OPERATOR_DATA = "of its operator's sessions"
#: The regions' level.
_REGION_LEVEL = 0.95
#: Beyond this many degrees of freedom a placing sigma's own uncertainty is not said as a
#: count (a hand-edited sigma_sigma can state millions): it is negligible.
_SAID_DOF = 1000


def _inches_per(units: Units) -> float:
    from twopose.values.units import unit_spec

    return unit_spec(units).inches


@dataclass(frozen=True, kw_only=True)
class PlacingSigma:
    """The operator's placing error: the 1-sigma of each typed translation component.

    In inches (converted per session); ``sigma_sigma_in`` is the estimate's own 1-sigma
    (NaN: not measured, taken as exact); ``measured_by`` names the board session(s) that
    measured it, over ``captures`` captures. ``upper_bound``: the captures showed no placing
    error their corners resolve (the fit's floor), and ``sigma_in`` is only the most it can
    be (no 1-sigma; never said "measured"; never what a region assumes: a bound says nothing
    of how small the error is, so the regions start from each pose's typed resolution, as
    without a board, and the sessions' own trials estimate the multiplier).
    """

    sigma_in: float
    sigma_sigma_in: float = math.nan
    measured_by: str = ""
    captures: int = 0
    upper_bound: bool = False
    #: Whose placing it is: the board sessions' operators (empty: not recorded, a rig file
    #: from before they were: applied to every operator's sessions, and said).
    operators: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """Refuse a placing sigma that is not a positive finite length."""
        from twopose.errors import InputValueError

        if not (math.isfinite(self.sigma_in) and self.sigma_in > 0):
            raise InputValueError(
                f"the placing sigma must be a positive length, got {self.sigma_in!r}; "
                "measure it again with `twopose-analyze rig` on a board session"
            )
        if self.upper_bound and math.isfinite(self.sigma_sigma_in):
            raise InputValueError(
                "an upper bound of the placing sigma has no 1-sigma (sigma_sigma): it bounds "
                "an error the captures did not resolve"
            )
        if math.isfinite(self.sigma_sigma_in) and self.dof < MIN_PLACING_DOF:
            raise InputValueError(
                f"the placing sigma {self.sigma_in:.3g} in is stated with a 1-sigma of "
                f"{self.sigma_sigma_in:.3g} in: an estimate from {self.dof:.2g} degrees of "
                f"freedom (fewer than {MIN_PLACING_DOF}), which says almost nothing; record a "
                "board session of more captures (docs/rig.md) and fit it again"
            )

    @property
    def dof(self) -> float:
        """The degrees of freedom the estimate is from, ``(sigma / sigma_sigma)^2 / 2``.

        (A variance from ``dof`` degrees of freedom has a relative 1-sigma of
        ``sqrt(2 / dof)``, its square root half that); infinite when no 1-sigma is stated.
        """
        if not (math.isfinite(self.sigma_sigma_in) and self.sigma_sigma_in > 0):
            return math.inf
        return 0.5 * (self.sigma_in / self.sigma_sigma_in) ** 2

    def sigma(self, units: Units) -> float:
        """The placing sigma, in ``units``: the regions start from it.

        Its own uncertainty is the anchor's degrees of freedom (:meth:`NoiseModel.anchor`).
        """
        return self.sigma_in / _inches_per(units)

    def describe(self, units: Units) -> str:
        """Which placing sigma a run used and where it came from, in words."""
        inches = _inches_per(units)
        value = f"{self.sigma_in / inches:.3g}"
        if self.upper_bound:
            captures = f"{self.captures} " if self.captures else ""
            who = self.measured_by or "the board session"
            return (
                f"placing sigma at most {value} {units}, an upper bound, not a measurement "
                f"({who}: its {captures}captures show no placing error their corners "
                "resolve); regions start from each pose's typed resolution, never from the "
                "bound"
            )
        if math.isfinite(self.sigma_sigma_in):
            value += f" ± {self.sigma_sigma_in / inches:.2g}"
        where = f"measured by {self.measured_by}" if self.measured_by else "given"
        if self.captures:
            where += f" ({self.captures} captures)"
        said = f"placing sigma {value} {units}, {where}"
        if math.isfinite(self.dof) and self.dof > _SAID_DOF:  # never "11057153" of them
            said += f"; over {_SAID_DOF} degrees of freedom: its own uncertainty negligible"
        elif math.isfinite(self.dof):
            said += f"; {self.dof:.0f} degrees of freedom, which the sessions' own add to"
        return said


def typed_placing(resolutions: list[float], units: Units) -> str:
    """The typed placing sigma in words (each pose's recorded resolution)."""
    if not resolutions:
        return "placing sigma: typed (no pose recorded)"
    low, high = min(resolutions), max(resolutions)
    value = f"{low:.3g}" if math.isclose(low, high) else f"{low:.3g} to {high:.3g}"
    return f"placing sigma {value} {units}, typed (the poses' recorded resolution)"


def region_quantile(k: int, dof: float = math.inf) -> float:
    """The 95% region's squared radius, in sigmas, for ``k`` dimensions.

    With the covariance known (``dof`` infinite): the chi-square's 95% quantile on ``k``
    degrees of freedom. With it scaled by a variance factor estimated from ``dof`` degrees
    of freedom: ``k F(k, dof)``, Fisher's F, wider, and the chi-square's limit as ``dof``
    grows.
    """
    if not math.isfinite(dof):
        return chi2_quantile(_REGION_LEVEL, k)
    return k * f_quantile(_REGION_LEVEL, k, dof)


# The distributions' quantiles from scipy.special's functions, not scipy.stats' objects:
# the same values, and scipy.stats costs a re-run 0.7 s to import (issue 47's budget).
def chi2_quantile(level: float, dof: float) -> float:
    """The chi-square's ``level`` quantile on ``dof`` degrees of freedom."""
    from scipy import special

    return float(special.chdtri(dof, 1.0 - level))


def f_quantile(level: float, dof_num: float, dof_den: float) -> float:
    """Fisher's F's ``level`` quantile on ``dof_num`` and ``dof_den`` degrees of freedom."""
    from scipy import special

    return float(special.fdtri(dof_num, dof_den, level))


def chi2_tails(chi2: float, dof: float) -> tuple[float, float]:
    """``chi2``'s upper and lower tail probabilities on ``dof`` degrees of freedom."""
    from scipy import special

    return float(special.chdtrc(dof, chi2)), float(special.chdtr(dof, chi2))


def p_words(p: float) -> str:
    """A p-value as the words print it: ``p = 0.17``, ``p = 0.003``, ``p < 0.001``."""
    if not math.isfinite(p):
        return "p -"
    if p < 0.001:
        return "p < 0.001"
    return f"p = {p:.2g}" if p < 0.1 else f"p = {p:.2f}"


@dataclass(frozen=True, kw_only=True)
class PlacingPrior:
    """What is known of the placing variance's multiplier before a session's own trials.

    A scaled inverse chi-square: ``scale`` (``lambda0``, relative to the placing sigma the
    regions start from) on ``dof`` degrees of freedom; ``source`` says where it came from
    (words), from how many ``sessions``; ``pooled`` names them (their session ids, sorted;
    empty when they had none), so that two runs whose priors read alike ("2 other sessions
    of operator Eve") but pooled other sessions are told apart (``check``). ``anchor_p``:
    the board's conflict test over all the operator's sessions (NaN: not made), one answer
    for each (:mod:`twopose.uncertainty.anchor_conflict`).
    """

    scale: float
    dof: float
    source: str
    sessions: int = 0
    pooled: tuple[str, ...] = ()
    anchor_p: float = math.nan
    #: A board's measured sigma as the anchor (:meth:`NoiseModel.anchor`): the one tested.
    measured: bool = False

    def __post_init__(self) -> None:
        """Refuse a prior that is not a positive scale on positive degrees of freedom."""
        from twopose.errors import InputValueError

        if not (math.isfinite(self.scale) and self.scale > 0 and self.dof > 0):
            raise InputValueError(
                f"a placing prior needs a positive multiplier on positive degrees of freedom, "
                f"got {self.scale!r} on {self.dof!r}"
            )


@dataclass(frozen=True, kw_only=True)
class VarianceFactor:
    """A session's noise as its trials' misclosures and its prior settle it (see the module).

    ``sigma0_sq``: the unflagged trials' misclosure chi-square under the typed model over
    their ``dof`` (1 when the typed model is right), ``trials`` of them; ``placing_variance``:
    the multiplier ``lambda`` of the placing variance every region is propagated with, on
    ``variance_dof`` degrees of freedom (infinite: taken as exact, nothing estimated), of
    which ``information`` beyond the anchor (the data's and the operator's); ``flagged``:
    trials whose poses disagree, kept out; ``at_limit``: ``lambda`` is beyond the grid;
    ``sources``: where ``lambda``'s information came from, in words; ``sigma0_sq_all`` on
    ``dof_all``: sigma0 over every tested trial, the flagged ones' misclosures included
    (NaN, 0: not known), which the words set beside sigma0 when flagging turned its test.
    """

    sigma0_sq: float
    dof: int
    trials: int = 0
    placing_variance: float = 1.0
    variance_dof: float = math.inf
    information: float = 0.0
    flagged: int = 0
    at_limit: bool = False
    sources: str = ""
    sigma0_sq_all: float = math.nan
    dof_all: int = 0
    #: What sigma0 tests the data against: ``typed``, or ``the board's sigma``.
    against: str = "typed"
    #: The F test's p where the data contradicted the board's placing sigma (NaN: not).
    anchor_conflict: float = math.nan
    #: The part of sigma0 (in ``dof``, ``dof_all``) from its trials of one target's scatter
    #: (:mod:`twopose.uncertainty.target_scatter`): chi-square under the typed model on its
    #: dof (NaN, 0: none).
    scatter_chi2: float = math.nan
    scatter_dof: int = 0

    @property
    def tested(self) -> bool:
        """Whether any redundancy was there to test the model."""
        return self.dof > 0 and math.isfinite(self.sigma0_sq)

    @property
    def estimated(self) -> bool:
        """Whether ``lambda`` was estimated (its regions widen for its uncertainty)."""
        return math.isfinite(self.variance_dof)

    @property
    def p_upper(self) -> float:
        """sigma0's chi-square test: the upper tail (NaN: not tested)."""
        return chi2_tails(self.dof * self.sigma0_sq, self.dof)[0] if self.tested else math.nan

    @property
    def p_lower(self) -> float:
        """sigma0's chi-square test: the lower tail (NaN: not tested)."""
        return chi2_tails(self.dof * self.sigma0_sq, self.dof)[1] if self.tested else math.nan

    @property
    def contradicted(self) -> bool:
        """sigma0's own chi-square test rejects the typed model (its upper 5% tail)."""
        return self.tested and self.p_upper < FACTOR_TEST_LEVEL

    @property
    def placing_scale(self) -> float:
        """The placing sigma the regions assume over the one they start from."""
        return math.sqrt(self.placing_variance)

    def widening(self, k: int, share: float = 1.0) -> float:
        """The propagated covariance's multiplier for a ``k``-dimensional region.

        ``k F(k, f) / chi2_k``: the region's quantile for a variance estimated from ``f``
        degrees of freedom; ``f`` is :attr:`variance_dof` over ``share^2``, ``share`` the
        placing's part of the region (Welch-Satterthwaite: a region the pixels dominate
        hardly depends on ``lambda``). 1 when nothing was estimated.
        """
        if not self.estimated or k < 1 or not share > 0:
            return 1.0
        dof = self.variance_dof / min(share, 1.0) ** 2
        return region_quantile(k, dof) / region_quantile(k)

    def describe(self, placing: float = math.nan, units: Units | None = None) -> str:
        """The test and the multiplier applied in words (:func:`noise_words`).

        ``placing``: the placing sigma the regions start from, in ``units``.
        """
        s0 = math.sqrt(self.sigma0_sq) if self.tested else math.nan
        said = noise_words(s0, self.dof, math.nan, self)
        if math.isfinite(placing) and units is not None and self.estimated:
            assumed = placing * self.placing_scale
            said += f"; the regions assume a placing sigma of {assumed:.2g} {units}"
        return said


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
    over_words = " over all this operator's sessions" if by_operator else ""
    # advice already followed is not given (a new user's r6 G2): pooled with the operator's
    # other sessions, only a board is left to measure the placing with
    advice = _BOARD if _OPERATORS_POOLED in sources else f"{_BESIDE}, or {_BOARD}"
    turned = _turned_words(sigma0, dof, flagged, *with_flagged, advice=advice)
    words = [turned or _test_words(sigma0, dof, flagged, against)]
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
    if flagged:
        trials = "trial" if flagged == 1 else "trials"
        words.append(f"{flagged} {trials} flagged: kept out of the pool")
    return "; ".join(words)


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
#: (:func:`twopose.uncertainty.placing_variance.operator_priors`' words).
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


def _test_words(sigma0: float, dof: int, flagged: int = 0, against: str = "typed") -> str:
    """sigma0's chi-square test said: never "agree" when it rejects or cannot tell."""
    if (dof <= 0 or not math.isfinite(sigma0)) and flagged:
        return "sigma0 not tested (no unflagged trial has redundant poses)"
    if dof <= 0 or not math.isfinite(sigma0):
        return "sigma0 not tested (no trial with redundant poses, or --no-sigma0)"
    upper, lower = chi2_tails(dof * sigma0**2, dof)
    head = f"sigma0 {sigma0:.2f} on {dof} dof ({p_words(upper)})"
    if upper < FACTOR_TEST_LEVEL:
        return f"{head}: the data contradict the noise model (they scatter more than {against})"
    if lower < FACTOR_TEST_LEVEL:
        return f"{head}: the data scatter less than the noise model says"
    if dof < MIN_PLACING_DOF:
        return f"{head}: too few degrees of freedom to judge the noise model"
    return f"{head}: the data agree with the noise model{_power_words(dof)}"


#: The test's power said: the placing sigma (over the one assumed) it detects this often.
POWER = 0.8
#: Below this sigma ratio detected at :data:`POWER`, "agree" needs no qualifier.
POWER_SAID_FROM = 1.25


def _power_words(dof: int) -> str:
    """What a test that did not reject could have missed, in words ("" where it is small).

    The placing sigma, over the one assumed, that sigma0's test at 5% on ``dof`` detects
    only :data:`POWER` of the time (``sqrt(q95 / q20)`` of chi-square on ``dof``: the
    misclosure all placing, so at best), said where it is :data:`POWER_SAID_FROM` or more.
    "Agree" on a small session's few dof is what the test says, not that the operator
    places as typed.
    """
    from scipy import special

    ratio = math.sqrt(
        float(special.chdtri(dof, FACTOR_TEST_LEVEL)) / float(special.chdtri(dof, POWER))
    )
    if ratio < POWER_SAID_FROM:
        return ""
    return (
        f" (on {dof} dof it tells a placing sigma {ratio:.1f}x the one assumed only "
        f"{POWER:.0%} of the time)"
    )


@dataclass(frozen=True, kw_only=True)
class NoiseModel:
    """The noise every region assumes: the placing sigma and the variance factor's rule.

    ``placing``: None takes each pose's typed resolution. ``test_redundancy``: estimate the
    placing variance's multiplier from the trials' misclosures (and flag the trials whose
    poses disagree). ``prior``: the operator's (their other sessions', or the recorder's
    noise file), beside the anchor (:meth:`anchor`). ``factor``: a factor already
    estimated (guidance's predicted regions use the session's, never one from predicted
    views); when given, it is applied as is.
    """

    placing: PlacingSigma | None = None
    test_redundancy: bool = True
    factor: VarianceFactor | None = field(default=None)
    prior: PlacingPrior | None = None
    #: The rig's constants' covariance (``--rig``): carried into every region, ``J C J^T``
    #: (:mod:`twopose.rig.carried`), beside the views' own noise and never widened by its
    #: test; None: no rig, or its constants taken as exact.
    rig: RigCovariance | None = None
    #: The F test's p where the data contradicted ``placing`` (NaN: not): it weighs as typed.
    anchor_contradicted: float = math.nan

    def anchor(self) -> PlacingPrior:
        """The prior the regions' placing sigma itself is.

        A board's measurement on its degrees of freedom, else (no board, or a board that only
        bounded it, or one the session's data contradict) the typed resolution's weak word
        (:data:`TYPED_PRIOR_DOF`), next to nothing beside an operator's prior
        (:data:`SUPERSEDED_PRIOR_DOF`).
        """
        placing = self.placing
        if placing is None or placing.upper_bound:  # a bound is no measurement: the typed
            # the operator's sessions measured what the typed word guessed: they supersede it
            dof = TYPED_PRIOR_DOF if self.prior is None else SUPERSEDED_PRIOR_DOF
            return PlacingPrior(scale=1.0, dof=dof, source="the typed resolution")
        where = placing.measured_by or "the given placing sigma"
        if math.isfinite(self.anchor_contradicted):  # the data contradict it: it gives way
            prior = self.prior
            dof = TYPED_PRIOR_DOF if prior is None else SUPERSEDED_PRIOR_DOF
            whose = f" {OPERATOR_DATA}" if prior and math.isfinite(prior.anchor_p) else ""
            return PlacingPrior(
                scale=1.0, dof=dof, source=f"{where} (contradicted by the data{whose})"
            )
        return PlacingPrior(scale=1.0, dof=placing.dof, source=where, measured=True)
