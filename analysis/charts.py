"""The report's charts as Vega-Lite specs (a session's here, the run's in
:mod:`analysis.run_charts`), drawn by the reader's browser from the run's own
tables (the scripts: ``analysis/report_js/``), so that a run draws no picture unless
asked (``run --figures``: :mod:`analysis.figures`) and a reader can explore each chart.

The honesty rules are the static figures': each chart is framed by the trials the
statistics use (a point beyond the frame is drawn at its edge, as a triangle, and its
tooltip gives its real value), one colour per trial across a session's charts (per-method
colours only on the overview, which shows no trial colour), a unit on every axis and in
every tooltip, the truth drawn. A session's charts are one spec (``concat``) sharing one
selection: clicking a trial picks it out in all of them; every chart zooms (wheel, drag).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from analysis.metrics import used_trials, warned
from twopose.uncertainty import CHI2_95

__all__ = ["Spec", "error_tip", "hex_colour", "records", "session_chart", "who", "zoom"]

Spec = dict[str, Any]

#: matplotlib's tab10, the static figures' colours for up to 10 trials.
TAB10 = [
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
]
#: The selection a session's charts share: the trial clicked (shift-click adds one).
PICK = "pick"
#: The charts a click picks a trial in (each names its unit view so).
_PICK_VIEWS = ["scatter_points", "topview_points", "running_x", "running_z"]
_ELLIPSE_POINTS = 48
#: A chart's plotting area (px): two side by side in the report's 1200 px.
WIDTH, _HEIGHT = 300, 240


def hex_colour(colour: str) -> str:
    """A method's colour (matplotlib's cycle name, ``C0``-``C9``; the registry's
    :attr:`~twopose.methods.MethodSpec.colour`) as the browser names it.

    Read from :data:`TAB10` (the default cycle), not by matplotlib, which a run that draws
    no figure never imports; any other name is matplotlib's to read.
    """
    if len(colour) == 2 and colour[0] == "C" and colour[1].isdigit():
        return TAB10[int(colour[1])]
    from matplotlib.colors import to_hex

    return str(to_hex(colour))


def records(table: pd.DataFrame) -> list[dict[str, Any]]:
    from twopose.jsonsafe import jsonable

    rows: list[dict[str, Any]] = jsonable(table.to_dict("records"))
    return rows


def _span(values: np.ndarray, pad: float = 0.08) -> list[float]:
    """The frame around the finite ``values``, padded by ``pad`` of their span."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if not len(v):
        return [-1.0, 1.0]
    lo, hi = float(v.min()), float(v.max())
    width = max(hi - lo, 1e-9)
    return [lo - pad * width, hi + pad * width]


def _clamped(values: pd.Series, domain: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Values drawn inside ``domain`` (at its edge beyond it), and which were beyond."""
    v = pd.to_numeric(values, errors="coerce").to_numpy(dtype=np.float64)
    shown = np.clip(v, domain[0], domain[1])
    return shown, np.isfinite(v) & (shown != v)


def _trial_colour(trials: list[int]) -> Spec:
    """One colour per trial, the session's in all its charts (the static figures' tab10 up
    to 10 trials, a viridis ramp beyond)."""
    scale: Spec = {"domain": trials}
    if len(trials) <= len(TAB10):
        scale["range"] = TAB10[: max(len(trials), 1)]
    else:
        scale["scheme"] = "viridis"
    return {
        "field": "trial",
        "type": "ordinal" if len(trials) > len(TAB10) else "nominal",
        "scale": scale,
        "title": "trial",
        "legend": {"columns": 2 if len(trials) > 10 else 1, "symbolLimit": 30},
    }


def _picked(value: float, other: float) -> Spec:
    return {"condition": {"param": PICK, "value": value, "empty": True}, "value": other}


def zoom(name: str, encodings: tuple[str, ...] = ("x", "y")) -> list[Spec]:
    """Wheel and drag zoom the chart (its scales along ``encodings``); a double-click
    restores it."""
    select = {"type": "interval", "encodings": list(encodings)}
    return [{"name": f"zoom_{name}", "select": select, "bind": "scales"}]


def _ellipses(used: pd.DataFrame) -> pd.DataFrame:
    """Each used trial's 95% ellipse in (x, z) around its error, as polygon rows."""
    angles = np.linspace(0.0, 2.0 * np.pi, _ELLIPSE_POINTS + 1)
    rows = []
    for _, r in used.iterrows():
        cov = np.array([[r["sigma_x"] ** 2, r["cov_xz"]], [r["cov_xz"], r["sigma_z"] ** 2]])
        if not np.isfinite(cov).all():
            continue
        vals, vecs = np.linalg.eigh(cov)
        radii = np.sqrt(np.maximum(vals, 0.0) * CHI2_95[2])
        circle = np.stack([np.cos(angles) * radii[0], np.sin(angles) * radii[1]])
        xy = (vecs @ circle).T + np.array([r["err_x"], r["err_z"]])
        rows += [
            {"trial": int(r["trial"]), "order": k, "ex": float(x), "ez": float(z)}
            for k, (x, z) in enumerate(xy)
        ]
    return pd.DataFrame(rows, columns=["trial", "order", "ex", "ez"])


def _scatter(unit_text: str, used: pd.DataFrame) -> tuple[Spec, Spec]:
    """The errors in the ground plane (x, z) with their 95% ellipses and the truth at 0."""
    ellipses = _ellipses(used) if {"sigma_x", "sigma_z", "cov_xz"} <= set(used) else None
    xs = [used["err_x"], *([ellipses["ex"]] if ellipses is not None else []), pd.Series([0.0])]
    zs = [used["err_z"], *([ellipses["ez"]] if ellipses is not None else []), pd.Series([0.0])]
    x_domain = _span(np.concatenate([np.asarray(v, dtype=np.float64) for v in xs]))
    z_domain = _span(np.concatenate([np.asarray(v, dtype=np.float64) for v in zs]))
    x_tip = {"field": "err_x", "title": f"x error ({unit_text})", "format": ".3f"}
    z_tip = {"field": "err_z", "title": f"z error ({unit_text})", "format": ".3f"}
    x = {
        "field": "sx",
        "type": "quantitative",
        "title": f"x error ({unit_text})",
        "scale": {"domain": x_domain},
    }
    z = {
        "field": "sz",
        "type": "quantitative",
        "title": f"z error ({unit_text})",
        "scale": {"domain": z_domain},
    }
    layers: list[Spec] = [
        {
            "mark": {"type": "rule", "color": "#444", "strokeDash": [4, 3]},
            "data": {"values": [{"zero": 0.0}]},
            "encoding": {"x": {"field": "zero", "type": "quantitative"}},
        },
        {
            "mark": {"type": "rule", "color": "#444", "strokeDash": [4, 3]},
            "data": {"values": [{"zero": 0.0}]},
            "encoding": {"y": {"field": "zero", "type": "quantitative"}},
        },
    ]
    if ellipses is not None and len(ellipses):
        layers.append(
            {
                "data": {"name": "ellipses"},
                "mark": {"type": "line", "strokeWidth": 1, "clip": True},
                "encoding": {
                    "x": {"field": "ex", "type": "quantitative"},
                    "y": {"field": "ez", "type": "quantitative"},
                    "order": {"field": "order"},
                    "detail": {"field": "trial"},
                    "opacity": _picked(0.9, 0.12),
                },
            }
        )
    layers.append(
        {
            "data": {"name": "trials"},
            "transform": [
                {"filter": "datum.shown == 'used'"},
                {
                    "aggregate": [
                        {"op": "mean", "field": "err_x", "as": "mean_x"},
                        {"op": "mean", "field": "err_z", "as": "mean_z"},
                    ]
                },
            ],
            "mark": {
                "type": "point",
                "shape": "M-1,-1L1,1M-1,1L1,-1",
                "size": 80,
                "color": "black",
                "strokeWidth": 2,
                "clip": True,
            },
            "encoding": {
                "x": {"field": "mean_x", "type": "quantitative"},
                "y": {"field": "mean_z", "type": "quantitative"},
                "tooltip": [
                    {"field": "mean_x", "title": f"bias x ({unit_text})", "format": ".3f"},
                    {"field": "mean_z", "title": f"bias z ({unit_text})", "format": ".3f"},
                ],
            },
        }
    )
    layers.append(
        {
            "data": {"name": "trials"},
            "transform": [{"filter": "datum.err_x != null && datum.err_z != null"}],
            "name": "scatter_points",
            "params": zoom("scatter"),
            "mark": {"type": "point", "filled": True, "size": 50, "clip": True},
            "encoding": {
                "x": x,
                "y": z,
                "shape": _shape(),
                "opacity": _picked(1.0, 0.15),
                "tooltip": [*who(), x_tip, z_tip, *error_tip(unit_text)],
            },
        }
    )
    chart = {
        "title": "Error in the ground plane, 95% ellipses; the truth at 0",
        "width": WIDTH,
        "height": _HEIGHT,
        "layer": layers,
    }
    return chart, {"ellipses": records(ellipses) if ellipses is not None else []} | {
        "domain": {"x": x_domain, "z": z_domain}
    }


def _shape() -> Spec:
    return {
        "field": "shown",
        "type": "nominal",
        "title": "drawn",
        "scale": {
            "domain": ["used", "left out (warned)", "beyond the frame, at its edge"],
            "range": ["circle", "square", "triangle-up"],
        },
    }


def who() -> list[Spec]:
    return [
        {"field": "session_name", "title": "session"},
        {"field": "trial", "title": "trial"},
    ]


def error_tip(unit_text: str) -> list[Spec]:
    return [
        {"field": "err", "title": f"error ({unit_text})", "format": ".3f"},
        {"field": "shown", "title": "drawn"},
    ]


def session_chart(
    name: str,
    trials: pd.DataFrame,
    averaging: pd.DataFrame,
    views: pd.DataFrame,
    *,
    unit_text: str,
    include_warned: bool = False,
) -> Spec | None:
    """A session's charts in one spec: its errors' scatter, its top view and its running
    averages, one colour per trial, one selection across them (``None``: nothing to draw)."""
    measured = used_trials(trials, include_warned=True, measured=True)
    if measured.empty:
        return None
    used = used_trials(measured, include_warned=include_warned, measured=True)
    table = measured.assign(session_name=name, trial=measured["trial"].astype(int))
    table["shown"] = np.where(table.index.isin(used.index), "used", "left out (warned)")
    scatter, extra = _scatter(unit_text, used if len(used) else measured)
    for axis, column in (("x", "err_x"), ("z", "err_z")):
        shown, beyond = _clamped(table[column], extra["domain"][axis])
        table[f"s{axis}"] = shown
        table.loc[beyond, "shown"] = "beyond the frame, at its edge"
    charts = [scatter]
    datasets: dict[str, Any] = {"trials": records(table), "ellipses": extra["ellipses"]}
    top = _topview(table, views, unit_text, used if len(used) else measured)
    if top is not None:
        charts.append(top[0])
        datasets |= top[1]
    running = _running(averaging, table, unit_text)
    if running is not None:
        charts += running[0]
        datasets |= running[1]
    ids = sorted(int(t) for t in table["trial"].unique())
    _colour_by_trial(charts, _trial_colour(ids))
    return {
        "datasets": datasets,
        "params": [
            {"name": PICK, "select": {"type": "point", "fields": ["trial"]}, "views": _PICK_VIEWS}
        ],
        "concat": charts,
        "columns": 2,
        "spacing": 24,
        "resolve": {
            "scale": {
                "x": "independent",
                "y": "independent",
                "color": "shared",
                "shape": "shared",
                "opacity": "independent",
            }
        },
        "config": {"view": {"stroke": "#ccc"}, "title": {"fontSize": 12}},
    }


def _colour_by_trial(charts: list[Spec], colour: Spec) -> None:
    """Every mark of a session's charts coloured by its trial (but a mark drawn in one
    colour: the truth)."""
    for chart in charts:
        for unit in chart.get("layer", [chart]):
            mark = unit["mark"]
            if not (isinstance(mark, dict) and "color" in mark):
                unit["encoding"]["color"] = colour


def _topview(
    table: pd.DataFrame, views: pd.DataFrame, unit_text: str, used: pd.DataFrame
) -> tuple[Spec, dict[str, Any]] | None:
    """The session from above: each view's camera, its sight line to the trial's estimate,
    the estimate and the truth (x, z)."""
    if views.empty or not {"t_x", "t_z"} <= set(views):
        return None
    seen = _joined(views[["trial", "pose", "t_x", "t_z"]], views, table, ["x", "z"])
    rays = pd.DataFrame(
        {
            "trial": seen["trial"].astype(int).to_numpy(),
            "pose": seen["pose"].to_numpy(),
            "t_x": seen["t_x"].to_numpy(dtype=np.float64),
            "t_z": seen["t_z"].to_numpy(dtype=np.float64),
            "x": seen["x"].to_numpy(dtype=np.float64),
            "z": seen["z"].to_numpy(dtype=np.float64),
        }
    )
    framed = rays[rays["trial"].isin(used["trial"])]
    x_domain = _span(np.concatenate([framed["t_x"], framed["x"], used["gt_x"]]))
    z_domain = _span(np.concatenate([framed["t_z"], framed["z"], used["gt_z"]]))
    x_ax = {"type": "quantitative", "title": f"x ({unit_text})", "scale": {"domain": x_domain}}
    z_ax = {
        "type": "quantitative",
        "title": f"z, depth ({unit_text})",
        "scale": {"domain": z_domain},
    }
    tips = [
        *who(),
        {"field": "x", "title": f"estimate x ({unit_text})", "format": ".3f"},
        {"field": "z", "title": f"estimate z ({unit_text})", "format": ".3f"},
        {"field": "gt_x", "title": f"truth x ({unit_text})", "format": ".3f"},
        {"field": "gt_z", "title": f"truth z ({unit_text})", "format": ".3f"},
        *error_tip(unit_text),
    ]
    layers = [
        {
            "data": {"name": "rays"},
            "mark": {"type": "rule", "strokeWidth": 1, "clip": True},
            "encoding": {
                "x": {"field": "t_x", **x_ax},
                "y": {"field": "t_z", **z_ax},
                "x2": {"field": "x"},
                "y2": {"field": "z"},
                "opacity": _picked(0.7, 0.08),
            },
        },
        {
            "data": {"name": "rays"},
            "mark": {"type": "square", "size": 30, "clip": True},
            "encoding": {
                "x": {"field": "t_x", **x_ax},
                "y": {"field": "t_z", **z_ax},
                "opacity": _picked(1.0, 0.15),
                "tooltip": [
                    {"field": "trial"},
                    {"field": "pose"},
                    {"field": "t_x", "title": f"camera x ({unit_text})", "format": ".3f"},
                    {"field": "t_z", "title": f"camera z ({unit_text})", "format": ".3f"},
                ],
            },
        },
        {
            "data": {"name": "trials"},
            "mark": {"type": "point", "shape": "cross", "size": 90, "color": "black", "clip": True},
            "encoding": {
                "x": {"field": "gt_x", **x_ax},
                "y": {"field": "gt_z", **z_ax},
                "opacity": _picked(1.0, 0.15),
                "tooltip": tips,
            },
        },
        {
            "data": {"name": "trials"},
            "params": zoom("topview"),
            "name": "topview_points",
            "mark": {"type": "point", "filled": True, "size": 50, "clip": True},
            "encoding": {
                "x": {"field": "x", **x_ax},
                "y": {"field": "z", **z_ax},
                "opacity": _picked(1.0, 0.15),
                "tooltip": tips,
            },
        },
    ]
    chart = {
        "title": "From above: cameras (squares), sight lines, estimates; truth: black cross",
        "width": WIDTH,
        "height": _HEIGHT,
        "layer": layers,
    }
    return chart, {"rays": records(rays)}


def _joined(
    rows: pd.DataFrame, keyed: pd.DataFrame, table: pd.DataFrame, columns: list[str]
) -> pd.DataFrame:
    """``rows`` (of ``keyed``, a per-view or per-frame table) with each one's trial's
    ``columns`` from ``table``, matched by trial and branch (a trial number repeated in
    another branch is another trial)."""
    keys = ["trial", *(["branch"] if "branch" in keyed and "branch" in table else [])]

    def key(t: pd.DataFrame) -> dict[str, pd.Series]:
        return {"trial": t["trial"].astype(float).astype(int).astype(str)} | {
            k: t[k].astype(str) for k in keys[1:]
        }

    left = rows.assign(**key(keyed))
    right = table[keys + columns].assign(**key(table))
    joined = left.merge(right.drop_duplicates(keys, keep="last"), on=keys, how="inner")
    return joined.assign(trial=pd.to_numeric(joined["trial"]))


def _running(
    averaging: pd.DataFrame, table: pd.DataFrame, unit_text: str
) -> tuple[list[Spec], dict[str, Any]] | None:
    """Each trial's running average's error in x and in z against its frames used."""
    if averaging.empty or averaging["n_frames"].max() <= 1:
        return None
    gt = _joined(averaging[["trial", "n_frames", "x", "z"]], averaging, table,
                 ["gt_x", "gt_z", "shown"])  # fmt: skip
    rows = pd.DataFrame(
        {
            "trial": gt["trial"].astype(int).to_numpy(),
            "n_frames": gt["n_frames"].to_numpy(),
            "ex": gt["x"].to_numpy(dtype=np.float64) - gt["gt_x"].to_numpy(np.float64),
            "ez": gt["z"].to_numpy(dtype=np.float64) - gt["gt_z"].to_numpy(np.float64),
            "used": gt["shown"].to_numpy() == "used",
        }
    )
    charts = []
    for axis in ("x", "z"):
        framed = rows.loc[rows["used"], f"e{axis}"] if rows["used"].any() else rows[f"e{axis}"]
        domain = _span(np.concatenate([framed.to_numpy(), [0.0]]))
        charts.append(
            {
                "title": f"Running average's {axis} error; the truth at 0",
                "width": WIDTH,
                "height": 160,
                "data": {"name": "running"},
                "name": f"running_{axis}",
                "transform": [
                    {
                        "calculate": f"clamp(datum.e{axis}, {domain[0]}, {domain[1]})",
                        "as": "shown_error",
                    }
                ],
                "params": zoom(f"running_{axis}"),
                "mark": {"type": "line", "point": True, "clip": True},
                "encoding": {
                    "x": {
                        "field": "n_frames",
                        "type": "quantitative",
                        "title": "frames averaged (number of)",
                    },
                    "y": {
                        "field": "shown_error",
                        "type": "quantitative",
                        "title": f"{axis} error ({unit_text})",
                        "scale": {"domain": domain},
                    },
                    "detail": {"field": "trial"},
                    "opacity": _picked(1.0, 0.12),
                    "tooltip": [
                        {"field": "trial"},
                        {"field": "n_frames", "title": "frames (number of)"},
                        {
                            "field": f"e{axis}",
                            "title": f"{axis} error ({unit_text})",
                            "format": ".3f",
                        },
                    ],
                },
            }
        )
    return charts, {"running": records(rows)}


def left_out_count(trials: pd.DataFrame) -> int:
    """Trials drawn as left out of the statistics (warned)."""
    return int(warned(trials).sum())
