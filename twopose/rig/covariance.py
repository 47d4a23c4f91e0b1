"""The rig's constants by name, and their covariance as a rig file keeps it (issue 54).

The scalars of the rig's constants (:data:`RIG_PARAMETERS`, :data:`SCALARS`) and
:class:`RigCovariance`, the fitted ones' covariance, declared apart from the constants
themselves so that the noise model (:mod:`twopose.uncertainty.noise`) can name the covariance
without
importing the estimation. No I/O.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.errors import InputValueError

__all__ = ["RIG_PARAMETERS", "SCALARS", "RigCovariance"]


#: Each constant's scalar parameters, in the order of
#: :meth:`twopose.rig.constants.RigConstants.vector`.
RIG_PARAMETERS = {
    "mount_rotation_deg": ("mount_rx_deg", "mount_ry_deg", "mount_rz_deg"),
    "camera_offset": ("offset_x", "offset_y", "offset_z"),
    "focal_scale": ("focal_scale",),
    "principal_offset_px": ("principal_dx_px", "principal_dy_px"),
    "tape_scale": ("tape_scale",),
    "ground_height_error": ("ground_height_error",),
}
#: Every scalar's name, in :meth:`twopose.rig.constants.RigConstants.vector` order.
SCALARS = tuple(n for names in RIG_PARAMETERS.values() for n in names)


@dataclass(frozen=True, kw_only=True)
class RigCovariance:
    """The fitted constants' covariance (issue 54): what a rig file's ``[covariance]`` holds.

    ``names``: the fitted scalars (of :data:`SCALARS`, in its order); ``matrix``: their
    covariance, each in its own unit (degrees, the rig's length unit, a ratio, pixels).
    Board fits find ``offset_x`` and ``principal_dx_px`` (a sideways shift of the camera and
    of its principal point look alike) strongly correlated: every ``--rig`` region carries
    the whole matrix (``J C J^T``, :mod:`twopose.rig.carried`), never the diagonal alone.
    ``independent``: only 1-sigmas were known (a rig file from before ``[covariance]``),
    carried as if uncorrelated, which overstates what the correlations cancel.
    """

    names: tuple[str, ...]
    matrix: tuple[tuple[float, ...], ...]
    independent: bool = False

    def __post_init__(self) -> None:
        """Refuse names that are no scalar (or twice), and a matrix that is no covariance."""
        unknown = [n for n in self.names if n not in SCALARS]
        if unknown or len(set(self.names)) != len(self.names):
            raise InputValueError(
                f"rig covariance: names must be distinct scalars of {', '.join(SCALARS)}, "
                f"got {list(self.names)}"
            )
        order = [SCALARS.index(n) for n in self.names]
        if order != sorted(order):
            raise InputValueError(
                f"rig covariance: names must be in the constants' order ({', '.join(SCALARS)})"
            )
        k = len(self.names)
        rows = [tuple(float(v) for v in row) for row in self.matrix]
        if len(rows) != k or any(len(row) != k for row in rows):
            raise InputValueError(
                f"rig covariance: matrix must be {k} x {k} (one row and column per name)"
            )
        object.__setattr__(self, "matrix", tuple(rows))
        m = self.array()
        if not np.isfinite(m).all():
            raise InputValueError("rig covariance: every entry must be a finite number")
        scale = float(np.abs(m).max()) if k else 0.0
        # The file's 6 significant digits: symmetric and positive semi-definite to rounding.
        if not np.allclose(m, m.T, rtol=1e-5, atol=1e-9 * scale):
            raise InputValueError("rig covariance: matrix must be symmetric")
        if k and float(np.linalg.eigvalsh(0.5 * (m + m.T))[0]) < -1e-5 * scale:
            raise InputValueError(
                "rig covariance: matrix is not a covariance (a negative variance along some "
                "direction); write the file again with `twopose-analyze rig`"
            )

    @classmethod
    def of(
        cls, names: Iterable[str], matrix: ArrayLike, *, independent: bool = False
    ) -> RigCovariance:
        """From a (k, k) array (symmetrised)."""
        m = np.asarray(matrix, dtype=np.float64)
        m = 0.5 * (m + m.T)
        rows = tuple(tuple(float(v) for v in row) for row in m)
        return cls(names=tuple(names), matrix=rows, independent=independent)

    def array(self) -> F64:
        """The matrix (k, k)."""
        return np.array(self.matrix, dtype=np.float64).reshape(len(self.names), len(self.names))

    def sigma(self) -> dict[str, float]:
        """Each scalar's 1-sigma."""
        diag = np.sqrt(np.clip(np.diag(self.array()), 0.0, None))
        return dict(zip(self.names, (float(v) for v in diag), strict=True))
