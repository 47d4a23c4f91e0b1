"""``compare``: side-by-side statistics and paired per-trial differences of two runs."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.gate.comparison import TEST_COLUMNS, compare_runs
from analysis.session.metrics import paired_difference

runner = CliRunner()


def test_the_paired_test_is_the_exact_sign_flip_test_for_few_pairs() -> None:
    # Five positive differences: only "all +" and "all -" are as extreme, 2 of 32 flips.
    result = paired_difference(np.array([0.1, 0.2, 0.3, 0.4, 0.5]))
    assert result["p_value"] == pytest.approx(2 / 32)
    assert result["mean_diff"] == pytest.approx(0.3)
    assert result["ci95_low"] < 0.3 < result["ci95_high"]
    # Symmetric differences: no evidence at all.
    assert paired_difference(np.array([-1.0, 1.0, -2.0, 2.0]))["p_value"] == 1.0
    # Many pairs with a clear shift: drawn flips, a small p-value.
    shifted = np.random.default_rng(1).normal(0.5, 0.2, 40)
    assert paired_difference(shifted)["p_value"] < 0.001
    assert paired_difference(np.array([]))["n_pairs"] == 0


@pytest.fixture(scope="module")
def two_runs(
    tmp_path_factory: pytest.TempPathFactory, point_session: Path, ground_session: Path
) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("compare")
    runs = []
    for combine in ("mean", "median"):
        out = root / combine
        args = ["run", str(point_session), str(ground_session), "--out", str(out)]
        result = runner.invoke(app, [*args, "--no-scene", "--combine", combine])
        assert result.exit_code == 0, result.output
        runs.append(out)
    return runs[0], runs[1]


def _errors(run: Path, column: str = "err") -> pd.Series:
    trials = pd.read_csv(run / "trials.csv", keep_default_na=False, na_values=[""])
    trials = trials[(trials["status"] == "ok") & (trials["warning"].fillna("") == "")]
    return trials.set_index([trials["session"].map(lambda s: Path(s).name), "trial"])[column]


def test_two_runs_compare_trial_by_trial(two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    mean_run, median_run = two_runs
    out = tmp_path / "cmp"
    result = runner.invoke(app, ["compare", str(mean_run), str(median_run), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert {p.name for p in out.iterdir()} >= {
        "tests.csv",
        "side_by_side.csv",
        "paired.csv",
        "compare.png",
        "compare.html",
    }
    tests = pd.read_csv(out / "tests.csv")
    assert list(tests.columns) == TEST_COLUMNS
    assert list(tests["method"]) == ["ground", "point"]
    paired = pd.read_csv(out / "paired.csv")
    expected = (_errors(median_run) - _errors(mean_run)).dropna()
    got = paired.set_index(["session", "trial"])["diff"]
    assert len(got) == len(expected) > 0
    np.testing.assert_allclose(got.loc[expected.index], expected, atol=1e-12)
    assert "shared trial(s); B - A mean error" in result.output
    page = (out / "compare.html").read_text()
    assert "<img alt='compare'" in page
    assert "twopose " in page  # the versions of the runs


def test_one_run_against_itself_has_no_difference(two_runs: tuple[Path, Path]) -> None:
    comparison = compare_runs(two_runs[0], two_runs[0])
    assert (comparison.paired["diff"] == 0).all()
    assert (comparison.tests["p_value"] == 1.0).all()
    side = comparison.side_by_side
    np.testing.assert_allclose(side["rmse_a"], side["rmse_b"])


def test_estimators_of_one_run_compare(two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    run = two_runs[0]
    comparison = compare_runs(run, run, estimator_b="optimal")
    point = comparison.paired[comparison.paired["method"] == "point"]
    expected = (_errors(run, "err_optimal") - _errors(run, "err")).loc["point.mcap"]
    assert len(point) == len(expected) > 0
    np.testing.assert_allclose(point["diff"], expected.to_numpy(), atol=1e-9)
    # Ground trials have no optimal estimate: they are not shared.
    assert set(comparison.paired["method"]) == {"point"}
    # A run with no such estimate at all is refused with what to do.
    result = runner.invoke(
        app, ["compare", str(run), str(run), "--estimator-b", "weighted", "--out", str(tmp_path)]
    )
    assert result.exit_code == 3
    assert "no weighted estimates" in result.output


def test_an_older_run_without_new_columns_still_compares(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    old = tmp_path / "old"
    shutil.copytree(two_runs[0], old)
    (old / "summary.json").unlink()
    trials = pd.read_csv(old / "trials.csv")
    trials.drop(columns=["warning", "within95", "notes"]).to_csv(old / "trials.csv", index=False)
    comparison = compare_runs(old, two_runs[1], include_warned=True)
    assert comparison.a.version == ""
    assert comparison.tests["n_pairs"].sum() == len(comparison.paired) > 0


@pytest.mark.parametrize("column", ["session_id", "part", "branch"])
def test_a_run_without_a_trial_identity_column_is_refused_not_a_traceback(
    two_runs: tuple[Path, Path], tmp_path: Path, column: str
) -> None:
    """A trials.csv without ``branch`` (hypothesis dropped column 4 in CI) was a KeyError."""
    old = tmp_path / "old"
    shutil.copytree(two_runs[0], old)
    trials = pd.read_csv(old / "trials.csv")
    trials.drop(columns=[column]).to_csv(old / "trials.csv", index=False)
    result = runner.invoke(
        app, ["compare", str(old), str(two_runs[1]), "--out", str(tmp_path / "c")]
    )
    assert result.exit_code == 3, result.output
    assert f"trials.csv has no column {column}: it predates session identities" in result.output


def test_compare_refuses_a_folder_that_is_not_a_run(tmp_path: Path) -> None:
    result = runner.invoke(app, ["compare", str(tmp_path), str(tmp_path), "--out", "x"])
    assert result.exit_code == 3
    assert "no trials.csv in" in result.output


def test_compare_is_one_call_from_python(two_runs: tuple[Path, Path], tmp_path: Path) -> None:
    import analysis

    comparison = analysis.compare(two_runs[0], two_runs[1], tmp_path / "cmp")
    assert (tmp_path / "cmp" / "compare.html").is_file()
    assert list(comparison.tests["method"]) == ["ground", "point"]


def _edited_copy(run: Path, copy: Path, edit: Callable[[pd.DataFrame], pd.DataFrame]) -> Path:
    """A copy of ``run`` whose trials.csv is ``edit`` of the original's."""
    shutil.copytree(run, copy)
    trials = pd.read_csv(copy / "trials.csv", keep_default_na=False, na_values=[""])
    edit(trials).to_csv(copy / "trials.csv", index=False)
    return copy


def test_runs_with_no_trial_in_common_are_refused(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    """Nothing to compare is exit 3 with nothing written, never 'ok' and an empty figure."""
    mean_run, _ = two_runs
    other = _edited_copy(mean_run, tmp_path / "other", lambda t: t.assign(trial=t["trial"] + 1000))
    out = tmp_path / "cmp"
    result = runner.invoke(app, ["compare", str(mean_run), str(other), "--out", str(out)])
    assert result.exit_code == 3, result.output
    assert "no trial measured in both runs" in result.output
    assert not out.exists() or not any(out.iterdir())


def test_differences_at_floating_point_level_are_ties(
    two_runs: tuple[Path, Path], tmp_path: Path
) -> None:
    """A re-solve that differs by 1e-13 is neither run better: the counts say ties."""
    mean_run, _ = two_runs

    def nudge(trials: pd.DataFrame) -> pd.DataFrame:
        sign = np.where(np.arange(len(trials)) % 2 == 0, 1.0, -1.0)
        return trials.assign(x=trials["x"] + sign * 1e-13)

    nudged = _edited_copy(mean_run, tmp_path / "nudged", nudge)
    tests = compare_runs(mean_run, nudged).tests
    assert (tests["n_pairs"] > 0).all()
    assert (tests["n_a_better"] == 0).all()
    assert (tests["n_b_better"] == 0).all()


def test_the_comparison_figure_names_its_units(two_runs: tuple[Path, Path]) -> None:
    """Before: every axis said "session units" where the runs' units are known."""
    from analysis.gate.comparison import plot_comparison

    mean_run, median_run = two_runs
    fig = plot_comparison(compare_runs(mean_run, median_run))
    labels = [ax.get_xlabel() for ax in fig.axes] + [fig.axes[0].get_ylabel()]
    assert labels == ["error in A (in)", "mean error B - A, 95% interval (in)", "error in B (in)"]
