"""A trial's result as the analysis reports it, for the live view.

A trial's result as the analysis reports it, for the recorder's live view (the thesis' GUI
computed the point on the spot, section 5.2.4).

:func:`trial_results` runs the analysis' own estimation
(:func:`twopose.session_estimate.estimate_session`: the same frame combination, solvers,
margins and uncertainty propagation) on the trials so far, and compares it with the truth
by the analysis' one rule (:func:`twopose.truth.reported`). The estimate and its error are
the analysis' exactly; the 95% region pools the frame scatter of the trials so far, where
the analysis pools the whole session.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twopose.arrays import F64
from twopose.estimate import EstimateOptions, EstimateSettings
from twopose.methods import spec_of
from twopose.session_estimate import SessionTrials, estimate_session
from twopose.truth import reported
from twopose.uncertainty import uncertainty_columns

__all__ = ["TrialResult", "trial_results"]


@dataclass(frozen=True, kw_only=True)
class TrialResult:
    """One trial's live result, in session units."""

    trial: int
    method: str
    units: str
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

    def text(self) -> str:
        """The result in one line, then its warning; or why there is none.

        One line: ``trial 3 (2 views): x 1.915 y 9.625 z 8.402 in; 95% within 0.183 in;
        error 0.052 in``, then the warning; or why there is no estimate.
        """
        head = f"trial {self.trial} ({self.n_views} views)"
        if self.status != "ok":
            return f"{head}: {self.status}: {self.reason}"
        x, y, z = self.point
        parts = [f"{head}: x {x:.3f} y {y:.3f} z {z:.3f} {self.units}"]
        if self.direction is not None:
            dx, dy, dz = self.direction
            parts.append(f"direction ({dx:.3f}, {dy:.3f}, {dz:.3f})")
        if math.isfinite(self.semiaxis95):
            parts.append(f"95% within {self.semiaxis95:.3f} {self.units}")
        if math.isfinite(self.error):
            parts.append(f"error {self.error:.3f} {self.units}")
        if self.warning:
            parts.append(f"WARNING {self.warning}")
        return "; ".join(parts)

    def to_json(self) -> dict[str, object]:
        """The result as a JSON-ready object for the web console and live view.

        The result as a JSON-ready object for the web console and the live view. NaN and
        infinity are left as floats: whoever serialises it uses the one encoder,
        :func:`twopose.jsonsafe.dumps`, which writes them as ``null``.
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
            "text": self.text(),
        }


def trial_results(
    trials: SessionTrials, options: EstimateSettings | None = None
) -> list[TrialResult]:
    """Every trial's result, estimated as the analysis estimates a session.

    Every trial's result, estimated in one batch as the analysis estimates a session
    (:func:`twopose.session_estimate.estimate_session`) and compared with the truth by the
    analysis' rule (:func:`twopose.truth.reported`).
    """
    estimate = estimate_session(trials, options or EstimateOptions())
    est, rep = estimate.estimates, reported(estimate)
    spread = uncertainty_columns(rep.error, rep.cov)
    line = spec_of(trials.method).estimates_line
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
        )
        for i, trial in enumerate(trials.trial_ids)
    ]


def _triple(values: F64) -> tuple[float, float, float]:
    return (float(values[0]), float(values[1]), float(values[2]))
