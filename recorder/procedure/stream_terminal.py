"""A pair's recording at the terminal: ``new OUT.mcap --pair PAIR.toml --source pair:A,B``.

:func:`record_pair` is what ``new --pair`` runs (one call from Python too): the setup (the
method, the units, the ground height where the method has a plane and the pair file has
no floor, the operator: each asked unless given, or the plan's), then stream trials
(:func:`recorder.procedure.stream.record_stream`) with :class:`TerminalStreamDriver`.

The keys, one line each (Enter ends it; a key thread reads them while frames flow, and
stamps each with the monotonic clock as it arrives):

==============  ==========================================================================
between trials  Enter starts the next trial's stream; ``q`` ends the session
during a trial  Enter: a touch *now*, at the plan's next keyed point (or the point typed
                last); ``x, y, z`` then Enter: a touch now at that grid point; ``e`` ends
                the trial; ``q`` ends the trial and the session
==============  ==========================================================================

With a plan (``--plan``) the trials start by themselves, its scheduled touches are marked
at their times and its trials end at their ``duration`` (else by ``e``). A plan is
unattended: one whose method needs a ground height the pair file lacks and the plan does
not give is refused before anything is recorded; every planned touch's point is checked (a
ground touch on the floor). A keyed touch is the one thing a plan asks of the operator (its
Enter, on the standard input: a terminal, or a script's pipe). A closed input (end of file)
ends the session where a key is waited for; while a trial streams by a plan it is said when
keyed touches are left (they cannot be marked: ``< /dev/null``), the trial goes on to its
end and, with no touch, is said incomplete; a trial with no ``duration`` (which only ``e``
would end) ends after its last scheduled touch, and the session with it.
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from typing_extensions import override

from recorder.procedure import stops
from recorder.procedure.stream import (
    ScheduledTouch,
    StreamDriver,
    StreamEvent,
    StreamSummary,
    TrialEnd,
    record_stream,
)
from twopose.errors import InputValueError
from twopose.format.entries import PlaneEntry, SessionInfo
from twopose.methods.specs import Method, spec_of
from twopose.values.bounds import GROUND_TRUTH, shown
from twopose.values.checks import Vec3
from twopose.values.units import Units

if TYPE_CHECKING:
    from recorder.procedure.terminal import Operator
    from recorder.setup.continuation import Continued
    from recorder.setup.stream_plan import StreamPlan
    from recorder.sources.pair import CameraStream
    from twopose.format.entries import Touch
    from twopose.pair.calibration import PairCalibration
    from twopose.pair.clock import ClockOffset

__all__ = ["CAMERA_IDS", "KeyReader", "PairSetup", "TerminalStreamDriver", "record_pair"]

#: The session's camera ids: camera 1's and camera 2's.
CAMERA_IDS = ("cam1", "cam2")
_POLL_S = 0.05


class KeyReader:
    """The operator's lines, read on a thread (so frames flow meanwhile), each with the
    monotonic time it arrived; ``readline`` returns "" at the end of the input."""

    def __init__(self, readline: Callable[[], str] | None = None) -> None:
        self._readline = readline or sys.stdin.readline
        self.lines: queue.Queue[tuple[str | None, int]] = queue.Queue()
        self._thread = threading.Thread(target=self._run, name="keys", daemon=True)
        self.closed = False  # the input ended

    def start(self) -> None:
        self._thread.start()

    def _run(self) -> None:
        while True:
            try:
                line = self._readline()
            except (OSError, ValueError):  # the input was closed under us
                line = ""
            at = time.monotonic_ns()
            if not line:
                self.lines.put((None, at))
                return
            self.lines.put((line.strip(), at))

    def get(self, timeout_s: float) -> tuple[str | None, int] | None:
        """The next line (None as its text: the input ended), or None within ``timeout_s``."""
        try:
            line = self.lines.get(timeout=timeout_s)
        except queue.Empty:
            return None
        if line[0] is None:
            self.closed = True
        return line


@dataclass(frozen=True, kw_only=True)
class PairSetup:
    """What a pair's session records besides its frames."""

    method: Method
    units: Units
    operator: str = ""
    notes: str = ""
    plane_offset: float | None = None  # the method's plane's offset, typed (no floor)
    #: The two-camera session this one continues (``--continue``): its pair, floor and
    #: identity kept, its trials numbered on (:mod:`recorder.setup.pair_continuation`).
    continued: Continued | None = None

    @classmethod
    def continuing(
        cls, continued: Continued, pair_path: Path | None = None, *,
        plan: StreamPlan | None = None, operator: str | None = None,
    ) -> PairSetup:  # fmt: skip
        """A continuation's setup: ``continued``'s (its pair checked against ``pair_path``
        and ``plan``: :func:`recorder.setup.pair_continuation.check_continuation`), recorded
        by ``operator`` (``--operator``, else the plan's, else the session's)."""
        from recorder.setup.pair_continuation import check_continuation

        check_continuation(continued, pair_path, plan=plan)
        if plan is not None:
            operator = operator or plan.operator or None
        info = continued.info
        return cls(
            method=info.method, units=info.units,
            operator=operator if operator is not None else continued.operator or info.operator,
            continued=replace(continued, operator=operator),
        )  # fmt: skip

    @property
    def first_trial(self) -> int:
        """The recording's first stream trial (a continuation's: after the session's last)."""
        return 1 if self.continued is None else self.continued.next_trial

    def info(self, notes: str = "") -> SessionInfo:
        import uuid

        if self.continued is not None:  # the same session, a part of its own
            return self.continued.info_for(notes or self.notes, operator=self.operator)
        return SessionInfo(
            method=self.method, units=self.units, camera_ids=CAMERA_IDS,
            operator=self.operator, notes=notes or self.notes,
            created_utc=datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            session_id=uuid.uuid4().hex, part_id=uuid.uuid4().hex,
        )  # fmt: skip

    def session_pair(self, pair: PairCalibration | None) -> PairCalibration:
        """The pair the session stores: a typed offset of the method's plane (the pair file
        has no floor) becomes its floor, ``normal . p = offset`` in camera 1's frame, exact,
        as a typed ground is for one camera (so that the stream's estimate has its plane)."""
        if self.continued is not None and self.continued.pair is not None:
            return self.continued.pair  # as the session stored it (its floor too)
        if pair is None:
            raise InputValueError("a pair session needs its pair (a pair file)")
        plane = spec_of(self.method).plane
        if self.plane_offset is None or plane is None or pair.floor is not None:
            return pair
        import numpy as np

        from twopose.pair.calibration import FloorPlane

        floor = FloorPlane(
            normal=np.asarray(plane.normal_grid, dtype=np.float64), height=self.plane_offset,
            cov=np.zeros((4, 4)),
        )  # fmt: skip
        return replace(pair.in_units(self.units), floor=floor)

    def ground(self) -> PlaneEntry | None:
        """The typed plane (None: the pair's floor, or a method on no plane); a
        continuation's: its session's."""
        from recorder.setup.rules import plane_entry

        if self.continued is not None:
            return self.continued.ground
        return plane_entry(self.method.spec, self.plane_offset)


class TerminalStreamDriver(StreamDriver):
    """The operator at the terminal (the module docstring), with a plan or without."""

    def __init__(
        self, say: Callable[[str], None], keys: KeyReader, units: Units,
        plan: StreamPlan | None = None, first_trial: int = 1,
    ) -> None:  # fmt: skip
        self.say, self.keys, self.units, self.plan = say, keys, units, plan
        self.first_trial = first_trial  # a continuation's: after its session's last
        self._keyed: list[Vec3] = []
        self._last_point: Vec3 | None = None
        self._endless, self._stuck, self._stuck_end_ns = False, False, 0

    def _planned(self, trial: int) -> Any:
        """The plan's trial recorded as ``trial`` (its first is :attr:`first_trial`)."""
        k = trial - self.first_trial
        if self.plan is None or not 0 <= k < len(self.plan.trials):
            return None
        return self.plan.trials[k]

    @override
    def start(self, cameras: tuple[CameraStream, CameraStream], path: Path) -> None:
        for n, camera in enumerate(cameras, start=1):
            self.say(f"camera {n}: {camera.text()}")
        self.say(f"recording {path}")
        self.keys.start()

    @override
    def next_trial(self, trial: int) -> bool:
        if self.plan is not None:
            return self._planned(trial) is not None
        self.say(f"trial {trial}: Enter starts its stream; q ends the session")
        while True:
            line = self._wait_line()
            if line is None or line.lower() == "q":
                return False
            if line == "":
                return True
            self.say("  Enter starts the trial, q ends the session")

    def _wait_line(self) -> str | None:
        """The next line (None: the input ended); a stop raises KeyboardInterrupt."""
        while True:
            stops.check()
            if self.keys.closed:  # the input ended (read during a trial): nothing more comes
                return None
            got = self.keys.get(_POLL_S)
            if got is not None:
                return got[0]

    @override
    def schedule(self, trial: int) -> Sequence[ScheduledTouch]:
        planned = self._planned(trial)
        if planned is None:
            return ()
        return tuple(ScheduledTouch(point=t.point, after_s=t.at_s) for t in planned.scheduled)

    @override
    def duration_s(self, trial: int) -> float | None:
        planned = self._planned(trial)
        return None if planned is None else planned.duration_s

    @override
    def streaming(self, trial: int) -> None:
        planned = self._planned(trial)
        self._keyed = list(planned.keyed) if planned is not None else []
        # No duration: only an `e` ends this trial, and a closed input never gives one.
        self._endless = planned is None or planned.duration_s is None
        self._stuck = False
        # when a stuck trial ends: after its last scheduled touch (marked on camera 1's
        # clock from its first frame, which comes after this), with a second to spare
        last_at = max((t.at_s for t in planned.scheduled), default=-1.0) if planned else -1.0
        self._stuck_end_ns = time.monotonic_ns() + int((last_at + 1.0) * 1e9) if last_at >= 0 else 0
        if self.keys.closed:
            self._input_ended()
        ends = "e ends the trial" if planned is None or planned.duration_s is None else (
            f"it ends after {planned.duration_s:g} s (e: now)"
        )  # fmt: skip
        self.say(f"trial {trial}: streaming; {ends}; q quits")
        if planned is not None and planned.scheduled:
            self.say(f"  {len(planned.scheduled)} touch(es) marked by the plan's schedule")
        self._prompt_next()

    def _prompt_next(self) -> None:
        if self._keyed:
            self.say(
                f"  next touch: {_point(self._keyed[0])}: Enter the moment the target is on it"
            )
        elif self.plan is None:
            self.say("  a touch: type the grid point x, y, z; Enter the moment the target is on it")

    @override
    def events(self) -> list[StreamEvent]:
        now = time.monotonic_ns()
        if self._stuck and now >= self._stuck_end_ns:  # else it would stream forever
            return [StreamEvent(kind="quit", at_ns=now)]
        events = []
        while (got := self.keys.get(0.0)) is not None:
            text, at = got
            if text is None:  # the input ended: nothing more is keyed
                if self.plan is None:
                    events.append(StreamEvent(kind="quit", at_ns=at))
                else:  # this batch's Enters take their points first
                    self._input_ended(taken=sum(e.point is None for e in events))
                    if self._stuck and at >= self._stuck_end_ns:
                        events.append(StreamEvent(kind="quit", at_ns=at))
                break
            event = self._event(text, at)
            if event is not None:
                events.append(event)
                if event.kind != "touch":  # the lines after an end are the next trial's
                    break
        return events

    def _input_ended(self, taken: int = 0) -> None:
        """The input ended during a plan's trial: its keyed touches left (but the ``taken``
        first, whose Enter came before the end) are said lost."""
        left = len(self._keyed) - taken
        if left > 0:
            self.say(
                f"  the input ended: {left} keyed touch(es) of this trial cannot be marked "
                "(nobody presses Enter); what was recorded is kept"
            )
            self._keyed = self._keyed[:taken]
        if self._endless:  # nothing else can end the trial: it and the session end here
            when = "after its last scheduled touch" if self._stuck_end_ns else "here"
            self.say(
                "  the input ended and this trial has no duration (only e would end it): "
                f"the trial and the session end {when}; give the plan's trials a duration "
                "to record unattended"
            )
            self._stuck = True

    def _event(self, text: str, at: int) -> StreamEvent | None:
        if text.lower() in ("e", "q"):
            return StreamEvent(kind="end" if text.lower() == "e" else "quit", at_ns=at)
        if not text:
            return StreamEvent(kind="touch", at_ns=at, how="key")
        try:
            x, y, z = GROUND_TRUTH.read_vector(text, self.units)
        except InputValueError as err:
            self.say(f"  not a touch: {err} (x, y, z then Enter; e ends the trial; q quits)")
            return None
        self._keyed[:1] = []  # a point typed takes the place of the plan's next
        self._last_point = (x, y, z)
        return StreamEvent(kind="touch", at_ns=at, point=(x, y, z), how="key")

    @override
    def next_point(self, trial: int) -> Vec3 | None:
        if self._keyed:
            self._last_point = self._keyed.pop(0)
            return self._last_point
        return self._last_point

    @override
    def touched(self, touch: Touch) -> None:
        self.say(f"  touch {touch.touch} at {_point(touch.point)} ({touch.how})")
        if touch.how == "key" and self._keyed:
            self._prompt_next()

    @override
    def refused(self, message: str) -> None:
        self.say(f"  not a touch: {message}")

    @override
    def trial_ended(self, end: TrialEnd) -> None:
        self.say(end.line())

    @override
    def offset(self, trial: int, offset: ClockOffset | None, said: str) -> None:
        self.say(f"  {said}")


def _point(p: Sequence[float]) -> str:
    return f"({', '.join(shown(v) for v in p)})"


def ask_pair_setup(
    op: Operator, pair: PairCalibration, *, method: Method | None = None,
    units: Units | None = None, ground_height: float | None = None,
    operator: str | None = None, plan: StreamPlan | None = None,
) -> PairSetup:  # fmt: skip
    """The pair session's setup: the plan's, else what was given, else asked. The method's
    plane (method 2's ground) is the pair's floor where the pair file has one (a typed
    height is then refused), else typed."""
    from recorder.procedure.terminal import _ask, _plane_offset

    if plan is not None:
        method, units, operator = plan.method, plan.units, plan.operator
        ground_height = plan.plane_offset
    m = Method(method or _ask(op, "method", pair.units))
    if not spec_of(m).measures:
        raise InputValueError(
            f"a {m} session calibrates one camera's rig; a pair's stream measures a moving "
            "target: point, line or ground"
        )
    u = Units(units or _ask(op, "units", pair.units))
    plane = spec_of(m).plane
    h = None
    if plane is not None and pair.floor is not None:
        if ground_height is not None:
            raise InputValueError(
                f"the pair file gives the floor ({plane.name}): leave the typed "
                f"{plane.setup_key} out, or calibrate the pair without the floor"
            )
    elif plane is not None:
        if plan is not None and ground_height is None:  # a plan is unattended: nobody to ask
            raise InputValueError(
                f"plan: {plane.setup_key} is missing: the pair file has no floor and a plan "
                f"records without prompts; add {plane.setup_key} = H ({plane.bound.words}, "
                f"the plan's units) to the plan, or calibrate the pair with its floor"
            )
        given = {} if ground_height is None else {plane.setup_key: ground_height}
        h = _plane_offset(op, m, u, given)
    elif ground_height is not None:
        raise InputValueError(f"a {m} session measures on no plane: leave the ground height out")
    who = operator if operator is not None else _ask(op, "operator", u)
    return PairSetup(method=m, units=u, operator=who, plane_offset=h)


def record_pair(  # noqa: PLR0913 - what new --pair takes
    out: Path, pair_path: Path | None, source: str, op: Operator, *,
    plan_path: Path | None = None, given: dict[str, Any] | None = None, notes: str = "",
    keys: KeyReader | None = None, fps: float | None = None, continued: Continued | None = None,
) -> StreamSummary:  # fmt: skip
    """``new OUT --pair PAIR.toml --source pair:A,B [--plan PLAN.toml]`` at the terminal;
    with ``continued`` (``--continue S.mcap``, read), its continuation: ``S``'s pair and
    setup (``pair_path`` None, or checked to be its pair: :mod:`recorder.setup.
    pair_continuation`), its trials numbered on."""
    from recorder.procedure.machine import refuse_existing
    from recorder.setup.stream_plan import load_stream_plan
    from twopose.pair.pair_file import read_pair_file

    refuse_existing(out)
    plan = load_stream_plan(plan_path) if plan_path is not None else None
    if continued is not None:
        who = (given or {}).get("operator")
        setup = PairSetup.continuing(continued, pair_path, plan=plan, operator=who)
        pair = setup.session_pair(None)
    elif pair_path is None:
        raise InputValueError("--pair PAIR.toml: the pair's calibration (calibrate-pair) is needed")
    else:
        pair = read_pair_file(pair_path)
        setup = ask_pair_setup(op, pair, plan=plan, **(given or {}))
        pair = setup.session_pair(pair)
    if plan is not None:
        refuse_off_floor(plan, pair)
    src = open_pair_source(source, pair, setup, fps=fps)
    if continued is not None and continued.fork_warning is not None:  # said once, checked
        op.say(f"warning: {continued.fork_warning}")
    if pair.check is not None and not pair.check.passed:  # recorded, and said before it is
        op.say(f"warning: {pair.check.unconfirmed()}")
    cameras = pair_cameras(pair)
    info = setup.info(notes or (plan.notes if plan is not None else ""))
    driver = TerminalStreamDriver(
        op.say, keys or KeyReader(), setup.units, plan, first_trial=setup.first_trial
    )
    with stops.handled():
        return record_stream(out, info, cameras, pair, src, driver, ground=setup.ground())


def refuse_off_floor(plan: StreamPlan, pair: PairCalibration) -> None:
    """Every planned touch's point, checked before anything is recorded (a ground touch
    off the floor: :func:`recorder.setup.stream_plan.touch_refusal`)."""
    from recorder.setup.stream_plan import touch_refusal

    for i, trial in enumerate(plan.trials, start=1):
        for k, touch in enumerate(trial.touches, start=1):
            off = touch_refusal(plan.method, pair, plan.units, touch.point)
            if off:
                raise InputValueError(f"plan: trials[{i}].touches[{k}].point: {off}")


def pair_cameras(pair: PairCalibration) -> list[Any]:
    """The session's two cameras: the pair's intrinsics and sigmas, ids :data:`CAMERA_IDS`."""
    from twopose.camera.model import Camera

    return [
        Camera(camera_id=CAMERA_IDS[0], intrinsics=pair.intrinsics1, intrinsics_sigma=pair.sigma1),
        Camera(camera_id=CAMERA_IDS[1], intrinsics=pair.intrinsics2, intrinsics_sigma=pair.sigma2),
    ]


def open_pair_source(
    spec: str, pair: PairCalibration, setup: PairSetup, *, fps: float | None
) -> Any:
    """``pair:A,B`` opened as a pair (each camera asked for its calibrated size)."""
    from recorder.sources.registry import (
        SOURCE_KINDS,
        SourceOptions,
        kind_of,
        open_pair,
        parse_pair,
    )

    kind = kind_of(spec)
    if kind.cameras != 2:
        raise InputValueError(
            f"--pair records two cameras: give --source pair:A,B (pair:camera:0,camera:1), "
            f"not {spec}"
        )
    k = pair.intrinsics1
    options = SourceOptions(
        method=setup.method, width=k.width, height=k.height, fps=fps or 30.0, units=setup.units,
    )  # fmt: skip
    return open_pair(*parse_pair(spec.partition(":")[2], SOURCE_KINDS), options)
