"""A session's trials in, one value of every estimate out: the one estimation entry point.

:class:`SessionTrials` is a session's trials as one value (what the analysis' replay and
the recorder's live result both build); :func:`estimate_session` runs the whole sequence
on it once: each pose's frames combined (:func:`twopose.solve.estimate.measure`), every detected
trial solved by every estimator in one batch, the input covariance propagated, the
degeneracy margins and their warnings. Its :class:`SessionEstimate` is what the tables,
the live result, the rig fit and the 3-D scenes take. Only the blunder test of
:mod:`twopose.uncertainty.blunders` reads the truth, as :mod:`twopose.methods.truth` reports it.

(Near 600 lines: the one estimation entry point and the values it takes and gives; the noise
model (:mod:`twopose.uncertainty.session_noise`), the truth and the solvers are their own modules.)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64, Bools, Ints
from twopose.camera.model import camera_centres
from twopose.detect.frames import PoseMeasurement, combine_frames
from twopose.methods.specs import Method, MethodSpec, spec_of
from twopose.methods.truth import reported
from twopose.rig.carried import rig_carried, with_carried, with_rig_dominance
from twopose.solve.estimate import (
    EstimateOptions,
    GroundSpec,
    PoseView,
    Solved,
    ViewBatch,
    across_line_sigma_px,
    input_covariance,
    margin_warnings,
    measure,
    scatters_of,
    shared_intrinsics,
    solve_batch,
    thesis_direction,
    thesis_estimate,
)
from twopose.solve.nview import image_lines, triangulate_lines
from twopose.solve.optimal_lines import centroid_segments, optimal_lines
from twopose.uncertainty.blunders import TrialTests
from twopose.uncertainty.misclosure import Misclosure
from twopose.uncertainty.noise import VarianceFactor
from twopose.uncertainty.propagate import (
    SECOND_ORDER,
    Propagated,
    Shared,
    dominant_input,
    pooled_scatter,
    propagate,
    region_widening,
)
from twopose.uncertainty.session_noise import (
    noise_of,
    placed,
    placing_parts,
    placing_sigma,
    placing_sigmas,
    placing_source,
    region_multipliers,
    with_one_target,
    with_own_truth,
)
from twopose.values.units import Units

__all__ = [
    "Estimates",
    "SessionEstimate",
    "SessionTrials",
    "Uncertainty",
    "estimate_session",
    "placing_sigma",
    "placing_sigmas",
    "placing_source",
    "running_estimates",
]


_A = TypeVar("_A", bound=NDArray[Any])


@dataclass(frozen=True, kw_only=True)
class SessionTrials:
    """A session's trials, as estimation and the comparison with the truth take them.

    ``views`` holds per trial its usable poses (fewer than two: the trial is incomplete);
    ``truth`` is (T, 2, 3), each trial's true point (twice) or line's two points, NaN where
    unknown; ``ground`` is the ground plane (method 2).
    """

    method: Method
    units: Units
    trial_ids: tuple[int, ...]
    views: list[list[PoseView]]
    truth: F64
    ground: GroundSpec | None = None

    def __len__(self) -> int:
        """The number of trials."""
        return len(self.trial_ids)

    @property
    def spec(self) -> MethodSpec:
        """The trials' method's spec: what estimating them reads of it."""
        return spec_of(self.method)


@dataclass(frozen=True, kw_only=True)
class Uncertainty:
    """Per trial: an estimate's covariance and the input dominating it.

    Per trial (T rows, NaN and "" where not ok): an estimate's propagated covariance (T, 3,
    3), the input dominating its variance and that input's share (T,), and how much the
    noise model's test widened it (T,).
    """

    cov: F64
    dominant: NDArray[np.object_]
    dominant_share: F64
    #: The 95% region's largest variance against the typed placing sigma's (1: unchanged).
    widening: F64
    #: (T, 2, 3, 3) the region at the sigma it starts from: the part the placing does not
    #: give, and the part it does (:mod:`twopose.uncertainty.target_scatter`; None: none).
    parts: F64 | None = None


@dataclass(frozen=True, kw_only=True)
class Estimates:
    """Per trial (T rows, NaN where not solved): every estimate, its status and uncertainty.

    A line's ``point`` is the thesis' solved point on it, and ``cov`` that point's
    covariance across the line; :func:`twopose.methods.truth.reported` moves both to the point the
    trial reports.
    """

    status: NDArray[np.str_]  # ok, degenerate, no_detection, incomplete
    reason: NDArray[np.str_]
    point: F64  # (T, 3) the thesis' estimate
    direction: F64  # (T, 3) lines: the unit direction
    optimal: F64  # (T, 3) points: the reprojection-optimal estimate
    weighted_line: F64  # (T, 2, 3) lines: the weighted/robust fit's point and direction
    optimal_line: F64  # (T, 2, 3) lines: the reprojection-optimal line's point and direction
    conditioning: F64  # (T,)
    margins: dict[str, F64]  # (T,) degrees, by column name
    cov: F64  # (T, 3, 3) of ``point``
    dominant: NDArray[np.object_]  # (T,) the input dominating the variance ("" if none)
    dominant_share: F64  # (T,)
    #: (T,) the region's largest variance against the typed placing sigma's (1: unchanged;
    #: NaN: no region): :mod:`twopose.uncertainty.noise`'s re-propagation and F quantile.
    widening: F64
    parts: F64 | None = None  # (T, 2, 3, 3) as :attr:`Uncertainty.parts`


@dataclass(frozen=True, kw_only=True)
class _Propagation:
    """What propagating the thesis' estimate needs again.

    The solved rows' batch, their input covariance and shared intrinsics (lines re-propagate
    at their reported point).
    """

    rows: Ints
    batch: ViewBatch
    cov_in: F64
    shared: Shared | None
    solved: Solved
    #: The session's noise every region is propagated and widened with (None: none).
    factor: VarianceFactor | None = None
    #: Which trials are flagged and their own misfit (None: none tested).
    tests: TrialTests | None = None

    def propagated(self, estimate: Callable[[F64], F64]) -> Propagated:
        """``estimate``'s covariance from the rows' inputs.

        To second order: every region's rule (:data:`twopose.uncertainty.propagate.SECOND_ORDER`).
        """
        return propagate(estimate, self.batch.inputs, self.cov_in, shared=self.shared,
                         second_order=SECOND_ORDER)  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class SessionEstimate:
    """Everything :func:`estimate_session` computed for a session's trials, as one value."""

    trials: SessionTrials
    measurements: list[list[PoseMeasurement]]  # per trial (empty: incomplete)
    complete: Bools  # (T,) at least two usable poses
    detected: Bools  # (T,) complete and every pose detected
    estimates: Estimates
    warnings: list[str]  # per trial, the margins under their thresholds ("" when none)
    options: EstimateOptions
    #: The session's a-posteriori variance factor (:mod:`twopose.uncertainty.noise`): estimated from
    #: its trials' misclosures, or the one the options gave; None when not tested.
    factor: VarianceFactor | None = None
    #: Per trial, the misclosure's chi-square and dof (None: not estimated here).
    misclosure: Misclosure | None = None
    #: Per trial, whether its poses disagree and which one (:mod:`twopose.uncertainty.blunders`).
    tests: TrialTests | None = None
    _propagation: _Propagation | None = None

    def uncertainty_at(self, reference: F64) -> Uncertainty:
        """The thesis' estimate's uncertainty, lines reported near ``reference``.

        The thesis' estimate's uncertainty with lines reported at their point nearest
        ``reference`` (T, 3), held fixed; points and ground points do not depend on it.
        """
        T = len(self.trials)
        if self._propagation is None:
            return _no_uncertainty(T)
        p = self._propagation
        estimate = thesis_estimate(
            self.trials.method, p.batch, self.trials.ground, self.options, reference[p.rows]
        )
        propagated = p.propagated(estimate)
        rig = rig_carried(
            self.options, self.trials.method, p.batch, self.trials.ground, reference[p.rows]
        )
        return _uncertainty(T, p, propagated, rig)

    def direction_cov(self) -> F64:
        """(T, 3, 3) lines: the covariance of each ok trial's unit direction (NaN else).

        Propagated from the same inputs as the point's; it lies across the direction.
        """
        T = len(self.trials)
        cov = np.full((T, 3, 3), np.nan)
        p = self._propagation
        if p is None or p.solved.direction is None:
            return cov
        d = p.solved.direction
        f = thesis_direction(p.batch, self.options, np.nan_to_num(d))
        propagated = p.propagated(f)
        ok = p.solved.status == "ok"
        placing = np.add(*placing_parts(propagated, p.cov_in))
        scale = region_multipliers(propagated.cov_grid, placing, p.factor, p.tests, p.rows)
        cov[p.rows[ok]] = (propagated.cov_grid * scale[:, None, None])[ok]
        return cov


def estimate_session(
    trials: SessionTrials,
    options: EstimateOptions,
    *,
    line_fits: bool = True,
    report_near: F64 | None = None,
) -> SessionEstimate:
    """Solve every detected trial with every estimator, and propagate.

    In one batch; each trial's input covariance is propagated: pixels from the frame scatter, poses
    from the typed resolution, intrinsics from the calibration's 1-sigma (one error for all views
    of a camera).

    Each pose's frames are combined first (the thesis' mean, or median / robust); trials
    with fewer than two poses are ``incomplete``, and those with a pose never detected
    ``no_detection``.

    Parameters
    ----------
    trials : SessionTrials
        The session's trials as replayed: each pose's typed view and its frames'
        detections (:func:`analysis.session.pipeline.replay_views` or the recorder's live result).
    options : EstimateOptions
        How frames are combined and when a trial is degenerate or warned.
    line_fits : bool
        Lines: also the weighted and the reprojection-optimal line (iterative); without
        them (NaN), what the thesis' line and its region need, as guidance ranks poses.
    report_near : (T, 3) ndarray, optional
        Lines: propagate each one's point nearest this point (NaN rows: the solved point),
        where :func:`twopose.methods.truth.reported` reports it, at once (guidance ranks many).

    Returns
    -------
    SessionEstimate
        Every estimator's estimate per trial, its status and margins, and its propagated
        covariance.
    """
    spec = trials.spec  # the method's spec, read once for the whole estimate
    measurements, complete, detected = measure(trials.views, options)
    solvable = np.flatnonzero(detected)
    if not solvable.size:
        est = _unsolved(len(trials), spec, complete)
        return _session_estimate(trials, measurements, complete, detected, est, options)
    rows_m = [measurements[i] for i in solvable]
    rows_v = [trials.views[i] for i in solvable]
    batch = ViewBatch.of(rows_m, rows_v)
    solved = solve_batch(trials.method, batch, trials.ground, options)
    # Each pose's frame scatter, once, for the pooled and the per-pose covariances.
    scatters = scatters_of(trials.views, measurements)
    cov_in = input_covariance(
        rows_m,
        rows_v,
        [scatters[i] for i in solvable],
        pooled_scatter([s for row in scatters for s in row]),
        batch,
        median=options.combine == "median",
        floor=spec.detector_floor,
        t_sigma=placing_sigma(trials, options),
    )
    context = _Propagation(
        rows=solvable,
        batch=batch,
        cov_in=cov_in,
        shared=shared_intrinsics(rows_v, batch),
        solved=solved,
    )
    ok = solved.status == "ok"
    noise = noise_of(
        trials.method,
        batch.rows(ok),
        cov_in[ok],
        _shared_rows(context.shared, ok),
        solvable[ok],
        len(trials),
        options,
    )
    factor = noise.factor
    context = dataclasses.replace(
        context, factor=factor, tests=noise.tests, cov_in=placed(cov_in, factor)
    )
    est = _solved_estimates(
        trials, complete, context, options, line_fits=line_fits, report_near=report_near
    )
    settled = with_one_target(noise, trials.truth, est.point, est.parts)
    for _ in range(2):  # a trial off the others of its target, then off its own truth
        if settled is not noise:  # kept out of the pool: the factor and regions again
            noise, factor = settled, settled.factor
            context = dataclasses.replace(
                context, factor=factor, tests=noise.tests, cov_in=placed(cov_in, factor)
            )
            est = _solved_estimates(
                trials, complete, context, options, line_fits=line_fits, report_near=report_near
            )
        out = dataclasses.replace(
            _session_estimate(trials, measurements, complete, detected, est, options, context),
            factor=factor, misclosure=noise.misclosure, tests=noise.tests,
        )  # fmt: skip
        if noise.misclosure is None or not np.isfinite(trials.truth).any():
            break  # not tested (a given factor: guidance's views), or no truth to test against
        rep = reported(out)  # the region each trial reports, after lambda, and its truth
        if (settled := with_own_truth(noise, rep.error, rep.cov)) is noise:
            break
    return out


def _shared_rows(shared: Shared | None, rows: Bools) -> Shared | None:
    """The shared inputs of some of the batch's rows."""
    if shared is None:
        return None
    return Shared(values=shared.values[rows], group=shared.group[rows], cov=shared.cov[rows])


def _session_estimate(
    trials: SessionTrials,
    measurements: list[list[PoseMeasurement]],
    complete: Bools,
    detected: Bools,
    est: Estimates,
    options: EstimateOptions,
    context: _Propagation | None = None,
) -> SessionEstimate:
    return SessionEstimate(
        trials=trials,
        measurements=measurements,
        complete=complete,
        detected=detected,
        estimates=est,
        warnings=margin_warnings(est.status, est.margins, options, trials.spec.seen_on),
        options=options,
        _propagation=context,
    )


def _with_rows(base: _A, rows: Ints, values: NDArray[Any]) -> _A:
    """A copy of ``base`` (T, ...) with the solved rows' ``values`` at their trials."""
    out = base.copy()
    out[rows] = values
    return out


def _unsolved(T: int, spec: MethodSpec, complete: Bools) -> Estimates:
    """Every trial as not solved: incomplete, or missing a detection."""
    status = np.where(complete, "no_detection", "incomplete").astype("<U12")
    reason = np.where(
        complete, "no frame of a pose was detected", "fewer than two complete captures"
    ).astype("<U64")
    none = _no_uncertainty(T)
    return Estimates(
        status=status,
        reason=reason,
        point=np.full((T, 3), np.nan),
        direction=np.full((T, 3), np.nan),
        optimal=np.full((T, 3), np.nan),
        weighted_line=np.full((T, 2, 3), np.nan),
        optimal_line=np.full((T, 2, 3), np.nan),
        conditioning=np.full(T, np.nan),
        margins={name: np.full(T, np.nan) for name in spec.margins},
        cov=none.cov,
        dominant=none.dominant,
        dominant_share=none.dominant_share,
        widening=none.widening,
    )


def _no_uncertainty(T: int) -> Uncertainty:
    return Uncertainty(
        cov=np.full((T, 3, 3), np.nan),
        dominant=np.full(T, "", dtype=object),
        dominant_share=np.full(T, np.nan),
        widening=np.full(T, np.nan),
    )


def _solved_estimates(
    trials: SessionTrials,
    complete: Bools,
    p: _Propagation,
    options: EstimateOptions,
    *,
    line_fits: bool = True,
    report_near: F64 | None = None,
) -> Estimates:
    """The solved rows' estimates at their trials, with every other trial unsolved."""
    T, rows, solved = len(trials), p.rows, p.solved
    base = _unsolved(T, trials.spec, complete)
    # Propagated at the solved point: a line's reported point is chosen by twopose.methods.truth.
    near = solved.point
    if report_near is not None:
        near = np.where(np.isfinite(report_near[rows]), report_near[rows], solved.point)
    uncertainty = _uncertainty(
        T,
        p,
        p.propagated(thesis_estimate(trials.method, p.batch, trials.ground, options, near)),
        rig_carried(options, trials.method, p.batch, trials.ground, solved.point),
    )
    lines = trials.spec.estimates_line and line_fits
    return Estimates(
        status=_with_rows(base.status, rows, solved.status),
        reason=_with_rows(base.reason, rows, solved.reason),
        point=_with_rows(base.point, rows, solved.point),
        direction=base.direction
        if solved.direction is None
        else _with_rows(base.direction, rows, solved.direction),
        optimal=base.optimal
        if solved.optimal is None
        else _with_rows(base.optimal, rows, solved.optimal),
        weighted_line=_with_rows(base.weighted_line, rows, _weighted_lines(p, options))
        if lines
        else base.weighted_line,
        optimal_line=_with_rows(base.optimal_line, rows, _optimal_lines(p, options))
        if lines
        else base.optimal_line,
        conditioning=_with_rows(base.conditioning, rows, solved.conditioning),
        margins={
            k: v if k not in solved.margins else _with_rows(v, rows, solved.margins[k])
            for k, v in base.margins.items()
        },
        cov=uncertainty.cov,
        dominant=uncertainty.dominant,
        dominant_share=uncertainty.dominant_share,
        widening=uncertainty.widening,
        parts=uncertainty.parts,
    )


def _uncertainty(
    T: int, p: _Propagation, propagated: Propagated, carried: F64 | None = None
) -> Uncertainty:
    """The covariance and dominant input of every ok trial (T rows).

    ``carried``: the rig's constants' covariance (:func:`twopose.rig.carried.rig_carried`).
    """
    ok, cov = p.solved.status == "ok", propagated.cov_grid
    lam = 1.0 if p.factor is None else p.factor.placing_variance
    first, second = placing_parts(propagated, p.cov_in)
    placing = first + second
    # the region the typed placing sigma gives: the placing's part back at 1 / lambda (its
    # second-order part, at 1 / lambda^2)
    model = cov if lam == 1.0 else cov - (1 - 1 / lam) * first - (1 - 1 / lam**2) * second
    typed = first / lam + second / lam**2  # the placing's part of ``model``
    if p.solved.direction is not None:
        # A line's reported point moves only across the line to first order (its error
        # is perpendicular by construction): keep the covariance of that offset.
        d = p.solved.direction
        across = np.eye(3) - np.einsum("ti,tj->tij", d, d)
        cov, model = across @ cov @ across, across @ model @ across
        placing, typed = across @ placing @ across, across @ typed @ across
    cov = cov * region_multipliers(cov, placing, p.factor, p.tests, p.rows)[:, None, None]
    parts = np.stack([model - typed, typed], axis=1)  # before the rig's (shared by all)
    # the rig's constants: carried beside the views' noise, never widened by its test
    cov, model, carried = with_carried(cov, model, carried, p.solved.direction)
    widening = region_widening(cov, model)
    names, share = dominant_input(propagated.variance_by_group, propagated.shared_variance)
    names, share = with_rig_dominance(names, share, propagated, carried)
    none, rows = _no_uncertainty(T), p.rows[ok]
    return Uncertainty(
        cov=_with_rows(none.cov, rows, cov[ok]),
        dominant=_with_rows(none.dominant, rows, np.array(names, dtype=object)[ok]),
        dominant_share=_with_rows(none.dominant_share, rows, share[ok]),
        widening=_with_rows(none.widening, rows, widening[ok]),
        parts=_with_rows(np.full((T, 2, 3, 3), np.nan), rows, parts[ok]),
    )


def _weighted_lines(p: _Propagation, options: EstimateOptions) -> F64:
    """The weighted/robust line fit (R, 2, 3) beside the thesis' one.

    (R, 2, 3) the weighted/robust line fit beside the thesis' one, weighted by each view's
    noise: each solved row's point and direction.
    """
    batch, cov_in = p.batch, p.cov_in
    weighted = triangulate_lines(
        image_lines(batch.inputs[..., :2], batch.inputs[..., 2]),
        batch.P(),
        valid=batch.valid,
        estimator="weighted",
        sigma_px=across_line_sigma_px(batch.inputs[..., 2], cov_in),
        sigma_pose=np.stack(
            [np.sqrt(cov_in[..., 3, 3]), np.deg2rad(np.sqrt(cov_in[..., 6, 6]))], axis=-1
        ),
        min_conditioning=options.min_conditioning,
    )
    return np.stack([weighted.point_grid, weighted.direction_grid], axis=1)


def _optimal_lines(p: _Propagation, options: EstimateOptions) -> F64:
    """(R, 2, 3) the reprojection-optimal line beside the thesis' one.

    Each view's centroid and angle become their equivalent segment
    (:func:`centroid_segments`) for their noise: the frame scatter plus the typed pose's,
    seen in the image at the thesis' line (a translation error moves the line across by
    ``f sigma_t / depth``, an angle error by ``f sigma_r`` and turns it by ``sigma_r``),
    the segment no longer than the image allows. With two views it is the thesis' line.
    """
    batch, cov_in = p.batch, p.cov_in
    theta = batch.inputs[..., 2]
    P = batch.P()
    depth = np.linalg.norm(camera_centres(P) - p.solved.point[:, None], axis=-1)
    f = batch.intrinsics[..., 0]
    sigma_r = np.deg2rad(np.sqrt(cov_in[..., 6, 6]))
    with np.errstate(invalid="ignore", divide="ignore"):
        pose_px2 = (f / depth) ** 2 * cov_in[..., 3, 3] + (f * sigma_r) ** 2
    var_theta = np.deg2rad(np.sqrt(np.abs(cov_in[..., 2, 2]))) ** 2 + sigma_r**2
    across = np.sqrt(
        across_line_sigma_px(theta, cov_in) ** 2 + np.where(np.isfinite(pose_px2), pose_px2, 0)
    )
    segments, sigma = centroid_segments(
        batch.inputs[..., :2],
        theta,
        across,
        np.degrees(np.sqrt(np.where(np.isfinite(var_theta), var_theta, 0.0))),
        # at most from the principal point to the image's nearer edge
        np.minimum(batch.intrinsics[..., 2], batch.intrinsics[..., 3]),
    )
    optimal = optimal_lines(
        segments,
        P,
        valid=batch.valid,
        sigma_px=np.where(batch.valid, sigma, 1.0),
        min_conditioning=options.min_conditioning,
    )
    return np.stack([optimal.point_grid, optimal.direction_grid], axis=1)


def running_estimates(estimate: SessionEstimate) -> tuple[list[tuple[int, int]], Solved | None]:
    """The estimate from the first 1..K frames of each pose (the thesis' Figures 22-23).

    Returns ``(trial index, frames used)`` per row and the rows' solution (None: no rows).
    """
    trials, options = estimate.trials, estimate.options
    rows_m: list[list[PoseMeasurement]] = []
    rows_v: list[list[PoseView]] = []
    keys: list[tuple[int, int]] = []
    for i, row in enumerate(trials.views):
        if not estimate.detected[i]:
            continue
        for n in range(1, min(len(v.found) for v in row) + 1):
            ms = [
                combine_frames(v.centroids[:n], v.thetas[:n], v.found[:n], options.combine)
                for v in row
            ]
            if all(m.found for m in ms):
                rows_m.append(ms)
                rows_v.append(row)
                keys.append((i, n))
    if not keys:
        return keys, None
    return keys, solve_batch(trials.method, ViewBatch.of(rows_m, rows_v), trials.ground, options)
