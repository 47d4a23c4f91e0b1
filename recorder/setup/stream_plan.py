"""A pair's plan: stream trials and their touches (``new --pair PAIR.toml --plan PLAN.toml``).

A plan for a pair (docs/recording.md, "Stream trials") gives the session's setup and, per
trial, the touches: each a grid point (``point = [x, y, z]``, session units, grid frame =
camera 1's) and, for a **scheduled** touch, its time ``at`` (seconds after the trial's
start: its first camera-1 frame); a touch without ``at`` is **keyed**: the operator
presses Enter at the terminal when the target is on it (the points in order). A trial's
``duration`` (seconds) ends it by itself; without one the operator ends it (``e``). Every
number is read by its quantity's one reader (:mod:`twopose.values.bounds`: the plan's
grammar); an unknown key, a one-camera key (poses, a camera: the pair file gives the
cameras), a scheduled touch after the trial's end, or one whose ``at`` is not later than
the scheduled touch before it (the plan's order is the touches' numbers; the target is at
one point at a time) is refused, naming it. A ground touch off the floor is refused once
the floor is known (:func:`touch_refusal`, also every touch's point as it is marked).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from recorder.setup.rules import PLANE_OFFSET_KEY
from twopose.errors import InputValueError
from twopose.methods.specs import METHODS, PLANES, Method, spec_of
from twopose.values.bounds import GROUND_TRUTH, STREAM_DURATION, TOUCH_TIME, Quantity
from twopose.values.checks import Vec3
from twopose.values.toml import read_toml
from twopose.values.units import DEFAULT_UNITS, UNITS, Units

if TYPE_CHECKING:
    from twopose.pair.calibration import PairCalibration

__all__ = [
    "StreamPlan",
    "StreamPlanTouch",
    "StreamPlanTrial",
    "load_stream_plan",
    "touch_refusal",
]

_TOP = {"method", "units", "operator", "notes", "trials", PLANE_OFFSET_KEY} | {
    p.setup_key for p in PLANES
}
_TRIAL = {"touches", "duration"}
_TOUCH = {"point", "at"}
#: What a one-camera plan has that a pair's has not, and why.
_ONE_CAMERA = {
    "camera": "the pair file gives both cameras",
    "cameras": "the pair file gives both cameras",
    "frames": "a stream trial records every frame",
    "adaptive_frames": "a stream trial records every frame",
    "guidance": "a stream trial has no poses to suggest",
    "board": "a pair is calibrated by calibrate-pair",
    "resolution": "no pose is typed",
    "poses": "a pair's trials are streams: no pose is typed",
    "ground_truth": "a stream trial's truth is its touches' points",
    "keep_off_ground": "a stream trial's truth is its touches' points",
    "max_poses": "no pose is typed",
    "start": "no pose is typed",
}


@dataclass(frozen=True, kw_only=True)
class StreamPlanTouch:
    """A planned touch: its grid point, and its time after the trial's start (None: keyed)."""

    point: Vec3
    at_s: float | None = None


@dataclass(frozen=True, kw_only=True)
class StreamPlanTrial:
    """A planned stream trial: its touches in order and its duration (None: ended by the
    operator)."""

    touches: tuple[StreamPlanTouch, ...]
    duration_s: float | None = None

    @property
    def scheduled(self) -> tuple[StreamPlanTouch, ...]:
        return tuple(t for t in self.touches if t.at_s is not None)

    @property
    def keyed(self) -> tuple[Vec3, ...]:
        """The points the operator marks by key, in order."""
        return tuple(t.point for t in self.touches if t.at_s is None)


@dataclass(frozen=True, kw_only=True)
class StreamPlan:
    """A pair's plan: the setup and its stream trials."""

    method: Method
    units: Units
    trials: tuple[StreamPlanTrial, ...]
    operator: str = ""
    notes: str = ""
    #: The method's plane's offset (method 2's ground height), where the plan gives it.
    plane_offset: float | None = None


def _table(value: Any, keys: set[str], where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise InputValueError(f"plan: {where or 'the plan'} must be a table")
    for key in sorted(value):
        if key in _ONE_CAMERA:
            raise InputValueError(
                f"plan: {where + '.' if where else ''}{key}: not in a pair's plan "
                f"({_ONE_CAMERA[key]}); leave it out"
            )
        if key not in keys:
            raise InputValueError(
                f"plan: unknown key {where + '.' if where else ''}{key}; known here: "
                f"{', '.join(sorted(keys))}"
            )
    return value


def _read(quantity: Quantity, value: Any, where: str, units: Units | None) -> float:
    try:
        return quantity.read(value, units, text=False)
    except InputValueError as err:
        raise InputValueError(f"plan: {where}: {err}") from None


def _touch(value: Any, where: str, units: Units, duration: float | None) -> StreamPlanTouch:
    t = _table(value, _TOUCH, where)
    if "point" not in t:
        raise InputValueError(f"plan: {where}.point is missing (the grid point x, y, z)")
    try:
        x, y, z = GROUND_TRUTH.read_vector(t["point"], units, text=False)
    except InputValueError as err:
        raise InputValueError(f"plan: {where}.point: {err}") from None
    at = None if "at" not in t else _read(TOUCH_TIME, t["at"], f"{where}.at", None)
    if at is not None and duration is not None and at > duration:
        raise InputValueError(
            f"plan: {where}.at {at:g} s is after the trial's end (duration {duration:g} s)"
        )
    return StreamPlanTouch(point=(x, y, z), at_s=at)


def _refuse_out_of_order(touches: tuple[StreamPlanTouch, ...], where: str) -> None:
    """A trial's scheduled touches in the order of their ``at`` (the touches are numbered
    in the plan's order, so one out of order would be renumbered), at most one at a time
    (the target is at one point at a moment)."""
    last: tuple[int, float] | None = None
    for k, touch in enumerate(touches, start=1):
        if touch.at_s is None:
            continue
        if last is not None and touch.at_s <= last[1]:
            j, at = last
            said = "the same moment as" if touch.at_s == at else "before"
            raise InputValueError(
                f"plan: {where}.touches[{k}].at {touch.at_s:g} s is {said} "
                f"{where}.touches[{j}].at {at:g} s: the target is at one point at a time; "
                "list a trial's scheduled touches in the order of their `at`, each later "
                "than the one before"
            )
        last = (k, touch.at_s)


def _trial(value: Any, i: int, units: Units) -> StreamPlanTrial:
    where = f"trials[{i}]"
    t = _table(value, _TRIAL, where)
    duration = t.get("duration")
    if duration is not None:
        duration = _read(STREAM_DURATION, duration, f"{where}.duration", None)
    raw = t.get("touches", [])
    if not isinstance(raw, list):
        raise InputValueError(f"plan: {where}.touches must be a list of touches")
    touches = tuple(
        _touch(v, f"{where}.touches[{k}]", units, duration) for k, v in enumerate(raw, start=1)
    )
    _refuse_out_of_order(touches, where)
    return StreamPlanTrial(touches=touches, duration_s=duration)


def _plane_offset(data: dict[str, Any], method: Method, units: Units) -> float | None:
    """The method's plane's offset under its key or ``plane_offset`` (never another's)."""
    plane = spec_of(method).plane
    keys = [k for k in (*(p.setup_key for p in PLANES), PLANE_OFFSET_KEY) if k in data]
    if plane is None or any(k not in (plane.setup_key, PLANE_OFFSET_KEY) for k in keys):
        if keys:
            raise InputValueError(f"plan: {keys[0]}: a {method} session measures on no such plane")
        return None
    if len(keys) > 1:
        raise InputValueError(f"plan: {' and '.join(keys)} both give {plane.name}'s offset")
    return None if not keys else _read(plane.bound, data[keys[0]], keys[0], units)


def load_stream_plan(path: str | Path) -> StreamPlan:
    """A pair's plan, read and checked (the module docstring); refusals name the key."""
    data = _table(read_toml(path, "plan", InputValueError), _TOP, "")
    method = data.get("method")
    if method not in METHODS or not spec_of(Method(method)).measures:
        measuring = [m for m in METHODS if spec_of(Method(m)).measures]
        got = "it has none" if method is None else f"got {method!r}"
        raise InputValueError(
            f"plan: method must be one of {', '.join(measuring)} (a pair's stream measures a "
            f"moving target; a continuation's, its session's): {got}"
        )
    units = data.get("units", DEFAULT_UNITS)
    if units not in UNITS:
        raise InputValueError(f"plan: units must be one of {', '.join(UNITS)}, got {units!r}")
    m, u = Method(method), Units(units)
    raw = data.get("trials", [])
    if not isinstance(raw, list) or not raw:
        raise InputValueError("plan: no [[trials]]")
    return StreamPlan(
        method=m, units=u, trials=tuple(_trial(t, i, u) for i, t in enumerate(raw, start=1)),
        operator=str(data.get("operator", "")), notes=str(data.get("notes", "")),
        plane_offset=_plane_offset(data, m, u),
    )  # fmt: skip


def touch_refusal(method: Method, pair: PairCalibration | None, units: Units, point: Vec3) -> str:
    """Why ``point`` (grid frame = camera 1's, ``units``) cannot be a touch of a ``method``
    session on ``pair`` ("": it can). A method on a plane (ground) touches its plane: the
    point must lie on the session's floor, ``normal . p = height`` (``y = h`` for a typed
    ground height), within the units' ground tolerance (half a 1/16 in tape tick, half a
    millimetre: a one-camera ground truth's) plus three of the floor's height sigmas (a
    calibrated floor's). The point and line methods take any grid point (the dot's place, a
    point the finger's line passes through) in front of both cameras; behind either, no
    camera saw a target there (a sign typed wrong: a new user's r7 K4)."""
    import numpy as np

    from twopose.values.bounds import shown
    from twopose.values.units import unit_spec

    behind = _behind(pair, units, point)
    if behind:
        return behind
    plane = spec_of(method).plane
    if plane is None or pair is None or pair.floor is None:
        return ""
    floor = pair.in_units(units).floor
    if floor is None:  # in_units keeps a floor: never
        return ""
    gap = float(np.dot(floor.normal, point)) - floor.height
    tol = unit_spec(units).ground_tolerance + 3.0 * float(np.sqrt(max(floor.cov[3, 3], 0.0)))
    if abs(gap) <= tol:
        return ""
    where = (
        f"{plane.axis} = {shown(floor.height)} {units}"
        if np.allclose(floor.normal, plane.normal_grid, atol=1e-12)
        else f"normal . p = {floor.height:.4g} {units}, normal "
        f"({', '.join(f'{v:.4f}' for v in floor.normal)})"
    )
    shown_point = ", ".join(shown(v) for v in point)
    return (
        f"({shown_point}) is {gap:+.4g} {units} off {plane.name} ({where}, within {tol:.2g} "
        f"{units}): a {method} touch is where the finger meets {plane.name}, so its grid "
        "point must lie on it"
    )


def _behind(pair: PairCalibration | None, units: Units, point: Vec3) -> str:
    """Why ``point`` (camera 1's frame, ``units``) is behind a camera of ``pair`` ("": not)."""
    import numpy as np

    from twopose.values.bounds import shown

    if pair is None:
        return ""
    mine = pair.in_units(units)
    p = np.asarray(point, dtype=np.float64)
    depths = (float(p[2]), float((mine.R_2_to_1.T @ (p - mine.t_2_in_1))[2]))
    for camera, depth in enumerate(depths, start=1):
        if depth <= 0.0:
            shown_point = ", ".join(shown(v) for v in point)
            return (
                f"({shown_point}) lies {abs(depth):.4g} {units} behind camera {camera} (the "
                "grid's z is camera 1's depth, ahead positive): no camera saw a target there: "
                "check its signs"
            )
    return ""
