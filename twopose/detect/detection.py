"""Detection: a target found in one frame by its registered detector.

:func:`detect` finds any target of the registry (:data:`twopose.values.choices.TARGET_SPECS`: the
gloved finger, the dot, or a registered one) by the detector its entry holds. The detectors
themselves (the thesis' glove filter, the dot's black-hat), their :class:`Detection` and
the orientation convention are :mod:`twopose.detect.detectors`'; their thresholds,
:mod:`twopose.detect.thresholds`'. Both are exported here too, as before.
"""

from __future__ import annotations

from typing import Any

from twopose.detect.detectors import (
    Detection,
    Image,
    RejectedBlob,
    blob_shape,
    detect_dot,
    detect_glove,
    detection_json,
    wrap_theta_deg,
)
from twopose.detect.thresholds import DotParams, GloveParams
from twopose.values.choices import Target, TargetSpec

__all__ = [
    "Detection",
    "DotParams",
    "GloveParams",
    "RejectedBlob",
    "blob_shape",
    "detect",
    "detect_dot",
    "detect_glove",
    "detection_json",
    "wrap_theta_deg",
]


def detect(image_bgr: Image, target: str | TargetSpec[Any], params: object = None) -> Detection:
    """Detect ``target`` in one frame: the gloved finger, the dark dot, or a registered one.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8 array
        The frame, OpenCV's BGR order.
    target : TargetSpec or str
        What to look for: its entry (a method's :attr:`~twopose.methods.specs.MethodSpec.target`)
        or its name (``"glove"``, ``"dot"``, a registered one's).
    params : optional
        The detector's thresholds (:class:`GloveParams`, :class:`DotParams`, ...); not of
        the target's type, or none: its defaults (the thesis').

    Returns
    -------
    Detection
        Found or not (with the reason), the centroid and orientation, area, eccentricity.

    Raises
    ------
    ValueError
        ``target`` names no registered target (the message lists them).
    """
    spec = target if isinstance(target, TargetSpec) else Target(target).spec
    return spec.detect(image_bgr, params if isinstance(params, spec.params) else None)
