"""Two runs compared (``twopose-analyze compare``, after evo's ``evo_res``): side-by-side
statistics per session and method, and paired per-trial differences on the trials both
runs measured, with a paired test and a confidence interval.

A run is a ``run --out`` folder; each side picks an estimator (``thesis``: ``x, y, z``;
``optimal``: the reprojection-optimal point or line, ``x_optimal``...; ``weighted``: the
line's weighted fit, ``x_weighted``...), so one run can be compared with itself across
estimators, and two runs across combine modes, settings or twopose versions (an older
run's missing columns read as not measured). Errors are recomputed from each estimate and
the truth, the same way for every estimator.
"""

from __future__ import annotations

import base64
import contextlib
import dataclasses
import html
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.batch.outputs import write_atomically
from analysis.choices import Estimator
from analysis.gate.match import trial_keys
from analysis.report.figures.draw import png_bytes
from analysis.report.writer import page_html, table_html
from analysis.session.metrics import paired_difference, summarize, too_few_for_interval, used_trials
from analysis.tables.read_back import read_results_table
from analysis.tables.row_units import row_unit
from twopose.errors import InputValueError
from twopose.format.entries import INCHES_PER_UNIT
from twopose.values.units import DEFAULT_UNITS, unit_factor

__all__ = [
    "ESTIMATORS",
    "Comparison",
    "RunSide",
    "compare",
    "compare_runs",
    "describe_one_sided",
    "describe_test",
    "plot_comparison",
    "write_comparison",
]

#: Each estimator's estimate columns in trials.csv.
ESTIMATORS: dict[str, tuple[str, str, str]] = {
    "thesis": ("x", "y", "z"),
    "optimal": ("x_optimal", "y_optimal", "z_optimal"),
    "weighted": ("x_weighted", "y_weighted", "z_weighted"),
}

SIDE_COLUMNS = ["n_used", "rmse", "median_err", "max_err", "bias_x", "bias_y", "bias_z"]
TEST_COLUMNS = [
    "method",
    "cameras",
    "units",
    "n_pairs",
    "mean_diff",
    "ci95_low",
    "ci95_high",
    "median_diff",
    "p_value",
    "n_b_better",
    "n_a_better",
]


@dataclass(frozen=True, kw_only=True)
class RunSide:
    """One side of a comparison: a run folder and the estimator read from it."""

    folder: Path
    estimator: Estimator = "thesis"
    version: str = ""  # twopose version that wrote the run (summary.json), if known

    @property
    def label(self) -> str:
        return f"{self.folder} ({self.estimator})"


#: ``one_sided.csv``: each trial one run holds and the other does not (``held_by``: A or B).
ONE_SIDED_COLUMNS = ["session", "branch", "part", "method", "cameras", "trial", "held_by"]


@dataclass(frozen=True, kw_only=True)
class Comparison:
    """``side_by_side``: per session, branch and method (one row per row of each run's
    ``summary.csv``: a fork's branches apart), ``SIDE_COLUMNS`` of A and B (suffixes
    ``_a``, ``_b``) and B - A of the RMSE and median; ``paired``: per shared trial (its
    session, branch, part and number), its error in A and B and ``diff`` = B - A;
    ``tests``: per method and cameras (a two-camera session's touches never pooled with one
    camera's trials, nor paired with them), ``TEST_COLUMNS`` (``mean_diff`` < 0: B's errors
    are smaller);
    ``one_sided``: the trials only one run holds (``ONE_SIDED_COLUMNS``)."""

    a: RunSide
    b: RunSide
    side_by_side: pd.DataFrame
    paired: pd.DataFrame
    tests: pd.DataFrame
    one_sided: pd.DataFrame = dataclasses.field(
        default_factory=lambda: pd.DataFrame(columns=ONE_SIDED_COLUMNS)
    )


def compare_runs(
    run_a: str | Path,
    run_b: str | Path,
    *,
    estimator_a: Estimator = "thesis",
    estimator_b: Estimator = "thesis",
    include_warned: bool = False,
) -> Comparison:
    """Compare two run folders (see the module's docstring)."""
    sides = [_side(Path(run_a), estimator_a), _side(Path(run_b), estimator_b)]
    held = [_with_errors(_read_trials(s), s) for s in sides]
    used = [_used_trials(h, include_warned=include_warned) for h in held]
    summaries = [summarize(u, include_warned=True) for u in used]  # already filtered
    labels = {str(k): str(v) for u in used for k, v in zip(u["session"], u["label"], strict=True)}
    side = _side_by_side(summaries[0], summaries[1], labels)
    paired = _paired(*used)
    if paired.empty:  # nothing to compare: no figure, no table, and no "ok"
        raise InputValueError(
            f"no trial measured in both runs ({run_a} and {run_b}): they share no session, "
            "method, units and trial that each measured with ground truth"
            + ("" if include_warned else " and without a warning (--include-warned counts those)")
        )
    return Comparison(
        a=sides[0],
        b=sides[1],
        side_by_side=side,
        paired=paired,
        tests=_tests(paired),
        one_sided=_one_sided(*held),
    )


def compare(
    run_a: str | Path,
    run_b: str | Path,
    out_dir: str | Path | None = None,
    *,
    estimator_a: Estimator = "thesis",
    estimator_b: Estimator = "thesis",
    include_warned: bool = False,
) -> Comparison:
    """``twopose-analyze compare`` in one call: :func:`compare_runs`, files written.

    With ``out_dir``, the comparison's files are written there (:func:`write_comparison`,
    in a checked, locked folder that is neither run nor inside one:
    :class:`analysis.batch.outputs.Inputs`).

    Parameters
    ----------
    run_a, run_b : path-like
        Two run folders (``twopose-analyze run --out``).
    out_dir : path-like, optional
        Where to write the comparison's tables, figure and page.
    estimator_a, estimator_b : {"thesis", "optimal", "weighted"}
        Which estimate of each run is compared.
    include_warned : bool
        Count ok trials with a near-degeneracy warning too.

    Returns
    -------
    Comparison
        The trial-by-trial comparison and its summary.
    """
    from analysis.batch.outputs import Inputs, OutputFolder

    if out_dir is not None:
        Inputs(folders=(Path(run_a), Path(run_b))).check_folder("--out", Path(out_dir))
    comparison = compare_runs(
        run_a,
        run_b,
        estimator_a=estimator_a,
        estimator_b=estimator_b,
        include_warned=include_warned,
    )
    if out_dir is not None:
        with OutputFolder.prepare(Path(out_dir)) as folder:
            folder.record(write_comparison(comparison, folder.path))
    return comparison


def _side(folder: Path, estimator: Estimator) -> RunSide:
    if estimator not in ESTIMATORS:
        raise InputValueError(f"estimator must be one of {', '.join(ESTIMATORS)}")
    version = ""
    # A run before summary.json: its version is unknown, its tables still compare.
    with contextlib.suppress(OSError, ValueError, KeyError, TypeError):
        if (folder / "summary.json").is_file():  # a FIFO would block the read forever
            version = str(json.loads((folder / "summary.json").read_text())["twopose_version"])
    return RunSide(folder=folder, estimator=estimator, version=version)


#: trials.csv's columns every comparison needs; the estimate columns are the estimator's.
TRIAL_KEY = ("session", "method", "trial")
TRIAL_COLUMNS = ("units", "status", "gt_x", "gt_y", "gt_z")


def _read_trials(side: RunSide) -> pd.DataFrame:
    """``side``'s trials.csv, checked as ``check`` checks a summary
    (:func:`analysis.batch.outputs.read_results_table`): one row per session, method and trial,
    the truth and the estimator's columns present and numbers."""
    columns = ESTIMATORS[side.estimator]
    trials = read_results_table(
        side.folder,
        "trials.csv",
        key=TRIAL_KEY,
        required=TRIAL_COLUMNS,
        numeric=("trial", "gt_x", "gt_y", "gt_z", *columns, "within95"),
    )
    if not set(columns) <= set(trials.columns):
        raise InputValueError(
            f"{side.folder}/trials.csv has no {side.estimator} estimates ({columns[0]}, ...): "
            "optimal is for point and line sessions, weighted for line sessions"
        )
    return trials


def _with_errors(trials: pd.DataFrame, side: RunSide) -> pd.DataFrame:
    """``trials`` with ``err_x, err_y, err_z, err`` of ``side``'s estimator against the
    truth; ``within95`` only for the thesis estimator, whose covariance it is. Each trial is
    keyed by what it is (``_pair``: its session, part and number), never by its path."""
    missing = [c for c in ("session_id", "part", "branch") if c not in trials.columns]
    if missing:
        raise InputValueError(
            f"{side.folder}/trials.csv has no column {', '.join(missing)}: it predates session "
            "identities (trials are matched by what they are, not by path); run "
            "`twopose-analyze run` again with this twopose to write it"
        )
    columns = ESTIMATORS[side.estimator]
    estimate = trials[list(columns)].apply(pd.to_numeric, errors="coerce").to_numpy()
    truth = trials[["gt_x", "gt_y", "gt_z"]].apply(pd.to_numeric, errors="coerce").to_numpy()
    err = estimate - truth
    label = trials["label"] if "label" in trials.columns else trials["session"]
    # A row of the run's summary is a session's strand (a fork's branches apart): named by
    # its session and the branch its trials end on, as summary.csv's rows are.
    strand = trials.groupby(trials["session"].astype(str), sort=False)["branch"].transform("last")
    # One camera's trials and two cameras' touches are never paired nor pooled (an older
    # run's trials.csv without the column is one camera's).
    cameras = (
        pd.to_numeric(trials["cameras"], errors="coerce").fillna(1).astype(int)
        if "cameras" in trials.columns
        else pd.Series(1, index=trials.index)
    )
    out = trials.assign(
        cameras=cameras,
        session=trials["session_id"].astype(str) + "|" + strand.astype(str),
        strand=strand.astype(str),
        label=label.astype(str),
        _pair=trials["session_id"].astype(str) + "|" + trial_keys(trials),
        err_x=err[:, 0],
        err_y=err[:, 1],
        err_z=err[:, 2],
        err=np.linalg.norm(err, axis=1),
    )
    if side.estimator != "thesis" or "within95" not in out:
        out = out.assign(within95=np.nan)
    return out


def _used_trials(trials: pd.DataFrame, *, include_warned: bool) -> pd.DataFrame:
    """The trials the summary uses (:func:`analysis.session.metrics.used_trials`) with a known
    error."""
    used = used_trials(trials, include_warned=include_warned)
    known: pd.DataFrame = used[np.isfinite(used["err"].to_numpy(dtype=np.float64))]
    return known


def _side_by_side(
    summary_a: pd.DataFrame, summary_b: pd.DataFrame, labels: dict[str, str]
) -> pd.DataFrame:
    """Per session (by id), method and cameras, each side's statistics; ``session`` its
    label."""
    keys = ["session", "method", "cameras", "units"]
    table = pd.merge(
        summary_a[keys + SIDE_COLUMNS],
        summary_b[keys + SIDE_COLUMNS],
        on=keys,
        how="outer",
        suffixes=("_a", "_b"),
        sort=True,
    )
    for column in ("rmse", "median_err"):
        table[f"{column}_diff"] = table[f"{column}_b"] - table[f"{column}_a"]
    branch = table["session"].astype(str).str.rsplit("|", n=1).str[-1]
    table = table.assign(session=table["session"].map(lambda s: labels.get(str(s), str(s))))
    table.insert(1, "branch", branch)
    return table


#: Differences of errors smaller than this, relative to the larger error (or absolute
#: under errors of 1), are ties: the two runs' floating point, not a better estimate
#: (a run that re-solves the same trials differs by about 1e-13).
TIE_TOLERANCE = 1e-9


def _paired(used_a: pd.DataFrame, used_b: pd.DataFrame) -> pd.DataFrame:
    """Each trial both runs measured, matched by what it is; A's error in B's units where a
    session's units differ between the runs."""
    keep = ["_pair", "method", "cameras", "units", "err"]
    pairs = pd.merge(
        used_a[keep].drop_duplicates("_pair", keep="last"),
        used_b[[*keep, "label", "trial", "branch", "part"]].drop_duplicates("_pair", keep="last"),
        on=["_pair", "method", "cameras"],
        suffixes=("_a", "_b"),
        sort=True,
    )
    scale = pairs["units_a"].map(INCHES_PER_UNIT).astype(float) / pairs["units_b"].map(
        INCHES_PER_UNIT
    ).astype(float)
    pairs = pairs.assign(
        session=pairs["label"], units=pairs["units_b"], err_a=pairs["err_a"] * scale
    )
    pairs = pairs.sort_values(["session", "method", "trial"], kind="stable")
    columns = [
        "session", "branch", "part", "method", "cameras", "units", "trial", "err_a", "err_b",
    ]  # fmt: skip
    out = pairs[columns].reset_index(drop=True)
    return out.assign(diff=out["err_b"] - out["err_a"])


def _one_sided(held_a: pd.DataFrame, held_b: pd.DataFrame) -> pd.DataFrame:
    """Every trial one run holds (in its ``trials.csv``, whatever its status) and the
    other does not: a part one run read and the other did not, a session one run lacks."""
    rows = []
    for side, mine, other in (("A", held_a, held_b), ("B", held_b, held_a)):
        alone = mine[~mine["_pair"].isin(set(other["_pair"]))]
        rows.append(
            pd.DataFrame(
                {
                    "session": alone["label"],
                    "branch": alone["branch"].astype(str),
                    "part": alone["part"].astype(str),
                    "method": alone["method"],
                    "cameras": alone["cameras"],
                    "trial": alone["trial"],
                    "held_by": side,
                }
            )
        )
    table = pd.concat(rows, ignore_index=True)[ONE_SIDED_COLUMNS]
    return table.sort_values(["held_by", "session", "method", "trial"], kind="stable")


def describe_one_sided(one_sided: pd.DataFrame) -> list[str]:
    """One line per run and session holding trials the other run does not:
    ``only in A: a.mcap [branch B] (point): trials 3, 4``."""
    from analysis.report.answer import with_branch

    lines = []
    table = one_sided if "cameras" in one_sided else one_sided.assign(cameras=1)
    for (side, session, branch, method, cameras), g in table.groupby(
        ["held_by", "session", "branch", "method", "cameras"], sort=True
    ):
        numbers = ", ".join(str(int(t)) for t in sorted(g["trial"]))
        unit = row_unit(cameras)  # trials; a two-camera session's touches
        lines.append(
            f"only in {side}: {with_branch(str(session), str(branch))} ({method}): "
            f"{unit.plural if len(g) > 1 else unit.noun} {numbers}"
        )
    return lines


def _tests(paired: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (method, cameras, units), g in paired.groupby(["method", "cameras", "units"], sort=True):
        diff = g["diff"].to_numpy(dtype=np.float64)
        errors = g[["err_a", "err_b"]].abs().to_numpy(dtype=np.float64)
        scale = np.maximum(1.0, errors.max(axis=1))
        tie = TIE_TOLERANCE * scale
        rows.append(
            {
                "method": method,
                "cameras": int(str(cameras)),
                "units": units,
                **paired_difference(diff),
                "n_b_better": int(np.sum(diff < -tie)),
                "n_a_better": int(np.sum(diff > tie)),
            }
        )
    tests = pd.DataFrame(rows, columns=TEST_COLUMNS)
    return tests.astype({"n_pairs": int, "cameras": int})


def describe_test(row: pd.Series) -> str:
    """One line per method: ``ground: 15 shared trials; B - A mean error ... p = ...``."""
    n = int(row["n_pairs"])
    unit = row_unit(row.get("cameras", 1))  # trials; a two-camera session's touches
    what = f"{row['method']}{', two cameras' if unit.cameras == 2 else ''}"
    shared = unit.maybe_plural
    if n == 0:
        return f"{what}: no {unit.noun} measured in both runs"
    interval = (
        f" (95% CI {row['ci95_low']:+.3g} to {row['ci95_high']:+.3g})"
        if math.isfinite(row["ci95_low"])
        else f" (no interval: {too_few_for_interval(n, unit.noun, unit.plural)})"
    )
    return (
        f"{what}: {n} shared {shared}; B - A mean error {row['mean_diff']:+.3g} "
        f"{row['units']}{interval}, p = {row['p_value']:.3g}; B better in "
        f"{int(row['n_b_better'])}, A in {int(row['n_a_better'])}"
    )


def _in_one_unit(table: pd.DataFrame, columns: list[str]) -> tuple[pd.DataFrame, str]:
    """``table``'s length ``columns`` in its one unit, or in inches when its rows differ."""
    units = sorted({str(u) for u in table["units"]}) if len(table) else []
    if len(units) <= 1:
        return table, units[0] if units else "no trial"
    scale = table["units"].map(lambda u: unit_factor(u, DEFAULT_UNITS)).astype(float)
    return table.assign(**{c: table[c] * scale for c in columns}), str(DEFAULT_UNITS)


def plot_comparison(comparison: Comparison) -> Figure:
    """Left: each shared trial's error in A against B (below the diagonal: B better).
    Right: per method, the mean difference B - A with its 95% interval. Every axis names
    its unit (the sessions', or inches when they differ)."""
    fig = Figure(figsize=(9.0, 3.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    paired, units = _in_one_unit(comparison.paired, ["err_a", "err_b"])
    for method, g in paired.groupby("method", sort=True):
        left.scatter(g["err_a"], g["err_b"], s=14, alpha=0.8, label=str(method))
    if len(paired):
        both = paired[["err_a", "err_b"]].to_numpy(dtype=np.float64)
        lo, hi = float(np.nanmin(both)), float(np.nanmax(both))
        left.plot([lo, hi], [lo, hi], color="0.5", lw=0.8, label="equal")
        left.legend(fontsize=7)
    left.set_xlabel(f"error in A ({units})")
    left.set_ylabel(f"error in B ({units})")
    left.set_title("Error per shared trial (below the line: B better)", fontsize=9)
    tests, _ = _in_one_unit(
        comparison.tests[comparison.tests["n_pairs"] > 0], ["mean_diff", "ci95_low", "ci95_high"]
    )
    y = np.arange(len(tests))
    mean = tests["mean_diff"].to_numpy(dtype=np.float64)
    low = np.nan_to_num(mean - tests["ci95_low"].to_numpy(dtype=np.float64))
    high = np.nan_to_num(tests["ci95_high"].to_numpy(dtype=np.float64) - mean)
    right.errorbar(mean, y, xerr=[low, high], fmt="o", capsize=3)
    right.axvline(0.0, color="0.5", lw=0.8)
    right.set_yticks(
        y, [f"{m} (n={n})" for m, n in zip(tests["method"], tests["n_pairs"], strict=True)]
    )
    right.set_xlabel(f"mean error B - A, 95% interval ({units})")
    right.set_title("Paired difference per method", fontsize=9)
    fig.suptitle(f"A: {comparison.a.label}   B: {comparison.b.label}", fontsize=8)
    return fig


def write_comparison(comparison: Comparison, out_dir: str | Path) -> list[str]:
    """``tests.csv``, ``side_by_side.csv``, ``paired.csv``, ``one_sided.csv``,
    ``compare.png`` and ``compare.html`` in ``out_dir`` (each written atomically); the
    names written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tables = {
        "tests.csv": comparison.tests,
        "side_by_side.csv": comparison.side_by_side,
        "paired.csv": comparison.paired,
        "one_sided.csv": comparison.one_sided,
    }
    for name, table in tables.items():
        write_atomically(out / name, table.to_csv(index=False).encode("utf-8", "backslashreplace"))
    png = png_bytes(plot_comparison(comparison))
    write_atomically(out / "compare.png", png)
    page = _compare_html(comparison, base64.b64encode(png).decode())
    write_atomically(out / "compare.html", page.encode("utf-8", "backslashreplace"))
    return [*tables, "compare.png", "compare.html"]


def _one_sided_html(one_sided: pd.DataFrame) -> str:
    lines = describe_one_sided(one_sided)
    if not lines:
        return "<p>None: both runs hold the same trials.</p>"
    return "<ul>" + "".join(f"<li>{html.escape(line)}</li>" for line in lines) + "</ul>"


def _compare_html(comparison: Comparison, png_base64: str) -> str:
    runs = "".join(
        f"<li>{side}: {html.escape(run.label)}"
        f"{' (twopose ' + html.escape(run.version) + ')' if run.version else ''}</li>"
        for side, run in (("A", comparison.a), ("B", comparison.b))
    )
    lines = "".join(
        f"<li>{html.escape(describe_test(r))}</li>" for _, r in comparison.tests.iterrows()
    )
    body = [
        "<h1>twopose: two runs compared</h1>",
        f"<ul>{runs}</ul>",
        "<h2 id='tests'>Paired differences (B - A, shared trials)</h2>",
        f"<ul>{lines or '<li>no trial measured in both runs</li>'}</ul>",
        table_html(comparison.tests),
        f"<img alt='compare' src='data:image/png;base64,{png_base64}'>",
        "<h2 id='side'>Side by side</h2>",
        table_html(comparison.side_by_side),
        "<h2 id='paired'>Per shared trial</h2>",
        table_html(comparison.paired),
        "<h2 id='one-sided'>Trials only one run holds</h2>",
        _one_sided_html(comparison.one_sided),
    ]
    return page_html("twopose comparison", body)
