"""The one synthetic camera: a scene rendered from the pose the rig really has.

The operator types (or the simulated operator draws) a pose; the laptop is placed there,
give or take the placing error; the camera then sits where the rig's hidden constants put
it (mount rotation, camera offset, tape scale) and sees through its real intrinsics (focal
scale, principal offset): the scene's ``[systematic]`` table (:class:`twopose.rig.RigConstants`).
Both the recorder's ``--source synthetic`` and ``twopose-record simulate`` render through
this class, so what the recorder rehearses is what the simulator writes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.camera.model import Intrinsics, rotation_from_angles_deg
from twopose.rig.constants import RigConstants, angles_deg_from_rotation
from twopose.sim.layout import Layout
from twopose.sim.render import expose, render_radiance
from twopose.sim.scene import CameraParams, Scene

__all__ = ["SyntheticCamera", "camera_pose", "true_intrinsics"]


def camera_pose(rig: RigConstants, t_placed: F64, r_placed: F64) -> tuple[F64, F64]:
    """Where the camera really is when the laptop is placed at a typed pose.

    The placed pose is ``t_placed, r_placed`` (grid frame, session units; degrees); the rig's mount
    rotation, camera offset and tape scale move it (:mod:`twopose.rig.constants`).
    """
    if rig.is_identity:
        return t_placed, r_placed
    t, R = rig.true_poses(t_placed, r_placed)
    return np.asarray(t), np.array(angles_deg_from_rotation(R))


def true_intrinsics(rig: RigConstants, intr: Intrinsics) -> Intrinsics:
    """The camera's real intrinsics: the rig's focal scale and principal offset."""
    if rig.is_identity:
        return intr
    fx, fy, cx, cy = rig.true_intrinsics([intr.fx, intr.fy, intr.cx, intr.cy])
    return dataclasses.replace(intr, fx=float(fx), fy=float(fy), cx=float(cx), cy=float(cy))


class SyntheticCamera:
    """The scene's cameras, rendered from where the rig puts them.

    The scene's cameras (one at a time: :attr:`camera`): :meth:`place` renders the scene
    once from where the rig puts the camera when the laptop is placed at a pose,
    :meth:`expose` makes each frame anew from it (lighting, sensor noise, quantisation:
    :func:`twopose.sim.render.expose`).
    """

    def __init__(self, scene: Scene, layout: Layout, rng: np.random.Generator) -> None:
        self.scene, self.layout, self.rng = scene, layout, rng
        self.camera: CameraParams = scene.cameras[0]
        self._radiance: NDArray[np.float32] | None = None

    def place(
        self, t_placed: F64, r_placed_deg: F64, *, between: Callable[[], None] | None = None
    ) -> None:
        """Render from where the camera really is when the laptop is placed here.

        Grid frame, session units, degrees; the rig's constants applied. ``between``: called
        between two bands of rays; what it raises abandons the rendering, the placement
        before kept (:func:`twopose.sim.render.render_radiance`).
        """
        t, r = camera_pose(self.scene.systematic, np.asarray(t_placed), np.asarray(r_placed_deg))
        self.place_camera(t, r, between=between)

    def place_camera(
        self, t_camera: F64, r_camera_deg: F64, *, between: Callable[[], None] | None = None
    ) -> None:
        """Render from the camera's own (true) pose.

        The rig's pose constants already applied (the simulator draws it to check the target
        is in view); the rig's intrinsics constants are applied here.
        """
        self._radiance = render_radiance(
            self.scene,
            self.layout,
            true_intrinsics(self.scene.systematic, self.camera.intrinsics),
            rotation_from_angles_deg(r_camera_deg),
            np.asarray(t_camera, dtype=np.float64),
            between=between,
        )

    def expose(self) -> NDArray[np.uint8]:
        """One frame of the current placement."""
        assert self._radiance is not None, "place the camera first"
        return expose(self._radiance, self.scene, self.rng)
