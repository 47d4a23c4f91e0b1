"""A trial as Foxglove shows it, in one palette: detections and the 3-D scene.

A detection drawn on its image as ``foxglove.ImageAnnotations`` (:func:`image_annotations`),
live by the recorder and offline in results.mcap: the detected blob's outline, centroid and
orientation in green, candidates the filters turned down in red with the reason, and the
verdict.

A trial's 3-D geometry as a ``foxglove.SceneUpdate``, in the grid frame and session units:
the camera frustums, the back-projected rays (points) or planes (lines, method 2), the
estimate with its 95% ellipsoid, the ground truth and the error vector; and the static grid
and ground plane. Pure builders, shared by the analysis' results.mcap and the recorder's
live view. The geometry is the solver's grid frame: ``p_grid = R_cam_to_grid p_cam +
t_grid``, y down.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.PointsAnnotation_pb2 import PointsAnnotation
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from twopose.arrays import F64
from twopose.camera.model import quaternion_xyzw_from_matrix, rotation_from_angles_deg
from twopose.detect.detection import Detection
from twopose.format.entries import PlaneEntry
from twopose.format.messages import GRID_FRAME
from twopose.methods.specs import Method, spec_of
from twopose.uncertainty.propagate import chi2_95, region_dof

__all__ = [
    "BLACK",
    "GREEN",
    "RED",
    "TrialScene",
    "image_annotations",
    "scene_of_views",
    "set_color",
    "set_xy",
    "static_scene",
    "trial_scene",
]

if TYPE_CHECKING:
    from twopose.detect.frames import PoseMeasurement
    from twopose.solve.estimate import PoseView


RGBA = tuple[float, float, float, float]
GREEN: RGBA = (0.1, 0.85, 0.2, 1.0)
RED: RGBA = (0.95, 0.15, 0.1, 1.0)
BLACK: RGBA = (0.0, 0.0, 0.0, 0.6)
ORANGE = (1.0, 0.55, 0.0, 1.0)
BLUE = (0.2, 0.5, 1.0, 1.0)
GREY = (0.6, 0.6, 0.6, 0.6)
WHITE = (1.0, 1.0, 1.0, 1.0)


def set_color(msg: Any, rgba: RGBA) -> None:
    """Fill a ``foxglove.Color``."""
    msg.r, msg.g, msg.b, msg.a = rgba


def set_xy(msg: Any, x: float, y: float) -> None:
    """Fill a ``foxglove.Point2``."""
    msg.x, msg.y = float(x), float(y)


def image_annotations(det: Detection, log_time_ns: int, label: str) -> ImageAnnotations:
    """One frame's overlay: the detection, the candidates turned down, a label.

    One frame's overlay: outline, centroid and orientation of the detection (green), the
    candidates turned down (red, with why), and ``label`` with the verdict.
    """
    msg = ImageAnnotations()

    def outline(points: F64 | None, rgba: tuple[float, float, float, float]) -> None:
        if points is None or len(points) < 2:
            return
        # Within a pixel of the boundary: a drawing needs no more, and fewer points
        # keep the overlay cheap (it is built for every frame).
        simple = cv2.approxPolyDP(points.astype(np.float32)[:, None, :], 1.0, closed=True)
        a = msg.points.add(type=PointsAnnotation.Type.LINE_LOOP, thickness=2.0)
        a.timestamp.FromNanoseconds(log_time_ns)
        set_color(a.outline_color, rgba)
        for x, y in simple[:, 0, :].tolist():
            a.points.add(x=x, y=y)

    def text(x: float, y: float, words: str, rgba: tuple[float, float, float, float]) -> None:
        t = msg.texts.add(text=words, font_size=14.0)
        t.timestamp.FromNanoseconds(log_time_ns)
        set_xy(t.position, x, y)
        set_color(t.text_color, rgba)
        set_color(t.background_color, BLACK)

    for blob in det.rejected_blobs:
        outline(blob.outline_px, RED)
        text(blob.centroid_px[0], blob.centroid_px[1], blob.reason, RED)
    if det.found:
        outline(det.outline_px, GREEN)
        col, row = det.centroid_px
        c = msg.circles.add(diameter=8.0, thickness=2.0)
        c.timestamp.FromNanoseconds(log_time_ns)
        set_xy(c.position, col, row)
        set_color(c.outline_color, GREEN)
        if math.isfinite(det.theta_deg):
            t = math.radians(det.theta_deg)
            d = np.array([math.cos(t), math.sin(t)]) * 80.0
            a = msg.points.add(type=PointsAnnotation.Type.LINE_LIST, thickness=2.0)
            a.timestamp.FromNanoseconds(log_time_ns)
            set_color(a.outline_color, GREEN)
            set_xy(a.points.add(), col - d[0], row - d[1])
            set_xy(a.points.add(), col + d[0], row + d[1])
    verdict = "found" if det.found else f"rejected: {det.reason}"
    text(10.0, 20.0, f"{label}: {verdict}", GREEN if det.found else RED)
    return msg


def _xyz(msg: Any, p: F64) -> None:
    msg.x, msg.y, msg.z = (float(v) for v in p)


@dataclass(frozen=True, kw_only=True)
class TrialScene:
    """What a trial's scene shows (grid frame, session units)."""

    trial: int
    method: str  # point, line or ground
    status: str
    intrinsics: F64  # (N, 4) fx, fy, cx, cy
    width_height: F64  # (N, 2) image size
    R_cam_to_grid: F64  # (N, 3, 3) typed
    t_grid: F64  # (N, 3) typed camera centres
    px: F64  # (N, 2) combined measurement per pose
    theta_deg: F64  # (N,) NaN for points
    estimate: F64  # (3,) NaN when not ok
    direction: F64 | None  # (3,) lines
    truth: F64  # (2, 3) the point twice, or two points of the true line; NaN if unknown
    cov: F64  # (3, 3) NaN when unknown


def scene_of_views(  # noqa: PLR0913 - one per TrialScene field its two callers know
    trial: int,
    method: Method,
    status: str,
    views: Sequence[PoseView],
    measurements: Sequence[PoseMeasurement],
    estimate: F64,
    direction: F64 | None,
    truth: F64,
    cov: F64,
) -> TrialScene:
    """A trial's scene from its poses and their combined measurements.

    NaN where a pose had no measurement; the one way results.mcap and the live view build it.
    """
    n = len(views)
    px, theta = np.full((n, 2), np.nan), np.full(n, np.nan)
    for j, m in enumerate(measurements):
        px[j], theta[j] = m.centroid_px, m.theta_deg
    return TrialScene(
        trial=trial,
        method=method,
        status=status,
        intrinsics=np.array([v.intrinsics for v in views]),
        width_height=np.array([v.width_height for v in views], dtype=np.float64),
        R_cam_to_grid=rotation_from_angles_deg(np.array([v.r_deg for v in views])),
        t_grid=np.array([v.t_grid for v in views]),
        px=px,
        theta_deg=theta,
        estimate=np.asarray(estimate, dtype=np.float64),
        direction=None if direction is None else np.asarray(direction, dtype=np.float64),
        truth=np.asarray(truth, dtype=np.float64),
        cov=np.asarray(cov, dtype=np.float64),
    )


def _rays(s: TrialScene, pixels: F64) -> F64:
    """Unit rays (N, M, 3) in the grid frame through pixels (N, M, 2) of each view."""
    k = s.intrinsics
    cam = np.stack(
        [
            (pixels[..., 0] - k[:, None, 2]) / k[:, None, 0],
            (pixels[..., 1] - k[:, None, 3]) / k[:, None, 1],
            np.ones(pixels.shape[:2]),
        ],
        axis=-1,
    )
    d = np.einsum("nij,nmj->nmi", s.R_cam_to_grid, cam)
    return np.asarray(d / np.linalg.norm(d, axis=-1, keepdims=True))


def _entity(update: SceneUpdate, log_time_ns: int, entity_id: str, trial: int) -> SceneEntity:
    e: SceneEntity = update.entities.add(frame_id=GRID_FRAME, id=entity_id, frame_locked=False)
    e.timestamp.FromNanoseconds(log_time_ns)
    e.metadata.add(key="trial", value=str(trial))
    return e


def _line(entity: SceneEntity, kind: int, points: F64, rgba: Any, thickness: float = 2.0) -> None:
    line = entity.lines.add(type=kind, thickness=thickness, scale_invariant=True)
    line.pose.orientation.w = 1.0
    set_color(line.color, rgba)
    for p in points:
        _xyz(line.points.add(), p)


def _sphere(entity: SceneEntity, centre: F64, size: F64, R: F64, rgba: Any) -> None:
    s = entity.spheres.add()
    _xyz(s.pose.position, centre)
    q = quaternion_xyzw_from_matrix(R)
    s.pose.orientation.x, s.pose.orientation.y, s.pose.orientation.z = q[:3]
    s.pose.orientation.w = q[3]
    _xyz(s.size, size)
    set_color(s.color, rgba)


def _arrow(entity: SceneEntity, start: F64, end: F64, rgba: Any) -> None:
    v = end - start
    length = float(np.linalg.norm(v))
    if not length > 0:
        return
    a = entity.arrows.add()
    _xyz(a.pose.position, start)
    # The arrow points along its pose's +x: rotate +x onto v.
    u = v / length
    axis = np.cross([1.0, 0.0, 0.0], u)
    s, c = float(np.linalg.norm(axis)), float(u[0])
    half = math.atan2(s, c) / 2.0
    axis = axis / s if s > 1e-12 else np.array([0.0, 0.0, 1.0])
    a.pose.orientation.x, a.pose.orientation.y, a.pose.orientation.z = axis * math.sin(half)
    a.pose.orientation.w = math.cos(half)
    head = min(0.3 * length, 0.5)
    a.shaft_length, a.head_length = length - head, head
    a.shaft_diameter, a.head_diameter = head * 0.25, head * 0.6
    set_color(a.color, rgba)


def static_scene(ground: PlaneEntry | None, extent: float = 12.0) -> SceneUpdate:
    """The grid the poses are typed on (y = 0, lines every unit) and the ground plane."""
    update = SceneUpdate()
    e = _entity(update, 0, "grid", 0)
    ticks = np.arange(-extent, extent + 0.5)
    segments = []
    for v in ticks:
        segments += [[v, 0.0, -extent], [v, 0.0, extent], [-extent, 0.0, v], [extent, 0.0, v]]
    _line(e, LinePrimitive.Type.LINE_LIST, np.array(segments), GREY, 1.0)
    if ground is not None:
        g = _entity(update, 0, "ground", 0)
        n = np.asarray(ground.normal_grid, dtype=np.float64)
        n = n / np.linalg.norm(n)
        cube = g.cubes.add()
        _xyz(cube.pose.position, n * ground.offset / float(np.linalg.norm(ground.normal_grid)))
        # A thin slab across the normal: rotate the cube's y onto n.
        R = _frame_with_axis(n)
        q = quaternion_xyzw_from_matrix(R)
        cube.pose.orientation.x, cube.pose.orientation.y, cube.pose.orientation.z = q[:3]
        cube.pose.orientation.w = q[3]
        _xyz(cube.size, np.array([2 * extent, 0.02, 2 * extent]))
        set_color(cube.color, (0.55, 0.45, 0.3, 0.35))
    return update


def _frame_with_axis(n: F64) -> F64:
    """A rotation whose second column is ``n``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    x = np.cross(n, helper)
    x /= np.linalg.norm(x)
    return np.column_stack([x, n, np.cross(x, n)])


def trial_scene(s: TrialScene, log_time_ns: int) -> SceneUpdate:
    """One trial's geometry as Foxglove scene entities (see the module docstring)."""
    update = SceneUpdate()
    centres = s.t_grid
    finite = bool(np.isfinite(s.estimate).all())
    reach = (
        1.25 * np.linalg.norm(s.estimate - centres, axis=1)
        if finite
        else np.full(len(centres), 10.0)
    )
    # Frustums: the image corners at a tenth of the way to the target.
    w, h = s.width_height[:, 0], s.width_height[:, 1]
    corners = np.stack(
        [
            np.stack([np.zeros_like(w), np.zeros_like(h)], -1),
            np.stack([w, np.zeros_like(h)], -1),
            np.stack([w, h], -1),
            np.stack([np.zeros_like(w), h], -1),
        ],
        axis=1,
    )
    depth = 0.1 * reach
    far = centres[:, None] + _rays(s, corners) * depth[:, None, None]
    e = _entity(update, log_time_ns, "cameras", s.trial)
    for c, f in zip(centres, far, strict=True):
        segs = [c, f[0], c, f[1], c, f[2], c, f[3], f[0], f[1], f[1], f[2], f[2], f[3], f[3], f[0]]
        _line(e, LinePrimitive.Type.LINE_LIST, np.array(segs), BLUE)
    # What each view measured: a ray (points) or the plane of its image line (lines).
    e = _entity(update, log_time_ns, "measurements", s.trial)
    spec = spec_of(s.method)  # the scene's method, as its table names it: looked up once
    seen = np.isfinite(s.px).all(axis=1) & (
        np.isfinite(s.theta_deg) if spec.uses_image_lines else True
    )
    if not spec.uses_image_lines:  # rays through the dot
        ray = _rays(s, s.px[:, None])[:, 0]
        rays = np.stack([centres, centres + ray * reach[:, None]], axis=1)[seen]
        _line(e, LinePrimitive.Type.LINE_LIST, rays.reshape(-1, 3), ORANGE, 1.5)
    else:
        t = np.radians(s.theta_deg)
        along = np.stack([np.cos(t), np.sin(t)], -1) * 150.0
        wedge = _rays(s, np.stack([s.px - along, s.px + along], axis=1))
        tri = e.triangles.add()
        tri.pose.orientation.w = 1.0
        set_color(tri.color, (1.0, 0.55, 0.0, 0.25))
        for c, r, L in zip(centres[seen], wedge[seen], reach[seen], strict=True):
            for p in (c, c + r[0] * L, c + r[1] * L):
                _xyz(tri.points.add(), p)
    if finite:
        e = _entity(update, log_time_ns, "estimate", s.trial)
        if s.direction is not None and np.isfinite(s.direction).all():
            span = 0.6 * float(np.mean(reach))
            line = np.stack([s.estimate - span * s.direction, s.estimate + span * s.direction])
            _line(e, LinePrimitive.Type.LINE_STRIP, line, ORANGE, 4.0)
        size = 0.04 * float(np.mean(reach))
        _sphere(e, s.estimate, np.full(3, size), np.eye(3), ORANGE)
        if np.isfinite(s.cov).all():
            vals, vecs = np.linalg.eigh(s.cov)
            if np.linalg.det(vecs) < 0:
                vecs[:, 0] = -vecs[:, 0]
            # The region's own quantile (a rank-2 region: 2 dof), as its semiaxis95 is.
            quantile = float(np.nan_to_num(chi2_95(region_dof(s.cov[None]))[0]))
            axes = 2.0 * np.sqrt(quantile * np.clip(vals, 0.0, None))
            _sphere(e, s.estimate, np.maximum(axes, size / 4), vecs, (1.0, 0.55, 0.0, 0.2))
    if np.isfinite(s.truth).all():
        e = _entity(update, log_time_ns, "truth", s.trial)
        size = 0.04 * float(np.mean(reach))
        if spec.estimates_line:
            _line(e, LinePrimitive.Type.LINE_STRIP, s.truth, GREEN, 4.0)
        else:
            _sphere(e, s.truth[0], np.full(3, size), np.eye(3), GREEN)
        if finite:
            target = 0.5 * (s.truth[0] + s.truth[1])
            e = _entity(update, log_time_ns, "error", s.trial)
            _arrow(e, target, s.estimate, RED)
    # A title at the estimate (or the first camera): trial, status.
    e = _entity(update, log_time_ns, "label", s.trial)
    text = e.texts.add(text=f"trial {s.trial}: {s.status}", billboard=True, font_size=14.0)
    text.scale_invariant = True
    _xyz(text.pose.position, s.estimate if finite else centres[0])
    text.pose.orientation.w = 1.0
    set_color(text.color, WHITE)
    return update
