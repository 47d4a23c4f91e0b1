"""Simulator scene parameters: every number the synthetic camera uses, loadable from TOML.

A scene file overrides any subset of the defaults below, table by table, e.g.::

    [finger]
    tilt_deg = 40.0

    [poses]
    x_range = [-3.0, 3.0]

Unknown tables or keys, wrong types and impossible values raise :class:`SceneError`
naming the key. Lengths are in the scene's ``units``; angles in degrees; colours are
8-bit sRGB as the camera would report them under full light.

Every length is a field marked by :data:`twopose.values.units.IS_LENGTH`: the defaults are the
thesis' inches, a file in other units gets them converted (``units = "cm"`` alone is the
default scene in centimetres), and :meth:`Scene.in_units` converts a whole scene, so the
same scene in any units renders the same images.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from twopose.camera.model import Intrinsics
from twopose.errors import SceneError
from twopose.methods.targets import FINGER_LENGTH, FINGER_TIP_HEIGHT, BoardPlacement
from twopose.rig.constants import RigConstants
from twopose.values.toml import build_dataclass, read_toml
from twopose.values.units import (
    IS_LENGTH,
    UNITS,
    Units,
    length_values,
    scale_lengths,
    unit_factor,
    unit_spec,
)

__all__ = [
    "CameraParams",
    "ClutterParams",
    "FingerParams",
    "LightingParams",
    "PointTargetParams",
    "PoseParams",
    "Scene",
    "SensorParams",
    "StandParams",
    "load_scene",
]

Pair = tuple[float, float]
Vec3 = tuple[float, float, float]
RGB = tuple[int, int, int]
Quad = tuple[float, float, float, float]


@dataclass(frozen=True, kw_only=True)
class CameraParams:
    """One camera: id and pinhole intrinsics (the thesis: f = 525 px, 640x480).

    ``calibration_sigma`` (fx, fy, cx, cy; pixels) is the 1-sigma of a calibration that
    gave these intrinsics: the session records the intrinsics with it, and the frames are
    rendered with true intrinsics drawn once per session from N(intrinsics, sigma^2)
    (:func:`recorder.simulate.one_camera.simulate_session`). Zero: the intrinsics are exact.
    """

    id: str = "cam0"
    width: int = 640
    height: int = 480
    fx: float = 525.0
    fy: float = 525.0
    cx: float = 320.0
    cy: float = 240.0
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    calibration_sigma: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    @property
    def intrinsics(self) -> Intrinsics:
        """The camera's intrinsics."""
        return Intrinsics(
            width=self.width,
            height=self.height,
            fx=self.fx,
            fy=self.fy,
            cx=self.cx,
            cy=self.cy,
            distortion=self.distortion,
        )


@dataclass(frozen=True, kw_only=True)
class PointTargetParams:
    """Method 1: a black dot on a white index card facing the camera (normal -z)."""

    position: Vec3 = field(default=(0.5, 1.5, 11.0), metadata=IS_LENGTH)
    dot_radius: float = field(default=0.15, metadata=IS_LENGTH)
    card_size: Pair = field(default=(5.0, 3.0), metadata=IS_LENGTH)
    # The card's centre minus the dot's centre, (x, y).
    card_offset: Pair = field(default=(0.8, -0.3), metadata=IS_LENGTH)
    dot_color: RGB = (25, 25, 28)
    card_color: RGB = (236, 236, 230)


@dataclass(frozen=True, kw_only=True)
class FingerParams:
    """The blue gloved finger, a 3-D capsule whose axis passes through the ground point.

    ``tilt_deg`` is the angle of the pointing direction from straight down; ``azimuth_deg``
    the direction of its horizontal part, from +z toward +x (180 points back at the camera).
    The tip sits ``tip_height`` above the ground along that line.
    """

    # (x, z) on the ground: the thesis' target (Appendix D).
    ground_point: Pair = field(default=(1.91, 8.375), metadata=IS_LENGTH)
    tilt_deg: float = 35.0
    azimuth_deg: float = 165.0
    tip_height: float = field(default=FINGER_TIP_HEIGHT, metadata=IS_LENGTH)
    length: float = field(default=FINGER_LENGTH, metadata=IS_LENGTH)
    radius: float = field(default=0.33, metadata=IS_LENGTH)
    color: RGB = (38, 108, 192)
    specular: float = 0.10


@dataclass(frozen=True, kw_only=True)
class StandParams:
    """The laboratory test stand holding the target: base plate, vertical rod, arm."""

    # The rod's (x, z) minus the held object's attachment point.
    rod_offset: Pair = field(default=(2.5, 1.5), metadata=IS_LENGTH)
    rod_radius: float = field(default=0.22, metadata=IS_LENGTH)
    base_size: Pair = field(default=(4.0, 6.0), metadata=IS_LENGTH)
    base_height: float = field(default=0.4, metadata=IS_LENGTH)
    # The rod's top above the arm.
    rod_above: float = field(default=0.6, metadata=IS_LENGTH)
    # The arm's end behind the point target's card.
    arm_gap: float = field(default=0.15, metadata=IS_LENGTH)
    color: RGB = (128, 130, 135)
    base_color: RGB = (60, 60, 64)


@dataclass(frozen=True, kw_only=True)
class PoseParams:
    """How the operator places the laptop: nominal (typed) poses on a lattice, per trial.

    True pose = typed pose + N(0, noise_sigma) per translation component (and
    N(0, rotation_noise_deg) per angle): frames are rendered from the true pose. Each pose
    entry records ``typed_resolution`` as its translation resolution, the placing error the
    operator claims: 0 (the default) is ``noise_sigma``, an honest operator; a positive
    length simulates one whose real placing error differs from what they type (issue 46).

    ``moves``: ``"free"`` draws every pose of a trial anywhere in the ranges; ``"thesis"``
    draws the first so and moves the laptop from each pose to the next as the thesis did
    (section 5.3): along x only, or along x and depth z with the depth move the larger,
    each move's length drawn from ``move_range`` on the lattice.
    """

    count: int = 2
    x_range: Pair = field(default=(-2.0, 2.0), metadata=IS_LENGTH)
    y_range: Pair = field(default=(0.0, 0.0), metadata=IS_LENGTH)
    z_range: Pair = field(default=(-2.0, 1.0), metadata=IS_LENGTH)
    rx_range: Pair = (0.0, 0.0)
    ry_range: Pair = (0.0, 0.0)
    rz_range: Pair = (0.0, 0.0)
    step: float = field(default=0.25, metadata=IS_LENGTH)
    rotation_step_deg: float = 1.0
    min_baseline: float = field(default=1.0, metadata=IS_LENGTH)
    noise_sigma: float = field(default=0.1, metadata=IS_LENGTH)
    typed_resolution: float = field(default=0.0, metadata=IS_LENGTH)
    rotation_noise_deg: float = 0.0
    moves: Literal["free", "thesis"] = "free"
    move_range: Pair = field(default=(1.0, 3.0), metadata=IS_LENGTH)

    @property
    def typed_sigma(self) -> float:
        """The translation resolution each pose entry records.

        ``typed_resolution``, else the real placing error ``noise_sigma``.
        """
        return self.typed_resolution if self.typed_resolution > 0 else self.noise_sigma


@dataclass(frozen=True, kw_only=True)
class LightingParams:
    """Ambient + one directional light; per-frame gain, white-balance and gradient jitter."""

    ambient: float = 0.5
    diffuse: float = 0.5
    direction: Vec3 = (0.35, -1.0, -0.45)  # toward the light, grid frame (y down)
    gain_jitter: float = 0.04
    white_balance_jitter: float = 0.02
    gradient_jitter: float = 0.05
    vignetting: float = 0.12


@dataclass(frozen=True, kw_only=True)
class SensorParams:
    """Noise, encoding and timing of the webcam."""

    read_noise_dn: float = 1.5
    shot_noise_dn: float = 0.03  # noise variance per DN of signal
    jpeg_quality: int = 85
    image_format: Literal["jpeg", "png"] = "jpeg"
    supersample: int = 2
    fps: float = 30.0
    seconds_between_poses: float = 20.0


@dataclass(frozen=True, kw_only=True)
class ClutterParams:
    """Blue-ish objects the thesis' filters must reject, placed once per session.

    Kinds: ``disk`` (fails eccentricity), ``ring`` (fails the pi filter), ``triangle``
    (fails the pi filter), ``speck`` (fails area), ``navy`` (fails colour).
    """

    count: int = 6
    kinds: tuple[str, ...] = ("disk", "ring", "triangle", "speck", "navy")
    color: RGB = (40, 100, 190)
    navy_color: RGB = (22, 32, 110)
    table_x_range: Pair = field(default=(-10.0, 12.0), metadata=IS_LENGTH)
    table_z_range: Pair = field(default=(24.0, 36.0), metadata=IS_LENGTH)
    wall_x_range: Pair = field(default=(-22.0, 22.0), metadata=IS_LENGTH)
    wall_y_range: Pair = field(default=(-14.0, 2.0), metadata=IS_LENGTH)
    # The shapes' sizes: the wall is far, so its shapes are bigger to stay visible; a
    # speck's radius is drawn in speck_radius; decals keep a gap between their extents.
    wall_size: float = field(default=3.0, metadata=IS_LENGTH)
    table_size: float = field(default=1.6, metadata=IS_LENGTH)
    speck_radius: Pair = field(default=(0.08, 0.15), metadata=IS_LENGTH)
    gap: float = field(default=1.0, metadata=IS_LENGTH)


@dataclass(frozen=True, kw_only=True)
class BoardParams:
    """A printed checkerboard standing upright on the grid paper.

    Facing the camera (the rig-from-a-board calibration's target): ``inner_corners``
    (columns, rows) of squares of side ``square`` (session units), its first inner corner at
    the grid point ``first_corner``, its rows along +x and its columns rising (-y), in the
    plane z = ``first_corner`` z; a white margin of one square around the pattern. Rendered
    when ``present``. The default is OpenCV's sample board at 1 in squares, its pattern
    centred on x = 0, its margin on the grid paper.
    """

    present: bool = False
    inner_corners: tuple[int, int] = (9, 6)
    square: float = field(default=1.0, metadata=IS_LENGTH)
    first_corner: Vec3 = field(default=(-4.0, 7.625, 24.0), metadata=IS_LENGTH)
    dark_color: RGB = (20, 20, 22)
    light_color: RGB = (238, 238, 232)

    def placement(self) -> BoardPlacement:
        """Where the board stands, as a board session records it."""
        return BoardPlacement(
            inner_corners=self.inner_corners, square=self.square, first_corner=self.first_corner
        )


@dataclass(frozen=True, kw_only=True)
class Scene:
    """Everything the synthetic camera renders; defaults mirror the thesis' set-up."""

    units: str = "in"
    # The camera centre down to the table top (thesis: h).
    ground_height: float = field(default=9.625, metadata=IS_LENGTH)
    cameras: tuple[CameraParams, ...] = (CameraParams(),)
    point: PointTargetParams = field(default_factory=PointTargetParams)
    finger: FingerParams = field(default_factory=FingerParams)
    stand: StandParams = field(default_factory=StandParams)
    poses: PoseParams = field(default_factory=PoseParams)
    lighting: LightingParams = field(default_factory=LightingParams)
    sensor: SensorParams = field(default_factory=SensorParams)
    clutter: ClutterParams = field(default_factory=ClutterParams)
    board: BoardParams = field(default_factory=BoardParams)
    # The rig's hidden constants (twopose.rig.constants): frames are rendered with them, the typed
    # poses, intrinsics and ground height are not. None by default.
    systematic: RigConstants = field(default_factory=RigConstants)
    grid_spacing: float = field(default=0.5, metadata=IS_LENGTH)
    grid_line_width: float = field(default=0.02, metadata=IS_LENGTH)
    # x0 x1 z0 z1
    paper_extent: Quad = field(default=(-14.0, 14.0, -4.0, 28.0), metadata=IS_LENGTH)
    table_extent: Quad = field(default=(-30.0, 30.0, -12.0, 48.0), metadata=IS_LENGTH)
    wall_z: float = field(default=48.0, metadata=IS_LENGTH)
    paper_color: RGB = (232, 233, 226)
    grid_color: RGB = (150, 192, 212)
    table_color: RGB = (150, 108, 72)
    wall_color: RGB = (205, 196, 178)
    floor_color: RGB = (70, 66, 62)

    def __post_init__(self) -> None:
        """Check the scene (units, sizes, cameras, targets)."""
        _check_scene(self)

    def in_units(self, units: Units) -> Scene:
        """The same scene with every length in ``units`` (the images are the same).

        The lengths are the fields marked by :data:`twopose.values.units.IS_LENGTH`, the rig's
        constants' among them (their ``units`` follow when they name one).
        """
        factor = unit_factor(self.units, units)
        scene = scale_lengths(dataclasses.replace(self, units=str(unit_spec(units).units)), factor)
        if self.systematic.units is not None:
            scene = dataclasses.replace(
                scene, systematic=dataclasses.replace(scene.systematic, units=Units(scene.units))
            )
        return scene

    def with_intrinsics(self, intrinsics: Intrinsics) -> Scene:
        """The same scene seen through ``intrinsics``.

        Its first camera's focal, principal point, image size and distortion are replaced
        (its id and calibration sigma kept); the scene itself when they are its camera's
        already. Raises :class:`SceneError` when the scene cannot render them (a calibration
        sigma over a tenth of the new focal, say).
        """
        first = self.cameras[0]
        if first.intrinsics == intrinsics:
            return self
        camera = dataclasses.replace(
            first,
            width=intrinsics.width,
            height=intrinsics.height,
            fx=intrinsics.fx,
            fy=intrinsics.fy,
            cx=intrinsics.cx,
            cy=intrinsics.cy,
            distortion=intrinsics.distortion,
        )
        return dataclasses.replace(self, cameras=(camera, *self.cameras[1:]))


def _check_scene(s: Scene) -> None:
    def need(ok: bool, key: str, msg: str) -> None:  # noqa: FBT001 - an assertion: condition first
        if not ok:
            raise SceneError(f"scene: {key} {msg}")

    known = f"{', '.join(UNITS[:-1])} or {UNITS[-1]}"  # the registry's: "in, mm, cm or m"
    need(s.units in UNITS, "units", f"must be {known}, got {s.units!r}")
    need(s.ground_height > 0, "ground_height", "must be > 0 (the table is below the camera)")
    need(len(s.cameras) >= 1, "cameras", "needs at least one camera")
    need(len({c.id for c in s.cameras}) == len(s.cameras), "cameras", "ids must be unique")
    for c in s.cameras:
        need(
            0 < c.width <= 10_000 and 0 < c.height <= 10_000,
            "cameras.width/height",
            "must be 1-10000 pixels",
        )
        need(c.fx > 0 and c.fy > 0, "cameras.fx/fy", "must be > 0")
        sx, sy = c.calibration_sigma[:2]
        need(
            min(c.calibration_sigma) >= 0 and sx <= c.fx / 10 and sy <= c.fy / 10,
            "cameras.calibration_sigma",
            f"must be >= 0, the focal's at most a tenth of fx, fy; got {list(c.calibration_sigma)}",
        )
    b = s.board
    need(
        min(b.inner_corners) >= 2 and max(b.inner_corners) <= 50,
        "board.inner_corners",
        f"must be 2-50 each way, got {list(b.inner_corners)}",
    )
    need(b.square > 0, "board.square", f"must be > 0, got {b.square}")
    p = s.poses
    need(p.count >= 2, "poses.count", f"must be >= 2 (two views at least), got {p.count}")
    need(p.count <= 100, "poses.count", f"must be <= 100, got {p.count}")
    for name in ("x_range", "y_range", "z_range", "rx_range", "ry_range", "rz_range"):
        lo, hi = getattr(p, name)
        need(lo <= hi, f"poses.{name}", f"must be [low, high], got [{lo}, {hi}]")
    need(p.step >= 1e-3 and p.rotation_step_deg >= 1e-3, "poses.step", "must be >= 0.001")
    need(
        max(abs(v) for name in ("x_range", "y_range", "z_range") for v in getattr(p, name)) / p.step
        <= 1e6,
        "poses.step",
        "makes a lattice of over a million steps across the ranges",
    )
    need(p.noise_sigma >= 0 and p.rotation_noise_deg >= 0, "poses.noise_sigma", "must be >= 0")
    need(
        0 <= p.typed_resolution < math.inf,
        "poses.typed_resolution",
        "must be a length >= 0 (0: the operator types noise_sigma)",
    )
    lo, hi = p.move_range
    longest = 100.0 * unit_factor("in", s.units)
    need(
        0 < lo <= hi <= longest,
        "poses.move_range",
        f"must be 0 < low <= high <= {longest:g} ({s.units}), got {lo}, {hi}",
    )
    f = s.finger
    need(0 <= f.tilt_deg < 85, "finger.tilt_deg", "must be in [0, 85) degrees from straight down")
    need(f.length > 2 * f.radius > 0, "finger.length", "must exceed the finger's diameter")
    need(
        0 < f.tip_height < s.ground_height,
        "finger.tip_height",
        "must be between 0 and ground_height",
    )
    need(s.point.dot_radius > 0, "point.dot_radius", "must be > 0")
    se = s.sensor
    need(se.supersample in (1, 2, 3, 4), "sensor.supersample", "must be 1, 2, 3 or 4")
    need(1 <= se.jpeg_quality <= 100, "sensor.jpeg_quality", "must be 1-100")
    need(se.image_format in ("jpeg", "png"), "sensor.image_format", "must be jpeg or png")
    need(1 <= se.fps <= 1000, "sensor.fps", "must be 1-1000")
    need(0 <= s.clutter.count <= 10_000, "clutter.count", "must be 0-10000")
    bad = [k for k in s.clutter.kinds if k not in ("disk", "ring", "triangle", "speck", "navy")]
    need(not bad, "clutter.kinds", f"has unknown kinds {bad}")
    need(s.grid_spacing > 0, "grid_spacing", "must be > 0")
    for key, rgb in _colours(s):
        need(all(0 <= v <= 255 for v in rgb), key, f"must be 0-255 per channel, got {rgb}")


def _colours(s: Scene) -> list[tuple[str, RGB]]:
    """Every colour of the scene, by its key (dataclass fields typed RGB, one level deep)."""
    found = []
    for part in (s, *(getattr(s, f.name) for f in dataclasses.fields(s))):
        if not dataclasses.is_dataclass(part):
            continue
        prefix = (
            ""
            if part is s
            else next(f.name + "." for f in dataclasses.fields(s) if getattr(s, f.name) is part)
        )
        for f in dataclasses.fields(part):
            if f.name.endswith("color"):
                found.append((prefix + f.name, getattr(part, f.name)))
    return found


#: :class:`RigConstants` fields a scene does not set: the true rig is exact, and these are
#: what a fit of it records.
_FITTED_ONLY = ("cameras", "covariance")


def load_scene(path: str | Path | None = None, **overrides: Any) -> Scene:
    """Read a scene TOML file over the defaults; keyword overrides win over the file.

    Raises
    ------
    SceneError
        Unknown key, wrong type, or impossible value; the message names the key.
    """
    data = read_toml(path, "scene file", SceneError) if path is not None else {}
    data.update(overrides)
    fitted = sorted(set(data.get("systematic") or ()) & set(_FITTED_ONLY))
    if fitted:  # what a rig file's fit says of the constants, not the constants themselves
        raise SceneError(
            f"scene: systematic.{fitted[0]} is what a rig file's fit records (its "
            f"[[camera]], its [covariance]), not a constant of the simulated rig; leave it out"
        )
    return build_dataclass(Scene, _over_defaults_in_units(data), "scene", SceneError)


def _over_defaults_in_units(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` over the default scene's lengths converted to ``data``'s units.

    A file in centimetres that leaves a length out gets the default length in centimetres,
    not the inch number read as centimetres: the same scene, whatever its units.
    """
    units = data.get("units", Scene.units)
    if units not in UNITS or units == Scene.units:
        return data  # an unknown unit: the scene's check names it
    return _merged(length_values(Scene().in_units(units)), data)


def _merged(base: dict[str, Any], top: dict[str, Any]) -> dict[str, Any]:
    merged = dict(base)
    for key, value in top.items():
        below = merged.get(key)
        both_tables = isinstance(below, dict) and isinstance(value, dict)
        merged[key] = _merged(below, value) if both_tables else value  # type: ignore[arg-type]
    return merged
