"""Clutter the target must not be seen over: a pose that would put it there loses the target.

The glove's filters reject blue-ish things that are not a finger (a round disk, a ring, a
speck), but a finger seen over one of them merges with it into one blob that fails the
filters in every frame (issue 55: at large reach the fourth suggestion put the finger over
the synthetic scene's blue disk, and none of its 5 frames found it). Guidance leaves such a
pose out, with its reason (:data:`twopose.guidance.paper.CLUTTER`).

Where the clutter is known from (:class:`Clutter`): the synthetic scene's decals, exactly
(:func:`scene_clutter`); for a real camera, the blobs the detector turned down in the last
frames (:func:`seen_clutter`), placed on the ground where the method knows it (method 2's
table) and else taken as far away (a far thing moves little in the image when the laptop
moves on the table, the target much more: :data:`FAR_IN`). A pose is over clutter when, from it, the
target's blob (the finger's nominal length about its centroid, or the dot, with the
finger's radius about it) comes within :data:`GAP_PX` pixels of a clutter's disc.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.camera.model import grid_rays, rotation_from_angles_deg
from twopose.guidance.paper import project, view_checks
from twopose.solve.estimate import GroundSpec, PoseView
from twopose.values.units import Units, unit_factor

__all__ = [
    "FAR_IN",
    "GAP_PX",
    "TARGET_RADIUS_IN",
    "Clutter",
    "over_clutter",
    "scene_clutter",
    "seen_clutter",
]

#: The least gap (pixels) between the target's blob and a clutter's disc: two blobs nearer
#: than this are one after the threshold (the thesis' Otsu step blurs their edges).
GAP_PX = 8.0
#: The target's blob's half-width about its axis (inches): the glove's finger (the
#: synthetic scene's 0.33 in), more than the dot's 0.15 in.
TARGET_RADIUS_IN = 0.33
#: A blob seen by a real camera whose ray does not meet the known ground is taken this far
#: away (inches; about 76 m): far beyond any table, so it keeps its pixels as the laptop
#: moves on the paper.
FAR_IN = 3000.0


@dataclass(frozen=True, kw_only=True)
class Clutter:
    """Things the target must not be seen over: each a point and its extent about it."""

    points: F64  # (M, 3) grid frame, session units
    radii: F64  # (M,) session units
    source: str  # where they are known from, in words ("the synthetic scene", ...)

    def __len__(self) -> int:
        """How many things."""
        return len(self.radii)


def over_clutter(
    view: PoseView, centres: F64, target: F64, units: Units, clutter: Clutter | None, *,
    lines: bool,
) -> Bools:  # fmt: skip
    """(K,) whether ``view``'s camera moved to each of ``centres`` sees the target over clutter.

    ``target`` (2, 3) as guidance uses it (:func:`twopose.guidance.prediction.target_of`); the
    target's blob is the finger's nominal length about its centroid (the dot: its point),
    :data:`TARGET_RADIUS_IN` about its axis.
    """
    centres = np.atleast_2d(np.asarray(centres, dtype=np.float64))
    if clutter is None or not len(clutter):
        return np.zeros(len(centres), dtype=bool)
    points, _ = view_checks(target, units, lines=lines)
    ends = points[1:] if lines else points[:1]  # the finger's two ends, or the dot twice
    a_px = project(ends[:1], view, centres)[:, 0]  # (K, 2)
    b_px = project(ends[-1:], view, centres)[:, 0]
    c_px = project(clutter.points, view, centres)  # (K, M, 2)
    R = rotation_from_angles_deg(view.r_deg)
    forward = R[:, 2]  # the camera's optical axis in the grid frame
    f = float(np.mean(view.intrinsics[:2]))
    depth_c = (clutter.points[None, :, :] - centres[:, None, :]) @ forward  # (K, M)
    depth_t = (target[0][None, :] - centres) @ forward  # (K,)
    with np.errstate(invalid="ignore", divide="ignore"):
        r_clutter = f * clutter.radii[None, :] / depth_c
        r_target = f * TARGET_RADIUS_IN * unit_factor(Units.IN, units) / depth_t
        ab = (b_px - a_px)[:, None, :]
        ap = c_px - a_px[:, None, :]
        length2 = np.maximum((ab**2).sum(axis=-1), 1e-12)
        s = np.clip((ap * ab).sum(axis=-1) / length2, 0.0, 1.0)
        gap = np.linalg.norm(ap - s[..., None] * ab, axis=-1)
        near = gap < r_clutter + r_target[:, None] + GAP_PX
    seen = (depth_c > 0) & np.isfinite(gap)
    return np.asarray((near & seen).any(axis=1))


def scene_clutter(decals: Iterable[object], ground_height: float, wall_z: float) -> Clutter:
    """The synthetic scene's clutter decals (:class:`twopose.sim.layout.Decal`) as clutter.

    Each decal is flat on the table (``y = ground_height``) or the wall (``z = wall_z``);
    its extent is its largest semi-axis (a triangle: its farthest vertex).
    """
    points, radii = [], []
    for d in decals:
        centre = np.asarray(d.center, dtype=np.float64)  # type: ignore[attr-defined]
        if d.surface == "table":  # type: ignore[attr-defined]
            points.append([centre[0], ground_height, centre[1]])
        else:
            points.append([centre[0], centre[1], wall_z])
        vertices = np.asarray(d.vertices, dtype=np.float64)  # type: ignore[attr-defined]
        size = float(np.max(d.size))  # type: ignore[attr-defined]
        if d.shape == "triangle":  # type: ignore[attr-defined]
            size = float(np.linalg.norm(vertices - centre, axis=1).max())
        radii.append(size)
    return Clutter(
        points=np.array(points, dtype=np.float64).reshape(-1, 3),
        radii=np.array(radii, dtype=np.float64),
        source="the synthetic scene",
    )


def seen_clutter(
    view: PoseView, blobs: Sequence[tuple[float, float, float]], ground: GroundSpec | None,
    units: Units,
) -> Clutter:  # fmt: skip
    """The blobs a camera's detector turned down in ``view``'s frames, placed in the grid.

    ``blobs``: each ``(u, v, radius)`` in pixels. A blob whose ray meets the ``ground``
    (known for method 2) ahead of the camera is placed there; any other is taken
    :data:`FAR_IN` away. Its radius follows from its pixels at that depth.
    """
    if not blobs:
        return Clutter(points=np.zeros((0, 3)), radii=np.zeros(0), source="the last frames")
    px = np.array([b[:2] for b in blobs], dtype=np.float64)
    r_px = np.array([b[2] for b in blobs], dtype=np.float64)
    R = rotation_from_angles_deg(view.r_deg)
    rays = np.atleast_2d(grid_rays(px, view.intrinsics, R))  # (M, 3) unit
    centre = np.asarray(view.t_grid, dtype=np.float64)
    far = FAR_IN * unit_factor(Units.IN, units)
    along = np.full(len(px), far)
    if ground is not None:
        normal, offset = ground
        facing = rays @ normal
        with np.errstate(invalid="ignore", divide="ignore"):
            t = (offset - float(normal @ centre)) / facing
        along = np.where((facing > 1e-9) & (t > 0) & (t < far), t, far)
    points = centre + along[:, None] * rays
    depth = along * (rays @ R[:, 2])
    f = float(np.mean(view.intrinsics[:2]))
    return Clutter(points=points, radii=r_px * depth / f, source="the last frames")
