"""Plan files: a whole session to record unattended (scripted rigs, tests).

:func:`load_plan` (:mod:`recorder.setup.plan_file`) reads and checks a plan (TOML, see
docs/recording.md); :func:`record_plan` runs it through the one procedure loop
(:func:`recorder.procedure.recording.record`).
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from typing_extensions import override

from recorder.procedure.capture import CaptureResult, CaptureSettings, FrameFeedback
from recorder.procedure.driver import Decision, Driver, Placement
from recorder.procedure.recording import record
from recorder.procedure.summary import RecordingSummary
from recorder.setup.plan_file import Plan, PlannedPose, PlannedTrial, load_plan
from recorder.sources.registry import FrameSource
from twopose.errors import SourceError
from twopose.format.entries import (
    GroundTruth,
    PoseEntry,
    SessionInfo,
    TruthKind,
    TypedEntry,
)
from twopose.guidance.advice import THESIS_MOVE_IN
from twopose.values.checks import Vec3
from twopose.values.units import Units, unit_factor

if TYPE_CHECKING:
    from recorder.live.trial_result import TrialResult
    from recorder.live.view import LiveView
    from recorder.setup.continuation import Continued
    from twopose.guidance.advice import Advice
    from twopose.rig.constants import RigConstants
    from twopose.uncertainty.noise import PlacingSigma


__all__ = [
    "Plan",
    "PlannedPose",
    "PlannedTrial",
    "load_plan",
    "record_plan",
]


class _PlanDriver(Driver):
    """Every planned pose, accepted (a plan cannot ask: a capture whose target was rarely
    or never found is recorded too, and the capture report says so); a failed capture ends
    the recording with an error."""

    unattended = True

    def __init__(
        self,
        plan: Plan,
        on_capture: Callable[[int, int, CaptureResult], None] | None,
        on_result: Callable[[TrialResult], None] | None = None,
        on_advice: Callable[[int, Advice], None] | None = None,
    ) -> None:
        self.plan = plan
        self.on_capture = on_capture
        self.on_result = on_result
        self.on_advice = on_advice
        self.path = Path()
        self.rig_problem = ""  # a board session: why its poses cannot determine the rig
        self.suggested: Vec3 | None = None  # a guided trial's next pose, as advised
        self.typed: Vec3 = (0.0, 0.0, 0.0)  # the last pose typed
        self.placing = np.random.default_rng(plan.placing_seed)

    @override
    def start(self, source: object, path: Path) -> None:
        self.path = path

    @override
    def finish(self, summary: RecordingSummary) -> None:
        import sys

        if self.rig_problem:  # the plan's poses, all recorded, cannot calibrate the rig
            print(f"  WARNING rig: {self.rig_problem}", file=sys.stderr, flush=True)

    def next_trial(self, trial: int) -> bool:
        return trial - self.first_trial < len(self.plan.trials)

    def trial_entries(self, trial: int) -> Sequence[TypedEntry]:
        truth = self.plan.trials[trial - self.first_trial].ground_truth
        kind: TruthKind | None = self.plan.spec.truth_kind
        if not truth or kind is None:
            return ()
        return (GroundTruth(trial=trial, kind=kind, points_grid=truth),)

    def poses_in(self, trial: int) -> int:
        planned = self.plan.trials[trial - self.first_trial]
        return planned.max_poses if planned.max_poses is not None else len(planned.poses)

    def place(self, trial: int, pose: int) -> Placement:
        planned = self.plan.trials[trial - self.first_trial]
        if not planned.guided:
            return self._placement(trial, pose, planned.poses[pose - 1])
        assert planned.start is not None
        if pose == 1:
            t_grid = planned.start.t_grid
        elif self.suggested is not None:
            t_grid = self.suggested
        else:  # no reachable pose keeps the target in view: the thesis' move
            f = unit_factor(Units.IN, self.plan.units)
            (x, y, z), (dx, dy, dz) = self.typed, THESIS_MOVE_IN
            t_grid = (x + dx * f, y + dy * f, z + dz * f)
        self.suggested = None
        # The simulated operator types the suggestion and places the laptop there with its
        # placing error: the resolution each entry promises the analysis.
        error = self.placing.normal(0.0, self.plan.translation_resolution, 3)
        true = tuple(float(v) for v in np.asarray(t_grid) + error)
        typed = PlannedPose(t_grid=t_grid, camera_id=planned.start.camera_id)
        return self._placement(trial, pose, typed, true_pose=((true[0], true[1], true[2]),
                                                               typed.r_deg))  # fmt: skip

    def _placement(
        self, trial: int, pose: int, p: PlannedPose, true_pose: tuple[Vec3, Vec3] | None = None
    ) -> Placement:
        self.typed = p.t_grid
        entry = PoseEntry(
            trial=trial,
            pose=pose,
            camera_id=p.camera_id,
            t_grid=p.t_grid,
            r_deg=p.r_deg,
            translation_resolution=self.plan.translation_resolution,
            rotation_resolution_deg=self.plan.rotation_resolution_deg,
        )
        return Placement(entry=entry, true_pose=true_pose)

    def advice(self, trial: int, advice: Advice) -> bool:
        if self.on_advice is not None:
            self.on_advice(trial, advice)
        guided = self.plan.trials[trial - self.first_trial].guided
        if guided and advice.suggestion is not None:
            self.suggested = advice.suggestion.t_grid
        return guided and advice.complete

    def captured(self, trial: int, pose: int, result: CaptureResult) -> None:
        if self.on_capture is not None:
            self.on_capture(trial, pose, result)

    def preview_result(self, result: TrialResult) -> None:
        # A plan accepts every complete capture: the result it would have is the result,
        # printed when the terminal prints it (before the decision).
        if self.on_result is not None:
            self.on_result(result)

    def live_failed(self, message: str) -> None:
        import sys

        print(f"  WARNING {message}", file=sys.stderr, flush=True)

    def notice(self, message: str) -> None:
        import sys

        print(f"  note: {message}", file=sys.stderr, flush=True)

    def board_progress(self, seen_from: Sequence[Vec3], problem: str) -> None:  # noqa: ARG002 - a plan says the problem only
        self.rig_problem = problem  # said once, at the end (a plan's poses are all planned)

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        if not result.complete:
            raise SourceError(
                f"trial {trial} pose {pose}: {result.reason}; the session so far is saved "
                f"in {self.path}"
            )
        return Decision.ACCEPT


def record_plan(  # noqa: PLR0913 - keyword-only callbacks, one per thing a caller shows
    plan: Plan,
    out: str | Path,
    source: FrameSource,
    *,
    on_frame: Callable[[FrameFeedback], None] | None = None,
    on_capture: Callable[[int, int, CaptureResult], None] | None = None,
    live: LiveView | None = None,
    on_result: Callable[[TrialResult], None] | None = None,
    rig: RigConstants | None = None,
    placing: PlacingSigma | None = None,
    on_advice: Callable[[int, Advice], None] | None = None,
    continued: Continued | None = None,
) -> RecordingSummary:
    """Record ``plan`` into the new session ``out`` from an (unopened) ``source``.

    A capture that fails is kept (incomplete) and the recording stops there with a
    :class:`SourceError`; everything written before it is in the file, which is closed.
    ``on_result`` receives each trial's live result (new or updated).

    Parameters
    ----------
    plan : Plan
        From :func:`load_plan`.
    out : path-like
        The new session file (never overwritten).
    source : FrameSource
        Where frames come from (opened and closed here): a camera, a video, stills or
        the synthetic camera.
    on_frame, on_capture, on_result : callable, optional
        Called with each frame's detection feedback, each capture's outcome and each
        trial's live result.
    on_advice : callable, optional
        Called with each trial's guidance after a decision (``[guidance]`` or guided
        trials): the next pose suggested, or the trial complete.
    continued : Continued, optional
        The session this recording continues (``new --continue``): its setup, its id, and
        its trials numbered on (the plan's method and units must be its).
    live : LiveView, optional
        Foxglove's live view, fed as the session is recorded.
    rig : RigConstants, optional
        A calibrated rig, correcting the live result.
    placing : PlacingSigma, optional
        The placing sigma the rig file's board session measured: the live result's
        regions take it (default: each pose's typed resolution).

    Returns
    -------
    RecordingSummary
        What was recorded: trials, poses, frames and the file.
    """
    info = SessionInfo(
        method=plan.method,
        units=plan.units,
        camera_ids=tuple(c.camera_id for c in plan.cameras),
        operator=plan.operator,
        notes=plan.notes,
        created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        board=plan.board,
        session_id=uuid.uuid4().hex,
        part_id=uuid.uuid4().hex,
    )
    cameras, ground = plan.cameras, plan.ground()
    if continued is not None:
        continued.check_plan(plan.method, plan.units)
        info, cameras, ground = continued.info_for(plan.notes), continued.cameras, continued.ground
    return record(
        out,
        info,
        cameras,
        source,
        _PlanDriver(plan, on_capture, on_result, on_advice),
        ground=ground,
        after_trial=continued.last_trial if continued is not None else 0,
        capture=CaptureSettings.live_detection(
            info,
            frames=plan.frames,
            adaptive_frames=plan.adaptive_frames,
            live=live,
            on_frame=on_frame,
            rig=rig,
            placing=placing,
            guidance=plan.guidance,
        ),
    )
