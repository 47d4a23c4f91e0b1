"""Detection: from images to measurements.

The targets' detection (``detection``: the glove by the thesis' filters, the dot), the
checkerboard found in an image (``checkerboard``), the clutter a target must not be seen
over (``clutter``) and a pose's frames combined into one measurement (``frames``). Arrays
in, frozen records out, no I/O.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.detect.checkerboard import (
        LIVE_BOARD_BUDGET_S,
        board_pattern,
        find_board,
        find_board_live,
        outlier_view,
    )
    from twopose.detect.clutter import Clutter, over_clutter, scene_clutter, seen_clutter
    from twopose.detect.detection import detect
    from twopose.detect.detectors import (
        Detection,
        Image,
        RejectedBlob,
        detect_dot,
        detect_glove,
        detection_json,
        wrap_theta_deg,
    )
    from twopose.detect.frames import PoseMeasurement, combine_frames
    from twopose.detect.thresholds import DotParams, GloveParams

__all__ = [
    "LIVE_BOARD_BUDGET_S",
    "Clutter",
    "Detection",
    "DotParams",
    "GloveParams",
    "Image",
    "PoseMeasurement",
    "RejectedBlob",
    "board_pattern",
    "combine_frames",
    "detect",
    "detect_dot",
    "detect_glove",
    "detection_json",
    "find_board",
    "find_board_live",
    "outlier_view",
    "over_clutter",
    "scene_clutter",
    "seen_clutter",
    "wrap_theta_deg",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "LIVE_BOARD_BUDGET_S": "twopose.detect.checkerboard",
    "Clutter": "twopose.detect.clutter",
    "Detection": "twopose.detect.detectors",
    "DotParams": "twopose.detect.thresholds",
    "GloveParams": "twopose.detect.thresholds",
    "Image": "twopose.detect.detectors",
    "PoseMeasurement": "twopose.detect.frames",
    "RejectedBlob": "twopose.detect.detectors",
    "board_pattern": "twopose.detect.checkerboard",
    "combine_frames": "twopose.detect.frames",
    "detect": "twopose.detect.detection",
    "detect_dot": "twopose.detect.detectors",
    "detect_glove": "twopose.detect.detectors",
    "detection_json": "twopose.detect.detectors",
    "find_board": "twopose.detect.checkerboard",
    "find_board_live": "twopose.detect.checkerboard",
    "outlier_view": "twopose.detect.checkerboard",
    "over_clutter": "twopose.detect.clutter",
    "scene_clutter": "twopose.detect.clutter",
    "seen_clutter": "twopose.detect.clutter",
    "wrap_theta_deg": "twopose.detect.detectors",
}

__getattr__, __dir__ = lazy_exports("twopose.detect", _HOMES, __all__)
