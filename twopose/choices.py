"""The closed sets of names a user picks from, declared once.

For the library and both command lines.

Each is a :data:`~typing.Literal`: the library's option records are typed with it, and
typer turns it into the command lines' choices (``--combine <mean|median|robust>``), so a
new choice is added here and nowhere else. This module imports nothing heavy, so that the
command lines can read it at start-up.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Literal

__all__ = ["TARGETS", "TARGET_SPECS", "CombineRule", "Target", "TargetSpec"]

#: How a pose's frames are combined into one measurement (:func:`twopose.frames.combine_frames`;
#: the thesis averages, section 5.3).
CombineRule = Literal["mean", "median", "robust"]
#: What the detector looks for in a frame: the gloved finger (method 2, the line) or the dot.
Target = Literal["glove", "dot"]


@dataclass(frozen=True, kw_only=True)
class TargetSpec:
    """What one target is, for every stage that depends on it.

    Its detector is named, not held, so that this module imports no OpenCV.
    """

    #: The target this entry describes (its key in :data:`TARGET_SPECS`).
    target: Target
    #: The function of :mod:`twopose.detect` that finds it (:func:`twopose.detect.detect`
    #: calls it) and the class of that function's thresholds there.
    detector: str
    #: The class of its detector's thresholds in :mod:`twopose.detect`.
    params: str
    #: The field of the analysis' options (``analysis.results.AnalysisOptions``) holding
    #: its detector's thresholds.
    options_field: str
    #: Whether a view's measurement is an image line (the finger's axis through its tip),
    #: not a point (the dot's centroid).
    image_line: bool


#: The target registry: each target's :class:`TargetSpec`. Every rule that depends on the
#: target reads it here.
TARGET_SPECS: Mapping[Target, TargetSpec] = MappingProxyType(
    {
        "glove": TargetSpec(
            target="glove",
            detector="detect_glove",
            params="GloveParams",
            options_field="glove",
            image_line=True,
        ),
        "dot": TargetSpec(
            target="dot",
            detector="detect_dot",
            params="DotParams",
            options_field="dot",
            image_line=False,
        ),
    }
)
#: The targets' names, in :data:`Target`'s order.
TARGETS: tuple[Target, ...] = tuple(TARGET_SPECS)
