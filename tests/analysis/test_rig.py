"""The rig's constants (analysis/rig/fit.py): estimated from a session's own ground truth,
checked for identifiability, selected by cross-validation, written and applied."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

from analysis.cli import app
from analysis.rig.fit import fit_constants, residuals, select_constants
from analysis.session.pipeline import analyse_session
from recorder.simulate.one_camera import simulate_session
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.sim.scene import Scene

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sessions"))
from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # on sys.path at run time

from tests.analysis.rig_helpers import RIG, rig_data, runner

pytestmark = pytest.mark.slow


def test_the_constants_are_found_within_their_intervals(rig_sessions: dict[str, Path]) -> None:
    fit = fit_constants(rig_data(rig_sessions["with"]), ["camera_offset", "mount_rotation_deg"])
    assert set(fit.free) == {
        "offset_x",
        "offset_y",
        "offset_z",
        *(f"mount_r{a}_deg" for a in "xyz"),
    }
    rows = {r["constant"]: r for r in fit.rows(RIG)}
    for name in fit.free:
        row = rows[name]
        assert abs(row["value"] - row["truth"]) <= 3 * row["sigma"], row  # type: ignore[operator]
    assert np.isfinite(fit.chi2)
    assert fit.dof == 3 * 10 - 6  # 10 trials of 3 residuals, 6 constants


def test_what_a_session_cannot_determine_is_fixed_and_named(rig_sessions: dict[str, Path]) -> None:
    fit = fit_constants(rig_data(rig_sessions["with"]), ["ground_height_error", "camera_offset"])
    assert fit.fixed == {"ground_height_error": "no trial of this session depends on it"}
    assert "ground_height_error" not in fit.free
    assert np.isnan(fit.sigma[-1])


def test_a_session_without_constants_keeps_none(rig_sessions: dict[str, Path]) -> None:
    fit = select_constants(rig_data(rig_sessions["without"]))
    assert fit.free == ()
    assert fit.constants.is_identity


def test_rig_writes_a_file_that_run_applies(rig_sessions: dict[str, Path], tmp_path: Path) -> None:
    rig_file = tmp_path / "rig.toml"
    args = ["rig", str(rig_sessions["with"]), "--out", str(rig_file)]
    constants = ["--constant", "camera_offset", "--constant", "mount_rotation_deg"]
    result = runner.invoke(app, [*args, *constants])
    assert result.exit_code == 0, result.output
    assert "offset_x = " in result.output
    text = rig_file.read_text()
    assert "[rig]" in text
    assert 'units = "in"' in text  # the offsets are lengths: the file says in what
    assert "camera_offset = [" in text
    before = analyse_session(rig_sessions["with"]).trials
    run = runner.invoke(
        app, ["run", str(rig_sessions["with"]), "--out", str(tmp_path / "o"), "--no-scene",
              "--rig", str(rig_file)],
    )  # fmt: skip
    assert run.exit_code == 0, run.output
    import pandas as pd

    after = pd.read_csv(tmp_path / "o" / "trials.csv")
    bias = [np.abs(t[["err_x", "err_y", "err_z"]].mean()).max() for t in (before, after)]
    assert bias[1] < 0.5 * bias[0]  # the constants' bias is gone (in-sample)
    assert np.sqrt((after["err"] ** 2).mean()) < np.sqrt((before["err"] ** 2).mean())
    # The run says which rig corrected it: terminal, summary.json and report.
    import hashlib
    import json

    digest = hashlib.sha256(rig_file.read_bytes()).hexdigest()
    said = f"rig file {rig_file} (given by --rig; sha256 {digest[:16]}...): every view"
    assert said in run.output
    recorded = json.loads((tmp_path / "o" / "summary.json").read_text())["rig"]
    assert recorded["path"] == str(rig_file)
    assert recorded["sha256"] == digest
    assert recorded["constants"]["units"] == "in"
    assert len(recorded["constants"]["camera_offset"]) == 3
    assert digest[:16] in (tmp_path / "o" / "report.html").read_text()
    plain = runner.invoke(
        app, ["run", str(rig_sessions["with"]), "--out", str(tmp_path / "p"), "--no-scene"]
    )
    assert plain.exit_code == 0, plain.output
    assert json.loads((tmp_path / "p" / "summary.json").read_text())["rig"] is None
    assert "No rig file" in (tmp_path / "p" / "report.html").read_text()


def test_a_bad_rig_file_is_refused(rig_sessions: dict[str, Path], tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[rig]\nfocal_scale = 7\n")
    result = runner.invoke(
        app, ["run", str(rig_sessions["without"]), "--out", str(tmp_path / "o"), "--rig", str(bad)]
    )
    assert result.exit_code == 3
    assert "focal_scale and tape_scale must be within" in result.output
    mixed = runner.invoke(app, ["rig", str(rig_sessions["with"]), "--constant", "warp_drive"])
    assert mixed.exit_code == 3
    assert "unknown rig constant" in mixed.output


def test_run_rig_calibration_loo_is_honest(rig_sessions: dict[str, Path], tmp_path: Path) -> None:
    """Each trial corrected by constants fitted without it: the bias goes, a session
    without constants is not made worse, and rig.csv sets the estimates against the truth."""
    import pandas as pd

    out = tmp_path / "o"
    args = ["run", str(rig_sessions["with"]), str(rig_sessions["without"]), "--out", str(out)]
    result = runner.invoke(app, [*args, "--no-scene", "--rig-calibration", "loo"])
    assert result.exit_code == 0, result.output
    trials = pd.read_csv(out / "trials.csv")
    assert {"x_rig", "y_rig", "z_rig", "err_rig", "within95_rig"} <= set(trials.columns)
    # The corrected regions (random plus the constants' covariance): known for every
    # trial, and where the constants biased the estimates they hold the truth more often.
    assert trials["within95_rig"].notna().all()
    biased = trials[trials["session"].str.endswith("/with.mcap")]
    assert biased["within95_rig"].mean() > biased["within95"].astype(float).mean()
    rmse = {
        Path(str(s)).stem: (np.sqrt((g["err"] ** 2).mean()), np.sqrt((g["err_rig"] ** 2).mean()))
        for s, g in trials.groupby("session")
    }
    assert rmse["with"][1] < 0.7 * rmse["with"][0]
    assert rmse["without"][1] <= 1.05 * rmse["without"][0]
    rig = pd.read_csv(out / "rig.csv")
    assert list(rig.columns) == [
        "session",
        "constant",
        "units",
        "value",
        "sigma",
        "fitted",
        "why_fixed",
        "truth",
    ]
    with_rows = rig[rig["session"].str.endswith("/with.mcap")].set_index("constant")
    assert with_rows.loc["offset_x", "truth"] == pytest.approx(0.3)
    assert rig[rig["session"].str.endswith("without.mcap")]["truth"].isna().all()
    # What dominates: the constants, in the session that has them; never without them.
    dominant = trials.groupby(trials["session"].map(lambda s: Path(s).stem))["dominant_input"]
    assert (dominant.get_group("with") == "systematic").sum() > 0
    assert (dominant.get_group("without") == "systematic").sum() == 0
    page = (out / "report.html").read_text()
    assert "The rig's constants" in page
    assert "RMSE, rig corrected (leave one out)" in page
    assert not rig[rig["session"].str.endswith("without.mcap")]["fitted"].any()


def test_line_trials_get_the_corrected_line_columns(tmp_path: Path) -> None:
    """The line method: each trial's corrected line (direction, angle and distance
    errors) beside the uncorrected one; the constants' bias leaves the distance."""
    import pandas as pd

    session = tmp_path / "line.mcap"
    poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
    scene = Scene(poses=poses, systematic=RIG)
    simulate_session(session, method=Method.LINE, trials=8, frames=2, seed=43, scene=scene)
    out = tmp_path / "o"
    args = ["run", str(session), "--out", str(out), "--no-scene", "--rig-calibration", "loo"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    trials = pd.read_csv(out / "trials.csv")
    line_columns = ["dir_x_rig", "dir_y_rig", "dir_z_rig", "angle_err_rig_deg", "dist_err_rig"]
    ok = trials[trials["status"] == "ok"]
    assert len(ok) >= 6
    assert ok[line_columns].notna().all().all()
    norms = np.linalg.norm(ok[["dir_x_rig", "dir_y_rig", "dir_z_rig"]].to_numpy(), axis=1)
    np.testing.assert_allclose(norms, 1.0, atol=1e-9)
    assert (ok["angle_err_rig_deg"].between(0, 90)).all()
    # err_rig is the distance of the corrected line from the true midpoint, as err is.
    np.testing.assert_allclose(ok["dist_err_rig"], ok["err_rig"], atol=1e-9)
    np.testing.assert_allclose(ok["dist_err"], ok["err"], atol=1e-9)
    assert ok["dist_err_rig"].mean() < ok["dist_err"].mean()


def test_a_ground_height_error_is_found_off_the_typed_plane(tmp_path: Path) -> None:
    """Method 2 estimates lie on the typed ground plane, so the error along its normal has
    no propagated variance; the fit must still weigh it, or a wrong ground height (and the
    constants that trade with it) goes unseen."""
    session = tmp_path / "ground.mcap"
    rig = RigConstants(ground_height_error=0.5)
    poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
    simulate_session(session, method=Method.GROUND, trials=8, frames=2, seed=11,
                     scene=Scene(poses=poses, systematic=rig))  # fmt: skip
    data = rig_data(session).fitting()
    ground = rig_data(session).grounds[0]
    assert ground is not None
    normal = np.array(ground[0])
    shifted = dataclasses.replace(data, truth=data.truth + 1.0 * normal)
    change = (residuals(shifted, rig) - residuals(data, rig)).reshape(-1, 3)
    assert len(change) >= 2
    assert (np.linalg.norm(change, axis=1) > 1.0).all()  # a 1-unit miss off the plane counts
    fit = fit_constants(data, ["ground_height_error"])
    assert fit.free == ("ground_height_error",)
    value, sigma = fit.constants.ground_height_error, fit.sigma[-1]
    assert abs(value - 0.5) < 0.05
    assert abs(value - 0.5) <= 3 * sigma


def test_a_constant_pushed_against_its_prior_is_said(
    rig_sessions: dict[str, Path], tmp_path: Path
) -> None:
    """A mount turned 8 degrees (prior 3): the fit finds it and says that the data push it
    past two prior sigmas, in the fit and in the rig file's header; RIG's mount (under a
    degree) is found without a word."""
    session = tmp_path / "tilted.mcap"
    poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
    scene = Scene(poses=poses, systematic=RigConstants(mount_rotation_deg=(8.0, 0.0, 0.0)))
    simulate_session(session, method=Method.POINT, trials=10, frames=2, seed=41, scene=scene)
    fit = fit_constants(rig_data(session), ["mount_rotation_deg"])
    assert fit.constants.mount_rotation_deg[0] > 6.0
    assert any(w.startswith("mount_rx_deg = nominal +") for w in fit.warnings), fit.warnings
    out = tmp_path / "rig.toml"
    result = runner.invoke(
        app, ["rig", str(session), "--out", str(out), "--constant", "mount_rotation_deg"]
    )
    assert result.exit_code == 0, result.output
    assert "prior sigmas off" in result.output
    assert "# warning: mount_rx_deg" in out.read_text()
    quiet = fit_constants(rig_data(rig_sessions["with"]), ["mount_rotation_deg"])
    assert quiet.warnings == ()
