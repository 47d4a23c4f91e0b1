"""What a run says about the noise its regions assumed (issue 54): per session, the
placing sigma and where it came from, sigma0's test and the multiplier taken
(:func:`analysis.report.answer.noise_phrases`), and every trial whose poses disagree, named with
the words the recorder says live (:meth:`twopose.uncertainty.blunders.TrialTests.words`, kept in
``trials.csv``'s ``disagreement``); the report's section explains the rule applied.
"""

from __future__ import annotations

import html

import pandas as pd

from analysis.report.answer import noise_phrases, session_order, shown_name
from twopose.uncertainty.blunders import EXPLAINS_LEVEL, TARGET_LEVEL, TRUTH_LEVEL
from twopose.uncertainty.noise import FACTOR_TEST_LEVEL, MIN_PLACING_DOF, TYPED_PRIOR_DOF
from twopose.uncertainty.placing_variance import BAARDA_LEVEL

__all__ = ["RULE", "flagged_lines", "noise_section"]

#: The rule the regions' noise follows, as the report explains it (docs/uncertainty.md).
RULE = (
    "Each trial's 95% region propagates the frames' scatter, the calibration's 1-sigma and "
    "the operator's placing sigma: each pose's typed resolution, or the one a board session "
    "measured (<code>run --rig</code>). That sigma is neither taken on trust nor kept because "
    "a test did not reject it: its multiplier (the placing variance over the one assumed) is "
    "always estimated, from the misclosures of the trials with redundant poses (how far each "
    "trial's views disagree with its own estimate, evaluated where the adjusted inputs "
    "agree), shrunk toward the same operator's other sessions of the run (same operator, same "
    f"method), with the typed resolution as a weak prior of {TYPED_PRIOR_DOF:g} degrees of "
    "freedom (or the board's measurement on its own). Every region is propagated with the "
    "placing sigma times the multiplier's square root and widened by Fisher's F on the "
    "degrees of freedom it rests on; with fewer than "
    f"{MIN_PLACING_DOF} beside the prior, nothing is estimated and the typed sigma stands. "
    "Before any pooling each trial is tested against the typed model and against the rest "
    f"(Baarda's global test at {BAARDA_LEVEL:.1%}): a trial both reject is flagged (its "
    "poses disagree), kept out of the pool and its own region widened by its own misfit; in "
    "a session whose trials measured one target (the same recorded truth), a trial whose "
    "estimate lies off the others' weighted mean (a chi-square test on its region's "
    f"dimensions at {TARGET_LEVEL:.1%}) is flagged too: a typed value its own poses cannot "
    "check; a trial whose reported point lies outside its own region far from the grid point "
    "recorded as its truth (its NEES beyond the chi-square's upper "
    f"{TRUTH_LEVEL:.1%} quantile on the region's dimensions, after the multiplier) is flagged "
    "too: one of its typed poses, the grid point or the detection is off; it is kept out of "
    "the session's pool but its region is not widened, and every flagged trial stays in the error "
    "statistics (rmse, bias, within 1). A trial without a truth has only the other tests. A "
    "pose is named when it alone, one typed component corrected, would make the trial agree "
    f"({EXPLAINS_LEVEL:.0%}). sigma0, the unflagged trials' misclosure under the typed model, "
    f'is said by its own chi-square test at {FACTOR_TEST_LEVEL:.0%}: "contradict" in its '
    'upper tail, "scatter less" in its lower tail, "agree" otherwise on at least '
    f"{MIN_PLACING_DOF} degrees of freedom; the test decides nothing, the estimate is used "
    "either way."
)


def flagged_lines(trials: pd.DataFrame, session: str) -> list[str]:
    """The session's flagged trials, each as ``trial 3 (by its misclosure): this trial's
    poses disagree (...)``, which test flagged it in brackets (``flagged_by``)."""
    if "flagged" not in trials or trials.empty:
        return []
    flags = trials["flagged"].fillna(value=False).astype(bool)
    mine = trials[(trials["session"] == session) & flags]
    return [f"trial {int(r['trial'])}{_by(r)}: {r['disagreement']}" for _, r in mine.iterrows()]


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
    return [
        "<h3 id='noise'>The noise model the regions assumed</h3>",
        f"<p>{RULE} (docs/uncertainty.md)</p>",
        f"<ul class='noise'>{''.join(items)}</ul>",
    ]
