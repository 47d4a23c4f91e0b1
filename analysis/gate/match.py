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
- a baseline in another unit than the run is converted to the run's (said in a note);
- where both runs have their ``trials.csv``, each pair says which trials the run's
  statistics left out that the baseline's used (a trial warned or failed since), and
  which are warned now and were not: ``check`` holds ``n_used`` and ``n_warned`` to
  these, trial by trial, so that a trial swapped for another is seen too.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from analysis.session.metrics import summarize, used_trials, warned
from analysis.tables.columns import SUMMARY_DOMAINS
from analysis.tables.row_units import row_unit
from twopose.errors import InputValueError
from twopose.methods.specs import Method, spec_of
from twopose.values.units import Units, unit_spec

__all__ = [
    "IDENTITY_COLUMNS",
    "Pair",
    "TrialChanges",
    "match_rows",
    "require_identity",
    "trial_keys",
]

#: The columns a summary row is matched by.
IDENTITY_COLUMNS = ("session_id", "trials_key", "units")
#: Summary columns that are lengths (converted between units); the others are counts or
#: shares.
_LENGTHS = tuple(c for c, domain in SUMMARY_DOMAINS.items() if domain in ("length", "signed"))


@dataclass(frozen=True)
class TrialChanges:
    """The trials of a pair whose use changed between the runs, each in words
    (``trial 3 (parallax 3.81 deg < 5)``), over the trials both runs hold."""

    #: used by the baseline's statistics, left out of the run's (warned or failed since)
    left_out: tuple[str, ...] = ()
    #: ok in both, warned in the run and not in the baseline
    newly_warned: tuple[str, ...] = ()


@dataclass(frozen=True)
class Pair:
    """One session and method as the baseline and the run hold it (either may be None)."""

    session: str  # how the output names it: the run's label (the baseline's if only there)
    method: Method
    baseline: pd.Series | None
    result: pd.Series | None
    lost: int = 0  # the baseline's trials of it this run does not hold
    notes: tuple[str, ...] = ()
    #: which trials' use changed (None: a run has no trials.csv, so only counts compare)
    changes: TrialChanges | None = None


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
            pairs += _same_trials(before, after, method, trials)
        else:
            pairs.append(_common_trials(session_id, method, (after, before), trials, names))
    return pairs


def _includes_warned(rows: pd.DataFrame) -> bool:
    """Whether a run's summary rows used their warned trials (``run --include-warned``):
    a row with warned trials that used every ok one. (A row with none is the same
    either way.)"""
    n_warned, n_used, n_ok = (pd.to_numeric(rows[c], errors="coerce") for c in SUMMARY_COUNTS)
    return bool(((n_warned > 0) & (n_used == n_ok)).any())


#: The counts :func:`_includes_warned` reads.
SUMMARY_COUNTS = ("n_warned", "n_used", "n_ok")


def _why_left_out(trial: pd.Series) -> str:
    """A trial the statistics do not use, and why: its status, else its warning."""
    name = row_unit(trial.get("cameras", 1)).numbered(trial)  # a touch: "trial 2, touch 1"
    if str(trial.get("branch", "") or ""):
        name += f" of branch {trial['branch']}"
    if trial["status"] != "ok":
        reason = str(trial.get("reason", "") or "")
        return f"{name} ({trial['status']}{': ' + reason if reason else ''})"
    return f"{name} ({trial['warning']})"


def trial_changes(
    run: pd.DataFrame, base: pd.DataFrame, include_warned: tuple[bool, bool]
) -> TrialChanges:
    """Which of the trials both ``run`` and ``base`` (one session's rows of each run's
    ``trials.csv``) hold changed their use: left out of the run's statistics and used by
    the baseline's, or warned in the run and not in the baseline (both ok)."""
    run, base = (t.assign(_key=trial_keys(t)).set_index("_key") for t in (run, base))
    both = run.index.intersection(base.index)
    run, base = run.loc[both], base.loc[both]
    used_run = set(used_trials(run, include_warned=include_warned[0]).index)
    used_base = set(used_trials(base, include_warned=include_warned[1]).index)
    ok_both = (run["status"] == "ok") & (base["status"] == "ok")
    newly = run.index[ok_both & warned(run) & ~warned(base)]
    order = run.sort_values("trial", kind="stable").index
    return TrialChanges(
        left_out=tuple(_why_left_out(run.loc[k]) for k in order if k in used_base - used_run),
        newly_warned=tuple(_why_left_out(run.loc[k]) for k in order if k in set(newly)),
    )


def _session_rows(
    table: pd.DataFrame | None, row: pd.Series, method: Method
) -> pd.DataFrame | None:
    """One summary row's trials in its run's ``trials.csv`` (its ``session`` and method);
    None when that table does not hold them all (a run without one, or a summary and a
    trials.csv that do not agree: then only the counts are compared, never nothing)."""
    if table is None or not {"part", "status"} <= set(table.columns):
        return None
    mine = (table["session"].astype(str) == str(row["session"])) & (table["method"] == method)
    rows: pd.DataFrame = table[mine]
    return rows if len(rows) == pd.to_numeric(row["n_trials"], errors="coerce") else None


def _label(rows: pd.DataFrame | None) -> str:
    assert rows is not None
    column = "label" if "label" in rows.columns else "session"
    return ", ".join(str(v) for v in rows[column])


def _same_trials(
    before: pd.DataFrame,
    after: pd.DataFrame,
    method: Method,
    trials: tuple[pd.DataFrame | None, pd.DataFrame | None],
) -> list[Pair]:
    """Rows holding the same trials: each pair as the two summaries give them, with the
    trials whose use changed when both runs' trials are known."""
    by_key = {str(r["trials_key"]): r for _, r in before.iterrows()}
    include = (_includes_warned(after), _includes_warned(before))
    pairs = []
    for _, row in after.iterrows():
        base_row = by_key[str(row["trials_key"])]
        old, notes = _in_units_of(base_row, unit_spec(row["units"]).units)
        held = (_session_rows(trials[0], row, method), _session_rows(trials[1], base_row, method))
        changes = (
            trial_changes(held[0], held[1], include)
            if held[0] is not None and held[1] is not None
            else None
        )
        pairs.append(
            Pair(session=_label(after.loc[[row.name]]), method=method, baseline=old, result=row,
                 notes=notes, changes=changes)
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
    rows: tuple[pd.DataFrame, pd.DataFrame],
    trials: tuple[pd.DataFrame | None, pd.DataFrame | None],
    names: tuple[str, str],
) -> Pair:
    """A session whose trials differ between the runs: compared over those both hold
    (``rows``: its summary rows in the run and in the baseline)."""
    label = _label(rows[0])
    include = (_includes_warned(rows[0]), _includes_warned(rows[1]))
    tables = []
    for table, name in zip(trials, names, strict=True):
        if table is None or not {"session_id", "part"} <= set(table.columns):
            raise InputValueError(
                f"{label} ({method}) holds different trials in {names[1]} and {names[0]}, and "
                f"{name} has no trials.csv with session identities to compare the trials both "
                "hold: give the folders of two finished runs of this twopose"
            )
        mine = table[(table["session_id"].astype(str) == session_id) & (table["method"] == method)]
        tables.append(mine.assign(_key=trial_keys(mine)))
    run_trials, base_trials = tables
    common = sorted(set(run_trials["_key"]) & set(base_trials["_key"]))
    lost = len(set(base_trials["_key"]) - set(run_trials["_key"]))
    sides, held = [], []
    for table, included in ((base_trials, include[1]), (run_trials, include[0])):
        held.append(table[table["_key"].isin(common)].drop(columns="_key"))
        # Each side's own rule for warned trials, as its run's summary applied it.
        summary = summarize(held[-1].assign(session=session_id), include_warned=included)
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
                notes=tuple(notes), changes=trial_changes(held[1], held[0], include))  # fmt: skip


def run_trials(folder: str | Path) -> pd.DataFrame | None:
    """A run folder's ``trials.csv`` as the matching needs it, or None when it has none."""
    from analysis.tables.read_back import read_results_table

    if not (Path(folder) / "trials.csv").is_file():
        return None
    return read_results_table(folder, "trials.csv", key=("session", "method", "trial"))
