"""Every quantity a person types, a plan gives or a command line passes, with its one bound.

One table (:data:`QUANTITIES`) holds each quantity's words, its kind (a length, an angle,
pixels, a count or a share) and its range; a length's range is stated in inches and converted with
:func:`twopose.values.units.unit_factor` (rounded to six significant digits, so the bound shown is
the bound applied). One function reads a value of a quantity from text or a number,
:meth:`Quantity.read` (three of them: :meth:`Quantity.read_vector`), and one message form
says why a value is refused::

    reach must be from 0.0393701 to 100 in, got 1000

The terminal, the browser's forms, a plan, the command line and the replay all read them
here, so they accept and refuse the same values with the same words (each path puts where
the value came from in front: ``plan: guidance.reach: ...``, ``--reach: ...``). Text goes
through the one number grammar (:data:`twopose.values.checks.NUMBER_GRAMMAR`: ASCII digits, a
sign, a decimal point, an exponent). ``python docs/bounds_table.py --write-docs`` writes the
table into the docs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from numbers import Integral, Real
from typing import Any

from twopose.errors import InputValueError
from twopose.values.checks import WHOLE_GRAMMAR, WHOLE_WORDS, Given, Unread, given_text, read_number
from twopose.values.units import UNITS, Units, unit_factor

__all__ = [
    "BOARD_CORNER",
    "BOARD_SQUARE",
    "CAMERAS",
    "CLOCK_OFFSET",
    "DEFAULT_MIN_GAIN",
    "DRIFT",
    "DROP",
    "FOCAL",
    "FPS",
    "FRAMES",
    "GRID",
    "GROUND_HEIGHT",
    "GROUND_TRUTH",
    "IMAGE_SIDE",
    "INNER_CORNERS",
    "JITTER",
    "JOBS",
    "MARGIN_ANGLE",
    "MAX_POSES",
    "MIN_GAIN",
    "PLANE_OFFSET",
    "PORT",
    "POSES",
    "POSE_NOISE",
    "POSE_TRANSLATION",
    "PRINCIPAL",
    "QUANTITIES",
    "REACH",
    "ROTATION",
    "SAMPLES",
    "SEED",
    "SESSION_TIMEOUT",
    "SIMULATED_FRAMES",
    "SIMULATED_TRIAL",
    "SPEED",
    "STREAM_DURATION",
    "TARGET_DISTANCE",
    "TARGET_PRECISION",
    "TOUCH_TIME",
    "TRIALS",
    "TYPED_RESOLUTION",
    "VIEWS",
    "Kind",
    "Quantity",
    "markdown_table",
    "shown",
]


class Kind(StrEnum):
    """What a quantity measures: its unit comes from the session (lengths) or is fixed."""

    LENGTH = "length"
    ANGLE = "angle"
    PIXELS = "px"
    COUNT = "count"
    SHARE = "share"
    SECONDS = "s"
    RATE = "fps"
    SPEED = "speed"  # a length per second, in the session's units
    MILLISECONDS = "ms"
    PPM = "ppm"


def shown(value: float) -> str:
    """How a value is shown back: as given, else as the text that reads back as it.

    The text it was given as (:class:`twopose.values.checks.Given`: ``525.000``, ``1e3``,
    ``2.50e-1`` as typed), else the text that reads back as the same float
    (``1234.56789``, ``525``, ``1e-05``); never ``:g``, which rounds to six digits.
    """
    text = given_text(value)
    if text is not None:
        return text
    if isinstance(value, int) and not isinstance(value, bool):
        return str(value)
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def _nice(value: float) -> float:
    """A converted bound to six significant digits: the bound applied is the bound shown."""
    return float(f"{value:.6g}")


@dataclass(frozen=True, kw_only=True)
class Quantity:
    """One quantity: its words, its kind, its range and where it is given.

    Attributes
    ----------
    key : str
        Its name in the table.
    words : str
        How messages name it ("reach", "camera centre").
    kind : Kind
        A length (in the session's units), an angle (degrees), pixels or a count.
    low, high : float
        Its range; a length's in inches.
    low_open : bool
        Whether ``low`` itself is refused (more than 0).
    axes : tuple of str
        The names of its components when it is a vector (``x``, ``y``, ``z``).
    given_as : str
        Where a person gives it (for the docs' table).
    """

    key: str
    words: str
    kind: Kind
    low: float
    high: float
    low_open: bool = False
    axes: tuple[str, ...] = ()
    given_as: str = ""

    # ------------------------------------------------------------------- its range

    def limits(self, units: Units) -> tuple[float, float]:
        """``(low, high)`` in ``units`` (the same for every unit but a length's)."""
        if self.kind not in (Kind.LENGTH, Kind.SPEED):
            return self.low, self.high
        factor = unit_factor(Units.IN, units)
        return _nice(self.low * factor), _nice(self.high * factor)

    def unit_label(self, units: Units) -> str:
        """The unit its values are in: the session's for a length, deg, px, or none."""
        if self.kind is Kind.LENGTH:
            return str(units)
        if self.kind is Kind.SPEED:
            return f"{units}/s"
        return {
            Kind.ANGLE: "deg", Kind.PIXELS: "px", Kind.SECONDS: "s", Kind.RATE: "fps",
            Kind.MILLISECONDS: "ms", Kind.PPM: "ppm",
        }.get(self.kind, "")  # fmt: skip

    def range_text(self, units: Units | None) -> str:
        """The range in words ("from -180 to 180 deg").

        A length's is given in every unit when the session's units are not known yet.
        """
        if units is None and self.kind in (Kind.LENGTH, Kind.SPEED):
            others = []
            for u in UNITS[1:]:
                lo, hi = self.limits(u)
                bare = self.low_open and lo == 0
                label = self.unit_label(u)
                others.append(f"{hi:g} {label}" if bare else f"{lo:g} to {hi:g} {label}")
            return f"{self.range_text(Units.IN)} ({', '.join(others)})"
        lo, hi = self.limits(units or Units.IN)
        unit = self.unit_label(units or Units.IN)
        tail = f" {unit}" if unit else ""
        if self.kind is Kind.COUNT:
            return f"a whole number from {int(lo)} to {int(hi)}"
        if self.low_open:
            return f"more than {lo:g} and at most {hi:g}{tail}"
        return f"from {lo:g} to {hi:g}{tail}"

    def refusal(self, value: float, units: Units | None, *, axis: str = "", given: str = "") -> str:
        """Why ``value`` is refused, in the one message form ("" when it is within range).

        With ``units`` None (a command line before the units are chosen) a length is
        refused only when no unit takes it.
        """
        ok = self._within(value, [units] if units is not None else list(UNITS))
        if ok:
            return ""
        name = f"{self.words} {axis}" if axis else self.words
        return f"{name} must be {self.range_text(units)}, got {given or shown(value)}"

    def _within(self, value: float, units: Sequence[Units]) -> bool:
        if not math.isfinite(value):
            return False
        if self.kind is Kind.COUNT and not float(value).is_integer():
            return False
        for u in units:
            lo, hi = self.limits(u)
            if (lo < value if self.low_open else lo <= value) and value <= hi:
                return True
        return False

    # ------------------------------------------------------------------- reading it

    def read(self, value: Any, units: Units | None, *, axis: str = "", text: bool = True) -> float:
        """``value`` (text as typed, or a number from a file) checked: the one reader.

        Text must follow the one number grammar (:func:`twopose.values.checks.read_number`; a
        count's: digits and a sign only); a number must be an int or a float (never a
        bool; a string only with ``text``: a plan's numbers are the file's numbers, never
        quoted), and a file's number comes with its source text
        (:func:`twopose.values.toml.read_toml`), judged so. Raises
        :class:`~twopose.errors.InputValueError` with the one message form.

        Returns
        -------
        float
            The value, with the text it was given as when it was given as text
            (:class:`twopose.values.checks.Given`, shown back so by :func:`shown`); a count's is
            a whole float (``int(...)`` it).
        """
        name = f"{self.words} {axis}" if axis else self.words
        whole = self.kind is Kind.COUNT
        given = given_text(value)
        if isinstance(value, Unread):  # a file's 0x5 or 1_0: refused as typed text is
            value.refuse(name, whole=whole)
        if isinstance(value, str) and text:
            number: float = read_number(value, name, whole=whole)
            given = value.strip()
        elif isinstance(value, bool) or not isinstance(value, Real):
            raise InputValueError(f"{name} must be a number, got {value!r}")
        elif whole and (
            not isinstance(value, Integral)
            or (given is not None and WHOLE_GRAMMAR.fullmatch(given) is None)
        ):  # a count is written whole: 5, never 5.0 or 5e0
            raise InputValueError(f"{name}: {given or repr(float(value))!r} is not a whole number "
                                  f"({WHOLE_WORDS})")  # fmt: skip
        else:
            try:
                number = float(value)
            except OverflowError:  # an integer beyond a float's range
                number, given = math.inf, f"{str(value)[:12]}..."
        why = self.refusal(number, units, axis=axis, given=given or "")
        if why:
            raise InputValueError(why)
        return number if given is None or isinstance(number, Given) else Given(number, given)

    def count(self, value: Any) -> int:
        """A count (frames, poses, corners) read as :meth:`read` reads it, as an int."""
        return int(self.read(value, None))

    def read_vector(
        self, value: Any, units: Units | None, *, text: bool = True
    ) -> tuple[float, ...]:
        """Its components (``axes``): text ``"x, y, z"`` (commas or spaces) or a list."""
        n = len(self.axes)
        names = ", ".join(self.axes)
        if isinstance(value, str) and text:
            parts: list[Any] = value.replace(",", " ").split()
            if len(parts) != n:
                raise InputValueError(
                    f"{self.words}: type {n} numbers {names} (got {value.strip()[:40]!r})"
                )
        elif isinstance(value, list | tuple):
            parts = list(value)
            if len(parts) != n:
                raise InputValueError(f"{self.words} must be {n} numbers {names}, got {value!r}")
        else:
            raise InputValueError(f"{self.words} must be {n} numbers {names}, got {value!r}")
        return tuple(
            self.read(p, units, axis=a, text=text) for p, a in zip(parts, self.axes, strict=True)
        )

    def vector_refusal(self, values: Sequence[float], units: Units) -> str:
        """Why a vector read from a file is refused ("": every component is within range).

        The replay sets such a pose or ground truth aside with this reason.
        """
        try:
            self.read_vector(list(values), units, text=False)
        except InputValueError as err:
            return str(err)
        return ""

    def parse_text(self, text: str, name: str = "") -> float:
        """Text as a number by the one grammar alone, its bound not checked.

        A count's grammar is digits and a sign. A command line parses an option so and
        checks the bound once ``--units`` are known.
        """
        return read_number(text, name or self.words, whole=self.kind is Kind.COUNT)


_MM = 1 / 25.4  # one millimetre in inches
_XYZ = ("x", "y", "z")

#: A typed position (a camera centre, a ground truth, a board corner): beyond, a typo.
POSE_TRANSLATION = Quantity(
    key="pose_translation", words="camera centre", kind=Kind.LENGTH, low=-200.0, high=200.0,
    axes=_XYZ, given_as="a pose's x, y, z (terminal, page, plan `t`, `start`)",
)  # fmt: skip
ROTATION = Quantity(
    key="rotation", words="rotation", kind=Kind.ANGLE, low=-180.0, high=180.0,
    axes=("rx", "ry", "rz"), given_as="a pose's rx, ry, rz (terminal, page, plan `r_deg`)",
)  # fmt: skip
GROUND_TRUTH = Quantity(
    key="ground_truth", words="ground truth", kind=Kind.LENGTH, low=-200.0, high=200.0,
    axes=_XYZ, given_as="`--ground-truth`, the setup, plan `ground_truth`",
)  # fmt: skip
BOARD_CORNER = Quantity(
    key="board_corner", words="board corner", kind=Kind.LENGTH, low=-200.0, high=200.0,
    axes=_XYZ, given_as="`--board-corner`, the setup, plan `board.first_corner`",
)  # fmt: skip
GROUND_HEIGHT = Quantity(
    key="ground_height", words="ground height", kind=Kind.LENGTH, low=0.0, high=200.0,
    low_open=True,
    given_as="`--ground-height` (or `--plane-offset`), the setup, plan `ground_height`",
)  # fmt: skip
#: The offset of a method's plane, whatever the plane (`--plane-offset`, plan `plane_offset`):
#: read as a length within this span, then within the method's plane's own bound (the
#: ground's :data:`GROUND_HEIGHT`; :attr:`twopose.methods.planes.ConstraintPlane.bound`).
PLANE_OFFSET = Quantity(
    key="plane_offset", words="plane offset", kind=Kind.LENGTH, low=-200.0, high=200.0,
    given_as="`--plane-offset` (`new`), plan `plane_offset`; then the plane's own "
    "bound (the ground's: ground height)",
)  # fmt: skip
BOARD_SQUARE = Quantity(
    key="board_square", words="board square", kind=Kind.LENGTH, low=0.0, high=20.0,
    low_open=True, given_as="`--square`, the setup, plan `board.square`",
)  # fmt: skip
FOCAL = Quantity(
    key="focal", words="focal length", kind=Kind.PIXELS, low=0.0, high=100000.0,
    low_open=True, given_as="`--focal`, the setup, plan `camera.focal`",
)  # fmt: skip
PRINCIPAL = Quantity(
    key="principal", words="principal point", kind=Kind.PIXELS, low=0.0, high=10000.0,
    axes=("cx", "cy"),
    given_as="`--principal`, the setup, plan `camera.principal` (and inside the image)",
)  # fmt: skip
IMAGE_SIDE = Quantity(
    key="image_side", words="image side", kind=Kind.COUNT, low=1, high=10000,
    given_as="`--width`, `--height`, plan `camera.width`, `camera.height`",
)  # fmt: skip
GRID = Quantity(
    key="grid", words="grid spacing", kind=Kind.LENGTH, low=_MM, high=100.0,
    given_as="`--grid`, plan `guidance.spacing` (and within the reach)",
)  # fmt: skip
REACH = Quantity(
    key="reach", words="reach", kind=Kind.LENGTH, low=_MM, high=100.0,
    given_as="`--reach`, plan `guidance.reach`",
)  # fmt: skip
TARGET_PRECISION = Quantity(
    key="target_precision", words="target precision", kind=Kind.LENGTH, low=0.0, high=100.0,
    low_open=True, given_as="`--target-precision`, the setup, plan `guidance.target_95`",
)  # fmt: skip
#: A target nearer than 2 in is not one a webcam sees in focus: such a distance is a slip
#: of units (11 typed in a mm session for 11 in), refused rather than trusted.
TARGET_DISTANCE = Quantity(
    key="target_distance", words="target distance", kind=Kind.LENGTH, low=2.0, high=200.0,
    given_as="`--target-distance`, plan `guidance.target_distance` (taped from the first "
    "pose's camera)",
)  # fmt: skip
#: The information-gain stop's default least share (``twopose.guidance.advice.MIN_GAIN``; here so
#: that the command line states it without importing NumPy): a sixth guided pose seldom
#: shrinks a region by 10% (``benchmarks/bench_guidance.py``; docs/guidance.md says why).
DEFAULT_MIN_GAIN = 0.10
MIN_GAIN = Quantity(
    key="min_gain", words="least gain", kind=Kind.SHARE, low=0.0, high=0.5,
    given_as="`--min-gain`, plan `guidance.min_gain` (a share; 0: no information-gain stop)",
)  # fmt: skip
MAX_POSES = Quantity(
    key="max_poses", words="max poses", kind=Kind.COUNT, low=2, high=100,
    given_as="`--max-poses`, plan `guidance.max_poses`, a guided trial's `max_poses`",
)  # fmt: skip
POSES = Quantity(
    key="poses", words="poses per trial", kind=Kind.COUNT, low=2, high=100,
    given_as="`--poses` (`new`, `simulate`)",
)  # fmt: skip
FRAMES = Quantity(
    key="frames", words="frames per pose", kind=Kind.COUNT, low=1, high=500,
    given_as="`--frames` (the most with `--adaptive-frames`), plan `frames`",
)  # fmt: skip
# 3 at least each way: OpenCV's board search refuses fewer ("bigger than 2").
INNER_CORNERS = Quantity(
    key="inner_corners", words="inner corners", kind=Kind.COUNT, low=3, high=100,
    axes=("cols", "rows"), given_as="`--board COLSxROWS`, the setup, plan `board.inner_corners`",
)  # fmt: skip

FPS = Quantity(
    key="fps", words="frame rate", kind=Kind.RATE, low=1, high=1000,
    given_as="`--fps` (a camera's: `--source camera:N`)",
)  # fmt: skip
PORT = Quantity(
    key="port", words="port", kind=Kind.COUNT, low=0, high=65535,
    given_as="`--port` (with `--ui`), `--live-port` (with `--live`); 0: a free one",
)  # fmt: skip
TRIALS = Quantity(
    key="trials", words="trials", kind=Kind.COUNT, low=1, high=10000,
    given_as="`simulate --trials`",
)  # fmt: skip
#: NumPy's generators take any seed >= 0; a 32-bit one is what a person types.
SEED = Quantity(
    key="seed", words="seed", kind=Kind.COUNT, low=0, high=2**32 - 1,
    given_as="`simulate --seed`, `sensitivity --seed`, plan `guidance.seed`",
)  # fmt: skip
POSE_NOISE = Quantity(
    key="pose_noise", words="pose noise", kind=Kind.LENGTH, low=0.0, high=10.0,
    given_as="`simulate --pose-noise` (0: a perfect operator)",
)  # fmt: skip
TYPED_RESOLUTION = Quantity(
    key="typed_resolution", words="typed resolution", kind=Kind.LENGTH, low=0.0, high=10.0,
    low_open=True, given_as="`simulate --typed-resolution`",
)  # fmt: skip
VIEWS = Quantity(
    key="views", words="views", kind=Kind.COUNT, low=3, high=10000,
    given_as="`calibrate --views`",
)  # fmt: skip
JOBS = Quantity(
    key="jobs", words="jobs", kind=Kind.COUNT, low=1, high=1024,
    given_as="`run --jobs`",
)  # fmt: skip
MARGIN_ANGLE = Quantity(
    key="margin_angle", words="warning angle", kind=Kind.ANGLE, low=0.0, high=90.0,
    given_as="`run --min-parallax`, `--min-plane-angle`, `--min-ground-angle`",
)  # fmt: skip
SESSION_TIMEOUT = Quantity(
    key="session_timeout", words="session timeout", kind=Kind.SECONDS, low=0.0, high=86400.0,
    given_as="`run --session-timeout` (0: no limit)",
)  # fmt: skip
CAMERAS = Quantity(
    key="cameras", words="cameras", kind=Kind.COUNT, low=1, high=2,
    given_as="`simulate --cameras` (2: a pair, a moving target)",
)  # fmt: skip
SPEED = Quantity(
    key="speed", words="speed", kind=Kind.SPEED, low=0.0, high=100.0, low_open=True,
    given_as="`simulate --speed` (with `--cameras 2`): the moving target's",
)  # fmt: skip
CLOCK_OFFSET = Quantity(
    key="clock_offset", words="clock offset", kind=Kind.MILLISECONDS, low=-1000.0,
    high=1000.0, given_as="`simulate --clock-offset-ms` (with `--cameras 2`), `point "
    "--clock-offset-ms`: camera 2's clock minus camera 1's; the rays' gap searches this "
    "range and 250 ms beyond",
)  # fmt: skip
DRIFT = Quantity(
    key="drift", words="drift", kind=Kind.PPM, low=-1000.0, high=1000.0,
    given_as="`simulate --drift-ppm` (with `--cameras 2`): camera 2's frame interval's",
)  # fmt: skip
JITTER = Quantity(
    key="jitter", words="jitter", kind=Kind.MILLISECONDS, low=0.0, high=10.0,
    given_as="`simulate --jitter-ms` (with `--cameras 2`): each capture stamp's 1-sigma",
)  # fmt: skip
DROP = Quantity(
    key="drop", words="dropped share", kind=Kind.SHARE, low=0.0, high=0.5,
    given_as="`simulate --drop` (with `--cameras 2`): the share of each camera's frames lost",
)  # fmt: skip
TOUCH_TIME = Quantity(
    key="touch_time", words="touch time", kind=Kind.SECONDS, low=0.0, high=3600.0,
    given_as="a pair plan's scheduled touch (`at`): seconds after the stream trial's start",
)  # fmt: skip
STREAM_DURATION = Quantity(
    key="stream_duration", words="stream trial duration", kind=Kind.SECONDS, low=0.0,
    high=3600.0, low_open=True,
    given_as="a pair plan's `duration`: a stream trial ends this long after its start",
)  # fmt: skip
SIMULATED_TRIAL = Quantity(
    key="simulated_trial", words="simulated stream trial's length", kind=Kind.SECONDS,
    low=0.0, high=600.0, low_open=True,
    given_as="`simulate --cameras 2`: a trial's path over `--speed` (10 minutes, the issue's "
    "longest recording: 18,000 frames a camera at 30 fps, about an hour of rendering at "
    "0.1 s a frame)",
)  # fmt: skip
SIMULATED_FRAMES = Quantity(
    key="simulated_frames", words="frames a camera of a simulated two-camera session",
    kind=Kind.COUNT, low=1, high=18_000,
    given_as="`simulate --cameras 2`: `--trials` times each trial's length times the "
    "scene's fps (the frames of one 10-minute trial at 30 fps, about an hour of rendering)",
)  # fmt: skip
SAMPLES = Quantity(
    key="samples", words="samples", kind=Kind.COUNT, low=100, high=10_000_000,
    given_as="`sensitivity --samples`",
)  # fmt: skip

#: Every quantity, in the order of the docs' table.
QUANTITIES: tuple[Quantity, ...] = (
    POSE_TRANSLATION, ROTATION, GROUND_TRUTH, BOARD_CORNER, GROUND_HEIGHT, PLANE_OFFSET,
    BOARD_SQUARE, FOCAL, PRINCIPAL, IMAGE_SIDE, GRID, REACH, TARGET_PRECISION, TARGET_DISTANCE,
    MIN_GAIN, MAX_POSES, POSES, FRAMES, INNER_CORNERS, FPS, PORT, TRIALS, SEED, POSE_NOISE,
    TYPED_RESOLUTION, VIEWS, JOBS, MARGIN_ANGLE, SESSION_TIMEOUT, SAMPLES, CAMERAS,
    SPEED, CLOCK_OFFSET, DRIFT, JITTER, DROP, TOUCH_TIME, STREAM_DURATION, SIMULATED_TRIAL,
    SIMULATED_FRAMES,
)  # fmt: skip


def markdown_table() -> str:
    """The table of :data:`QUANTITIES` as the docs show it, one row per quantity."""
    head = "| quantity | given as | range |\n| --- | --- | --- |\n"
    rows = [f"| {q.words} | {q.given_as} | {q.range_text(None)} |" for q in QUANTITIES]
    return head + "\n".join(rows) + "\n"
