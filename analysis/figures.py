"""Figures (matplotlib, object API: nothing global is configured).

Every figure has a title and every series a name. What a figure draws does not grow with
the number of trials: collections (one artist per kind, not per trial), and small multiples
capped at :data:`MAX_PANELS` panels, the rest in the CSV tables. The report's cost is then
the same for 15 trials or 500.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import matplotlib.colors
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.figure import Figure

from analysis.outputs import printable_stem
from twopose.uncertainty import CHI2_95

if TYPE_CHECKING:
    from analysis.results import RunResult

__all__ = [
    "MAX_LEGEND",
    "MAX_PANELS",
    "error_ellipses",
    "figure_key",
    "make_figures",
    "plot_error_by_trial",
    "plot_error_histogram",
    "plot_error_scatter",
    "plot_error_vs_baseline",
    "plot_running_average",
    "plot_top_view",
    "png_bytes",
    "run_figures",
    "session_figures",
]

#: Series in one legend; beyond it, a figure switches to small multiples.
MAX_LEGEND = 8
#: Small multiples drawn at most (the first trials); every trial is in the CSV tables.
MAX_PANELS = 16


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


def _warned(trials: pd.DataFrame) -> pd.Series:
    if "warning" not in trials:
        return pd.Series(False, index=trials.index)
    return trials["warning"].fillna("").astype(str) != ""


def plot_error_scatter(ax: Axes, trials: pd.DataFrame, title: str) -> None:
    """Estimate minus truth in x-z, ok trials (the thesis' Figures 11 and 21), each with its
    95% error ellipse, every ellipse inside the axes. Trials with a near-degeneracy warning
    are hollow red and drawn without their (degenerate) ellipses: the summary leaves them
    out."""
    ok = _ok_with_error(trials)
    warned = _warned(ok)
    clean, doubtful = ok[~warned], ok[warned]
    units = trials["units"].iloc[0] if len(trials) else ""
    ax.axhline(0, color="0.8", lw=0.8)
    ax.axvline(0, color="0.8", lw=0.8)
    if len(clean) and "sigma_x" in clean:
        ellipses = error_ellipses(clean)
        ellipses.set_offset_transform(ax.transData)
        ax.add_collection(ellipses, autolim=False)
        ax.plot([], [], color="C0", lw=0.6, alpha=0.45, label="95% ellipses")
    ax.scatter(clean["err_x"], clean["err_z"], s=18, label=f"{len(clean)} ok trials")
    if len(doubtful):
        ax.scatter(
            doubtful["err_x"],
            doubtful["err_z"],
            s=22,
            facecolors="none",
            edgecolors="C3",
            label=f"{len(doubtful)} warned (left out)",
        )
    if len(clean):
        mean = (clean["err_x"].mean(), clean["err_z"].mean())
        ax.scatter([mean[0]], [mean[1]], marker="x", s=60, color="k", label="bias")
    _limits_around(ax, clean, doubtful)
    ax.set_xlabel(f"x error ({units})")
    ax.set_ylabel(f"z error ({units})")
    ax.set_title(title, fontsize=9)
    _legend(ax, 7)


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


def plot_running_average(
    ax: Axes, averaging: pd.DataFrame, trials: pd.DataFrame, axis: str
) -> None:
    """Estimate of one coordinate against the number of frames averaged (Figures 22-23),
    one line per trial: for at most :data:`MAX_LEGEND` trials (more: :func:`session_figures`
    draws small multiples)."""
    units = trials["units"].iloc[0] if len(trials) else ""
    for k, (trial, g) in enumerate(averaging.groupby("trial")):
        line = ax.plot(
            g["n_frames"], g[axis], marker=".", ms=3, lw=0.8, color=f"C{k}", label=f"trial {trial}"
        )
        truth = trials.loc[trials["trial"] == trial, f"gt_{axis}"]
        if len(truth):
            ax.axhline(float(truth.iloc[0]), color=line[0].get_color(), ls="--", lw=0.8)
    ax.plot([], [], "--", color="0.3", lw=0.8, label="truth")
    ax.set_xlabel("frames averaged per pose")
    ax.set_ylabel(f"{axis} estimate ({units})")
    ax.set_title(f"{axis} estimate", fontsize=9)
    _legend(ax, 6)


def _running_average_panels(fig: Figure, averaging: pd.DataFrame, trials: pd.DataFrame) -> str:
    """Small multiples: one panel per trial (the first :data:`MAX_PANELS`), its x and z
    running-average error against the frames averaged; the figure's subtitle."""
    truth = trials.drop_duplicates("trial", keep="last").set_index("trial")
    shown = sorted(averaging["trial"].unique())
    n_all = len(shown)
    shown = shown[:MAX_PANELS]
    cols = 4
    rows = math.ceil(len(shown) / cols)
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False)
    by_trial = dict(tuple(averaging[averaging["trial"].isin(shown)].groupby("trial")))
    for k, ax in enumerate(axes.flat):
        if k >= len(shown):
            ax.set_axis_off()
            continue
        trial = shown[k]
        g = by_trial[trial]
        for j, axis in enumerate(("x", "z")):
            gt = truth[f"gt_{axis}"].get(trial, np.nan) if f"gt_{axis}" in truth else np.nan
            ax.plot(g["n_frames"], g[axis] - gt, lw=0.8, color=f"C{j}", label=f"{axis} error")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_title(f"trial {trial}", fontsize=7)
        ax.tick_params(labelsize=6)
    axes.flat[0].legend(fontsize=6)
    more = (
        f"; trials {shown[0]}-{shown[-1]} of {n_all}, all in averaging.csv"
        if n_all > len(shown)
        else ""
    )
    return f"error of the running average against frames averaged{more}"


def _legend(ax: Axes, fontsize: int) -> None:
    """A legend when something is named (an empty one would only warn)."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=fontsize)


def _ok_with_error(trials: pd.DataFrame) -> pd.DataFrame:
    """The ok trials whose error is known and finite (no truth: NaN; absurd truth: inf)."""
    err = pd.to_numeric(trials["err"], errors="coerce")
    ok: pd.DataFrame = trials[(trials["status"] == "ok") & np.isfinite(err)]
    return ok


def plot_error_histogram(ax: Axes, trials: pd.DataFrame) -> None:
    ok = _ok_with_error(trials)
    for method, g in ok.groupby("method"):
        with np.errstate(over="ignore", invalid="ignore"):
            span = float(g["err"].max() - g["err"].min())
        bins = 20 if np.isfinite(span) else [float(b) for b in np.geomspace(1e-300, 1e300, 20)]
        ax.hist(g["err"], bins=bins, alpha=0.6, label=str(method))
        if not np.isfinite(span):
            ax.set_xscale("log")
    ax.set_xlabel("error (session units)")
    ax.set_ylabel("trials")
    ax.set_title("Error per ok trial, by method", fontsize=9)
    _legend(ax, 7)


def plot_top_view(ax: Axes, trials: pd.DataFrame, views: pd.DataFrame, title: str) -> None:
    """Looking down the y axis (x-z): each trial's typed camera centres, the ray through each
    view's measurement (for lines, the plane's central ray), the estimate and the truth."""
    units = trials["units"].iloc[0] if len(trials) else ""
    # One artist per kind, not per trial: long sessions must not slow the layout down. A
    # trial number recorded twice is drawn once (its last occurrence).
    by_trial = trials.drop_duplicates("trial", keep="last").set_index("trial")
    order = {t: k for k, t in enumerate(sorted(views["trial"].unique()))}
    colors = np.array([matplotlib.colors.to_rgba(f"C{k % 10}") for k in range(10)])
    view_color = colors[views["trial"].map(order).to_numpy() % 10]
    c = views[["t_x", "t_z"]].to_numpy(dtype=np.float64)
    ray = views[["ray_x", "ray_z"]].to_numpy(dtype=np.float64)
    est = by_trial.loc[views["trial"], ["x", "z"]].to_numpy(dtype=np.float64)
    reach = np.where(np.isfinite(est).all(axis=1), 1.2 * np.linalg.norm(est - c, axis=1), 10.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        end = c + ray / np.linalg.norm(ray, axis=1)[:, None] * reach[:, None]
    segments = np.stack([c, end], axis=1)
    good = np.isfinite(segments).all(axis=(1, 2))
    ax.add_collection(
        LineCollection(list(segments[good]), colors=view_color[good], linewidths=0.6, alpha=0.6)
    )
    ax.scatter(c[:, 0], c[:, 1], marker="^", s=25, c=view_color)
    trial_color = colors[[order[t] % 10 for t in by_trial.index if t in order]]
    shown = by_trial.loc[[t for t in by_trial.index if t in order]]
    ax.scatter(shown["x"], shown["z"], marker="x", s=45, c=trial_color)
    truth = ax.scatter(shown["gt_x"], shown["gt_z"], marker="o", s=45, facecolors="none")
    truth.set_edgecolor([tuple(rgba) for rgba in trial_color])
    ax.plot([], [], "^", color="0.3", label="cameras (typed)")
    ax.plot([], [], "-", color="0.3", lw=0.6, label="rays (colour: trial)")
    ax.plot([], [], "x", color="0.3", label="estimate")
    ax.plot([], [], "o", mfc="none", color="0.3", label="truth")
    ax.set_xlabel(f"x ({units})")
    ax.set_ylabel(f"z, depth ({units})")
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    _legend(ax, 7)


def plot_error_by_trial(ax: Axes, trials: pd.DataFrame) -> None:
    """Each ok trial's error, with the radius of its 95% ellipsoid for scale; one series
    per session (beyond :data:`MAX_LEGEND` sessions, grey and unnamed but for the first)."""
    ok = _ok_with_error(trials)
    for k, (session, g) in enumerate(ok.groupby("session", sort=False)):
        named = k < MAX_LEGEND
        color = f"C{k}" if named else "0.6"
        label = printable_stem(str(session)) if named else None
        ax.plot(g["trial"], g["err"], "o-", color=color, ms=3, lw=0.8, label=label)
        if "semiaxis95" in g:
            ax.plot(g["trial"], g["semiaxis95"], ":", color=color, lw=0.8)
    ax.plot([], [], ":", color="0.3", label="95% ellipsoid, longest semi-axis")
    ax.set_yscale("log")
    ax.set_xlabel("trial")
    ax.set_ylabel("error (session units)")
    ax.set_title("Error by trial, per session", fontsize=9)
    _legend(ax, 6)


def plot_error_vs_baseline(ax: Axes, trials: pd.DataFrame) -> None:
    """Error against the distance between the cameras (the thesis' strongest lever)."""
    ok = _ok_with_error(trials)
    ok = ok[ok["baseline"].notna()]
    for method, g in ok.groupby("method"):
        ax.scatter(g["baseline"], g["err"], s=14, label=str(method), alpha=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("baseline (session units)")
    ax.set_ylabel("error (session units)")
    ax.set_title("Error against baseline", fontsize=9)
    _legend(ax, 7)


def session_figures(
    session: str, trials: pd.DataFrame, averaging: pd.DataFrame, views: pd.DataFrame
) -> dict[str, Figure]:
    """One session's figures: ``scatter``, ``topview`` and (with more than one frame)
    ``averaging``: one panel per coordinate for up to :data:`MAX_LEGEND` trials, small
    multiples beyond."""
    name = printable_stem(session)
    figures = {
        "scatter": _figure(
            (4.2, 4.0),
            lambda fig: plot_error_scatter(fig.add_subplot(), trials, f"{name}: estimate - truth"),
        )
    }
    if not views.empty:
        figures["topview"] = _figure(
            (4.6, 4.0),
            lambda fig: plot_top_view(fig.add_subplot(), trials, views, f"{name}: top view"),
        )
    if not averaging.empty and averaging["n_frames"].max() > 1:
        many = averaging["trial"].nunique() > MAX_LEGEND

        def running(fig: Figure) -> None:
            if many:
                subtitle = _running_average_panels(fig, averaging, trials)
            else:
                for j, axis in enumerate(("x", "z")):
                    plot_running_average(fig.add_subplot(1, 2, j + 1), averaging, trials, axis)
                subtitle = "estimate against frames averaged"
            fig.suptitle(f"{name}: running average ({subtitle})", fontsize=9)

        figures["averaging"] = _figure((8.0, 6.4 if many else 3.4), running)
    return figures


def _figure(size: tuple[float, float], draw: Callable[[Figure], None]) -> Figure:
    """A figure drawn by ``draw``; if the data defeat it, a figure that says why instead, so
    that one odd session never costs the run its report."""
    fig = Figure(figsize=size, layout="constrained")
    try:
        draw(fig)
        fig.canvas.draw()  # layout errors surface here, not when the PNG is written
    except (ValueError, OverflowError, FloatingPointError, KeyError, IndexError) as err:
        fig = Figure(figsize=size, layout="constrained")
        fig.text(
            0.5,
            0.5,
            f"figure not drawn:\n{type(err).__name__}: {err}"[:300],
            ha="center",
            wrap=True,
        )
    return fig


def figure_key(kind: str, index: int, session: str) -> str:
    """File-name stem of a session figure in a run: ``<kind>_<index>_<session stem>``."""
    return f"{kind}_{index:02d}_{printable_stem(session)}"


def run_figures(result: RunResult) -> dict[str, Figure]:
    """The figures spanning all sessions of a run."""
    if result.trials.empty:
        return {}
    trials = result.trials
    return {
        "error_histogram": _figure(
            (5.0, 3.4), lambda fig: plot_error_histogram(fig.add_subplot(), trials)
        ),
        "error_by_trial": _figure(
            (5.6, 3.4), lambda fig: plot_error_by_trial(fig.add_subplot(), trials)
        ),
        "error_vs_baseline": _figure(
            (5.0, 3.4), lambda fig: plot_error_vs_baseline(fig.add_subplot(), trials)
        ),
    }


def make_figures(result: RunResult) -> dict[str, Figure]:
    """Named figures of a run: one scatter per session, running averages, a histogram."""
    figures: dict[str, Figure] = {}
    for i, s in enumerate(result.sessions):
        for kind, fig in session_figures(s.session, s.trials, s.averaging, s.views).items():
            figures[figure_key(kind, i, s.session)] = fig
    return figures | run_figures(result)


def png_bytes(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, metadata={"Software": None})
    return buf.getvalue()
