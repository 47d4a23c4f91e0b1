"""The camera: its model and the images it gives.

The self-validating intrinsics and the pose conventions (``model``) and images decoded
safely, header first, within their size and pixel limits (``images``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.camera.images import decode_image
    from twopose.camera.model import (
        SIGMA_KEYS,
        Camera,
        Intrinsics,
        camera_centres,
        camera_rays,
        grid_rays,
        intrinsics_sigma,
        project_points,
        quaternion_xyzw_from_matrix,
        rotation_from_angles_deg,
    )

__all__ = [
    "SIGMA_KEYS",
    "Camera",
    "Intrinsics",
    "camera_centres",
    "camera_rays",
    "decode_image",
    "grid_rays",
    "intrinsics_sigma",
    "project_points",
    "quaternion_xyzw_from_matrix",
    "rotation_from_angles_deg",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "SIGMA_KEYS": "twopose.camera.model",
    "Camera": "twopose.camera.model",
    "Intrinsics": "twopose.camera.model",
    "camera_centres": "twopose.camera.model",
    "camera_rays": "twopose.camera.model",
    "decode_image": "twopose.camera.images",
    "grid_rays": "twopose.camera.model",
    "intrinsics_sigma": "twopose.camera.model",
    "project_points": "twopose.camera.model",
    "quaternion_xyzw_from_matrix": "twopose.camera.model",
    "rotation_from_angles_deg": "twopose.camera.model",
}

__getattr__, __dir__ = lazy_exports("twopose.camera", _HOMES, __all__)
