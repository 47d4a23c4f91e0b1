"""Metrics: estimates against ground truth, as tidy tables (one row per trial / session).

Vectors are ``x, y, z`` columns in the grid frame and the session's units.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pandas as pd

from analysis.tables.columns import SUMMARY_COLUMNS, typed

__all__ = [
    "MIN_INTERVAL_TRIALS",
    "SESSION_SETS",
    "by_session_set",
    "noise_summary",
    "paired_difference",
    "session_set",
    "skew_summary",
    "summarize",
    "t95",
    "too_few_for_interval",
    "used_trials",
    "warned",
]


def warned(trials: pd.DataFrame) -> pd.Series:
    """Which trials carry a near-degeneracy warning (part of :func:`used_trials`' rule)."""
    if "warning" not in trials:
        return pd.Series(data=False, index=trials.index)
    # A column read back from a CSV with no warning at all is float NaN: not a warning.
    text = trials["warning"].astype(object).where(trials["warning"].notna(), "")
    return text.astype(str) != ""


def used_trials(
    trials: pd.DataFrame, *, include_warned: bool = False, measured: bool = False
) -> pd.DataFrame:
    """The trials the statistics use: ok, and without a warning unless ``include_warned``;
    with ``measured``, only those whose error is known and finite (what a figure can draw).

    The one rule: the summary, the answer, the thesis table and verdict, every figure, the
    rig's before/after and ``compare`` all call it.
    """
    keep = trials["status"] == "ok"
    if not include_warned:
        keep &= ~warned(trials)
    if measured:
        keep &= np.isfinite(pd.to_numeric(trials["err"], errors="coerce"))
    used: pd.DataFrame = trials[keep]
    return used


#: Session sets a file name declares, in the order the report and the console show them:
#: ``thesis_*.mcap`` repeat the thesis' experiments, ``stress_*.mcap`` go beyond them (the
#: bundled sample sessions are named so). Any other file is in no set.
SESSION_SETS = {
    "thesis": "thesis_* sessions: the thesis' experiments",
    "stress": "stress_* sessions: free poses, some near a degenerate geometry",
}


def session_set(session: str) -> str:
    """The set a session's file name declares (``thesis_line.mcap``: ``thesis``; see
    :data:`SESSION_SETS`), or ``""``."""
    name = str(session).replace("\\", "/").rsplit("/", 1)[-1]
    prefix = name.split("_", 1)[0] if "_" in name else ""
    return prefix if prefix in SESSION_SETS else ""


def by_session_set(trials: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """``trials`` split by session set, in :data:`SESSION_SETS`' order, the sessions in no
    set last (``""``); one group, ``""``, when the run has a single group (or no
    ``session`` column): sets are only told apart when there is more than one."""
    if "session" not in trials or trials.empty:
        return [("", trials)]
    sets = trials["session"].map(session_set)
    order = [*SESSION_SETS, ""]
    groups = [(name, trials[sets == name]) for name in order if (sets == name).any()]
    return groups if len(groups) > 1 else [("", trials)]


def summarize(trials: pd.DataFrame, *, include_warned: bool = False) -> pd.DataFrame:
    """One row per session and method: bias, spread and error statistics.

    The statistics are over the ok trials *without* a near-degeneracy warning (the tool
    itself doubts the others), unless ``include_warned``; ``n_warned`` counts what was left
    out and ``*_all_ok`` give the figures over every ok trial beside them. ``within_1`` is
    the share of used trials whose error is within 1 session unit (the thesis' "< 1 inch").
    Errors that are unknown (no ground truth) are left out of the error statistics.
    """
    rows = []
    for (session, method), g in trials.groupby(["session", "method"], sort=True):
        ok = g[g["status"] == "ok"]
        used = used_trials(g, include_warned=include_warned)
        all_ok = _error_statistics(ok)
        rows.append(
            {
                "session": session,
                **_identity(g),
                "method": method,
                "units": g["units"].iloc[0],
                "cameras": int(g["cameras"].iloc[0]) if "cameras" in g else 1,
                "n_trials": len(g),
                "n_ok": len(ok),
                "n_warned": int(warned(ok).sum()),
                "n_used": len(used),
                **_error_statistics(used),
                "rmse_all_ok": all_ok["rmse"],
                "median_err_all_ok": all_ok["median_err"],
                "max_err_all_ok": all_ok["max_err"],
                **noise_summary(g),
                **skew_summary(used),
            }
        )
    return typed(pd.DataFrame(rows, columns=SUMMARY_COLUMNS))


def skew_summary(used: pd.DataFrame) -> dict[str, float]:
    """A two-camera session's skew (``summary.csv``): the RMSE of its used touches' errors
    with camera 1's paired frame taken as it is (``err_uninterpolated``), and the share of
    it that interpolating camera 1 to camera 2's capture time removed,
    ``max(0, 1 - rmse / rmse_uninterpolated)``; NaN for typed-pose trials (no skew)."""
    if "err_uninterpolated" not in used:
        return {}
    both = used[["err", "err_uninterpolated"]].apply(pd.to_numeric, errors="coerce").dropna()
    if both.empty:
        return {}
    rmse, raw = (float(np.sqrt(np.mean(both[c] ** 2))) for c in ("err", "err_uninterpolated"))
    return {
        "rmse_uninterpolated": raw,
        "skew_share": max(0.0, 1.0 - rmse / raw) if raw > 0 else np.nan,
    }


def noise_summary(trials: pd.DataFrame) -> dict[str, object]:
    """A session's noise model (``summary.csv``'s last columns): the placing sigma its
    regions assumed, where it came from and the multiplier taken with its degrees of
    freedom; sigma0 over its unflagged ok trials' misclosures under the typed model, with
    its chi-square test (:class:`twopose.uncertainty.noise.VarianceFactor`'s rule), and over
    every ok trial with redundancy, the flagged ones' too (the words say both where flagging
    turned the test); the flagged trials.
    A table from before the columns: not known."""
    from twopose.uncertainty.noise import VarianceFactor

    if "misclosure_dof" not in trials:
        return {}
    ok = trials[trials["status"] == "ok"]
    flagged = _flags(ok)
    kept = ok[~flagged]
    chi2 = pd.to_numeric(kept["misclosure_chi2"], errors="coerce").to_numpy(dtype=np.float64)
    dof = pd.to_numeric(kept["misclosure_dof"], errors="coerce").fillna(0).to_numpy()
    use = np.isfinite(chi2) & (dof > 0)
    # the trials of one target's scatter (twopose.uncertainty.target_scatter), in both
    s_dof = int(np.nan_to_num(_first_number(trials, "target_scatter_dof")))
    s_chi2 = _first_number(trials, "target_scatter_chi2") if s_dof else 0.0
    total = int(dof[use].sum()) + s_dof
    every = pd.to_numeric(ok["misclosure_chi2"], errors="coerce").to_numpy(dtype=np.float64)
    every_dof = pd.to_numeric(ok["misclosure_dof"], errors="coerce").fillna(0).to_numpy()
    has = np.isfinite(every) & (every_dof > 0)  # the flagged trials' misclosures too
    total_all = int(every_dof[has].sum()) + s_dof
    every_chi2 = every[has].sum() + s_chi2
    factor = VarianceFactor(
        sigma0_sq=float((chi2[use].sum() + s_chi2) / total) if total else np.nan, dof=total
    )
    everyone = VarianceFactor(sigma0_sq=every_chi2 / total_all if total_all else np.nan,
                              dof=total_all)  # fmt: skip
    widening = pd.to_numeric(kept["noise_widening"], errors="coerce")
    sigma = pd.to_numeric(trials["placing_sigma"], errors="coerce")
    sources = [s for s in trials["placing_source"].astype(str) if s]
    scale = _first_number(trials, "placing_scale")
    rig = {c: str(trials[c].fillna("").iloc[0]) for c in ("rig_file", "rig_sha256") if c in trials}
    return {
        "placing_sigma": float(sigma.median()) if sigma.notna().any() else np.nan,
        "placing_source": sources[0] if sources else "",
        "placing_scale": scale,
        "placing_dof": _first_number(trials, "placing_dof"),
        "prior_sessions": _first_text(trials, "prior_sessions"),
        "floor_unmeasured": _distinct_text(trials, "floor_unmeasured"),
        **rig,
        "sigma0": float(np.sqrt(factor.sigma0_sq)) if total else np.nan,
        "sigma0_dof": total,
        "sigma0_p": factor.p_upper if total else np.nan,
        "sigma0_placing_share": _placing_share(kept, use, s_dof, total),
        "sigma0_all": float(np.sqrt(every_chi2 / total_all)) if total_all else np.nan,
        "sigma0_all_dof": total_all,
        # What the words call "contradict": the unflagged trials' test, or where no
        # unflagged trial is left to test, every trial's (the flagged ones' too).
        "noise_contradicted": factor.contradicted or (total == 0 and everyone.contradicted),
        "noise_widening": float(widening.max()) if widening.notna().any() else np.nan,
        "n_flagged": int(flagged.sum()),
        "n_off_truth": int((ok["flagged_by"] == "truth").sum()) if "flagged_by" in ok else 0,
    }


def _placing_share(kept: pd.DataFrame, use: np.ndarray, scatter_dof: int, total: int) -> float:
    """The placing's mean share of sigma0's directions: its misclosures' (their
    ``misclosure_placing_share`` over their dof), the trials of one target's contrasts
    counted as all placing (NaN: not tested; 1 in a table from before the column)."""
    if not total:
        return np.nan
    if "misclosure_placing_share" not in kept:
        return 1.0
    share = pd.to_numeric(kept["misclosure_placing_share"], errors="coerce").to_numpy()
    dof = pd.to_numeric(kept["misclosure_dof"], errors="coerce").fillna(0).to_numpy()
    return float((np.nan_to_num(share[use]) * dof[use]).sum() + scatter_dof) / total


def _flags(trials: pd.DataFrame) -> pd.Series:
    """Which of ``trials`` are flagged (none in a table from before the column)."""
    if "flagged" not in trials:
        return pd.Series(data=False, index=trials.index)
    return trials["flagged"].fillna(value=False).astype(bool)


def _first_number(trials: pd.DataFrame, column: str) -> float:
    """The first known value of a column the session's trials share (NaN: none)."""
    if column not in trials:
        return np.nan
    values = pd.to_numeric(trials[column], errors="coerce").dropna()
    return float(values.iloc[0]) if len(values) else np.nan


def _first_text(trials: pd.DataFrame, column: str) -> str:
    """The first value of a text column the session's trials share (``""``: none)."""
    if column not in trials:
        return ""
    values = trials[column].dropna().astype(str)
    return str(values.iloc[0]) if len(values) else ""


def _distinct_text(trials: pd.DataFrame, column: str) -> str:
    """A text column's distinct non-empty values over the session's trials, ``; ``-joined
    in order (``""``: none, or a table from before the column)."""
    if column not in trials:
        return ""
    values = [str(v) for v in trials[column].dropna() if str(v)]
    return "; ".join(dict.fromkeys(values))


def _identity(trials: pd.DataFrame) -> dict[str, str]:
    """A session's summary row's identity: its label, session id, the branch it ends on,
    and which trials it is over (their parts and numbers, hashed: ``check`` compares two
    rows as given only when they are over the same trials)."""
    if "session_id" not in trials.columns:  # a table from before identities (compare)
        return {}
    held = sorted(f"{p}:{int(t)}" for p, t in zip(trials["part"], trials["trial"], strict=True))
    return {
        "label": str(trials["label"].iloc[0]),
        "session_id": str(trials["session_id"].iloc[0]),
        "branch": str(trials["branch"].iloc[-1]),
        "trials_key": hashlib.sha256(" ".join(held).encode()).hexdigest()[:16],
    }


#: Two-sided 95% Student t quantiles by degrees of freedom (1-30); beyond, the normal's.
_T95 = [
    12.706,
    4.303,
    3.182,
    2.776,
    2.571,
    2.447,
    2.365,
    2.306,
    2.262,
    2.228,
    2.201,
    2.179,
    2.160,
    2.145,
    2.131,
    2.120,
    2.110,
    2.101,
    2.093,
    2.086,
    2.080,
    2.074,
    2.069,
    2.064,
    2.060,
    2.056,
    2.052,
    2.048,
    2.045,
    2.042,
]


#: The fewest trials an interval is given from (``summary.csv``'s ``*_ci95`` columns, the
#: report, the thesis table, ``compare``'s paired test): from fewer, a bootstrap can only
#: resample the few values there are (from 2 trials, its 95% interval of the RMSE is their
#: smaller and larger error), and a t-interval rests on a normality its 4 points cannot
#: show; so none is given, and the tables say why (:func:`too_few_for_interval`).
MIN_INTERVAL_TRIALS = 5


def too_few_for_interval(n: int, noun: str = "trial", plural: str = "trials") -> str:
    """Why no interval is shown over ``n`` trials (fewer than :data:`MIN_INTERVAL_TRIALS`);
    ``noun``, ``plural``: what the rows are (a two-camera session's: ``touch``, ``touches``)."""
    return f"{n} {noun if n == 1 else plural}: an interval needs {MIN_INTERVAL_TRIALS}"


def t95(dof: int) -> float:
    """The two-sided 95% Student t quantile with ``dof`` degrees of freedom."""
    return _T95[dof - 1] if dof <= len(_T95) else 1.96


#: Sign flips drawn for the paired test when there are too many pairs to enumerate.
_SIGN_FLIPS = 20000


def paired_difference(diff: np.ndarray, seed: int = 0) -> dict[str, float]:
    """Paired per-trial differences ``diff`` (n,): mean with its 95% t-interval (from
    :data:`MIN_INTERVAL_TRIALS` pairs on), median,
    and the two-sided p-value of the sign-flip permutation test of a zero mean (exact for
    up to 16 pairs, else ``_SIGN_FLIPS`` seeded draws; no normality assumed)."""
    d = np.asarray(diff, dtype=np.float64)
    d = d[np.isfinite(d)]
    n = len(d)
    out = {"n_pairs": float(n), "mean_diff": np.nan, "ci95_low": np.nan, "ci95_high": np.nan}
    out |= {"median_diff": np.nan, "p_value": np.nan}
    if n == 0:
        return out
    mean = float(d.mean())
    out |= {"mean_diff": mean, "median_diff": float(np.median(d))}
    if n >= MIN_INTERVAL_TRIALS:
        half = t95(n - 1) * float(d.std(ddof=1)) / np.sqrt(n)
        out |= {"ci95_low": mean - half, "ci95_high": mean + half}
    if n <= 16:
        signs = 1 - 2 * ((np.arange(2**n)[:, None] >> np.arange(n)) & 1)
    else:
        signs = np.random.default_rng(seed).choice([-1.0, 1.0], size=(_SIGN_FLIPS, n))
    flipped = np.abs((signs * d).mean(axis=1))
    out["p_value"] = float(np.mean(flipped >= abs(mean) - 1e-12 * max(1.0, abs(mean))))
    return out


def _error_statistics(trials: pd.DataFrame) -> dict[str, float]:
    """Bias (with 95% t-intervals), spread, RMSE (with a seeded bootstrap interval), median,
    max, share within 1 unit and 95% coverage, over the trials whose error is known; the
    intervals only from :data:`MIN_INTERVAL_TRIALS` trials on (NaN below)."""
    known = trials[trials["err"].notna()]
    err = known[["err_x", "err_y", "err_z"]].to_numpy(dtype=np.float64)
    total = known["err"].to_numpy(dtype=np.float64)
    n = len(known)
    out: dict[str, float] = {}
    enough = n >= MIN_INTERVAL_TRIALS  # an interval from fewer is none (the constant's note)
    for i, a in enumerate("xyz"):
        out[f"bias_{a}"] = float(err[:, i].mean()) if n else np.nan
        std = float(err[:, i].std(ddof=1)) if n > 1 else np.nan
        out[f"std_{a}"] = std
        out[f"bias_{a}_ci95"] = t95(n - 1) * std / np.sqrt(n) if enough else np.nan
    with np.errstate(over="ignore"):
        out["rmse"] = float(np.sqrt(np.mean(total**2))) if n else np.nan
        if enough:
            rng = np.random.default_rng(0)
            draws = total[rng.integers(0, n, size=(2000, n))]
            boot = np.sqrt(np.mean(draws**2, axis=1))
            out["rmse_ci95_low"], out["rmse_ci95_high"] = (
                float(v) for v in np.percentile(boot, [2.5, 97.5])
            )
        else:
            out["rmse_ci95_low"] = out["rmse_ci95_high"] = np.nan
    out["median_err"] = float(np.median(total)) if n else np.nan
    out["max_err"] = float(total.max()) if n else np.nan
    out["within_1"] = float(np.mean(total <= 1.0)) if n else np.nan
    inside = known["within95"] if "within95" in known else pd.Series(dtype=object)
    inside = inside[inside.notna()]
    out["coverage95"] = float(inside.astype(bool).mean()) if len(inside) else np.nan
    return out
