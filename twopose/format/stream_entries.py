"""A two-camera session's typed entries (format 1.6): the pair, its clocks, its streams.

- :class:`PairEntry` on ``/twopose/pair``: the pair's calibration
  (:class:`twopose.pair.calibration.PairCalibration`: both cameras' intrinsics, camera 2's
  pose in camera 1's frame with its 6x6 covariance, the fit's RMS, the floor);
- :class:`ClockOffsetEntry` on ``/twopose/clock_offset``: camera 2's capture clock minus
  camera 1's, measured, with its 1-sigma (:class:`twopose.pair.clock.ClockOffset`);
- :class:`StreamWindow` on ``/twopose/stream``: which frames of a camera belong to which
  stream trial (a window is announced ``open`` when it starts, closed ``complete`` when it
  ends; a crash loses at most the open one);
- :class:`Touch` on ``/twopose/touch``: a moment the target was at a known grid point.

In a two-camera session the grid frame is camera 1's frame (x right, y down, z forward),
so the pair's floor, the ground plane and the touches' points share one frame. The
entries are data alone: :mod:`twopose.format.pair_convert` turns them into the pair's core
types and back (so that the format, which the core's solvers import, imports nothing of
the pair).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

from twopose.camera.model import SIGMA_KEYS
from twopose.errors import InputValueError
from twopose.format.declared import (
    CAMERA_SCHEMA,
    INDEX_SCHEMA,
    TypedEntry,
    entry,
    json_field,
    vec3_schema,
)
from twopose.values.checks import Vec3, camera_id, finite, index, vec3
from twopose.values.units import UNITS, Units

__all__ = [
    "CLOCK_SOURCES",
    "STREAM_ENTRIES",
    "TOUCH_MARKS",
    "ClockOffsetEntry",
    "PairEntry",
    "StreamWindow",
    "Touch",
]

#: Where a camera's capture times come from (the session entry's ``clocks``): the
#: driver's stamp (the kernel's V4L2 buffer time), the monotonic clock when the frame was
#: grabbed, or the simulator's clock.
CLOCK_SOURCES = ("driver", "monotonic at grab", "simulated")
#: How a touch was marked: a key at the terminal, the console's button, a plan's schedule.
TOUCH_MARKS = ("key", "button", "schedule")
WindowStatus = Literal["open", "complete", "incomplete"]
TouchMark = Literal["key", "button", "schedule"]


def _matrix_schema(n: int, description: str) -> dict[str, Any]:
    row = {"type": "array", "items": {"type": "number"}, "minItems": n, "maxItems": n}
    return {"type": "array", "items": row, "minItems": n, "maxItems": n,
            "description": description}  # fmt: skip


def _rows(values: Any) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in values)


_INTRINSICS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        **{k: {"type": "integer", "minimum": 1} for k in ("width", "height")},
        **{k: {"type": "number"} for k in ("fx", "fy", "cx", "cy")},
        "distortion": {"type": "array", "items": {"type": "number"}, "minItems": 5,
                       "maxItems": 5},
    },
    "required": ["width", "height", "fx", "fy", "cx", "cy", "distortion"],
    "additionalProperties": False,
}  # fmt: skip
_SIGMA_SCHEMA: dict[str, Any] = {
    "type": "object",
    "propertyNames": {"enum": list(SIGMA_KEYS)},
    "additionalProperties": {"type": "number", "minimum": 0},
}
_FLOOR_SCHEMA: dict[str, Any] = {
    "type": "object",
    "description": "the floor normal . p = height in camera 1's frame, the normal toward it",
    "properties": {
        "normal": vec3_schema("unit normal, camera 1's frame"),
        "height": {"type": "number", "exclusiveMinimum": 0},
        "cov": _matrix_schema(4, "covariance of (normal, height)"),
    },
    "required": ["normal", "height", "cov"],
    "additionalProperties": False,
}
_MAYBE = {"type": ["number", "null"]}  # a check's statistic over no spacing is NaN: null
_CHECK_KEYS = ("worst_sigmas", "median_error", "median_sigma")
_CHECK_SCHEMA: dict[str, Any] = {
    "type": "object",
    "description": "the leave-one-out check of the covariance (docs/pair-file.md)",
    "properties": {
        "folds": INDEX_SCHEMA,
        "spacings": INDEX_SCHEMA,
        "beyond_3_sigma": INDEX_SCHEMA,
        **dict.fromkeys(_CHECK_KEYS, _MAYBE),
        "jackknife_ratio": {"type": "array", "items": _MAYBE, "minItems": 6, "maxItems": 6},
        "passed": {"type": "boolean"},
    },
    "required": ["folds", "spacings", "beyond_3_sigma", *_CHECK_KEYS, "jackknife_ratio",
                 "passed"],
    "additionalProperties": False,
}  # fmt: skip


@entry(
    "/twopose/pair",
    "PairCalibration",
    "Two cameras fixed to each other (1.6): intrinsics, camera 2's pose in camera 1's frame "
    "(p1 = R_2_to_1 p2 + t_2_in_1, session units) with its covariance, the fit's RMS, the floor.",
)
@dataclass(frozen=True, kw_only=True)
class PairEntry(TypedEntry):
    """The pair's calibration as a session stores it.

    As the pair file holds it (docs/pair-file.md), in the session's units, with the ids of
    the session's camera 1 and camera 2. :func:`twopose.format.pair_convert.pair_entry`
    makes it of a :class:`~twopose.pair.calibration.PairCalibration`, and
    :func:`~twopose.format.pair_convert.pair_calibration` that calibration of it (checked:
    a rotation, covariances, a unit floor normal).
    """

    camera1: str = json_field("camera1", CAMERA_SCHEMA)
    camera2: str = json_field("camera2", CAMERA_SCHEMA)
    units: Units = json_field("units", {"enum": list(UNITS)})
    R_2_to_1: tuple[tuple[float, ...], ...] = json_field(
        "R_2_to_1", _matrix_schema(3, "rows: camera 2's axes in camera 1's frame"), decode=_rows
    )
    t_2_in_1: Vec3 = json_field("t_2_in_1", vec3_schema("camera 2's centre in camera 1's frame"))
    cov_extrinsic: tuple[tuple[float, ...], ...] = json_field(
        "cov_extrinsic",
        _matrix_schema(6, "covariance of (rotation vector in camera 1's frame, rad; t_2_in_1)"),
        decode=_rows,
    )
    cov_factor: float = json_field("cov_factor", {"type": "number", "minimum": 1}, default=1.0)
    rms_px: float = json_field("rms_px", {"type": "number", "minimum": 0})
    views: int = json_field("views", INDEX_SCHEMA)
    intrinsics1: dict[str, Any] = json_field("intrinsics1", _INTRINSICS_SCHEMA, compare=False)
    intrinsics2: dict[str, Any] = json_field("intrinsics2", _INTRINSICS_SCHEMA, compare=False)
    sigma1: dict[str, float] | None = json_field(
        "sigma1", _SIGMA_SCHEMA, required=False, default=None, compare=False
    )
    sigma2: dict[str, float] | None = json_field(
        "sigma2", _SIGMA_SCHEMA, required=False, default=None, compare=False
    )
    floor: dict[str, Any] | None = json_field(
        "floor", _FLOOR_SCHEMA, required=False, default=None, compare=False
    )
    intrinsics_from: str = json_field(
        "intrinsics_from", {"type": "string"}, required=False, default=""
    )
    view_names: tuple[str, ...] = json_field(
        "view_names", {"type": "array", "items": {"type": "string"}}, required=False,
        default=(), decode=tuple,
    )  # fmt: skip
    view_rms_px: tuple[float, ...] = json_field(
        "view_rms_px", {"type": "array", "items": {"type": "number", "minimum": 0}},
        required=False, default=(), decode=tuple,
    )  # fmt: skip
    dropped: tuple[str, ...] = json_field(
        "dropped", {"type": "array", "items": {"type": "string"}}, required=False, default=(),
        decode=tuple,
    )  # fmt: skip
    check: dict[str, Any] | None = json_field(
        "check", _CHECK_SCHEMA, required=False, default=None, compare=False
    )

    def __post_init__(self) -> None:
        """Check the cameras and the pose's shapes.

        The calibration they hold is built, and so checked, by
        :func:`twopose.format.pair_convert.pair_calibration`.
        """
        camera_id(self.camera1)
        camera_id(self.camera2)
        if self.camera1 == self.camera2:
            raise InputValueError(f"the pair's two cameras must differ, got {self.camera1!r}")
        object.__setattr__(self, "t_2_in_1", vec3(self.t_2_in_1, "t_2_in_1"))
        object.__setattr__(self, "R_2_to_1", _rows(self.R_2_to_1))
        object.__setattr__(self, "cov_extrinsic", _rows(self.cov_extrinsic))


@entry(
    "/twopose/clock_offset",
    "ClockOffset",
    "The cameras' clock offset (1.6): camera 2's capture clock minus camera 1's for the same "
    "instant (t1 = t2 - offset_ns), measured, with its 1-sigma; the last one applies.",
)
@dataclass(frozen=True, kw_only=True)
class ClockOffsetEntry(TypedEntry):
    """A measured clock offset (:class:`twopose.pair.clock.ClockOffset`) as stored.

    ``method`` how it was measured (``flash``, ``ray gap``, ``flash and ray gap``,
    ``pooled``), ``n`` the frames or pairs it rests on.
    """

    offset_ns: float = json_field("offset_ns", {"type": "number"})
    sigma_ns: float = json_field("sigma_ns", {"type": "number", "minimum": 0})
    method: str = json_field("method", {"type": "string", "minLength": 1})
    n: int = json_field("n", INDEX_SCHEMA)

    def __post_init__(self) -> None:
        """Check a finite offset, a 1-sigma >= 0 and the count."""
        finite(self.offset_ns, "clock offset")
        if finite(self.sigma_ns, "clock offset's sigma") < 0:
            raise InputValueError(f"the clock offset's sigma must be >= 0, got {self.sigma_ns}")
        index(self.n, "n")
        if not self.method.strip():
            raise InputValueError("the clock offset's method must be said")


@entry(
    "/twopose/stream",
    "StreamWindow",
    "A window of one camera's frames of a stream trial (1.6): the frames on its image topic "
    "with start_ns <= log_time <= end_ns; announced open, then closed.",
)
@dataclass(frozen=True, kw_only=True)
class StreamWindow(TypedEntry):
    """One window of a camera's frames of a stream trial (format 1.6).

    The frames are the messages on the camera's image topic with ``start_ns <= log_time
    <= end_ns``. A window is announced ``open`` when it starts (``end_ns = start_ns``, no
    frames yet) and closed when it ends (``complete``, or ``incomplete`` with the
    ``reason``); the last entry naming a trial's camera's window counts.
    """

    trial: int = json_field("trial", INDEX_SCHEMA)
    camera_id: str = json_field("camera", CAMERA_SCHEMA)
    window: int = json_field("window", {"type": "integer", "minimum": 1})
    start_ns: int = json_field("start_ns", INDEX_SCHEMA)
    end_ns: int = json_field("end_ns", INDEX_SCHEMA)
    n_frames: int = json_field("n_frames", INDEX_SCHEMA)
    status: WindowStatus = json_field("status", {"enum": ["open", "complete", "incomplete"]})
    reason: str = json_field("reason", {"type": "string"}, required=False, default="")
    dropped_frames: int = json_field("dropped_frames", INDEX_SCHEMA, required=False, default=0)

    def __post_init__(self) -> None:
        """Check the numbers, the camera and the status."""
        for name in ("trial", "start_ns", "end_ns", "n_frames", "dropped_frames"):
            index(getattr(self, name), name)
        if index(self.window, "window") < 1:
            raise InputValueError(f"stream windows are numbered from 1, got {self.window}")
        camera_id(self.camera_id)
        if self.end_ns < self.start_ns:
            raise InputValueError(f"window ends ({self.end_ns}) before it starts ({self.start_ns})")
        if self.status not in ("open", "complete", "incomplete"):
            raise InputValueError(
                f"window status must be open, complete or incomplete, got {self.status!r}"
            )


@entry(
    "/twopose/touch",
    "Touch",
    "A moment of a stream trial the target was at a known grid point (1.6): its time on "
    "camera 1's capture clock, the point (grid frame = camera 1's, session units), how marked.",
)
@dataclass(frozen=True, kw_only=True)
class Touch(TypedEntry):
    """A touch: the target at a known grid point at ``time_ns`` (camera 1's clock).

    ``point`` is the typed truth: the dot's centre (point), the point the finger's axis
    passes through (line: its tip there) or meets the floor at (ground). ``how`` it was
    marked: :data:`TOUCH_MARKS`.
    """

    trial: int = json_field("trial", INDEX_SCHEMA)
    touch: int = json_field("touch", {"type": "integer", "minimum": 1})
    time_ns: int = json_field("time_ns", INDEX_SCHEMA)
    point: Vec3 = json_field("point", vec3_schema("the grid point touched, session units"))
    how: TouchMark = json_field("how", {"enum": list(TOUCH_MARKS)})

    def __post_init__(self) -> None:
        """Check the trial, the number, the time, the point and the mark."""
        index(self.trial, "trial")
        if index(self.touch, "touch") < 1:
            raise InputValueError(f"touches are numbered from 1, got {self.touch}")
        index(self.time_ns, "touch time")
        object.__setattr__(self, "point", vec3(self.point, "touched point"))
        if self.how not in TOUCH_MARKS:
            raise InputValueError(
                f"a touch is marked by {', '.join(TOUCH_MARKS)}, got {self.how!r}"
            )


#: Format 1.6's entries, registered after the 1.1 decision channel in a two-camera
#: session (:func:`twopose.format.messages.register_session_channels`), in this order.
STREAM_ENTRIES: tuple[type[TypedEntry], ...] = (PairEntry, ClockOffsetEntry, StreamWindow, Touch)
