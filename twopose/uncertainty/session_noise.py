"""A session's noise, as :func:`twopose.solve.session.estimate_session` settles it.

Issue 54: its trials' misclosures (:mod:`twopose.uncertainty.misclosure`, at their adjusted inputs),
the trials whose poses disagree flagged before any pooling (:mod:`twopose.uncertainty.blunders`),
the
placing variance's multiplier ``lambda`` from the others, the anchor and the operator's
prior (:mod:`twopose.uncertainty.placing_variance`), and each region's multiplier for ``lambda``'s
uncertainty and, for a flagged trial, its own misfit. The placing sigma each trial's
region assumed, and where it came from, in words.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.anchor_conflict import alone_checked, operator_decided
from twopose.uncertainty.blunders import (
    TrialTests,
    one_target,
    trial_tests,
    truth_tests,
)
from twopose.uncertainty.misclosure import Misclosure, misclosures
from twopose.uncertainty.noise import MIN_PLACING_DOF, NoiseModel, VarianceFactor, region_quantile
from twopose.uncertainty.operator_pool import SessionNoise
from twopose.uncertainty.placing_variance import posterior
from twopose.uncertainty.propagate import PLACING, Propagated, Shared, region_dof
from twopose.uncertainty.robust_flags import Flags, flag_trials
from twopose.uncertainty.target_scatter import Evidence, TargetScatter, scatter_tests
from twopose.values.units import Units

if TYPE_CHECKING:
    from twopose.methods.specs import Method
    from twopose.solve.estimate import EstimateOptions, PoseView, ViewBatch


class SessionTrials(Protocol):
    """What the placing sigma's words read of a session's trials.

    Those of :class:`twopose.solve.session.SessionTrials`.
    """

    @property
    def units(self) -> str: ...

    @property
    def views(self) -> list[list[PoseView]]: ...


__all__ = [
    "NoiseResult",
    "noise_from",
    "noise_of",
    "operator_group",
    "placed",
    "placing_parts",
    "placing_sigma",
    "placing_sigmas",
    "placing_source",
    "region_multipliers",
    "session_base_in",
    "session_statistics",
    "with_one_target",
    "with_own_truth",
]


@dataclass(frozen=True, kw_only=True)
class NoiseResult:
    """A session's noise: its factor (None: not tested), misclosures and tests (T rows).

    ``flags``: the misclosures' robust test (:func:`flag_trials`), kept to settle the
    factor again when more trials are kept out (:func:`with_one_target`).
    """

    factor: VarianceFactor | None
    misclosure: Misclosure | None
    tests: TrialTests
    flags: Flags | None = None
    noise: NoiseModel | None = None
    #: Its trials of one target (:mod:`twopose.uncertainty.target_scatter`; None: none).
    scatter: TargetScatter | None = None


def noise_of(
    method: Method,
    batch: ViewBatch,
    cov_in: F64,
    shared: Shared | None,
    rows: Ints,
    T: int,
    options: EstimateOptions,
) -> NoiseResult:
    """The noise of a session's ``T`` trials, ``rows`` of them solved ok.

    ``batch``, ``cov_in`` and ``shared`` hold those rows alone.

    A factor the options give is applied as is (guidance's predicted views never estimate
    one); without the test (``test_redundancy`` off), none.
    """
    from twopose.solve.estimate import misclosure_residuals

    noise = options.noise
    if noise.factor is not None or not noise.test_redundancy:
        factor = noise.factor if noise.factor is not None else _measured_alone(noise)
        return NoiseResult(factor=factor, misclosure=None, tests=TrialTests.none(T))
    N = batch.valid.shape[1]
    residuals, parameters = misclosure_residuals(method, batch)
    m_rows = misclosures(residuals, batch.inputs, cov_in, batch.valid, parameters, shared=shared)
    return noise_from(_at_rows(Misclosure.none(T, N), rows, m_rows), noise)


def noise_from(m: Misclosure, noise: NoiseModel) -> NoiseResult:
    """The noise of a session whose trials' misclosures are ``m``, under ``noise``.

    The board's sigma as its operator's pooled sessions decided, before any trial is
    flagged against it (:mod:`twopose.uncertainty.anchor_conflict`), then the trials
    flagged (and a session with no operator's answer tests the board on those left),
    then the factor from the others.
    """
    noise = operator_decided(noise)  # before any trial is flagged against the board
    flags = flag_trials(m.chi2, m.dof, m.placing_share, m.z2, noise.anchor(), noise.prior)
    checked = alone_checked(noise, m, flags.flagged)  # no operator's answer: this session's
    if checked is not noise:  # the board's sigma gives way: the trials tested again
        noise = checked
        flags = flag_trials(m.chi2, m.dof, m.placing_share, m.z2, noise.anchor(), noise.prior)
    factor = _factor(m, flags, flags.flagged, noise)
    tests = trial_tests(m, flags.flagged, flags.p, factor.placing_variance)
    return NoiseResult(factor=factor, misclosure=m, tests=tests, flags=flags, noise=noise)


def _factor(
    m: Misclosure, flags: Flags, out: Bools, noise: NoiseModel, scatter: Evidence | None = None
) -> VarianceFactor:
    """The session's factor from the trials not kept ``out`` (flagged).

    ``scatter``: its unflagged trials of one target's contrasts, evidence beside the
    misclosures' in the posterior and in sigma0 (:mod:`twopose.uncertainty.target_scatter`).
    """
    anchor, prior = noise.anchor(), noise.prior
    use = (m.dof > 0) & np.isfinite(m.chi2) & ~out
    pool = np.where(out[:, None], 0.0, flags.kept).sum(axis=0)
    info = np.where(out[:, None], 0.0, flags.info).sum(axis=0)
    extra = (0.0, 0) if scatter is None else (scatter.chi2, scatter.dof)
    if scatter is not None:
        pool, info = pool + scatter.loglik, info + scatter.info
    post = posterior(pool, anchor, prior, info)
    dof = int(m.dof[use].sum()) + extra[1]
    has = (m.dof > 0) & np.isfinite(m.chi2)  # the flagged trials' too
    dof_all = int(m.dof[has].sum()) + extra[1]
    estimated = round(post.information) >= MIN_PLACING_DOF
    said = _sources(int(use.sum()), prior.source if prior else "", anchor.source, scatter)
    return VarianceFactor(
        sigma0_sq=float((m.chi2[use].sum() + extra[0]) / dof) if dof else math.nan,
        dof=dof,
        trials=int(use.sum()),
        placing_variance=post.scale if estimated else 1.0,
        variance_dof=post.dof if estimated else _measured_dof(noise),
        information=post.information,
        flagged=int(out.sum()),
        at_limit=post.at_limit and estimated,
        sources=said,
        sigma0_sq_all=float((m.chi2[has].sum() + extra[0]) / dof_all) if dof_all else math.nan,
        dof_all=dof_all,
        against="typed" if _measured_dof(noise) == math.inf else "the board's sigma",
        scatter_chi2=math.nan if scatter is None else scatter.chi2,
        scatter_dof=extra[1],
        anchor_conflict=noise.anchor_contradicted,
        placing_share=float((m.placing_share[use].sum() + extra[1]) / dof) if dof else 1.0,
    )


def with_one_target(noise: NoiseResult, truth: F64, point: F64, parts: F64 | None) -> NoiseResult:
    """The session's noise with its trials of one target tested against each other.

    :mod:`twopose.uncertainty.target_scatter`: ``truth`` (T, 2, 3) the recorded truths
    (only their equality is read), ``point`` (T, 3) and ``parts`` (T, 2, 3, 3) each trial's
    estimate and its region's part the placing does not give and the part it does, at the
    sigma the regions start from. The trials are tested against each other at the
    multiplier the rest of them measure, and their scatter is evidence on the multiplier
    beside the misclosures': a trial flagged is kept out of the pool, and the factor is
    settled again. The same result (the same object) when the session is no one target's
    (fewer than three trials to compare), or was not tested (``--no-sigma0``; no ``parts``).
    """
    m, flags, model = noise.misclosure, noise.flags, noise.noise
    if m is None or flags is None or model is None or parts is None:
        return noise
    same = one_target(truth)
    if not same.any():
        return noise
    out = noise.tests.flagged
    base = (np.where(out[:, None], 0.0, flags.kept), np.where(out[:, None], 0.0, flags.info))
    scatter, target = scatter_tests(point, parts, same, out, base, model.anchor(), model.prior)
    if scatter is None:
        return noise
    tests = noise.tests.with_target(target)
    return _settled(dataclasses.replace(noise, scatter=scatter), m, model, tests)


def with_own_truth(noise: NoiseResult, error: F64, cov: F64) -> NoiseResult:
    """The session's noise with each trial tested against its own recorded truth.

    :mod:`twopose.uncertainty.blunders`: ``error`` (T, 3) each reported point less its
    truth (NaN: none), ``cov`` its region. A trial it flags is kept out of the pool, the
    factor settled again without it; its region is not widened. The same result (the same
    object) when nothing more is flagged, or the session was not tested (``--no-sigma0``).
    """
    m, flags, model = noise.misclosure, noise.flags, noise.noise
    if m is None or flags is None or model is None:
        return noise
    tests = noise.tests.with_truth(truth_tests(error, cov))
    if tests is noise.tests:
        return noise
    return _settled(noise, m, model, tests)


def _settled(
    noise: NoiseResult, m: Misclosure, model: NoiseModel, tests: TrialTests
) -> NoiseResult:
    """The noise once ``tests`` flagged trials by their estimate, tested again without them.

    Trials off the others' of their target, or off their own truth: their misclosures
    leave every other trial's rest, the misclosures' test is made again, then the factor.

    A trial another test flagged is in no pool: "the rest" a misclosure is tested against
    is the pool (:func:`flag_trials`). A typo can shrink its own trial's misclosure (its
    offset against that trial's placing error): left in the rest, it made an operator 1.6x
    worse than typed look typed-right, a clean trial's misclosure was flagged against it,
    and the two trials left said "the data agree" (the new user's F2).
    """
    T = len(tests.flagged)
    by_estimate = tests.flagged & (_noted(tests.apart, T) | _noted(tests.truth_off, T))
    flags = flag_trials(m.chi2, m.dof, m.placing_share, m.z2, model.anchor(), model.prior,
                        out=by_estimate)  # fmt: skip
    out = flags.flagged | by_estimate
    factor = _factor(
        m, flags, out, model, None if noise.scatter is None else noise.scatter.evidence(out)
    )
    base = trial_tests(m, flags.flagged, flags.p, factor.placing_variance)
    settled = dataclasses.replace(
        base,
        flagged=base.flagged | by_estimate,
        own=np.where(by_estimate, tests.own, base.own),
        own_dof=np.where(by_estimate, tests.own_dof, base.own_dof),
        apart=tests.apart,
        truth_off=tests.truth_off,
        truth_sigmas=tests.truth_sigmas,
        truth_axis=tests.truth_axis,
    )
    return dataclasses.replace(noise, factor=factor, tests=settled, flags=flags)


def _noted(values: F64 | None, T: int) -> Bools:
    """Where a per-trial column another test fills is known (``T`` False: none)."""
    return np.zeros(T, dtype=bool) if values is None else np.isfinite(values)


def _measured_dof(noise: NoiseModel) -> float:
    """The degrees of freedom a board's measured placing sigma rests on.

    Infinite: typed, given exactly, or an upper bound. Without the session's own estimate
    the regions still take Fisher's F on them, as on any sigma estimated from data
    (docs/rig.md).
    """
    return math.inf if noise.placing is None else noise.placing.dof


def _measured_alone(noise: NoiseModel) -> VarianceFactor | None:
    """The factor of a session not tested (``--no-sigma0``).

    A board's measured placing sigma on its own degrees of freedom, the multiplier 1
    (None: nothing measured).
    """
    dof = _measured_dof(noise)
    if not math.isfinite(dof):
        return None
    return VarianceFactor(sigma0_sq=math.nan, dof=0, variance_dof=dof,
                          sources=f"{noise.anchor().source} alone")  # fmt: skip


def _sources(trials: int, prior: str, anchor: str, scatter: Evidence | None = None) -> str:
    """Where the multiplier's information came from, in words."""
    said = [f"this session's {trials} trial{'s' if trials != 1 else ''}"] if trials else []
    if scatter is not None:  # its trials of one target, about each other
        whose = "its" if trials else "this session's"
        said.append(f"the scatter of {whose} {scatter.trials} trials of one target")
    return ", ".join([*said, *([prior] if prior else []), anchor])


def _at_rows(base: Misclosure, rows: Ints, m: Misclosure) -> Misclosure:
    """``base`` (T trials) with the solved rows' misclosures at their trials."""
    values = {}
    for name in ("chi2", "dof", "placing_share", "z", "bias", "iterations"):
        out = getattr(base, name).copy()
        out[rows] = getattr(m, name)
        values[name] = out
    return Misclosure(**values)


def operator_group(operator: str, method: Method) -> str:
    """Whose sessions pool their placing error: one operator's, one method's (a setup).

    ``""`` (no operator named): a session alone.
    """
    name = operator.strip()
    return f"{name} ({method})" if name else ""  # matched by operator_key: the caller's


def session_statistics(
    group: str, m: Misclosure | None, tests: TrialTests | None = None,
    placing_in: float = math.nan,
) -> SessionNoise:  # fmt: skip
    """What a session's misclosures say of its operator (:class:`SessionNoise`).

    Its tested trials' chi-square, dof and components (none when not tested); a trial
    ``tests`` flagged for its estimate off the others of its target
    (:attr:`TrialTests.apart`) is left out, as the session's own pool leaves it. A trial
    flagged by its own truth (:attr:`TrialTests.truth_off`) is not: the run's first pass
    tests it in regions the operator's prior has not settled yet (at 3x the typed placing
    it would flag merely noisy trials and thin the operator's pool by the truth), and a
    blunder only the truth sees is one its misclosure cannot: its misclosure is a clean one.
    ``placing_in``: the session's base (:func:`session_base_in`), so that its operator's
    sessions of other typed resolutions pool with it as placing variances.
    """
    if m is None:
        return SessionNoise(group=group, chi2=np.zeros(0), dof=np.zeros(0, dtype=np.int_),
                            share=np.zeros((0, 0)), z2=np.zeros((0, 0)),
                            placing_in=placing_in)  # fmt: skip
    use = (m.dof > 0) & np.isfinite(m.chi2)
    if tests is not None and tests.apart is not None:
        use &= ~np.isfinite(tests.apart)
    return SessionNoise(group=group, chi2=m.chi2[use], dof=m.dof[use],
                        share=m.placing_share[use], z2=m.z2[use],
                        placing_in=placing_in)  # fmt: skip


def session_base_in(trials: SessionTrials, options: EstimateOptions) -> float:
    """The placing sigma a session's multiplier is relative to, in inches (NaN: no pose).

    A board's measured ``[placing]``, else the RMS of its poses' typed resolutions
    (:func:`twopose.uncertainty.hand.base_placing_in`).
    """
    from twopose.uncertainty.hand import base_placing_in
    from twopose.values.units import unit_spec

    placing = options.noise.placing
    if placing is not None and not placing.upper_bound:
        return placing.sigma_in
    if not trials.units:
        return math.nan
    typed = [v.t_sigma for row in trials.views for v in row]
    return base_placing_in(typed, unit_spec(Units(trials.units)).inches)


def placed(cov_in: F64, factor: VarianceFactor | None) -> F64:
    """The input covariance (T, N, 9, 9) with the placing variance times ``lambda``.

    Every region, fit and direction is propagated from it.
    """
    if factor is None or factor.placing_variance == 1.0:
        return cov_in
    out = cov_in.copy()
    out[..., PLACING, PLACING] *= factor.placing_variance
    return out


def placing_parts(propagated: Propagated, cov_in: F64) -> tuple[F64, F64]:
    """(R, W, W) twice: what the typed translations' covariance gives of an estimate.

    Its first-order part (in proportion to the placing variance) and its second-order part
    (:attr:`~twopose.uncertainty.propagate.Propagated.curvature`: to its square).
    """
    J = propagated.jacobian[..., PLACING]
    first = np.einsum("tinj,tnjk,tlnk->til", J, cov_in[..., PLACING, PLACING], J)
    c = propagated.curvature
    if c is None:
        return np.asarray(first), np.zeros_like(first)
    second = np.einsum("tink,tjnk->tij", c[..., PLACING], c[..., PLACING])
    return np.asarray(first), np.asarray(second)


def region_multipliers(
    cov: F64, placing: F64, factor: VarianceFactor | None, tests: TrialTests | None = None,
    rows: Ints | None = None,
) -> F64:  # fmt: skip
    """(R,) each region's covariance multiplier (1: unchanged; NaN: no finite covariance).

    :meth:`VarianceFactor.widening` for the region's own dimensions (3 for a point, 2 for
    a ground point or a line's point) and the placing's share of it (``placing``: the
    placing's part of ``cov``); a flagged trial's (``tests`` at ``rows``) times its own
    misfit and its own F quantile (:mod:`twopose.uncertainty.blunders`).
    """
    k = region_dof(cov)
    out = np.where(k > 0, 1.0, np.nan)
    good = k > 0
    if factor is not None and factor.estimated and good.any():
        share = _placing_share(cov[good], placing[good], k[good])
        out[good] = [factor.widening(int(d), float(h)) for d, h in zip(k[good], share, strict=True)]
    if tests is not None and rows is not None:
        own, dof = tests.own[rows], tests.own_dof[rows]
        flagged = tests.flagged[rows] & good & (dof > 0)
        for i in np.flatnonzero(flagged):
            d = int(k[i])
            out[i] *= own[i] * region_quantile(d, float(dof[i])) / region_quantile(d)
    return out


def _placing_share(cov: F64, placing: F64, k: Ints) -> F64:
    """(R,) the placing's share of each region: ``trace(cov^+ placing) / k``."""
    w, V = np.linalg.eigh(cov)
    keep = w > 1e-9 * w[:, -1:]
    inv = np.where(keep, 1.0 / np.where(keep, w, 1.0), 0.0)
    pinv = np.einsum("rij,rj,rkj->rik", V, inv, V)
    share = np.einsum("rij,rji->r", pinv, placing) / np.maximum(k, 1)
    return np.asarray(np.clip(np.nan_to_num(share), 0.0, 1.0))


def placing_sigma(trials: SessionTrials, options: EstimateOptions) -> float | None:
    """The placing sigma in the session's units, measured (:mod:`twopose.uncertainty.noise`).

    None: each pose's typed resolution stands (no board, or one that only bounded it: an
    upper bound is no value to start from).
    """
    placing = options.noise.placing
    if placing is None or placing.upper_bound or not trials.units:
        return None
    return placing.sigma(Units(trials.units))


def placing_sigmas(
    trials: SessionTrials, options: EstimateOptions, factor: VarianceFactor | None = None
) -> F64:
    """(T,) the placing sigma each trial's region assumed, in the session's units.

    The measured one (:func:`placing_sigma`), else the mean of its poses' typed resolution
    (NaN: no pose); times ``sqrt(lambda)``, the multiplier the session settled
    (:attr:`twopose.uncertainty.noise.VarianceFactor.placing_variance`).
    """
    measured = placing_sigma(trials, options)
    scale = 1.0 if factor is None else factor.placing_scale
    return scale * np.array(
        [
            measured
            if measured is not None and row
            else (float(np.mean([v.t_sigma for v in row])) if row else np.nan)
            for row in trials.views
        ],
        dtype=np.float64,
    )


def placing_source(options: EstimateOptions, factor: VarianceFactor | None = None) -> str:
    """Where the placing sigma came from, briefly.

    ``typed``, ``measured by <board session> (<n> captures)``, ``typed (not the upper bound
    from <board session> (<n> captures))`` or ``given``, then, when the
    multiplier was estimated, ``times 1.6 (estimated from ...)``.
    """
    placing = options.noise.placing
    if placing is None:
        base = "typed"
    elif not placing.measured_by:
        base = "given"
    else:
        captures = f" ({placing.captures} captures)" if placing.captures else ""
        base = f"measured by {placing.measured_by}{captures}"
        if placing.upper_bound:  # not measured, only bounded: the regions start from typed
            base = f"typed (not the upper bound from {placing.measured_by}{captures})"
    if factor is None or not factor.estimated:
        return base
    return f"{base}, times {factor.placing_scale:.3g} (estimated from {factor.sources})"
