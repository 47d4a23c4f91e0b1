"""The analyst's closed sets of names, declared once for the library and the command line.

Like :mod:`twopose.values.choices`: a :data:`~typing.Literal` types the option record, and typer
makes it the command line's choices. Nothing heavy is imported, so that the command line
reads it at start-up.
"""

from __future__ import annotations

from typing import Literal

__all__ = [
    "DEFAULT_SESSION_TIMEOUT_S",
    "FIGURE_FORMATS",
    "Estimator",
    "FigureFormat",
    "RigCalibrationMode",
]

#: The estimate a comparison reads from a run (``thesis``: ``x, y, z``; ``optimal``: the
#: reprojection-optimal estimate; ``weighted``: the weighted/robust line fit).
Estimator = Literal["thesis", "optimal", "weighted"]
#: ``--rig-calibration``: ``loo`` also corrects each trial by the rig constants that its
#: session's other trials give.
RigCalibrationMode = Literal["none", "loo"]

#: ``run --figures``: the static figures' formats (matplotlib's savefig formats).
FigureFormat = Literal["png", "svg", "pdf"]
FIGURE_FORMATS: tuple[FigureFormat, ...] = ("png", "svg", "pdf")
#: How long one session may run before a batch stops it and lists it as failed (seconds).
DEFAULT_SESSION_TIMEOUT_S = 600.0
