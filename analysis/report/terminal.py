"""The run's answer as terminal text: readable in an 80-column terminal and in a CI log.

A per-method table (pooled over the sessions, per session set when the run has more than
one: ``thesis_*`` first, and per units: its share "within 1" names the unit, ``≤1 cm``)
that fits 80 columns, then one line per session, wrapped at the terminal's width when
printing to a terminal and left whole when piped (a log or a file keeps every number on
its line); the run ends with one verdict line per method against the thesis (in inches,
the thesis' unit: a line that converted errors says from what; a method with no usable
trial says so) and the path of ``report.html``.

The biases are each method's along its plane's two in-plane axes
(:attr:`twopose.methods.specs.MethodSpec.seen_on`: the ground's x and z, a wall's y and z), and
named so: a per-method table repeats its header above the methods whose axes differ.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pandas as pd

from analysis.report.answer import (
    flagged_lines,
    noise_phrases,
    off_truth_notes,
    session_order,
    shown_name,
    skew_phrases,
    touch_warnings,
    two_cameras,
)
from analysis.report.answer import number as _num
from analysis.report.answer import share as _share
from analysis.report.plane_axes import with_in_plane
from analysis.session.metrics import SESSION_SETS, by_session_set, summarize
from analysis.tables.row_units import rows_word
from twopose.methods.planes import ConstraintPlane
from twopose.methods.specs import spec_of
from twopose.values.units import UNIT_SPECS, Units, unit_spec

__all__ = ["UNIT_NAMES", "closing_lines", "summary_lines", "wrap_phrases"]

UNIT_NAMES = {str(u): spec.name for u, spec in UNIT_SPECS.items()}


def _header(unit: Units, axes: tuple[str, str], rows: str = "trials") -> str:
    """A per-method table's header; its count names its ``rows`` (``trials``; a two-camera
    block's ``touches``: :mod:`analysis.tables.row_units`); its biases name the in-plane
    ``axes`` of the methods below it (``bias x``, ``bias z``); its last column, the share
    within 1 ``unit``, names it (``≤1 cm``: 1 cm, not the thesis' 1 in, which the verdict
    lines count)."""
    within = f"≤1 {unit}"
    bias_a, bias_b = (f"bias {a}" for a in axes)
    return (
        f"{'method':<7}{'sessions':>8}{rows:>8}{'ok':>4}{'warned':>7}"
        f"{'rmse':>7}{'median':>7}{'max':>7}{bias_a:>7}{bias_b:>7}{within:>6}"
    )


def _biases(row: pd.Series, on: ConstraintPlane) -> tuple[float, float]:
    """A summary row's bias along each in-plane axis of ``on`` (its ``bias_x`` and
    ``bias_z`` for the ground)."""
    r = with_in_plane(row.to_frame().T, on, ("bias_",)).iloc[0]
    a, b = on.axis_names
    return r[f"bias_{a}"], r[f"bias_{b}"]


def _units_name(units: Units) -> str:
    return unit_spec(units).name


def summary_lines(
    trials: pd.DataFrame,
    summary: pd.DataFrame,
    *,
    include_warned: bool = False,
    width: int | None = 80,
) -> list[str]:
    """The console summary: per-method tables (one per session set and units: no number
    ever pools two units), then per-session lines with their units, wrapped at ``width``
    (None: never wrapped, for pipes)."""
    if summary.empty:
        return []
    which = (
        f"every ok {rows_word(trials, 'noun')}"
        if include_warned
        else f"ok {rows_word(trials)} without a warning"
    )
    lines = [f"per method, over {which}:"]
    groups = by_session_set(trials)
    for name, group in groups:
        keys = ["units", "cameras"] if "cameras" in group else ["units"]
        for (units, *cameras), part in group.groupby(keys, sort=False):
            where = f"{SESSION_SETS.get(name, 'sessions in no set')}, " if len(groups) > 1 else ""
            if cameras == [2]:  # never pooled with one-camera trials
                where += "two-camera sessions, one row per touch, "
            title = f"{where}errors in {_units_name(Units(str(units)))}:"
            lines += wrap_phrases(title.split(" "), width)
            lines += _method_rows(
                part, summary, Units(str(units)), rows_word(part), include_warned=include_warned
            )
    lines += _off_truth_lines(trials, width)
    lines.append("per session:")
    for _, r in session_order(summary).iterrows():
        on = spec_of(str(r["method"])).seen_on
        (a, bias_a), (b, bias_b) = zip(on.axis_names, _biases(r, on), strict=True)
        pair = two_cameras(r)  # a two-camera session: its rows are touches
        phrases = [
            f"{shown_name(r)} ({r['method']}, {r['units']}"
            + (", two cameras, per touch):" if pair else "):"),
            f"{r['n_ok']}/{r['n_trials']} ok,",
            f"{r['n_warned']} warned;",
            f"rmse {_num(r['rmse'])},",
            f"median {_num(r['median_err'])},",
            f"max {_num(r['max_err'])},",
            f"bias {a} {_num(bias_a, signed=True)} {b} {_num(bias_b, signed=True)},",
            f"within 1 {r['units']}: {_share(r['within_1'])}",
        ]
        noise = skew_phrases(r) if pair else noise_phrases(r)
        if noise:  # the noise model its regions assumed (twopose.uncertainty.noise)
            phrases = [*phrases[:-1], phrases[-1] + ";", *noise]
        lines += wrap_phrases(phrases, width, indent="  ")
        for flagged in flagged_lines(trials, str(r["session"])):  # poses that disagree
            lines += wrap_phrases(["flagged:", *flagged.split(" ")], width, indent="    ")
        for warned in touch_warnings(trials, str(r["session"])):  # a pair's: why warned
            lines += wrap_phrases(["warned:", *warned.split(" ")], width, indent="    ")
    return lines


def _method_rows(
    part: pd.DataFrame, summary: pd.DataFrame, units: Units, rows: str, *, include_warned: bool
) -> list[str]:
    """The per-method table over ``part``'s trials (one set, one units): one row per
    method, under a header naming its plane's axes (the methods on the same axes together,
    under one header)."""
    pooled = summarize(part.assign(session="all"), include_warned=include_warned)
    mine = summary[summary["session"].isin(set(part["session"]))]
    # Sessions, not rows: a fork's branches are one session (so is a session whose middle
    # part is missing, analysed in two rows).
    key = "session_id" if "session_id" in mine else "session"
    sessions = mine.groupby("method")[key].nunique()
    by_axes: dict[tuple[str, str], list[str]] = {}
    for _, r in pooled.iterrows():
        on = spec_of(str(r["method"])).seen_on
        bias_a, bias_b = _biases(r, on)
        by_axes.setdefault(on.axis_names, []).append(
            f"{r['method']!s:<7}{sessions.get(r['method'], 0):>8}{r['n_trials']:>8}"
            f"{r['n_ok']:>4}{r['n_warned']:>7}{_num(r['rmse']):>7}"
            f"{_num(r['median_err']):>7}{_num(r['max_err']):>7}"
            f"{_num(bias_a, signed=True):>7}{_num(bias_b, signed=True):>7}"
            f"{_share(r['within_1']):>6}"
        )
    return [line for axes, each in by_axes.items() for line in [_header(units, axes, rows), *each]]


_KEEP = "\x00"  # joins the words of a phrase: textwrap only breaks at real whitespace


def wrap_phrases(phrases: list[str], width: int | None, indent: str = "") -> list[str]:
    """``phrases`` joined by spaces on one line (``width`` None: a pipe), or wrapped at
    ``width`` between phrases, never inside one (``rmse`` stays beside its number)."""
    if width is None:
        return [indent + " ".join(phrases)]
    text = " ".join(p.replace(" ", _KEEP) for p in phrases)
    wrapped = textwrap.wrap(
        text, width, initial_indent=indent, subsequent_indent=indent + "  ",
        break_long_words=False, break_on_hyphens=False,
    )  # fmt: skip
    return [line.replace(_KEEP, " ") for line in wrapped]


def closing_lines(verdict: list[str], out: Path, *, width: int | None = 80) -> list[str]:
    """The run's last lines: one verdict per method against the thesis (per session set,
    ``thesis_*`` first: :attr:`analysis.results.RunResult.verdict`; in inches, each line
    saying which errors it converted, a method with no usable trial saying so), then
    where ``report.html`` is (when it was written)."""
    lines = []
    for line in verdict:
        lines += wrap_phrases(["verdict:", *line.split(" ")], width)
    report = out / "report.html"
    if report.is_file():
        lines.append(f"report: {report}")
    return lines


def _off_truth_lines(trials: pd.DataFrame, width: int | None) -> list[str]:
    """The run's trials off their truths per method, where more than chance makes them
    (:func:`analysis.report.answer.off_truth_notes`), as ``note:`` lines."""
    lines: list[str] = []
    for said in off_truth_notes(trials):
        lines += wrap_phrases(f"note: {said}".split(" "), width)
    return lines
