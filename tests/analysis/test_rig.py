"""The rig's constants: estimated from a session's own ground truth, checked for
identifiability, selected by cross-validation, written and applied."""

from __future__ import annotations

import dataclasses
import itertools
import shutil
import sys
from pathlib import Path
from typing import Literal

import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.pipeline import analyse_session, replay_views
from analysis.rig import fit_constants, residuals, select_constants
from analysis.rig_data import RigData, prepare_trials
from recorder.simulate import simulate_session
from twopose.methods import Method
from twopose.rig import RigConstants
from twopose.sim.scene import Scene
from twopose.units import Units

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sessions"))
from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # on sys.path at run time

# Slow (a real browser, a cluster, or fits over many sessions): make test-all and CI run it.
pytestmark = pytest.mark.slow

runner = CliRunner()
RIG = RigConstants(camera_offset=(0.3, 0.2, 0.4), mount_rotation_deg=(0.8, -0.5, 0.3))


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("rig")
    out = {}
    for name, rig in (("with", RIG), ("without", RigConstants())):
        out[name] = folder / f"{name}.mcap"
        # No typing error: what remains is the constants' bias and the pixels' noise.
        poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
        scene = Scene(poses=poses, systematic=rig)
        simulate_session(out[name], method="point", trials=10, frames=2, seed=41, scene=scene)
    return out


def _data(path: Path) -> RigData:
    return prepare_trials(replay_views(path))


def test_the_constants_are_found_within_their_intervals(sessions: dict[str, Path]) -> None:
    fit = fit_constants(_data(sessions["with"]), ["camera_offset", "mount_rotation_deg"])
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


def test_what_a_session_cannot_determine_is_fixed_and_named(sessions: dict[str, Path]) -> None:
    fit = fit_constants(_data(sessions["with"]), ["ground_height_error", "camera_offset"])
    assert fit.fixed == {"ground_height_error": "no trial of this session depends on it"}
    assert "ground_height_error" not in fit.free
    assert np.isnan(fit.sigma[-1])


def test_a_session_without_constants_keeps_none(sessions: dict[str, Path]) -> None:
    fit = select_constants(_data(sessions["without"]))
    assert fit.free == ()
    assert fit.constants.is_identity


def test_rig_writes_a_file_that_run_applies(sessions: dict[str, Path], tmp_path: Path) -> None:
    rig_file = tmp_path / "rig.toml"
    args = ["rig", str(sessions["with"]), "--out", str(rig_file)]
    constants = ["--constant", "camera_offset", "--constant", "mount_rotation_deg"]
    result = runner.invoke(app, [*args, *constants])
    assert result.exit_code == 0, result.output
    assert "offset_x = " in result.output
    text = rig_file.read_text()
    assert "[rig]" in text
    assert 'units = "in"' in text  # the offsets are lengths: the file says in what
    assert "camera_offset = [" in text
    before = analyse_session(sessions["with"]).trials
    run = runner.invoke(
        app, ["run", str(sessions["with"]), "--out", str(tmp_path / "o"), "--no-scene",
              "--rig", str(rig_file)],
    )  # fmt: skip
    assert run.exit_code == 0, run.output
    import pandas as pd

    after = pd.read_csv(tmp_path / "o" / "trials.csv")
    bias = [np.abs(t[["err_x", "err_y", "err_z"]].mean()).max() for t in (before, after)]
    assert bias[1] < 0.5 * bias[0]  # the constants' bias is gone (in-sample)
    assert np.sqrt((after["err"] ** 2).mean()) < np.sqrt((before["err"] ** 2).mean())


def test_a_bad_rig_file_is_refused(sessions: dict[str, Path], tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[rig]\nfocal_scale = 7\n")
    result = runner.invoke(
        app, ["run", str(sessions["without"]), "--out", str(tmp_path / "o"), "--rig", str(bad)]
    )
    assert result.exit_code == 3
    assert "focal_scale and tape_scale must be within" in result.output
    mixed = runner.invoke(app, ["rig", str(sessions["with"]), "--constant", "warp_drive"])
    assert mixed.exit_code == 3
    assert "unknown rig constant" in mixed.output


def test_run_rig_calibration_loo_is_honest(sessions: dict[str, Path], tmp_path: Path) -> None:
    """Each trial corrected by constants fitted without it: the bias goes, a session
    without constants is not made worse, and rig.csv sets the estimates against the truth."""
    import pandas as pd

    out = tmp_path / "o"
    args = ["run", str(sessions["with"]), str(sessions["without"]), "--out", str(out)]
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
    assert "rmse_rig_loo" in page
    assert not rig[rig["session"].str.endswith("without.mcap")]["fitted"].any()


def test_line_trials_get_the_corrected_line_columns(tmp_path: Path) -> None:
    """The line method: each trial's corrected line (direction, angle and distance
    errors) beside the uncorrected one; the constants' bias leaves the distance."""
    import pandas as pd

    session = tmp_path / "line.mcap"
    poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
    scene = Scene(poses=poses, systematic=RIG)
    simulate_session(session, method="line", trials=8, frames=2, seed=43, scene=scene)
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


def test_only_trusted_trials_inform_the_constants(tmp_path: Path) -> None:
    """A near-degenerate trial (a warning in trials.csv) is corrected but does not steer
    the fit: its linearized covariance understates its error."""
    session = tmp_path / "ground.mcap"
    simulate_session(session, method="ground", trials=8, frames=2, seed=7,
                     scene=Scene(poses=THESIS_POSES, systematic=RIG))  # fmt: skip
    trials = analyse_session(session).trials
    ok = trials[(trials["status"] == "ok") & trials["gt_x"].notna()]
    unwarned = set(ok[ok["warning"].fillna("") == ""]["trial"])
    data = _data(session)
    trusted = {t for t, keep in zip(data.trial_ids, data.trusted, strict=True) if keep}
    assert set(data.trial_ids) == set(ok["trial"])
    assert trusted == unwarned
    assert 2 <= len(trusted) < len(data.trial_ids)  # this seed has both kinds
    fit = fit_constants(data, ["camera_offset"])
    assert fit.dof == 3 * len(trusted) - len(fit.free)


def test_a_ground_height_error_is_found_off_the_typed_plane(tmp_path: Path) -> None:
    """Method 2 estimates lie on the typed ground plane, so the error along its normal has
    no propagated variance; the fit must still weigh it, or a wrong ground height (and the
    constants that trade with it) goes unseen."""
    session = tmp_path / "ground.mcap"
    rig = RigConstants(ground_height_error=0.5)
    poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
    simulate_session(session, method="ground", trials=8, frames=2, seed=11,
                     scene=Scene(poses=poses, systematic=rig))  # fmt: skip
    data = _data(session).fitting()
    ground = _data(session).grounds[0]
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


# Several sessions at once (issue 22): each solved with its own ground plane, intrinsics
# and units; given in any order, or twice, they give the same constants.


@pytest.fixture(scope="module")
def tables(exact_sessions: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two clean method 2 sessions, the tables at 9.625 in (the shared exact session) and
    10.5 in (the same seed, typing and trials; only the table is lower)."""
    high = tmp_path_factory.mktemp("tables") / "table_10.5.mcap"
    simulate_session(high, method="ground", trials=4, frames=2, seed=22, pose_noise=0.0,
                     scene=Scene(ground_height=10.5))  # fmt: skip
    return {"9.625": exact_sessions / "ground.mcap", "10.5": high}


def _empty_session(
    path: Path, method: Literal["point", "line", "ground"], units: str, ground: float | None = None
) -> Path:
    """A session without trials (what a recording that stopped at once leaves)."""
    from twopose.camera import Camera, Intrinsics
    from twopose.format.entries import GroundPlane, SessionInfo
    from twopose.format.writer import SessionWriter

    camera = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    plane = GroundPlane(offset=ground) if ground is not None else None
    info = SessionInfo(method=Method(method), units=Units(units))
    with SessionWriter(path, info, [camera], ground=plane):
        pass
    return path


def _rig_values(path: Path) -> dict[str, object]:
    """The [rig] and [sigma] tables of a rig file (what `run --rig` reads, and the 1-sigma)."""
    import tomllib

    data = tomllib.loads(path.read_text())
    return {"rig": data["rig"], "sigma": data["sigma"]}


def _rig(tmp_path: Path, *paths: Path) -> tuple[dict[str, object], str]:
    out = tmp_path / f"rig_{len(list(tmp_path.glob('rig_*.toml')))}.toml"
    result = runner.invoke(app, ["rig", *(str(p) for p in paths), "--out", str(out)])
    assert result.exit_code == 0, result.output
    return _rig_values(out), result.output


@pytest.mark.parametrize("order", list(itertools.permutations(range(3))))
def test_the_constants_do_not_depend_on_the_order_of_the_sessions(
    sessions: dict[str, Path], tmp_path: Path, order: tuple[int, ...]
) -> None:
    """Every permutation of three sessions, one of them a copy of another: the same
    constants and sigmas, to the last digit, as the two distinct sessions give."""
    from analysis.calibration import calibrate

    copy = tmp_path / "copy_of_with.mcap"
    shutil.copyfile(sessions["with"], copy)
    given = [sessions["with"], sessions["without"], copy]
    reference, _ = calibrate([str(sessions["with"]), str(sessions["without"])])
    fit, data = calibrate([str(given[i]) for i in order])
    assert len(data.trial_ids) == 20  # the copy's 10 trials are not counted again
    assert np.array_equal(fit.constants.vector(), reference.constants.vector())
    assert np.array_equal(fit.sigma, reference.sigma, equal_nan=True)
    assert (fit.free, fit.chi2, fit.dof) == (reference.free, reference.chi2, reference.dof)


def test_a_session_given_twice_is_counted_once(sessions: dict[str, Path], tmp_path: Path) -> None:
    """``rig S S`` and ``rig S copy-of-S`` fit what ``rig S`` fits, with a note (the
    duplicated trials fooled the leave-one-out selection and halved the variances)."""
    once, _ = _rig(tmp_path, sessions["with"])
    twice, output = _rig(tmp_path, sessions["with"], sessions["with"])
    assert twice == once
    assert "given twice: counted once" in output
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(sessions["with"], copy)
    copied, output = _rig(tmp_path, sessions["with"], copy)
    assert copied == once
    assert f"{copy} holds the same session as {sessions['with']}" in output


def test_tables_at_two_heights_fit_no_ground_height_error(
    tables: dict[str, Path], tmp_path: Path
) -> None:
    """Two clean method 2 sessions, tables at 9.625 and 10.5 in: each solved on its own
    table, so no ground height error appears, whichever is named first (both were solved
    on the first one's table: a ground height error of either sign, by the order)."""
    low, high = tables["9.625"], tables["10.5"]
    first, _ = _rig(tmp_path, low, high)
    second, _ = _rig(tmp_path, high, low)
    assert first == second
    assert first["rig"]["ground_height_error"] == 0  # type: ignore[index]
    assert first["sigma"]["ground_height_error"] == 0  # type: ignore[index]  # not fitted


def test_a_session_without_trials_changes_nothing(tables: dict[str, Path], tmp_path: Path) -> None:
    """A session with no trial, named first, on a table at 12 in: the others' fit is
    unchanged (its ground plane was everyone's), and a note says it informs nothing."""
    empty = _empty_session(tmp_path / "empty.mcap", "ground", "in", ground=12.0)
    alone, _ = _rig(tmp_path, tables["9.625"], tables["10.5"])
    with_empty, output = _rig(tmp_path, empty, tables["9.625"], tables["10.5"])
    assert with_empty == alone
    assert f"{empty}: no ok trial with ground truth; it informs nothing" in output


def test_sessions_in_different_units_are_refused(sessions: dict[str, Path], tmp_path: Path) -> None:
    metric = _empty_session(tmp_path / "metric.mcap", "point", "mm")
    out = tmp_path / "rig.toml"
    result = runner.invoke(app, ["rig", str(sessions["with"]), str(metric), "--out", str(out)])
    assert result.exit_code == 3, result.output
    assert f"{sessions['with']} (in), {metric} (mm)" in result.output
    assert not out.exists()


def test_run_refuses_a_rig_in_other_units(sessions: dict[str, Path], tmp_path: Path) -> None:
    """A rig in mm for a session in inches: a clear error before any analysis (exit 3); a
    rig file from before units were recorded is read as before, with a note."""
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text('[rig]\nunits = "mm"\ncamera_offset = [3.0, 2.0, 4.0]\n')
    args = ["run", str(sessions["without"]), "--out", str(tmp_path / "o"), "--no-scene"]
    result = runner.invoke(app, [*args, "--rig", str(rig_file)])
    assert result.exit_code == 3, result.output
    assert "is in mm, the session in in" in result.output
    assert not (tmp_path / "o").exists()
    rig_file.write_text("[rig]\ncamera_offset = [0.3, 0.2, 0.4]\n")
    result = runner.invoke(app, [*args, "--rig", str(rig_file)])
    assert result.exit_code == 0, result.output
    assert "records no units" in result.output
    assert "taken in the session's units (in)" in result.output


@pytest.mark.parametrize(
    ("line", "named"),
    [
        ("ground_height_error = 1e300", "ground_height_error = 1e+300 (within half the ground"),
        ("ground_height_error = 6.0", "ground_height_error = 6 (within half the ground height"),
        ("mount_rotation_deg = [180, 0, 0]", "mount_rotation_deg = [180, 0, 0] (each angle"),
        ("principal_offset_px = [1e300, 0]", "principal_offset_px = [1e+300, 0] (within a quar"),
    ],
)
def test_run_refuses_an_implausible_rig(
    tables: dict[str, Path], tmp_path: Path, line: str, named: str
) -> None:
    """What gave 6/6 'ok' trials with an infinite error or an RMSE of 13.8 in, or an
    'unexpected LinAlgError': refused before the analysis, naming the key and the limit."""
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text(f"[rig]\n{line}\n")
    out = tmp_path / "o"
    args = ["run", str(tables["9.625"]), "--out", str(out), "--no-scene", "--rig", str(rig_file)]
    result = runner.invoke(app, args)
    assert result.exit_code == 3, result.output
    assert "implausible for a laptop on grid paper" in result.output
    assert named in result.output
    assert "unexpected" not in result.output
    assert not out.exists()
