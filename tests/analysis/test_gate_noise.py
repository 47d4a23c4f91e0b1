"""``check`` compares the noise model too (issue 56, item 4): a run and a baseline that
used different rig files (their placing sigma, their constants' covariance) say so, and
compare on what is comparable (the errors), never the regions' coverage across models."""

from __future__ import annotations

import json
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


def _settings(run: Path, **values: object) -> None:
    """``run``'s summary.json with these settings changed."""
    path = run / "summary.json"
    document = json.loads(path.read_text())
    document["settings"] = {**document["settings"], **values}
    path.write_text(json.dumps(document))


def test_a_baseline_of_another_noise_setting_says_so_and_leaves_the_coverage_out(
    bundled_run: Path, tmp_path: Path
) -> None:
    """Issue 54's adversary: a baseline computed with --no-sigma0 was checked against a
    --sigma0 run as if their regions claimed the same thing."""
    assert json.loads((bundled_run / "summary.json").read_text())["settings"]["sigma0"] is True
    run, _ = _copy_with(bundled_run, tmp_path)  # its coverage 0.3 lower
    _settings(run, sigma0=False)
    outcome = check(run, bundled_run)
    lines = check_lines(outcome, bundled_run)
    assert not outcome.regressed, lines
    assert (
        "note: different settings: --sigma0 is off (--no-sigma0) in the run and on (--sigma0) "
        "in the baseline"
    ) in lines
    assert any(line.startswith("note: coverage95 not compared") for line in lines)
    assert "coverage95" not in set(outcome.comparisons["metric"])
    assert lines[-1].endswith("no regression (across different settings: see the notes)")


def test_a_baseline_of_another_combine_rule_is_said_and_still_gated(
    bundled_run: Path, tmp_path: Path
) -> None:
    run, _ = _copy_with(bundled_run, tmp_path)
    _settings(run, combine="median")
    outcome = check(run, bundled_run)
    assert outcome.regressed  # the coverage is still compared: not a noise setting
    assert "different settings: --combine is median in the run and mean in the baseline" in (
        outcome.notes
    )
    assert outcome.settings_differ


def test_a_baseline_without_recorded_settings_is_said(bundled_run: Path, tmp_path: Path) -> None:
    baseline = tmp_path / "baseline"
    shutil.copytree(bundled_run, baseline)
    document = json.loads((baseline / "summary.json").read_text())
    del document["settings"]
    (baseline / "summary.json").write_text(json.dumps(document))
    outcome = check(bundled_run, baseline)
    assert any(n.startswith("not compared: the settings (the baseline's") for n in outcome.notes)
    same = check(bundled_run, bundled_run)
    assert not any("settings" in n for n in same.notes)


def test_a_run_that_pooled_other_sessions_of_the_operator_says_so(
    bundled_run: Path, tmp_path: Path
) -> None:
    """The operator's prior is part of the noise model: a baseline that pooled none (or
    other sessions) claims different regions."""
    source = (
        "typed, times 1.2 (estimated from this session's 4 trials, 3 other sessions of operator "
        "Ada (point), the typed resolution)"
    )
    run, label = _copy_with(bundled_run, tmp_path, placing_source=source)
    outcome = check(run, bundled_run)
    assert not outcome.regressed, check_lines(outcome, bundled_run)
    said = [n for n in outcome.notes if "different priors" in n]
    assert len(said) == 1, outcome.notes
    assert said[0].startswith(f"{label} (")
    assert (
        "(the operator's other sessions pooled: in the run, 3 other sessions of operator Ada "
        "(point); in the baseline, none):" in said[0]
    )
    assert said[0].endswith("the errors are compared")
    pair = outcome.comparisons[outcome.comparisons["session"] == label]
    assert "coverage95" not in set(pair["metric"])


def test_priors_said_alike_that_pooled_other_sessions_are_told_apart(
    bundled_run: Path, tmp_path: Path
) -> None:
    """Issue 54's F5 (a new user): two runs whose session pooled "2 other sessions of
    operator Eve" but not the same two took different priors; their words alike, their
    ``prior_sessions`` not. The coverage is then not compared; the same sessions gate it."""
    source = (
        "typed, times 1.2 (estimated from this session's 4 trials, 2 other sessions of operator "
        "Eve (point), the typed resolution)"
    )
    base, _ = _copy_with(bundled_run, tmp_path / "b", placing_source=source,
                         prior_sessions="aaaa1111bbbb;cccc2222dddd")  # fmt: skip
    summary = pd.read_csv(base / "summary.csv", keep_default_na=False)
    summary["coverage95"] = pd.read_csv(bundled_run / "summary.csv")["coverage95"]
    summary.to_csv(base / "summary.csv", index=False)  # the baseline's coverage as it was
    run, _ = _copy_with(bundled_run, tmp_path / "r", placing_source=source,
                            prior_sessions="eeee3333ffff;gggg4444hhhh")  # fmt: skip
    outcome = check(run, base)
    assert not outcome.regressed, check_lines(outcome, base)
    said = [n for n in outcome.notes if "different priors" in n]
    assert len(said) == 1, outcome.notes
    assert "(sessions eeee3333, gggg4444); in the baseline," in said[0]
    assert "(sessions aaaa1111, cccc2222)):" in said[0]
    same, _ = _copy_with(bundled_run, tmp_path / "s", placing_source=source,
                         prior_sessions="aaaa1111bbbb;cccc2222dddd")  # fmt: skip
    gated = check(same, base)
    assert gated.regressed  # the same prior: the coverage's drop is a regression
    assert not any("different priors" in n for n in gated.notes)
