"""The simulator's truth entries: what a simulated trial really was.

``/simulation/truth`` (:class:`SimulationTruth`, format 1.0): a typed-pose trial's true
poses and target (a board session's trial: its true poses and the board's inner corners,
``kind`` ``"board"``). ``/twopose/sim/trajectory`` (:class:`SimTrajectory`, format 1.6): a
stream trial's true motion (the target at every frame's true instant), each camera's true
clock and the pair the frames were rendered with. Both are declared as every entry is
(:mod:`twopose.format.declared`); :mod:`twopose.format.entries` registers them.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Literal

from twopose.errors import InputValueError
from twopose.format.declared import (
    CAMERA_SCHEMA,
    INDEX_SCHEMA,
    TypedEntry,
    entry,
    from_json,
    json_field,
    object_schema,
    vec3_schema,
)
from twopose.methods.specs import TRUTH_POINTS, TruthKind
from twopose.values.checks import Vec3, camera_id, finite, index, numbers, vec3

__all__ = [
    "BOARD_TRUTH",
    "SimClock",
    "SimFrames",
    "SimTrajectory",
    "SimTruthKind",
    "SimulationTruth",
    "TruePose",
]

#: A simulated board session's truth: the poses the frames were rendered from, and the
#: board's inner corners as its target (the session entry's board, where it really stood).
BOARD_TRUTH: Literal["board"] = "board"
#: What a simulated trial's truth is: a target's point or line, or a board.
SimTruthKind = TruthKind | Literal["board"]
_POINTS_SCHEMA = {"enum": [*TRUTH_POINTS, BOARD_TRUTH]}


@dataclass(frozen=True, kw_only=True)
class TruePose:
    """The pose the simulated camera really had (the typed one carries the typing error)."""

    pose: int = json_field("pose", INDEX_SCHEMA)
    camera_id: str = json_field("camera", {"type": "string"})
    t_grid: Vec3 = json_field("translation", vec3_schema("true camera centre, grid frame"))
    r_deg: Vec3 = json_field("rotation_deg", vec3_schema("true (rx, ry, rz), degrees"))

    def __post_init__(self) -> None:
        """Check the true pose's six numbers."""
        object.__setattr__(self, "t_grid", vec3(self.t_grid, "true translation"))
        object.__setattr__(self, "r_deg", vec3(self.r_deg, "true rotation"))


@entry(
    "/simulation/truth",
    "SimulationTruth",
    "Simulated sessions only: the true poses (frames were rendered from these) and target.",
)
@dataclass(frozen=True, kw_only=True)
class SimulationTruth(TypedEntry):
    """What a simulated trial really was: true poses and the true point or line.

    A board session's trial (``kind`` :data:`BOARD_TRUTH`): its captures' true poses, and
    ``points_grid`` the board's inner corners (``BoardPlacement.corners_grid`` order).
    """

    trial: int = json_field("trial", INDEX_SCHEMA)
    poses: tuple[TruePose, ...] = json_field(
        "poses",
        {"type": "array", "items": object_schema(TruePose)},
        decode=lambda items: tuple(from_json(TruePose, p) for p in items),
    )
    kind: SimTruthKind = json_field("kind", _POINTS_SCHEMA)
    points_grid: tuple[Vec3, ...] = json_field(
        "points",
        {
            "type": "array",
            "items": vec3_schema("grid frame"),
            "minItems": 1,
            "description": "the true point, the line's two points, or the board's inner corners",
        },
    )
    rig: tuple[float, ...] | None = json_field(
        "rig",
        {
            "type": "array",
            "items": {"type": "number"},
            "minItems": 11,
            "maxItems": 11,
            "description": "the rig's systematic constants the frames were rendered with "
            "(twopose.rig.RIG_PARAMETERS order); absent: none",
        },
        required=False,
        default=None,
        decode=lambda values: tuple(float(v) for v in values),
    )

    def __post_init__(self) -> None:
        """Check the trial and the truth's points."""
        index(self.trial, "trial")
        object.__setattr__(
            self, "points_grid", tuple(vec3(p, "truth point") for p in self.points_grid)
        )
        if self.kind not in (*TRUTH_POINTS, BOARD_TRUTH):
            kinds = ", ".join((*TRUTH_POINTS, BOARD_TRUTH))
            raise InputValueError(f"a simulated truth's kind is one of {kinds}, got {self.kind!r}")
        if self.rig is not None:
            object.__setattr__(self, "rig", tuple(float(v) for v in numbers(self.rig, 11, "rig")))


# --------------------------------------------------------------------------- format 1.6


def _times(values: Any, what: str) -> tuple[int, ...]:
    """Whole nanoseconds that never go back (a clock's readings)."""
    times = tuple(index(v, what) for v in values)
    if any(b < a for a, b in itertools.pairwise(times)):
        raise InputValueError(f"{what} must not go back")
    return times


@dataclass(frozen=True, kw_only=True)
class SimClock:
    """One simulated camera's true clock (:class:`twopose.pair.motion.CameraClock`).

    ``fps`` its frame rate (times ``1 + drift_ppm 1e-6`` per interval), ``phase_ns`` its
    first frame after the session's true start, ``jitter_ns`` its stamps' 1-sigma,
    ``drop`` the share of frames it lost, ``offset_ns`` its clock minus camera 1's,
    ``latency_ns`` from a frame's capture to its write (its log time).
    """

    camera_id: str = json_field("camera", CAMERA_SCHEMA)
    fps: float = json_field("fps", {"type": "number", "exclusiveMinimum": 0})
    phase_ns: float = json_field("phase_ns", {"type": "number", "minimum": 0})
    drift_ppm: float = json_field("drift_ppm", {"type": "number"})
    jitter_ns: float = json_field("jitter_ns", {"type": "number", "minimum": 0})
    drop: float = json_field("drop", {"type": "number", "minimum": 0, "maximum": 1})
    offset_ns: float = json_field("offset_ns", {"type": "number"})
    latency_ns: float = json_field("latency_ns", {"type": "number", "minimum": 0})

    def __post_init__(self) -> None:
        """Check the camera and that every number is finite."""
        camera_id(self.camera_id)
        for name in (
            "fps",
            "phase_ns",
            "drift_ppm",
            "jitter_ns",
            "drop",
            "offset_ns",
            "latency_ns",
        ):
            finite(getattr(self, name), name)


@dataclass(frozen=True, kw_only=True)
class SimFrames:
    """The true capture instants (camera 1's clock, ns) of one camera's frames of a trial.

    In the order of the trial's frames on that camera's image topic (a dropped frame is
    not written, so it has none).
    """

    camera_id: str = json_field("camera", CAMERA_SCHEMA)
    true_ns: tuple[int, ...] = json_field(
        "true_ns", {"type": "array", "items": INDEX_SCHEMA}, decode=tuple
    )

    def __post_init__(self) -> None:
        """Check the camera and the instants."""
        camera_id(self.camera_id)
        object.__setattr__(self, "true_ns", _times(self.true_ns, "a frame's true instant"))


def _vectors(values: Any, what: str) -> tuple[Vec3, ...]:
    return tuple(vec3(v, what) for v in values)


@entry(
    "/twopose/sim/trajectory",
    "SimTrajectory",
    "Simulated stream trials only (1.6): the target's true motion, clocks and pair.",
)
@dataclass(frozen=True, kw_only=True)
class SimTrajectory(TypedEntry):
    """What a simulated stream trial really was (format 1.6).

    ``t_ns`` the samples' true instants on camera 1's clock (every written frame's and
    every touch's), ``points`` the target there (the dot's centre, the fingertip; grid
    frame, session units), ``directions`` the finger's unit direction from its knuckle
    toward its tip and on to the floor (absent for a dot), ``length`` the finger's length;
    ``frames`` each camera's frames' true instants, ``clocks`` each camera's true clock,
    ``R_2_to_1``, ``t_2_in_1`` the pair the frames were rendered with (a calibration's
    error apart from the session's pair).
    """

    trial: int = json_field("trial", INDEX_SCHEMA)
    t_ns: tuple[int, ...] = json_field(
        "t_ns", {"type": "array", "items": INDEX_SCHEMA, "minItems": 1}, decode=tuple
    )
    points: tuple[Vec3, ...] = json_field(
        "points", {"type": "array", "items": vec3_schema("grid frame")}, decode=tuple
    )
    directions: tuple[Vec3, ...] | None = json_field(
        "directions",
        {"type": "array", "items": vec3_schema("unit, grid frame")},
        required=False,
        default=None,
        decode=tuple,
    )
    length: float | None = json_field(
        "length", {"type": "number", "exclusiveMinimum": 0}, required=False, default=None
    )
    frames: tuple[SimFrames, ...] = json_field(
        "frames",
        {"type": "array", "items": object_schema(SimFrames)},
        decode=lambda items: tuple(from_json(SimFrames, f) for f in items),
    )
    clocks: tuple[SimClock, ...] = json_field(
        "clocks",
        {"type": "array", "items": object_schema(SimClock)},
        decode=lambda items: tuple(from_json(SimClock, c) for c in items),
    )
    R_2_to_1: tuple[Vec3, Vec3, Vec3] = json_field(
        "R_2_to_1",
        {"type": "array", "items": vec3_schema("a row"), "minItems": 3, "maxItems": 3},
        decode=tuple,
    )
    t_2_in_1: Vec3 = json_field("t_2_in_1", vec3_schema("camera 2's true centre, camera 1"))

    def __post_init__(self) -> None:
        """Check the samples (one point, and direction, per instant) and the pair."""
        index(self.trial, "trial")
        object.__setattr__(self, "t_ns", _times(self.t_ns, "a sample's instant"))
        object.__setattr__(self, "points", _vectors(self.points, "a true point"))
        if len(self.points) != len(self.t_ns):
            raise InputValueError(f"{len(self.points)} points for {len(self.t_ns)} instants")
        if self.directions is not None:
            directions = _vectors(self.directions, "a true direction")
            if len(directions) != len(self.t_ns):
                raise InputValueError(f"{len(directions)} directions for {len(self.t_ns)} instants")
            if any(abs(math.hypot(*d) - 1.0) > 1e-6 for d in directions):
                raise InputValueError("a true direction must be a unit vector")
            object.__setattr__(self, "directions", directions)
        rows = _vectors(self.R_2_to_1, "a row of R_2_to_1")
        if len(rows) != 3:
            raise InputValueError(f"R_2_to_1 needs 3 rows, got {len(rows)}")
        object.__setattr__(self, "R_2_to_1", rows)
        object.__setattr__(self, "t_2_in_1", vec3(self.t_2_in_1, "t_2_in_1"))
