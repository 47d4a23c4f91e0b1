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
* its words (:mod:`twopose.uncertainty.noise_words`): the one place a test is said, so that
  the words never say more than the numbers: "agree" only when sigma0's own chi-square
  test does not reject on enough degrees of freedom, "contradict" only when it rejects,
  "scatter less" only in its lower tail;
* :class:`NoiseModel`: all of it as the estimation's options carry it
  (:attr:`twopose.solve.margins.EstimateOptions.noise`).

Light: the command lines read it; NumPy and SciPy are imported where a number is computed.
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
    #: The placing's mean share of sigma0's directions (its misclosures' ``beta``, the
    #: trials of one target's contrasts counted as all placing): 1 when the test sees
    #: placing alone, near 0 when the pixels' noise is most of it (its power said with it).
    placing_share: float = 1.0
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
