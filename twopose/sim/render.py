"""The synthetic webcam: ray-cast the laptop-on-grid scene into realistic frames.

What the thesis' laptop webcam would see: grid paper on a table, a wall behind, the
laboratory test stand, and either a black dot on a white card (method 1) or the blue
gloved finger as a 3-D capsule pointing at the ground target (line method, method 2),
plus blue-ish clutter the glove filters must reject (the objects: :mod:`twopose.sim.layout`).
Geometry is ray-cast once per pose
(supersampled, then area-averaged); each frame then gets its own lighting gain,
white balance and gradient, vignetting, sensor noise, and JPEG compression.

A pose's rays are cast in bands of :data:`BAND_RAYS` (each ray's colour is its own, so the
image is the same whatever the band): a band's arrays stay in the processor's cache, which
halves the time of the whole grid at once, and between two bands a stop can cut the
rendering (``between``). Each stage works only on the rays it concerns (the background on
the rays no object took, a decal on the rays near it, the highlight on shiny surfaces).

Everything here is deterministic for a given scene, pose and random generator.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import cv2
import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F32, F64
from twopose.camera.model import Intrinsics, camera_rays
from twopose.sim.layout import GAMMA, Decal, Layout, Primitive, srgb_to_linear
from twopose.sim.scene import Scene

__all__ = ["BAND_RAYS", "expose", "render_radiance", "render_sprite"]

#: Rays cast together: about 1.5 MB per array of a band, in the cache; ~10 ms of work, the
#: longest a stop waits for (``render_radiance``'s ``between``).
BAND_RAYS = 1 << 16


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


@lru_cache(maxsize=4)
def _pixel_rays(intr: Intrinsics, s: int) -> F64:
    """Camera-frame ray directions (z = 1) of the supersampled pixel grid, (H*s*W*s, 3).

    The same for every pose of a camera: made once, read-only, and kept for the next pose.
    """
    cols = (np.arange(intr.width * s) + 0.5) / s - 0.5
    rows = (np.arange(intr.height * s) + 0.5) / s - 0.5
    cc, rr = np.meshgrid(cols, rows)
    px = np.stack([cc.ravel(), rr.ravel()], axis=1)
    if intr.has_distortion:
        norm = cv2.undistortPoints(
            px.reshape(-1, 1, 2), intr.K, np.asarray(intr.distortion, dtype=np.float64)
        ).reshape(-1, 2)
        rays = np.concatenate([norm, np.ones((norm.shape[0], 1))], axis=1)
    else:
        rays = camera_rays(px, [intr.fx, intr.fy, intr.cx, intr.cy])
    rays.setflags(write=False)
    return rays


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
    *,
    between: Callable[[], None] | None = None,
) -> F32:
    """Linear radiance image (H, W, 3) RGB, float32, seen from one (true) pose.

    The ray grid is ``sensor.supersample`` times denser than the pixels and averaged
    back with ``cv2.INTER_AREA``, which anti-aliases edges (sub-pixel centroids depend on it).
    ``between`` is called before each band of :data:`BAND_RAYS` rays: it may raise to
    abandon the rendering (the recorder's stop; nothing is half written).
    """
    s = scene.sensor.supersample
    rays = _pixel_rays(intr, s)
    # Contiguous: NumPy multiplies by a transposed view ~50x slower (no BLAS), same bits.
    R_T = np.ascontiguousarray(np.asarray(R_cam_to_grid, dtype=np.float64).T)
    o = np.asarray(t_grid, dtype=np.float64)
    footprint = np.array([1.0 / (intr.fx * s), 1.0 / (intr.fy * s)])  # per unit depth
    flat = np.empty((rays.shape[0], 3), dtype=np.float32)
    for start in range(0, rays.shape[0], BAND_RAYS):
        if between is not None:
            between()
        band = slice(start, start + BAND_RAYS)
        flat[band] = _band_radiance(scene, layout, o, rays[band] @ R_T, footprint)
    img = flat.reshape(intr.height * s, intr.width * s, 3)
    if s > 1:
        return np.asarray(
            cv2.resize(img, (intr.width, intr.height), interpolation=cv2.INTER_AREA),
            dtype=np.float32,
        )
    return img


def render_sprite(
    scene: Scene,
    prim: Primitive,
    intr: Intrinsics,
    R_cam_to_grid: F64,
    t_grid: F64,
    rows: tuple[int, int],
    cols: tuple[int, int],
) -> tuple[F32, F32]:
    """One primitive alone over the pixels ``rows`` x ``cols`` (half-open).

    Its linear radiance, premultiplied by its coverage, and the coverage (0-1), the rays
    cast as :func:`render_radiance` casts them (supersampled, then area-averaged).

    A moving target is composited so over a cached static background
    (``background (1 - coverage) + radiance``; :mod:`twopose.sim.moving`): each frame casts
    only the rays about the target, and shades only those that hit it.
    """
    s = scene.sensor.supersample
    grid = _pixel_rays(intr, s).reshape(intr.height * s, intr.width * s, 3)
    block = grid[rows[0] * s : rows[1] * s, cols[0] * s : cols[1] * s].reshape(-1, 3)
    R_T = np.ascontiguousarray(np.asarray(R_cam_to_grid, dtype=np.float64).T)
    footprint = np.array([1.0 / (intr.fx * s), 1.0 / (intr.fy * s)])
    o = np.asarray(t_grid, dtype=np.float64)
    # einsum, not @: a large (N, 3) @ (3, 3) goes to BLAS' threads, ~15x the CPU here
    d = np.einsum("ij,jk->ik", block, R_T)
    alone = Layout(primitives=(prim,), decals=())
    t_best, owner, normals = _intersect(alone, o, d)
    hit = np.flatnonzero(owner == 0)
    flat = np.zeros((d.shape[0], 4), dtype=np.float32)
    if hit.size:
        albedo, specular = _surface(alone, o, d[hit], owner[hit], t_best[hit], footprint)
        flat[hit, :3] = _lit(scene, d[hit], albedo, specular, normals[hit])
        flat[hit, 3] = 1.0
    img = flat.reshape((rows[1] - rows[0]) * s, (cols[1] - cols[0]) * s, 4)
    if s > 1:
        size = (cols[1] - cols[0], rows[1] - rows[0])
        img = np.asarray(cv2.resize(img, size, interpolation=cv2.INTER_AREA), np.float32)
    return np.ascontiguousarray(img[:, :, :3]), np.ascontiguousarray(img[:, :, 3])


def _band_radiance(scene: Scene, layout: Layout, o: F64, d: F64, footprint: F64) -> F64:
    """The radiance (R, 3) of the rays ``d`` (R, 3, grid frame) from ``o``."""
    t_best, owner, normals = _intersect(layout, o, d)
    albedo, specular = _surface(layout, o, d, owner, t_best, footprint)
    _shade_background(scene, layout, o, d, owner, t_best, albedo, normals)
    return _lit(scene, d, albedo, specular, normals)


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
    layout: Layout, o: F64, d: F64, owner: NDArray[np.int32], t_best: F64, footprint: F64
) -> tuple[F64, F64]:
    """Albedo (R, 3) and specular strength (R,) where each ray hit (the dot on its card).

    ``footprint`` (2,): a ray sample's width and height per unit of depth, over which the
    board's squares are averaged (:func:`_box_filtered_checker`).
    """
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
        elif prim.kind == "checkerboard":
            p = o + d[m] * t_best[m, None]
            width = t_best[m, None] * footprint / prim.square  # (R, 2), in squares
            dark = _box_filtered_checker(
                (p[:, 0] - prim.dot_center[0]) / prim.square,
                (prim.dot_center[1] - p[:, 1]) / prim.square,
                width,
                prim.squares,
            )
            albedo[m] = prim.color + dark[:, None] * (prim.dot_color - prim.color)
    return albedo, specular


def _lit(scene: Scene, d: F64, albedo: F64, specular: F64, normals: F64) -> F64:
    """Ambient + Lambert + a Blinn highlight under the scene's one directional light.

    The highlight is worked out only where a surface is shiny.
    """
    light = np.asarray(scene.lighting.direction, dtype=np.float64)
    light /= np.linalg.norm(light)
    lam = np.clip(normals @ light, 0.0, None)
    radiance = albedo * (scene.lighting.ambient + scene.lighting.diffuse * lam)[:, None]
    shiny = np.flatnonzero(specular)
    if shiny.size:
        ds, ns = d[shiny], normals[shiny]
        view = -ds / np.linalg.norm(ds, axis=1, keepdims=True)
        half = light + view
        half /= np.linalg.norm(half, axis=1, keepdims=True)
        highlight = specular[shiny] * np.clip(np.einsum("ij,ij->i", ns, half), 0, None) ** 40
        radiance[shiny] += highlight[:, None]
    return np.asarray(radiance)


def _box_filtered_checker(x: F64, y: F64, width: F64, squares: tuple[int, int]) -> F64:
    """How much of each sample's footprint is dark on the board, in [0, 1].

    ``x, y`` (R,) in squares from the pattern's lower-left corner, ``width`` (R, 2) the
    footprint in squares, ``squares`` the pattern's (cols, rows). The squares whose indices
    sum to an even number are dark (the corner square is). Point-sampled, a square's edge
    moves in steps of a sample and the corners found by OpenCV carry a bias of 0.1-0.4 px
    that changes with the distance (most where the board is aligned with the pixel grid);
    a sensor integrates over its pixels, so the pattern is averaged over the footprint
    exactly: with s(x) = +1 on even squares and -1 on odd ones, dark = (1 + s(x) s(y)) / 2
    is separable, and s's integral is a triangle wave.
    """

    def integral(u: F64) -> F64:
        """The integral of s from 0: a triangle wave of period 2."""
        return np.asarray(1.0 - np.abs(1.0 - np.mod(u, 2.0)))

    def averaged(v: F64, w: F64, n: int) -> tuple[F64, F64]:
        """The footprint's share inside [0, n), and s's mean over it (0 outside)."""
        lo, hi = np.clip(v - w / 2, 0, n), np.clip(v + w / 2, 0, n)
        return (hi - lo) / w, (integral(hi) - integral(lo)) / w

    inside_x, sx = averaged(x, width[:, 0], squares[0])
    inside_y, sy = averaged(y, width[:, 1], squares[1])
    return np.asarray(0.5 * (inside_x * inside_y + sx * sy))


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
    free = np.flatnonzero(owner < 0)
    df = d.take(free, axis=0)  # take and compress: 4x faster than indexing, same rows
    h = scene.ground_height
    with np.errstate(divide="ignore", invalid="ignore"):
        t_table = (h - o[1]) / df[:, 1]
    p = o + df * np.where(np.isfinite(t_table), t_table, 0.0)[:, None]
    x0, x1, z0, z1 = scene.table_extent
    on_table = (t_table > 0) & (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 2] >= z0) & (p[:, 2] <= z1)
    table = free[on_table]
    albedo[table] = _table_texture(
        scene,
        layout,
        p.compress(on_table, axis=0),
        df.compress(on_table, axis=0),
        t_table[on_table],
    )
    normals[table] = (0.0, -1.0, 0.0)

    rest, dr = free[~on_table], df.compress(~on_table, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_wall = (scene.wall_z - o[2]) / dr[:, 2]
    pw = o + dr * np.where(np.isfinite(t_wall), t_wall, 0.0)[:, None]
    on_wall = (t_wall > 0) & (pw[:, 1] < h)
    wall_tex = np.tile(srgb_to_linear(scene.wall_color), (int(on_wall.sum()), 1))
    _paint_decals(layout.decals, "back_wall", pw.compress(on_wall, axis=0)[:, :2], wall_tex)
    albedo[rest[on_wall]] = wall_tex
    normals[rest[on_wall]] = (0.0, 0.0, -1.0)
    floor = rest[~on_wall]
    albedo[floor] = srgb_to_linear(scene.floor_color)
    normals[floor] = (0.0, -1.0, 0.0)
    t_best[table] = t_table[on_table]


def _table_texture(scene: Scene, layout: Layout, tab: F64, d: F64, t_table: F64) -> F64:
    """The table's colour (R, 3) at the points ``tab`` its rays ``d`` meet at ``t_table``.

    The grid paper's lines, anti-aliased by their footprint in the plane, on the paper; the
    wood around it; the table's decals.
    """
    px0, px1, pz0, pz1 = scene.paper_extent
    on_paper = np.flatnonzero(
        (tab[:, 0] >= px0) & (tab[:, 0] <= px1) & (tab[:, 2] >= pz0) & (tab[:, 2] <= pz1)
    )
    tex = np.tile(srgb_to_linear(scene.table_color), (tab.shape[0], 1))
    f = 0.5 * (scene.cameras[0].fx + scene.cameras[0].fy) * scene.sensor.supersample
    d_paper = d.take(on_paper, axis=0)
    length = np.linalg.norm(d_paper, axis=1)
    ray_len = t_table[on_paper] * length
    grazing = np.clip(np.abs(d_paper[:, 1]) / length, 0.03, 1.0)
    foot_x = ray_len / f
    foot_z = foot_x / grazing
    g = scene.grid_spacing
    w = scene.grid_line_width

    def coverage(coord: F64, foot: F64) -> F64:
        dist = np.abs(coord / g - np.round(coord / g)) * g
        cov = np.clip((w / 2 - dist) / foot + 0.5, 0.0, 1.0) * np.clip(w / foot, 0.0, 1.0)
        return np.asarray(np.maximum(cov, 0.0))

    paper_points = tab.take(on_paper, axis=0)
    line = np.maximum(coverage(paper_points[:, 0], foot_x), coverage(paper_points[:, 2], foot_z))
    paper, grid = srgb_to_linear(scene.paper_color), srgb_to_linear(scene.grid_color)
    tex[on_paper] = paper * (1 - line[:, None]) + grid * line[:, None]
    _paint_decals(layout.decals, "table", tab[:, [0, 2]], tex)
    return tex


def _paint_decals(decals: tuple[Decal, ...], surface: str, ab: F64, tex: F64) -> None:
    """Paint the ``surface``'s decals into ``tex`` (R, 3) at its points ``ab`` (R, 2).

    Each decal is tested only on the points within its bounding box.
    """
    for decal in decals:
        if decal.surface != surface:
            continue
        lo, hi = _decal_box(decal)
        near = np.flatnonzero(
            (ab[:, 0] >= lo[0]) & (ab[:, 0] <= hi[0]) & (ab[:, 1] >= lo[1]) & (ab[:, 1] <= hi[1])
        )
        if near.size:
            tex[near[_decal_mask(decal, ab[near])]] = decal.color


def _decal_box(decal: Decal) -> tuple[F64, F64]:
    """A box (lo, hi) in the surface's (a, b) that holds the decal, with a margin.

    No point outside it is painted: a disk's, a ring's or an ellipse's points lie within
    its largest semi-axis of its centre, a triangle's within its vertices' box.
    """
    if decal.shape == "triangle":
        lo, hi = decal.vertices.min(axis=0), decal.vertices.max(axis=0)
    else:
        r = float(np.max(decal.size))
        lo, hi = decal.center - r, decal.center + r
    margin = 0.01 * float(np.max(hi - lo)) + 1e-9
    return lo - margin, hi + margin


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
