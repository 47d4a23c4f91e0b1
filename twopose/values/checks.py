"""The one home of value checks shared by every entry point.

Typed poses, plans, requests, session entries. Each raises
:class:`~twopose.errors.InputValueError` naming ``what``.
"""

from __future__ import annotations

import math
import re
from numbers import Real as numbers_Real
from typing import Any, NoReturn

from twopose.errors import InputValueError

__all__ = [
    "CAMERA_ID_PATTERN",
    "MAX_MAGNITUDE",
    "MAX_NUMBER_CHARS",
    "NUMBER_GRAMMAR",
    "NUMBER_WORDS",
    "WHOLE_GRAMMAR",
    "WHOLE_WORDS",
    "Given",
    "GivenWhole",
    "Unread",
    "Vec3",
    "camera_id",
    "finite",
    "given_text",
    "index",
    "numbers",
    "parse_number",
    "read_number",
    "vec3",
]

Vec3 = tuple[float, float, float]
CAMERA_ID_PATTERN = r"^[A-Za-z0-9_-]{1,32}$"
_CAMERA_ID = re.compile(CAMERA_ID_PATTERN)


def _number(value: Any, what: str) -> float:
    # A typed number is an int or a float (numpy's included); never a bool or a string.
    if isinstance(value, Unread):
        value.refuse(what)
    if isinstance(value, bool) or not isinstance(value, numbers_Real):
        raise InputValueError(f"{what} must be a number, got {value!r}")
    if isinstance(value, Given):  # kept with the text it was given as, to show it back
        return value
    try:
        return float(value)
    except OverflowError as err:  # an integer beyond the float range
        raise InputValueError(f"{what} is too large, got {value!r}") from err


#: The largest magnitude a typed or sent number may have: beyond any length, angle or pixel
#: coordinate a session holds, and far inside a float's range (a 400-digit integer would
#: overflow the float it is judged as).
MAX_MAGNITUDE = 1e9
#: The longest text read as one number (a 64-bit float needs 24 characters at most).
MAX_NUMBER_CHARS = 40
#: The one grammar of a number a person or a file gives as text: ASCII digits, an optional
#: sign, one decimal point, an optional exponent. Python's own ``float`` takes more (``1_0``
#: as 10, full-width and Arabic-Indic digits, ``inf``), and TOML more again (``0x5``,
#: ``0o5``, ``0b101``, ``1_0``, ``inf``, ``nan``), which an operator never means.
NUMBER_GRAMMAR = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
#: The one grammar of a whole number (a count, a seed, a port): digits and a sign only.
WHOLE_GRAMMAR = re.compile(r"[+-]?[0-9]+")
#: How the grammars are said when a text does not follow them (one wording, every path).
NUMBER_WORDS = "digits 0-9, a sign, a decimal point, an exponent: -1.5, 2e-3"
WHOLE_WORDS = "digits 0-9 and a sign: 15, -3"


class _AsGiven:
    """What a number given as text shows, and how it travels: its text."""

    __slots__ = ()
    text: str

    def __repr__(self) -> str:
        """As given (a message's ``got {value!r}`` says ``1e309``, never ``inf``)."""
        return self.text

    __str__ = __repr__

    def __reduce__(self) -> tuple[type, tuple[object, str]]:
        """Pickled with its text (a worker process or a copied setup keeps it)."""
        return (type(self), (getattr(self, "real"), self.text))  # noqa: B009 - float's, int's


class Given(_AsGiven, float):
    """A number with the text it was given as.

    Typed, passed on a command line or written in a file: it computes as its float, and
    is shown back as its text (:func:`twopose.values.bounds.shown`), never normalised
    (``525.000``, ``1e3``, ``2.50e-1``).
    """

    __slots__ = ("text",)

    def __new__(cls, value: float, text: str) -> Given:
        """The number ``value``, given as ``text``."""
        made = super().__new__(cls, value)
        made.text = text
        return made


class GivenWhole(_AsGiven, int):  # an int takes no __slots__ of its own
    """A whole number with the text it was given as (a TOML integer: ``+5``)."""

    def __new__(cls, value: int, text: str) -> GivenWhole:
        """The whole number ``value``, given as ``text``."""
        made = super().__new__(cls, value)
        made.text = text
        return made


class Unread:
    """A number a file wrote outside the one grammar (TOML's ``0x5``, ``1_0``, ``inf``).

    Kept as its text, not a number, until a reader judges it with its own grammar (a
    count's or any number's): :func:`twopose.values.bounds.Quantity.read` and the TOML tables'
    dataclasses refuse it in the one wording, naming the quantity; used as a number
    anywhere else (``float()``, :func:`finite`), it is refused naming its key.
    """

    __slots__ = ("key", "text")

    def __init__(self, text: str, key: str) -> None:
        """The number written as ``text`` at ``key``."""
        self.text, self.key = text, key

    def __repr__(self) -> str:
        """As written."""
        return self.text

    def refuse(self, what: str = "", *, whole: bool = False) -> NoReturn:
        """Raise the one grammar's refusal of its text, naming ``what`` (else its key)."""
        read_number(self.text, what or self.key, whole=whole)
        raise AssertionError(self.text)  # pragma: no cover - the grammar refused it

    def __float__(self) -> float:
        """Refused: it is no number twopose reads."""
        self.refuse()


def given_text(value: object) -> str | None:
    """The text ``value`` was given as (None: a number computed, not given)."""
    return value.text if isinstance(value, Given | GivenWhole) else None


def read_number(text: str, what: str, *, whole: bool = False) -> Given:
    """Text as a number by the one grammar, its value and its text kept together.

    ``whole``: digits and a sign only. Its bound is the caller's (:mod:`twopose.values.bounds`).
    The one reader of numbers as text: the terminal's answers, the page's forms and
    request bodies, the command lines' options and every number of a TOML file (its source
    text). Anything else raises :class:`InputValueError` naming ``what``, in one wording::

        reach: '1_0' is not a number (digits 0-9, a sign, a decimal point, an exponent: ...)

    ``1e309`` follows the grammar: it reads as infinity, which every bound refuses
    showing the text (``got 1e309``).
    """
    stripped = str(text).strip()
    kind = "a whole number" if whole else "a number"
    if not stripped:
        raise InputValueError(f"{what}: type {kind}")
    if len(stripped) > MAX_NUMBER_CHARS:
        raise InputValueError(
            f"{what}: {stripped[:12]}... ({len(stripped)} characters) is not a number of sane size"
        )
    grammar, words = (WHOLE_GRAMMAR, WHOLE_WORDS) if whole else (NUMBER_GRAMMAR, NUMBER_WORDS)
    if grammar.fullmatch(stripped) is None:
        raise InputValueError(f"{what}: {stripped!r} is not {kind} ({words})")
    return Given(float(stripped), stripped)


def parse_number(text: str, what: str, *, limit: float = MAX_MAGNITUDE) -> float:
    """Typed or sent text as a finite number of sane size, ``|v| <= limit``.

    For a number no quantity's bound judges (:func:`read_number`, then these limits).
    """
    value = read_number(text, what)
    if not math.isfinite(value) or abs(value) > limit:
        raise InputValueError(
            f"{what} must be a number from {-limit:g} to {limit:g}, got {value.text}"
        )
    return value


def finite(value: Any, what: str, *, positive: bool = False) -> float:
    """``value`` as a finite float (and > 0 with ``positive``)."""
    v = _number(value, what)
    said = given_text(v) or v  # as given: 1e309, never the inf it reads as
    if not math.isfinite(v):
        raise InputValueError(f"{what} must be finite, got {said}")
    if positive and v <= 0:
        raise InputValueError(f"{what} must be positive, got {said}")
    return v


def numbers(value: Any, n: int, what: str) -> tuple[float, ...]:
    """Exactly ``n`` finite numbers from a list, tuple or 1-D array."""
    try:
        if isinstance(value, str | bytes | dict):
            raise TypeError
        items = list(value)
    except TypeError as err:  # not iterable (a number, a 0-d array, None)
        raise InputValueError(f"{what} must be a list of {n} numbers, got {value!r}") from err
    if len(items) != n:
        raise InputValueError(f"{what} must be a list of {n} numbers, got {len(items)}")
    v = tuple(_number(x, what) for x in items)
    if not all(math.isfinite(x) for x in v):
        raise InputValueError(f"{what} must hold finite numbers, got {v}")
    return v


def vec3(value: Any, what: str) -> Vec3:
    """Three finite numbers ``(x, y, z)``."""
    x, y, z = numbers(value, 3, what)
    return (x, y, z)


def index(value: Any, what: str) -> int:
    """A whole number >= 0 (trial, pose, frame counts, nanoseconds)."""
    import numpy as np  # numpy integers count as whole numbers

    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise InputValueError(f"{what} must be a whole number >= 0, got {value!r}")
    return int(value)


def camera_id(value: Any) -> str:
    """A camera id: 1-32 letters, digits, ``_`` or ``-``."""
    if not isinstance(value, str) or not _CAMERA_ID.match(value):
        raise InputValueError(f"camera id must be 1-32 letters, digits, '_' or '-', got {value!r}")
    return value
