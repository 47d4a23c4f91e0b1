"""The thesis' reported figures against what twopose reproduces (thesis.csv)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.batch import run
from analysis.thesis import THESIS_COLUMNS, fisher_p, thesis_table

SESSIONS = Path(__file__).resolve().parents[2] / "sessions"


def test_fisher_exact_test_against_fifteen_of_fifteen() -> None:
    assert fisher_p(15, 15) == pytest.approx(1.0)
    assert fisher_p(12, 13) == pytest.approx(13 / 28)  # the only as-likely table: itself
    assert fisher_p(5, 15) < 0.001


def _ground_trials(err_x: np.ndarray) -> pd.DataFrame:
    n = len(err_x)
    return pd.DataFrame(
        {
            "session": "s.mcap",
            "trial": np.arange(1, n + 1),
            "method": "ground",
            "units": "mm",
            "status": "ok",
            "err_x": err_x,
            "err": np.abs(err_x) + 1.0,
            "warning": "",
            "gt_x": 48.5,
            "gt_y": 244.5,
            "gt_z": 212.7,
        }
    )


def test_method2_row_reads_the_x_bias_in_inches() -> None:
    rng = np.random.default_rng(0)
    biased = _ground_trials(5.0 + rng.normal(0, 1.0, 15))  # mm: +0.2 in, clearly
    table = thesis_table(biased, pd.DataFrame(columns=["session", "trial", "n_frames"]))
    assert list(table.columns) == THESIS_COLUMNS
    row = table.iloc[1]
    assert row["reproduced"] == "yes"
    assert "15 of 15 trials within 1 in" in row["twopose"]
    assert "x bias +0.19 ± 0.02 in" in row["twopose"]  # 4.9 mm: the mean of the draws
    unbiased = _ground_trials(rng.normal(0, 1.0, 15))
    row = thesis_table(unbiased, pd.DataFrame(columns=["session", "trial", "n_frames"])).iloc[1]
    assert row["reproduced"] == "errors yes, x bias no"
    assert "not significant" in row["twopose"]
    assert table.iloc[3]["reproduced"] == "no data"  # no trial with 50 frames


def test_the_bundled_thesis_sessions_reproduce_the_thesis(tmp_path: Path) -> None:
    result = run(sorted(SESSIONS.glob("thesis_*.mcap")), tmp_path / "out", scene=False)
    table = pd.read_csv(tmp_path / "out" / "thesis.csv")
    claims = table.set_index("claim")["reproduced"]
    assert claims["method 1 (fixed point) errors"] == "yes"
    assert claims["method 2 (pointed ground point) errors"].startswith("errors ")
    assert claims.iloc[3] == "yes"  # 5 against 50 averages: about 1%
    assert "The thesis, reproduced" in (tmp_path / "out" / "report.html").read_text()
    assert result.summary["n_trials"].sum() == 48
