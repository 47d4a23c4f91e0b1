"""The one home of value checks shared by every entry point.

Typed poses, plans, requests, session entries. Each raises
:class:`~twopose.errors.InputValueError` naming ``what``.
"""

from __future__ import annotations

import math
import re
from numbers import Real as numbers_Real
from typing import Any

from twopose.errors import InputValueError

__all__ = [
    "CAMERA_ID_PATTERN",
    "MAX_MAGNITUDE",
    "MAX_NUMBER_CHARS",
    "NUMBER_GRAMMAR",
    "Vec3",
    "camera_id",
    "finite",
    "index",
    "numbers",
    "parse_number",
    "vec3",
]

Vec3 = tuple[float, float, float]
CAMERA_ID_PATTERN = r"^[A-Za-z0-9_-]{1,32}$"
_CAMERA_ID = re.compile(CAMERA_ID_PATTERN)


def _number(value: Any, what: str) -> float:
    # A typed number is an int or a float (numpy's included); never a bool or a string.
    if isinstance(value, bool) or not isinstance(value, numbers_Real):
        raise InputValueError(f"{what} must be a number, got {value!r}")
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
#: The one grammar of a number typed or sent as text: ASCII digits, an optional sign, one
#: decimal point, an optional exponent. Python's own ``float`` takes more (``1_0`` as 10,
#: full-width and Arabic-Indic digits, ``inf``), which an operator never means.
NUMBER_GRAMMAR = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def parse_number(text: str, what: str, *, limit: float = MAX_MAGNITUDE) -> float:
    """Typed or sent text as a finite float of sane size, ``|v| <= limit``.

    The one parser of numbers that arrive as text (the terminal's answers, the console's
    forms and request bodies): anything else raises :class:`InputValueError` naming
    ``what``, never ``ValueError`` or ``OverflowError``.
    """
    stripped = str(text).strip()
    if not stripped:
        raise InputValueError(f"{what}: type a number")
    if len(stripped) > MAX_NUMBER_CHARS:
        raise InputValueError(
            f"{what}: {stripped[:12]}... ({len(stripped)} characters) is not a number of sane size"
        )
    if NUMBER_GRAMMAR.fullmatch(stripped) is None:
        raise InputValueError(
            f"{what}: {stripped!r} is not a number (digits 0-9, a sign, a decimal point, an "
            "exponent: -1.5, 2e-3)"
        )
    value = float(stripped)
    if not math.isfinite(value):
        raise InputValueError(f"{what} must be a finite number, got {stripped!r}")
    if abs(value) > limit:
        raise InputValueError(f"{what}: {stripped} is too large (at most {limit:g})")
    return value


def finite(value: Any, what: str, *, positive: bool = False) -> float:
    """``value`` as a finite float (and > 0 with ``positive``)."""
    v = _number(value, what)
    if not math.isfinite(v):
        raise InputValueError(f"{what} must be finite, got {v}")
    if positive and v <= 0:
        raise InputValueError(f"{what} must be positive, got {v}")
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
