"""Figures (matplotlib, object API: nothing global is configured).

Every figure draws the trials the statistics use (:func:`analysis.metrics.used_trials`):
a session's figures draw its warned trials distinctly (hollow, dashed), the run's figures
leave them out, as the answer does; :mod:`analysis.captions` says which in each caption.
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
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from analysis.answer import session_order
from analysis.figure_style import (
    DPI,
    LABEL,
    TICK,
    TITLE,
    colour_key,
    common_units,
    key,
    layout,
    legend_below,
    method_colour,
    place_colour_key,
    trial_colours,
)
from analysis.metrics import by_session_set, session_set, used_trials, warned
from analysis.outputs import printable_stem
from analysis.topview_figure import plot_top_view
from twopose.uncertainty import CHI2_95

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

#: Series in one legend; beyond it, a figure switches to small multiples.
MAX_LEGEND = 8
#: Figures are at most this wide (inches): at 110 dpi, 528 px, shown on a 390 px phone
#: at two thirds, their 9 pt labels about 9 px high.
WIDTH = 4.8
HISTOGRAM_BINS = 20


def _style(ax: Axes, title: str, xlabel: str, ylabel: str) -> None:
    ax.set_title(title, fontsize=TITLE)
    ax.set_xlabel(xlabel, fontsize=LABEL)
    ax.set_ylabel(ylabel, fontsize=LABEL)
    ax.tick_params(labelsize=TICK)


def _covariances_xz(trials: pd.DataFrame) -> np.ndarray:
    """(n, 2, 2) x-z marginal covariances of ``trials`` (NaN read as 0)."""
    C = np.zeros((len(trials), 2, 2))
    C[:, 0, 0] = trials["sigma_x"].to_numpy(dtype=np.float64) ** 2
    C[:, 1, 1] = trials["sigma_z"].to_numpy(dtype=np.float64) ** 2
    C[:, 0, 1] = C[:, 1, 0] = trials["cov_xz"].to_numpy(dtype=np.float64)
    return np.nan_to_num(C, posinf=0.0, neginf=0.0)


def error_ellipses(trials: pd.DataFrame, chi2: float = CHI2_95[2]) -> EllipseCollection:
    """The x-z marginal 95% ellipse of each trial's covariance, centred on its error: the
    truth (the origin) lies inside about 95% of them when the uncertainty is honest."""
    w, V = np.linalg.eigh(_covariances_xz(trials))
    angle = np.degrees(np.arctan2(V[:, 1, 1], V[:, 0, 1]))  # of the major axis
    size = 2.0 * np.sqrt(chi2 * np.clip(w, 0.0, None))
    return EllipseCollection(
        size[:, 1],
        size[:, 0],
        angle,
        units="xy",
        offsets=trials[["err_x", "err_z"]].to_numpy(dtype=np.float64),
        offset_transform=None,
        facecolors="none",
        edgecolors="C0",
        linewidths=0.6,
        alpha=0.45,
    )


def _ellipse_bounds(trials: pd.DataFrame, chi2: float = CHI2_95[2]) -> np.ndarray:
    """[[x_min, z_min], [x_max, z_max]] covering every 95% ellipse and every point: an
    ellipse's half-extent along an axis is sqrt(chi2 * variance along it)."""
    C = _covariances_xz(trials)
    half = np.sqrt(chi2 * np.stack([C[:, 0, 0], C[:, 1, 1]], axis=1))
    centre = trials[["err_x", "err_z"]].to_numpy(dtype=np.float64)
    finite = np.isfinite(centre).all(axis=1) & np.isfinite(half).all(axis=1)
    if not finite.any():
        return np.array([[-1.0, -1.0], [1.0, 1.0]])
    lo = (centre - half)[finite].min(axis=0)
    hi = (centre + half)[finite].max(axis=0)
    return np.array([np.minimum(lo, 0.0), np.maximum(hi, 0.0)])  # the truth is in view


def plot_error_scatter(
    ax: Axes, trials: pd.DataFrame, title: str, *, include_warned: bool = False
) -> list[Line2D]:
    """Estimate minus truth in x-z, ok trials (the thesis' Figures 11 and 21), each with its
    95% error ellipse, every ellipse inside the axes. Trials with a near-degeneracy warning
    are hollow red and drawn without their (degenerate) ellipses; the bias is over the
    trials the statistics use. Returns the legend's entries."""
    ok = used_trials(trials, include_warned=True, measured=True)
    doubted = warned(ok)
    clean, doubtful = ok[~doubted], ok[doubted]
    used = ok if include_warned else clean
    units = str(trials["units"].iloc[0]) if len(trials) else "session units"
    ax.axhline(0, color="0.8", lw=0.8)
    ax.axvline(0, color="0.8", lw=0.8)
    handles = []
    if len(clean) and "sigma_x" in clean:
        ellipses = error_ellipses(clean)
        ellipses.set_offset_transform(ax.transData)
        ax.add_collection(ellipses, autolim=False)
        handles.append(key("95% ellipses", color="C0", lw=0.6, alpha=0.45, linestyle="-"))
    ax.scatter(clean["err_x"], clean["err_z"], s=18, color="C0")
    handles.append(key(f"{len(clean)} ok trials", marker="o", color="C0", ms=5))
    if len(doubtful):
        ax.scatter(doubtful["err_x"], doubtful["err_z"], s=22, facecolors="none", edgecolors="C3")
        fate = "included" if include_warned else "left out"
        handles.append(key(f"{len(doubtful)} warned ({fate})", marker="o", mfc="none", mec="C3"))
    if len(used):
        ax.scatter([used["err_x"].mean()], [used["err_z"].mean()], marker="x", s=60, color="k")
        handles.append(key("bias (mean error)", marker="x", color="k", ms=7))
    _limits_around(ax, clean, doubtful)
    _style(ax, title, f"x error ({units})", f"z error ({units})")
    ax.xaxis.set_major_locator(MaxNLocator(nbins=5))  # tick labels that never touch
    return handles


def _limits_around(ax: Axes, clean: pd.DataFrame, doubtful: pd.DataFrame) -> None:
    """Axis limits that hold every drawn ellipse, every point and the origin."""
    bounds = [np.zeros((2, 2))]
    if len(clean) and "sigma_x" in clean:
        bounds.append(_ellipse_bounds(clean))
    for points in (clean, doubtful):
        xz = points[["err_x", "err_z"]].to_numpy(dtype=np.float64)
        xz = xz[np.isfinite(xz).all(axis=1)]
        if len(xz):
            bounds.append(np.array([xz.min(axis=0), xz.max(axis=0)]))
    lo = np.min([b[0] for b in bounds], axis=0)
    hi = np.max([b[1] for b in bounds], axis=0)
    pad = 0.08 * np.maximum(hi - lo, 1e-9)
    ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
    ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])


def running_errors(averaging: pd.DataFrame, trials: pd.DataFrame) -> pd.DataFrame:
    """The running averages of the ok trials as errors: ``trial, n_frames, err_x, err_z``
    (estimate minus truth, session units) and ``warned``."""
    ok = used_trials(trials, include_warned=True).drop_duplicates("trial", keep="last")
    truth = ok.set_index("trial")
    picked = averaging[averaging["trial"].isin(truth.index)]
    gt = truth.reindex(picked["trial"])
    return pd.DataFrame(
        {
            "trial": picked["trial"].to_numpy(),
            "n_frames": picked["n_frames"].to_numpy(),
            "err_x": picked["x"].to_numpy(dtype=np.float64) - gt["gt_x"].to_numpy(np.float64),
            "err_z": picked["z"].to_numpy(dtype=np.float64) - gt["gt_z"].to_numpy(np.float64),
            "warned": warned(gt).to_numpy(),
        }
    )


def _running_axes(fig: Figure, units: str) -> tuple[Axes, Axes]:
    """The running averages' two panels, x and z error, on one y scale."""
    ax_x, ax_z = fig.subplots(1, 2, sharey=True, squeeze=False)[0]
    for ax, axis in ((ax_x, "x"), (ax_z, "z")):
        ax.axhline(0.0, color="0.6", lw=0.8)
        _style(ax, f"{axis} error", "", "")
    ax_x.set_ylabel(f"error of the running average ({units})", fontsize=LABEL)
    return ax_x, ax_z


def plot_running_averages(fig: Figure, errors: pd.DataFrame, units: str) -> list[Line2D]:
    """Up to :data:`MAX_LEGEND` trials: the x and the z error of the running average
    against the frames averaged (Figures 22-23, as errors), one named line per trial (a
    warned one dashed), the two panels on one y scale. Returns the legend's entries."""
    axes = _running_axes(fig, units)
    by_trial = list(errors.groupby("trial", sort=True))
    for ax, axis in zip(axes, ("x", "z"), strict=True):
        for k, (_, g) in enumerate(by_trial):
            style = "--" if g["warned"].any() else "-"
            ax.plot(g["n_frames"], g[f"err_{axis}"], style, color=f"C{k}", lw=1.0)
    handles = []
    for k, (trial, g) in enumerate(by_trial):
        doubt = bool(g["warned"].any())
        label = f"trial {trial}" + (" (warned)" if doubt else "")
        handles.append(key(label, color=f"C{k}", linestyle="--" if doubt else "-"))
    return [*handles, key("truth (zero error)", color="0.6", linestyle="-")]


def plot_running_averages_keyed(fig: Figure, errors: pd.DataFrame, units: str) -> Axes:
    """More trials: the same two panels, one collection of lines per panel, each trial's
    colour its number's (the colour key returned, to place once the layout is set), a
    warned trial dashed; what is drawn does not grow with the trials."""
    axes = _running_axes(fig, units)
    cmap, norm = trial_colours([int(t) for t in errors["trial"].unique()])
    by_trial = list(errors.groupby("trial", sort=True))
    colours = [cmap(norm(int(g["trial"].iloc[0]))) for _, g in by_trial]
    styles = ["--" if g["warned"].any() else "-" for _, g in by_trial]
    for ax, axis in zip(axes, ("x", "z"), strict=True):
        lines = [g[["n_frames", f"err_{axis}"]].to_numpy(dtype=np.float64) for _, g in by_trial]
        ax.add_collection(
            LineCollection(lines, colors=colours, linestyles=styles, linewidths=0.9, alpha=0.9)
        )
        ax.autoscale_view()
    return colour_key(fig, cmap, norm)


def _running_figure(name: str, errors: pd.DataFrame, units: str) -> Figure:
    """The running averages' figure: named lines, or lines keyed by colour beyond
    :data:`MAX_LEGEND` trials."""
    many = errors["trial"].nunique() > MAX_LEGEND

    def draw(fig: Figure) -> None:
        if many:
            cax = plot_running_averages_keyed(fig, errors, units)
            handles = [key("truth (zero error)", color="0.6", linestyle="-")]
            if errors["warned"].any():
                handles.insert(0, key("warned trial", color="0.3", linestyle="--"))
            bottom = legend_below(fig, handles, 2)
            layout(fig, left=0.8, right=1.2, top=0.6, bottom=0.6 + bottom, wspace=0.08)
            place_colour_key(fig, cax, fig.axes[1])
        else:
            bottom = legend_below(fig, plot_running_averages(fig, errors, units), 3)
            layout(fig, left=0.8, right=0.15, top=0.6, bottom=0.6 + bottom, wspace=0.08)
        height = fig.get_size_inches()[1]
        fig.supxlabel(
            "number of frames averaged per pose",
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
) -> dict[str, Figure]:
    """One session's figures: ``scatter``, ``topview`` (ok trials with views) and, with
    more than one frame per pose, ``averaging``."""
    name = printable_stem(session)
    units = str(trials["units"].iloc[0]) if len(trials) else "session units"

    def scatter(fig: Figure) -> None:
        ax = fig.add_subplot()
        title = f"{name}: estimate - truth"
        handles = plot_error_scatter(ax, trials, title, include_warned=include_warned)
        bottom = legend_below(fig, handles, 2)
        layout(fig, left=0.75, right=0.2, top=0.35, bottom=0.5 + bottom)

    figures = {"scatter": _figure((WIDTH - 0.3, 4.9), scatter)}
    if not views.empty and not used_trials(trials, include_warned=True).empty:
        figures["topview"] = _figure(
            (WIDTH, 5.2), lambda fig: plot_top_view(fig, trials, views, f"{name}: top view")
        )
    errors = running_errors(averaging, trials) if not averaging.empty else averaging
    if not errors.empty and errors["n_frames"].max() > 1:
        figures["averaging"] = _running_figure(name, errors, units)
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


def plot_error_histogram(
    fig: Figure, trials: pd.DataFrame, *, include_warned: bool = False
) -> None:
    """The error of each trial the answer uses, by method, one panel per session set, every
    panel with the same bins (one width, from 0 to the largest error) and y scale."""
    used, units = common_units(used_trials(trials, include_warned=include_warned, measured=True))
    top = float(used["err"].max()) if len(used) else 1.0
    edges = np.linspace(0.0, top if top > 0 else 1.0, HISTOGRAM_BINS + 1)
    methods = sorted(used["method"].unique()) if len(used) else []
    panels = _grouped_axes(fig, used)
    for name, ax in panels:
        g = used if not name else used[used["session"].map(session_set) == name]
        data = [g.loc[g["method"] == m, "err"].to_numpy() for m in methods]
        if methods:
            ax.hist(data, bins=list(edges), color=[method_colour(m) for m in methods])
        _style(ax, _set_title(name, "Error per trial"), "", "number of trials")
    width = f"{edges[1] - edges[0]:.3g}"
    panels[-1][1].set_xlabel(f"error ({units}); bins {width} {units} wide", fontsize=LABEL)
    handles = [key(str(m), marker="s", color=method_colour(m), ms=7) for m in methods]
    _run_layout(fig, len(panels), legend_below(fig, handles, 3))


def _run_layout(fig: Figure, panels: int, legend: float) -> None:
    fig.set_size_inches(WIDTH, 0.95 + legend + 2.3 * panels)
    layout(fig, left=0.75, right=0.2, top=0.35, bottom=0.55 + legend, hspace=0.3)


def plot_error_by_trial(fig: Figure, trials: pd.DataFrame, *, include_warned: bool = False) -> None:
    """Each used trial's error, with the radius of its 95% ellipsoid for scale; one series
    per session (beyond :data:`MAX_LEGEND` sessions, one grey collection, unnamed)."""
    used, units = common_units(used_trials(trials, include_warned=include_warned, measured=True))
    ax = fig.add_subplot()
    handles = []
    rest = []
    for k, (session, g) in enumerate(session_order(used).groupby("session", sort=False)):
        xy = g[["trial", "err"]].to_numpy(dtype=np.float64)
        if k >= MAX_LEGEND:
            rest.append(xy)
            continue
        ax.plot(xy[:, 0], xy[:, 1], "o-", color=f"C{k}", ms=3, lw=0.8)
        if "semiaxis95" in g:
            ax.plot(g["trial"], g["semiaxis95"], ":", color=f"C{k}", lw=0.8)
        name = printable_stem(str(session))
        handles.append(key(name, color=f"C{k}", marker="o", ms=3, linestyle="-"))
    if rest:
        ax.add_collection(LineCollection(rest, colors="0.6", linewidths=0.6))
        handles.append(key(f"{len(rest)} more sessions", color="0.6", linestyle="-"))
    handles.append(key("95% ellipsoid, longest semi-axis", linestyle=":", lw=0.8))
    ax.set_yscale("log")
    _style(ax, "Error by trial, per session", "trial number", f"error ({units}, log scale)")
    legend = legend_below(fig, handles, 2)
    fig.set_size_inches(WIDTH, 3.4 + legend)
    layout(fig, left=0.75, right=0.2, top=0.35, bottom=0.55 + legend)


def plot_error_vs_baseline(
    fig: Figure, trials: pd.DataFrame, *, include_warned: bool = False
) -> None:
    """Error against the distance between the cameras (the thesis' strongest lever), by
    method, one panel per session set on shared scales."""
    used, units = common_units(used_trials(trials, include_warned=include_warned, measured=True))
    used = used[used["baseline"].notna()] if "baseline" in used else used.head(0)
    methods = sorted(used["method"].unique()) if len(used) else []
    panels = _grouped_axes(fig, used)
    for name, ax in panels:
        g = used if not name else used[used["session"].map(session_set) == name]
        for method, m in g.groupby("method"):
            ax.scatter(m["baseline"], m["err"], s=14, color=method_colour(method), alpha=0.8)
        ax.set_yscale("log")
        _style(ax, _set_title(name, "Error against baseline"), "", f"error ({units}, log)")
    panels[-1][1].set_xlabel(f"baseline ({units})", fontsize=LABEL)
    handles = [key(str(m), marker="o", color=method_colour(m), ms=5) for m in methods]
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
    """Named figures of a run: per session its scatter, top view and running averages;
    then the histogram, the error by trial and the error against baseline."""
    figures: dict[str, Figure] = {}
    for i, s in enumerate(result.sessions):
        drawn = session_figures(
            s.session, s.trials, s.averaging, s.views, include_warned=result.include_warned
        )
        figures |= {figure_key(kind, i, s.session): fig for kind, fig in drawn.items()}
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
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=DPI, metadata=_metadata(fig))
    except (ValueError, OverflowError, FloatingPointError) as err:
        buf = io.BytesIO()
        size = fig.get_size_inches()
        fallback = _not_drawn((float(size[0]), float(size[1])), err)
        fallback.savefig(buf, format="png", dpi=DPI, metadata=_metadata(fallback))
    return buf.getvalue()


def _metadata(fig: Figure) -> dict[str, str | None]:
    return {"Software": None, "Description": describe(fig)}
