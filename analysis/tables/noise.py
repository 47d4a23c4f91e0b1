"""How ``trials.csv``'s noise columns are filled from a session's estimate (issues 46, 54):
the placing sigma each trial's region assumed and where it came from, the degrees of
freedom it rests on, the trial's misclosure and its test, whether its poses disagree and
which pose's typed component looks off (:mod:`twopose.uncertainty.blunders`). Declared in
:data:`analysis.tables.trials.TRIAL_TABLE`; filled here, each from a
:class:`~analysis.tables.trials.TrialResult`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

if TYPE_CHECKING:
    from twopose.arrays import F64
    from twopose.solve.session import SessionEstimate
    from twopose.uncertainty.blunders import TrialTests


class TrialResult(Protocol):
    """What a fill reads (:class:`analysis.tables.trials.TrialResult`'s session estimate)."""

    @property
    def estimate(self) -> SessionEstimate: ...


__all__ = [
    "FLAGGED_BY",
    "disagreement",
    "flagged",
    "flagged_by",
    "floor_unmeasured",
    "misclosure_chi2",
    "misclosure_dof",
    "misclosure_p",
    "misclosure_placing_share",
    "noise_widening",
    "placing_dof",
    "placing_scale",
    "placing_sigma",
    "placing_source",
    "prior_sessions",
    "suspect_axis",
    "suspect_offset",
    "suspect_pose",
    "target_scatter_chi2",
    "target_scatter_dof",
]


#: ``flagged_by``'s values: :data:`twopose.uncertainty.blunders.FLAGGED_BY`, spelled here so
#: that reading a table needs no estimation at import (tests/analysis/test_own_truth_flags.py).
FLAGGED_BY = ("misclosure", "other trials", "truth")


def placing_sigma(t: TrialResult) -> F64:
    """The placing sigma each trial's region assumed (:func:`placing_sigmas`)."""
    from twopose.uncertainty.session_noise import placing_sigmas

    return placing_sigmas(t.estimate.trials, t.estimate.options, t.estimate.factor)


def placing_source(t: TrialResult) -> list[str]:
    """Where the placing sigma came from (typed, or measured by which board session, and
    the multiplier the session estimated and from what)."""
    from twopose.uncertainty.session_noise import placing_source as source

    return [source(t.estimate.options, t.estimate.factor)] * len(t.estimate.trials)


def floor_unmeasured(t: TrialResult) -> list[str]:
    """Per trial, where its views' image size is not one the detector's floor was measured
    at, the words saying so (:func:`twopose.methods.specs.floors_unmeasured`; ``""``: the
    floor holds at every view's size)."""
    from twopose.methods.specs import floors_unmeasured

    return [floors_unmeasured(v.width_height for v in row) for row in t.estimate.trials.views]


def prior_sessions(t: TrialResult) -> list[str]:
    """The operator's other sessions the placing's prior pooled: their ids, ``;``-joined
    (empty: no prior, or the recorder's noise file's, whose sessions are not named)."""
    prior = t.estimate.options.noise.prior
    return [";".join(prior.pooled) if prior is not None else ""] * len(t.estimate.trials)


def placing_scale(t: TrialResult) -> F64:
    """The placing sigma taken over the one assumed, ``sqrt(lambda)`` (1: none estimated)."""
    factor = t.estimate.factor
    return np.full(len(t.estimate.trials), 1.0 if factor is None else factor.placing_scale)


def placing_dof(t: TrialResult) -> F64:
    """The degrees of freedom the placing sigma rests on (NaN: taken as exact)."""
    factor, T = t.estimate.factor, len(t.estimate.trials)
    dof = factor.variance_dof if factor is not None and factor.estimated else np.nan
    return np.full(T, dof)


def target_scatter_chi2(t: TrialResult) -> F64:
    """The session's trials of one target: their contrasts' chi-square under the typed model
    (:mod:`twopose.uncertainty.target_scatter`; the same in every trial; NaN: none)."""
    factor = t.estimate.factor
    return np.full(len(t.estimate.trials), np.nan if factor is None else factor.scatter_chi2)


def target_scatter_dof(t: TrialResult) -> Any:
    """The degrees of freedom of :func:`target_scatter_chi2` (0: none)."""
    factor = t.estimate.factor
    dof = 0 if factor is None else factor.scatter_dof
    return np.full(len(t.estimate.trials), dof, dtype=np.int64)


def misclosure_chi2(t: TrialResult) -> F64:
    """Each trial's misclosure chi-square (NaN: no redundancy, or not tested)."""
    m = t.estimate.misclosure
    return np.full(len(t.estimate.trials), np.nan) if m is None else m.chi2


def misclosure_dof(t: TrialResult) -> Any:
    """Each trial's redundant measurements tested (0: none, or not tested)."""
    m = t.estimate.misclosure
    return np.zeros(len(t.estimate.trials), dtype=np.int64) if m is None else m.dof


def misclosure_placing_share(t: TrialResult) -> F64:
    """Each trial's misclosure: the placing's mean share of its directions (NaN: none)."""
    m = t.estimate.misclosure
    if m is None:
        return np.full(len(t.estimate.trials), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(m.dof > 0, m.placing_share.sum(axis=1) / m.dof, np.nan)


def noise_widening(t: TrialResult) -> F64:
    """Each ok trial's region's largest variance against the typed placing's (1: unchanged)."""
    return t.estimate.estimates.widening


def _tests(t: TrialResult) -> TrialTests:
    from twopose.uncertainty.blunders import TrialTests

    return t.estimate.tests or TrialTests.none(len(t.estimate.trials))


def misclosure_p(t: TrialResult) -> F64:
    """Each trial's misclosure p-value against the rest of its session (NaN: none)."""
    return _tests(t).p


def flagged(t: TrialResult) -> Any:
    """Whether a test flagged the trial (empty: none tested it: no redundant poses and no
    truth, or ``--no-sigma0``)."""
    tests, m = _tests(t), t.estimate.misclosure
    tested = m is not None and t.estimate.options.noise.test_redundancy
    truth = [bool(k) for k in np.isfinite(t.estimate.trials.truth).all(axis=(1, 2)).ravel()]
    return [
        bool(f) if tested and (d > 0 or known) else None
        for f, d, known in zip(tests.flagged, _dof(t), truth, strict=True)
    ]


def flagged_by(t: TrialResult) -> list[str]:
    """Which test flagged the trial: ``misclosure``, ``other trials`` or ``truth``
    (:data:`twopose.uncertainty.blunders.FLAGGED_BY`; ``""``: not flagged)."""
    tests = _tests(t)
    return [tests.by(i) for i in range(len(t.estimate.trials))]


def _dof(t: TrialResult) -> Any:
    m = t.estimate.misclosure
    return np.zeros(len(t.estimate.trials), dtype=np.int64) if m is None else m.dof


def suspect_pose(t: TrialResult) -> Any:
    """The pose a flagged trial names (0: none named)."""
    return _tests(t).pose.astype(np.int64)


def suspect_axis(t: TrialResult) -> list[str]:
    """Which typed component of it looks off (``""``: not said)."""
    return [str(a) for a in _tests(t).axis]


def suspect_offset(t: TrialResult) -> F64:
    """By how much the named pose's component looks off: typed minus where the laptop
    stood (NaN: no pose named; the words give the range)."""
    return _tests(t).offset


#: Beside a trial its truth flagged where nothing in its session tested the typed placing
#: sigma: a clean trial of an operator placing worse than typed lies off its truth too (a
#: new user's r6 G3: 4 clean trials told only "check what you typed").
UNTESTED_CAUSE = (
    "; or the operator places worse than typed: nothing in this session tests the typed "
    "placing sigma"
)


def disagreement(t: TrialResult) -> list[str]:
    """A flagged trial's poses' disagreement in words (the recorder's live words)."""
    from twopose.values.units import Units

    tests, trials, factor = _tests(t), t.estimate.trials, t.estimate.factor
    units = Units(trials.units)
    said = [tests.words(i, units, len(v)) for i, v in enumerate(trials.views)]
    typed = t.estimate.options.noise.placing is None  # no board's sigma: the typed one
    if factor is None or factor.tested or factor.estimated or not typed:
        return said
    truth = FLAGGED_BY[2]
    return [w + UNTESTED_CAUSE if tests.by(i) == truth else w for i, w in enumerate(said)]
