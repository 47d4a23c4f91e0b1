"""Report: figures (matplotlib, object API: nothing global is configured), CSV files, a
self-contained ``report.html`` and the terminal summary."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib.colors
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.figure import Figure

from twopose.uncertainty import CHI2_95

if TYPE_CHECKING:
    from analysis.results import RunResult

__all__ = [
    "dominant_inputs",
    "error_ellipses",
    "make_figures",
    "plot_error_by_trial",
    "plot_error_histogram",
    "plot_error_scatter",
    "plot_error_vs_baseline",
    "plot_running_average",
    "plot_top_view",
    "write_outputs",
]


def error_ellipses(trials: pd.DataFrame, chi2: float = CHI2_95[2]) -> EllipseCollection:
    """The x-z marginal 95% ellipse of each trial's covariance, centred on its error: the
    truth (the origin) lies inside about 95% of them when the uncertainty is honest."""
    C = np.zeros((len(trials), 2, 2))
    C[:, 0, 0] = trials["sigma_x"].to_numpy(dtype=np.float64) ** 2
    C[:, 1, 1] = trials["sigma_z"].to_numpy(dtype=np.float64) ** 2
    C[:, 0, 1] = C[:, 1, 0] = trials["cov_xz"].to_numpy(dtype=np.float64)
    C = np.nan_to_num(C)
    w, V = np.linalg.eigh(C)
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


_MAX_LEGEND = 8


def plot_error_scatter(ax: Axes, trials: pd.DataFrame, title: str) -> None:
    """Estimate minus truth in x-z, ok trials (the thesis' Figures 11 and 21), each with its
    95% error ellipse (analysis/uncertainty.py)."""
    ok = trials[trials["status"] == "ok"]
    units = trials["units"].iloc[0] if len(trials) else ""
    ax.axhline(0, color="0.8", lw=0.8)
    ax.axvline(0, color="0.8", lw=0.8)
    if len(ok) and "sigma_x" in ok:
        ellipses = error_ellipses(ok)
        ellipses.set_offset_transform(ax.transData)
        ax.add_collection(ellipses, autolim=False)  # the points, not the ellipses, set limits
        ax.plot([], [], color="C0", lw=0.6, alpha=0.45, label="95% ellipses")
    ax.scatter(ok["err_x"], ok["err_z"], s=18, label=f"{len(ok)} ok trials")
    if len(ok):
        ax.scatter(
            [ok["err_x"].mean()], [ok["err_z"].mean()], marker="x", s=60, color="C3", label="bias"
        )
    ax.set_xlabel(f"x error ({units})")
    ax.set_ylabel(f"z error ({units})")
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=7)


def plot_running_average(
    ax: Axes, averaging: pd.DataFrame, trials: pd.DataFrame, axis: str
) -> None:
    """Estimate of one coordinate against the number of frames averaged (Figures 22-23)."""
    units = trials["units"].iloc[0] if len(trials) else ""
    for k, (trial, g) in enumerate(averaging.groupby("trial")):
        label = f"trial {trial}" if k < _MAX_LEGEND else None  # a legend, not a wall
        line = ax.plot(g["n_frames"], g[axis], marker=".", ms=3, lw=0.8, label=label)
        truth = trials.loc[trials["trial"] == trial, f"gt_{axis}"]
        if len(truth):
            ax.axhline(float(truth.iloc[0]), color=line[0].get_color(), ls="--", lw=0.8)
    ax.set_xlabel("frames averaged per pose")
    ax.set_ylabel(f"{axis} estimate ({units})")
    ax.legend(fontsize=7)


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
    ax.legend(fontsize=7)


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
    ax.plot([], [], "x", color="0.3", label="estimate")
    ax.plot([], [], "o", mfc="none", color="0.3", label="truth")
    ax.set_xlabel(f"x ({units})")
    ax.set_ylabel(f"z, depth ({units})")
    ax.set_title(title, fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=7)


def plot_error_by_trial(ax: Axes, trials: pd.DataFrame) -> None:
    """Each ok trial's error, with the radius of its 95% ellipsoid for scale."""
    from analysis.outputs import printable_stem

    ok = _ok_with_error(trials)
    for k, (session, g) in enumerate(ok.groupby("session", sort=False)):
        color = f"C{k % 10}"
        ax.plot(
            g["trial"],
            g["err"],
            "o-",
            color=color,
            ms=3,
            lw=0.8,
            label=printable_stem(str(session)),
        )
        if "semiaxis95" in g:
            ax.plot(g["trial"], g["semiaxis95"], ":", color=color, lw=0.8)
    ax.plot([], [], ":", color="0.3", label="95% ellipsoid, longest semi-axis")
    ax.set_yscale("log")
    ax.set_xlabel("trial")
    ax.set_ylabel("error (session units)")
    ax.legend(fontsize=7)


def plot_error_vs_baseline(ax: Axes, trials: pd.DataFrame) -> None:
    """Error against the distance between the cameras (the thesis' strongest lever)."""
    ok = _ok_with_error(trials)
    ok = ok[ok["baseline"].notna()]
    for method, g in ok.groupby("method"):
        ax.scatter(g["baseline"], g["err"], s=14, label=str(method), alpha=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("baseline (session units)")
    ax.set_ylabel("error (session units)")
    ax.legend(fontsize=7)


def session_figures(
    session: str, trials: pd.DataFrame, averaging: pd.DataFrame, views: pd.DataFrame
) -> dict[str, Figure]:
    """One session's figures: ``scatter``, ``topview`` and (with more than one frame)
    ``averaging``."""
    from analysis.outputs import printable_stem

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

        def running(fig: Figure) -> None:
            for j, axis in enumerate(("x", "z")):
                plot_running_average(fig.add_subplot(1, 2, j + 1), averaging, trials, axis)
            fig.suptitle(f"{name}: running average", fontsize=9)

        figures["averaging"] = _figure((8.0, 3.4), running)
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
    from analysis.outputs import printable_stem

    return f"{kind}_{index:02d}_{printable_stem(session)}"


def run_figures(result: RunResult) -> dict[str, Figure]:
    """The figures spanning all sessions of a run (the error histogram)."""
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


def _rounded(value: float) -> str:
    """Four significant digits; floating-point noise (|v| < 1e-9) reads 0."""
    return "0" if abs(value) < 1e-9 else f"{value:.4g}"


def _table(df: pd.DataFrame) -> str:
    """A table that scrolls inside its own box: a wide one never widens the page."""
    body = df.to_html(index=False, float_format=_rounded, na_rep="", border=0, classes="t")
    return f"<div class='scroll'>{body}</div>"


ANSWER_COLUMNS = [
    "method",
    "n_trials",
    "n_ok",
    "n_warned",
    "rmse",
    "rmse_ci95_low",
    "rmse_ci95_high",
    "median_err",
    "bias_x",
    "bias_x_ci95",
    "bias_z",
    "bias_z_ci95",
    "coverage95",
    "within_1",
]


def answer_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Per method, pooled over the sessions: the report's first table."""
    from analysis.metrics import summarize

    if trials.empty:
        return pd.DataFrame(columns=ANSWER_COLUMNS)
    return summarize(trials.assign(session="all"))[ANSWER_COLUMNS]


def write_outputs(result: RunResult, out_dir: Path, sweeps: pd.DataFrame) -> list[str]:
    """Write the CSV tables, one PNG per figure, the sensitivity ``sweeps`` and
    ``report.html`` into ``out_dir`` (each atomically: :mod:`analysis.outputs`); the names
    of the files written."""
    from analysis.outputs import write_atomically

    out_dir.mkdir(parents=True, exist_ok=True)
    tables = {
        "trials.csv": result.trials,
        "summary.csv": result.summary,
        "averaging.csv": result.averaging,
        "frames.csv": result.frames,
        "errors.csv": result.errors,
        "views.csv": result.views,
        "sensitivity.csv": sweeps,
    }
    for name, table in tables.items():
        csv = table.to_csv(index=False).encode("utf-8", "backslashreplace")
        write_atomically(out_dir / name, csv)
    # Session figures were rendered by the workers (in parallel); a session analysed
    # without them is drawn here. Only what spans sessions is always drawn here.
    pngs: dict[str, bytes] = {}
    for i, s in enumerate(result.sessions):
        rendered = s.images or {
            kind: png_bytes(fig)
            for kind, fig in session_figures(s.session, s.trials, s.averaging, s.views).items()
        }
        pngs |= {figure_key(kind, i, s.session): data for kind, data in rendered.items()}
    pngs |= {name: png_bytes(fig) for name, fig in run_figures(result).items()}
    from analysis.sensitivity import plot_sensitivity

    pngs["sensitivity"] = png_bytes(plot_sensitivity(sweeps))
    images = {}
    for name, data in pngs.items():
        write_atomically(out_dir / f"{name}.png", data)
        images[name] = base64.b64encode(data).decode()
    page = _report_html(result, images, sweeps).encode("utf-8", "backslashreplace")
    write_atomically(out_dir / "report.html", page)
    return [*tables, *(f"{name}.png" for name in pngs), "report.html"]


def dominant_inputs(trials: pd.DataFrame) -> pd.DataFrame:
    """Per session, how many ok trials each input dominated, and its median share."""
    ok = trials[(trials["status"] == "ok") & (trials["dominant_input"] != "")]
    if ok.empty:
        return pd.DataFrame(columns=["session", "dominant_input", "trials", "median_share"])
    return (
        ok.groupby(["session", "dominant_input"], sort=True)
        .agg(trials=("trial", "size"), median_share=("dominant_share", "median"))
        .reset_index()
    )


def _sensitivity_table(sweeps: pd.DataFrame) -> pd.DataFrame:
    """RMS error per sweep value, one column per method."""
    table = sweeps.pivot_table(
        index=["sweep", "value", "unit"], columns="method", values="rmse", sort=False
    ).reset_index()
    table.columns = [str(c) if c in ("sweep", "value", "unit") else f"rmse {c}" for c in table]
    order = {s: i for i, s in enumerate(dict.fromkeys(sweeps["sweep"]))}
    return table.sort_values(
        ["sweep", "value"], key=lambda c: c.map(order) if c.name == "sweep" else c
    )


def _report_html(result: RunResult, images: dict[str, str], sweeps: pd.DataFrame) -> str:
    n_ok = int((result.trials["status"] == "ok").sum())
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'><title>twopose report</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
        ".scroll{overflow-x:auto;max-width:100%}img{max-width:100%;height:auto}"
        "table.t{border-collapse:collapse;font-size:12px;margin:1em 0}"
        "table.t td,table.t th{padding:2px 8px;border-bottom:1px solid #ddd;text-align:right}"
        "h2{border-bottom:1px solid #aaa}.err{color:#a00}</style></head><body>",
        "<h1>twopose report</h1>",
        f"<p>{len(result.sessions)} session(s) analysed, {len(result.errors)} failed, "
        f"{len(result.trials)} trial(s), {n_ok} ok.</p>",
        "<p><a href='#answer'>Answer per method</a> · <a href='#summary'>Per session</a> · "
        "<a href='#dominant'>What dominates the error</a> · "
        "<a href='#sensitivity'>Sensitivity</a> · <a href='#sessions'>Sessions</a></p>",
        "<h2 id='answer'>Answer per method</h2>",
        "<p>Pooled over the sessions, over the ok trials without a near-degeneracy warning "
        "(<code>n_warned</code> counts those left out); 95% intervals of the RMSE (bootstrap) "
        "and of the biases (<code>_ci95</code>: half-widths); <code>coverage95</code>: the "
        "share of trials whose truth is inside their 95% ellipsoid.</p>",
        _table(answer_table(result.trials)),
        "<h2 id='summary'>Per session</h2>",
        _table(result.summary),
    ]
    for key in ("error_histogram", "error_by_trial", "error_vs_baseline"):
        if key in images:
            parts.append(
                f"<img alt='{key.replace('_', ' ')}' src='data:image/png;base64,{images[key]}'>"
            )
    if not result.errors.empty:
        parts.append("<h2>Inputs that failed</h2>")
        parts.append(f"<div class='err'>{_table(result.errors)}</div>")
    parts += [
        "<h2 id='dominant'>What dominates the error</h2>",
        "<p>Per trial, the input whose uncertainty contributes most to the estimate's "
        "covariance (first-order propagation of the frame scatter and the typed poses' "
        "recorded 1-sigma resolution; trials.csv: <code>dominant_input</code>, "
        "<code>dominant_share</code>).</p>",
        _table(dominant_inputs(result.trials)),
        "<h2 id='sensitivity'>Sensitivity (the thesis' geometry)</h2>",
        "<p>Seeded Monte Carlo sweeps through the solvers, one input varied at a time, in the "
        "thesis' geometry (f = 525 px, h = 9.625 in, a 1.1 in baseline along x; "
        "<code>twopose-analyze sensitivity</code>; sensitivity.csv).</p>",
        f"<img alt='sensitivity' src='data:image/png;base64,{images['sensitivity']}'>",
        _table(_sensitivity_table(sweeps)),
    ]
    parts.append("<h2 id='sessions'>Sessions</h2>" if result.sessions else "")
    for i, s in enumerate(result.sessions):
        name = Path(s.session).stem
        parts.append(f"<h2>{html.escape(s.session)}</h2><div class='scroll'><table class='t'>")
        parts += [
            f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>"
            for k, v in s.metadata.items()
        ]
        parts.append("</table></div>")
        for kind in ("scatter", "topview", "averaging"):
            key = f"{kind}_{i:02d}_{name}"
            if key in images:
                parts.append(
                    f"<img alt='{html.escape(key)}' src='data:image/png;base64,{images[key]}'>"
                )
        parts.append(_table(s.trials.drop(columns=["session"])))
    parts.append("</body></html>")
    return "\n".join(parts)
