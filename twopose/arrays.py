"""The array aliases every module annotates with.

One home, so that a change of dtype policy is one edit: shapes are documented where the arrays are,
in the docstrings.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["F32", "F64", "Bools", "Ints"]

#: Float arrays: coordinates, pixels, covariances (units in each name or docstring).
F64 = NDArray[np.float64]
#: Single-precision images and OpenCV's corner arrays.
F32 = NDArray[np.float32]
#: Boolean masks (valid views, found frames, used trials).
Bools = NDArray[np.bool_]
#: Integer index arrays.
Ints = NDArray[np.intp]
