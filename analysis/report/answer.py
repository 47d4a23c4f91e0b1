"""The run's answer per method: the numbers (``summary.json``'s ``methods``) and the table a
reader sees (human labels, units in the headers, two decimals as the console prints them,
shares in percent), per session set (``thesis_*`` first, then ``stress_*``,
:data:`analysis.session.metrics.SESSION_SETS`) when the run has more than one.

And what that answer assumed, per session, as the terminal and the report both say it
(issue 54): the placing sigma and where it came from, sigma0's test and the multiplier
taken (:func:`noise_phrases`), every trial whose poses disagree, named with the words the
recorder says live (:meth:`twopose.uncertainty.blunders.TrialTests.words`, kept in
``trials.csv``'s ``disagreement``: :func:`flagged_lines`), and the report's section that
explains the rule applied (:func:`noise_section`, :data:`RULE`).
"""

from __future__ import annotations

import html
import math
import re
from pathlib import Path

import pandas as pd

from analysis.session.metrics import (
    MIN_INTERVAL_TRIALS,
    by_session_set,
    summarize,
    too_few_for_interval,
)
from analysis.tables.row_units import row_unit, rows_word
from twopose.methods.specs import label_of
from twopose.uncertainty.blunders import EXPLAINS_LEVEL, TRUTH_LEVEL
from twopose.uncertainty.noise import (
    FACTOR_TEST_LEVEL,
    MIN_PLACING_DOF,
    OPERATOR_DATA,
    TYPED_PRIOR_DOF,
)
from twopose.uncertainty.robust_flags import BAARDA_LEVEL

__all__ = [
    "ANSWER_COLUMNS",
    "RULE",
    "answer_table",
    "cameras_said",
    "flagged_lines",
    "noise_phrases",
    "noise_section",
    "number",
    "off_truth_notes",
    "readable",
    "session_order",
    "share",
    "shown_name",
    "skew_phrases",
    "strand_names",
    "two_cameras",
    "with_branch",
]

ANSWER_COLUMNS = [
    "set",
    "method",
    "units",
    "cameras",
    "n_trials",
    "n_ok",
    "n_warned",
    "n_used",
    "rmse",
    "rmse_ci95_low",
    "rmse_ci95_high",
    "median_err",
    "max_err",
    "bias_x",
    "bias_x_ci95",
    "bias_z",
    "bias_z_ci95",
    "coverage95",
    "within_1",
]


def answer_table(trials: pd.DataFrame, *, include_warned: bool = False) -> pd.DataFrame:
    """Per session set, method and units, pooled over the sessions: the report's first
    table (``set``: ``thesis``, ``stress``, or ``""`` for one group or no set)."""
    if trials.empty:
        return pd.DataFrame(columns=ANSWER_COLUMNS)
    parts = []
    for name, group in by_session_set(trials):
        # one-camera trials and two-camera touches are never pooled (``cameras``)
        pooled = group.assign(session="all (" + group["units"].astype(str) + ")")
        if "cameras" in group:
            pooled["session"] += group["cameras"].astype(str)
        parts.append(summarize(pooled, include_warned=include_warned).assign(set=name))
    table: pd.DataFrame = pd.concat(parts, ignore_index=True)[ANSWER_COLUMNS]
    return table


def session_order(summary: pd.DataFrame) -> pd.DataFrame:
    """``summary``'s rows with the sessions of each set together, in the sets' order."""
    if summary.empty:
        return summary
    groups = by_session_set(summary)
    ordered: pd.DataFrame = pd.concat([g for _, g in groups]) if len(groups) > 1 else summary
    return ordered


def shown_name(row: pd.Series) -> str:
    """How a reader is shown a row's session: its label (the shortest tail of its path
    that no other input of the run shares), or, in a table without one, its file name;
    with its branch when it is on one (a fork's: ``a3.mcap [branch B]``, as ``info``
    shows it)."""
    label = str(row.get("label", "") or "") or Path(str(row["session"])).name
    return with_branch(label, str(row.get("branch", "") or ""))


def with_branch(name: str, branch: str) -> str:
    """A session's name with the branch it is on, when it is on one."""
    return f"{name} [branch {branch}]" if branch else name


def strand_names(trials: pd.DataFrame) -> pd.Series:
    """Each trial's session as a reader is shown it (a chart's row, a figure's legend):
    its label with the branch its session's trials end on (:func:`with_branch`), as the
    report's tables name it. Over every trial of the run: a subset (the used trials) may
    not hold its strand's last."""
    label = (
        trials["label"] if "label" in trials else trials["session"].map(lambda s: Path(str(s)).name)
    )
    if "branch" not in trials or trials.empty:
        return label.astype(str)
    last = trials.groupby("session", sort=False)["branch"].transform("last")
    names = [with_branch(str(n), str(b)) for n, b in zip(label, last, strict=True)]
    return pd.Series(names, index=trials.index, dtype="str")


def two_cameras(row: pd.Series) -> bool:
    """Whether a ``summary.csv`` row (or a trial's) is a two-camera session's touches."""
    return bool(row.get("cameras", 1) == 2)


def cameras_said(row: pd.Series) -> str:
    """``, two cameras, per touch`` after a two-camera session's method (else nothing)."""
    return ", two cameras, per touch" if two_cameras(row) else ""


def skew_phrases(row: pd.Series) -> list[str]:
    """A two-camera session's skew in words (a ``summary.csv`` row): the RMSE with camera
    1's paired frame taken as it is, and the share of it interpolation removed."""
    raw = _known(row.get("rmse_uninterpolated"))
    if not math.isfinite(raw):
        return ["skew not measured (no touch with an estimate both ways)"]
    return [
        f"rmse {number(raw)} {row['units']} without interpolating camera 1,",
        f"skew's share {share(row.get('skew_share'))}",
    ]


def noise_phrases(row: pd.Series) -> list[str]:
    """A session's noise model in words (a ``summary.csv`` row): the placing sigma its
    regions assumed and where it came from, and sigma0's test with the multiplier taken
    (:func:`twopose.uncertainty.noise_words.noise_words`, the one home of these words);
    none for a table from before these columns. The terminal and the report say these."""
    from twopose.uncertainty.noise_words import noise_words

    if "sigma0_dof" not in row or pd.isna(row["sigma0_dof"]):
        return []
    if row_unit(row.get("cameras", 1)).cameras == 2:  # a pair's touches: no pose is typed
        return []
    sigma = row.get("placing_sigma", math.nan)
    said = str(row.get("placing_source", "") or "typed")
    source = said.split(", times ")[0]
    estimated = _ESTIMATED_FROM.search(said)
    widening = _known(row.get("noise_widening"))
    sigma0 = _known(row.get("sigma0"))
    words = noise_words(
        sigma0,
        int(row["sigma0_dof"]),
        math.sqrt(widening) if widening > 0 else math.nan,
        placing_scale=_known(row.get("placing_scale")),
        placing_dof=_known(row.get("placing_dof")),
        flagged=int(_known(row.get("n_flagged"), 0.0)),
        sources=estimated.group(1) if estimated else "",
        with_flagged=(_known(row.get("sigma0_all")), int(_known(row.get("sigma0_all_dof"), 0.0))),
        against="the board's sigma" if source.startswith("measured by") else "typed",
        board_contradicted="(contradicted by the data" in said,
        by_operator=f"(contradicted by the data {OPERATOR_DATA})" in said,
        placing_share=_known(row.get("sigma0_placing_share"), 1.0),
        off_truth=int(_known(row.get("n_off_truth"), 0.0)),
    )
    scale = _known(row.get("placing_scale"))
    start = sigma / scale if isinstance(sigma, int | float) and scale > 0 else sigma  # assumed
    phrases = [f"placing sigma {_sig(start)} {row['units']} {source};", *_phrases(words)]
    floor = row.get("floor_unmeasured", "")  # a camera of another image size ("": none)
    if not isinstance(floor, str) or not floor:
        return phrases
    return [*phrases[:-1], phrases[-1] + ";", *floor.split(" ")]


def _phrases(words: str) -> list[str]:
    """``words`` in phrases a terminal may break between: a number kept with the words
    either side of it (``sigma0 1.55 on``, ``50 dof``, ``p < 0.001``), never cut from them."""
    phrases: list[str] = []
    glued = False  # the last token was a number or a relation: the next one stays with it
    for token in words.split(" "):
        number = bool(_NUMBER.fullmatch(token))
        if phrases and (number or glued):
            phrases[-1] += " " + token
        else:
            phrases.append(token)
        glued = number or token in ("=", "<", "p", "(p")
    return phrases


#: ``placing_source``'s "..., times 1.2 (estimated from ...)": where the multiplier came from.
_ESTIMATED_FROM = re.compile(r", times \S+ \(estimated from (.*)\)$")
_NUMBER = re.compile(r"[(]?x?[-+]?[0-9][0-9.]*(x|%)?[),;:]*")


def _known(value: object, default: float = math.nan) -> float:
    """A number from a table's cell (``default`` when it holds none)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
        return default
    return float(value)


def _sig(value: object) -> str:
    """Three significant digits (1/16 in reads 0.0625), ``-`` when unknown."""
    if not isinstance(value, int | float) or math.isnan(value):
        return "-"
    return f"{value:.3g}"


def number(value: object, *, signed: bool = False) -> str:
    """Two decimals (``-`` when unknown): the report's answer and the console alike."""
    if not isinstance(value, int | float) or math.isnan(value):
        return "-"
    value = round(value, 2) + 0.0  # -0.001 reads +0.00, not -0.00
    return f"{value:+.2f}" if signed else f"{value:.2f}"


def share(value: object) -> str:
    """A share in whole percent (``-`` when unknown)."""
    if not isinstance(value, int | float) or math.isnan(value):
        return "-"
    return f"{100 * value:.0f}%"


def _interval(low: object, high: object, n_used: int, cameras: object = 1) -> str:
    """An interval, or why there is none (too few trials, or a two-camera session's
    touches: :data:`MIN_INTERVAL_TRIALS`)."""
    if number(low) != "-":
        return f"{number(low)} to {number(high)}"
    unit = row_unit(cameras)
    few = too_few_for_interval(n_used, unit.noun, unit.plural)
    return f"none ({few})" if 0 < n_used < MIN_INTERVAL_TRIALS else "-"


def _plus_minus(value: object, half: object, n_used: int) -> str:
    if number(half) != "-":
        return f"{number(value, signed=True)} ± {number(half)}"
    if number(value) != "-" and n_used < MIN_INTERVAL_TRIALS:  # why: the RMSE's cell
        return f"{number(value, signed=True)} (no interval)"
    return number(value, signed=True)


#: The share within 1 unit, its header naming the unit (``within 1 cm``: 1 cm, not the
#: thesis' 1 in, which the verdict lines count), or the rows' own in a mixed table.
_WITHIN, _WITHIN_MIXED = "within 1 {}", "within 1 (the row's units)"


def readable(table: pd.DataFrame, *, include_warned: bool = False) -> pd.DataFrame:
    """An answer table or a summary (``summary.csv``'s columns) as a reader sees it: labels
    in words, the units in the headers (a ``units`` column when they differ), lengths with
    two decimals, biases with their 95% half-widths, shares in percent; the errors first
    (what a phone shows without scrolling), the counts last."""
    units = sorted({str(u) for u in table["units"]})
    one = units[0] if len(units) == 1 else ""
    u = f" ({one})" if one else ""
    rows = []
    counted = rows_word(table)  # trials; a two-camera session's touches; or both
    for _, r in table.iterrows():
        row: dict[str, object] = {}
        if "session" in table:
            row["session"] = shown_name(r)
        row["method"] = label_of(r["method"]) + cameras_said(r)
        if not one:
            row["units"] = r["units"]
        n_used = int(r["n_used"])
        row |= {
            f"RMSE{u}": number(r["rmse"]),
            f"RMSE 95% interval{u}": _interval(
                r["rmse_ci95_low"], r["rmse_ci95_high"], n_used, r.get("cameras", 1)
            ),
            f"median{u}": number(r["median_err"]),
            f"largest{u}": number(r["max_err"]),
            _WITHIN.format(one) if one else _WITHIN_MIXED: share(r["within_1"]),
            f"bias x ± 95%{u}": _plus_minus(r["bias_x"], r["bias_x_ci95"], n_used),
            f"bias z ± 95%{u}": _plus_minus(r["bias_z"], r["bias_z_ci95"], n_used),
            "truth inside its 95% ellipsoid": share(r["coverage95"]),
            counted: r["n_trials"],
            "ok": r["n_ok"],
            "warned (included)" if include_warned else "warned (left out)": r["n_warned"],
            "used": r["n_used"],
        }
        rows.append(row)
    return pd.DataFrame(rows)


#: The rule the regions' noise follows, as the report explains it (docs/uncertainty.md).
RULE = (
    "Each trial's 95% region propagates the frames' scatter, the calibration's 1-sigma and "
    "the operator's placing sigma: each pose's typed resolution, or the one a board session "
    "measured (<code>run --rig</code>). That sigma is neither taken on trust nor kept because "
    "a test did not reject it: its multiplier (the placing variance over the one assumed) is "
    "always estimated, from the misclosures of the trials with redundant poses (how far each "
    "trial's views disagree with its own estimate, evaluated where the adjusted inputs "
    "agree) and, in a session whose trials measured one target, from their estimates' "
    "scatter about each other (their contrasts, as a misclosure), shrunk toward the same "
    "operator's other sessions of the run (same operator, same "
    f"method), with the typed resolution as a weak prior of {TYPED_PRIOR_DOF:g} degrees of "
    "freedom where the session has no such other sessions (they supersede it), or the "
    "board's measurement on its own. Every region is propagated with the "
    "placing sigma times the multiplier's square root and widened by Fisher's F on the "
    "degrees of freedom it rests on; with fewer than "
    f"{MIN_PLACING_DOF} beside the prior, nothing is estimated and the typed sigma stands. "
    "Before any pooling each trial is tested against the typed model and against the rest "
    f"(Baarda's global test at {BAARDA_LEVEL:.1%}), on its whole misclosure and, where "
    "part of it is the pixels' alone (a line's or method 2's from three poses), on the "
    "directions a typed pose can move: a trial both reject on either is flagged (its "
    "poses disagree), kept out of the pool and its own region widened by its own misfit; in "
    "a session whose trials measured one target (the same recorded truth), a trial whose "
    "estimate lies off the others' weighted mean (a test on its region's dimensions, at the "
    f"multiplier the others measure, at {BAARDA_LEVEL:.1%}) is flagged too and left out of "
    "the scatter: a typed value its own poses cannot "
    "check; a trial whose reported point lies outside its own region far from the grid point "
    "recorded as its truth (its NEES beyond the chi-square's upper "
    f"{TRUTH_LEVEL:.1%} quantile on the region's dimensions, after the multiplier) is flagged "
    "too: one of its typed poses, the grid point or the detection is off; it is kept out of "
    "the session's pool but its region is not widened, and every flagged trial stays in the error "
    "statistics (rmse, bias, within 1). A trial flagged by its estimate or its truth lies in "
    "no other trial's rest: the misclosures' test is made again without it. A trial without "
    "a truth has only the other tests. A "
    "pose is named when it alone, one typed component corrected, would make the trial agree "
    f"({EXPLAINS_LEVEL:.0%}), from a fourth pose on. sigma0, the unflagged trials' "
    "misclosure under the typed model, "
    f'is said by its own chi-square test at {FACTOR_TEST_LEVEL:.0%}: "contradict" in its '
    'upper tail, "scatter less" in its lower tail, "agree" otherwise on at least '
    f"{MIN_PLACING_DOF} degrees of freedom; where it rejects the typed model with the "
    'flagged trials\' misclosures and not without them, both are said, never "agree" alone: '
    "if the flagged trials are not blunders, the operator places worse than typed. The test "
    "decides nothing, the estimate is used either way."
)


def flagged_lines(trials: pd.DataFrame, session: str) -> list[str]:
    """The session's flagged trials, each as ``trial 3 (by its misclosure): this trial's
    poses disagree (...)`` (a touch: ``trial 1, touch 2 (by its truth): ...``), which test
    flagged it in brackets (``flagged_by``)."""
    if "flagged" not in trials or trials.empty:
        return []
    flags = trials["flagged"].fillna(value=False).astype(bool)
    mine = trials[(trials["session"] == session) & flags]
    return [
        f"{row_unit(r.get('cameras', 1)).numbered(r)}{_by(r)}: {r['disagreement']}"
        for _, r in mine.iterrows()
    ]


def touch_warnings(trials: pd.DataFrame, session: str) -> list[str]:
    """A two-camera session's warnings on its ok touches, each once, as ``4 of 4 touches:
    <words>``: what voids them is the session's (two copies of one recording, a pair file
    not these cameras'), and the terminal says it, not ``trials.csv`` alone (a new user's
    r8 F8). A one-camera trial's warnings (its margins) stay in ``trials.csv``."""
    if "warning" not in trials or trials.empty:
        return []
    mine = trials[(trials["session"] == session) & (trials.get("cameras", 1) == 2)]
    ok = mine[mine["status"] == "ok"]
    said = ok["warning"].fillna("").astype(str)
    return [
        f"{int((said == words).sum())} of {len(ok)} touches: {words}"
        for words in dict.fromkeys(w for w in said if w)
    ]


def _by(row: pd.Series) -> str:
    """`` (by its truth)``: which test flagged the trial, as ``flagged_by`` says it."""
    by = row.get("flagged_by")
    return f" (by {_BY.get(str(by), str(by))})" if isinstance(by, str) and by else ""


#: ``flagged_by``'s values as the lines say them.
_BY = {"misclosure": "its misclosure", "other trials": "the other trials", "truth": "its truth"}


def noise_section(summary: pd.DataFrame, trials: pd.DataFrame) -> list[str]:
    """The report's section: the rule, then per session its noise and flagged trials."""
    items = []
    for _, r in session_order(summary).iterrows():
        said = noise_phrases(r)
        if not said:
            continue
        flagged = "".join(
            f"<li class='flagged'>{html.escape(line)}</li>"
            for line in flagged_lines(trials, str(r["session"]))
        )
        items.append(
            f"<li><b>{html.escape(shown_name(r))}</b>: {html.escape(' '.join(said))}"
            + (f"<ul>{flagged}</ul>" if flagged else "")
            + "</li>"
        )
    if not items:
        return []
    # what more trials off their truths than chance says of the run, before the rule's
    # long explanation, where a reader sees it
    notes = [
        f"<p class='off-truth'><b>note:</b> {html.escape(said)}</p>"
        for said in off_truth_notes(trials)
    ]
    return [
        "<h3 id='noise'>The noise model the regions assumed</h3>",
        *notes,
        f"<p>{RULE} (docs/uncertainty.md)</p>",
        f"<ul class='noise'>{''.join(items)}</ul>",
    ]


#: A run's trials off their truths said when this unlikely by chance (each 1 in 1000).
_OFF_TRUTH_P = 0.01


def off_truth_notes(trials: pd.DataFrame) -> list[str]:
    """Per method, the run's trials flagged by their truth, where more than chance makes
    them (a binomial tail at :data:`_OFF_TRUTH_P`, each 1 in 1000), as the terminal's
    ``note:`` lines and the report's noise section say it: one or two a session, a rig's
    unknown constants go unsaid by every session line (a new user's r6 G10: 10 of 48
    trials over 12 sessions, regions covering 35%, every line "agree")."""
    from twopose.uncertainty.noise_words import off_truth_words

    if "flagged_by" not in trials or "nees_dof" not in trials:
        return []
    notes: list[str] = []
    ok = trials[(trials["status"] == "ok") & (pd.to_numeric(trials["nees_dof"]) > 0)]
    for method, part in ok.groupby("method", sort=False):
        off = int((part["flagged_by"] == "truth").sum())
        if off >= 2 and _at_least(off, len(part), TRUTH_LEVEL) < _OFF_TRUTH_P:
            notes.append(f"{method}: {off_truth_words(off, len(part))}")
    return notes


def _at_least(k: int, n: int, p: float) -> float:
    """A binomial's upper tail ``P(X >= k)`` on ``n`` trials of chance ``p`` (by its terms:
    the report imports no estimation library, so that a re-run from the cache stays light)."""
    below = sum(math.comb(n, i) * p**i * (1 - p) ** (n - i) for i in range(min(k, n + 1)))
    return max(0.0, 1.0 - below)
