"""Report: the CSV tables, one PNG per figure (:mod:`analysis.report.figures.draw`) and a
self-contained ``report.html`` that answers first: per session set and method (the
``thesis_*`` sessions first: the thesis reproduced, then ``stress_*``), then per session.
The page reads at 1280 px and at 390 px (:mod:`analysis.report.html`). (Near 600 lines:
one page, a short function per section; its words and charts live elsewhere.)"""

from __future__ import annotations

import html
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from analysis.report.answer import (
    ANSWER_COLUMNS,
    answer_table,
    number,
    readable,
    session_order,
    share,
    shown_name,
    with_branch,
)
from analysis.report.captions import overview_caption, session_caption
from analysis.report.charts import session_chart
from analysis.report.html import chart_html, chart_scripts, page_html, table_html
from analysis.report.run_charts import overview_charts, sensitivity_chart
from analysis.report.thesis import thesis_sessions
from analysis.rig.scope import rig_files_json, rig_lines
from analysis.session.metrics import (
    MIN_INTERVAL_TRIALS,
    SESSION_SETS,
    by_session_set,
    session_set,
    used_trials,
)
from analysis.tables.labels import metadata_table, readable_columns, table_units, unit_label
from analysis.tables.row_units import rows_counted, rows_word
from twopose.methods.specs import label_of, spec_of
from twopose.values import jsonsafe
from twopose.values.jsonsafe import jsonable
from twopose.values.units import UNITS, Units

if TYPE_CHECKING:
    from analysis.report.figures.cache import FigureCache
    from analysis.results import RunResult, SessionResult

__all__ = [
    "ANSWER_COLUMNS",
    "answer_table",
    "dominant_inputs",
    "page_html",
    "summary_document",
    "table_html",
    "write_outputs",
]


#: The per-trial columns the report shows (every column is in trials.csv).
REPORT_TRIAL_COLUMNS = [
    "trial",
    "branch",  # only in a session with a branch (:func:`_trial_table`)
    "status",
    "n_views",
    "x",
    "y",
    "z",
    "gt_x",
    "gt_y",
    "gt_z",
    "err_x",
    "err_y",
    "err_z",
    "err",
    *("touch", "err_uninterpolated", "skew_share"),  # a two-camera session's only
    "angle_err_deg",
    "dist_err",
    "semiaxis95",
    "within95",
    "warning",
    "reason",
    "notes",
]


def _units_of(session: SessionResult) -> Units | None:
    """A session's length unit, from its trials or, when it has none, its metadata."""
    return table_units(session.trials, session.metadata.get("units", ""))


def _trial_table(trials: pd.DataFrame) -> pd.DataFrame:
    """The report's view of a session's trials: what was measured, its error and why not;
    the line's columns only for a line session."""
    columns = [c for c in REPORT_TRIAL_COLUMNS if c in trials]
    if "branch" in trials and not trials["branch"].astype(str).ne("").any():
        columns.remove("branch")  # a session that never forked: no column of blanks
    if not any(spec_of(str(m)).estimates_line for m in trials["method"].unique()):
        columns = [c for c in columns if c not in ("angle_err_deg", "dist_err")]
    return trials[columns]


def write_outputs(
    result: RunResult,
    out_dir: Path,
    sweeps: pd.DataFrame,
    *,
    figure_cache: FigureCache | None = None,
    figures: tuple[str, ...] = (),
) -> list[str]:
    """Write the CSV tables, ``summary.json``, the sensitivity ``sweeps`` and
    ``report.html`` (its charts drawn by the reader's browser: :mod:`analysis.report.charts`) into
    ``out_dir`` (each atomically: :mod:`analysis.batch.outputs`); the names of the files written.
    With ``figures`` (formats: ``png``, ``svg``, ``pdf``; ``run --figures``), also the
    matplotlib figures in each, and ``figures.json`` (each session figure's digest): a
    session whose PNGs were not drawn by the batch is drawn here, or reused from
    ``figure_cache``."""
    from analysis.batch.outputs import write_atomically

    out_dir.mkdir(parents=True, exist_ok=True)
    tables = {
        "trials.csv": result.trials,
        "summary.csv": result.summary,
        "thesis.csv": result.thesis,
        "averaging.csv": result.averaging,
        "frames.csv": result.frames,
        "errors.csv": result.errors,
        "views.csv": result.views,
        "sensitivity.csv": sweeps,
    }
    if not result.rig.empty:  # --rig-calibration
        tables["rig.csv"] = result.rig
    for name, table in tables.items():
        csv = table.to_csv(index=False).encode("utf-8", "backslashreplace")
        write_atomically(out_dir / name, csv)
    document = jsonsafe.dumps(summary_document(result), indent=1)
    write_atomically(out_dir / "summary.json", document.encode() + b"\n")
    names = _write_figures(result, out_dir, sweeps, figure_cache, figures) if figures else []
    page = _report_html(result, sweeps).encode("utf-8", "backslashreplace")
    write_atomically(out_dir / "report.html", page)
    return [*tables, "summary.json", *names, "report.html"]


def _write_figures(
    result: RunResult,
    out_dir: Path,
    sweeps: pd.DataFrame,
    figure_cache: FigureCache | None,
    formats: tuple[str, ...],
) -> list[str]:
    """``run --figures``: the matplotlib figures as PNG (drawn by the batch, or here, or
    reused from ``figure_cache``; ``figures.json``), and in any other of ``formats``."""
    from analysis.batch.outputs import write_atomically
    from analysis.report.figures.cache import FIGURE_INDEX, FigureJob, index_document
    from analysis.report.figures.draw import figure_key, png_bytes, run_figures
    from analysis.report.figures.drawer import session_pngs
    from analysis.tools.sensitivity import plot_sensitivity

    files: dict[str, bytes] = {}
    if "png" in formats:
        digests: dict[str, str] = {}
        for i, s in enumerate(result.sessions):
            job = FigureJob.of(s, include_warned=result.include_warned)
            rendered = s.images or session_pngs(job, figure_cache)[0]
            for kind, data in rendered.items():
                files[f"{figure_key(kind, _number(s, i), s.name)}.png"] = data
                digests[f"{figure_key(kind, _number(s, i), s.name)}.png"] = job.digest()
        pngs = run_figures(result) | {"sensitivity": plot_sensitivity(sweeps)}
        files |= {f"{name}.png": png_bytes(fig) for name, fig in pngs.items()}
        files[FIGURE_INDEX] = index_document(digests)
    others = [f for f in formats if f != "png"]
    if others:
        from analysis.report.figures.draw import make_figures, saved

        drawn = make_figures(result) | {"sensitivity": plot_sensitivity(sweeps)}
        files |= {f"{n}.{f}": saved(fig, f) for n, fig in drawn.items() for f in others}
    for name, data in files.items():
        write_atomically(out_dir / name, data)
    return list(files)


def _records(table: pd.DataFrame) -> list[dict[str, object]]:
    """Rows as JSON objects (NaN and infinities as null, NumPy's scalars as Python's: the
    one encoder's rule, :func:`twopose.values.jsonsafe.jsonable`)."""
    records: list[dict[str, object]] = jsonable(table.to_dict("records"))
    return records


def summary_document(result: RunResult) -> dict[str, object]:
    """``summary.json``: the run's answer for machines (CI): versions, counts, the per-method
    table, the per-session summary (summary.csv's columns), the verdict and the failures."""
    from twopose import __version__
    from twopose.format.entries import FORMAT_VERSION

    return {
        "twopose_version": __version__,
        "format_version": FORMAT_VERSION,
        "include_warned": result.include_warned,
        "settings": result.settings,
        "n_sessions": result.n_sessions,
        "n_analysed_apart": len(result.sessions),
        "n_failed": len(result.errors),
        "n_trials": len(result.trials),
        "n_ok": int((result.trials["status"] == "ok").sum()),
        "methods": _records(answer_table(result.trials, include_warned=result.include_warned)),
        "summary": _records(result.summary),
        "verdict": result.verdict,
        "failed": _records(result.errors),
        "rig": None if result.rig_source is None else result.rig_source.to_json(),
        "rig_files": rig_files_json(result),
    }


def dominant_inputs(trials: pd.DataFrame) -> pd.DataFrame:
    """Per session, how many ok trials each input dominated, and its median share."""
    ok = trials[(trials["status"] == "ok") & (trials["dominant_input"] != "")]
    if ok.empty:
        return pd.DataFrame(columns=["session", "dominant_input", "trials", "median_share"])
    table = (
        ok.groupby(["session", "dominant_input"], sort=True)
        .agg(trials=("trial", "size"), median_share=("dominant_share", "median"))
        .reset_index()
    )
    if "label" in ok.columns:  # how the session is shown
        labels = dict(zip(ok["session"], ok["label"], strict=True))
        table.insert(1, "label", table["session"].map(labels))
    return table


def _dominant_shown(table: pd.DataFrame) -> pd.DataFrame:
    """:func:`dominant_inputs` as a reader sees it: file names, words, percent."""
    ordered = session_order(table)
    return pd.DataFrame(
        {
            "session": [shown_name(r) for _, r in ordered.iterrows()],
            "dominant input": ordered["dominant_input"],
            "trials": ordered["trials"],
            "its median share of the variance": [share(v) for v in ordered["median_share"]],
        }
    )


def _sensitivity_table(sweeps: pd.DataFrame) -> pd.DataFrame:
    """RMS error per sweep value, one column per method."""
    table = sweeps.pivot_table(
        index=["sweep", "value", "unit"], columns="method", values="rmse", sort=False
    ).reset_index()
    order = {s: i for i, s in enumerate(dict.fromkeys(sweeps["sweep"]))}
    table = table.sort_values(
        ["sweep", "value"], key=lambda c: c.map(order) if c.name == "sweep" else c
    )
    shown = readable_columns(table[["sweep", "value", "unit"]])
    for method in [c for c in table.columns if c not in ("sweep", "value", "unit")]:
        name = label_of(method)
        shown[f"RMS error, {name} (in)"] = [number(v) for v in table[method]]
    return shown


def _answer_section(result: RunResult) -> list[str]:
    """The answer per session set and method, each set's verdict against the thesis, and
    a table of contents."""
    n_ok = int((result.trials["status"] == "ok").sum())
    rows = rows_word(result.trials)  # trials; a two-camera session's touches
    which = (  # trials; a two-camera session's touches
        f"every ok {rows_word(result.trials, 'noun')} (warned ones included: --include-warned)"
        if result.include_warned
        else f"the ok {rows_word(result.trials)} without a warning (a near-degeneracy, or a "
        "pair's two copies of one recording; “warned” counts those left out; trials.csv has "
        "them all)"
    )
    inputs = _inputs_section(result)
    parts = [
        "<h1>twopose report</h1>",
        f"<p>{html.escape(result.sessions_said('analysed'))}, {len(result.errors)} failed, "
        f"{rows_counted(result.trials)}, {n_ok} ok"
        + (
            f"; {len(result.inputs_set_aside)} input(s) not analysed as given"
            if result.inputs_set_aside
            else ""
        )
        + ".</p>",
        *_inputs_line(result),
        *_rig_used(result),
        "<nav><a href='#answer'>Answer per method</a> · "
        + ("<a href='#inputs'>Inputs: failed, left out, copies</a> · " if inputs else "")
        + "<a href='#thesis'>The thesis</a> · "
        "<a href='#summary'>Per session</a> · "
        "<a href='#figures'>Overview charts</a> · "
        "<a href='#dominant'>What dominates the error</a> · "
        "<a href='#sensitivity'>Sensitivity</a> · <a href='#sessions'>Sessions</a></nav>",
        "<h2 id='answer'>Answer per method</h2>",
    ]
    groups = by_session_set(result.trials)
    verdicts = dict(result.verdicts)
    for name, group in groups:
        if len(groups) > 1:
            title = SESSION_SETS.get(name, "sessions in no set")
            parts.append(f"<h3 id='set-{name or 'other'}'>{html.escape(title)}</h3>")
        table = answer_table(group, include_warned=result.include_warned)
        units = sorted({str(u) for u in table["units"]}, key=lambda u: UNITS.index(Units(u)))
        per_unit = [table[table["units"].astype(str) == u] for u in units] or [table]
        for part in per_unit:  # a table per unit, the registry's order: its headers name it
            parts.append(table_html(readable(part, include_warned=result.include_warned)))
        parts += [f"<p class='verdict'>{html.escape(line)}</p>" for line in verdicts[name]]
    # How to read the tables comes after them, so that the numbers are on the first
    # screen of a phone too.
    parts.append(
        f"<p class='how-to-read'>Pooled over the sessions, over {which}. Errors are distances "
        "from the truth; RMSE with its 95% bootstrap interval, biases (mean error) with the "
        f"half-widths of their 95% intervals, each from {MIN_INTERVAL_TRIALS} {rows} on (from "
        "fewer, a bootstrap only reshuffles the few errors there are: none is shown, and the "
        "cell says why); the “truth inside its 95% ellipsoid” column is "
        f"the share of {rows} whose truth lies inside their own 95% uncertainty ellipsoid "
        "(95% when the uncertainty is honest). A table per unit: its “within 1” is 1 of that "
        "unit; the verdict lines count the thesis' 1 in, saying which errors they converted "
        "to inches."
        + (
            " Per session set, as the file names declare it: <code>thesis_*</code> repeat "
            "the thesis' experiments, <code>stress_*</code> go beyond them."
            if len(groups) > 1
            else ""
        )
        + "</p>"
    )
    # The inputs' lists come after the answer: it stays on the first screen whatever failed.
    return parts + inputs + _noise_section(result) + _thesis_section(result)


def _inputs_line(result: RunResult) -> list[str]:
    """One line above the answer counting the inputs that failed or were left out, with a
    link to their list (after the answer)."""
    failed, aside = len(result.errors), len(result.inputs_set_aside)
    if not (failed or aside):
        return []
    return [
        f"<p class='inputs-line err'>{failed} input(s) failed and {aside} not analysed as "
        "given (copies, board sessions, empty sessions, files named twice): "
        "<a href='#inputs'>the list, after the answer</a>.</p>"
    ]


def _noise_section(result: RunResult) -> list[str]:
    """Per session, the noise its 95% regions assumed and the trials whose poses disagree,
    after the rule applied (:func:`analysis.report.answer.noise_section`)."""
    from analysis.report.answer import noise_section

    return noise_section(result.summary, result.trials)


def _thesis_section(result: RunResult) -> list[str]:
    sessions = thesis_sessions(result.trials)["session"].nunique() if len(result.trials) else 0
    over = (
        f"the {sessions} <code>thesis_*</code> session(s)"
        if sessions < result.trials["session"].nunique()
        else "every session"
    )
    table = result.thesis
    return [
        "<h2 id='thesis'>The thesis, reproduced</h2>",
        "<p>What the thesis reported (sections 3.4, 5.3, 5.4) against this run, over "
        f"{over} (thesis.csv; errors in inches, the thesis' unit: a row that converted "
        "sessions in other units says from what).</p>",
        table_html(table, text=True),
    ]


def _overview_section(result: RunResult) -> list[str]:
    summary = session_order(result.summary)
    return [
        "<h2 id='summary'>Per session</h2>",
        "<p>As the answer, per session (every column: <code>summary.csv</code>).</p>",
        table_html(readable(summary, include_warned=result.include_warned)) if len(summary) else "",
        "<h2 id='figures'>Overview charts</h2>",
        chart_html(
            "overview",
            overview_charts(result.trials, include_warned=result.include_warned),
            overview_caption(result.trials, include_warned=result.include_warned),
        ),
    ]


def _inputs_section(result: RunResult) -> list[str]:
    """At the top: the inputs that failed, and those not analysed as given (copies counted
    once, board sessions left to `rig`, empty sessions)."""
    parts: list[str] = []
    if not result.errors.empty:
        parts += [
            "<h3>Inputs that failed</h3>",
            f"<div class='err'>{table_html(readable_columns(result.errors), text=True)}</div>",
        ]
    if result.input_notes:
        items = "".join(f"<li>{html.escape(n)}</li>" for n in result.input_notes)
        parts += ["<h3>Inputs not analysed as given</h3>", f"<ul>{items}</ul>"]
    return ["<h2 id='inputs'>Inputs</h2>", *parts] if parts else []


def _method_sections(result: RunResult, sweeps: pd.DataFrame) -> list[str]:
    return [
        "<h2 id='dominant'>What dominates the error</h2>",
        "<p>Per trial, the input whose uncertainty contributes most to the estimate's "
        "covariance (first-order propagation of the frame scatter and the typed poses' "
        "recorded 1-sigma resolution; trials.csv: <code>dominant_input</code>, "
        "<code>dominant_share</code>).</p>",
        table_html(_dominant_shown(dominant_inputs(result.trials))),
        "<h2 id='sensitivity'>Sensitivity (the thesis' geometry)</h2>",
        "<p>Seeded Monte Carlo sweeps through the solvers, one input varied at a time, in the "
        "thesis' geometry (f = 525 px, h = 9.625 in, a 1.1 in baseline along x; "
        "<code>twopose-analyze sensitivity</code>; sensitivity.csv).</p>",
        chart_html("sensitivity", sensitivity_chart(sweeps)),
        table_html(_sensitivity_table(sweeps)),
    ]


def rig_before_after(trials: pd.DataFrame, *, include_warned: bool = False) -> pd.DataFrame:
    """Per session, the RMSE and 95% coverage before and after the leave-one-out rig
    correction, over the trials the summary uses (ok, without a warning unless
    ``include_warned``) that the correction reached."""
    used = used_trials(trials, include_warned=include_warned)
    ok = used[used["err_rig"].notna()]
    rows = [
        {
            "session": session,
            "trials": len(g),
            "rmse": float(np.sqrt(np.mean(g["err"] ** 2))),
            "rmse_rig_loo": float(np.sqrt(np.mean(g["err_rig"] ** 2))),
            "coverage95": float(pd.to_numeric(g["within95"], errors="coerce").mean()),
            "coverage95_rig": float(pd.to_numeric(g["within95_rig"], errors="coerce").mean()),
            "systematic_dominant": int((g["dominant_input"] == "systematic").sum()),
        }
        for session, g in ok.groupby("session", sort=False)
    ]
    return pd.DataFrame(
        rows,
        columns=[
            "session",
            "trials",
            "rmse",
            "rmse_rig_loo",
            "coverage95",
            "coverage95_rig",
            "systematic_dominant",
        ],
    )


def _run_units(result: RunResult) -> Units | None:
    """The run's length unit when its sessions share one (None otherwise)."""
    return table_units(result.trials)


def _rig_used(result: RunResult) -> list[str]:
    """Which rig files corrected which sessions' views (and none said when none did)."""
    lines = rig_lines(result)
    if not lines:
        cameras = result.trials.get("cameras", pd.Series(1, index=result.trials.index))
        if len(cameras) and bool((cameras.astype(int) == 2).all()):
            # A pair types no view: its poses are the pair file's, never a rig file's.
            return ["<p class='rig-used'>No rig file: the poses are the pair file's.</p>"]
        return ["<p class='rig-used'>No rig file: the views are as typed.</p>"]
    return [
        f"<p class='rig-used'><strong>{html.escape(line[0].upper() + line[1:])}.</strong></p>"
        for line in lines
    ]


def _rig_section(result: RunResult) -> list[str]:
    """``--rig-calibration loo``: errors before and after, and the constants."""
    if result.rig.empty or "err_rig" not in result.trials:
        return []
    fitted = result.rig[result.rig["fitted"].astype(bool)]
    return [
        "<h2 id='rig'>The rig's constants</h2>",
        "<p>Each trial corrected by the constants its session's other trials give (leave "
        "one out: selected and fitted without it; trials.csv <code>x_rig, y_rig, z_rig, "
        "err_rig</code>), over the trials the summary uses, and the constants each "
        "session supports (rig.csv; <code>truth</code>: the simulation's).</p>",
        table_html(
            readable_columns(
                rig_before_after(result.trials, include_warned=result.include_warned),
                _run_units(result),
            )
        ),
        table_html(readable_columns(fitted if not fitted.empty else result.rig.head(0))),
    ]


def _notes(metadata: dict[str, str]) -> str:
    """The operator's notes on the session and its trials, as a list."""
    notes = [
        f"{label}: {metadata[key]}"
        for key, label in (("operator_notes", "session"), ("trial_notes", "trials"))
        if metadata.get(key)
    ]
    if not notes:
        return "<p>No operator notes.</p>"
    items = "".join(f"<li>{html.escape(n)}</li>" for n in notes)
    return f"<p>Operator notes:</p><ul>{items}</ul>"


def _number(session: SessionResult, i: int) -> int:
    """The number a session's output files carry: its place among the run's inputs."""
    return session.index if session.index >= 0 else i


def _session_sections(result: RunResult) -> list[str]:
    parts = ["<h2 id='sessions'>Sessions</h2>" if result.sessions else ""]
    rank = {name: k for k, name in enumerate([*SESSION_SETS, ""])}
    order = sorted(
        range(len(result.sessions)), key=lambda k: rank[session_set(result.sessions[k].session)]
    )
    for i in order:  # thesis_* first, as the answer; figures keep the run's numbering
        s = result.sessions[i]
        heading = with_branch(s.name, s.branch)  # a fork's branch named wherever its trials are
        parts.append(f"<h3 title='{html.escape(s.session)}'>{html.escape(heading)}</h3>")
        metadata = metadata_table(s.metadata)
        parts.append(table_html(metadata, text=True).replace("<thead>", "<thead hidden>", 1))
        parts.append(_notes(s.metadata))
        units = _units_of(s)
        caption = session_caption(s.trials, include_warned=result.include_warned, units=units)
        try:
            spec = session_chart(
                heading,
                s.trials,
                s.averaging,
                s.pose_views,
                unit_text=unit_label(units),
                include_warned=result.include_warned,
            )
        except (ValueError, KeyError, TypeError) as err:  # said, never fatal: the numbers stay
            spec, caption = None, f"This session's charts could not be drawn ({err!r})."
            parts.append(f"<p class='err'>{html.escape(caption)}</p>")
        parts.append(chart_html(f"session_{_number(s, i):02d}", spec, caption))
        rows = rows_word(s.trials).capitalize()  # a two-camera session's: touches
        parts.append(f"<p>{rows} (every column: <code>trials.csv</code>):</p>")
        parts.append(table_html(readable_columns(_trial_table(s.trials), _units_of(s))))
    return parts


def _report_html(result: RunResult, sweeps: pd.DataFrame) -> str:
    body = [
        *_answer_section(result),
        *_overview_section(result),
        *_rig_section(result),
        *_method_sections(result, sweeps),
        *_session_sections(result),
    ]
    return page_html("twopose report", body, chart_scripts())
