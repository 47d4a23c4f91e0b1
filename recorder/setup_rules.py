"""The rules of a session's setup, in one place: which answers a session needs before its
first trial, which apply to which method, their defaults (the thesis' rig), and the check
each answer must pass.

The terminal (:func:`recorder.interactive.ask_setup`) asks them one at a time with these
parsers; the web console (:func:`setup_from_answers`) checks a whole form with the same
parsers, called directly, and reports every refusal at once, by field. Neither matches
the other's wording.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import twopose.methods as registry
from twopose.bounds import (
    BOARD_CORNER,
    BOARD_SQUARE,
    FOCAL,
    GRID,
    GROUND_HEIGHT,
    GROUND_TRUTH,
    INNER_CORNERS,
    MAX_POSES,
    POSE_TRANSLATION,
    POSES,
    PRINCIPAL,
    REACH,
    ROTATION,
    TARGET_PRECISION,
    Quantity,
    shown,
)
from twopose.camera import Camera, Intrinsics
from twopose.errors import InputValueError
from twopose.format.entries import (
    DEFAULT_ROTATION_RESOLUTION_DEG,
    GroundPlane,
    SessionInfo,
    default_translation_resolution,
)
from twopose.methods import METHODS, Method, MethodSpec, spec_of
from twopose.targets import BoardPlacement
from twopose.units import DEFAULT_UNITS, UNITS, Units, unit_spec
from twopose.values import Vec3

if TYPE_CHECKING:
    from recorder.continuation import Continued
    from twopose.guidance import Guidance
    from twopose.rig.constants import RigConstants

__all__ = [
    "SETUP_FIELDS",
    "THESIS_FOCAL_PX",
    "THESIS_IMAGE_SIZE",
    "FormRefusedError",
    "Setup",
    "SetupField",
    "board_corner",
    "board_refusal",
    "check_rig",
    "default_ground_height",
    "default_principal",
    "distinct_point",
    "form_fields",
    "inner_corners",
    "number_pair",
    "off_ground",
    "one_of",
    "parse_pose_form",
    "parse_vector",
    "reader",
    "setup_from_answers",
    "target_precision",
]

#: The thesis' rig (section 5.2): f = 525 px, principal point at the centre of 640x480, a
#: ground 9 5/8 in below the camera centre. Offered as defaults, never assumed silently, by
#: the terminal, the browser and a plan alike.
THESIS_FOCAL_PX = 525.0
THESIS_IMAGE_SIZE = (640, 480)
THESIS_GROUND_HEIGHT_IN = 9.625
#: The camera of a session set up by hand (terminal or browser): one laptop webcam.
CAMERA_ID = "cam0"


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
    ground_height: float | None
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

    def ground(self) -> GroundPlane | None:
        """The ground plane ``y = h`` (method 2), or None."""
        return GroundPlane(offset=self.ground_height) if self.ground_height else None

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
            ground_height=continued.ground.offset if continued.ground else None,
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
    ground: GroundPlane | None,
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

    sizes = [(c.intrinsics.width, c.intrinsics.height) for c in cameras]
    spec = ground.spec() if ground is not None else None
    return check_applicable(rig, units, spec, sizes, "the rig file")


class FormRefusedError(InputValueError):
    """A form's answers refused; ``errors`` holds every refusal by field name, in the
    operator's words (the console shows each next to its field)."""

    def __init__(self, errors: Mapping[str, str]) -> None:
        self.errors = dict(errors)
        super().__init__("; ".join(f"{_LABELS.get(k, k)}: {v}" for k, v in self.errors.items()))


def parse_pose_form(form: Mapping[str, str], units: Units) -> tuple[Vec3, Vec3]:
    """A pose typed in a form (``x``, ``y``, ``z``, ``rotation``), each field read as the
    terminal reads it (:mod:`twopose.bounds`); raises :class:`FormRefusedError` with every
    refusal."""
    errors: dict[str, str] = {}
    xyz: list[float] = []
    for axis in "xyz":
        try:
            xyz.append(POSE_TRANSLATION.read(str(form.get(axis, "") or ""), units, axis=axis))
        except InputValueError as err:
            errors[axis] = str(err)
    rotation = str(form.get("rotation", "") or "").strip() or "0, 0, 0"
    r: Vec3 = (0.0, 0.0, 0.0)
    try:
        r = parse_vector(rotation, units, quantity=ROTATION)
    except InputValueError as err:
        errors["rotation"] = str(err)
    if errors:
        raise FormRefusedError(errors)
    return (xyz[0], xyz[1], xyz[2]), r


# --------------------------------------------------------------------------- the checks


def parse_vector(text: str, units: Units | None, *, quantity: Quantity = POSE_TRANSLATION) -> Vec3:
    """Three numbers typed as ``x, y, z`` (commas or spaces), each within ``quantity``'s
    bound (:mod:`twopose.bounds`); raises InputValueError."""
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


def off_ground(point: Vec3, height: float, units: Units) -> str:
    """Why a method 2 ground truth point is not on the ground plane ``y = height`` (empty
    when it is, within the units' tolerance: half a 1/16 in tape tick, or half a
    millimetre). Every front end refuses such a point unless the operator keeps it: the
    terminal asks, the browser has a box to tick, a plan says ``keep_off_ground = true``."""
    gap = point[1] - height
    if abs(gap) <= unit_spec(units).ground_tolerance:
        return ""
    return (
        f"the ground truth {point} has y = {point[1]:g} {units}, but the ground plane is at "
        f"y = {height:g} {units} ({gap:+g} {units}): the finger points at the table, so "
        "its y should be the ground height"
    )


def default_ground_height(units: Units) -> str:
    """The thesis' ground height where the units are the thesis' (the units registry's
    default, :data:`twopose.units.DEFAULT_UNITS`); nothing to assume otherwise."""
    return f"{THESIS_GROUND_HEIGHT_IN:g}" if units == DEFAULT_UNITS else ""


# --------------------------------------------------------------------------- the fields


def _every_method(_spec: MethodSpec) -> bool:
    return True


def _measuring(spec: MethodSpec) -> bool:
    """A method that reconstructs something: it has a ground truth and a stop rule."""
    return spec.measures


def _calibrating(spec: MethodSpec) -> bool:
    """A method that reconstructs nothing (the board): its truth is the board's placement."""
    return not spec.measures


def _on_the_ground(spec: MethodSpec) -> bool:
    """A method whose estimate needs the ground plane y = h: it asks the ground height."""
    return spec.needs_ground


def _two_truth_points(spec: MethodSpec) -> bool:
    """A method whose ground truth is a line's two points."""
    return spec.truth_points >= 2


@dataclass(frozen=True, kw_only=True)
class SetupField:
    """One answer of the setup, as the page shows it.

    Which methods ask it is decided by each method's spec (:class:`twopose.methods.MethodSpec`:
    ``needs_ground``, ``measures``, ``truth_points``), never by naming methods: a method
    added to the registry is asked what its flags say, by the page, the terminal and
    :func:`setup_from_answers` alike.
    """

    name: str  # the form's key
    label: str  # the operator's words
    kind: str  # choice, text or check
    #: Whether a method asks it, from the method's spec (default: every method).
    asked_by: Callable[[MethodSpec], bool] = field(default=_every_method, repr=False)
    options: tuple[str, ...] = ()

    @property
    def methods(self) -> tuple[Method, ...]:
        """The methods that ask it: those of the registry whose spec says so."""
        return tuple(m for m, spec in registry.METHOD_SPECS.items() if self.asked_by(spec))

    def asks(self, method: Method) -> bool:
        """Whether a session of ``method`` asks this field."""
        return self.asked_by(spec_of(method))


SETUP_FIELDS: tuple[SetupField, ...] = (
    SetupField(name="method", label="method", kind="choice", options=METHODS),
    SetupField(name="units", label="units", kind="choice", options=UNITS),
    SetupField(name="focal", label="focal length (px)", kind="text"),
    SetupField(name="principal", label="principal point cx, cy (px)", kind="text"),
    SetupField(
        name="ground_height",
        label="ground height: camera centre to table",
        kind="text",
        asked_by=_on_the_ground,
    ),
    SetupField(
        name="board",
        label="board's inner corners COLSxROWS",
        kind="text",
        asked_by=_calibrating,
    ),
    SetupField(name="square", label="board's square side", kind="text", asked_by=_calibrating),
    SetupField(
        name="board_corner",
        label="board's first inner corner x, y, z (lower left)",
        kind="text",
        asked_by=_calibrating,
    ),
    SetupField(name="truth1", label="ground-truth point x, y, z", kind="text", asked_by=_measuring),
    SetupField(
        name="truth2",
        label="second ground-truth point x, y, z",
        kind="text",
        asked_by=_two_truth_points,
    ),
    SetupField(
        name="keep_off_ground",
        label="keep a ground-truth point that is off the ground",
        kind="check",
        asked_by=_on_the_ground,
    ),
    SetupField(name="operator", label="operator", kind="text"),
    SetupField(
        name="target_precision",
        label="stop a trial when its 95% region is within (session units; empty: none)",
        kind="text",
        asked_by=_measuring,
    ),
)
_FIELDS = {f.name: f for f in SETUP_FIELDS}
_LABELS = {f.name: f.label for f in SETUP_FIELDS} | {"rotation": "rotation", "rig": "rig file"}


def _given_text(name: str, given: Mapping[str, Any]) -> str | None:
    """The command line's answer for a field, as text (None: not given)."""
    k = given.get("intrinsics")
    truth = list(given.get("ground_truth") or [])
    b = given.get("board")
    texts: dict[str, Any] = {
        "method": given.get("method"),
        "units": given.get("units") if given.get("units") in UNITS else None,
        "focal": shown(k.fx) if k is not None else given.get("focal"),
        "principal": f"{shown(k.cx)}, {shown(k.cy)}" if k is not None else given.get("principal"),
        "ground_height": given.get("ground_height"),
        "truth1": truth[0] if truth else None,
        "truth2": truth[1] if len(truth) > 1 else None,
        "keep_off_ground": None,
        "board": "x".join(str(n) for n in b.inner_corners) if b is not None else None,
        "square": b.square if b is not None else None,
        "board_corner": b.first_corner if b is not None else None,
        "operator": given.get("operator"),
        "target_precision": given.get("target_precision"),
    }
    value = texts[name]
    if value is None or (value == "" and name != "operator"):
        return None
    if isinstance(value, tuple):
        return ", ".join(shown(v) for v in value)
    return shown(value) if isinstance(value, float) else str(value)


def _default_text(name: str, units: Units) -> str:
    defaults = {
        "units": DEFAULT_UNITS.value,
        "focal": f"{THESIS_FOCAL_PX:g}",
        "principal": ", ".join(f"{v:g}" for v in default_principal(THESIS_IMAGE_SIZE)),
        "ground_height": default_ground_height(units),
    }
    return defaults.get(name, "")


def form_fields(given: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The setup form as the page draws it: each field with what the command line gave
    (shown read-only), or its default (the thesis' rig), and the methods it applies to.

    ``from`` says where a field's value comes from: ``given["given_from"]`` names the file
    a continuation's fixed fields come from (else the command line), and
    ``given["prefill"]`` holds ``(value, from)`` for fields filled in but the operator's
    to change (a continuation's stop rule and operator).
    """
    units = Units(given.get("units") or DEFAULT_UNITS)
    given_from: Mapping[str, str] = given.get("given_from") or {}
    prefill: Mapping[str, tuple[Any, str]] = given.get("prefill") or {}
    fields = []
    for f in SETUP_FIELDS:
        fixed = _given_text(f.name, given)
        value, source = fixed, given_from.get(f.name, "the command line")
        if fixed is None:
            filled = prefill.get(f.name)
            value = _given_text(f.name, {f.name: filled[0]}) if filled else None
            source = filled[1] if filled else ""
            if value is None:
                value = _default_text(f.name, units)
        fields.append(
            {
                "name": f.name,
                "label": f.label,
                "kind": f.kind,
                "options": list(f.options),
                "methods": list(f.methods),
                "given": fixed is not None,
                "from": source,
                "value": value,
            }
        )
    return fields


# --------------------------------------------------------------------------- a whole form


class _Answers:
    """The form's answers with the command line's on top; refusals collected by field."""

    def __init__(self, form: Mapping[str, str], given: Mapping[str, Any]) -> None:
        self.form, self.given = form, given
        self.errors: dict[str, str] = {}

    def text(self, name: str) -> str:
        fixed = _given_text(name, self.given)
        return fixed if fixed is not None else str(self.form.get(name, "") or "").strip()

    def check(self, name: str, parse: Callable[[str], Any]) -> Any:
        """The parsed answer, or None with the refusal kept under ``name``."""
        try:
            return parse(self.text(name))
        except InputValueError as err:
            self.errors[name] = str(err)
            return None


def setup_from_answers(form: Mapping[str, str], given: Mapping[str, Any]) -> Setup:
    """The setup a form describes, with what the command line gave taking precedence over
    the form (the page shows it read-only); empty text fields take their defaults. Raises
    :class:`FormRefusedError` holding every refusal, by field."""
    a = _Answers(form, given)
    method = a.check("method", _method)
    units = a.check("units", lambda s: Units(one_of(UNITS)(s or DEFAULT_UNITS))) or DEFAULT_UNITS
    intrinsics = given.get("intrinsics") or _intrinsics(a, given.get("size", (640, 480)))
    height = None
    if method is not None and _FIELDS["ground_height"].asks(method):
        height = a.check("ground_height", lambda s: _ground_height(s, units))
    truth = _truth(a, method, units, height) if method is not None else ()
    board = _board(a, units) if method is not None and _FIELDS["board"].asks(method) else None
    operator = a.text("operator")
    target = None
    if method is not None and _FIELDS["target_precision"].asks(method):
        target = a.check("target_precision", lambda s: target_precision(s, units))
    if a.errors:
        raise FormRefusedError(a.errors)
    sigma = dict(given.get("intrinsics_sigma") or {})
    assert method is not None  # a.errors holds its refusal otherwise
    return Setup(
        method=method,
        units=units,
        intrinsics=intrinsics,
        ground_height=height,
        ground_truth=truth,
        operator=operator,
        intrinsics_sigma=sigma,
        board=board,
        target95=target,
    )


def _method(text: str) -> Method:
    if not text:
        raise InputValueError(f"choose {', '.join(METHODS)}")
    return Method(one_of(METHODS)(text))


def board_corner(text: str, units: Units | None) -> Vec3:
    """The board's first inner corner: a measured grid point, checked as a typed one."""
    return parse_vector(text, units, quantity=BOARD_CORNER)


def _board(a: _Answers, units: Units) -> BoardPlacement | None:
    """The board's size and placement (every part required: it is the session's truth)."""
    corners = a.check("board", inner_corners)
    square = a.check("square", reader(BOARD_SQUARE, units))
    corner = a.check("board_corner", lambda s: board_corner(s, units))
    if corners is None or square is None or corner is None:
        return None
    return BoardPlacement(inner_corners=corners, square=square, first_corner=corner)


def _ground_height(text: str, units: Units) -> float:
    if not text:
        raise InputValueError(f"type the height of the camera centre above the table ({units})")
    return GROUND_HEIGHT.read(text, units)


def _intrinsics(a: _Answers, size: tuple[int, int]) -> Intrinsics:
    focal = a.check("focal", lambda s: FOCAL.read(s or shown(THESIS_FOCAL_PX), None))
    principal = a.check("principal", lambda s: number_pair(s) if s else default_principal(size))
    f = focal or THESIS_FOCAL_PX
    cx, cy = principal or default_principal(size)
    if not (0 <= cx <= size[0] and 0 <= cy <= size[1]):  # a typo: it lies in the image
        a.errors["principal"] = (
            f"the principal point ({cx:g}, {cy:g}) px is outside the {size[0]}x{size[1]} "
            "image; type a point inside it (its centre if you do not know)"
        )
        return Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=size[0] / 2, cy=size[1] / 2)
    try:
        return Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=cx, cy=cy)
    except InputValueError as err:  # e.g. a principal point outside the image
        a.errors["principal"] = str(err)
        return Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=size[0] / 2, cy=size[1] / 2)


def _truth(a: _Answers, method: Method, units: Units, height: float | None) -> tuple[Vec3, ...]:
    """The ground truth (optional): a line's two points must differ, and a method 2 point
    off the ground plane is kept only when the operator ticked that it should be."""
    names = ("truth1", "truth2")[: spec_of(method).truth_points]
    points: list[Vec3] = []
    for name in names:
        if not a.text(name):
            continue
        point = a.check(
            name, lambda s: distinct_point(parse_vector(s, units, quantity=GROUND_TRUTH), points)
        )
        if point is not None:
            points.append(point)
    if spec_of(method).truth_points == 2 and len(points) == 1 and not a.errors:
        missing = "truth2" if a.text("truth1") else "truth1"
        a.errors[missing] = "a line needs two points (or leave both empty: no ground truth)"
    keep = a.text("keep_off_ground").lower() in ("y", "yes", "true", "on", "1")
    if height is not None and points and not keep:
        off = off_ground(points[0], height, units)
        if off:
            a.errors["truth1"] = f"{off}; tick '{_LABELS['keep_off_ground']}' to keep it"
    return tuple(points)


@dataclass(frozen=True, kw_only=True)
class GuidanceAsked:
    """The guidance a recording was asked for (``new``'s options): the most poses of a
    trial with a stop rule, and the reach of the suggestions (None: the thesis'). The stop
    rule's precision is the setup's (:attr:`Setup.target95`), given or answered.
    ``given`` names the guidance options the command line gave (a board session refuses
    them: :meth:`refusals`)."""

    max_poses: int = 6
    reach: float | None = None
    spacing: float | None = None
    given: tuple[str, ...] = ()

    def refusals(self, method: Method, units: Units) -> dict[str, str]:
        """Why these options cannot guide a session of ``method`` in ``units``, by the
        setup field the page shows it at ({}: they can). The terminal, the page and the
        command line refuse with these words (a plan: :func:`recorder.plan.load_plan`)."""
        if not spec_of(method).measures and self.given:
            return {"method": board_refusal(self.given)}
        errors = {}
        for value, quantity in ((self.reach, REACH), (self.spacing, GRID)):
            why = quantity.refusal(value, units) if value is not None else ""
            if why:
                errors["units"] = f"--{'grid' if quantity is GRID else 'reach'}: {why}"
        return errors

    def guidance(self, units: Units, poses: int, target95: float | None) -> Guidance:
        """The recording's guidance in the session's units; without a target, a trial
        has ``poses`` poses (``--poses``), as without guidance."""
        from twopose.guidance import Guidance, Reach

        thesis = Reach.thesis(units)
        radius = self.reach if self.reach is not None else thesis.radius
        spacing = self.spacing if self.spacing is not None else thesis.spacing
        for value, quantity in ((radius, REACH), (spacing, GRID)):
            quantity.read(value, units)
        if spacing > radius:
            raise InputValueError(
                f"the grid spacing ({spacing:g} {units}) must be within the reach "
                f"({radius:g} {units})"
            )
        most = MAX_POSES.count(self.max_poses) if target95 is not None else POSES.count(poses)
        try:
            return Guidance(
                reach=Reach(radius=radius, spacing=spacing), target95=target95,
                max_poses=most,
            )  # fmt: skip
        except ValueError as err:
            raise InputValueError(str(err)) from None


def board_refusal(options: Sequence[str]) -> str:
    """Why a board session refuses guidance options (``--target-precision``, ``--reach``,
    ``--grid``, ``--max-poses``, ``--adaptive-frames``; a plan's ``[guidance]``)."""
    return (
        f"{', '.join(options)}: a board session has no guidance: it locates no target, so "
        "nothing suggests its poses, says when a trial is precise enough or when a pose has "
        "frames enough; leave them out"
    )
