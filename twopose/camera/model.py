"""The pinhole camera model and pose conventions shared by every stage.

Conventions (``docs/method.md``): camera frame x right, y down, z forward;
grid frame G x right, y down (toward the table), z forward. A pose is the camera
centre ``t_grid`` in G and ``R_cam_to_grid`` built from typed angles as
``Rx(rx) Ry(ry) Rz(rz)``, so that ``p_grid = R_cam_to_grid @ p_cam + t_grid``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.errors import InputValueError
from twopose.values.checks import camera_id, finite, numbers

__all__ = [
    "SIGMA_KEYS",
    "Camera",
    "Intrinsics",
    "camera_centres",
    "camera_rays",
    "grid_rays",
    "intrinsics_sigma",
    "project_points",
    "quaternion_xyzw_from_matrix",
    "rotation_from_angles_deg",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class Intrinsics:
    """Pinhole intrinsics in pixels, with OpenCV ``plumb_bob`` distortion (k1, k2, p1, p2, k3)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        """Check the image size and the focal lengths, principal point and distortion."""
        for name in ("width", "height"):
            size = getattr(self, name)
            if isinstance(size, bool) or not isinstance(size, int | np.integer) or size <= 0:
                raise InputValueError(f"image {name} must be a whole number > 0, got {size!r}")
            object.__setattr__(self, name, int(size))
        for name in ("fx", "fy"):
            object.__setattr__(self, name, finite(getattr(self, name), name, positive=True))
        for name in ("cx", "cy"):
            object.__setattr__(self, name, finite(getattr(self, name), name))
        k1, k2, p1, p2, k3 = numbers(self.distortion, 5, "distortion (k1, k2, p1, p2, k3)")
        object.__setattr__(self, "distortion", (k1, k2, p1, p2, k3))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], what: str) -> Intrinsics:
        """Intrinsics from a table of ``width, height, fx, fy, cx, cy[, distortion]``.

        From ``width, height, fx, fy, cx, cy[, distortion]`` (calibration files, plans, the
        session metadata); a missing or bad value raises InputValueError naming ``what``.
        """
        missing = [k for k in ("width", "height", "fx", "fy", "cx", "cy") if k not in data]
        if missing:
            raise InputValueError(f"{what}: missing {', '.join(missing)}")
        try:
            return cls(
                width=data["width"],
                height=data["height"],
                fx=data["fx"],
                fy=data["fy"],
                cx=data["cx"],
                cy=data["cy"],
                distortion=data.get("distortion", (0.0, 0.0, 0.0, 0.0, 0.0)),
            )
        except InputValueError as err:
            raise InputValueError(f"{what}: {err}") from err

    def to_dict(self) -> dict[str, Any]:
        """The inverse of :meth:`from_dict`."""
        return {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "distortion": list(self.distortion),
        }

    @property
    def K(self) -> FloatArray:
        """The 3x3 camera matrix."""
        return np.array(
            [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]], dtype=np.float64
        )

    @property
    def has_distortion(self) -> bool:
        """Whether any distortion coefficient is non-zero."""
        return any(k != 0.0 for k in self.distortion)


#: The intrinsics a calibration's 1-sigma may be given for (OpenCV's order).
SIGMA_KEYS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")


@dataclass(frozen=True, kw_only=True)
class Camera:
    """A camera of a session: its id, its calibration and the calibration's sigma.

    The sigma (format 1.2) is a 1-sigma per intrinsic (:data:`SIGMA_KEYS`), empty when unknown,
    e.g. typed by hand.
    """

    camera_id: str
    intrinsics: Intrinsics
    intrinsics_sigma: Mapping[str, float] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        """Check the camera id and the calibration's sigma."""
        camera_id(self.camera_id)
        object.__setattr__(self, "intrinsics_sigma", intrinsics_sigma(self.intrinsics_sigma))


def intrinsics_sigma(values: Mapping[str, Any]) -> dict[str, float]:
    """A calibration's 1-sigma per intrinsic, checked: known keys, finite numbers >= 0."""
    out: dict[str, float] = {}
    for key, value in values.items():
        if key not in SIGMA_KEYS:
            raise InputValueError(f"unknown intrinsic {key!r}; known: {', '.join(SIGMA_KEYS)}")
        v = finite(value, f"the sigma of {key}")
        if v < 0:
            raise InputValueError(f"the sigma of {key} must be >= 0, got {v}")
        out[key] = v
    return out


def rotation_from_angles_deg(angles_deg: ArrayLike) -> FloatArray:
    """``R_cam_to_grid = Rx(rx) Ry(ry) Rz(rz)`` from typed angles in degrees.

    Parameters
    ----------
    angles_deg : (..., 3) array_like
        ``(rx, ry, rz)`` in degrees; leading dimensions are batched.

    Returns
    -------
    (..., 3, 3) ndarray
    """
    a = np.deg2rad(np.asarray(angles_deg, dtype=np.float64))
    cx, cy, cz = np.cos(a[..., 0]), np.cos(a[..., 1]), np.cos(a[..., 2])
    sx, sy, sz = np.sin(a[..., 0]), np.sin(a[..., 1]), np.sin(a[..., 2])
    one, zero = np.ones_like(cx), np.zeros_like(cx)
    Rx = np.stack([one, zero, zero, zero, cx, -sx, zero, sx, cx], -1).reshape(*cx.shape, 3, 3)
    Ry = np.stack([cy, zero, sy, zero, one, zero, -sy, zero, cy], -1).reshape(*cx.shape, 3, 3)
    Rz = np.stack([cz, -sz, zero, sz, cz, zero, zero, zero, one], -1).reshape(*cx.shape, 3, 3)
    R: FloatArray = Rx @ Ry @ Rz
    return R


def quaternion_xyzw_from_matrix(R: ArrayLike) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w) of a 3x3 rotation matrix, w >= 0 (Shepperd's method)."""
    m = np.asarray(R, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, s / 4)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = (s / 4, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 1] + m[1, 0]) / s, s / 4, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, s / 4, (m[1, 0] - m[0, 1]) / s)
    v = np.array(q, dtype=np.float64)
    v /= np.linalg.norm(v)
    if v[3] < 0:
        v = -v
    return (float(v[0]), float(v[1]), float(v[2]), float(v[3]))


def project_points(
    p_grid: ArrayLike,
    intrinsics: Intrinsics,
    R_cam_to_grid: ArrayLike,
    t_grid: ArrayLike,
) -> FloatArray:
    """Project grid-frame points to pixels (col, row), applying the stored distortion.

    Parameters
    ----------
    p_grid : (N, 3) array_like
        Points in the grid frame.
    intrinsics : Intrinsics
    R_cam_to_grid : (3, 3) array_like
    t_grid : (3,) array_like
        Camera centre in the grid frame.

    Returns
    -------
    (N, 2) ndarray
        Pixel coordinates; points behind the camera come back as NaN.
    """
    p = np.atleast_2d(np.asarray(p_grid, dtype=np.float64))
    R = np.asarray(R_cam_to_grid, dtype=np.float64)
    p_cam = (p - np.asarray(t_grid, dtype=np.float64)) @ R  # R^T (p - t), row-wise
    z = p_cam[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = p_cam[:, 0] / z, p_cam[:, 1] / z
    if intrinsics.has_distortion:
        k1, k2, p1, p2, k3 = intrinsics.distortion
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
        x, y = (
            x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y,
        )
    px = np.stack([intrinsics.fx * x + intrinsics.cx, intrinsics.fy * y + intrinsics.cy], axis=1)
    px[z <= 0] = np.nan
    return px


def camera_rays(px: ArrayLike, intrinsics: ArrayLike) -> FloatArray:
    """Back-projection of pixels ``px`` (..., 2) to camera-frame directions (..., 3).

    ``((col - cx) / fx, (row - cy) / fy, 1)`` by pinhole ``intrinsics`` (..., 4: fx, fy,
    cx, cy): the one place a pixel becomes a ray (no distortion: undistort it first).
    """
    p = np.asarray(px, dtype=np.float64)
    k = np.asarray(intrinsics, dtype=np.float64)
    x = (p[..., 0] - k[..., 2]) / k[..., 0]
    y = (p[..., 1] - k[..., 3]) / k[..., 1]
    return np.stack([x, y, np.ones_like(x)], axis=-1)


def grid_rays(px: ArrayLike, intrinsics: ArrayLike, R_cam_to_grid: ArrayLike) -> FloatArray:
    """Unit directions in the grid frame (..., 3) of pixels ``px`` (..., 2).

    Seen by cameras of ``intrinsics`` (..., 4) turned by ``R_cam_to_grid`` (..., 3, 3).
    """
    d = np.einsum("...ij,...j->...i", np.asarray(R_cam_to_grid, dtype=np.float64),
                  camera_rays(px, intrinsics))  # fmt: skip
    return np.asarray(d / np.linalg.norm(d, axis=-1, keepdims=True))


def camera_centres(P: ArrayLike) -> FloatArray:
    """Camera centres (..., 3): ``-M^-1 p4`` for ``P = [M | p4]``."""
    p = np.asarray(P, dtype=np.float64)
    return np.asarray(-np.linalg.solve(p[..., :, :3], p[..., :, 3:])[..., 0])
