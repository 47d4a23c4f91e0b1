"""The run's charts as Vega-Lite specs (:mod:`analysis.report.charts` says how and why): the
overview over every session (one colour per method, no trial colour on that screen) and
the sensitivity sweeps. The overview alone colours by method: a method's colour as the
browser names it is here (:func:`hex_colour`)."""

from __future__ import annotations

import json

import pandas as pd

from analysis.report.answer import strand_names
from analysis.report.charts import TAB10, WIDTH, Spec, error_tip, records, who, zoom
from analysis.session.metrics import by_session_set, session_set, used_trials
from analysis.tables.row_units import rows_word
from twopose.methods.specs import Method, label_of, spec_of

__all__ = ["hex_colour", "overview_charts", "sensitivity_chart"]


def hex_colour(colour: str) -> str:
    """A method's colour (matplotlib's cycle name, ``C0``-``C9``; the registry's
    :attr:`~twopose.methods.specs.MethodSpec.colour`) as the browser names it.

    Read from :data:`~analysis.report.charts.TAB10` (the default cycle), not by matplotlib,
    which a run that draws no figure never imports; any other name is matplotlib's to read.
    """
    if len(colour) == 2 and colour[0] == "C" and colour[1].isdigit():
        return TAB10[int(colour[1])]
    from matplotlib.colors import to_hex

    return str(to_hex(colour))


def overview_charts(trials: pd.DataFrame, *, include_warned: bool = False) -> Spec | None:
    """The run's overview, one colour per method (no trial colour on this screen): the
    error histogram (a panel per session set, as the static figure), each session's trials
    as a strip sorted by error, the error against the baseline (a shape per session set)."""
    from analysis.tables.labels import common_units

    used, units = common_units(used_trials(trials, include_warned=include_warned, measured=True))
    if used.empty:
        return None
    methods = sorted(Method(m) for m in used["method"].unique())
    table = used.assign(
        session_name=strand_names(trials).loc[used.index],
        set=used["session"].map(lambda s: session_set(s) or "no set"),
        method=used["method"].astype(str),
        trial=used["trial"].astype(int),
    )
    colour = method_colours(methods)
    tips = [*who(), {"field": "method"}, *error_tip(units)[:1]]
    order = table.groupby("session_name")["err"].median().sort_values().index.tolist()
    top = float(table["err"].max())
    positive = table["err"][table["err"] > 0]
    low = float(positive.min()) / 1.5 if len(positive) else top / 100
    charts: list[Spec] = [
        {
            "title": f"Error per {rows_word(used, 'noun', joiner=' or ')} (histogram)",
            "width": WIDTH,
            "height": 180,
            "mark": "bar",
            "encoding": {
                "x": {
                    "field": "err",
                    "bin": {"maxbins": 20, "extent": [0, top]},
                    "title": f"error ({units})",
                },
                "y": {"aggregate": "count", "title": f"number of {rows_word(used)}"},
                "color": colour,
                "tooltip": [
                    {
                        "field": "err",
                        "bin": {"maxbins": 20, "extent": [0, top]},
                        "title": f"error ({units})",
                    },
                    {"aggregate": "count", "title": f"number of {rows_word(used)}"},
                ],
            },
        },
        {
            "title": "Error by trial: each session a row, sorted by its median",
            "width": WIDTH,
            "height": {"step": 16},
            "params": zoom("by_trial", ("x",)),
            "mark": {"type": "tick", "thickness": 2, "clip": True},
            "encoding": {
                "x": {
                    "field": "err",
                    "type": "quantitative",
                    "title": f"error ({units}, log scale)",
                    "scale": {"type": "log", "domain": [low, top * 1.5]},
                },
                "y": {
                    "field": "session_name",
                    "type": "nominal",
                    "title": "session",
                    "sort": order,
                },
                "color": colour,
                "tooltip": tips,
            },
        },
        {
            "title": "Error against baseline",
            "width": WIDTH,
            "height": 180,
            "transform": [{"filter": "datum.baseline != null"}],
            "params": zoom("baseline"),
            "mark": {"type": "point", "filled": True, "clip": True},
            "encoding": {
                "x": {"field": "baseline", "type": "quantitative", "title": f"baseline ({units})"},
                "y": {
                    "field": "err",
                    "type": "quantitative",
                    "title": f"error ({units}, log scale)",
                    "scale": {"type": "log", "domain": [low, top * 1.5]},
                },
                "color": colour,
                "tooltip": [
                    *tips,
                    {"field": "baseline", "title": f"baseline ({units})", "format": ".3f"},
                ],
            },
        },
    ]
    if len(by_session_set(table)) > 1:  # a histogram panel per set; shapes tell them apart
        charts[0]["encoding"]["row"] = {"field": "set", "type": "nominal", "title": "session set"}
        charts[0]["height"] = 120
        charts[2]["encoding"]["shape"] = {"field": "set", "type": "nominal", "title": "session set"}
    return {
        "data": {"values": records(table[_OVERVIEW_COLUMNS])},
        "concat": charts,
        "columns": 2,
        "spacing": 24,
        "resolve": {"scale": {"x": "independent", "y": "independent"}},
    }


_OVERVIEW_COLUMNS = ["session_name", "set", "method", "trial", "err", "baseline"]


def method_colours(methods: list[Method]) -> Spec:
    """The colour encoding of a chart over methods: each method's registry colour, its
    legend naming each by its label (:attr:`~twopose.methods.specs.MethodSpec.label`)."""
    return {
        "field": "method",
        "type": "nominal",
        "title": "method",
        "scale": {
            "domain": [str(m) for m in methods],
            "range": [hex_colour(spec_of(m).colour) for m in methods],
        },
        "legend": {"labelExpr": _labels_expression(methods)},
    }


def _labels_expression(methods: list[Method]) -> str:
    """A Vega expression naming a legend's entry (``datum.label``, a method's name) by its
    method's label."""
    expression = "datum.label"
    for m in reversed(methods):
        expression = (
            f"datum.label === {json.dumps(str(m))} ? {json.dumps(label_of(m))} : {expression}"
        )
    return expression


def sensitivity_chart(sweeps: pd.DataFrame) -> Spec | None:
    """The RMS error against each swept input, one chart per sweep (its own unit), one
    colour per method."""
    if sweeps.empty:
        return None
    methods = sorted(Method(m) for m in sweeps["method"].unique())
    colour = method_colours(methods)
    charts: list[Spec] = []
    for sweep, g in sweeps.groupby("sweep", sort=False):
        unit = str(g["unit"].iloc[0])
        charts.append(
            {
                "title": str(sweep),
                "width": 220,
                "height": 150,
                "data": {
                    "values": records(
                        g[["method", "value", "rmse", "n_ok"]].astype({"method": str})
                    )
                },
                "params": zoom(f"sweep_{len(charts)}"),
                "mark": {"type": "line", "point": True},
                "encoding": {
                    "x": {"field": "value", "type": "quantitative", "title": f"{sweep} ({unit})"},
                    "y": {"field": "rmse", "type": "quantitative", "title": "RMS error (in)"},
                    "color": colour,
                    "tooltip": [
                        {"field": "method"},
                        {"field": "value", "title": f"{sweep} ({unit})"},
                        {"field": "rmse", "title": "RMS error (in)", "format": ".3f"},
                    ],
                },
            }
        )
    return {"concat": charts, "columns": 3, "spacing": 20}
