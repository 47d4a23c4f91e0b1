"""The synthetic webcam: ray-cast the laptop-on-grid scene into realistic frames.

What the thesis' laptop webcam would see: grid paper on a table, a wall behind, the
laboratory test stand, and either a black dot on a white card (method 1) or the blue
gloved finger as a 3-D capsule pointing at the ground target (line method, method 2),
plus blue-ish clutter the glove filters must reject. Geometry is ray-cast once per pose
(supersampled, then area-averaged); each frame then gets its own lighting gain,
white balance and gradient, vignetting, sensor noise, and JPEG compression.

Everything here is deterministic for a given scene, pose and random generator.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.camera import Intrinsics, project_points, rotation_from_angles_deg
from twopose.sim.scene import BoardParams, Scene
from twopose.targets import finger_axis as target_finger_axis

__all__ = ["Layout", "Primitive", "build_layout", "expose", "render_radiance"]

F32 = NDArray[np.float32]
GAMMA = 2.2


def srgb_to_linear(rgb: tuple[int, int, int]) -> F64:
    """8-bit display colour -> linear reflectance (simple 2.2 gamma, as the sensor model)."""
    return (np.asarray(rgb, dtype=np.float64) / 255.0) ** GAMMA


# --------------------------------------------------------------------------- primitives


@dataclass(frozen=True, kw_only=True)
class Primitive:
    """A renderable surface. ``kind`` selects the intersection routine.

    kinds: ``capsule`` (a, b, radius), ``box`` (lo, hi), ``card`` (centre, half size,
    dot centre and radius, in the plane z = centre z, facing -z), ``board`` (a card whose
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

    surface: str  # "table" | "wall"
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


def finger_axis(scene: Scene) -> tuple[F64, F64]:
    """Tip and base of the scene's finger axis in the grid frame (it meets the ground point)."""
    f = scene.finger
    return target_finger_axis(
        f.ground_point, scene.ground_height, f.tilt_deg, f.azimuth_deg, f.tip_height, f.length
    )


def _stand(scene: Scene, attach: F64) -> list[Primitive]:
    st = scene.stand
    h = scene.ground_height
    rod_xz = np.array([attach[0] + st.rod_offset[0], attach[2] + st.rod_offset[1]])
    color = srgb_to_linear(st.color)
    rod_top = np.array([rod_xz[0], attach[1] - 0.6, rod_xz[1]])
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


def build_layout(scene: Scene, method: str, rng: np.random.Generator) -> Layout:
    """Place the target for ``method`` (point | line | ground), the stand and the clutter."""
    prims: list[Primitive] = []
    if method == "point":
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
        attach = card_center + np.array([0.0, 0.0, 0.15])
        prims += _stand(scene, attach)
    else:
        tip, base = finger_axis(scene)
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
    return Layout(primitives=tuple(prims), decals=tuple(_clutter(scene, method, rng)))


def board_layout(scene: Scene) -> Layout:
    """What a board session sees: the checkerboard alone on the grid paper.

    What a board session sees: the scene's checkerboard alone on the grid paper (no target,
    stand or clutter in front of it).
    """
    return Layout(primitives=(_board(scene.board),), decals=())


def board_corners(board: BoardParams) -> F64:
    """The board's inner corners (cols * rows, 3) in the grid frame.

    (cols * rows, 3) the board's inner corners in the grid frame, row by row from the first
    (rows along +x, columns rising along -y), as ``cv2.findChessboardCorners`` lists them
    for an upright board.
    """
    cols, rows = board.inner_corners
    i, j = np.meshgrid(np.arange(cols), np.arange(rows))
    x0, y0, z0 = board.first_corner
    return np.stack(
        [x0 + board.square * i.ravel(), y0 - board.square * j.ravel(), np.full(i.size, z0)],
        axis=1,
    )


def _board(board: BoardParams) -> Primitive:
    """The board as a card of (cols + 1) x (rows + 1) squares and a margin.

    The board as a card: the pattern of (cols + 1) x (rows + 1) squares, the first inner
    corner one square in from the pattern's lower left, a one-square margin around.
    """
    cols, rows = board.inner_corners
    s = board.square
    x0, y0, z0 = board.first_corner
    corner = np.array([x0 - s, y0 + s, z0])  # the pattern's lower-left corner (y down)
    size = np.array([(cols + 1) * s, (rows + 1) * s])
    centre = corner + np.array([size[0] / 2, -size[1] / 2, 0.0])
    half = np.array([size[0] / 2 + s, size[1] / 2 + s, 0.0])  # with the margin
    return Primitive(
        kind="board",
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
    point_grid: F64, extent: float, target_grid: F64, views: list[tuple[Intrinsics, F64, F64]]
) -> bool:
    """Whether a decal at ``point_grid`` (size ``extent``) would touch the target in a view."""
    for intr, R, t in views:
        target_px = project_points(target_grid, intr, R, t)
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


def _clutter(scene: Scene, method: str, rng: np.random.Generator) -> list[Decal]:
    c = scene.clutter
    decals: list[Decal] = []
    blue, navy = srgb_to_linear(c.color), srgb_to_linear(c.navy_color)
    views = _sample_views(scene)
    if method == "point":
        target = np.asarray([scene.point.position], dtype=np.float64)
    else:
        target = np.stack(finger_axis(scene))
    for i in range(c.count):
        kind = c.kinds[i % len(c.kinds)]
        for _ in range(50):  # keep clutter off the target in every view; give up on a crowded scene
            on_wall = rng.random() < 0.5
            if on_wall:
                center = np.array([rng.uniform(*c.wall_x_range), rng.uniform(*c.wall_y_range)])
                scale = 3.0  # the wall is far: bigger shapes to stay visible
                point = np.array([center[0], center[1], scene.wall_z])
            else:
                center = np.array([rng.uniform(*c.table_x_range), rng.uniform(*c.table_z_range)])
                scale = 1.6
                point = np.array([center[0], scene.ground_height, center[1]])
            apart = all(
                d.surface != ("wall" if on_wall else "table")
                or np.linalg.norm(d.center - center) > 2.2 * scale + 1.0
                for d in decals
            )
            if apart and not _too_close_to_target(point, 2.5 * scale, target, views):
                break
        else:
            continue
        angle = float(rng.uniform(0, np.pi))
        surface = "wall" if on_wall else "table"
        if kind == "disk":
            r = scale * rng.uniform(0.6, 1.0)
            decals.append(
                Decal(
                    surface=surface,
                    shape="disk",
                    center=center,
                    size=np.array([r, r]),
                    angle=angle,
                    color=blue,
                )
            )
        elif kind == "speck":
            r = rng.uniform(0.08, 0.15)
            decals.append(
                Decal(
                    surface=surface,
                    shape="disk",
                    center=center,
                    size=np.array([r, r]),
                    angle=angle,
                    color=blue,
                )
            )
        elif kind == "ring":
            a = scale * rng.uniform(1.0, 1.4)
            decals.append(
                Decal(
                    surface=surface,
                    shape="ring",
                    center=center,
                    size=np.array([a, a * 0.35]),
                    angle=angle,
                    color=blue,
                )
            )
        elif kind == "triangle":
            length, width = scale * rng.uniform(1.5, 2.2), scale * rng.uniform(0.4, 0.6)
            local = np.array(
                [[-length / 2, -width / 2], [-length / 2, width / 2], [length / 2, 0.0]]
            )
            rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
            verts = local @ rot.T + center
            decals.append(
                Decal(
                    surface=surface,
                    shape="triangle",
                    center=center,
                    size=np.zeros(2),
                    angle=angle,
                    color=blue,
                    vertices=verts,
                )
            )
        else:  # navy: a glove-shaped blob of the wrong colour
            a = scale * rng.uniform(0.8, 1.1)
            decals.append(
                Decal(
                    surface=surface,
                    shape="ellipse",
                    center=center,
                    size=np.array([a, a * 0.3]),
                    angle=angle,
                    color=navy,
                )
            )
    return decals


def _decal_mask(decal: Decal, ab: F64) -> NDArray[np.bool_]:
    d = ab - decal.center
    c, s = np.cos(decal.angle), np.sin(decal.angle)
    u, v = d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c
    if decal.shape == "disk":
        return np.asarray(u * u + v * v <= decal.size[0] ** 2)
    if decal.shape in ("ring", "ellipse"):
        r = (u / decal.size[0]) ** 2 + (v / decal.size[1]) ** 2
        if decal.shape == "ellipse":
            return np.asarray(r <= 1.0)
        return np.asarray((r <= 1.0) & (r >= 0.55**2))
    p0, p1, p2 = decal.vertices

    def edge(pa: F64, pb: F64) -> F64:
        return np.asarray(
            (pb[0] - pa[0]) * (ab[:, 1] - pa[1]) - (pb[1] - pa[1]) * (ab[:, 0] - pa[0])
        )

    e0, e1, e2 = edge(p0, p1), edge(p1, p2), edge(p2, p0)
    return np.asarray(((e0 >= 0) & (e1 >= 0) & (e2 >= 0)) | ((e0 <= 0) & (e1 <= 0) & (e2 <= 0)))


# --------------------------------------------------------------------------- ray casting


def _pixel_rays(intr: Intrinsics, s: int) -> F64:
    """Camera-frame ray directions (z = 1) of the supersampled pixel grid, (H*s*W*s, 3)."""
    cols = (np.arange(intr.width * s) + 0.5) / s - 0.5
    rows = (np.arange(intr.height * s) + 0.5) / s - 0.5
    cc, rr = np.meshgrid(cols, rows)
    px = np.stack([cc.ravel(), rr.ravel()], axis=1)
    if intr.has_distortion:
        norm = cv2.undistortPoints(
            px.reshape(-1, 1, 2), intr.K, np.asarray(intr.distortion, dtype=np.float64)
        ).reshape(-1, 2)
    else:
        norm = np.stack([(px[:, 0] - intr.cx) / intr.fx, (px[:, 1] - intr.cy) / intr.fy], axis=1)
    return np.concatenate([norm, np.ones((norm.shape[0], 1))], axis=1)


def _capsule(o: F64, d: F64, a: F64, b: F64, r: float) -> tuple[F64, F64]:
    """Ray-capsule intersection (nearest t, inf for a miss) and the outward normals."""
    ba = b - a
    oa = o - a
    baba = ba @ ba
    bard = d @ ba
    baoa = oa @ ba
    rdoa = d @ oa
    oaoa = oa @ oa
    dd = np.einsum("ij,ij->i", d, d)
    A = baba * dd - bard * bard
    B = baba * rdoa - baoa * bard
    C = baba * oaoa - baoa * baoa - r * r * baba
    h = B * B - A * C
    t = np.full(d.shape[0], np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        t_body = (-B - np.sqrt(h)) / A
        y = baoa + t_body * bard
        body = (h >= 0) & (y > 0) & (y < baba) & (t_body > 0)
        t[body] = t_body[body]
        for cap in (a, b):
            oc = o - cap
            bq = d @ oc
            cq = oc @ oc - r * r
            hq = bq * bq - dd * cq
            tq = (-bq - np.sqrt(hq)) / dd
            hit = (hq >= 0) & (tq > 0) & (tq < t) & ~body
            t[hit] = tq[hit]
    p = o + d * np.where(np.isfinite(t), t, 0.0)[:, None]
    s = np.clip(((p - a) @ ba) / baba, 0.0, 1.0)
    n = p - (a + s[:, None] * ba)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return t, n


def _box(o: F64, d: F64, lo: F64, hi: F64) -> tuple[F64, F64]:
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t0 = (lo - o) * inv
        t1 = (hi - o) * inv
    tmin = np.nanmax(np.minimum(t0, t1), axis=1)
    tmax = np.nanmin(np.maximum(t0, t1), axis=1)
    hit = (tmax >= tmin) & (tmin > 0)
    t = np.where(hit, tmin, np.inf)
    axis = np.argmax(np.minimum(t0, t1), axis=1)
    n = np.zeros_like(d)
    n[np.arange(d.shape[0]), axis] = -np.sign(d[np.arange(d.shape[0]), axis])
    return t, n


def _bounding_sphere(prim: Primitive) -> tuple[F64, float]:
    if prim.kind == "capsule":
        return (prim.a + prim.b) / 2, float(np.linalg.norm(prim.b - prim.a)) / 2 + prim.radius
    if prim.kind == "box":
        return (prim.a + prim.b) / 2, float(np.linalg.norm(prim.b - prim.a)) / 2
    return prim.a, float(np.linalg.norm(prim.b[:2]))


def render_radiance(
    scene: Scene,
    layout: Layout,
    intr: Intrinsics,
    R_cam_to_grid: F64,
    t_grid: F64,
) -> F32:
    """Linear radiance image (H, W, 3) RGB, float32, seen from one (true) pose.

    The ray grid is ``sensor.supersample`` times denser than the pixels and averaged
    back with ``cv2.INTER_AREA``, which anti-aliases edges (sub-pixel centroids depend on it).
    """
    s = scene.sensor.supersample
    d = _pixel_rays(intr, s) @ np.asarray(R_cam_to_grid, dtype=np.float64).T
    o = np.asarray(t_grid, dtype=np.float64)
    t_best, owner, normals = _intersect(layout, o, d)
    albedo, specular = _surface(layout, o, d, owner, t_best)
    _shade_background(scene, layout, o, d, owner, t_best, albedo, normals)
    radiance = _lit(scene, d, albedo, specular, normals)
    img = radiance.reshape(intr.height * s, intr.width * s, 3).astype(np.float32)
    if s > 1:
        return np.asarray(
            cv2.resize(img, (intr.width, intr.height), interpolation=cv2.INTER_AREA),
            dtype=np.float32,
        )
    return img


def _intersect(layout: Layout, o: F64, d: F64) -> tuple[F64, NDArray[np.int32], F64]:
    """Per ray, the nearest hit's distance, the primitive hit and its normal.

    Per ray from ``o`` along ``d`` (R, 3): the nearest hit's distance, the primitive hit
    (-1: none) and the surface normal there.
    """
    n_rays = d.shape[0]
    t_best = np.full(n_rays, np.inf)
    owner = np.full(n_rays, -1, dtype=np.int32)
    normals = np.zeros((n_rays, 3))
    dd = np.einsum("ij,ij->i", d, d)
    for idx, prim in enumerate(layout.primitives):
        # Cull with the bounding sphere first: the full intersection runs on few rays.
        center, bound = _bounding_sphere(prim)
        w = center - o
        dw = d @ w
        cand = np.flatnonzero((w @ w - dw * dw / dd <= bound * bound) & (dw > 0))
        if cand.size == 0:
            continue
        t, n = _hit(prim, o, d[cand])
        closer = t < t_best[cand]
        hit = cand[closer]
        t_best[hit] = t[closer]
        owner[hit] = idx
        normals[hit] = n[closer]
    return t_best, owner, normals


def _hit(prim: Primitive, o: F64, dc: F64) -> tuple[F64, F64]:
    """Distance (inf: missed) and normal of rays ``dc`` against one primitive."""
    if prim.kind == "capsule":
        return _capsule(o, dc, prim.a, prim.b, prim.radius)
    if prim.kind == "box":
        return _box(o, dc, prim.a, prim.b)
    # a card in the plane z = a_z, facing -z
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (prim.a[2] - o[2]) / dc[:, 2]
    p = o + dc * np.where(np.isfinite(t), t, 0.0)[:, None]
    inside = (np.abs(p[:, 0] - prim.a[0]) <= prim.b[0]) & (np.abs(p[:, 1] - prim.a[1]) <= prim.b[1])
    t = np.where(inside & (t > 0), t, np.inf)
    return t, np.tile(np.array([0.0, 0.0, -1.0]), (dc.shape[0], 1))


def _surface(
    layout: Layout, o: F64, d: F64, owner: NDArray[np.int32], t_best: F64
) -> tuple[F64, F64]:
    """Albedo (R, 3) and specular strength (R,) where each ray hit (the dot on its card)."""
    albedo = np.zeros((d.shape[0], 3))
    specular = np.zeros(d.shape[0])
    for idx, prim in enumerate(layout.primitives):
        m = owner == idx
        if not m.any():
            continue
        albedo[m] = prim.color
        specular[m] = prim.specular
        if prim.kind == "card":
            p = o + d[m] * t_best[m, None]
            on_dot = (
                np.hypot(p[:, 0] - prim.dot_center[0], p[:, 1] - prim.dot_center[1])
                <= prim.dot_radius
            )
            sub = albedo[m]
            sub[on_dot] = prim.dot_color
            albedo[m] = sub
        elif prim.kind == "board":
            p = o + d[m] * t_best[m, None]
            i = np.floor((p[:, 0] - prim.dot_center[0]) / prim.square)
            j = np.floor((prim.dot_center[1] - p[:, 1]) / prim.square)
            inside = (i >= 0) & (i < prim.squares[0]) & (j >= 0) & (j < prim.squares[1])
            sub = albedo[m]
            sub[inside & ((i + j) % 2 == 0)] = prim.dot_color  # the corner square is dark
            albedo[m] = sub
    return albedo, specular


def _lit(scene: Scene, d: F64, albedo: F64, specular: F64, normals: F64) -> F64:
    """Ambient + Lambert + a Blinn highlight under the scene's one directional light."""
    light = np.asarray(scene.lighting.direction, dtype=np.float64)
    light /= np.linalg.norm(light)
    lam = np.clip(normals @ light, 0.0, None)
    radiance = albedo * (scene.lighting.ambient + scene.lighting.diffuse * lam)[:, None]
    if specular.any():
        view = -d / np.linalg.norm(d, axis=1, keepdims=True)
        half = light + view
        half /= np.linalg.norm(half, axis=1, keepdims=True)
        highlight = specular * np.clip(np.einsum("ij,ij->i", normals, half), 0, None) ** 40
        radiance += highlight[:, None]
    return np.asarray(radiance)


def _shade_background(
    scene: Scene,
    layout: Layout,
    o: F64,
    d: F64,
    owner: NDArray[np.int32],
    t_best: F64,
    albedo: F64,
    normals: F64,
) -> None:
    """Table (grid paper on wood), wall and floor for the rays no primitive took."""
    free = owner < 0
    h = scene.ground_height
    with np.errstate(divide="ignore", invalid="ignore"):
        t_table = (h - o[1]) / d[:, 1]
    p = o + d * np.where(np.isfinite(t_table), t_table, 0.0)[:, None]
    x0, x1, z0, z1 = scene.table_extent
    on_table = (
        free & (t_table > 0) & (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 2] >= z0) & (p[:, 2] <= z1)
    )

    # Grid paper: lines every grid_spacing, anti-aliased by their footprint in the plane.
    px0, px1, pz0, pz1 = scene.paper_extent
    tab = p[on_table]
    on_paper = (tab[:, 0] >= px0) & (tab[:, 0] <= px1) & (tab[:, 2] >= pz0) & (tab[:, 2] <= pz1)
    f = 0.5 * (scene.cameras[0].fx + scene.cameras[0].fy) * scene.sensor.supersample
    ray_len = t_table[on_table] * np.linalg.norm(d[on_table], axis=1)
    grazing = np.clip(np.abs(d[on_table, 1]) / np.linalg.norm(d[on_table], axis=1), 0.03, 1.0)
    foot_x = ray_len / f
    foot_z = foot_x / grazing
    g = scene.grid_spacing
    w = scene.grid_line_width

    def coverage(coord: F64, foot: F64) -> F64:
        dist = np.abs(coord / g - np.round(coord / g)) * g
        cov = np.clip((w / 2 - dist) / foot + 0.5, 0.0, 1.0) * np.clip(w / foot, 0.0, 1.0)
        return np.asarray(np.maximum(cov, 0.0))

    line = np.maximum(coverage(tab[:, 0], foot_x), coverage(tab[:, 2], foot_z)) * on_paper
    paper, grid = srgb_to_linear(scene.paper_color), srgb_to_linear(scene.grid_color)
    tex = np.where(on_paper[:, None], paper, srgb_to_linear(scene.table_color))
    tex = tex * (1 - line[:, None]) + grid * line[:, None]
    for decal in layout.decals:
        if decal.surface == "table":
            m = _decal_mask(decal, tab[:, [0, 2]])
            tex[m] = decal.color
    albedo[on_table] = tex
    normals[on_table] = (0.0, -1.0, 0.0)

    rest = free & ~on_table
    with np.errstate(divide="ignore", invalid="ignore"):
        t_wall = (scene.wall_z - o[2]) / d[:, 2]
    pw = o + d * np.where(np.isfinite(t_wall), t_wall, 0.0)[:, None]
    on_wall = rest & (t_wall > 0) & (pw[:, 1] < h)
    wall_tex = np.tile(srgb_to_linear(scene.wall_color), (int(on_wall.sum()), 1))
    wall_pts = pw[on_wall][:, [0, 1]]
    for decal in layout.decals:
        if decal.surface == "wall":
            wall_tex[_decal_mask(decal, wall_pts)] = decal.color
    albedo[on_wall] = wall_tex
    normals[on_wall] = (0.0, 0.0, -1.0)
    floor = rest & ~on_wall
    albedo[floor] = srgb_to_linear(scene.floor_color)
    normals[floor] = (0.0, -1.0, 0.0)
    t_best[on_table] = t_table[on_table]


# --------------------------------------------------------------------------- the sensor


def expose(radiance: F32, scene: Scene, rng: np.random.Generator) -> NDArray[np.uint8]:
    """One frame from a radiance image: lighting jitter, vignetting, gamma, noise -> BGR uint8.

    Per frame: a global gain, a per-channel white-balance gain and a linear brightness
    gradient (a light that moves a little); then the 2.2 gamma, Gaussian read noise and
    signal-dependent shot noise in digital numbers.
    """
    li, se = scene.lighting, scene.sensor
    H, W = radiance.shape[:2]
    gain = 1.0 + li.gain_jitter * rng.standard_normal()
    wb = 1.0 + li.white_balance_jitter * rng.standard_normal(3)
    gx, gy = li.gradient_jitter * rng.standard_normal(2)
    xs = np.linspace(-0.5, 0.5, W, dtype=np.float32)
    ys = np.linspace(-0.5, 0.5, H, dtype=np.float32)
    field = 1.0 + gx * xs[None, :] + gy * ys[:, None]
    vignette = 1.0 - li.vignetting * (xs[None, :] ** 2 + ys[:, None] ** 2) * 2.0
    lin = radiance * (gain * field * vignette)[:, :, None] * wb.astype(np.float32)[None, None, :]
    dn = 255.0 * np.clip(lin, 0.0, 1.0) ** (1.0 / GAMMA)
    sigma = np.sqrt(se.read_noise_dn**2 + se.shot_noise_dn * dn)
    dn = dn + sigma * rng.standard_normal(dn.shape).astype(np.float32)
    rgb = np.clip(np.rint(dn), 0, 255).astype(np.uint8)
    return np.ascontiguousarray(rgb[:, :, ::-1])
