"""What the synthetic webcam looks at: the scene's objects as primitives to ray-cast.

The laboratory test stand, the dot on its card (method 1), the gloved finger as a capsule
(line method, method 2), the calibration board, and blue-ish clutter decals the glove filters
must reject, placed where no view would confuse them with the target. :mod:`twopose.sim.render`
ray-casts a :class:`Layout`; nothing here draws.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twopose.arrays import F64
from twopose.camera.model import Intrinsics, project_points, rotation_from_angles_deg
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import Method, MethodSpec, spec_of
from twopose.methods.targets import finger_axis as target_finger_axis
from twopose.sim.scene import BoardParams, ClutterParams, Scene
from twopose.values.units import unit_factor

__all__ = [
    "BOARD_POSES",
    "Decal",
    "Layout",
    "Primitive",
    "board_corners",
    "board_layout",
    "board_poses",
    "build_layout",
    "finger_axis",
    "srgb_to_linear",
]

GAMMA = 2.2


def srgb_to_linear(rgb: tuple[int, int, int]) -> F64:
    """8-bit display colour -> linear reflectance (simple 2.2 gamma, as the sensor model)."""
    return (np.asarray(rgb, dtype=np.float64) / 255.0) ** GAMMA


# --------------------------------------------------------------------------- primitives


@dataclass(frozen=True, kw_only=True)
class Primitive:
    """A renderable surface. ``kind`` selects the intersection routine.

    kinds: ``capsule`` (a, b, radius), ``box`` (lo, hi), ``card`` (centre, half size,
    dot centre and radius, in the plane z = centre z, facing -z), ``checkerboard`` (a card whose
    face is a checkerboard: squares of side ``square`` from the pattern's corner
    ``dot_center``, ``color`` light and ``dot_color`` dark, the margin light).
    """

    kind: str
    color: F64
    a: F64
    b: F64 = field(default_factory=lambda: np.zeros(3))
    radius: float = 0.0
    specular: float = 0.0
    dot_color: F64 = field(default_factory=lambda: np.zeros(3))
    dot_center: F64 = field(default_factory=lambda: np.zeros(3))
    dot_radius: float = 0.0
    square: float = 0.0  # board: the squares' side
    squares: tuple[int, int] = (0, 0)  # board: squares along x and y (inner corners + 1)


@dataclass(frozen=True, kw_only=True)
class Decal:
    """A flat clutter shape painted on the table (plane y = h) or the wall (z = wall_z).

    ``points`` are the shape's 2-D vertices or parameters in that surface's (a, b) coords:
    table (x, z), wall (x, y).
    """

    surface: str  # "table" | "back_wall" (the scene's wall z = wall_z)
    shape: str  # disk | ring | ellipse | triangle
    center: F64
    size: F64  # disk: (r, r); ring: (a, b) outer semi-axes; triangle unused
    angle: float
    color: F64
    vertices: F64 = field(default_factory=lambda: np.zeros((3, 2)))


@dataclass(frozen=True, kw_only=True)
class Layout:
    """Everything placed in the scene for one session (target, stand, clutter)."""

    primitives: tuple[Primitive, ...]
    decals: tuple[Decal, ...]


def finger_axis(scene: Scene, plane: ConstraintPlane | None = None) -> tuple[F64, F64]:
    """Tip and base of the scene's finger axis in the grid frame.

    It meets ``plane`` (the method's; the ground ``y = h`` when None, the line method's
    finger too) at the finger's ``ground_point``, the plane's offset the scene's
    ``ground_height``.
    """
    f = scene.finger
    return target_finger_axis(
        f.ground_point, scene.ground_height, f.tilt_deg, f.azimuth_deg, f.tip_height, f.length,
        plane=plane or GROUND_PLANE,
    )  # fmt: skip


def _stand(scene: Scene, attach: F64) -> list[Primitive]:
    st = scene.stand
    h = scene.ground_height
    rod_xz = np.array([attach[0] + st.rod_offset[0], attach[2] + st.rod_offset[1]])
    color = srgb_to_linear(st.color)
    rod_top = np.array([rod_xz[0], attach[1] - st.rod_above, rod_xz[1]])
    rod_bottom = np.array([rod_xz[0], h - st.base_height, rod_xz[1]])
    arm_start = np.array([rod_xz[0], attach[1], rod_xz[1]])
    half = np.array([st.base_size[0] / 2, 0.0, st.base_size[1] / 2])
    base_lo = np.array([rod_xz[0], h - st.base_height, rod_xz[1]]) - half
    base_hi = np.array([rod_xz[0], h, rod_xz[1]]) + half
    base_lo[1], base_hi[1] = h - st.base_height, h
    return [
        Primitive(
            kind="capsule",
            color=color,
            a=rod_top,
            b=rod_bottom,
            radius=st.rod_radius,
            specular=0.25,
        ),
        Primitive(
            kind="capsule",
            color=color,
            a=arm_start,
            b=attach,
            radius=st.rod_radius * 0.6,
            specular=0.25,
        ),
        Primitive(kind="box", color=srgb_to_linear(st.base_color), a=base_lo, b=base_hi),
    ]


def build_layout(
    scene: Scene,
    method: Method,
    rng: np.random.Generator,
    keep_off: tuple[list[tuple[Intrinsics, F64, F64]], F64] | None = None,
) -> Layout:
    """Place the target for ``method``, the stand and the clutter.

    The target of point, line or ground; a board session's scene is the board alone
    (:func:`board_layout`). ``keep_off``: the views (intrinsics, R, t) the clutter is kept
    off the target in and the (S, 3) shifts of the target along its path (a moving
    target's, seen by two cameras); None: the static target in one camera's sample views.
    """
    spec = spec_of(method)  # looked up once; its parts travel from here
    if not spec.measures:
        return board_layout(scene)
    prims: list[Primitive] = []
    if not spec.uses_image_lines:  # the dot on its card
        pt = scene.point
        dot = np.asarray(pt.position, dtype=np.float64)
        card_center = dot + np.array([pt.card_offset[0], pt.card_offset[1], 0.0])
        half = np.array([pt.card_size[0] / 2, pt.card_size[1] / 2, 0.0])
        prims.append(
            Primitive(
                kind="card",
                color=srgb_to_linear(pt.card_color),
                a=card_center,
                b=half,
                dot_color=srgb_to_linear(pt.dot_color),
                dot_center=dot,
                dot_radius=pt.dot_radius,
            )
        )
        attach = card_center + np.array([0.0, 0.0, scene.stand.arm_gap])
        prims += _stand(scene, attach)
    else:
        tip, base = finger_axis(scene, spec.plane)
        f = scene.finger
        prims.append(
            Primitive(
                kind="capsule",
                color=srgb_to_linear(f.color),
                a=base,
                b=tip,
                radius=f.radius,
                specular=f.specular,
            )
        )
        prims += _stand(scene, base)
    if scene.board.present:
        prims.append(_board(scene.board))
    return Layout(primitives=tuple(prims), decals=tuple(_clutter(scene, spec, rng, keep_off)))


#: A board session's typed camera centres in inches (no typed rotation; :func:`board_poses`
#: gives them in a scene's units):
#: moves along x and along z, so that every constant the board determines is seen
#: (twopose.rig.board.check_identifiable), three as near the default board as keeps its
#: lowest corners in view (19 in), three far (58 in, squares of about 9 px) and two between.
#: The depths' spread decides how well the focal scale parts from the camera's depth offset,
#: and the lateral offset from the principal point (each capture's depth is known only to
#: the placing error): with 0.2 px corners and 0.04 in placing, the depth offset's 1 sigma
#: is 0.044 in and the principal point's 0.61 px, where the same moves at 20-38 in leave
#: 0.061 in and 1.04 px (tests/twopose/test_board_rig.py), and 21-28 in left 0.15 in.
BOARD_POSES: tuple[tuple[float, float, float], ...] = (
    (-3.0, 0.0, 5.0),
    (3.0, 0.0, 5.0),
    (0.0, 0.0, 5.0),
    (-10.0, 0.0, -34.0),
    (10.0, 0.0, -34.0),
    (0.0, 0.0, -34.0),
    (-6.0, 0.0, -12.0),
    (6.0, 0.0, -12.0),
)


def board_poses(scene: Scene) -> tuple[tuple[float, float, float], ...]:
    """:data:`BOARD_POSES` in the scene's units."""
    k = unit_factor("in", scene.units)
    return tuple((x * k, y * k, z * k) for x, y, z in BOARD_POSES)


def board_layout(scene: Scene) -> Layout:
    """What a board session sees: the checkerboard alone on the grid paper.

    No target, stand or clutter in front of it.
    """
    return Layout(primitives=(_board(scene.board),), decals=())


def board_corners(board: BoardParams) -> F64:
    """The board's inner corners (cols * rows, 3) in the grid frame.

    (:meth:`twopose.methods.targets.BoardPlacement.corners_grid` of the scene's board.)
    """
    return board.placement().corners_grid()


def _board(board: BoardParams) -> Primitive:
    """The board as a card of (cols + 1) x (rows + 1) squares and a margin.

    The first inner corner lies one square in from the pattern's lower left; the margin is one
    square around.
    """
    cols, rows = board.inner_corners
    s = board.square
    x0, y0, z0 = board.first_corner
    corner = np.array([x0 - s, y0 + s, z0])  # the pattern's lower-left corner (y down)
    size = np.array([(cols + 1) * s, (rows + 1) * s])
    centre = corner + np.array([size[0] / 2, -size[1] / 2, 0.0])
    half = np.array([size[0] / 2 + s, size[1] / 2 + s, 0.0])  # with the margin
    return Primitive(
        kind="checkerboard",
        color=srgb_to_linear(board.light_color),
        a=centre,
        b=half,
        dot_color=srgb_to_linear(board.dark_color),
        dot_center=corner,
        square=s,
        squares=(cols + 1, rows + 1),
    )


def _sample_views(scene: Scene) -> list[tuple[Intrinsics, F64, F64]]:
    """Corner and centre poses of the pose ranges: where the target can appear."""
    p = scene.poses
    views = []
    for x in (*p.x_range, sum(p.x_range) / 2):
        for z in (*p.z_range, sum(p.z_range) / 2):
            t = np.array([x, sum(p.y_range) / 2, z])
            r = np.array([sum(p.rx_range), sum(p.ry_range), sum(p.rz_range)]) / 2
            views.append((scene.cameras[0].intrinsics, rotation_from_angles_deg(r), t))
    return views


def _too_close_to_target(
    point_grid: F64,
    extent: float,
    target_grid: F64,
    views: list[tuple[Intrinsics, F64, F64]],
    shifts: F64 | None = None,
) -> bool:
    """Whether a decal at ``point_grid`` (size ``extent``) would touch the target in a view.

    ``shifts`` (S, 3): the target at each of these shifts (its path) too.
    """
    for target in [target_grid] if shifts is None else [target_grid + d for d in shifts]:
        for intr, R, t in views:
            target_px = project_points(target, intr, R, t)
            center_px = project_points(point_grid[None, :], intr, R, t)[0]
            if not np.all(np.isfinite(target_px)) or not np.all(np.isfinite(center_px)):
                continue
            depth = float(np.linalg.norm(point_grid - t))
            radius_px = intr.fx * extent / depth + 40.0
            a, b = target_px[0], target_px[-1]
            ab = b - a
            s = float(np.clip((center_px - a) @ ab / max(ab @ ab, 1e-9), 0.0, 1.0))
            if np.linalg.norm(center_px - (a + s * ab)) < radius_px:
                return True
    return False


def _clutter(
    scene: Scene,
    spec: MethodSpec,
    rng: np.random.Generator,
    keep_off: tuple[list[tuple[Intrinsics, F64, F64]], F64] | None = None,
) -> list[Decal]:
    c = scene.clutter
    decals: list[Decal] = []
    views, shifts = (_sample_views(scene), None) if keep_off is None else keep_off
    if not spec.uses_image_lines:  # the dot
        target = np.asarray([scene.point.position], dtype=np.float64)
    else:
        target = np.stack(finger_axis(scene, spec.plane))
    for i in range(c.count):
        placed = _clutter_place(scene, decals, target, (views, shifts), rng)
        if placed is not None:
            surface, center, scale = placed
            decals.append(_clutter_decal(c, c.kinds[i % len(c.kinds)], surface, center, scale, rng))
    return decals


def _clutter_place(
    scene: Scene,
    decals: list[Decal],
    target: F64,
    keep_off: tuple[list[tuple[Intrinsics, F64, F64]], F64 | None],
    rng: np.random.Generator,
) -> tuple[str, F64, float] | None:
    """A decal's surface, centre and size (scene units), off the other decals and the target.

    None on a crowded scene (50 draws failed): the decal is left out.
    """
    c = scene.clutter
    for _ in range(50):
        on_wall = rng.random() < 0.5
        if on_wall:
            center = np.array([rng.uniform(*c.wall_x_range), rng.uniform(*c.wall_y_range)])
            scale = c.wall_size
            point = np.array([center[0], center[1], scene.wall_z])
        else:
            center = np.array([rng.uniform(*c.table_x_range), rng.uniform(*c.table_z_range)])
            scale = c.table_size
            point = np.array([center[0], scene.ground_height, center[1]])
        surface = "back_wall" if on_wall else "table"
        apart = all(
            d.surface != surface or np.linalg.norm(d.center - center) > 2.2 * scale + c.gap
            for d in decals
        )
        if apart and not _too_close_to_target(point, 2.5 * scale, target, *keep_off):
            return surface, center, scale
    return None


def _clutter_decal(
    c: ClutterParams, kind: str, surface: str, center: F64, scale: float, rng: np.random.Generator
) -> Decal:
    """One clutter decal of `kind`; its random draws in the order the scenes were made with."""
    angle = float(rng.uniform(0, np.pi))
    blue = srgb_to_linear(c.color)
    shape, color, vertices = "disk", blue, np.zeros((3, 2))
    if kind == "disk":
        r = scale * rng.uniform(0.6, 1.0)
        size = np.array([r, r])
    elif kind == "speck":
        r = rng.uniform(*c.speck_radius)
        size = np.array([r, r])
    elif kind == "ring":
        a = scale * rng.uniform(1.0, 1.4)
        shape, size = "ring", np.array([a, a * 0.35])
    elif kind == "triangle":
        length, width = scale * rng.uniform(1.5, 2.2), scale * rng.uniform(0.4, 0.6)
        local = np.array([[-length / 2, -width / 2], [-length / 2, width / 2], [length / 2, 0.0]])
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        shape, size, vertices = "triangle", np.zeros(2), local @ rot.T + center
    else:  # navy: a glove-shaped blob of the wrong colour
        a = scale * rng.uniform(0.8, 1.1)
        shape, size, color = "ellipse", np.array([a, a * 0.3]), srgb_to_linear(c.navy_color)
    return Decal(
        surface=surface,
        shape=shape,
        center=center,
        size=size,
        angle=angle,
        color=color,
        vertices=vertices,
    )
