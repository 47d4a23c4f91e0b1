"""``check`` compares the noise model too (issue 56, item 4): a run and a baseline that
used different rig files (their placing sigma, their constants' covariance) say so, and
compare on what is comparable (the errors), never the regions' coverage across models."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd

from analysis.gate.baseline import check, check_lines

RIG_SHA = "ab" * 32


def _copy_with(bundled_run: Path, tmp_path: Path, **values: str) -> tuple[Path, str]:
    """A copy of the bundled run, its first session's summary row changed: its coverage
    0.3 lower (a regression if the models were the same) and ``values``."""
    run = tmp_path / "run"
    shutil.copytree(bundled_run, run)
    summary = pd.read_csv(run / "summary.csv", keep_default_na=False)
    row = summary.index[pd.to_numeric(summary["coverage95"], errors="coerce") > 0.3][0]
    summary.loc[row, "coverage95"] = float(summary.loc[row, "coverage95"]) - 0.3
    for column, value in values.items():
        summary.loc[row, column] = value
    summary.to_csv(run / "summary.csv", index=False)
    return run, str(summary.loc[row, "label"])


def test_a_run_with_another_noise_model_says_so_and_leaves_its_coverage_out(
    bundled_run: Path, tmp_path: Path
) -> None:
    run, label = _copy_with(
        bundled_run, tmp_path, rig_sha256=RIG_SHA, rig_file="calib/rig.toml",
        placing_source="measured by board.mcap (16 captures)",
    )  # fmt: skip
    outcome = check(run, bundled_run)
    assert not outcome.regressed, check_lines(outcome, bundled_run)
    said = [n for n in outcome.notes if "different noise models" in n]
    assert len(said) == 1, outcome.notes
    assert said[0].startswith(f"{label} (")
    assert "the run: rig file calib/rig.toml" in said[0]
    assert "the baseline: no rig file" in said[0]
    assert "coverage95 not compared" in said[0]
    compared = outcome.comparisons
    pair = compared[compared["session"] == label]
    assert "coverage95" not in set(pair["metric"])
    assert "rmse" in set(pair["metric"])  # the errors are compared as ever


def test_the_same_noise_model_still_gates_the_coverage(bundled_run: Path, tmp_path: Path) -> None:
    run, label = _copy_with(bundled_run, tmp_path)
    outcome = check(run, bundled_run)
    assert outcome.regressed
    bad = outcome.worse()
    assert list(bad[bad["session"] == label]["metric"]) == ["coverage95"]
    assert not any("noise model" in n for n in outcome.notes)


def test_a_baseline_from_before_the_rig_digest_is_said(bundled_run: Path, tmp_path: Path) -> None:
    baseline = tmp_path / "baseline"
    shutil.copytree(bundled_run, baseline)
    summary = pd.read_csv(baseline / "summary.csv", keep_default_na=False)
    summary.drop(columns=["rig_file", "rig_sha256"]).to_csv(baseline / "summary.csv", index=False)
    outcome = check(bundled_run, baseline)
    assert not outcome.regressed
    assert any("the baseline predates rig_sha256" in n for n in outcome.notes), outcome.notes
