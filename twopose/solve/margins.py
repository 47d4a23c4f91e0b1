"""The estimation's options, in one record.

How frames are combined, when a trial is degenerate and when an ok trial's degeneracy
margin warns (degrees). One record, :class:`EstimateOptions`, declared apart from the
solvers so that the command line takes its defaults from it without importing NumPy
(:mod:`twopose.solve.estimate` and :mod:`twopose.solve.nview` read it from here).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from twopose.uncertainty.noise import NoiseModel
from twopose.values.choices import CombineRule

__all__ = [
    "DEFAULT_MIN_CONDITIONING",
    "DEFAULT_MIN_GROUND_ANGLE_DEG",
    "DEFAULT_MIN_PARALLAX_DEG",
    "DEFAULT_MIN_PLANE_ANGLE_DEG",
    "EstimateOptions",
]

DEFAULT_MIN_CONDITIONING = 1e-6  # below it a solver's system is singular: the trial fails
DEFAULT_MIN_PARALLAX_DEG = 1.0  # ray parallax, points
DEFAULT_MIN_PLANE_ANGLE_DEG = 5.0  # between back-projected planes, lines and method 2
DEFAULT_MIN_GROUND_ANGLE_DEG = 10.0  # between the line and the ground, method 2


@dataclass(frozen=True, kw_only=True)
class EstimateOptions:
    """How frames are combined, when a trial is degenerate and when a margin warns.

    The one record of these settings: the analysis' ``AnalysisOptions.estimate``, the
    recorder's live result and ``twopose-analyze run``'s defaults read it.
    """

    combine: CombineRule = "mean"
    min_conditioning: float = DEFAULT_MIN_CONDITIONING
    min_parallax_deg: float = DEFAULT_MIN_PARALLAX_DEG
    min_plane_angle_deg: float = DEFAULT_MIN_PLANE_ANGLE_DEG
    min_ground_angle_deg: float = DEFAULT_MIN_GROUND_ANGLE_DEG
    #: The noise every region assumes: the placing sigma (typed or measured) and the
    #: variance factor's test (:mod:`twopose.uncertainty.noise`).
    noise: NoiseModel = field(default_factory=NoiseModel)
