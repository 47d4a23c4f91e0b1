"""The reconstruction methods as a type, with one registry of what each one is.

Every rule that depends on the method reads it here: which target the detector looks for,
what ground truth a trial carries, whether a constraint plane is needed, whether the estimate
is a line, which degeneracy margins and extra table columns apply, and how the thesis names
it. Adding a method is adding a :class:`MethodSpec`; nothing else compares method names.

``Method`` is a :class:`~enum.StrEnum`: its members equal their names (``Method.POINT ==
"point"``), print as them and serialise as them, so session files, tables and JSON are the
same as when the method was a plain string.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, ClassVar, Literal, TypeVar

from twopose.errors import InputValueError
from twopose.methods.geometry import (
    GeometryCases,
    MethodGeometry,
    PlanesToLine,
    PlanesToPlanePoint,
    RaysToPoint,
)
from twopose.methods.planes import CONSTRAINT_PLANES, GROUND_PLANE, ConstraintPlane, register_plane
from twopose.registry import Listing, Name, Registry, load_extensions
from twopose.values.checks import Vec3
from twopose.values.choices import TARGET_SPECS, Target, TargetSpec, register_target

if TYPE_CHECKING:
    from twopose.solve.entries import SolverEntry

__all__ = [
    "FLOOR_MEASURED_SIZES",
    "LINE_TRUTH",
    "MEASURING_METHODS",
    "METHODS",
    "METHOD_SPECS",
    "PLANES",
    "POINT_TRUTH",
    "TRUTH_POINTS",
    "Method",
    "MethodPage",
    "MethodSpec",
    "Solver",
    "TruthKind",
    "floor_unmeasured",
    "floors_unmeasured",
    "label_of",
    "register_method",
    "spec_of",
]

T = TypeVar("T")

#: The ground truth a trial carries: one point, or a line's two points.
TruthKind = Literal["point", "line"]
#: A trial's truth is one point (the point and ground methods).
POINT_TRUTH: TruthKind = "point"
#: A trial's truth is a line's two points (the line method).
LINE_TRUTH: TruthKind = "line"
#: How many grid points each kind of truth has.
TRUTH_POINTS: Mapping[str, int] = MappingProxyType({POINT_TRUTH: 1, LINE_TRUTH: 2})


class Method(Name):
    """What a session reconstructs: the thesis' method 1, the line, method 2, or another.

    A name of :data:`METHOD_SPECS` (docs/method.md), the board's or a registered method's.
    ``Method("ground")`` is the registered method of that name (a :class:`ValueError`
    naming the registered ones otherwise); ``method.spec`` is its entry.
    """

    __slots__ = ()
    #: Method 1: a fixed dot, two rays (thesis eq. for [p1, -R p2] a = d).
    POINT: ClassVar[Method]
    #: A fixed line: each image line back-projects to a plane.
    LINE: ClassVar[Method]
    #: Method 2: the glove's planes meet the ground plane y = h.
    GROUND: ClassVar[Method]
    #: No reconstruction: a checkerboard's corners calibrate the rig (issue 24).
    BOARD: ClassVar[Method]

    @property
    def spec(self) -> MethodSpec:
        """Its entry in the registry."""
        return METHOD_SPECS[self]


Method.POINT, Method.LINE = Method.declare("point"), Method.declare("line")
Method.GROUND, Method.BOARD = Method.declare("ground"), Method.declare("board")


@dataclass(frozen=True, kw_only=True)
class Solver:
    """How a method's measurements become its estimate.

    One entry (:class:`twopose.solve.entries.SolverEntry`), read by the estimation
    (:func:`twopose.solve.estimate.solve_batch`), the propagation of its uncertainty, the
    misclosure (:mod:`twopose.uncertainty.misclosure`) and ``twopose-analyze solve``.
    """

    #: What it solves, in words (the docs' list of methods).
    words: str
    #: Its entry, returned on first use (a function, so that the registry loads no NumPy:
    #: ``lambda: MY_ENTRY`` for an extension's).
    load: Callable[[], SolverEntry]


@dataclass(frozen=True, kw_only=True)
class MethodPage:
    """What the operator's web console shows for a method (recorder/console*.js).

    Its panels, its table's heading and its words: the page reads them from the server's
    state (``page``) and never names a method; the defaults are a measuring method's.
    """

    #: Whether the page shows the rig's readiness in place of the trials' results (a board
    #: session calibrates the rig; it has no trial result).
    reports_rig: bool = False
    #: What each capture looks for, as the decision's shortfall names it.
    sought: str = "the target"
    #: The camera panel's aside: what the live image has drawn on it.
    camera_aside: str = "detection drawn: green found, red turned down"
    #: The frames table's second column heading (each frame's objects, or its board).
    objects_header: str = "obj."
    #: Whether the frames table shows the detection's columns (centroid, orientation, area,
    #: eccentricity, image line) after the objects' column.
    detection_columns: bool = True
    #: What the guidance says while the recorder works out the next step after a decision.
    computing: str = "computing the next pose to suggest..."
    #: The top view's title once it draws a trial (``{trial}``: the trial's number).
    topview_title: str = "trial {trial}, from above"
    #: The top view's two lines before there is anything to draw.
    topview_empty: tuple[str, str] = ("a trial, from above,", "once it has two poses")
    #: The top view's legend entry of the camera centres.
    legend_cameras: str = "camera centre (each pose)"
    #: The legend entry of the suggested next pose ("": the page shows none in the legend).
    legend_next: str = "suggested next pose (g takes it)"
    #: The legend entries of what each view measured: ``(kind, mark, words)``, ``kind`` a
    #: segment kind of :class:`twopose.methods.topview.TopView`, listed when the view has one.
    legend_segments: tuple[tuple[str, str, str], ...] = ()
    #: The legend entry of the estimate (what the cross marks).
    estimate_label: str = "estimate"
    #: The legend entry of the truth (what the circle marks).
    truth_label: str = "true point"

    def to_json(self) -> dict[str, object]:
        """The description as the page's state carries it (``page``)."""
        return asdict(self)


@dataclass(frozen=True, kw_only=True)
class MethodSpec:
    """What one method is, for every stage that depends on it."""

    #: The method this entry describes (its key in :data:`METHOD_SPECS`).
    method: Method
    #: What the detector looks for in each frame (:mod:`twopose.detect.detection`): the dark dot's
    #: or
    #: the glove's entry, or a registered target's; None for a board session, whose
    #: corners the rig calibration finds (twopose.rig.board).
    target: TargetSpec[Any] | None
    #: The ground truth a trial carries: one point, or a line's two points; None for a board
    #: session, whose truth is the board's placement (the session entry's ``board``).
    truth_kind: TruthKind | None
    #: The plane its estimate lies on (:class:`twopose.methods.planes.ConstraintPlane`: method 2's
    #: ground y = h), whose offset the setup asks; None: the estimate is not constrained.
    plane: ConstraintPlane | None
    #: How its measurements are solved (None: a board session reconstructs nothing).
    solver: Solver | None
    #: What its views' measurements meet in (:mod:`twopose.methods.geometry`): every caller that
    #: draws, places or sweeps a trial asks it (:meth:`geometry_cases`); None for a board.
    geometry: MethodGeometry | None
    #: Degeneracy margins (trials.csv columns, degrees) that apply to the method.
    margins: tuple[str, ...]
    #: The method's own trials.csv columns beside the common ones (analysis/tables/columns.py).
    extra_columns: tuple[str, ...]
    #: How the thesis names it, and how tables and verdicts label it.
    thesis_name: str
    #: Its label in tables, figures and the console ("point (method 1)", "line").
    label: str
    #: The estimators a measurement of it can be solved by (``thesis`` first): the
    #: thesis' formulas, the reprojection-optimal fit, the weighted plane fit.
    estimators: tuple[str, ...] = ("thesis",)
    #: Its colour in every figure over a run (matplotlib's cycle; the sensitivity figure's).
    colour: str = "C4"
    #: Whether the thesis tested it (its verdict lines set a run against the thesis).
    thesis_tested: bool = False
    #: The detector's systematic error per view in the thesis' one camera, (centroid px,
    #: orientation degrees): what stays when its frames are averaged (the blob's centroid
    #: and axis against the target's projection, the same in every frame of a pose), so the
    #: frame scatter cannot see it. Measured on rendered views by
    #: benchmarks/bench_detector_floor.py: a bound, the largest RMS over the geometries
    #: rounded up to the next 0.05 (the glove's one-camera RMS is about half of it; the
    #: one-camera figures were measured with it). Added to each view's pixel covariance.
    detector_floor: tuple[float, float] = (0.0, 0.0)
    #: The same error's 1-sigma in a camera of a pair at the sizes in
    #: :data:`FLOOR_MEASURED_SIZES` (None: :attr:`detector_floor`), added to each pair
    #: camera's noise per frame (:func:`twopose.pair.frame_noise.camera_noise`): the RMS over
    #: both cameras of the simulator's pair (a user's pair is neither), rounded up to the
    #: next 0.01, where the stream's regions measured carry nothing else
    #: (docs/figures/detector_floor.txt, stream_rendered.txt).
    pair_floor: tuple[float, float] | None = None
    #: What a top view draws for one view, how it names the truth, and its caption.
    view_segment: str = "segment"
    #: How a top view names the truth in its legend.
    truth_name: str = "truth"
    #: The top view's caption: what it draws for each view.
    top_view: str = "each view"
    #: What the operator's web console shows for it (:class:`MethodPage`).
    page: MethodPage = MethodPage()

    def __post_init__(self) -> None:
        """Check that its geometry and plane go together (an extension's entry)."""
        takes_plane = self.geometry is not None and self.geometry.takes_plane
        if takes_plane != (self.plane is not None):
            need = "needs a plane" if takes_plane else "takes no plane"
            raise ValueError(f"method {self.method!r}: its geometry {need}")

    def geometry_cases(self, cases: GeometryCases[T]) -> T:
        """``cases``' case of the method's geometry (a board has none: ValueError)."""
        if self.geometry is None:
            raise ValueError(f"{self.method} sessions reconstruct nothing (the rig's calibration)")
        return self.geometry.cases(cases, self.plane)

    @property
    def floor_in_pair(self) -> tuple[float, float]:
        """The detector's floor per frame in a camera of a pair (:attr:`pair_floor`)."""
        return self.detector_floor if self.pair_floor is None else self.pair_floor

    @property
    def in_plane(self) -> tuple[Vec3, Vec3]:
        """The two axes its results are read in: its plane's, else the ground's (x, z)."""
        return (self.plane or GROUND_PLANE).in_plane_grid

    @property
    def measures(self) -> bool:
        """Whether the session reconstructs something (a board session calibrates the rig)."""
        return self.target is not None

    @property
    def needs_plane(self) -> bool:
        """Whether the estimate needs its plane (:attr:`plane`) and the setup its offset."""
        return self.plane is not None

    @property
    def needs_ground(self) -> bool:
        """:attr:`needs_plane`'s old name, kept for one release (docs/changelog.md).

        Any plane, not only the ground.
        """
        return self.needs_plane

    @property
    def seen_on(self) -> ConstraintPlane:
        """The plane its trials are drawn and their errors read on, face on.

        Its own (:attr:`plane`), else the ground (the grid paper seen from above, x and z).
        """
        return self.plane if self.plane is not None else GROUND_PLANE

    @property
    def truth_points(self) -> int:
        """How many ground-truth points a trial has (a line's two ends; none on a board)."""
        return TRUTH_POINTS.get(self.truth_kind, 0) if self.truth_kind else 0

    @property
    def estimates_line(self) -> bool:
        """Whether the estimate is a 3-D line (a point on it and a direction)."""
        return self.truth_kind == LINE_TRUTH

    @property
    def uses_image_lines(self) -> bool:
        """Whether each view's measurement is an image line, as its target's entry says."""
        return self.target is not None and self.target.image_line


def _rays() -> SolverEntry:
    from twopose.solve.entries import RAYS  # on use: the registry loads no NumPy

    return RAYS


def _planes() -> SolverEntry:
    from twopose.solve.entries import PLANES  # on use: the registry loads no NumPy

    return PLANES


def _planes_and_plane() -> SolverEntry:
    from twopose.solve.entries import PLANES_AND_PLANE  # on use: the registry loads no NumPy

    return PLANES_AND_PLANE


#: The glove's one-camera floor (centroid across its line px, orientation degrees), the
#: line's and the ground's: its largest systematic RMS over the measured geometries (0.13
#: px across and 0.12 degrees in the pair's cameras, 0.08 px and 0.07 degrees in the
#: thesis' one) rounded up to the next 0.05 (docs/figures/detector_floor.txt): a bound.
GLOVE_FLOOR = (0.15, 0.15)
#: The glove's 1-sigma in a camera of a pair: its systematic RMS over both cameras (0.115
#: px across, 0.103 degrees: docs/figures/detector_floor.txt) rounded up to the next 0.01.
#: The ground's point rests on the image line's direction almost alone, and its stream
#: regions with it cover 95% (docs/figures/stream_rendered.txt). The line's point rests on
#: the centroid across the line and the direction together, whose errors are one mode
#: (correlated -0.85 to -0.90 per camera: the axis turning about a point off its
#: centroid), which two independent 1-sigmas do not carry: with them its regions cover
#: 88%, so the line keeps :data:`GLOVE_FLOOR` in the pair (96%) until the
#: correlation is carried.
GLOVE_PAIR_FLOOR = (0.12, 0.11)
#: The image sizes (width, height) the floors hold at, measured: bench_detector_floor.py
#: measures 320x240 too, where the glove's direction errs 0.14 degrees RMS (the finger's
#: image half as long) and the dot's stream regions cover 85% (stream_rendered.txt), so
#: neither floor holds there, and a stream's noise says so (:func:`floor_unmeasured`).
FLOOR_MEASURED_SIZES = ((640, 480),)


def floor_unmeasured(width: int, height: int) -> str:
    """Words for a camera whose image size the floors do not hold at ("" where they do)."""
    if (width, height) in FLOOR_MEASURED_SIZES:
        return ""
    sizes = " and ".join(f"{w}x{h}" for w, h in FLOOR_MEASURED_SIZES)
    return (
        f"the detector's floor holds at {sizes} only, not at this camera's {width}x{height}: "
        "its error in pixels there is not the floor's and the regions may be too small; "
        "measure it (benchmarks/bench_detector_floor.py --size) or give the noise"
    )


def floors_unmeasured(sizes: Iterable[tuple[int, int]]) -> str:
    """:func:`floor_unmeasured`'s words for each image size the floors do not hold at.

    ``sizes`` (width, height): each said once, in order ("" where the floors hold at all).
    """
    said = (floor_unmeasured(w, h) for w, h in dict.fromkeys(sizes))
    return "; ".join(w for w in said if w)


#: Method 1's solver: the rays through each view's dot (thesis eq. 3.9).
RAYS_SOLVER = Solver(words="the rays through each view's dot (thesis eq. 3.9)", load=_rays)
#: The fixed line's: the planes of each view's image line and their line (eq. 3.17).
PLANES_SOLVER = Solver(
    words="the planes of each view's image line, and their line (thesis eq. 3.17)", load=_planes
)
#: Method 2's: those planes' line cut by the method's plane (the ground y = h, eq. 19).
PLANES_AND_PLANE_SOLVER = Solver(
    words="the planes of each view's image line, their line cut by the method's plane "
    "(thesis eq. 19)",
    load=_planes_and_plane,
)

_BUILT_IN = (
    MethodSpec(
        method=Method.POINT,
        target=Target.DOT.spec,
        truth_kind="point",
        plane=None,
        solver=RAYS_SOLVER,
        geometry=RaysToPoint(),
        margins=("parallax_deg",),
        extra_columns=("x_optimal", "y_optimal", "z_optimal", "err_optimal"),
        thesis_name="method 1",
        label="point (method 1)",
        thesis_tested=True,
        estimators=("thesis", "optimal"),
        detector_floor=(0.05, 0.0),
        colour="C1",
        page=MethodPage(
            legend_segments=(("ray", "\u2014", "ray through the dot, per pose"),),
        ),
        view_segment="ray through the dot, per view",
        top_view="each view's ray through the dot, from its typed camera centre: the rays "
        "meet at the estimate",
    ),
    MethodSpec(
        method=Method.LINE,
        target=Target.GLOVE.spec,
        truth_kind="line",
        plane=None,
        solver=PLANES_SOLVER,
        geometry=PlanesToLine(),
        margins=("parallax_deg", "plane_angle_deg"),
        extra_columns=("dir_x", "dir_y", "dir_z", "angle_err_deg", "dist_err"),
        thesis_name="fixed line",
        label="line",
        estimators=("thesis", "weighted", "optimal"),
        detector_floor=GLOVE_FLOOR,
        colour="C2",
        page=MethodPage(
            legend_segments=(
                ("estimated_line", "\u2501", "estimated line"),
                ("truth_line", "\u254c", "true line"),
            ),
            estimate_label="line's point (estimate)",
            truth_label="true line, seen end-on",
        ),
        view_segment="estimated line",
        truth_name="truth (true segment's midpoint)",
        top_view="the estimated line through its reported point; the circle is the true "
        "segment's midpoint",
    ),
    MethodSpec(
        method=Method.GROUND,
        target=Target.GLOVE.spec,
        truth_kind="point",
        plane=GROUND_PLANE,
        solver=PLANES_AND_PLANE_SOLVER,
        geometry=PlanesToPlanePoint(),
        margins=("parallax_deg", "plane_angle_deg", "line_plane_angle_deg"),
        extra_columns=(),
        thesis_name="method 2",
        label="ground (method 2)",
        thesis_tested=True,
        detector_floor=GLOVE_FLOOR,
        pair_floor=GLOVE_PAIR_FLOOR,
        colour="C0",
        page=MethodPage(
            legend_segments=(("trace", "\u2014", "finger's plane on the ground, per pose"),),
            estimate_label="ground point (estimate)",
            truth_label="true ground point",
        ),
        view_segment="view plane's trace on the ground",
        top_view="each view's plane (the finger's image line back-projected) cut by the "
        "ground: the traces meet at the estimate, the ground point the finger points at "
        "(not the finger)",
    ),
    MethodSpec(
        method=Method.BOARD,
        target=None,
        truth_kind=None,
        plane=None,
        solver=None,
        geometry=None,
        margins=(),
        extra_columns=(),
        thesis_name="board (rig calibration)",
        label="board (rig calibration)",
        page=MethodPage(
            reports_rig=True,
            sought="the board",
            camera_aside="each frame's board corners are looked for (nothing drawn)",
            objects_header="the board",
            detection_columns=False,
            computing="working out what the poses say of the rig...",
            topview_title="the board session, from above",
            topview_empty=("the board and the poses", "once a capture has seen it"),
            legend_cameras="camera centre (each capture that saw the board)",
            legend_next="",
            legend_segments=(("corners", "\u2501", "the board (its inner corners, from above)"),),
        ),
    ),
)

#: The method registry: each method's :class:`MethodSpec`, in the order the thesis presents
#: them, then the board, then those registered (:func:`register_method`). Every rule that
#: depends on the method reads it here.
METHOD_SPECS: Registry[Method, MethodSpec] = Registry("method", lambda s: s.method, _BUILT_IN)
Method.registry = METHOD_SPECS
#: The methods' names, in the order the thesis presents them, then the board (then the
#: registered ones).
METHODS: Listing[Method] = Listing(lambda: tuple(METHOD_SPECS), METHOD_SPECS)
#: The planes a method may constrain its estimate to (method 2's ground, and those
#: registered), each once: the setup asks each one's offset (recorder.setup.form's plane
#: fields) for the methods on it.
PLANES: Listing[ConstraintPlane] = Listing(
    lambda: tuple(CONSTRAINT_PLANES.values()), CONSTRAINT_PLANES
)
#: The methods that reconstruct something (every one but the board).
MEASURING_METHODS: Listing[Method] = Listing(
    lambda: tuple(m for m, s in METHOD_SPECS.items() if s.measures), METHOD_SPECS
)


def register_method(spec: MethodSpec) -> Method:
    """Add a method to the registry (its name from :meth:`Method.declare`) and return it.

    Its plane and its target, if not yet registered, are registered too
    (:func:`twopose.methods.planes.register_plane`, :func:`twopose.values.choices.register_target`).
    Every command and stage then knows it: ``simulate --method``, ``new``, ``run``,
    ``solve`` and the page read the registry, as the estimation reads its solver and the
    figures its geometry. A name already registered is refused (:class:`ValueError`), as
    is a target whose name another target holds.
    """
    if spec.method in METHOD_SPECS:
        raise ValueError(f"a method named {str(spec.method)!r} is already registered")
    target = spec.target
    if target is not None and TARGET_SPECS.get(target.target, target) is not target:
        raise ValueError(f"another target is registered as {str(target.target)!r}")
    if spec.plane is not None:
        register_plane(spec.plane)
    if target is not None and target.target not in TARGET_SPECS:
        register_target(target)
    return METHOD_SPECS.register(spec).method


def label_of(method: object) -> str:
    """How tables and verdicts name ``method``: its :attr:`MethodSpec.label`.

    A name the registry does not know is shown as it is.
    """
    try:
        return spec_of(str(method)).label
    except InputValueError:
        return str(method)


def spec_of(method: str) -> MethodSpec:
    """The spec of ``method``: a :class:`Method` (``method.spec``), or its name.

    A name as a file or a table gives it.

    An unknown name raises :class:`~twopose.errors.InputValueError` listing the known ones.
    """
    try:
        return Method(method).spec
    except ValueError:
        raise InputValueError(
            f"method must be one of {', '.join(METHODS)}, got {method!r}"
        ) from None


# Last, with every registry made: an installed extension's module registers its methods,
# targets, sources and planes (the entry-point group twopose.extensions), so that every
# process that knows the methods (a command line, a spawned worker) knows them too.
load_extensions()
