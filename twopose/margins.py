"""The degeneracy margins' defaults (degrees): under one of them an ok trial gets a warning.

Declared here, apart from the solvers, so that the command line offers them as its defaults
without importing NumPy (:mod:`twopose.estimate` reads them from here).
"""

from __future__ import annotations

__all__ = [
    "DEFAULT_MIN_GROUND_ANGLE_DEG",
    "DEFAULT_MIN_PARALLAX_DEG",
    "DEFAULT_MIN_PLANE_ANGLE_DEG",
]

DEFAULT_MIN_PARALLAX_DEG = 1.0  # ray parallax, points
DEFAULT_MIN_PLANE_ANGLE_DEG = 5.0  # between back-projected planes, lines and method 2
DEFAULT_MIN_GROUND_ANGLE_DEG = 10.0  # between the line and the ground, method 2
