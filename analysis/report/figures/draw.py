"""Figures (matplotlib, object API: nothing global is configured).

Every figure draws the trials the statistics use (:func:`analysis.session.metrics.used_trials`):
a session's figures draw its warned trials distinctly (hollow, dashed), the run's figures
leave them out, as the answer does; :mod:`analysis.report.captions` says which in each caption.
Every axis names its unit (the sessions', or inches when they differ); legends sit beside
the data, never on it; a figure has one bin width and one y scale.

Layouts are fixed (margins in inches, no constrained layout) and what a figure draws does
not grow with the number of trials: collections (one artist per kind, not per trial),
a colour per trial with its key beyond :data:`MAX_LEGEND` named series. The report's cost
is then the same for 15 trials or 500.
"""

from __future__ import annotations

import functools
import io
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from analysis.batch.outputs import printable_stem
from analysis.report.answer import session_order, strand_names, with_branch
from analysis.report.figures.plane import (
    error_ellipses,
    plot_error_scatter,
    plot_running_averages,
    running_errors,
)
from analysis.report.figures.style import (
    DPI,
    KEY_MARGIN,
    LABEL,
    MAX_LEGEND,
    TITLE,
    TrialColours,
    common_units,
    figure_name,
    key,
    layout,
    legend_below,
    method_colour,
    style,
)
from analysis.report.figures.topview import plot_top_view
from analysis.report.plane_axes import plane_of
from analysis.session.metrics import by_session_set, session_set, used_trials
from analysis.tables.labels import table_units
from analysis.tables.row_units import row_units_of, rows_word
from twopose.methods.specs import Method, label_of
from twopose.values.units import Units

if TYPE_CHECKING:
    from analysis.results import RunResult

__all__ = [
    "MAX_LEGEND",
    "common_units",
    "error_ellipses",
    "figure_key",
    "make_figures",
    "plot_error_by_trial",
    "plot_error_histogram",
    "plot_error_scatter",
    "plot_error_vs_baseline",
    "plot_top_view",
    "png_bytes",
    "run_figures",
    "session_figures",
]

#: Figures are at most this wide (inches): at 110 dpi, 528 px, shown on a 390 px phone
#: at two thirds, their 9 pt labels about 9 px high.
WIDTH = 4.8
HISTOGRAM_BINS = 20


def _running_figure(
    name: str,
    errors: pd.DataFrame,
    units: Units | None,
    palette: TrialColours,
    *,
    include_warned: bool,
) -> Figure:
    """The running averages' figure: the trials named in the legend, or keyed by a colour
    bar beyond :data:`MAX_LEGEND` trials."""

    def draw(fig: Figure) -> None:
        handles, note = plot_running_averages(
            fig, errors, units, palette, include_warned=include_warned
        )
        bottom = legend_below(fig, handles, 3, note)
        right = 0.15 if palette.named else KEY_MARGIN
        layout(fig, left=0.8, right=right, top=0.6, bottom=0.6 + bottom, wspace=0.08)
        if not palette.named:
            palette.colour_key(fig, fig.axes[1])
        height = fig.get_size_inches()[1]
        fig.supxlabel(
            palette.unit.averaged_count,
            fontsize=LABEL,
            y=(bottom + 0.05) / height,
            va="bottom",
        )
        fig.suptitle(f"{name}: running average, error", fontsize=TITLE)

    return _figure((WIDTH, 3.9), draw)


def session_figures(
    session: str,
    trials: pd.DataFrame,
    averaging: pd.DataFrame,
    views: pd.DataFrame,
    *,
    include_warned: bool = False,
    units: Units | None = None,
) -> dict[str, Figure]:
    """One session's figures: ``scatter``, ``topview`` (ok trials with views) and, with
    more than one frame per pose, ``averaging``; each trial in one colour in all of them
    (:class:`~analysis.report.figures.style.TrialColours`). ``units``: the session's, named on
    the axes when it has no trial to name them."""
    name = figure_name(session)
    units = table_units(trials) or units
    unit = row_units_of(trials)[0]  # a session's rows: trials, or a pair's touches
    palette = TrialColours.of(used_trials(trials, include_warned=True)["trial"], unit)

    def scatter(fig: Figure) -> None:
        ax = fig.add_subplot()
        title = f"{name}: estimate - truth"
        handles, note = plot_error_scatter(
            ax, trials, title, include_warned=include_warned, palette=palette, units=units
        )
        bottom = legend_below(fig, handles, 2, note)
        right = 0.2 if palette.named else KEY_MARGIN
        layout(fig, left=0.75, right=right, top=0.35, bottom=0.5 + bottom)
        if not palette.named:
            palette.colour_key(fig, ax)

    figures = {"scatter": _figure((WIDTH, 4.9), scatter)}
    if not views.empty and palette.trials:
        title = f"{name}: {plane_of(trials).drawing_name}"  # the ground's: top view
        figures["topview"] = _figure(
            (WIDTH, 5.2),
            lambda fig: plot_top_view(
                fig, trials, views, title, palette, include_warned=include_warned
            ),
        )
    errors = running_errors(averaging, trials) if not averaging.empty else averaging
    if not errors.empty and errors["n_frames"].max() > 1:
        figures["averaging"] = _running_figure(
            name, errors, units, palette, include_warned=include_warned
        )
    return figures


def _figure(size: tuple[float, float], draw: Callable[[Figure], None]) -> Figure:
    """A figure drawn by ``draw``; if the data defeat it, a figure that says why instead, so
    that one odd session never costs the run its report (errors that only rendering meets
    are caught by :func:`png_bytes`)."""
    fig = Figure(figsize=size, dpi=DPI)
    try:
        draw(fig)
    except (ValueError, OverflowError, FloatingPointError, KeyError, IndexError) as err:
        fig = _not_drawn(size, err)
    return fig


def _not_drawn(size: tuple[float, float], err: Exception) -> Figure:
    fig = Figure(figsize=size, dpi=DPI)
    text = f"figure not drawn:\n{type(err).__name__}: {err}"[:300]
    fig.text(0.5, 0.5, text, ha="center", wrap=True)
    return fig


def figure_key(kind: str, index: int, session: str) -> str:
    """File-name stem of a session figure in a run: ``<kind>_<index>_<session stem>``."""
    return f"{kind}_{index:02d}_{printable_stem(session)}"


def _grouped_axes(fig: Figure, trials: pd.DataFrame) -> list[tuple[str, Axes]]:
    """One panel per session set (stacked, on shared x and y scales), each with its set."""
    groups = by_session_set(trials)
    axes = fig.subplots(len(groups), 1, sharex=True, sharey=True, squeeze=False)[:, 0]
    return [(name, ax) for (name, _), ax in zip(groups, axes, strict=True)]


def _set_title(name: str, base: str) -> str:
    return f"{base}: {name}_* sessions" if name else base


def _drawn(trials: pd.DataFrame, *, include_warned: bool) -> tuple[pd.DataFrame, str, str]:
    """The trials a run figure draws, in one unit; that unit, the run's own when none is
    drawn (all warned: never "session units"); and what was converted to it, in words."""
    used, units = common_units(used_trials(trials, include_warned=include_warned, measured=True))
    if used.empty:
        return used, common_units(trials)[1], ""
    others = sorted({str(u) for u in used["units"]} - {units})
    said = f"; {', '.join(others)} converted to {units}"
    return used, units, said if others else ""


def plot_error_histogram(
    fig: Figure, trials: pd.DataFrame, *, include_warned: bool = False
) -> None:
    """The error of each trial the answer uses, by method, one panel per session set, every
    panel with the same bins (one width, from 0 to the largest error) and y scale; the x
    axis names the unit and what was converted to it."""
    used, units, converted = _drawn(trials, include_warned=include_warned)
    top = float(used["err"].max()) if len(used) else 1.0
    edges = np.linspace(0.0, top if top > 0 else 1.0, HISTOGRAM_BINS + 1)
    methods = sorted(Method(m) for m in used["method"].unique()) if len(used) else []
    panels = _grouped_axes(fig, used)
    for name, ax in panels:
        g = used if not name else used[used["session"].map(session_set) == name]
        data = [g.loc[g["method"] == m, "err"].to_numpy() for m in methods]
        if methods:
            ax.hist(data, bins=list(edges), color=[method_colour(m) for m in methods])
        else:
            ax.text(0.5, 0.5, "no trial usable", ha="center", transform=ax.transAxes)
        style(ax, _set_title(name, "Error per trial"), "", "number of trials")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # counts: whole trials
    width = f"{edges[1] - edges[0]:.3g}"
    label = f"error ({units}); bins {width} {units} wide{converted}"
    panels[-1][1].set_xlabel(label, fontsize=LABEL)
    handles = [key(label_of(m), marker="s", color=method_colour(m), ms=7) for m in methods]
    _run_layout(fig, len(panels), legend_below(fig, handles, 3))


def _run_layout(fig: Figure, panels: int, legend: float) -> None:
    fig.set_size_inches(WIDTH, 0.95 + legend + 2.3 * panels)
    layout(fig, left=0.75, right=0.2, top=0.35, bottom=0.55 + legend, hspace=0.3)


def plot_error_by_trial(fig: Figure, trials: pd.DataFrame, *, include_warned: bool = False) -> None:
    """Each used trial's error, with the radius of its 95% ellipsoid for scale; one series
    per session (beyond :data:`MAX_LEGEND` sessions, one grey collection, unnamed). A
    series is broken where a trial is left out (a warned one): a line never joins two
    trials across one the statistics do not use."""
    measured, units = common_units(used_trials(trials, include_warned=True, measured=True))
    used = used_trials(measured, include_warned=include_warned, measured=True)
    ax = fig.add_subplot()
    handles = []
    rest = []
    for k, (_session, g) in enumerate(session_order(measured).groupby("session", sort=False)):
        g = g.sort_values("trial")
        keep = g.index.isin(used.index)
        err = np.where(keep, g["err"].to_numpy(dtype=np.float64), np.nan)
        xy = np.column_stack([g["trial"].to_numpy(dtype=np.float64), err])
        if k >= MAX_LEGEND:
            rest += _runs(xy)
            continue
        ax.plot(xy[:, 0], xy[:, 1], "o-", color=f"C{k}", ms=3, lw=0.8)
        if "semiaxis95" in g:
            semi = np.where(keep, g["semiaxis95"].to_numpy(dtype=np.float64), np.nan)
            ax.plot(xy[:, 0], semi, ":", color=f"C{k}", lw=0.8)
        name = figure_name(str(strand_names(trials).loc[g.index[0]]))  # all: its branch
        handles.append(key(name, color=f"C{k}", marker="o", ms=3, linestyle="-"))
    if rest:
        ax.add_collection(LineCollection(rest, colors="0.6", linewidths=0.6))
        handles.append(key(f"{len(rest)} more series", color="0.6", linestyle="-"))
    handles.append(key("95% ellipsoid, longest semi-axis", linestyle=":", lw=0.8))
    ax.set_yscale("log")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    noun = rows_word(trials, "noun", joiner=" or ")  # trial; a two-camera session's touch
    style(ax, f"Error by {noun}, per session", f"{noun} number", f"error ({units}, log scale)")
    legend = legend_below(fig, handles, 2)
    fig.set_size_inches(WIDTH, 3.4 + legend)
    layout(fig, left=0.75, right=0.2, top=0.35, bottom=0.55 + legend)


def _runs(xy: np.ndarray) -> list[np.ndarray]:
    """The unbroken runs of finite rows of ``xy`` (a line split where a value is missing)."""
    finite = np.isfinite(xy).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, finite.astype(int), 0]))
    return [xy[a:b] for a, b in zip(edges[::2], edges[1::2], strict=True)]


def plot_error_vs_baseline(
    fig: Figure, trials: pd.DataFrame, *, include_warned: bool = False
) -> None:
    """Error against the distance between the cameras (the thesis' strongest lever), by
    method, one panel per session set on shared scales."""
    used, units, _ = _drawn(trials, include_warned=include_warned)
    used = used[used["baseline"].notna()] if "baseline" in used else used.head(0)
    methods = sorted(Method(m) for m in used["method"].unique()) if len(used) else []
    panels = _grouped_axes(fig, used)
    for name, ax in panels:
        g = used if not name else used[used["session"].map(session_set) == name]
        for method in methods:
            m = g[g["method"] == method]
            ax.scatter(m["baseline"], m["err"], s=14, color=method_colour(method), alpha=0.8)
        ax.set_yscale("log")
        style(ax, _set_title(name, "Error against baseline"), "", f"error ({units}, log)")
    panels[-1][1].set_xlabel(f"baseline ({units})", fontsize=LABEL)
    handles = [key(label_of(m), marker="o", color=method_colour(m), ms=5) for m in methods]
    _run_layout(fig, len(panels), legend_below(fig, handles, 3))


def run_figures(result: RunResult) -> dict[str, Figure]:
    """The figures spanning all sessions of a run."""
    if result.trials.empty:
        return {}
    plots = {
        "error_histogram": plot_error_histogram,
        "error_by_trial": plot_error_by_trial,
        "error_vs_baseline": plot_error_vs_baseline,
    }
    return {
        name: _figure(
            (WIDTH, 3.6),
            functools.partial(plot, trials=result.trials, include_warned=result.include_warned),
        )
        for name, plot in plots.items()
    }


def make_figures(result: RunResult) -> dict[str, Figure]:
    """Named figures of a run, as matplotlib Figures (for a notebook).

    Per session its scatter, top view and running averages; then the histogram, the error
    by trial and the error against baseline.

    Parameters
    ----------
    result : RunResult
        What :func:`analysis.run` returned.

    Returns
    -------
    dict of str to Figure
        The figures by the name of the PNG the run writes for each.
    """
    figures: dict[str, Figure] = {}
    for i, s in enumerate(result.sessions):
        name, tables = with_branch(s.name, s.branch), (s.trials, s.averaging, s.pose_views)
        drawn = session_figures(name, *tables, include_warned=result.include_warned)
        number = s.index if s.index >= 0 else i
        figures |= {figure_key(kind, number, s.name): fig for kind, fig in drawn.items()}
    return figures | run_figures(result)


def describe(fig: Figure) -> str:
    """What a figure shows, for its PNG's ``Description`` and the report's alt text: its
    titles and every axis label (``x: ...``, ``y: ...``)."""
    parts = [fig.get_suptitle()]
    parts += [f"x: {fig.get_supxlabel()}", f"y: {fig.get_supylabel()}"]
    parts += _axes_labels(ax for ax in fig.axes if ax.axison)
    if not fig.axes:  # a figure that says why it was not drawn
        parts += [t.get_text() for t in fig.texts]
    return "; ".join(dict.fromkeys(p for p in parts if p and p not in ("x: ", "y: ")))


def _axes_labels(axes: Iterable[Axes]) -> list[str]:
    out = []
    for ax in axes:
        out += [ax.get_title()]
        out += [f"x: {ax.get_xlabel()}"] if ax.get_xlabel() else []
        out += [f"y: {ax.get_ylabel()}"] if ax.get_ylabel() else []
    return out


def png_bytes(fig: Figure) -> bytes:
    """The figure as a PNG whose ``Description`` is :func:`describe`'s; a figure whose data
    defeat rendering becomes one that says why."""
    return saved(fig, "png")


def saved(fig: Figure, fmt: str) -> bytes:
    """The figure in ``fmt`` (``png``, ``svg``, ``pdf``: ``run --figures``); a PNG carries
    :func:`describe`'s ``Description``; a figure whose data defeat rendering says why. The
    same figure gives the same bytes in every format (no date, no random SVG ids), so that
    two runs' figures compare as their tables do."""
    import matplotlib

    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "twopose"}):  # SVG ids: else random
        try:
            fig.savefig(buf, format=fmt, dpi=DPI, metadata=_METADATA[fmt](fig))
        except (ValueError, OverflowError, FloatingPointError) as err:
            buf = io.BytesIO()
            size = fig.get_size_inches()
            fallback = _not_drawn((float(size[0]), float(size[1])), err)
            fallback.savefig(buf, format=fmt, dpi=DPI, metadata=_METADATA[fmt](fallback))
    return buf.getvalue()


#: Each format's metadata (their keys differ): a PNG's description, no creation date.
_METADATA: dict[str, Callable[[Figure], dict[str, str | None]]] = {
    "png": lambda fig: {"Software": None, "Description": describe(fig)},
    "svg": lambda _fig: {"Date": None},
    "pdf": lambda _fig: {"CreationDate": None},
}
