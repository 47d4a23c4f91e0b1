"""The guided procedure at the terminal: the operator answers, :func:`record` records.

:func:`ask_setup` asks for whatever the command line did not give (method, units,
intrinsics, ground height, ground truth, operator, the stop rule); :func:`record_interactive`
then runs trial after trial: type each pose, capture, accept or redo. The questions go through an
:class:`Operator` (``ask`` and ``say``), so tests drive it with scripted answers.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from typing_extensions import override

from recorder.procedure.capture import CaptureResult, CaptureSettings
from recorder.procedure.driver import Decision, Driver, Placement, ProcedureRefusedError
from recorder.procedure.machine import Shortfall, detection_shortfall
from recorder.procedure.recording import record
from recorder.procedure.summary import RecordingSummary
from recorder.setup.form import SETUP_FIELDS
from recorder.setup.rules import (
    PLANE_OFFSET_KEY,
    GuidanceAsked,
    PoseTyping,
    Setup,
    board_corner,
    check_rig_early,
    default_principal,
    distinct_point,
    inner_corners,
    number_pair,
    off_plane,
    parse_vector,
    plane_option,
    reader,
    refuse_other_planes,
    target_precision,
)
from recorder.sources.registry import FrameSource, SourceInfo
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import InputValueError
from twopose.format.entries import (
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
    TruthKind,
    TypedEntry,
)
from twopose.methods.planes import ConstraintPlane
from twopose.methods.specs import PLANES, Method, MethodSpec, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.values.bounds import (
    BOARD_CORNER,
    BOARD_SQUARE,
    FOCAL,
    GROUND_TRUTH,
    PRINCIPAL,
    ROTATION,
    TARGET_PRECISION,
    Quantity,
    shown,
)
from twopose.values.checks import Vec3
from twopose.values.units import DEFAULT_UNITS, UNITS, Units

if TYPE_CHECKING:
    from recorder.live.trial_result import TrialResult
    from recorder.setup.continuation import Continued
    from twopose.guidance.advice import Advice
    from twopose.rig.constants import RigConstants

__all__ = [
    "Operator",
    "Setup",
    "ask_setup",
    "ask_target",
    "parse_vector",
    "record_interactive",
]


class Operator:
    """How the procedure talks to the operator: ``ask`` a question, ``say`` a line."""

    def __init__(self, ask: Callable[[str, str], str], say: Callable[[str], None]) -> None:
        self.ask_raw, self.say = ask, say
        self.questions = 0  # asked so far

    def ask(self, question: str, parse: Callable[[str], Any], default: str = "") -> Any:
        """Ask until the answer parses; say why an answer was refused."""
        self.questions += 1
        while True:
            answer = self.ask_raw(question, default).strip()
            try:
                return parse(answer)
            except InputValueError as err:
                self.say(f"  not accepted: {err}")


# --------------------------------------------------------------------------- setup


def ask_setup(  # noqa: PLR0913 - one keyword per setup value the operator may have given
    op: Operator,
    *,
    method: Method | None,
    units: Units | None,
    intrinsics: Intrinsics | None,
    focal: float | None,
    principal: tuple[float, float] | None,
    size: tuple[int, int],
    ground_truth: Sequence[Vec3],
    operator: str | None,
    intrinsics_sigma: dict[str, float] | None = None,
    board: BoardPlacement | None = None,
    target_precision: float | None = None,
    guidance: GuidanceAsked | None = None,
    rig: RigConstants | None = None,
    **plane_offsets: float | None,
) -> Setup:
    """Ask for whatever is None (or missing) above; answers are checked as they are typed.
    ``intrinsics_sigma`` (a calibration file's) travels with the intrinsics; ``board`` is a
    board session's board, asked part by part where the command line did not give it. The
    stop rule's precision is asked last (Enter: none) when anything else was and
    ``--poses`` was not given (a trial's fixed poses: no stop rule): a command line that
    gives the whole setup is asked nothing (``--target-precision`` sets it).

    A value given is checked against its bound in the units chosen
    (:mod:`twopose.values.bounds`) and refused, never asked again; so are ``guidance``'s options
    (a board session takes none), as soon as the method and units are known; so is the
    ``rig`` file (``--rig``): before any question for what the command line gave (its
    units, the image size, the camera), then as each answer comes
    (:func:`recorder.setup.rules.check_rig_early`).
    ``plane_offsets`` are the planes' offsets given, each under its plane's setup key
    (``ground_height=`` for method 2's ground, :data:`twopose.methods.specs.PLANES`)."""
    asked_before = op.questions
    given_units = Units(units) if units in UNITS else None
    check_rig_early(rig, units=given_units, size=size, intrinsics=intrinsics)
    m = Method(method or _ask(op, "method", DEFAULT_UNITS))
    check_rig_early(rig, method=m)
    u = Units(units if units in UNITS else _ask(op, "units", DEFAULT_UNITS))
    check_rig_early(rig, units=u)
    refused = (guidance or GuidanceAsked()).refusals(m, u)
    if refused:
        raise InputValueError("; ".join(refused.values()))
    if intrinsics is None:
        f = _given(FOCAL, focal, u, "--focal") if focal is not None else _ask(op, "focal", u)
        centre = ", ".join(shown(v) for v in default_principal(size))
        if principal is not None:
            cx, cy = (_given(PRINCIPAL, v, u, "--principal", axis=a) for v, a in
                      zip(principal, PRINCIPAL.axes, strict=True))  # fmt: skip
        else:
            cx, cy = op.ask("principal point cx, cy (px)", number_pair, centre)
        intrinsics = Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=cx, cy=cy)
        check_rig_early(rig, intrinsics=intrinsics)
    h = _plane_offset(op, m, u, _known_planes(plane_offsets))
    for point in ground_truth:
        for v, a in zip(point, GROUND_TRUTH.axes, strict=True):
            _given(GROUND_TRUTH, v, u, "--ground-truth", axis=a)
    if board is not None:
        _given(BOARD_SQUARE, board.square, u, "--square")
        for v, a in zip(board.first_corner, BOARD_CORNER.axes, strict=True):
            _given(BOARD_CORNER, v, u, "--board-corner", axis=a)
    if target_precision is not None:
        _given(TARGET_PRECISION, target_precision, u, "--target-precision")
    spec = spec_of(m)  # the method came in as text (the option or the answer): looked up once
    truth = _ask_truth(op, spec, u, h, list(ground_truth))
    if not spec.measures and board is None:
        board = _ask_board(op, u)
    who = operator if operator is not None else _ask(op, "operator", u)
    target = target_precision
    fixed = guidance is not None and guidance.poses is not None  # --poses: no stop rule
    if target is None and spec.measures and op.questions > asked_before and not fixed:
        target = ask_target(op, u)
    return Setup(
        method=m,
        units=u,
        intrinsics=intrinsics,
        plane_offset=h,
        ground_truth=truth,
        operator=who,
        intrinsics_sigma=dict(intrinsics_sigma or {}),
        board=board if not spec.measures else None,
        target95=target,
    )


def ask_target(op: Operator, units: Units) -> float | None:
    """The stop rule's precision (``--target-precision``): a trial is complete once its
    predicted 95% region is within it; ``none`` (the default): suggestions only."""
    question = f"stop a trial when its 95% region is within ({units}; none: no stop rule)"
    answer: float | None = op.ask(question, lambda s: target_precision(s, units), "none")
    return answer


#: The setup's fields by name: what the terminal asks and how it reads the answers.
SETUP_FIELD = {f.name: f for f in SETUP_FIELDS}


def _known_planes(given: Mapping[str, float | None]) -> dict[str, float]:
    """The planes' offsets given (None: not given), each key a plane's setup key."""
    keys = {PLANE_OFFSET_KEY, *(p.setup_key for p in PLANES)}
    unknown = sorted(set(given) - keys)
    if unknown:
        raise TypeError(f"ask_setup() got unexpected keyword arguments {unknown}")
    return {k: v for k, v in given.items() if v is not None}


def _plane_offset(
    op: Operator, method: Method, units: Units, given: Mapping[str, float]
) -> float | None:
    """The offset of the method's plane (method 2's ground height): the one given under
    the plane's setup key (``--ground-height``) or as the method's plane's
    (``--plane-offset``), checked against the plane's bound, or asked; None on no plane."""
    plane = spec_of(method).plane
    refuse_other_planes(method, given)  # another plane's, or any to a method on none
    if plane is None:
        return None
    for key in (plane.setup_key, PLANE_OFFSET_KEY):
        if key in given:
            return _given(plane.bound, given[key], units, plane_option(key))
    return float(_ask(op, plane.setup_key, units))


def _ask(op: Operator, name: str, units: Units) -> Any:
    """The setup field ``name`` asked as the page's form asks it: its label, its reader and
    its default (:data:`recorder.setup.form.SETUP_FIELDS`, the one description)."""
    f = SETUP_FIELD[name]
    return op.ask(f.question(units), lambda s: f.answer(s, units), f.default(units))


def _given(quantity: Quantity, value: float, units: Units, option: str, *, axis: str = "") -> float:
    """A value the command line (or a caller) gave, checked as a typed one would be;
    refused, naming its option, when past its bound in ``units``."""
    try:
        return quantity.read(value, units, axis=axis)
    except InputValueError as err:
        raise InputValueError(f"{option}: {err}") from None


def _ask_board(op: Operator, units: Units) -> BoardPlacement:
    """A board session's board: its inner corners, its square and where it stands."""
    corners = op.ask("board's inner corners COLSxROWS", inner_corners, "9x6")
    square = op.ask(f"board's square side ({units})", reader(BOARD_SQUARE, units))
    corner = op.ask(
        f"board's first inner corner x, y, z ({units}; lower left, seen from the camera)",
        lambda s: board_corner(s, units),
    )
    return BoardPlacement(inner_corners=corners, square=square, first_corner=corner)


def _ask_truth(
    op: Operator, spec: MethodSpec, units: Units, height: float | None, given: list[Vec3]
) -> tuple[Vec3, ...]:
    """The ground truth, checked as typed: a line's two points must differ, and a point off
    the method's plane (method 2's ground) is kept only if the operator confirms it."""
    n_truth = spec.truth_points
    if n_truth == 2 and len(given) >= 2 and given[0] == given[1]:
        raise InputValueError(f"the two ground-truth points of a line must differ, got {given}")
    given = given[:n_truth]
    plane = spec.plane
    if (
        plane is not None
        and height is not None
        and given
        and not _keep(op, plane, given[0], height, units)
    ):
        given = []  # the option's point is off the ground and not confirmed: ask again
    while len(given) < n_truth:
        point = op.ask(
            f"ground truth point {len(given) + 1} x, y, z ({units})",
            lambda s: distinct_point(parse_vector(s, units, quantity=GROUND_TRUTH), given),
        )
        if plane is None or height is None or _keep(op, plane, point, height, units):
            given.append(point)
    return tuple(given)


def _keep(op: Operator, plane: ConstraintPlane, point: Vec3, offset: float, units: Units) -> bool:
    """True if ``point`` is on the method's plane, or the operator keeps it anyway."""
    off = off_plane(plane, point, offset, units)
    if not off:
        return True
    op.say(f"  warning: {off}")
    return bool(op.ask("keep this ground truth anyway? [y/N]", _yes_no, "n"))


# --------------------------------------------------------------------------- the procedure


def _yes_no(text: str) -> bool:
    if text.lower() in ("y", "yes", ""):
        return True
    if text.lower() in ("n", "no"):
        return False
    raise InputValueError("answer y or n")


def _choice(text: str) -> Decision:
    if text.strip().lower() in ("anyway", "accept anyway", "aa") or text.strip() == "A":
        return Decision.ACCEPT_ANYWAY
    c = (text or "a")[0].lower()
    if c not in "arunq":
        raise InputValueError(
            "answer a (accept), anyway (accept although the target was rarely found), "
            "r (redo), u (undo), n (note) or q (quit)"
        )
    return Decision(c)


def capture_lines(pose: int, result: CaptureResult) -> list[str]:
    """What the terminal and plan print after a capture: the counts, the pose's averaged
    centroid and orientation (the thesis GUI's per-pose numbers), and a shortfall."""
    state = result.state
    detected = f"{result.n_found} detected, " if result.feedback else ""  # a board: none live
    lines = [f"pose {pose}: {result.n_frames} frames, {detected}{state}, {result.dropped} dropped"]
    average = result.pose_average()
    if average is not None and average.found:
        u, v = average.centroid_px
        theta = "" if math.isnan(average.theta_deg) else f", theta {average.theta_deg:+.2f} deg"
        lines.append(
            f"  averaged over {average.n_used} of {average.n_frames} frames: "
            f"centroid ({u:.2f}, {v:.2f}){theta}"
        )
    shortfall = detection_shortfall(result)
    if shortfall is Shortfall.NONE_FOUND:
        lines.append("  WARNING the target was found in no frame: redo this pose")
    elif shortfall is Shortfall.FEW_FOUND:
        lines.append(
            f"  WARNING the target was found in only {result.n_found} of "
            f"{len(result.feedback)} frames"
        )
    return lines


class _OperatorDriver(Driver):
    """The operator decides: poses typed, each capture accepted, redone or undone."""

    def __init__(
        self,
        op: Operator,
        info: SessionInfo,
        camera: Camera,
        ground_truth: tuple[Vec3, ...],
        typing: PoseTyping,
    ) -> None:
        self.op, self.info, self.camera = op, info, camera
        self.ground_truth = ground_truth
        self.typing = typing
        self.poses_per_trial = typing.poses_per_trial  # --poses (d18a7fc had lost it: 2 always)
        self._rig_problem = ""  # a board session: why its poses cannot determine the rig yet

    def start(self, source: SourceInfo, path: Path) -> None:
        self.op.say(
            f"recording {path} from {source.description} "
            f"({source.width}x{source.height} at {source.fps:g} fps)"
        )

    def next_trial(self, trial: int) -> bool:
        first = trial == self.first_trial
        return first or bool(self.op.ask("another trial? [Y/n]", _yes_no, "y"))

    def trial_entries(self, trial: int) -> Sequence[TypedEntry]:
        self.op.say(f"trial {trial}")
        kind: TruthKind | None = spec_of(self.info.method).truth_kind
        if not self.ground_truth or kind is None:
            return ()
        return (GroundTruth(trial=trial, kind=kind, points_grid=self.ground_truth),)

    def place(self, trial: int, pose: int) -> Placement:
        units = self.info.units
        t = self.op.ask(
            f"pose {pose} camera centre x, y, z ({units})", lambda s: parse_vector(s, units)
        )
        r = self.op.ask(
            "rotation rx, ry, rz (deg)",
            lambda s: parse_vector(s, units, quantity=ROTATION),
            "0, 0, 0",
        )
        entry = PoseEntry(
            trial=trial,
            pose=pose,
            camera_id=self.camera.camera_id,
            t_grid=t,
            r_deg=r,
            translation_resolution=self.typing.translation_sigma(units),
            rotation_resolution_deg=self.typing.rotation_resolution_deg,
        )
        return Placement(entry=entry)

    @override
    def captured(self, trial: int, pose: int, result: CaptureResult) -> None:
        for line in capture_lines(pose, result):
            self.op.say(line)

    def preview_result(self, result: TrialResult) -> None:
        self.op.say(f"  result if accepted: {result.text()}")

    def computing(self, what: str) -> None:
        self.op.say(f"  {what}")

    def advice(self, trial: int, advice: Advice) -> bool:  # noqa: ARG002 - said, not kept
        from recorder.live.result import MappedAdvice

        self.op.say(f"  guidance: {advice.text}")
        # The good poses beside the suggestion, for an operator who cannot reach it.
        region_map = advice.region_map if isinstance(advice, MappedAdvice) else None
        for line in [] if region_map is None else region_map.best_lines(3):
            self.op.say(f"  {line}")
        return advice.complete

    def live_failed(self, message: str) -> None:
        self.op.say(f"  WARNING {message}")

    def notice(self, message: str) -> None:
        self.op.say(f"  note: {message}")

    def board_progress(self, seen_from: Sequence[Vec3], problem: str) -> None:  # noqa: ARG002 - the terminal says the problem only
        if problem != self._rig_problem:  # said when it changes, not after every pose
            self.op.say(f"  rig: {problem}" if problem else "  rig: these poses can determine it")
        self._rig_problem = problem

    @override
    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        accept = "[a]ccept"
        if detection_shortfall(result) is Shortfall.FEW_FOUND:
            accept = "accept [anyway]"
        return cast(
            "Decision",
            self.op.ask(
                f"{accept}, [r]edo, [u]ndo previous, [n]ote, [q]uit (this capture unused)",
                _choice,
                "anyway" if accept != "[a]ccept" else "a",
            ),
        )

    def refused(self, error: ProcedureRefusedError) -> None:
        self.op.say(f"  not possible: {error}")

    def note(self, trial: int) -> Note:
        return Note(text=self.op.ask("note", str), trial=trial)


def record_interactive(
    out: str | Path,
    source: FrameSource,
    operator: Operator,
    *,
    setup: Setup,
    notes: str = "",
    capture: CaptureSettings | None = None,
    typing: PoseTyping | None = None,
    continued: Continued | None = None,
) -> RecordingSummary:
    """The guided procedure: trial after trial, type each pose, capture, accept or redo.

    After each capture the operator answers ``a`` (accept), ``r`` (redo this pose), ``u``
    (undo: discard this capture and the previous pose's, then retype that pose), ``n`` (add
    a note) or ``q`` (end the session; this capture is not used). A refused answer (accept
    an incomplete capture, undo at pose 1) is explained and asked again. After each trial:
    another trial (``y``) or finish (``n``). Ctrl-C closes the file cleanly and returns the
    summary with ``interrupted`` set.
    """
    info = continued.info_for(notes) if continued is not None else setup.info(notes)
    camera = continued.cameras[0] if continued is not None else setup.camera()
    driver = _OperatorDriver(operator, info, camera, setup.ground_truth, typing or PoseTyping())
    sought = CaptureSettings.live_detection(info)  # the method's target, or the board
    settings = dataclasses.replace(
        capture or CaptureSettings(),
        target=sought.target,
        board=sought.board,
        on_frame=lambda fb: operator.say(fb.line()),
    )
    after = continued.last_trial if continued is not None else 0
    return record(
        out, info, [camera], source, driver, ground=setup.ground(), capture=settings,
        after_trial=after,
    )  # fmt: skip
