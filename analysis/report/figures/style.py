"""What every figure shares: its resolution, font sizes, method colours, a colour per
trial with its key, a fixed layout (margins in inches: no constrained layout, which was
most of a figure's drawing time) and a legend below the axes, never on the data."""

from __future__ import annotations

import functools
import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.colors import BoundaryNorm, Colormap, ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from analysis.tables.labels import MAX_LEGEND, common_units
from analysis.tables.row_units import ROW_UNITS, RowUnit
from twopose.methods.specs import Method, spec_of
from twopose.values.text import for_terminal

__all__ = [
    "DPI",
    "KEY_MARGIN",
    "LABEL",
    "MAX_LEGEND",
    "TICK",
    "TITLE",
    "TrialColours",
    "beyond_note",
    "common_units",
    "equal_scales",
    "figure_name",
    "frame",
    "key",
    "layout",
    "legend_below",
    "mark_beyond",
    "method_colour",
    "set_title",
    "style",
]

#: Pixels per inch of the PNGs (a 5 in figure is 550 px wide).
DPI = 110
#: The tick labels' font size (points).
TICK = 9
#: The axis labels' font size (points).
LABEL = 10
#: The titles' font size (points).
TITLE = 10
NOTE = 8  # a note under a legend


def method_colour(method: Method) -> str:
    """One colour per method in every figure: the registry's
    :attr:`~twopose.methods.specs.MethodSpec.colour`."""
    return spec_of(method).colour


def layout(
    fig: Figure, *, left: float, right: float, top: float, bottom: float, **space: float
) -> None:
    """A fixed layout: the margins around the axes in inches; ``space``: ``wspace`` and
    ``hspace`` between panels (fractions of a panel)."""
    w, h = fig.get_size_inches()
    fig.subplots_adjust(
        left=left / w, right=1 - right / w, top=1 - top / h, bottom=bottom / h, **space
    )


def legend_below(fig: Figure, handles: list[Line2D], columns: int, note: str = "") -> float:
    """A legend along the figure's bottom edge, out of every axes, and under it ``note``
    (wrapped to the figure's width); the inches they take. Both are placed in inches from
    the bottom, so a figure that grows taller afterwards keeps them in place."""
    width = float(fig.get_size_inches()[0])
    below = 0.0
    if note:
        lines = textwrap.wrap(note, int(width * 72 / (0.56 * NOTE)))
        fig.text(0.12, 0.08, "\n".join(lines), fontsize=NOTE, va="bottom", ha="left",
                 transform=fig.dpi_scale_trans)  # fmt: skip
        below = 0.1 + 0.16 * len(lines)
    if not handles:
        return below
    fig.legend(
        handles=handles,
        loc="lower center",
        ncol=columns,
        fontsize=TICK,
        frameon=False,
        bbox_to_anchor=(width / 2, below),
        bbox_transform=fig.dpi_scale_trans,
    )
    return below + 0.1 + 0.22 * math.ceil(len(handles) / columns)


def key(label: str, **style: object) -> Line2D:
    """A legend entry drawn by ``style`` (a marker or a line; none by default)."""
    defaults: dict[str, object] = {"color": "0.3", "linestyle": "none"}
    return Line2D([], [], label=label, **(defaults | style))  # type: ignore[arg-type]


def figure_name(name: str) -> str:
    """A session's name as a figure shows it: its label as it is (``a/x/session.mcap``,
    ``session.MCAP``: what tells it from every other input, never a stem made for a file
    name), with its control characters escaped, bytes that are no text replaced, and
    ``$`` escaped (matplotlib would read ``$...$`` as mathematics)."""
    text = name.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    return for_terminal(text).replace("$", r"\$")


def set_title(ax: Axes, title: str) -> None:
    """An axes' title at a fixed height: matplotlib's automatic placement measures every
    tick label of the axes again at each draw (a tenth of a figure's drawing time)."""
    ax.set_title(title, fontsize=TITLE, y=1.0, pad=5.0)


def style(ax: Axes, title: str, xlabel: str, ylabel: str) -> None:
    """An axes' title, its axes' labels and its ticks, in the figures' sizes."""
    set_title(ax, title)
    ax.set_xlabel(xlabel, fontsize=LABEL)
    ax.set_ylabel(ylabel, fontsize=LABEL)
    ax.tick_params(labelsize=TICK)


@dataclass(frozen=True)
class TrialColours:
    """One colour per trial of a session, the same in every figure of it, with its key:
    tab10's distinct colours up to 10 trials (in trial order), a viridis ramp beyond;
    named in the legend up to :data:`MAX_LEGEND` trials, by a colour bar beyond."""

    trials: tuple[int, ...]
    #: What the numbered rows are (trials; a two-camera session's touches), as the legend
    #: and the key name them.
    unit: RowUnit = ROW_UNITS[1]

    @classmethod
    def of(cls, trial_ids: object, unit: RowUnit = ROW_UNITS[1]) -> TrialColours:
        """The colours of these trial numbers (repeats and order do not matter)."""
        ids = pd.Series(trial_ids, dtype="float64").dropna().astype(int)
        return cls(tuple(sorted(set(ids.tolist()))), unit)

    @property
    def named(self) -> bool:
        """Whether the legend names each trial (else a colour bar keys them)."""
        return len(self.trials) <= MAX_LEGEND

    @functools.cached_property
    def _table(self) -> dict[int, tuple[float, float, float, float]]:
        """Every trial's colour, computed once."""
        cmap, norm = self._map()
        values = self.trials if len(self.trials) > 20 else range(len(self.trials))
        rgba = cmap(norm(np.asarray(list(values), dtype=np.float64)))
        return {t: tuple(float(v) for v in c) for t, c in zip(self.trials, rgba, strict=True)}  # type: ignore[misc]

    def _map(self) -> tuple[Colormap, Normalize]:
        from matplotlib import colormaps

        n = len(self.trials)
        if n > 20:
            return colormaps["viridis"], Normalize(self.trials[0], self.trials[-1])
        if n <= 10:
            colours = [colormaps["tab10"](k) for k in range(max(n, 1))]
        else:  # a ramp: distinct neighbours, and never so light it fades on white
            colours = [colormaps["viridis"](0.9 * k / (n - 1)) for k in range(n)]
        listed = ListedColormap(colours)
        return listed, BoundaryNorm(np.arange(max(n, 1) + 1) - 0.5, max(n, 1))

    def colour(self, trial: object) -> tuple[float, float, float, float]:
        """The trial's colour (grey for a trial not in the session's set)."""
        return self._table.get(int(trial), (0.5, 0.5, 0.5, 1.0))  # type: ignore[call-overload]

    def colours(self, trials: object) -> list[tuple[float, float, float, float]]:
        """The colours of ``trials`` (an iterable of trial numbers), in order."""
        return [self.colour(t) for t in trials]  # type: ignore[attr-defined]

    def legend(self, **style: object) -> list[Line2D]:
        """Legend entries naming each trial in its colour, drawn by ``style``."""
        return [
            key(f"{self.unit.noun} {t}", **(style | {"color": self.colour(t)})) for t in self.trials
        ]

    def colour_key(self, fig: Figure, beside: Axes) -> None:
        """The trials' colour key right of ``beside``: a strip of one swatch per trial
        (one collection) with their numbers, drawn on the figure, not as another axes (a
        colour bar's axes cost as much to draw as the plot). Call it once the layout is set;
        keep :data:`KEY_MARGIN` inches of right margin for it."""
        box = beside.get_position()
        width = float(fig.get_size_inches()[0])
        x0, w = box.x1 + 0.12 / width, 0.12 / width
        n = max(len(self.trials), 1)
        cell = (box.y1 - box.y0) / n
        cells = [
            [(x0, box.y0 + k * cell), (x0 + w, box.y0 + k * cell),
             (x0 + w, box.y0 + (k + 1) * cell), (x0, box.y0 + (k + 1) * cell)]
            for k in range(len(self.trials))
        ]  # fmt: skip
        strip = PolyCollection(
            cells,
            facecolors=[self.colour(t) for t in self.trials],
            edgecolors="none",
            transform=fig.transFigure,
            label="<colour key>",
        )
        fig.add_artist(strip)
        step = max(1, math.ceil(len(self.trials) / 8))
        for k in range(0, len(self.trials), step):
            fig.text(x0 + w + 0.05 / width, box.y0 + (k + 0.5) * cell, str(self.trials[k]),
                     fontsize=TICK, va="center", ha="left")  # fmt: skip
        said = f"{self.unit.noun} number (colour key)"
        fig.text(x0 + w + 0.42 / width, (box.y0 + box.y1) / 2, said,
                 fontsize=LABEL, rotation=90, va="center", ha="left")  # fmt: skip


#: The right margin (inches) a figure keeps for :meth:`TrialColours.colour_key`.
KEY_MARGIN = 1.0


def frame(ax: Axes, points: np.ndarray, *, pad: float = 0.08, least: float = 1e-9) -> None:
    """Axis limits around the finite rows of ``points`` (n, 2), padded by ``pad`` of their
    span (at least ``least`` wide): the points the statistics use set the scale."""
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    xy = xy[np.isfinite(xy).all(axis=1)]
    if not len(xy):
        xy = np.array([[-1.0, -1.0], [1.0, 1.0]])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.maximum(hi - lo, least)
    centre = (lo + hi) / 2
    lo, hi = centre - span * (0.5 + pad), centre + span * (0.5 + pad)
    ax.set_xlim(float(lo[0]), float(hi[0]))
    ax.set_ylim(float(lo[1]), float(hi[1]))


def equal_scales(ax: Axes, box_inches: tuple[float, float]) -> None:
    """Widen the axes' limits about their centres so that a unit is as long on both axes
    in a box of ``box_inches`` (width, height): nothing framed leaves the view."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    per_inch = max((x1 - x0) / box_inches[0], (y1 - y0) / box_inches[1])
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    ax.set_xlim(cx - per_inch * box_inches[0] / 2, cx + per_inch * box_inches[0] / 2)
    ax.set_ylim(cy - per_inch * box_inches[1] / 2, cy + per_inch * box_inches[1] / 2)


#: Trials listed by name in a figure's "beyond the frame" legend entry (the rest counted).
MAX_BEYOND_LISTED = 6


def mark_beyond(ax: Axes, points: np.ndarray, colours: Sequence[Any]) -> np.ndarray:
    """Points outside the axes' (final) limits drawn at the edge they lie beyond: an
    arrowhead pointing out, in their colour. Returns which points were outside (the
    caller lists them, with their values, under the legend: :func:`beyond_note`)."""
    xy = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    finite = np.isfinite(xy).all(axis=1)
    inside = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
    beyond = finite & ~inside
    if not beyond.any():
        return beyond
    span = np.array([x1 - x0, y1 - y0])
    edge = np.clip(xy[beyond], [x0, y0] + 0.02 * span, [x1, y1] - 0.02 * span)
    # how far beyond each side, in spans: the largest names the arrow's direction
    over = np.stack(
        [(xy[beyond, 0] - x1), (x0 - xy[beyond, 0]), (xy[beyond, 1] - y1), (y0 - xy[beyond, 1])],
        axis=1,
    ) / np.repeat(span, 2)
    markers = np.array([">", "<", "^", "v"])[over.argmax(axis=1)]
    chosen = [c for c, b in zip(colours, beyond, strict=True) if b]
    for marker in dict.fromkeys(markers.tolist()):  # in a fixed order: the same file each run
        pick = markers == marker
        ax.scatter(edge[pick, 0], edge[pick, 1], marker=marker, s=55, linewidths=0.6,
                   c=[c for c, k in zip(chosen, pick, strict=True) if k], edgecolors="k",
                   zorder=8, clip_on=False)  # fmt: skip
    return beyond


def beyond_note(listed: Sequence[str]) -> str:
    """The note under a legend naming the points drawn at the frame's edge, with their
    values (the first :data:`MAX_BEYOND_LISTED`; the rest counted); "" when none."""
    if not listed:
        return ""
    names = list(listed[:MAX_BEYOND_LISTED])
    if len(listed) > MAX_BEYOND_LISTED:
        names.append(f"and {len(listed) - MAX_BEYOND_LISTED} more")
    return "\u25b2 beyond the frame, drawn at its edge: " + "; ".join(names) + "."
