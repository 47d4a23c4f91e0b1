"""A laptop-on-grid rig's hidden constants, and how they act on what the operator types.

Nobody measures them, yet each biases every trial the same way (the thesis' own
explanation of its bias, sections 5.3-5.4): averaging frames or adding poses does not
remove them. The simulator uses them to render (typed -> true); the analysis, once it has
estimated them, uses the same map to correct every view before solving; the recorder can
apply a calibrated rig to its live result. One home for the rule:

* ``mount_rotation_deg`` (rx, ry, rz): the webcam relative to the laptop body, the
  screen's tilt included: ``R_true = R_typed · R_mount``;
* ``camera_offset`` (x, y, z, session units): the camera centre relative to the point the
  operator measures with the tape, in the laptop's frame: ``t_true = tape_scale · t_typed +
  R_typed · camera_offset``;
* ``focal_scale``: true focal parameter = typed × scale (the thesis assumed 525 px);
* ``principal_offset_px`` (dx, dy): true principal point = typed + offset;
* ``tape_scale``: what the tape reads against the true distance (applied as above);
* ``ground_height_error``: the typed ground height minus the true one.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.camera import rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.estimate import GroundSpec, PoseView

__all__ = [
    "RIG_PARAMETERS",
    "RigConstants",
    "angles_deg_from_rotation",
    "corrected_ground",
    "corrected_view",
    "load_rig",
]

F64 = NDArray[np.float64]

#: Each constant's scalar parameters, in the order of :meth:`RigConstants.vector`.
RIG_PARAMETERS = {
    "mount_rotation_deg": ("mount_rx_deg", "mount_ry_deg", "mount_rz_deg"),
    "camera_offset": ("offset_x", "offset_y", "offset_z"),
    "focal_scale": ("focal_scale",),
    "principal_offset_px": ("principal_dx_px", "principal_dy_px"),
    "tape_scale": ("tape_scale",),
    "ground_height_error": ("ground_height_error",),
}


@dataclass(frozen=True)
class RigConstants:
    """The rig's constants (see the module docstring); the defaults change nothing."""

    mount_rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    camera_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    focal_scale: float = 1.0
    principal_offset_px: tuple[float, float] = (0.0, 0.0)
    tape_scale: float = 1.0
    ground_height_error: float = 0.0

    def __post_init__(self) -> None:
        values = self.vector()
        if not np.isfinite(values).all():
            raise InputValueError(f"rig constants must be finite numbers, got {self}")
        if not (0.5 < self.focal_scale < 2.0 and 0.5 < self.tape_scale < 2.0):
            raise InputValueError(
                "rig constants: focal_scale and tape_scale must be within (0.5, 2), got "
                f"{self.focal_scale} and {self.tape_scale}"
            )

    @property
    def is_identity(self) -> bool:
        return bool(np.allclose(self.vector(), RigConstants().vector(), rtol=0.0, atol=0.0))

    def vector(self) -> F64:
        """The 11 scalars in :data:`RIG_PARAMETERS` order."""
        parts: list[float] = []
        for f in fields(self):
            value = getattr(self, f.name)
            parts += list(value) if isinstance(value, tuple) else [value]
        return np.array(parts, dtype=np.float64)

    @classmethod
    def from_vector(cls, values: ArrayLike) -> RigConstants:
        v = [float(x) for x in np.asarray(values, dtype=np.float64)]
        return cls((v[0], v[1], v[2]), (v[3], v[4], v[5]), v[6], (v[7], v[8]), v[9], v[10])

    def true_poses(self, t_typed: ArrayLike, r_typed_deg: ArrayLike) -> tuple[F64, F64]:
        """Typed camera centres (..., 3) and angles (..., 3, degrees) -> the true centres
        (..., 3) and rotations ``R_cam_to_grid`` (..., 3, 3)."""
        t = np.asarray(t_typed, dtype=np.float64)
        R_typed = rotation_from_angles_deg(r_typed_deg)
        R_mount = rotation_from_angles_deg(self.mount_rotation_deg)
        offset = np.einsum("...ij,j->...i", R_typed, np.asarray(self.camera_offset))
        return self.tape_scale * t + offset, np.asarray(R_typed @ R_mount)

    def true_intrinsics(self, intrinsics: ArrayLike) -> F64:
        """Typed ``(fx, fy, cx, cy)`` (..., 4) -> the true ones."""
        k = np.array(intrinsics, dtype=np.float64)
        k[..., :2] *= self.focal_scale
        k[..., 2:] += np.asarray(self.principal_offset_px)
        return k

    def true_ground_height(self, typed: float) -> float:
        return typed - self.ground_height_error


def angles_deg_from_rotation(R: ArrayLike) -> F64:
    """The angles ``(rx, ry, rz)`` (..., 3) in degrees with ``rotation_from_angles_deg``
    giving ``R`` (..., 3, 3) (``R = Rx Ry Rz``; ry in [-90, 90])."""
    m = np.asarray(R, dtype=np.float64)
    ry = np.arcsin(np.clip(m[..., 0, 2], -1.0, 1.0))
    rx = np.arctan2(-m[..., 1, 2], m[..., 2, 2])
    rz = np.arctan2(-m[..., 0, 1], m[..., 0, 0])
    angles: F64 = np.degrees(np.stack([rx, ry, rz], axis=-1))
    return angles


def corrected_view(view: PoseView, rig: RigConstants) -> PoseView:
    """A pose as the rig really had it: typed centre, angles and intrinsics corrected."""
    t, R = rig.true_poses(view.t_grid, view.r_deg)
    return dataclasses.replace(
        view,
        t_grid=np.asarray(t, dtype=np.float64),
        r_deg=angles_deg_from_rotation(R),
        intrinsics=rig.true_intrinsics(view.intrinsics),
    )


def corrected_ground(ground: GroundSpec | None, rig: RigConstants) -> GroundSpec | None:
    """The ground plane at its true height (the typed one minus the rig's error)."""
    if ground is None:
        return None
    normal, offset = ground
    return normal, offset - rig.ground_height_error * float(np.linalg.norm(normal))


def load_rig(path: str | Path) -> RigConstants:
    """A rig file written by ``twopose-analyze rig`` (its ``[rig]`` table)."""
    from twopose.config import build_dataclass, read_toml

    data = read_toml(path, "rig file", InputValueError)
    if not isinstance(data.get("rig"), dict):
        raise InputValueError(
            f"rig file {path}: no [rig] table; write one with twopose-analyze rig"
        )
    return build_dataclass(RigConstants, data["rig"], f"rig file {path}", InputValueError)
