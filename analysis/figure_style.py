"""What every figure shares: its resolution, font sizes, method colours, a colour per
trial with its key, a fixed layout (margins in inches: no constrained layout, which was
most of a figure's drawing time) and a legend below the axes, never on the data."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.cm import ScalarMappable
from matplotlib.colors import BoundaryNorm, Colormap, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from twopose.format.entries import INCHES_PER_UNIT

__all__ = [
    "DPI",
    "LABEL",
    "TICK",
    "TITLE",
    "colour_key",
    "common_units",
    "key",
    "layout",
    "legend_below",
    "method_colour",
    "place_colour_key",
    "trial_colours",
]

#: Pixels per inch of the PNGs (a 5 in figure is 550 px wide).
DPI = 110
TICK, LABEL, TITLE = 9, 10, 10  # font sizes (points)

_METHOD_COLOURS = {"ground": "C0", "point": "C1", "line": "C2"}  # as the sensitivity figure


def method_colour(method: object) -> str:
    """One colour per method in every figure."""
    return _METHOD_COLOURS.get(str(method), "C4")


def layout(
    fig: Figure, *, left: float, right: float, top: float, bottom: float, **space: float
) -> None:
    """A fixed layout: the margins around the axes in inches; ``space``: ``wspace`` and
    ``hspace`` between panels (fractions of a panel)."""
    w, h = fig.get_size_inches()
    fig.subplots_adjust(
        left=left / w, right=1 - right / w, top=1 - top / h, bottom=bottom / h, **space
    )


def legend_below(fig: Figure, handles: list[Line2D], columns: int) -> float:
    """A legend along the figure's bottom edge, out of every axes; the inches it takes."""
    if not handles:
        return 0.0
    fig.legend(
        handles=handles,
        loc="lower center",
        ncol=columns,
        fontsize=TICK,
        frameon=False,
        bbox_to_anchor=(0.5, 0.0),
    )
    return 0.1 + 0.22 * math.ceil(len(handles) / columns)


def key(label: str, **style: object) -> Line2D:
    """A legend entry drawn by ``style`` (a marker or a line; none by default)."""
    defaults: dict[str, object] = {"color": "0.3", "linestyle": "none"}
    return Line2D([], [], label=label, **(defaults | style))  # type: ignore[arg-type]


def common_units(trials: pd.DataFrame) -> tuple[pd.DataFrame, str]:
    """``trials`` with their lengths in one unit, and its name: the sessions' own when they
    share one, else every length converted to inches."""
    units = sorted({str(u) for u in trials["units"]}) if "units" in trials else []
    if len(units) == 1:
        return trials, units[0]
    if not units:
        return trials, "session units"
    scale = trials["units"].map(INCHES_PER_UNIT).astype(float)
    lengths = ("err", "err_x", "err_y", "err_z", "semiaxis95", "baseline")
    converted = {c: trials[c] * scale for c in lengths if c in trials}
    inches: pd.DataFrame = trials.assign(**converted)
    return inches, "in"


def trial_colours(trial_ids: list[int]) -> tuple[Colormap, Normalize]:
    """A colour per trial number: distinct steps up to 20 trials, a ramp beyond."""
    from matplotlib import colormaps

    cmap = colormaps["viridis"].resampled(256)
    lo, hi = min(trial_ids), max(trial_ids)
    if len(trial_ids) <= 20:
        return cmap, BoundaryNorm(np.arange(lo - 0.5, hi + 1.0), cmap.N)
    return cmap, Normalize(lo, hi)


def colour_key(fig: Figure, cmap: Colormap, norm: Normalize) -> Axes:
    """The trials' colour key, a colour bar (place it with :func:`place_colour_key` once
    the layout is set; keep 1.2 in of right margin for it)."""
    cax = fig.add_axes((0.86, 0.3, 0.03, 0.6), label="<colorbar>")  # as matplotlib names it
    bar = fig.colorbar(ScalarMappable(norm, cmap), cax=cax)
    bar.set_label("trial number (colour key)", fontsize=LABEL)
    bar.locator = MaxNLocator(nbins=8, integer=True)
    bar.update_ticks()
    bar.ax.tick_params(labelsize=TICK)
    return cax


def place_colour_key(fig: Figure, cax: Axes, beside: Axes, below: Axes | None = None) -> None:
    """The colour key right of ``beside``, 0.12 in wide and 0.12 in away, from the bottom
    of ``below`` (``beside`` by default) to its top."""
    top, bottom = beside.get_position(), (below or beside).get_position()
    width = fig.get_size_inches()[0]
    cax.set_position((top.x1 + 0.12 / width, bottom.y0, 0.12 / width, top.y1 - bottom.y0))
