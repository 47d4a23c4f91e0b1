"""Each trial's result while the operator is still at the bench (the thesis' GUI computed
the point on the spot, section 5.2.4).

:class:`LiveResults` follows the procedure: the captures' live detections, which of them
the operator accepted, each trial's typed ground truth. After every accepted pose of a
trial with two or more, it solves every trial so far with the core's estimation
(:func:`recorder.live.trial_result.trial_results`, the analysis' own), so a third pose updates
the result, and an undone pose withdraws it. Nothing is written: the file holds what the
operator did, the analysis stays the reference.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from recorder.live.trial_result import TrialResult, results_of
from recorder.procedure.capture import CaptureResult
from twopose.camera.model import Camera
from twopose.display.scene import TrialScene, scene_of_views
from twopose.format.entries import GroundTruth, PlaneEntry, PoseEntry, TypedEntry
from twopose.guidance.advice import Advice
from twopose.methods.specs import Method, floors_unmeasured, spec_of
from twopose.rig.constants import RigConstants, check_applicable, corrected_ground, corrected_view
from twopose.solve.estimate import EstimateOptions, GroundSpec, PoseView, measure, pose_view
from twopose.solve.session import SessionTrials, estimate_session
from twopose.uncertainty.noise import VarianceFactor
from twopose.uncertainty.operator_pool import SessionNoise
from twopose.uncertainty.session_noise import session_base_in, session_statistics
from twopose.values.operators import operator_key
from twopose.values.units import Units

__all__ = ["LiveResults", "MappedAdvice", "guidance_options", "live_results"]

if TYPE_CHECKING:
    from pathlib import Path

    from recorder.live.operator_noise import LivePrior
    from recorder.procedure.capture import CaptureSettings
    from twopose.detect.clutter import Clutter
    from twopose.format.entries import SessionInfo
    from twopose.guidance.advice import Guidance


#: The advice with the map it is the best of (:attr:`twopose.guidance.advice.Advice.region_map`):
#: the console and the terminal show the map, a plan takes the suggestion.
MappedAdvice = Advice


class LiveResults:
    """The live results of a recording (see the module docstring)."""

    def __init__(
        self,
        method: Method,
        units: Units,
        cameras: Sequence[Camera],
        ground: PlaneEntry | None,
        options: EstimateOptions | None = None,
        rig: RigConstants | None = None,
    ) -> None:
        self.method, self.units = Method(method), units
        self.rig = rig  # a calibrated rig (`twopose-analyze rig`): views corrected by it
        self.options = options or EstimateOptions()
        self._cameras = {c.camera_id: c for c in cameras}
        self._ground: GroundSpec | None = ground.spec() if ground else None
        #: what the operator should know about the rig (e.g. a file without units)
        self.notes: list[str] = []
        if rig is not None:  # the analysis' own check (`run --rig`): units and plausibility
            self.notes = check_applicable(
                rig, Units(units), self._ground, (), "the rig file",
                cameras=[c.intrinsics for c in cameras],
            )  # fmt: skip
            self._ground = corrected_ground(self._ground, rig)
        self._captures: dict[int, PoseView] = {}  # capture number -> its detections
        #: the scene's clutter where the source knows it (the synthetic camera), else None
        self.known_clutter: Clutter | None = None
        #: capture number -> the blobs its last frame's detector turned down (u, v, r px)
        self._turned_down: dict[int, tuple[tuple[float, float, float], ...]] = {}
        #: the same as typed: guidance suggests where the operator puts the laptop, on the
        #: grid as typed, not where the rig says its camera then stands
        self._typed: dict[int, PoseView] = {}
        self._truth: dict[int, np.ndarray] = {}  # trial -> (2, 3)
        self._views: dict[int, list[PoseView]] = {}  # trial -> its accepted poses, in order
        self._solved: dict[int, tuple[int, ...]] = {}  # trial -> captures last solved
        self.results: dict[int, TrialResult] = {}  # trial -> its latest result
        #: what the trials so far say of the operator's placing (the noise file keeps it)
        self.statistics: SessionNoise | None = None
        #: the operator's earlier sessions: the prior at the base the poses type
        self.operator_prior: LivePrior | None = None

    def begin(self, trial: int, entries: Iterable[TypedEntry]) -> None:
        """A trial begins; its ground truth (if typed) is among ``entries``."""
        truth = np.full((2, 3), np.nan)
        for entry in entries:
            if isinstance(entry, GroundTruth) and entry.trial == trial:
                points = np.array(entry.points_grid, dtype=np.float64)
                truth = points[[0, -1]]  # a point twice, or the line's two points
        self._truth[trial] = truth

    def captured(self, entry: PoseEntry, result: CaptureResult) -> None:
        """A capture ended: keep its frames' detections under its capture number."""
        if entry.capture is None or not result.feedback:
            return
        camera = self._cameras[entry.camera_id]
        fb = result.feedback
        view = pose_view(
            entry,
            camera.intrinsics,
            [f.found for f in fb],
            [f.centroid_px for f in fb],
            [f.theta_deg for f in fb],
            camera.intrinsics_sigma,
        )
        self._typed[entry.capture] = view
        self._turned_down[entry.capture] = fb[-1].turned_down_px
        self._captures[entry.capture] = view if self.rig is None else corrected_view(view, self.rig)

    def update(self, trial: int, accepted: Mapping[int, PoseEntry]) -> TrialResult | None:
        """The trial's accepted poses now (pose -> entry): its new result when they changed
        and number two or more (also when they dropped below two: then None is kept)."""
        captures = _captures_of(accepted)
        if self._solved.get(trial) == captures:
            return None
        self._solved[trial] = captures
        self._views[trial] = [self._captures[c] for c in captures if c in self._captures]
        if len(self._views[trial]) < 2:
            self.results.pop(trial, None)
            return None
        before = self.results
        self.results = self._solve(self._views, keep=True)
        lapsed = _lapsed(before, self.results, trial)
        if lapsed:
            self.results[trial] = dataclasses.replace(self.results[trial], lapsed=lapsed)
        return self.results[trial]

    def preview(self, trial: int, accepted: Mapping[int, PoseEntry]) -> TrialResult | None:
        """The result ``trial`` would have with these accepted poses (the capture awaiting
        a decision among them), solved exactly as :meth:`update` would solve it, without
        changing what is kept. None with fewer than two poses."""
        views = [self._captures[c] for c in _captures_of(accepted) if c in self._captures]
        if len(views) < 2:
            return None
        return self._solve({**self._views, trial: views})[trial]

    def _solve(
        self, views: Mapping[int, list[PoseView]], *, keep: bool = False
    ) -> dict[int, TrialResult]:
        """Every trial with two or more poses, in one batch (the 95% regions pool their
        frame scatter, as the analysis pools a session's); ``keep``: their misclosures
        are the session's statistics now (:attr:`statistics`)."""
        trials = sorted(t for t, v in views.items() if len(v) >= 2)
        session = SessionTrials(
            method=self.method,
            units=self.units,
            trial_ids=tuple(trials),
            views=[views[t] for t in trials],
            truth=np.array([self._truth.get(t, np.full((2, 3), np.nan)) for t in trials]),
            ground=self._ground,
        )
        base_in, options = session_base_in(session, self.options), self.options
        prior = self.operator_prior.at(base_in) if self.operator_prior else None
        if prior is not None:  # a typed session's: known once its poses typed their base
            options = dataclasses.replace(
                options, noise=dataclasses.replace(options.noise, prior=prior)
            )
        estimate = estimate_session(session, options)
        if keep:
            self.statistics = session_statistics("", estimate.misclosure, estimate.tests, base_in)
        return dict(zip(trials, results_of(estimate), strict=True))

    def advise(self, trial: int, guidance: Guidance) -> MappedAdvice | None:
        """After a decision: the trial complete, or its next pose (:mod:`twopose.guidance.advice`),
        from its accepted poses and its result now, with the map of every reachable pose
        beside it (:attr:`MappedAdvice.region_map`); None before its first pose."""
        from twopose.guidance.advice import advise

        views = [self._typed[c] for c in self._solved.get(trial, ()) if c in self._typed]
        if not views:
            return None
        session = SessionTrials(
            method=self.method,
            units=self.units,
            trial_ids=(trial,),
            views=[views],
            truth=self._truth.get(trial, np.full((2, 3), np.nan))[None],
            ground=self._ground,
        )
        result = self.results.get(trial) if len(views) >= 2 else None
        ok = result is not None and result.status == "ok"
        point = np.asarray(result.point) if ok and result is not None else None
        # The session's variance factor, never one estimated from predicted views.
        options = guidance_options(self.options, self.results.values())
        return advise(
            session,
            guidance,
            options,
            point=None if point is None else point.tolist(),
            region95=result.semiaxis95 if ok and result is not None else math.nan,
            clutter=self.clutter_for(self._solved.get(trial, ())),
        )

    def clutter_for(self, captures: Sequence[int]) -> Clutter | None:
        """What guidance keeps the target from being seen over: the scene's clutter where
        the source knows it, else the blobs turned down in the last frames of the last of
        ``captures`` that saw the target (:func:`twopose.detect.clutter.seen_clutter`)."""
        from twopose.detect.clutter import seen_clutter

        if self.known_clutter is not None:
            return self.known_clutter
        seen = [c for c in captures if c in self._typed and self._typed[c].found.any()]
        if not seen:
            return None
        return seen_clutter(self._typed[seen[-1]], self._turned_down.get(seen[-1], ()),
                            self._ground, Units(self.units))  # fmt: skip

    def remember(self, info: SessionInfo, out: Path, notice: Callable[[str], None]) -> None:
        """What the recording said of its operator's placing, kept in their noise file
        (:mod:`recorder.live.operator_noise`); what went wrong is told to ``notice``."""
        from recorder.live.operator_noise import remember_session

        trouble = remember_session(
            info.operator, info.method, info.units, out, self.options, self.statistics
        )
        if trouble:
            notice(trouble)

    def scene(self, trial: int) -> TrialScene | None:
        """The trial's geometry for the live view's 3-D panel (None: no result yet)."""
        result = self.results.get(trial)
        if result is None:
            return None
        views = self._views[trial]
        measurements, _, _ = measure([views], self.options)
        return scene_of_views(
            trial,
            self.method,
            result.status,
            views,
            measurements[0],
            np.array(result.point),
            None if result.direction is None else np.array(result.direction),
            self._truth.get(trial, np.full((2, 3), np.nan)),
            np.array(result.cov, dtype=np.float64).reshape(3, 3),
        )


def _lapsed(before: Mapping[int, TrialResult], now: Mapping[int, TrialResult], trial: int) -> str:
    """Other trials flagged before ``trial``'s new pose and not now, in words ("": none).

    A trial tested against the rest passes where the rest now scatters as much (the session
    contradicts the typed placing, and the multiplier grows): what was said of it may still
    hold, so its flag is never withdrawn without a word (a new user's r6 G1).
    """
    said = [
        f"trial {t} no longer flagged: beside trial {trial} the session's trials scatter "
        f"more than typed, which its poses fit; what was said of it may still hold "
        f"({before[t].disagreement})"
        for t in sorted(before)
        if t != trial and before[t].flagged and t in now and not now[t].flagged
    ]
    return "; ".join(said)


def _captures_of(accepted: Mapping[int, PoseEntry]) -> tuple[int, ...]:
    """The capture numbers of the accepted poses, in pose order."""
    return tuple(e.capture for _, e in sorted(accepted.items()) if e.capture is not None)


def live_results(
    info: SessionInfo,
    cameras: Sequence[Camera],
    ground: PlaneEntry | None,
    settings: CaptureSettings,
) -> LiveResults:
    """The live results of a recording: its regions from the rig file's placing sigma (or
    each pose's typed one), the operator's earlier sessions their prior
    (:mod:`recorder.live.operator_noise`); what they start from is said as it starts, and
    a camera whose image size the detector's floor was not measured at
    (:func:`twopose.methods.specs.floors_unmeasured`)."""
    from recorder.live.operator_noise import live_prior

    estimate, placing_words = _placing_of_operator(settings, info)
    estimate, prior_words, prior = live_prior(info.operator, info.method, estimate, info.units)
    results = LiveResults(info.method, info.units, cameras, ground, estimate, settings.rig)
    results.operator_prior = prior
    results.notes.insert(0, placing_words)
    if prior_words:
        results.notes.insert(1, prior_words)
    floor = floors_unmeasured((c.intrinsics.width, c.intrinsics.height) for c in cameras)
    if floor and spec_of(info.method).measures:  # a camera of another image size
        results.notes.append(floor)
    return results


def _placing_of_operator(
    settings: CaptureSettings, info: SessionInfo
) -> tuple[EstimateOptions, str]:
    """The live estimate's options and its placing sigma in words: the rig file's
    ``[placing]`` when it is this session's operator's (or names none), else each pose's
    typed resolution (another operator's board is not this one's hand; the analysis' rule,
    :meth:`analysis.rig.scope.RigUse.placing_for`)."""
    estimate = settings.estimate_options()
    placing = settings.placing
    theirs = {operator_key(n) for n in placing.operators} if placing is not None else set()
    if placing is None or not placing.operators or operator_key(info.operator) in theirs:
        return estimate, settings.placing_words(info.units)
    noise = dataclasses.replace(estimate.noise, placing=None)
    said = (
        f"placing sigma: typed (each pose's recorded resolution): the rig file's [placing] "
        f"({placing.measured_by}) is operator {', '.join(placing.operators)}'s, not "
        f"{info.operator.strip() or 'this session'}'s"
    )
    return dataclasses.replace(estimate, noise=noise), said


def guidance_options(options: EstimateOptions, results: Iterable[TrialResult]) -> EstimateOptions:
    """``options`` with the session's variance factor fixed, for guidance's predictions.

    The factor its solved trials estimated (or an untested one before any): a predicted
    view has no noise of its own, so guidance never estimates a factor from it, and its
    predicted regions widen as the session's did. A factor the options give stands.
    """
    if options.noise.factor is not None or not options.noise.test_redundancy:
        return options
    factor = next((r.factor for r in results if r.factor is not None), None)
    fixed = factor or VarianceFactor(sigma0_sq=math.nan, dof=0)
    return dataclasses.replace(options, noise=dataclasses.replace(options.noise, factor=fixed))
