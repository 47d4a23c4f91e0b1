"""The rules of a session's setup, in one place: which answers a session needs before its
first trial, their defaults (the thesis' rig), and the check each answer must pass.

The terminal (:func:`recorder.procedure.terminal.ask_setup`) asks them one at a time with these
parsers; the web console's form (:mod:`recorder.setup.form`: which fields apply to which
method, :func:`~recorder.setup.form.setup_from_answers`) checks a whole form with the same
parsers, called directly, and reports every refusal at once, by field. Neither matches
the other's wording.

(Near 600 lines: every setup answer's rule and parser, kept together so that the terminal
and the page cannot disagree; the form's layout is :mod:`recorder.setup.form`.)
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from twopose.camera.model import Camera, Intrinsics
from twopose.errors import InputValueError
from twopose.format.entries import (
    DEFAULT_ROTATION_RESOLUTION_DEG,
    GuidanceRecord,
    PlaneEntry,
    SessionInfo,
    default_translation_resolution,
)
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import PLANES, Method, MethodSpec, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.values.bounds import (
    BOARD_CORNER,
    GRID,
    INNER_CORNERS,
    MAX_POSES,
    POSE_TRANSLATION,
    POSES,
    PRINCIPAL,
    REACH,
    TARGET_DISTANCE,
    TARGET_PRECISION,
    Quantity,
    shown,
)
from twopose.values.bounds import MIN_GAIN as MIN_GAIN_BOUND
from twopose.values.checks import Vec3
from twopose.values.units import DEFAULT_UNITS, Units, unit_spec

if TYPE_CHECKING:
    from recorder.setup.continuation import Continued
    from twopose.guidance.advice import Guidance
    from twopose.guidance.paper import Reach
    from twopose.rig.constants import RigConstants

__all__ = [
    "PLANE_OFFSET_KEY",
    "THESIS_FOCAL_PX",
    "THESIS_IMAGE_SIZE",
    "Setup",
    "board_corner",
    "board_refusal",
    "check_rig",
    "check_rig_early",
    "default_plane_offset",
    "default_principal",
    "distinct_point",
    "inherited_words",
    "inner_corners",
    "no_plane_refusal",
    "number_pair",
    "off_plane",
    "one_of",
    "other_plane_refusal",
    "parse_vector",
    "plane_entry",
    "plane_offsets_given",
    "plane_option",
    "poses_refusal",
    "reader",
    "refuse_other_planes",
    "target_precision",
    "thesis_reach",
    "with_guidance",
]

#: The thesis' rig (section 5.2): f = 525 px, principal point at the centre of 640x480 (its
#: ground, 9 5/8 in below the camera centre, is :data:`twopose.methods.planes.GROUND_PLANE`'s).
#: Offered as defaults, never assumed silently, by the terminal, the browser and a plan.
THESIS_FOCAL_PX = 525.0
THESIS_IMAGE_SIZE = (640, 480)
#: The camera of a session set up by hand (terminal or browser): one laptop webcam.
CAMERA_ID = "cam0"
#: The setup's key of the offset of whichever plane the method has (``--plane-offset``, a
#: plan's ``plane_offset``), beside each plane's own key (the ground's ``ground_height``).
PLANE_OFFSET_KEY = "plane_offset"


@dataclass(frozen=True, kw_only=True)
class PoseTyping:
    """How the operator types poses: how many a trial has, and the 1-sigma of each typed
    translation component and angle (the thesis': grid paper read to 1/16, 0.5 degree)."""

    poses_per_trial: int = 2
    translation_resolution: float | None = None  # session units; None: 1/16 in in them
    rotation_resolution_deg: float = DEFAULT_ROTATION_RESOLUTION_DEG

    def translation_sigma(self, units: Units) -> float:
        """The typed translation's 1-sigma in ``units`` (1/16 in, converted, unless given)."""
        if self.translation_resolution is not None:
            return self.translation_resolution
        return default_translation_resolution(units)


@dataclass(frozen=True, kw_only=True)
class Setup:
    """What a session needs before its first trial."""

    method: Method
    units: Units
    intrinsics: Intrinsics
    # The offset of the method's plane (its spec's ``plane``: method 2's ground height), in
    # session units; None for a method on no plane.
    plane_offset: float | None
    ground_truth: tuple[Vec3, ...]
    operator: str
    intrinsics_sigma: dict[str, float] = field(default_factory=dict, compare=False)
    board: BoardPlacement | None = None  # a board session's board and where it stands
    # The stop rule's precision (session units; None: suggestions only): a capture setting,
    # not written in the session entry, but asked with the setup (issue 36).
    target95: float | None = None

    def camera(self) -> Camera:
        """The session's one camera (``cam0``), with its calibration's sigma."""
        return Camera(
            camera_id=CAMERA_ID, intrinsics=self.intrinsics, intrinsics_sigma=self.intrinsics_sigma
        )

    @property
    def spec(self) -> MethodSpec:
        """The method's spec: what every rule of the setup reads of it."""
        return spec_of(self.method)

    def ground(self) -> PlaneEntry | None:
        """The method's plane at the typed offset (method 2's ground ``y = h``), or None."""
        return plane_entry(self.spec, self.plane_offset)

    def plane_offsets(self) -> dict[str, float]:
        """The plane's offset under its setup key (``{"ground_height": h}``), or nothing."""
        plane = self.spec.plane
        if plane is None or self.plane_offset is None:
            return {}
        return {plane.setup_key: self.plane_offset}

    def info(self, notes: str = "") -> SessionInfo:
        """The session's opening entry, created now."""
        return SessionInfo(
            method=self.method,
            units=self.units,
            operator=self.operator,
            notes=notes,
            created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            board=self.board,
            session_id=uuid.uuid4().hex,  # its continuations share it
            part_id=uuid.uuid4().hex,  # this recording's part of it
        )

    @classmethod
    def of(cls, continued: Continued) -> Setup:
        """The setup of the session a continuation continues (``new --continue``)."""
        camera = continued.cameras[0]
        return cls(
            method=continued.info.method,
            units=continued.info.units,
            intrinsics=camera.intrinsics,
            plane_offset=continued.ground.offset if continued.ground else None,
            ground_truth=continued.truth,
            operator=continued.info.operator if continued.operator is None else continued.operator,
            intrinsics_sigma=dict(camera.intrinsics_sigma),
            board=continued.info.board,
        )


def check_rig(
    rig: RigConstants | None,
    method: Method,
    units: Units,
    cameras: Sequence[Camera],
    ground: PlaneEntry | None,
) -> list[str]:
    """Refuse a rig file (``--rig``) this session cannot use; the notes to show about it.

    Every front end (the terminal, a plan, the browser) calls this once its setup is known
    and before anything is recorded, so they refuse the same rig with the same words: a
    board session calibrates a rig and takes none; otherwise the rig's units must be the
    session's and its constants plausible for this camera's images and ground height
    (:func:`twopose.rig.check_applicable`, the analysis' own check).
    """
    if rig is None:
        return []
    if not spec_of(method).measures:
        raise InputValueError(
            "the rig file: a board session calibrates the rig (twopose-analyze rig) and "
            "is recorded without one; leave out --rig"
        )
    from twopose.rig.constants import check_applicable

    spec = ground.spec() if ground is not None else None
    intrinsics = [c.intrinsics for c in cameras]
    return check_applicable(rig, units, spec, (), "the rig file", cameras=intrinsics)


def check_rig_early(
    rig: RigConstants | None,
    *,
    method: Method | None = None,
    units: Units | None = None,
    size: tuple[int, int] | None = None,
    intrinsics: Intrinsics | None = None,
) -> None:
    """Refuse a rig file (``--rig``) as soon as what it must match is known.

    The terminal calls this before its first question, with what the command line gave,
    and again as each answer comes (the method, the units, the camera), so that a rig in
    other units or of another camera is refused at once, never after the whole setup was
    typed (:func:`check_rig` then checks the rest: plausibility for the ground height).
    """
    if rig is None:
        return
    from twopose.rig.cameras import check_cameras, same_size
    from twopose.rig.constants import check_units

    if method is not None and not spec_of(method).measures:
        check_rig(rig, method, Units.IN, [], None)  # a board session takes no rig: refused
    if units is not None:
        check_units(rig, units, "the rig file")
    if intrinsics is not None:
        check_cameras(rig.cameras, [intrinsics], "the rig file")
    elif size is not None:
        same_size(rig.cameras, size, "the rig file")


# --------------------------------------------------------------------------- the checks


def parse_vector(text: str, units: Units | None, *, quantity: Quantity = POSE_TRANSLATION) -> Vec3:
    """Three numbers typed as ``x, y, z`` (commas or spaces), each within ``quantity``'s
    bound (:mod:`twopose.values.bounds`); raises InputValueError."""
    x, y, z = quantity.read_vector(text, units)
    return (x, y, z)


def reader(quantity: Quantity, units: Units | None) -> Callable[[str], float]:
    """The parser of one typed ``quantity`` (the terminal asks with it, the page's fields
    are read with it)."""
    return lambda text: quantity.read(text, units)


def one_of(options: Sequence[str]) -> Callable[[str], str]:
    def parse(text: str) -> str:
        if text not in options:
            raise InputValueError(f"choose one of {', '.join(options)}")
        return text

    return parse


def target_precision(text: str, units: Units | None) -> float | None:
    """The stop rule's precision: a length within its bound, or none ("", "none": no stop
    rule)."""
    if text.strip().lower() in ("", "none", "-"):
        return None
    try:
        return TARGET_PRECISION.read(text, units)
    except InputValueError as err:
        raise InputValueError(f"{err}; or none for no stop rule") from None


def number_pair(text: str) -> tuple[float, float]:
    """The principal point typed as ``cx, cy`` (px)."""
    cx, cy = PRINCIPAL.read_vector(text, None)
    return cx, cy


def inner_corners(text: str) -> tuple[int, int]:
    """A checkerboard's inner corners typed as ``COLSxROWS`` (each within its bound), e.g. 9x6."""
    parts = text.strip().lower().split("x")
    if len(parts) != 2:
        raise InputValueError(
            f"type the board's inner corners as COLSxROWS, e.g. 9x6 (got {text.strip()[:40]!r})"
        )
    cols, rows = INNER_CORNERS.read_vector(parts, None)
    return int(cols), int(rows)


def distinct_point(point: Vec3, earlier: Sequence[Vec3]) -> Vec3:
    if point in earlier:
        raise InputValueError("this point was already given; a line needs two different points")
    return point


def default_principal(size: tuple[int, int]) -> tuple[float, float]:
    """The principal point assumed when none is given: the image's centre (the thesis'
    320, 240 for its 640x480 webcam)."""
    return size[0] / 2, size[1] / 2


def plane_entry(spec: MethodSpec, offset: float | None) -> PlaneEntry | None:
    """The session's plane entry for the method ``spec`` at the typed ``offset`` (its plane,
    :class:`twopose.methods.planes.ConstraintPlane`), or None (no plane, or no offset)."""
    plane = spec.plane
    if plane is None or offset is None:
        return None
    normal, c = plane.plane(offset)
    return PlaneEntry(normal_grid=normal, offset=c)


def plane_option(setup_key: str) -> str:
    """How the command line gives a plane's offset: ``--plane-offset`` for any method's
    plane; ``--ground-height`` for the ground's, its own option (kept)."""
    return "--ground-height" if setup_key == GROUND_PLANE.setup_key else "--plane-offset"


def plane_offsets_given(
    method: Method | None, ground_height: float | None, plane_offset: float | None
) -> dict[str, float]:
    """The planes' offsets a command line gave, by setup key: ``--ground-height`` under
    the ground's, ``--plane-offset`` under :data:`PLANE_OFFSET_KEY` (the offset of the
    method's plane, whichever it is). Refused: another plane's offset than the method's,
    either to a method on no plane, or both (two answers to one question)."""
    given = {GROUND_PLANE.setup_key: ground_height, PLANE_OFFSET_KEY: plane_offset}
    offsets = {k: v for k, v in given.items() if v is not None}
    if method is not None:
        refuse_other_planes(method, offsets)
    if len(offsets) > 1:
        raise InputValueError(
            "--ground-height and --plane-offset both give the ground's offset: give one "
            "(--plane-offset is any method's plane's, --ground-height the ground's own option)"
        )
    return offsets


def other_plane_refusal(spec: MethodSpec, given: Iterable[str], how: Callable[[str], str]) -> str:
    """Why offsets of another plane than the method's may not be given (a wall session
    given the ground height), ``how`` naming a key as its front end does (``--ground-height``,
    a plan's ``ground_height``); empty when none is. A method on no plane ignores them."""
    plane, method = spec.plane, spec.method
    if plane is None:
        return ""
    others = sorted(set(given) & ({p.setup_key for p in PLANES} - {plane.setup_key}))
    if not others:
        return ""
    return (
        f"{how(others[0])} is not a {method} session's: its plane is {plane.name}, "
        f"{plane.equation}, given as {how(plane.setup_key)}"
    )


def refuse_other_planes(method: Method, given: Iterable[str]) -> None:
    """Raise :class:`InputValueError` if the command line (or a caller) gave another
    plane's offset than the method's (:func:`other_plane_refusal`), or any plane's to a
    method on no plane (``--ground-height`` of a point session was ignored)."""
    spec = spec_of(method)
    refused = other_plane_refusal(spec, given, plane_option) or no_plane_refusal(spec, given)
    if refused:
        raise InputValueError(refused)


def no_plane_refusal(spec: MethodSpec, given: Iterable[str]) -> str:
    """Why a plane's offset given to a method on no plane is refused ("": none given, or
    the method has a plane): nothing would use it."""
    keys = sorted(set(given) & {PLANE_OFFSET_KEY, *(p.setup_key for p in PLANES)})
    if spec.plane is not None or not keys:
        return ""
    return (
        f"{plane_option(keys[0])}: a {spec.method} session measures on no plane, so nothing "
        "would use it; leave it out, or choose a method on a plane (ground)"
    )


def off_plane(plane: ConstraintPlane, point: Vec3, offset: float, units: Units) -> str:
    """Why a ground-truth point is not on the method's plane (method 2: the ground ``y =
    h``), empty when it is, within the units' tolerance: half a 1/16 in tape tick, or half
    a millimetre. Every front end refuses such a point unless the operator keeps it: the
    terminal asks, the browser has a box to tick, a plan says ``keep_off_ground = true``."""
    gap = plane.gap(point, offset)
    if abs(gap) <= unit_spec(units).ground_tolerance:
        return ""
    a = plane.axis
    return (
        f"the ground truth {point} has {a} = {gap + offset:g} {units}, but {plane.name} is at "
        f"{a} = {shown(offset)} {units} ({gap:+g} {units}): the finger points at {plane.name}, "
        f"so its {a} should be the {plane.bound.words}"
    )


def default_plane_offset(plane: ConstraintPlane, units: Units) -> str:
    """The thesis' offset of the plane (its ground height) where the units are the
    thesis' (the units registry's default, :data:`twopose.values.units.DEFAULT_UNITS`); nothing
    to assume otherwise."""
    known = plane.thesis_offset_in
    return f"{known:g}" if known is not None and units == DEFAULT_UNITS else ""


def board_corner(text: str, units: Units | None) -> Vec3:
    """The board's first inner corner: a measured grid point, checked as a typed one."""
    return parse_vector(text, units, quantity=BOARD_CORNER)


def thesis_reach(units: Units) -> Reach:
    """The thesis' reach (3 in about the first pose, its 1/2 in grid) in ``units``, to six
    significant digits as every converted bound is (76.2 mm, never 76.19999999999999)."""
    from twopose.guidance.paper import Reach

    exact = Reach.thesis(units)
    return Reach(radius=float(f"{exact.radius:.6g}"), spacing=float(f"{exact.spacing:.6g}"))


#: A trial's most poses under a stop rule when ``--max-poses`` does not say.
DEFAULT_MAX_POSES = 6


@dataclass(frozen=True, kw_only=True)
class GuidanceAsked:
    """The guidance a recording was asked for (``new``'s options): the most poses of a
    trial with a stop rule (None: :data:`DEFAULT_MAX_POSES`), and the reach of the
    suggestions (None: the thesis'). The stop rule's precision is the setup's
    (:attr:`Setup.target95`), given or answered. ``given`` names the guidance options the
    command line gave (a board session refuses them: :meth:`refusals`); ``poses`` is
    ``--poses`` when it was given (every trial has that many poses: no stop rule)."""

    max_poses: int | None = None
    reach: float | None = None
    spacing: float | None = None
    given: tuple[str, ...] = ()
    #: ``--target-distance``: taped from the first pose's camera to the target (session
    #: units; None: not taped, the first suggestion weighs every depth the scene allows).
    target_distance: float | None = None
    #: ``--min-gain``: the information-gain stop's least share (None: the default,
    #: :data:`twopose.guidance.advice.MIN_GAIN`; 0: none). With a target precision only.
    min_gain: float | None = None
    #: ``--poses`` as given (None: not given): a trial's fixed number of poses.
    poses: int | None = None

    def refusals(
        self, method: Method, units: Units, target95: float | None = None
    ) -> dict[str, str]:
        """Why these options cannot guide a session of ``method`` in ``units`` with the
        stop rule ``target95``, by the setup field the page shows it at ({}: they can).
        The terminal, the page and the command line refuse with these words (a plan:
        :func:`recorder.setup.plan.load_plan`)."""
        if not spec_of(method).measures and self.given:
            return {"method": board_refusal(self.given)}
        errors = {}
        flags = ((self.reach, REACH, "--reach"), (self.spacing, GRID, "--grid"),
                 (self.target_distance, TARGET_DISTANCE, "--target-distance"))  # fmt: skip
        for value, quantity, flag in flags:
            why = quantity.refusal(value, units) if value is not None else ""
            if why:
                errors["units"] = f"{flag}: {why}"
        if target95 is not None and self.poses is not None:
            errors["target_precision"] = poses_refusal(self.poses)
        return errors

    def guidance(self, units: Units, poses: int, target95: float | None) -> Guidance:
        """The recording's guidance in the session's units; without a target, a trial
        has ``poses`` poses (``--poses``), as without guidance."""
        from twopose.guidance.advice import MIN_GAIN, Guidance, Reach

        thesis = thesis_reach(units)
        radius = self.reach if self.reach is not None else thesis.radius
        spacing = self.spacing if self.spacing is not None else thesis.spacing
        for value, quantity in ((radius, REACH), (spacing, GRID)):
            quantity.read(value, units)
        if spacing > radius:
            raise InputValueError(
                f"the grid spacing ({shown(spacing)} {units}) must be within the reach "
                f"({shown(radius)} {units})"
            )
        most_asked = DEFAULT_MAX_POSES if self.max_poses is None else self.max_poses
        most = MAX_POSES.count(most_asked) if target95 is not None else POSES.count(poses)
        distance = self.target_distance
        if distance is not None:
            distance = TARGET_DISTANCE.read(distance, units)
        gain = MIN_GAIN if self.min_gain is None else MIN_GAIN_BOUND.read(self.min_gain, None)
        try:
            return Guidance(
                reach=Reach(radius=radius, spacing=spacing), target95=target95,
                max_poses=most, target_distance=distance,
                # The information-gain stop ends a trial early, as the target does: without
                # a target precision a trial has its --poses poses, as without guidance.
                min_gain=gain or None if target95 is not None else None,
            )  # fmt: skip
        except ValueError as err:
            raise InputValueError(str(err)) from None

    def inherited(
        self, record: GuidanceRecord | None, units: Units
    ) -> tuple[GuidanceAsked, list[str]]:
        """A continuation's guidance: each setting the command line gave, else the one its
        session recorded (``record``; None: a file that recorded none); and the settings
        taken from the session, in words (lengths in ``units``). A trial's most poses and
        the least gain are a stop rule's, taken when the session had one; without one its
        trials' poses are (``--poses``)."""
        if record is None:
            return self, []
        taken: dict[str, Any] = {}
        for name, value in (("reach", record.reach), ("spacing", record.spacing),
                            ("target_distance", record.target_distance)):  # fmt: skip
            if getattr(self, name) is None and value is not None:
                taken[name] = value
        if record.target95 is not None:
            for name in ("max_poses", "min_gain"):
                if getattr(self, name) is None:
                    taken[name] = getattr(record, name)
        elif self.poses is None:
            taken["poses"] = record.max_poses
        return replace(self, **taken), inherited_words(taken, units)


def inherited_words(taken: dict[str, Any], units: Units) -> list[str]:
    """The settings a continuation took from its session (by the record's keys: ``max_poses``,
    ``reach``, ...; ``poses``: a trial's without a stop rule), each as given, in words."""
    return [said(taken[k], units) for k, said in _INHERITED_WORDS.items() if k in taken]


#: How a setting taken from the continued session is said, in the session's units.
_INHERITED_WORDS: dict[str, Callable[[Any, Units], str]] = {
    "target_95": lambda v, u: f"95% within {shown(v)} {u}",
    "max_poses": lambda v, _: f"at most {shown(v)} poses",
    "min_gain": lambda v, _: f"least gain {shown(v)}" + (" (none)" if v == 0 else ""),
    "poses": lambda v, _: f"{shown(v)} poses a trial",
    "spacing": lambda v, u: f"suggested on the {shown(v)} {u} grid",
    "reach": lambda v, u: f"within {shown(v)} {u} of the first pose",
    "target_distance": lambda v, u: f"the target taped {shown(v)} {u} from the first pose",
}


def with_guidance(info: SessionInfo, guidance: Guidance | None) -> SessionInfo:
    """The session entry recording the guidance a recording runs with (format 1.5; a
    board session has none)."""
    if guidance is None or not spec_of(info.method).measures:
        return info
    return replace(info, guidance=GuidanceRecord.of(
        target95=guidance.target95, max_poses=guidance.max_poses, min_gain=guidance.min_gain,
        reach=guidance.reach.radius, spacing=guidance.reach.spacing,
        target_distance=guidance.target_distance,
    ))  # fmt: skip


def poses_refusal(poses: int) -> str:
    """Why ``--poses`` and a stop rule cannot go together (the page, the command line)."""
    return (
        f"--poses {poses} gives every trial {poses} poses, and a stop rule ends a trial when "
        "it is precise enough (at most --max-poses poses): give one of them"
    )


def board_refusal(options: Sequence[str]) -> str:
    """Why a board session refuses guidance options (``--target-precision``, ``--reach``,
    ``--grid``, ``--max-poses``, ``--adaptive-frames``; a plan's ``[guidance]``)."""
    return (
        f"{', '.join(options)}: a board session has no guidance: it locates no target, so "
        "nothing suggests its poses, says when a trial is precise enough or when a pose has "
        "frames enough; leave them out"
    )
