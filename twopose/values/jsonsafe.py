"""The one JSON encoder of what the recorder shows live: NaN and infinity become ``null``.

Standard JSON has no NaN: Python's ``json`` writes a bare ``NaN`` by default (which
browsers' ``JSON.parse`` and Foxglove refuse) and raises with ``allow_nan=False``. A
trial with no estimate, a pose with no ground truth or a degenerate line all carry NaN,
so everything the web console answers (``recorder/console/server.py``) and everything the
live view publishes (``recorder/live/view.py``) goes through :func:`dumps`, which turns every
non-finite float, wherever it sits, into ``null``. Producers (``TrialResult.to_json``,
the console's state) keep their floats as they are.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

__all__ = ["dumps", "finite_or_none", "jsonable"]


def finite_or_none(value: float) -> float | None:
    """``value``, or None when it is NaN or infinite (JSON has neither)."""
    return value if math.isfinite(value) else None


def jsonable(value: Any) -> Any:
    """``value`` made JSON-safe: non-finite floats as None, NumPy as Python.

    ``value`` with every non-finite float (also in lists, tuples, dicts, NumPy arrays and
    NumPy scalars) replaced by None, tuples as lists and NumPy values as Python's.
    """
    if value is None or isinstance(value, str | int):  # bool is an int
        return value
    if isinstance(value, float):  # np.float64 too
        return finite_or_none(float(value))
    if isinstance(value, Mapping):
        return {str(k) if not isinstance(k, str) else k: jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [jsonable(v) for v in value]
    if hasattr(value, "tolist"):  # NumPy arrays and scalars (np.int64 is not an int)
        return jsonable(value.tolist())
    return value  # json.dumps says what it cannot encode


def dumps(value: Any, **options: Any) -> str:
    """JSON text of ``value`` with NaN and infinity as ``null`` (``options``: json.dumps')."""
    options.setdefault("allow_nan", False)
    return json.dumps(jsonable(value), **options)
