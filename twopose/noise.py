"""The noise a trial's 95% region assumes, defined once (issue 46).

Every region (the analysis' ``trials.csv``, the recorder's live result, guidance's
predictions) propagates three inputs (:mod:`twopose.uncertainty`): each pose's frame
scatter, the calibration's 1-sigma and the operator's **placing error**, the 1-sigma of each
typed translation component. That last one dominates a trial's region, and it is the one
nobody measured: it was the resolution the operator typed. Here it is

* :class:`PlacingSigma`: the placing error, typed (each pose's recorded resolution) or
  **measured** by a board session (:func:`twopose.rig.board.fit_board_rig`: each capture's
  camera position, known from the board's corners to a fraction of a millimetre, against
  its typed pose after the rig's constants), with its own 1-sigma and where it came from;
* :class:`VarianceFactor`: the **a-posteriori variance factor** ``sigma0^2`` of
  photogrammetry, pooled over the trials that share an operator and a setup (a session):
  trials with redundant measurements (three poses or more, or two rays of a point) test the
  noise model by their misclosures. The component the model is unsure of, the placing
  variance, is **measured** from them by variance component estimation (Helmert, Förstner):
  each trial's misclosure has the covariance ``A + lambda B`` (``A`` from the pixels, the
  rotation resolution and the calibration, ``B`` from the placing sigma), and ``lambda`` is
  the maximum of their joint likelihood. When a likelihood-ratio test contradicts
  ``lambda = 1`` (one-sided, 5%), every region is propagated again with the placing sigma
  times ``sqrt(lambda)`` and widened by the quantile of Fisher's F instead of the
  chi-square (``lambda`` is itself estimated, from few degrees of freedom); when the data
  agree, nothing changes;
* :class:`NoiseModel`: the two as the estimation's options carry them
  (:attr:`twopose.margins.EstimateOptions.noise`).

Light: the command lines read it; NumPy and SciPy are imported where a number is computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from twopose.rig.covariance import RigCovariance
    from twopose.units import Units

__all__ = [
    "FACTOR_TEST_LEVEL",
    "MIN_PLACING_DOF",
    "NoiseModel",
    "PlacingSigma",
    "VarianceFactor",
    "noise_words",
    "region_quantile",
]

#: The variance factor's test: the model is contradicted when ``dof * sigma0^2`` lies in
#: the chi-square's upper 5% tail.
FACTOR_TEST_LEVEL = 0.05
#: A measured placing sigma must rest on at least this many degrees of freedom (its
#: 1-sigma at most sigma / sqrt(6)): below, its F quantile (:attr:`PlacingSigma.widening`)
#: explodes, and a board session of the recommended size gives about 17.
MIN_PLACING_DOF = 3
#: The regions' level.
_REGION_LEVEL = 0.95


def _inches_per(units: Units) -> float:
    from twopose.units import unit_spec

    return unit_spec(units).inches


@dataclass(frozen=True, kw_only=True)
class PlacingSigma:
    """The operator's placing error: the 1-sigma of each typed translation component.

    In inches (converted per session); ``sigma_sigma_in`` is the estimate's own 1-sigma
    (NaN: not measured); ``measured_by`` names the board session(s) that measured it, over
    ``captures`` captures. ``upper_bound``: the captures showed no placing error their
    corners resolve (the fit's floor), and ``sigma_in`` is only the most it can be (no
    1-sigma; never said "measured").
    """

    sigma_in: float
    sigma_sigma_in: float = math.nan
    measured_by: str = ""
    captures: int = 0
    upper_bound: bool = False

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

    @property
    def widening(self) -> float:
        """The factor on the measured sigma that the regions assume (1: stated exactly).

        A sigma estimated from few degrees of freedom (a board session's 8 captures give
        about 17) is itself uncertain: a region built on it covers less than 95% on
        average. As for the variance factor, the region's quantile becomes Fisher's F
        instead of the chi-square (:func:`region_quantile`), carried on the sigma as
        ``sqrt(3 F(3, dof) / chi2_3)``: the 3-D region's (the widest of a region's
        1-3 dimensions), exact where the placing dominates the region.
        """
        if not math.isfinite(self.dof):
            return 1.0
        return math.sqrt(region_quantile(3, self.dof) / region_quantile(3))

    def sigma(self, units: Units) -> float:
        """The placing sigma the regions assume, in ``units``.

        The measured one, widened for its own uncertainty (:attr:`widening`).
        """
        return self.sigma_in * self.widening / _inches_per(units)

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
                f"resolve); regions assume {value} {units}"
            )
        if math.isfinite(self.sigma_sigma_in):
            value += f" ± {self.sigma_sigma_in / inches:.2g}"
        where = f"measured by {self.measured_by}" if self.measured_by else "given"
        if self.captures:
            where += f" ({self.captures} captures)"
        said = f"placing sigma {value} {units}, {where}"
        if self.widening >= 1.005:  # shown as x1.01 or more; a nearly exact one is not said
            said += (
                f"; regions assume {self.sigma(units):.3g} {units} (x{self.widening:.2f} for "
                f"the estimate's own uncertainty, {self.dof:.0f} degrees of freedom)"
            )
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


@dataclass(frozen=True, kw_only=True)
class VarianceFactor:
    """The noise model tested by a session's redundant trials (see the module).

    ``sigma0_sq``: the misclosures' chi-square over their ``dof`` degrees of freedom (1
    when the noise model is right); ``trials``: the trials that carried redundancy.

    The placing variance's multiplier ``lambda`` is estimated from the same misclosures by
    variance component estimation (:func:`twopose.misclosure.placing_component`):
    ``placing_scale`` is ``sqrt(lambda)`` (NaN: not estimated), ``placing_dof`` the
    degrees of freedom it is estimated from and ``placing_lr`` the likelihood-ratio
    statistic of ``lambda`` against 1. A factor without them (built from sigma0 alone)
    puts all of the misfit on the placing: ``lambda = sigma0^2`` on ``dof``.
    """

    sigma0_sq: float
    dof: int
    trials: int = 0
    placing_scale: float = math.nan
    placing_dof: float = math.nan
    placing_lr: float = math.nan

    @property
    def tested(self) -> bool:
        """Whether any redundancy was there to test the model."""
        return self.dof > 0 and math.isfinite(self.sigma0_sq)

    @property
    def estimated(self) -> bool:
        """Whether the placing variance's multiplier was estimated (variance components)."""
        return math.isfinite(self.placing_scale) and math.isfinite(self.placing_lr)

    @property
    def contradicted(self) -> bool:
        """The data contradict the typed placing sigma: the regions are re-propagated.

        With ``lambda`` estimated: ``lambda > 1`` and its likelihood-ratio statistic beyond
        the chi-square's (1 dof) upper ``2 x 5%`` quantile (one-sided 5%: only a larger
        placing error widens). Without: ``dof sigma0^2`` beyond its 95% quantile.
        """
        if not self.tested:
            return False
        if self.estimated:
            limit = chi2_quantile(1.0 - 2 * FACTOR_TEST_LEVEL, 1)
            return self.placing_scale > 1.0 and self.placing_lr > limit
        limit = chi2_quantile(1.0 - FACTOR_TEST_LEVEL, self.dof)
        return self.dof * self.sigma0_sq > limit

    @property
    def placing_variance(self) -> float:
        """The multiplier of the placing variance the regions assume (1: unchanged)."""
        if not self.contradicted:
            return 1.0
        return self.placing_scale**2 if self.estimated else self.sigma0_sq

    @property
    def variance_dof(self) -> float:
        """The degrees of freedom :attr:`placing_variance` is estimated from."""
        return self.placing_dof if self.estimated else float(self.dof)

    def widening(self, k: int) -> float:
        """The re-propagated covariance's multiplier for a ``k``-dimensional region.

        ``k F(k, f) / chi2_k``, ``f`` = :attr:`variance_dof`: the region's radius is then
        the F quantile's of the covariance re-propagated with the placing sigma times
        ``sqrt(lambda)`` (1: unchanged), every column read from one covariance.
        """
        if not self.contradicted or k < 1:
            return 1.0
        return region_quantile(k, self.variance_dof) / region_quantile(k)

    def describe(self, placing: float = math.nan, units: Units | None = None) -> str:
        """The test in words; ``placing``: the placing sigma typed (or given), in ``units``."""
        if not self.tested:
            return "noise model not tested (no trial with redundant poses)"
        s0 = math.sqrt(self.sigma0_sq)
        head = f"sigma0 {s0:.2f} over {self.dof} degrees of freedom ({self.trials} trials)"
        if not self.contradicted:
            return f"{head}: the data agree with the noise model; regions unchanged"
        scale = math.sqrt(self.placing_variance)
        if math.isfinite(placing) and units is not None:
            measured = (
                f"the sessions' redundancy measures the placing sigma at {placing * scale:.2g} "
                f"{units} ({scale:.1f}x the assumed {placing:.3g} {units})"
            )
        else:
            measured = (
                f"the sessions' redundancy measures the placing sigma {scale:.1f}x the one assumed"
            )
        return (
            f"{measured}, from {self.variance_dof:.0f} degrees of freedom ({head}); every "
            f"95% region is propagated with it and widened by Fisher's F for its uncertainty"
        )


def noise_words(sigma0: float, dof: int, region_widening: float, placing_scale: float = 1.0) -> str:
    """The variance factor's test in a few words, one home for every place that says it.

    ``region_widening``: the 95% region's radius multiplier against the typed placing
    sigma's (its largest semi-axis; 1: unchanged); ``placing_scale``: the placing sigma the
    session's redundancy measured, over the typed (1: not said).
    """
    if dof <= 0 or not math.isfinite(sigma0):
        return "sigma0 not tested (no redundant trial, or --no-sigma0)"
    head = f"sigma0 {sigma0:.2f} on {dof} dof"
    if region_widening > 1:
        said = "the data contradict the noise model (the placing error is larger than assumed)"
        if placing_scale > 1:
            said += f": placing sigma measured {placing_scale:.1f}x the one assumed"
        return f"{head}: regions' largest semi-axis widened x{region_widening:.1f}: {said}"
    if _below_model(sigma0, dof):
        return (
            f"{head}: the data scatter less than the noise model says (its regions may be "
            "too wide; they are never narrowed)"
        )
    return f"{head}: the data agree with the noise model"


def _below_model(sigma0: float, dof: int) -> bool:
    """``dof sigma0^2`` in the chi-square's lower 5% tail: the model overstates the noise.

    A sigma0 of 1 or more never is (the tail lies below the mean, ``dof``): no quantile
    is computed, nor scipy imported, for it.
    """
    return sigma0 < 1.0 and dof * sigma0**2 < chi2_quantile(FACTOR_TEST_LEVEL, dof)


@dataclass(frozen=True, kw_only=True)
class NoiseModel:
    """The noise every region assumes: the placing sigma and the variance factor's rule.

    ``placing``: None takes each pose's typed resolution. ``test_redundancy``: estimate the
    variance factor from the trials' misclosures and widen when they contradict the model.
    ``factor``: a factor already estimated (guidance's predicted regions use the session's,
    never one from predicted views); when given, it is applied as is.
    """

    placing: PlacingSigma | None = None
    test_redundancy: bool = True
    factor: VarianceFactor | None = field(default=None)
    #: The rig's constants' covariance (``--rig``): carried into every region, ``J C J^T``
    #: (:mod:`twopose.rig.carried`), beside the views' own noise and never widened by its
    #: test; None: no rig, or its constants taken as exact.
    rig: RigCovariance | None = None
