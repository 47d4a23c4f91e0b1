"""What Foxglove and the pages show, drawn from the core's results.

A trial as Foxglove shows it, its detections on their images and its 3-D scene, in one
palette (``scene``), and the fonts the pages carry (``fonts``: the subsets shipped in
``twopose/fonts/``), so that the live view, the results file, the console and the report
agree.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.display.scene import (
        TrialScene,
        image_annotations,
        scene_of_views,
        static_scene,
        trial_scene,
    )

__all__ = [
    "TrialScene",
    "image_annotations",
    "scene_of_views",
    "static_scene",
    "trial_scene",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "TrialScene": "twopose.display.scene",
    "image_annotations": "twopose.display.scene",
    "scene_of_views": "twopose.display.scene",
    "static_scene": "twopose.display.scene",
    "trial_scene": "twopose.display.scene",
}

__getattr__, __dir__ = lazy_exports("twopose.display", _HOMES, __all__)
