"""A session's trials as the rig fit takes them (analysis/rig/data.py): only trusted trials
inform the constants."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from analysis.rig.fit import fit_constants
from analysis.session.pipeline import analyse_session
from recorder.simulate.one_camera import simulate_session
from twopose.methods.specs import Method
from twopose.sim.scene import Scene

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sessions"))
from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # on sys.path at run time

from tests.analysis.rig_helpers import RIG, rig_data

pytestmark = pytest.mark.slow


def test_only_trusted_trials_inform_the_constants(tmp_path: Path) -> None:
    """A near-degenerate trial (a warning in trials.csv) is corrected but does not steer
    the fit: its linearized covariance understates its error."""
    session = tmp_path / "ground.mcap"
    simulate_session(session, method=Method.GROUND, trials=8, frames=2, seed=7,
                     scene=Scene(poses=THESIS_POSES, systematic=RIG))  # fmt: skip
    trials = analyse_session(session).trials
    ok = trials[(trials["status"] == "ok") & trials["gt_x"].notna()]
    unwarned = set(ok[ok["warning"].fillna("") == ""]["trial"])
    data = rig_data(session)
    trusted = {t for t, keep in zip(data.trial_ids, data.trusted, strict=True) if keep}
    assert set(data.trial_ids) == set(ok["trial"])
    assert trusted == unwarned
    assert 2 <= len(trusted) < len(data.trial_ids)  # this seed has both kinds
    fit = fit_constants(data, ["camera_offset"])
    assert fit.dof == 3 * len(trusted) - len(fit.free)
