"""A trial whose views nearly coincide is not tested, never given a chi-square its noise
does not span (a new user's r6 G11: a clean method-2 trial of three poses read 1780 at the
typed poses and 70,610 after diverging steps, on 2 dof, flagged "no single typed value
explains it ... and that the target did not move", its 95% region 920 in)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from recorder.cli.app import app


def test_a_trial_whose_range_is_not_known_is_not_tested_nor_flagged(tmp_path: Path) -> None:
    import analysis

    session = tmp_path / "ground_s1006.mcap"
    said = CliRunner().invoke(app, [
        "simulate", str(session), "--method", "ground", "--trials", "2", "--poses", "3",
        "--frames", "3", "--pose-noise", "0.3", "--typed-resolution", "0.1",
        "--operator", "G3", "--seed", "1006",
    ])  # fmt: skip
    assert said.exit_code == 0, said.output
    trials = analysis.run([session], tmp_path / "out", jobs=1).trials.set_index("trial")
    # trial 1's views are well apart: tested as before
    assert trials.loc[1, "misclosure_dof"] == 2
    assert trials.loc[1, "misclosure_chi2"] < 10
    # trial 2's: no misclosure said, no flag, its region unwidened (1.7 in, not 920)
    assert trials.loc[2, "misclosure_dof"] == 0
    assert np.isnan(trials.loc[2, "misclosure_chi2"])
    assert not trials.loc[2, "flagged"] or trials.loc[2, "flagged_by"] != "misclosure"
    assert trials.loc[2, "semiaxis95"] < 5
