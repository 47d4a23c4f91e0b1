"""The detectors' thresholds: one frozen record per target's detector.

Each is its target's parameter type in the registry
(:attr:`twopose.values.choices.TargetSpec.params`), so that a run's options hold them
(``analysis.AnalysisOptions``) and the type checker sees which detector takes which. Plain
values: this module imports nothing heavy (the registry reads it at start-up).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DotParams", "GloveParams"]


@dataclass(frozen=True, kw_only=True)
class GloveParams:
    """Thresholds of the thesis' glove filter (docs/method.md: the code's inequalities).

    A pixel is glove-coloured when its normalized RGB ``(R, G, B) / |RGB|`` has
    ``Rn <= r_max``, ``Gn >= g_min`` and ``Bn >= b_min``; blobs must have area
    ``> min_area_px``, eccentricity in ``[ecc_min, ecc_max)`` and ``4 A / (major minor)``
    in ``[pi_min, pi_max]`` (the "pi filter"; full axis lengths, as MATLAB's).
    """

    r_max: float = 0.45
    g_min: float = 0.40
    b_min: float = 0.60
    min_area_px: float = 200.0
    ecc_min: float = 0.86
    ecc_max: float = 1.0
    pi_min: float = 2.90
    pi_max: float = 3.08
    use_otsu: bool = True


@dataclass(frozen=True, kw_only=True)
class DotParams:
    """The dark dot on a white card: black-hat contrast, size and roundness limits."""

    max_radius_px: int = 25
    min_area_px: float = 12.0
    max_eccentricity: float = 0.85
    min_contrast: float = 40.0  # grey levels darker than the local background
    # The dot is black: a dark blob whose colour (normalised r, g, b, weighted by its
    # contrast) strays further than this from grey is a coloured thing (a navy mark on the
    # grid paper was taken for the dot in 2 of 80 rendered views, every frame alike, so no
    # scatter could flag it). A black dot under a warm lamp stays within about 0.1.
    max_chroma: float = 0.15
