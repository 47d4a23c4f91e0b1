"""The sets of names a user picks from, declared once, and the targets' registry.

For the library and both command lines.

A closed set is a :data:`~typing.Literal`: the library's option records are typed with it,
and typer turns it into the command lines' choices (``--combine <mean|median|robust>``),
so a new choice is added here and nowhere else. The targets a detector finds are open: a
:class:`TargetSpec` holds its detector (a callable) and its thresholds' type, and an
extension adds one with :func:`register_target`. This module imports nothing heavy, so that
the command lines can read it at start-up: twopose's own detectors are loaded on first use
(:mod:`twopose.detect.detectors`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Generic, Literal, TypeVar

from twopose.detect.thresholds import DotParams, GloveParams
from twopose.registry import Listing, Name, Registry

if TYPE_CHECKING:
    from twopose.detect.detectors import Detection, Image

__all__ = [
    "TARGETS",
    "TARGET_SPECS",
    "CombineRule",
    "Target",
    "TargetSpec",
    "register_target",
]

#: How a pose's frames are combined into one measurement
#: (:func:`twopose.detect.frames.combine_frames`;
#: the thesis averages, section 5.3).
CombineRule = Literal["mean", "median", "robust"]

#: A detector's thresholds' type (:class:`twopose.detect.thresholds.GloveParams`, ...).
P = TypeVar("P")


class Target(Name):
    """What the detector looks for in a frame: the glove, the dot, or a registered target.

    A name of :data:`TARGET_SPECS` (the glove is method 2's and the line's, the dot method
    1's); ``target.spec`` is its entry.
    """

    __slots__ = ()
    GLOVE: ClassVar[Target]
    DOT: ClassVar[Target]

    @property
    def spec(self) -> TargetSpec[Any]:
        """Its entry in the registry."""
        return TARGET_SPECS[self]


@dataclass(frozen=True, kw_only=True)
class TargetSpec(Generic[P]):
    """What one target is, for every stage that depends on it.

    Its detector and its thresholds' type: the type checker checks that the detector takes
    them.
    """

    #: The target this entry describes (its key in :data:`TARGET_SPECS`).
    target: Target
    #: Finds it in one frame: ``(image (H, W, 3) BGR uint8, thresholds) -> Detection``
    #: (:func:`twopose.detect.detection.detect` calls it; no I/O).
    detector: Callable[[Image, P], Detection]
    #: Its detector's thresholds' type; built with no arguments, the defaults (the thesis').
    params: type[P]
    #: Whether a view's measurement is an image line (the finger's axis through its tip),
    #: not a point (the dot's centroid).
    image_line: bool

    def thresholds(self, given: Iterable[object] = ()) -> P:
        """Its detector's thresholds: the first of ``given`` of its type, else the defaults.

        A run's options give one record per target (``AnalysisOptions.thresholds``).
        """
        for one in given:
            if isinstance(one, self.params):
                return one
        return self.params()

    def detect(self, image_bgr: Image, params: P | None = None) -> Detection:
        """Its detection in one frame, with ``params`` (default: the defaults)."""
        return self.detector(image_bgr, self.params() if params is None else params)


def _glove(image_bgr: Image, params: GloveParams) -> Detection:
    """The thesis' glove filter (:func:`twopose.detect.detectors.detect_glove`)."""
    from twopose.detect.detectors import detect_glove  # on use: the registry loads no OpenCV

    return detect_glove(image_bgr, params)


def _dot(image_bgr: Image, params: DotParams) -> Detection:
    """The dark dot's black-hat (:func:`twopose.detect.detectors.detect_dot`)."""
    from twopose.detect.detectors import detect_dot  # on use: the registry loads no OpenCV

    return detect_dot(image_bgr, params)


Target.GLOVE, Target.DOT = Target.declare("glove"), Target.declare("dot")
_GLOVE: TargetSpec[GloveParams] = TargetSpec(
    target=Target.GLOVE, detector=_glove, params=GloveParams, image_line=True
)
_DOT: TargetSpec[DotParams] = TargetSpec(
    target=Target.DOT, detector=_dot, params=DotParams, image_line=False
)

#: The target registry: each target's :class:`TargetSpec`, the glove first. Every rule that
#: depends on the target reads it here; :func:`register_target` adds one.
TARGET_SPECS: Registry[Target, TargetSpec[Any]] = Registry(
    "target", lambda spec: spec.target, (_GLOVE, _DOT)
)
Target.registry = TARGET_SPECS
#: The targets' names, in registration order.
TARGETS: Listing[Target] = Listing(lambda: tuple(TARGET_SPECS), TARGET_SPECS)


def register_target(spec: TargetSpec[P]) -> TargetSpec[P]:
    """Add a target to the registry (its name from :meth:`Target.declare`), and return it.

    A method whose :attr:`~twopose.methods.specs.MethodSpec.target` it is then detects it in every
    frame, live and in the analysis; a run's options may give its thresholds
    (``AnalysisOptions(thresholds=(...,))``). A name already registered is refused
    (:class:`ValueError`).
    """
    return TARGET_SPECS.register(spec)
