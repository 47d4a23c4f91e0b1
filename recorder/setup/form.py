"""The setup's form: the field table and a whole form's answers read into a setup.

The field table says which answers the page shows, asked by which methods, with their
labels; :func:`setup_from_answers` reads a form into a :class:`recorder.setup.rules.Setup`,
every refusal reported at once, by field. The checks themselves are
:mod:`recorder.setup.rules`' parsers, the terminal's, called directly: the page and the
terminal refuse the same answers with the same words.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import twopose.methods.specs as registry
from recorder.setup.rules import (
    PLANE_OFFSET_KEY,
    THESIS_FOCAL_PX,
    THESIS_IMAGE_SIZE,
    Setup,
    board_corner,
    default_plane_offset,
    default_principal,
    distinct_point,
    inner_corners,
    no_plane_refusal,
    number_pair,
    off_plane,
    one_of,
    other_plane_refusal,
    parse_vector,
    plane_option,
    reader,
    target_precision,
)
from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError
from twopose.methods.planes import ConstraintPlane
from twopose.methods.specs import METHODS, Method, MethodSpec, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.values.bounds import (
    BOARD_SQUARE,
    FOCAL,
    GROUND_TRUTH,
    POSE_TRANSLATION,
    ROTATION,
    Quantity,
    shown,
)
from twopose.values.checks import Vec3
from twopose.values.units import DEFAULT_UNITS, UNITS, Units

__all__ = [
    "SETUP_FIELDS",
    "FormRefusedError",
    "SetupField",
    "form_fields",
    "parse_pose_form",
    "parse_touch_form",
    "setup_from_answers",
]


class FormRefusedError(InputValueError):
    """A form's answers refused; ``errors`` holds every refusal by field name, in the
    operator's words (the console shows each next to its field)."""

    def __init__(self, errors: Mapping[str, str]) -> None:
        self.errors = dict(errors)
        super().__init__("; ".join(f"{_LABELS.get(k, k)}: {v}" for k, v in self.errors.items()))


def parse_pose_form(form: Mapping[str, str], units: Units) -> tuple[Vec3, Vec3]:
    """A pose typed in a form (``x``, ``y``, ``z``, ``rotation``), each field read as the
    terminal reads it (:mod:`twopose.values.bounds`); raises :class:`FormRefusedError` with every
    refusal."""
    errors: dict[str, str] = {}
    xyz = _xyz(form, units, POSE_TRANSLATION, errors)
    rotation = str(form.get("rotation", "") or "").strip() or "0, 0, 0"
    r: Vec3 = (0.0, 0.0, 0.0)
    try:
        r = parse_vector(rotation, units, quantity=ROTATION)
    except InputValueError as err:
        errors["rotation"] = str(err)
    if errors:
        raise FormRefusedError(errors)
    return (xyz[0], xyz[1], xyz[2]), r


def parse_touch_form(form: Mapping[str, str], units: Units) -> Vec3:
    """A touch's grid point typed in the console (``x``, ``y``, ``z``: a pair's stream
    trial), each field read as the terminal reads a ground-truth point; raises
    :class:`FormRefusedError` with every refusal."""
    errors: dict[str, str] = {}
    xyz = _xyz(form, units, GROUND_TRUTH, errors)
    if errors:
        raise FormRefusedError(errors)
    return (xyz[0], xyz[1], xyz[2])


def _xyz(
    form: Mapping[str, str], units: Units, quantity: Quantity, errors: dict[str, str]
) -> list[float]:
    """The form's ``x``, ``y``, ``z`` read by ``quantity``; each refusal in ``errors``."""
    xyz: list[float] = []
    for axis in "xyz":
        try:
            xyz.append(quantity.read(str(form.get(axis, "") or ""), units, axis=axis))
        except InputValueError as err:
            errors[axis] = str(err)
    return xyz


# --------------------------------------------------------------------------- the fields


def _every_method(_spec: MethodSpec) -> bool:
    return True


def _measuring(spec: MethodSpec) -> bool:
    """A method that reconstructs something: it has a ground truth and a stop rule."""
    return spec.measures


def _calibrating(spec: MethodSpec) -> bool:
    """A method that reconstructs nothing (the board): its truth is the board's placement."""
    return not spec.measures


def _on_a_plane(spec: MethodSpec) -> bool:
    """A method whose estimate lies on a plane (method 2's ground y = h): it asks whether
    to keep a ground-truth point off that plane."""
    return spec.plane is not None


def _two_truth_points(spec: MethodSpec) -> bool:
    """A method whose ground truth is a line's two points."""
    return spec.truth_points >= 2


def _method(text: str, _units: Units) -> Method:
    if not text:
        raise InputValueError(f"choose {', '.join(METHODS)}")
    return Method(one_of(METHODS)(text))


def _units(text: str, _units: Units) -> Units:
    return Units(one_of(UNITS)(text))


def _focal(text: str, _units: Units) -> float:
    return FOCAL.read(text, None)


def _plane_offset(plane: ConstraintPlane, text: str, units: Units) -> float:
    """The plane's offset typed (method 2's ground height), read by its bound."""
    if not text:
        raise InputValueError(f"type {plane.measured} ({units})")
    return plane.bound.read(text, units)


def _no_default(_units: Units) -> str:
    return ""


@dataclass(frozen=True, kw_only=True)
class SetupField:
    """One answer of the setup, as the page shows it.

    Which methods ask it is decided by each method's spec
    (:class:`twopose.methods.specs.MethodSpec`:
    ``plane``, ``measures``, ``truth_points``), never by naming methods: a method
    added to the registry is asked what its flags say, by the page, the terminal and
    :func:`setup_from_answers` alike. A plane's offset is one field per plane of the
    registry (:func:`plane_fields`), keyed, labelled and bounded by the plane.
    """

    name: str  # the form's key
    label: str  # the operator's words
    kind: str  # choice, text or check
    #: Whether a method asks it, from the method's spec (default: every method).
    asked_by: Callable[[MethodSpec], bool] = field(default=_every_method, repr=False)
    options: Sequence[str] = ()
    #: The one reader of its typed text in the session's units, empty text its default's:
    #: the page's form and the terminal's question both call it (None: read with others,
    #: as a truth's points and a board's parts are).
    read: Callable[[str, Units], Any] | None = field(default=None, repr=False)
    #: The answer offered when nothing is typed, in the session's units ("": none).
    default: Callable[[Units], str] = field(default=_no_default, repr=False)
    #: Whether it is a length: the terminal's question then says the session's units.
    length: bool = False

    def question(self, units: Units) -> str:
        """The terminal's question for it: its label, with its options or units."""
        if self.options:
            return f"{self.label} ({', '.join(self.options)})"
        return f"{self.label} ({units})" if self.length else self.label

    def answer(self, text: str, units: Units) -> Any:
        """``text`` read by :attr:`read` (empty: the default's answer)."""
        assert self.read is not None, f"{self.name} is read with other fields"
        return self.read(text.strip() or self.default(units), units)

    @property
    def methods(self) -> tuple[Method, ...]:
        """The methods that ask it: those of the registry whose spec says so."""
        return tuple(m for m, spec in registry.METHOD_SPECS.items() if self.asked_by(spec))

    def asks(self, method: Method) -> bool:
        """Whether a session of ``method`` asks this field."""
        return self.asked_by(spec_of(method))


def _asked_by_the_plane(plane: ConstraintPlane) -> Callable[[MethodSpec], bool]:
    def asked(spec: MethodSpec) -> bool:
        return spec.plane == plane

    return asked


def plane_fields() -> tuple[SetupField, ...]:
    """One field per plane of the method registry (method 2's ground height): the plane's
    offset, under the plane's setup key, asked by the methods on that plane."""
    return tuple(
        SetupField(
            name=p.setup_key, label=p.label, kind="text", asked_by=_asked_by_the_plane(p),
            read=partial(_plane_offset, p), default=partial(default_plane_offset, p),
            length=True,
        )
        for p in registry.PLANES
    )  # fmt: skip


SETUP_FIELDS: tuple[SetupField, ...] = (
    SetupField(name="method", label="method", kind="choice", options=METHODS, read=_method),
    SetupField(
        name="units",
        label="units",
        kind="choice",
        options=UNITS,
        read=_units,
        default=lambda _u: DEFAULT_UNITS.value,
    ),
    SetupField(
        name="focal",
        label="focal length (px)",
        kind="text",
        read=_focal,
        default=lambda _u: shown(THESIS_FOCAL_PX),
    ),
    SetupField(name="principal", label="principal point cx, cy (px)", kind="text"),
    *plane_fields(),
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
        label="keep a ground-truth point that is off its plane (method 2: the ground)",
        kind="check",
        asked_by=_on_a_plane,
    ),
    SetupField(name="operator", label="operator", kind="text", read=lambda s, _u: s),
    SetupField(
        name="target_precision",
        label="stop a trial when its 95% region is within (session units; empty: none)",
        kind="text",
        asked_by=_measuring,
        read=lambda s, u: target_precision(s, u),
    ),
)
_FIELDS = {f.name: f for f in SETUP_FIELDS}
_PLANE_KEYS = frozenset(p.setup_key for p in registry.PLANES)
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
        "truth1": truth[0] if truth else None,
        "truth2": truth[1] if len(truth) > 1 else None,
        "keep_off_ground": None,
        "board": "x".join(str(n) for n in b.inner_corners) if b is not None else None,
        "square": b.square if b is not None else None,
        "board_corner": b.first_corner if b is not None else None,
        "operator": given.get("operator"),
        "target_precision": given.get("target_precision"),
    }
    value = texts[name] if name in texts else given.get(name)  # a plane's offset: its key
    if value is None and name in _PLANE_KEYS:  # --plane-offset: the method's plane's
        value = given.get(PLANE_OFFSET_KEY)
    if value is None or (value == "" and name != "operator"):
        return None
    if isinstance(value, tuple):
        return ", ".join(shown(v) for v in value)
    return shown(value) if isinstance(value, float) else str(value)


def _default_text(name: str, units: Units) -> str:
    if name == "principal":  # the thesis' image's centre (the terminal knows the camera's)
        return ", ".join(f"{v:g}" for v in default_principal(THESIS_IMAGE_SIZE))
    return _FIELDS[name].default(units)


def form_fields(given: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The setup form as the page draws it: each field with what the command line gave
    (shown read-only), or its default (the thesis' rig), and the methods it applies to.

    ``from`` says where a field's value comes from: ``given["given_from"]`` names the file
    a continuation's fixed fields come from (else the command line), and
    ``given["prefill"]`` holds ``(value, from)`` for fields filled in but the operator's
    to change (a continuation's stop rule and operator). ``unit_defaults`` is the default
    under each unit (the thesis' ground height, offered for inches only): the page refills
    a field whose default depends on the units when they change.
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
                "unit_defaults": {u.value: _default_text(f.name, u) for u in UNITS},
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
    method = a.check("method", lambda s: _FIELDS["method"].answer(s, DEFAULT_UNITS))
    units = a.check("units", lambda s: _FIELDS["units"].answer(s, DEFAULT_UNITS)) or DEFAULT_UNITS
    intrinsics = given.get("intrinsics") or _intrinsics(a, given.get("size", (640, 480)))
    spec = spec_of(method) if method is not None else None  # its spec travels from here
    plane = spec.plane if spec is not None else None
    offset = None
    keys = [k for k in given if given[k] is not None]
    refused = (
        other_plane_refusal(spec, keys, plane_option) or no_plane_refusal(spec, keys)
        if spec is not None
        else ""
    )
    if refused:  # the command line gave another plane's offset, or one to a method on none
        a.errors["method"] = refused
    if plane is not None:
        # Read as typed: an emptied field is refused, never the thesis' height assumed.
        read_offset = _FIELDS[plane.setup_key].read
        assert read_offset is not None
        offset = a.check(plane.setup_key, lambda s: read_offset(s, units))
    truth = _truth(a, spec, units, offset) if spec is not None else ()
    board = _board(a, units) if spec is not None and _FIELDS["board"].asked_by(spec) else None
    operator = a.text("operator")
    target = None
    if spec is not None and _FIELDS["target_precision"].asked_by(spec):
        target = a.check("target_precision", lambda s: _FIELDS["target_precision"].answer(s, units))
    if a.errors:
        raise FormRefusedError(a.errors)
    sigma = dict(given.get("intrinsics_sigma") or {})
    assert method is not None  # a.errors holds its refusal otherwise
    return Setup(
        method=method,
        units=units,
        intrinsics=intrinsics,
        plane_offset=offset,
        ground_truth=truth,
        operator=operator,
        intrinsics_sigma=sigma,
        board=board,
        target95=target,
    )


def _board(a: _Answers, units: Units) -> BoardPlacement | None:
    """The board's size and placement (every part required: it is the session's truth)."""
    corners = a.check("board", inner_corners)
    square = a.check("square", reader(BOARD_SQUARE, units))
    corner = a.check("board_corner", lambda s: board_corner(s, units))
    if corners is None or square is None or corner is None:
        return None
    return BoardPlacement(inner_corners=corners, square=square, first_corner=corner)


def _intrinsics(a: _Answers, size: tuple[int, int]) -> Intrinsics:
    focal = a.check("focal", lambda s: _FIELDS["focal"].answer(s, DEFAULT_UNITS))
    principal = a.check("principal", lambda s: number_pair(s) if s else default_principal(size))
    f = focal or THESIS_FOCAL_PX
    cx, cy = principal or default_principal(size)
    if not (0 <= cx <= size[0] and 0 <= cy <= size[1]):  # a typo: it lies in the image
        a.errors["principal"] = (
            f"the principal point ({shown(cx)}, {shown(cy)}) px is outside the {size[0]}x{size[1]} "
            "image; type a point inside it (its centre if you do not know)"
        )
        return Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=size[0] / 2, cy=size[1] / 2)
    try:
        return Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=cx, cy=cy)
    except InputValueError as err:  # e.g. a principal point outside the image
        a.errors["principal"] = str(err)
        return Intrinsics(width=size[0], height=size[1], fx=f, fy=f, cx=size[0] / 2, cy=size[1] / 2)


def _truth(a: _Answers, spec: MethodSpec, units: Units, offset: float | None) -> tuple[Vec3, ...]:
    """The ground truth (optional): a line's two points must differ, and a point off the
    method's plane (method 2's ground) is kept only when the operator ticked that it
    should be."""
    names = ("truth1", "truth2")[: spec.truth_points]
    points: list[Vec3] = []
    for name in names:
        if not a.text(name):
            continue
        point = a.check(
            name, lambda s: distinct_point(parse_vector(s, units, quantity=GROUND_TRUTH), points)
        )
        if point is not None:
            points.append(point)
    if spec.truth_points == 2 and len(points) == 1 and not a.errors:
        missing = "truth2" if a.text("truth1") else "truth1"
        a.errors[missing] = "a line needs two points (or leave both empty: no ground truth)"
    keep = a.text("keep_off_ground").lower() in ("y", "yes", "true", "on", "1")
    plane = spec.plane
    if plane is not None and offset is not None and points and not keep:
        off = off_plane(plane, points[0], offset, units)
        if off:
            a.errors["truth1"] = f"{off}; tick '{_LABELS['keep_off_ground']}' to keep it"
    return tuple(points)
