"""The report's figure captions: what each figure draws, which trials (the rule of
:func:`analysis.session.metrics.used_trials`, and what became of the warned ones), in which units,
and, for the figures over the run, the largest error drawn per session set and method: the
answer table's "largest" column, so that a reader can check one against the other.

Captions are HTML fragments (escaped here).
"""

from __future__ import annotations

import html

import pandas as pd

from analysis.report.plane_axes import plane_of
from analysis.report.terminal import UNIT_NAMES
from analysis.session.metrics import by_session_set, used_trials, warned
from analysis.tables.labels import MAX_LEGEND, common_units, table_units, unit_label
from analysis.tables.row_units import row_units_of, rows_word
from twopose.methods.specs import spec_of
from twopose.values.units import Units

__all__ = ["run_captions", "session_captions"]


def _which(trials: pd.DataFrame, *, include_warned: bool) -> str:
    """Which trials a run figure draws, in words."""
    n_warned = int(warned(used_trials(trials, include_warned=True)).sum())
    noun, rows = rows_word(trials, "noun"), rows_word(trials)  # trials; a pair's touches
    if include_warned:
        return f"every ok {noun}, the {n_warned} warned included (--include-warned)"
    if not n_warned:
        return f"the ok {rows} (none is warned)"
    each = rows_word(trials, "maybe_plural", joiner=" or ")
    return f"the {rows} the answer uses ({n_warned} warned {each} left out, as there)"


def largest_errors(trials: pd.DataFrame, *, include_warned: bool) -> list[tuple[str, str, float]]:
    """(set, method, largest error) over the trials a run figure draws, in its units."""
    used, _ = common_units(used_trials(trials, include_warned=include_warned, measured=True))
    out = []
    for name, group in by_session_set(used):
        for method, g in group.groupby("method", sort=True):
            out.append((name, str(method), float(g["err"].max())))
    return out


def _largest(trials: pd.DataFrame, label: str, *, include_warned: bool) -> str:
    """The largest error drawn, per set and method, marked up for a reader and a test."""
    parts: dict[str, list[str]] = {}
    for name, method, value in largest_errors(trials, include_warned=include_warned):
        cell = (
            f"{html.escape(method)} <span class='largest' data-set='{html.escape(name)}' "
            f"data-method='{html.escape(method)}'>{value:.2f}</span>"
        )
        parts.setdefault(name, []).append(cell)
    groups = [
        (f"{name}_*: " if name else "") + ", ".join(cells) + f" {html.escape(label)}"
        for name, cells in parts.items()
    ]
    if not groups:
        return "No trial drawn: none is usable, as the verdict lines say."
    return "Largest error drawn: " + "; ".join(groups) + ", as in the answer."


def run_captions(trials: pd.DataFrame, *, include_warned: bool) -> dict[str, str]:
    """The captions of the figures over the run, by figure name."""
    if trials.empty:
        return {}
    _, units = common_units(trials)
    mixed = trials["units"].nunique() > 1 if "units" in trials else False
    unit_note = f"Errors in {UNIT_NAMES.get(units, units)}" + (
        " (sessions in other units converted)" if mixed else ""
    )
    which = _which(trials, include_warned=include_warned)
    common = f"Drawn: {which}; {unit_note[0].lower()}{unit_note[1:]}."
    largest = _largest(trials, units, include_warned=include_warned)
    rows, noun = rows_word(trials), rows_word(trials, "noun", joiner=" or ")
    return {
        "error_histogram": f"{rows.capitalize()} per error bin, by method, a panel per "
        f"session set, one bin width throughout. {common} {largest}",
        "error_by_trial": f"Each {noun}'s error (log scale), a line per session; dotted: the "
        f"longest semi-axis of its 95% ellipsoid, for scale. {common} {largest}",
        "error_vs_baseline": f"Each {noun}'s error (log scale) against its baseline (the "
        f"longest distance between two of its camera centres: {_centres(trials)}), a panel "
        f"per session set. {common} {largest}",
    }


def session_captions(
    trials: pd.DataFrame, *, include_warned: bool, units: Units | None = None
) -> dict[str, str]:
    """The captions of one session's figures, by figure kind (``units``: the session's,
    when it has no trial to name them)."""
    label = html.escape(unit_label(table_units(trials) or units))
    top_view = spec_of(str(trials["method"].iloc[0])).top_view if len(trials) else "each view"
    on = plane_of(trials)  # the ground's: x and z, seen from above
    a, b = on.axis_names
    seen, axes = html.escape(on.seen_words), html.escape(on.axes_said)
    ok = used_trials(trials, include_warned=True)
    n_warned = int(warned(ok).sum())
    # a session's rows: trials; a two-camera session's touches (analysis.tables.row_units)
    noun, rows, each = (rows_word(trials, f) for f in ("noun", "plural", "maybe_plural"))
    fate = "included in the statistics" if include_warned else "left out of the statistics"
    not_ok = len(trials) - len(ok)
    skipped = f" {not_ok} {each} not ok are not drawn." if not_ok else ""
    doubt = f" {n_warned} warned {each} {{how}}, {fate}." if n_warned else ""
    key = "the legend" if ok["trial"].nunique() <= MAX_LEGEND else "the key at the right"
    colour = f" Each {noun} has one colour in all of this session's figures ({key})."
    framed = (
        ""
        if include_warned or not n_warned
        else f" The axes are framed by the {rows} the statistics use; a left-out {noun} "
        "beyond them is drawn at the edge (▲), its value under the legend."
    )
    averaged = " and ".join(u.averaged_from for u in row_units_of(trials))
    return {
        "scatter": f"Estimate minus truth in {a} and {b} ({label}) of each ok {noun}, with its "
        "95% error ellipse (about 95% of them hold the truth, the + at the origin, when the "
        f"uncertainty is honest); the x is the bias over the {rows} the statistics use."
        + colour
        + doubt.format(how="hollow, without an ellipse")
        + framed
        + skipped,
        "topview": f"Seen {seen} ({axes}, {label}): "
        f"{top_view}; the truth is drawn over them."
        + colour
        + doubt.format(how="dashed")
        + framed
        + skipped,
        "averaging": f"The error of the estimate from {averaged} "
        f"({label}), against n; zero is the truth; {a} and {b} on one scale."
        + colour
        + doubt.format(how="dashed")
        + framed
        + skipped,
    }


#: What every chart of the report lets a reader do (analysis.report.charts).
def explore(noun: str) -> str:
    """How to explore the charts, their rows called ``noun`` (trial, touch, trial or touch)."""
    return (
        f"Hover a point for its session, {noun} and values; drag or turn the wheel over a "
        "chart to zoom it, double-click to restore it."
    )


def overview_caption(trials: pd.DataFrame, *, include_warned: bool) -> str:
    """The caption of the run's overview charts (one colour per method)."""
    if trials.empty:
        return ""
    _, units = common_units(trials)
    mixed = trials["units"].nunique() > 1 if "units" in trials else False
    which = _which(trials, include_warned=include_warned)
    said = f"errors in {UNIT_NAMES.get(units, units)}" + (
        " (sessions in other units converted)" if mixed else ""
    )
    largest = _largest(trials, units, include_warned=include_warned)
    rows, noun = rows_word(trials), rows_word(trials, "noun", joiner=" or ")
    return (
        f"One colour per method on these charts. The histogram counts {rows} per error bin; "
        f"“error by trial” draws each session's {rows} as ticks on one row (log scale), the "
        f"sessions sorted by their median error; the last chart puts each {noun}'s error "
        f"against its baseline (the longest distance between two of its camera centres: "
        f"{_centres(trials)}). Drawn: {which}; {said}. {largest} {explore(noun)}"
    )


def _centres(trials: pd.DataFrame) -> str:
    """Whose camera centres a baseline is between, for the rows drawn: a trial's typed
    poses, a touch's pair of cameras."""
    said = {1: "its typed poses'", 2: "the pair's two cameras'"}
    return " or ".join(said[u.cameras] for u in row_units_of(trials))


def session_caption(
    trials: pd.DataFrame, *, include_warned: bool, units: Units | None = None
) -> str:
    """The caption of a session's charts (one colour per trial, one click picks one)."""
    captions = session_captions(trials, include_warned=include_warned, units=units)
    scatter = captions["scatter"].replace("the + at the origin", "the dashed cross at 0")
    return (
        f"{scatter} Click a {rows_word(trials, 'noun')} (a point in any chart) to pick it out "
        "in every chart of "
        f"this session; shift-click adds another, a click on empty space shows all. "
        f"{explore(rows_word(trials, 'noun'))}"
    )
