"""The report's charts as Vega-Lite specs (a session's here, the run's in
:mod:`analysis.report.run_charts`), drawn by the reader's browser from the run's own
tables (the scripts: ``analysis/report/js/``), so that a run draws no picture unless
asked (``run --figures``: :mod:`analysis.report.figures.draw`) and a reader can explore each chart.

The honesty rules are the static figures': each chart is framed by the trials the
statistics use (a point beyond the frame is drawn at its edge, as a triangle, and its
tooltip gives its real value), one colour per trial across a session's charts (per-method
colours only on the overview, which shows no trial colour), a unit on every axis and in
every tooltip, the truth drawn. A session's charts are one spec (``concat``) sharing one
selection: clicking a trial picks it out in all of them; every chart zooms (wheel, drag).
They read a session in its method's plane's two in-plane axes (:mod:`analysis.report.plane_axes`:
the ground's x and z, a wall's y and z), each chart's fields named by the axes' letters.

(Near 600 lines: a session's charts, one spec sharing one selection; the run's charts are
:mod:`analysis.report.run_charts`, the axes :mod:`analysis.report.plane_axes`.)
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from analysis.report.plane_axes import covariance_column, plane_of, with_in_plane
from analysis.session.metrics import used_trials, warned
from analysis.tables.row_units import row_units_of, rows_word
from twopose.methods.planes import ConstraintPlane
from twopose.uncertainty.propagate import CHI2_95

__all__ = ["TAB10", "Spec", "error_tip", "records", "session_chart", "who", "zoom"]

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
#: The charts a click picks a trial in (each names its unit view so; the running
#: averages' by their axes: ``running_x``, ``running_z``).
_PICK_VIEWS = ["scatter_points", "topview_points"]
_ELLIPSE_POINTS = 48
#: A chart's plotting area (px): two side by side in the report's 1200 px.
WIDTH, _HEIGHT = 300, 240


def records(table: pd.DataFrame) -> list[dict[str, Any]]:
    from twopose.values.jsonsafe import jsonable

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


def _trial_colour(trials: list[int], noun: str = "trial") -> Spec:
    """One colour per trial (a touch: its ``noun``), the session's in all its charts (the
    static figures' tab10 up to 10, a viridis ramp beyond)."""
    scale: Spec = {"domain": trials}
    if len(trials) <= len(TAB10):
        scale["range"] = TAB10[: max(len(trials), 1)]
    else:
        scale["scheme"] = "viridis"
    return {
        "field": "trial",
        "type": "ordinal" if len(trials) > len(TAB10) else "nominal",
        "scale": scale,
        "title": noun,
        "legend": {"columns": 2 if len(trials) > 10 else 1, "symbolLimit": 30},
    }


def _picked(value: float, other: float) -> Spec:
    return {"condition": {"param": PICK, "value": value, "empty": True}, "value": other}


def zoom(name: str, encodings: tuple[str, ...] = ("x", "y")) -> list[Spec]:
    """Wheel and drag zoom the chart (its scales along ``encodings``); a double-click
    restores it."""
    select = {"type": "interval", "encodings": list(encodings)}
    return [{"name": f"zoom_{name}", "select": select, "bind": "scales"}]


def _ellipses(used: pd.DataFrame, on: ConstraintPlane) -> pd.DataFrame:
    """Each used trial's 95% ellipse in the plane's axes (the ground's x and z) around its
    error, as polygon rows (``e<a>``, ``e<b>``: ``ex``, ``ez``)."""
    a, b = on.axis_names
    cov_ab = covariance_column(on)
    angles = np.linspace(0.0, 2.0 * np.pi, _ELLIPSE_POINTS + 1)
    rows = []
    for _, r in used.iterrows():
        cov = np.array([[r[f"sigma_{a}"] ** 2, r[cov_ab]], [r[cov_ab], r[f"sigma_{b}"] ** 2]])
        if not np.isfinite(cov).all():
            continue
        vals, vecs = np.linalg.eigh(cov)
        radii = np.sqrt(np.maximum(vals, 0.0) * CHI2_95[2])
        circle = np.stack([np.cos(angles) * radii[0], np.sin(angles) * radii[1]])
        xy = (vecs @ circle).T + np.array([r[f"err_{a}"], r[f"err_{b}"]])
        rows += [
            {"trial": int(r["trial"]), "order": k, f"e{a}": float(x), f"e{b}": float(z)}
            for k, (x, z) in enumerate(xy)
        ]
    return pd.DataFrame(rows, columns=["trial", "order", f"e{a}", f"e{b}"])


def _scatter(unit_text: str, used: pd.DataFrame, on: ConstraintPlane) -> tuple[Spec, Spec]:
    """The errors in the plane's axes (the ground's x and z) with their 95% ellipses and
    the truth at 0."""
    a, b = on.axis_names
    spread = {f"sigma_{a}", f"sigma_{b}", covariance_column(on)}
    ellipses = _ellipses(used, on) if spread <= set(used) else None
    xs = [
        used[f"err_{a}"],
        *([ellipses[f"e{a}"]] if ellipses is not None else []),
        pd.Series([0.0]),
    ]
    zs = [
        used[f"err_{b}"],
        *([ellipses[f"e{b}"]] if ellipses is not None else []),
        pd.Series([0.0]),
    ]
    x_domain = _span(np.concatenate([np.asarray(v, dtype=np.float64) for v in xs]))
    z_domain = _span(np.concatenate([np.asarray(v, dtype=np.float64) for v in zs]))
    x_tip = {"field": f"err_{a}", "title": f"{a} error ({unit_text})", "format": ".3f"}
    z_tip = {"field": f"err_{b}", "title": f"{b} error ({unit_text})", "format": ".3f"}
    x = {
        "field": f"s{a}",
        "type": "quantitative",
        "title": f"{a} error ({unit_text})",
        "scale": {"domain": x_domain},
    }
    z = {
        "field": f"s{b}",
        "type": "quantitative",
        "title": f"{b} error ({unit_text})",
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
                    "x": {"field": f"e{a}", "type": "quantitative"},
                    "y": {"field": f"e{b}", "type": "quantitative"},
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
                        {"op": "mean", "field": f"err_{a}", "as": f"mean_{a}"},
                        {"op": "mean", "field": f"err_{b}", "as": f"mean_{b}"},
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
                "x": {"field": f"mean_{a}", "type": "quantitative"},
                "y": {"field": f"mean_{b}", "type": "quantitative"},
                "tooltip": [
                    {"field": f"mean_{a}", "title": f"bias {a} ({unit_text})", "format": ".3f"},
                    {"field": f"mean_{b}", "title": f"bias {b} ({unit_text})", "format": ".3f"},
                ],
            },
        }
    )
    layers.append(
        {
            "data": {"name": "trials"},
            "transform": [{"filter": f"datum.err_{a} != null && datum.err_{b} != null"}],
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
        "title": f"Error in {on.name} plane, 95% ellipses; the truth at 0",
        "width": WIDTH,
        "height": _HEIGHT,
        "layer": layers,
    }
    return chart, {"ellipses": records(ellipses) if ellipses is not None else []} | {
        "domain": {a: x_domain, b: z_domain}
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
    on = plane_of(trials)  # the ground's: x and z
    measured = with_in_plane(used_trials(trials, include_warned=True, measured=True), on)
    if measured.empty:
        return None
    used = used_trials(measured, include_warned=include_warned, measured=True)
    table = measured.assign(session_name=name, trial=measured["trial"].astype(int))
    table["shown"] = np.where(table.index.isin(used.index), "used", "left out (warned)")
    scatter, extra = _scatter(unit_text, used if len(used) else measured, on)
    for axis in on.axis_names:
        shown, beyond = _clamped(table[f"err_{axis}"], extra["domain"][axis])
        table[f"s{axis}"] = shown
        table.loc[beyond, "shown"] = "beyond the frame, at its edge"
    charts = [scatter]
    datasets: dict[str, Any] = {"trials": records(table), "ellipses": extra["ellipses"]}
    top = _topview(
        table, with_in_plane(views, on, ("t_",)), unit_text, used if len(used) else measured, on
    )
    if top is not None:
        charts.append(top[0])
        datasets |= top[1]
    running = _running(with_in_plane(averaging, on, ("",)), table, unit_text, on)
    if running is not None:
        charts += running[0]
        datasets |= running[1]
    ids = sorted(int(t) for t in table["trial"].unique())
    _colour_by_trial(charts, _trial_colour(ids, rows_word(trials, "noun")))
    views_picked = [*_PICK_VIEWS, *(f"running_{axis}" for axis in on.axis_names)]
    return {
        "datasets": datasets,
        "params": [
            {"name": PICK, "select": {"type": "point", "fields": ["trial"]}, "views": views_picked}
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
    table: pd.DataFrame,
    views: pd.DataFrame,
    unit_text: str,
    used: pd.DataFrame,
    on: ConstraintPlane,
) -> tuple[Spec, dict[str, Any]] | None:
    """The session face on its plane (the ground's from above: x, z): each view's camera,
    its sight line to the trial's estimate, the estimate and the truth."""
    a, b = on.axis_names
    if views.empty or not {f"t_{a}", f"t_{b}"} <= set(views):
        return None
    seen = _joined(views[["trial", "pose", f"t_{a}", f"t_{b}"]], views, table, [a, b])
    rays = pd.DataFrame(
        {
            "trial": seen["trial"].astype(int).to_numpy(),
            "pose": seen["pose"].to_numpy(),
            f"t_{a}": seen[f"t_{a}"].to_numpy(dtype=np.float64),
            f"t_{b}": seen[f"t_{b}"].to_numpy(dtype=np.float64),
            a: seen[a].to_numpy(dtype=np.float64),
            b: seen[b].to_numpy(dtype=np.float64),
        }
    )
    framed = rays[rays["trial"].isin(used["trial"])]
    x_domain = _span(np.concatenate([framed[f"t_{a}"], framed[a], used[f"gt_{a}"]]))
    z_domain = _span(np.concatenate([framed[f"t_{b}"], framed[b], used[f"gt_{b}"]]))
    across, up = on.titles  # the ground's "x" and "z, depth"
    x_ax = {
        "type": "quantitative",
        "title": f"{across} ({unit_text})",
        "scale": {"domain": x_domain},
    }
    z_ax = {
        "type": "quantitative",
        "title": f"{up} ({unit_text})",
        "scale": {"domain": z_domain},
    }
    tips = [
        *who(),
        {"field": a, "title": f"estimate {a} ({unit_text})", "format": ".3f"},
        {"field": b, "title": f"estimate {b} ({unit_text})", "format": ".3f"},
        {"field": f"gt_{a}", "title": f"truth {a} ({unit_text})", "format": ".3f"},
        {"field": f"gt_{b}", "title": f"truth {b} ({unit_text})", "format": ".3f"},
        *error_tip(unit_text),
    ]
    layers = [
        {
            "data": {"name": "rays"},
            "mark": {"type": "rule", "strokeWidth": 1, "clip": True},
            "encoding": {
                "x": {"field": f"t_{a}", **x_ax},
                "y": {"field": f"t_{b}", **z_ax},
                "x2": {"field": a},
                "y2": {"field": b},
                "opacity": _picked(0.7, 0.08),
            },
        },
        {
            "data": {"name": "rays"},
            "mark": {"type": "square", "size": 30, "clip": True},
            "encoding": {
                "x": {"field": f"t_{a}", **x_ax},
                "y": {"field": f"t_{b}", **z_ax},
                "opacity": _picked(1.0, 0.15),
                "tooltip": [
                    {"field": "trial"},
                    {"field": "pose"},
                    {"field": f"t_{a}", "title": f"camera {a} ({unit_text})", "format": ".3f"},
                    {"field": f"t_{b}", "title": f"camera {b} ({unit_text})", "format": ".3f"},
                ],
            },
        },
        {
            "data": {"name": "trials"},
            "mark": {"type": "point", "shape": "cross", "size": 90, "color": "black", "clip": True},
            "encoding": {
                "x": {"field": f"gt_{a}", **x_ax},
                "y": {"field": f"gt_{b}", **z_ax},
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
                "x": {"field": a, **x_ax},
                "y": {"field": b, **z_ax},
                "opacity": _picked(1.0, 0.15),
                "tooltip": tips,
            },
        },
    ]
    seen_from = on.seen_words[:1].upper() + on.seen_words[1:]  # the ground's: From above
    chart = {
        "title": f"{seen_from}: cameras (squares), sight lines, estimates; truth: black cross",
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
    averaging: pd.DataFrame, table: pd.DataFrame, unit_text: str, on: ConstraintPlane
) -> tuple[list[Spec], dict[str, Any]] | None:
    """Each trial's running average's error along each in-plane axis (the ground's x and
    z) against its frames used."""
    if averaging.empty or averaging["n_frames"].max() <= 1:
        return None
    a, b = on.axis_names
    gt = _joined(averaging[["trial", "n_frames", a, b]], averaging, table,
                 [f"gt_{a}", f"gt_{b}", "shown"])  # fmt: skip
    rows = pd.DataFrame(
        {
            "trial": gt["trial"].astype(int).to_numpy(),
            "n_frames": gt["n_frames"].to_numpy(),
            **{
                f"e{axis}": gt[axis].to_numpy(dtype=np.float64)
                - gt[f"gt_{axis}"].to_numpy(np.float64)
                for axis in (a, b)
            },
            "used": gt["shown"].to_numpy() == "used",
        }
    )
    # a two-camera session's: per touch, the pair estimates nearest it (averaging.csv)
    what = " and ".join(u.averaged for u in row_units_of(averaging))
    charts = []
    for axis in (a, b):
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
                        "title": f"{what} averaged (number of)",
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
                        {"field": "trial", "title": rows_word(averaging, "noun")},
                        {"field": "n_frames", "title": f"{what} (number of)"},
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
