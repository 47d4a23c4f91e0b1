"""The placing sigma a rig file carries reaches every region of ``run`` (issue 46, part 1):
``--rig`` with a ``[placing]`` widens each trial's 95% region (trials.csv ``semiaxis95``)
against the typed resolution; a ``rig.toml`` beside the sessions is used and said unless
``--no-rig``; ``rig_toml`` writes the table the reader reads."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.cli import app
from analysis.rig.fit import RigFit, rig_toml
from analysis.session.pipeline import analyse_session
from recorder.simulate.one_camera import simulate_session
from tests.analysis.rig_helpers import runner
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.rig.file import load_rig_file
from twopose.uncertainty.noise import PlacingSigma

#: A placing sigma four times the simulated session's typed 0.05 in.
PLACING = '[rig]\nunits = "in"\n\n[placing]\nsigma = 0.2\nmeasured_by = "board.mcap"\n'


def test_rig_toml_writes_the_placing_the_reader_reads(tmp_path: Path) -> None:
    fit = RigFit(
        constants=RigConstants(units="in"),  # type: ignore[arg-type]
        sigma=np.full(11, np.nan),
        free=(),
        fixed={},
        chi2=1.0,
        dof=1,
        press=np.nan,
    )
    measured = PlacingSigma(
        sigma_in=0.11, sigma_sigma_in=0.02, measured_by="b1.mcap, b2.mcap", captures=16
    )
    path = tmp_path / "rig.toml"
    path.write_text(rig_toml(fit, ["b1.mcap", "b2.mcap"], placing=measured))
    assert load_rig_file(path).placing == measured
    path.write_text(rig_toml(fit, ["targets.mcap"]))  # from target sessions: none, said
    assert load_rig_file(path).placing is None
    assert "no [placing]" in path.read_text()


def _semiaxis(out: Path) -> pd.Series:
    trials = pd.read_csv(out / "trials.csv").set_index("trial")
    return trials.loc[trials["status"] == "ok", "semiaxis95"]


# Slow: it renders a 2-trial session (8 frames) and analyses it three times (about 8 s).
@pytest.mark.slow
def test_run_gives_every_region_the_rig_files_placing(tmp_path: Path) -> None:
    folder = tmp_path / "sessions"
    folder.mkdir()
    session = folder / "s.mcap"
    simulate_session(session, method=Method.POINT, trials=2, frames=2, seed=7, pose_noise=0.05)

    def run(name: str, *extra: str) -> tuple[pd.Series, str]:
        args = ["run", str(folder), "--out", str(tmp_path / name), "--no-scene", *extra]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        return _semiaxis(tmp_path / name), result.output

    plain = analyse_session(session).trials.set_index("trial")
    typed = plain.loc[plain["status"] == "ok", "semiaxis95"]
    rig_file = tmp_path / "placing.toml"
    rig_file.write_text(PLACING)
    measured, _ = run("rig", "--rig", str(rig_file))
    assert len(typed) == 2
    assert (measured > 2.0 * typed).all(), (typed, measured)  # 4x the sigma it dominates
    (folder / "rig.toml").write_text(PLACING)
    beside, said = run("beside")
    assert "found up the tree: its folder and below" in said
    pd.testing.assert_series_equal(beside, measured)
    unused, _ = run("no-rig", "--no-rig")  # not even the one beside
    pd.testing.assert_series_equal(unused, typed, check_names=False)
    both = runner.invoke(app, ["run", str(folder), "--out", str(tmp_path / "x"), "--no-rig",
                               "--rig", str(rig_file)])  # fmt: skip
    assert both.exit_code != 0
    assert "contradict" in both.output
