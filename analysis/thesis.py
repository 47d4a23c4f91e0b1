"""The thesis' reported figures set against what a run reproduces (``thesis.csv``, the
report's "The thesis, reproduced").

Four claims (sections 3.4, 5.3 and 5.4): method 1 within ±1 in; method 2 within ±1 in,
with x overestimated (a bias); a 0.1 in x-translation error moving x by up to about
0.2 in; and 50 frames averaged instead of 5 improving the estimate by about 1%. Each row
is computed from the run's trials of that method (errors converted to inches), from the
sensitivity model, or from the running averages of trials with 50 frames or more per pose.

When a run holds sessions of the ``thesis`` set (``thesis_*.mcap``,
:data:`analysis.metrics.SESSION_SETS`), the table is over those alone: the thesis'
experiments, not the stress sessions beside them. The verdict lines are per set.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from analysis.metrics import by_session_set, session_set, used_trials
from twopose.format.entries import INCHES_PER_UNIT
from twopose.methods import METHOD_SPECS, Method

__all__ = ["THESIS_COLUMNS", "fisher_p", "thesis_sessions", "thesis_table", "thesis_verdict"]

THESIS_COLUMNS = ["claim", "thesis", "twopose", "reproduced"]

_WITHIN_IN = 1.0  # the thesis' "within ± 1 inch"
_AVERAGES = (5, 50)  # section 5.4: five averages against fifty


def thesis_table(
    trials: pd.DataFrame, averaging: pd.DataFrame, *, include_warned: bool = False
) -> pd.DataFrame:
    """One row per claim: ``claim``, what the ``thesis`` reported, what ``twopose``
    measured here and whether that ``reproduced`` it (``yes``, ``no``, or ``no data``);
    over :func:`thesis_sessions`."""
    trials, averaging = thesis_sessions(trials), thesis_sessions(averaging)
    used = _used(trials, include_warned=include_warned)
    rows = [
        _within_row(used, "point", "method 1 (fixed point) errors", "within ±1 in"),
        _method2_row(used),
        _x_translation_row(),
        _averaging_row(trials, averaging),
    ]
    table: pd.DataFrame = pd.DataFrame(rows, columns=THESIS_COLUMNS)
    return table


# The thesis tested methods 1 and 2, not the line.
_THESIS_NAME = {str(m): METHOD_SPECS[m].thesis_name for m in (Method.POINT, Method.GROUND)}


def thesis_sessions(table: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``table`` from sessions of the ``thesis`` set, if the run has any;
    otherwise every row (a run of other sessions is set against the thesis as a whole)."""
    if "session" not in table or table.empty:
        return table
    mine = table["session"].map(session_set) == "thesis"
    picked: pd.DataFrame = table[mine] if mine.any() else table
    return picked


def thesis_verdict(trials: pd.DataFrame, *, include_warned: bool = False) -> list[str]:
    """One line per method set against the thesis' figure (errors within 1 in): how many
    of the trials the summary uses are within it, and so whether twopose reproduces it;
    per session set (``thesis_*`` first) when the run has more than one."""
    lines = []
    groups = by_session_set(trials)
    for name, group in groups:
        prefix = f"{name}_*: " if name else ("other sessions: " if len(groups) > 1 else "")
        for method, g in _used(group, include_warned=include_warned).groupby("method", sort=True):
            lines.append(prefix + _verdict(str(method), g))
    return lines


def _verdict(method: str, g: pd.DataFrame) -> str:
    """The thesis table's rule in a line: all within 1 in, as the thesis; or some not,
    consistent with its 15 of 15 (Fisher's exact test, p > 0.05) or not."""
    n_in, counts = _within(g)
    name = _THESIS_NAME.get(method)
    if name is None:
        return f"{method}: {counts}; the thesis did not test this method."
    if n_in == len(g):
        return f"{method} ({name}): {counts}; reproduced: the thesis reports all within 1 in."
    p_value = fisher_p(n_in, len(g))
    agrees = "consistent with" if p_value > 0.05 else "unlike"
    return f"{method} ({name}): {counts}; {agrees} the thesis' 15 of 15 (Fisher p = {p_value:.2f})."


def _used(trials: pd.DataFrame, *, include_warned: bool) -> pd.DataFrame:
    """The trials the statistics use (:func:`analysis.metrics.used_trials`) with a known
    error, in inches (``err_in``, ``err_x_in``)."""
    used = used_trials(trials, include_warned=include_warned, measured=True)
    scale = used["units"].map(INCHES_PER_UNIT).astype(float)
    inches: pd.DataFrame = used.assign(err_in=used["err"] * scale, err_x_in=used["err_x"] * scale)
    return inches


def _within(g: pd.DataFrame) -> tuple[int, str]:
    n_in = int((g["err_in"] <= _WITHIN_IN).sum())
    return n_in, f"{n_in} of {len(g)} trials within 1 in (largest {g['err_in'].max():.2f} in)"


_THESIS_TRIALS = 15  # each of its experiments: 15 trials, every one within 1 in


def fisher_p(k: int, n: int, k_ref: int = _THESIS_TRIALS, n_ref: int = _THESIS_TRIALS) -> float:
    """Two-sided Fisher exact test that ``k`` of ``n`` and ``k_ref`` of ``n_ref`` come from
    one proportion (the hypergeometric tables as or less likely than the one observed)."""
    total, hits = n + n_ref, k + k_ref

    def p(a: int) -> float:
        return math.comb(n, a) * math.comb(n_ref, hits - a) / math.comb(total, hits)

    observed = p(k)
    tables = range(max(0, hits - n_ref), min(n, hits) + 1)
    return min(1.0, sum(p(a) for a in tables if p(a) <= observed * (1 + 1e-9)))


def _within_row(used: pd.DataFrame, method: str, claim: str, reported: str) -> dict[str, str]:
    """All within 1 in: yes; some not, but consistent with the thesis' 15 of 15 (Fisher's
    exact test, p > 0.05): consistent; else no."""
    g = used[used["method"] == method]
    if g.empty:
        return {"claim": claim, "thesis": reported, "twopose": "no trials", "reproduced": "no data"}
    n_in, text = _within(g)
    if n_in == len(g):
        verdict = "yes"
    else:
        p_value = fisher_p(n_in, len(g))
        text += f"; against the thesis' 15 of 15, Fisher p = {p_value:.2f}"
        verdict = "consistent" if p_value > 0.05 else "no"
    return {"claim": claim, "thesis": reported, "twopose": text, "reproduced": verdict}


def _method2_row(used: pd.DataFrame) -> dict[str, str]:
    """Within ±1 in, and the x bias: the mean x error with its 95% t-interval."""
    from analysis.metrics import t95

    row = _within_row(
        used, "ground", "method 2 (pointed ground point) errors", "within ±1 in, x overestimated"
    )
    g = used[used["method"] == "ground"]
    if len(g) < 2:
        return row
    ex = g["err_x_in"].to_numpy(dtype=np.float64)
    half = t95(len(ex) - 1) * ex.std(ddof=1) / np.sqrt(len(ex))
    bias = float(ex.mean())
    significant = abs(bias) > half
    row["twopose"] += f"; x bias {bias:+.2f} ± {half:.2f} in (95%)" + (
        "" if significant else ", not significant"
    )
    if row["reproduced"] in ("yes", "consistent") and not (significant and bias > 0):
        row["reproduced"] = f"errors {row['reproduced']}, x bias no"
    return row


def _x_translation_row() -> dict[str, str]:
    from analysis.sensitivity import worst_x_translation_effect, x_translation_effect

    ours = x_translation_effect()
    worst, tilt, azimuth = worst_x_translation_effect()
    return {
        "claim": "a 0.1 in x-translation error moves method 2's x by",
        "thesis": "up to about 0.2 in",
        "twopose": f"{ours:.2f} in with our finger; at most {worst:.2f} in over finger "
        f"orientations (tilt {tilt:g}°, azimuth {azimuth:g}°)",
        "reproduced": _x_translation_verdict(ours, worst),
    }


def _x_translation_verdict(ours: float, worst: float) -> str:
    """The thesis gives a bound ("up to about 0.2 in") for a finger whose orientation it
    does not record: it holds if our finger stays under it, fully if every orientation
    does."""
    if ours > 0.25:
        return "no"
    return "yes" if worst <= 0.25 else "for our finger; not every orientation"


def _averaging_row(trials: pd.DataFrame, averaging: pd.DataFrame) -> dict[str, str]:
    """50 against 5 frames: the change of each trial's x and z error as a share of the
    target's distance, averaged over the trials averaged over 50 frames or more."""
    claim = "averaging 50 frames per pose instead of 5 improves the estimate by"
    few, many = _AVERAGES
    long = averaging.groupby(["session", "trial"])["n_frames"].transform("max") >= many
    picked = averaging[long & averaging["n_frames"].isin(_AVERAGES)]
    truth = trials.drop_duplicates(["session", "trial"], keep="last").set_index(
        ["session", "trial"]
    )[["gt_x", "gt_y", "gt_z"]]
    table = picked.join(truth, on=["session", "trial"])
    if table.empty:
        return {
            "claim": claim,
            "thesis": "about 1%",
            "twopose": "no trial with 50 frames",
            "reproduced": "no data",
        }
    error = table[["x", "y", "z"]].to_numpy() - table[["gt_x", "gt_y", "gt_z"]].to_numpy()
    distance = np.linalg.norm(table[["gt_x", "gt_y", "gt_z"]].to_numpy(dtype=np.float64), axis=1)
    share = pd.DataFrame(
        np.abs(error[:, [0, 2]]) / distance[:, None] * 100.0, columns=["x", "z"], index=table.index
    ).assign(session=table["session"], trial=table["trial"], n=table["n_frames"])
    wide = share.pivot_table(index=["session", "trial"], columns="n", values=["x", "z"])
    diff = (wide.xs(few, axis=1, level=1) - wide.xs(many, axis=1, level=1)).to_numpy()
    gain_x, gain_z = (float(v) for v in np.nanmean(diff, axis=0))
    text = (
        f"x {gain_x:+.2f}%, z {gain_z:+.2f}% of the target's distance from the origin "
        f"({len(wide)} trials)"
    )
    small = abs(gain_x) <= 2.0 and abs(gain_z) <= 2.0
    return {
        "claim": claim,
        "thesis": "about 1%",
        "twopose": text,
        "reproduced": "yes" if small else "no",
    }
