"""A trial's result as the analysis reports it, for the live view.

The thesis' GUI computed the point on the spot (section 5.2.4); the recorder's live view shows the
analysis' own result.

:func:`trial_results` runs the analysis' own estimation
(:func:`twopose.solve.session.estimate_session`: the same frame combination, solvers,
margins and uncertainty propagation) on the trials so far, and compares it with the truth
by the analysis' one rule (:func:`twopose.methods.truth.reported`). The estimate and its error are
the analysis' exactly; the 95% region pools the frame scatter of the trials so far, where
the analysis pools the whole session.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twopose.arrays import F64
from twopose.methods.specs import Method
from twopose.methods.truth import line_errors, reported
from twopose.solve.estimate import EstimateOptions
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session
from twopose.uncertainty.blunders import TrialTests
from twopose.uncertainty.noise import VarianceFactor
from twopose.uncertainty.noise_words import noise_words
from twopose.uncertainty.propagate import semiaxis95, uncertainty_columns
from twopose.values.units import Units

__all__ = ["STATUS_WORDS", "TrialResult", "results_of", "trial_results"]

#: A region widened by at least this (its size) has the noise said on the result's line.
_SAID_WIDENING = 1.1
#: A trial's status (trials.csv's codes) in the operator's words.
STATUS_WORDS = {
    "ok": "solved",
    "degenerate": "no estimate: the poses' geometry is degenerate",
    "no_detection": "no estimate: the target was not found in a pose",
    "incomplete": "no estimate yet: fewer than two usable poses",
}


@dataclass(frozen=True, kw_only=True)
class TrialResult:
    """One trial's live result, in session units."""

    trial: int
    method: Method
    units: Units
    n_views: int
    status: str  # ok, degenerate, no_detection, incomplete (as trials.csv)
    reason: str
    point: tuple[float, float, float]
    direction: tuple[float, float, float] | None  # lines
    semiaxis95: float  # the 95% ellipsoid's longest semi-axis
    ci95: tuple[float, float, float]  # 95% half-widths per axis
    margins: dict[str, float] = field(default_factory=dict)  # degrees, by trials.csv column
    warning: str = ""  # margins under their thresholds
    error: float = math.nan  # against the typed ground truth (NaN: none)
    error_xyz: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    cov: tuple[tuple[float, float, float], ...] = ()  # (3, 3) of ``point``, propagated
    angle95_deg: float = math.nan  # lines: the direction's 95% half-angle
    angle_err_deg: float = math.nan  # lines: against the true line (as trials.csv)
    #: The session's variance factor so far (:mod:`twopose.uncertainty.noise`; None: not tested),
    #: and
    #: the multiplier of this trial's 95% region's size it applied (1: unchanged).
    factor: VarianceFactor | None = None
    widened: float = 1.0
    #: Its poses disagree (:mod:`twopose.uncertainty.blunders`): said in words (the analysis'
    #: words).
    flagged: bool = False
    disagreement: str = ""
    #: Which test flagged it: ``misclosure``, ``other trials`` or ``truth`` (its estimate far
    #: off the grid point typed as its truth); ``""`` when not flagged (trials.csv's
    #: ``flagged_by``).
    flagged_by: str = ""
    #: Other trials flagged before this trial's pose that pass now, beside it, in words
    #: (""): a flag never withdrawn silently (a new user's r6 G1).
    lapsed: str = ""

    @property
    def noise(self) -> str:
        """The noise model's test in words (:func:`twopose.uncertainty.noise_words.noise_words`)."""
        if self.factor is None:
            return ""
        sigma0 = math.sqrt(self.factor.sigma0_sq) if self.factor.tested else math.nan
        return noise_words(sigma0, self.factor.dof, self.widened, self.factor)

    @property
    def noise_said(self) -> bool:
        """Whether the result line says the noise: its region widened by a tenth or more,
        or sigma0's test rejecting the typed model."""
        f = self.factor
        return self.widened >= _SAID_WIDENING or (f is not None and f.contradicted)

    def text(self) -> str:
        """The result in one line, then its warning; or why there is none.

        One line: ``trial 3 (2 views): x 1.915 y 9.625 z 8.402 in; 95% within 0.183 in;
        error 0.052 in``, then the warning; or why there is no estimate. A line gives its
        direction's too: ``direction (...) 95% within 1.2 deg; angle error 0.8 deg;
        distance error 0.052 in (95% within 0.183 in)``.
        """
        head = f"trial {self.trial} ({self.n_views} views)"
        if self.status != "ok":
            said = STATUS_WORDS.get(self.status, self.status)
            return f"{head}: {said}: {self.reason}" if self.reason else f"{head}: {said}"
        x, y, z = self.point
        parts = [f"{head}: x {x:.3f} y {y:.3f} z {z:.3f} {self.units}"]
        if self.direction is not None:
            parts += self._line_parts()
        else:
            if math.isfinite(self.semiaxis95):
                parts.append(f"95% within {self.semiaxis95:.3f} {self.units}")
            if math.isfinite(self.error):
                parts.append(f"error {self.error:.3f} {self.units}")
        if self.flagged:
            parts.append(f"WARNING {self.disagreement}")
        if self.noise_said:  # said when it changed the region, or the test rejects
            parts.append(self.noise)
        if self.warning:
            parts.append(f"WARNING {self.warning}")
        if self.outside95:
            parts.append("WARNING the error is beyond its 95% region: check the truth and poses")
        if self.lapsed:
            parts.append(f"NOTE {self.lapsed}")
        return "; ".join(parts)

    @property
    def outside95(self) -> bool:
        """Whether the error against the typed truth is beyond its 95% region.

        The region's largest semi-axis; for a line, its angle or its distance. A wrong
        truth, pose or setup, or a 1-in-20 trial.
        """
        beyond = self.error > self.semiaxis95  # False where either is NaN
        return bool(beyond or self.angle_err_deg > self.angle95_deg)

    def _line_parts(self) -> list[str]:
        """A line's direction and its errors, each with its 95% region.

        An angle and a distance, never the distance alone: a line 69 degrees off can pass
        through its true midpoint.
        """
        assert self.direction is not None
        dx, dy, dz = self.direction
        direction = f"direction ({dx:.3f}, {dy:.3f}, {dz:.3f})"
        if math.isfinite(self.angle95_deg):
            direction += f" 95% within {self.angle95_deg:.1f} deg"
        parts = [direction]
        region = (
            f" (95% within {self.semiaxis95:.3f} {self.units})"
            if math.isfinite(self.semiaxis95)
            else ""
        )
        if math.isfinite(self.angle_err_deg):
            parts.append(f"angle error {self.angle_err_deg:.1f} deg")
        if math.isfinite(self.error):
            parts.append(f"distance error {self.error:.3f} {self.units}{region}")
        elif region:
            parts.append(f"position{region}")
        return parts

    def to_json(self) -> dict[str, object]:
        """The result as a JSON-ready object for the web console and live view.

        NaN and infinity are left as floats: whoever serialises it uses the one encoder,
        :func:`twopose.values.jsonsafe.dumps`, which writes them as ``null``.
        """
        return {
            "trial": self.trial,
            "method": self.method,
            "units": self.units,
            "n_views": self.n_views,
            "status": self.status,
            "reason": self.reason,
            "point": list(self.point),
            "direction": None if self.direction is None else list(self.direction),
            "semiaxis95": self.semiaxis95,
            "ci95": list(self.ci95),
            "margins": dict(self.margins),
            "warning": self.warning,
            "error": self.error,
            "error_xyz": list(self.error_xyz),
            "cov": [list(row) for row in self.cov],
            "angle95_deg": self.angle95_deg,
            "angle_err_deg": self.angle_err_deg,
            "outside95": self.outside95,
            "sigma0": math.sqrt(self.factor.sigma0_sq) if self.factor else math.nan,
            "sigma0_dof": self.factor.dof if self.factor else 0,
            "widened": self.widened,
            "noise": self.noise,
            "flagged": self.flagged,
            "disagreement": self.disagreement,
            "flagged_by": self.flagged_by,
            "lapsed": self.lapsed,
            "text": self.text(),
        }


def trial_results(
    trials: SessionTrials, options: EstimateOptions | None = None
) -> list[TrialResult]:
    """Every trial's result, estimated as the analysis estimates a session.

    In one batch, as :func:`twopose.solve.session.estimate_session` estimates a session, and
    compared with the truth by the analysis' rule (:func:`twopose.methods.truth.reported`).
    """
    return results_of(estimate_session(trials, options or EstimateOptions()))


def results_of(estimate: SessionEstimate) -> list[TrialResult]:
    """Every trial's result from the session's estimate (:func:`trial_results`)."""
    trials = estimate.trials
    est, rep = estimate.estimates, reported(estimate)
    tests = estimate.tests or TrialTests.none(len(trials))
    spread = uncertainty_columns(rep.error, rep.cov)
    line = trials.spec.estimates_line
    angle95, angle_err = _line_angles(estimate) if line else (None, None)
    with np.errstate(invalid="ignore"):  # a region's size: the covariance's square root
        widened = np.sqrt(est.widening)
    return [
        TrialResult(
            trial=int(trial),
            method=trials.method,
            units=trials.units,
            n_views=len(trials.views[i]),
            status=str(est.status[i]),
            reason=str(est.reason[i]),
            point=_triple(rep.point[i]),
            direction=_triple(est.direction[i]) if line else None,
            semiaxis95=float(spread["semiaxis95"][i]),
            ci95=_triple(np.array([spread[f"ci95_{a}"][i] for a in "xyz"])),
            margins={k: float(v[i]) for k, v in est.margins.items()},
            warning=estimate.warnings[i],
            error=float(np.linalg.norm(rep.error[i])),
            error_xyz=_triple(rep.error[i]),
            cov=tuple(_triple(row) for row in rep.cov[i]),
            angle95_deg=math.nan if angle95 is None else float(angle95[i]),
            angle_err_deg=math.nan if angle_err is None else float(angle_err[i]),
            factor=estimate.factor,
            widened=float(widened[i]) if np.isfinite(widened[i]) else 1.0,
            flagged=bool(tests.flagged[i]),
            disagreement=tests.words(i, Units(trials.units), len(trials.views[i])),
            flagged_by=tests.by(i),
        )
        for i, trial in enumerate(trials.trial_ids)
    ]


def _line_angles(estimate: SessionEstimate) -> tuple[F64, F64]:
    """Lines (T,): the direction's 95% half-angle and the angle to the true line.

    The half-angle (degrees) comes from the propagated direction covariance's largest
    variance across it; the angle error is trials.csv's ``angle_err_deg`` (NaN without
    truth).
    """
    est, truth = estimate.estimates, estimate.trials.truth
    cov = estimate.direction_cov()
    # A unit direction's covariance lies in the plane across it: a 2-dof region, its
    # semi-axis by the one rule (radians, as the direction is a unit vector).
    angle95 = np.degrees(semiaxis95(cov))
    with np.errstate(invalid="ignore"):
        _, _, angle_err, _ = line_errors(est.point, est.direction, truth[:, 0], truth[:, 1])
    return angle95, angle_err


def _triple(values: F64) -> tuple[float, float, float]:
    return (float(values[0]), float(values[1]), float(values[2]))
