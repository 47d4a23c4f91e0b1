"""Which rows of a run and a baseline hold the same measurements: matched by identity.

``check`` and ``compare`` are given two run folders written from any folders, named any
way: the same session may lie at another path, its parts may be split across folders one
run read and the other did not, and the two runs may even be in different units. So rows
are matched by what they are (:mod:`twopose.format.identity`), never by path:

- a summary row is one session's strand and method: ``session_id`` names the session and
  ``trials_key`` the trials it holds (their parts and numbers);
- rows of one session and method whose trials are the same in both runs are compared as
  the two ``summary.csv`` files give them;
- where the two runs hold different trials of a session (one run read a part the other
  did not, or a fork's branches), the session is compared over the trials both hold,
  each side's statistics recomputed from its ``trials.csv`` (said in a note), and the
  baseline's trials this run lacks are a regression of their own;
- a baseline in another unit than the run is converted to the run's (said in a note).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from analysis.columns import SUMMARY_DOMAINS
from analysis.metrics import summarize
from twopose.errors import InputValueError
from twopose.methods import Method, spec_of
from twopose.units import Units, unit_spec

__all__ = ["IDENTITY_COLUMNS", "Pair", "match_rows", "require_identity", "trial_keys"]

#: The columns a summary row is matched by.
IDENTITY_COLUMNS = ("session_id", "trials_key", "units")
#: Summary columns that are lengths (converted between units); the others are counts or
#: shares.
_LENGTHS = tuple(c for c, domain in SUMMARY_DOMAINS.items() if domain in ("length", "signed"))


@dataclass(frozen=True)
class Pair:
    """One session and method as the baseline and the run hold it (either may be None)."""

    session: str  # how the output names it: the run's label (the baseline's if only there)
    method: Method
    baseline: pd.Series | None
    result: pd.Series | None
    lost: int = 0  # the baseline's trials of it this run does not hold
    notes: tuple[str, ...] = ()


def require_identity(table: pd.DataFrame, what: str, fix: str) -> None:
    """Refuse a summary without the columns rows are matched by, saying what to do."""
    if "units" not in table.columns:
        raise InputValueError(
            f"{what} has no units column: its lengths could be in any unit, so nothing can "
            f"be compared with them; {fix}"
        )
    missing = [c for c in IDENTITY_COLUMNS if c not in table.columns]
    if missing:
        raise InputValueError(
            f"{what} has no column {', '.join(missing)}: it predates session identities "
            f"(sessions are matched by what they are, not by path); {fix}"
        )


def trial_keys(trials: pd.DataFrame) -> pd.Series:
    """Each trial's identity within its session: its part and its number."""
    return trials["part"].astype(str) + ":" + trials["trial"].astype("Int64").astype(str)


def match_rows(
    result: pd.DataFrame,
    baseline: pd.DataFrame,
    trials: tuple[pd.DataFrame | None, pd.DataFrame | None],
    *,
    names: tuple[str, str],
) -> list[Pair]:
    """Every session and method of either table, paired by identity (module docstring).

    ``trials`` are the two runs' ``trials.csv`` (None when a run has none: then a session
    whose trials differ cannot be compared, and that is an error saying so).
    """
    pairs: list[Pair] = []
    old = dict(list(baseline.groupby(["session_id", "method"], sort=True)))
    new = dict(list(result.groupby(["session_id", "method"], sort=True)))
    for key in sorted(set(old) | set(new), key=lambda k: (str(k[0]), str(k[1]))):
        session_id, method = str(key[0]), spec_of(str(key[1])).method
        before, after = old.get(key), new.get(key)
        if before is None or after is None:
            shown = _label(after if after is not None else before)
            pairs.append(
                Pair(
                    session=shown,
                    method=method,
                    baseline=None if before is None else before.iloc[0],
                    result=None if after is None else after.iloc[0],
                )
            )
            continue
        if sorted(before["trials_key"]) == sorted(after["trials_key"]):
            pairs += _same_trials(before, after, method)
        else:
            pairs.append(_common_trials(session_id, method, after, trials, names))
    return pairs


def _label(rows: pd.DataFrame | None) -> str:
    assert rows is not None
    column = "label" if "label" in rows.columns else "session"
    return ", ".join(str(v) for v in rows[column])


def _same_trials(before: pd.DataFrame, after: pd.DataFrame, method: Method) -> list[Pair]:
    """Rows holding the same trials: each pair as the two summaries give them."""
    by_key = {str(r["trials_key"]): r for _, r in before.iterrows()}
    pairs = []
    for _, row in after.iterrows():
        old, notes = _in_units_of(by_key[str(row["trials_key"])], unit_spec(row["units"]).units)
        pairs.append(
            Pair(session=_label(after.loc[[row.name]]), method=method, baseline=old, result=row,
                 notes=notes)
        )  # fmt: skip
    return pairs


def _in_units_of(row: pd.Series, units: Units) -> tuple[pd.Series, tuple[str, ...]]:
    """``row``'s lengths in ``units`` (with a note when they were converted)."""
    own = unit_spec(row["units"]).units
    if own == units:
        return row, ()
    factor = unit_spec(own).inches / unit_spec(units).inches
    converted = row.copy()
    for column in _LENGTHS:
        if column in converted.index:
            converted[column] = pd.to_numeric(converted[column], errors="coerce") * factor
    converted["units"] = units
    return converted, (f"the baseline's lengths converted from {own} to {units} (x {factor:g})",)


def _common_trials(
    session_id: str,
    method: Method,
    after: pd.DataFrame,
    trials: tuple[pd.DataFrame | None, pd.DataFrame | None],
    names: tuple[str, str],
) -> Pair:
    """A session whose trials differ between the runs: compared over those both hold."""
    label = _label(after)
    tables = []
    for table, name in zip(trials, names, strict=True):
        if table is None or not {"session_id", "part"} <= set(table.columns):
            raise InputValueError(
                f"{label} ({method}) holds different trials in {names[1]} and {names[0]}, and "
                f"{name} has no trials.csv with session identities to compare the trials both "
                "hold: give the folders of two finished runs of this twopose"
            )
        rows = table[(table["session_id"].astype(str) == session_id) & (table["method"] == method)]
        tables.append(rows.assign(_key=trial_keys(rows)))
    run_trials, base_trials = tables
    common = sorted(set(run_trials["_key"]) & set(base_trials["_key"]))
    lost = len(set(base_trials["_key"]) - set(run_trials["_key"]))
    sides = []
    for rows in (base_trials, run_trials):
        held = rows[rows["_key"].isin(common)].drop(columns="_key").assign(session=session_id)
        # The same rule on each side: warned trials left out, as a run's summary does.
        summary = summarize(held)
        sides.append(summary.iloc[0] if len(summary) else None)
    old, new = sides
    notes = [
        f"{label} ({method}): the runs hold different trials of this session (the baseline "
        f"{len(base_trials)}, this run {len(run_trials)}): compared over the {len(common)} "
        "both hold, each side's statistics recomputed from its trials.csv"
    ]
    if old is not None and new is not None:
        old, said = _in_units_of(old, unit_spec(new["units"]).units)
        notes += said
    return Pair(session=label, method=method, baseline=old, result=new, lost=lost,
                notes=tuple(notes))  # fmt: skip


def run_trials(folder: str | Path) -> pd.DataFrame | None:
    """A run folder's ``trials.csv`` as the matching needs it, or None when it has none."""
    from analysis.run_tables import read_results_table

    if not (Path(folder) / "trials.csv").is_file():
        return None
    return read_results_table(folder, "trials.csv", key=("session", "method", "trial"))
