"""The analysis job through the Python API: tables, units, statuses, batches, workers."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.batch.runner import results_mcap_name, run
from analysis.report.figures.draw import make_figures
from analysis.results import AnalysisOptions
from analysis.session.pipeline import analyse_session
from tests.helpers import write_accepted_capture
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import InputValueError
from twopose.format.entries import GroundTruth, PoseEntry, SessionInfo
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.solve.estimate import EstimateOptions
from twopose.values.units import Units

REQUIRED = [
    "session",
    "trial",
    "method",
    "status",
    "n_views",
    "x",
    "y",
    "z",
    "gt_x",
    "gt_y",
    "gt_z",
    "err_x",
    "err_y",
    "err_z",
    "err",
]


@pytest.mark.slow
def test_exact_poses_leave_only_detection_error(exact_sessions: Path) -> None:
    result = run([exact_sessions])
    t = result.trials
    assert (t["status"] == "ok").all()
    by = dict(list(t.groupby("method")))
    assert by["point"]["err"].max() < 0.05
    assert by["line"]["dist_err"].max() < 0.05
    assert by["line"]["angle_err_deg"].max() < 2.0
    # Method 2 extrapolates ~7 in down the finger: well-conditioned trials stay within 0.3 in,
    # and the error grows as the conditioning falls (a near-degenerate trial may reach ~1 in).
    ground = by["ground"]
    assert ground.loc[ground["conditioning"] > 0.05, "err"].max() < 0.3
    assert ground["err"].max() < 1.0
    assert (t["units"] == "in").all()


def test_output_files_columns_and_report(
    tmp_path: Path, point_session: Path, line_session: Path
) -> None:
    out = tmp_path / "out"
    # --figures png: the static figures too (a default run draws none: the charts).
    result = run([point_session, line_session], out, options=AnalysisOptions(figures=("png",)))
    trials = pd.read_csv(out / "trials.csv")
    assert set(REQUIRED) <= set(trials.columns)
    line_rows = trials[trials["method"] == "line"]
    assert line_rows[["dir_x", "dir_y", "dir_z", "angle_err_deg", "dist_err"]].notna().all().all()
    np.testing.assert_allclose(np.linalg.norm(line_rows[["dir_x", "dir_y", "dir_z"]], axis=1), 1.0)
    # err is the norm of the error vector, in the session's units
    np.testing.assert_allclose(
        trials["err"], np.linalg.norm(trials[["err_x", "err_y", "err_z"]], axis=1)
    )
    summary = pd.read_csv(out / "summary.csv")
    for col in (
        "n_trials",
        "n_ok",
        "bias_x",
        "bias_y",
        "bias_z",
        "std_x",
        "std_y",
        "std_z",
        "rmse",
        "median_err",
        "max_err",
        "within_1",
    ):
        assert col in summary.columns
    assert list(summary["n_trials"]) == [2, 2]
    averaging = pd.read_csv(out / "averaging.csv")
    assert list(averaging.columns) == [
        "session",
        "trial",
        "branch",
        "n_frames",
        "units",
        "x",
        "y",
        "z",
        "err",
        "cameras",
    ]
    assert sorted(averaging["n_frames"].unique()) == [1, 2, 3]
    frames = pd.read_csv(out / "frames.csv")
    assert len(frames) == 2 * 2 * 2 * 3
    assert frames["found"].all()
    assert (out / "errors.csv").exists()
    html = (out / "report.html").read_text()
    assert html.count("class='chart-spec'") == 2 + 2  # overview, sensitivity, two sessions
    assert "src='http" not in html  # self-contained: nothing fetched from elsewhere
    assert 'src="http' not in html
    assert "fx=525" in html
    assert set(make_figures(result)) >= {"error_histogram"}
    assert all((out / f"{name}.png").exists() for name in make_figures(result))
    # What dominates each trial, and the sensitivity sweeps, are in the report.
    assert "What dominates the error" in html
    assert "x translation" in html
    sweeps = pd.read_csv(out / "sensitivity.csv")
    assert {"pixel noise", "pose error x", "baseline length"} <= set(sweeps["sweep"])
    assert "Sensitivity (the thesis' geometry)" in html
    # The geometry per pose, and the plots made of it.
    views = pd.read_csv(out / "views.csv")
    assert len(views) == trials["n_views"].sum()
    np.testing.assert_allclose(np.linalg.norm(views[["ray_x", "ray_y", "ray_z"]], axis=1), 1.0)
    spread = views.groupby(["session", "trial"])["t_x"].agg(lambda s: s.max() - s.min())
    baseline = trials.set_index(["session", "trial"])["baseline"]
    assert (baseline.loc[spread.index] >= spread - 1e-12).all()
    for name in ("error_by_trial", "error_vs_baseline", "topview_00_point"):
        assert (out / f"{name}.png").exists(), name
    assert (out / "sensitivity.png").stat().st_size > 1000


def test_running_average_with_all_frames_equals_the_trial_estimate(ground_session: Path) -> None:
    r = analyse_session(ground_session)
    last = r.averaging[r.averaging["n_frames"] == 3].set_index("trial")
    trials = r.trials.set_index("trial")
    assert len(last) == len(trials) == 2  # both trials, averaged up to all their frames
    estimates = trials.loc[last.index, ["x", "y", "z"]].to_numpy()
    assert np.isfinite(estimates).all()  # (assert_allclose would pass NaN against NaN)
    np.testing.assert_allclose(last[["x", "y", "z"]].to_numpy(), estimates, atol=1e-12)


def test_combine_option_changes_nothing_on_clean_data_but_runs(ground_session: Path) -> None:
    mean = analyse_session(
        ground_session, AnalysisOptions(estimate=EstimateOptions(combine="mean"))
    ).trials
    robust = analyse_session(
        ground_session, AnalysisOptions(estimate=EstimateOptions(combine="robust"))
    ).trials
    assert len(mean) == len(robust) == 2
    assert np.isfinite(mean[["x", "z"]].to_numpy()).all()
    np.testing.assert_allclose(mean[["x", "z"]], robust[["x", "z"]], atol=0.05)


def _handmade(path: Path, frames_by_pose: dict[int, list[np.ndarray]], poses: int = 2) -> None:
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    with SessionWriter(
        path, SessionInfo(method=Method.POINT, units=Units.IN), [cam], start_ns=0
    ) as w:
        w.write_ground_truth(GroundTruth(trial=1, kind="point", points_grid=((0.0, 0.0, 10.0),)), 1)
        for k in range(1, poses + 1):
            w.write_pose(
                PoseEntry(trial=1, pose=k, camera_id="cam0", t_grid=(float(k), 0.0, 0.0)), 10 * k
            )
            if k in frames_by_pose:
                with w.capture(1, k, "cam0") as cap:
                    for j, img in enumerate(frames_by_pose[k]):
                        cap.add_frame(img, 10 * k + j + 1)


def test_incomplete_and_no_detection_statuses(tmp_path: Path) -> None:
    blank = np.full((480, 640, 3), 200, np.uint8)
    _handmade(tmp_path / "incomplete.mcap", {1: [blank]})
    _handmade(tmp_path / "nodetect.mcap", {1: [blank], 2: [blank]})
    a = analyse_session(tmp_path / "incomplete.mcap").trials.iloc[0]
    assert a["status"] == "incomplete"
    assert a["reason"] == "fewer than two complete captures (usable: pose 1)"
    assert np.isnan(a["x"])
    b = analyse_session(tmp_path / "nodetect.mcap")
    assert b.trials.iloc[0]["status"] == "no_detection"
    assert (~b.frames["found"]).all()
    assert b.frames["reason"].str.len().gt(0).all()


def test_bad_files_are_listed_and_the_batch_goes_on(
    tmp_path: Path, ground_session: Path, point_session: Path
) -> None:
    shutil.copy(ground_session, tmp_path / "good.mcap")
    # Another session cut short (one of good.mcap would be its copy, not a failure).
    (tmp_path / "truncated.mcap").write_bytes(point_session.read_bytes()[:40_000])
    (tmp_path / "garbage.mcap").write_bytes(b"\x00" * 100)
    out = tmp_path / "out"
    result = run([tmp_path], out, jobs=2)
    assert result.failed
    assert len(result.sessions) == 1
    errors = pd.read_csv(out / "errors.csv")
    assert sorted(Path(s).name for s in errors["session"]) == ["garbage.mcap", "truncated.mcap"]
    said = dict(zip([Path(s).name for s in errors["session"]], errors["error"], strict=True))
    assert "recover" in said["truncated.mcap"]  # an MCAP file cut short: salvaged
    assert "not an MCAP file" in said["garbage.mcap"]  # no MCAP at all: nothing to recover
    assert (result.trials["status"] == "ok").all()


def test_jobs_do_not_change_results(
    tmp_path: Path, ground_session: Path, point_session: Path, line_session: Path
) -> None:
    paths = [ground_session, point_session, line_session]
    one = run(paths, jobs=1)
    # Equal empty tables would pass: every session's trials and frames are there.
    assert sorted(one.trials["method"].unique()) == ["ground", "line", "point"]
    assert (one.trials["status"] == "ok").all()
    assert len(one.frames) > 0
    assert len(one.averaging) > 0
    assert len(one.summary) == 3
    for jobs in (2, 3):  # the main process works too: 1 or 2 workers beside it
        many = run(paths, jobs=jobs)
        for a, b in (
            (one.trials, many.trials),
            (one.frames, many.frames),
            (one.averaging, many.averaging),
            (one.summary, many.summary),
        ):
            pd.testing.assert_frame_equal(a, b)


def test_dask_local_cluster_gives_the_same_tables(
    tmp_path: Path, ground_session: Path, point_session: Path
) -> None:
    distributed = pytest.importorskip("distributed")
    paths = [ground_session, point_session]
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster:
        on_dask = run(paths, tmp_path, dask_address=cluster.scheduler_address)
    local = run(paths)
    assert len(local.trials) > 0
    assert (local.trials["status"] == "ok").all()
    pd.testing.assert_frame_equal(on_dask.trials, local.trials)
    assert {p.name for p in tmp_path.glob("*.mcap")} == {
        results_mcap_name(i, p) for i, p in enumerate(paths)
    }


@pytest.mark.slow
def test_unreachable_dask_scheduler_is_a_clear_error(ground_session: Path) -> None:
    with pytest.raises(InputValueError, match="cannot reach the Dask scheduler"):
        run([ground_session], dask_address="tcp://127.0.0.1:9")


def test_bad_arguments(ground_session: Path, tmp_path: Path) -> None:
    with pytest.raises(InputValueError, match="jobs"):
        run([ground_session], jobs=0)
    with pytest.raises(InputValueError, match="does not exist"):
        run([tmp_path / "nope"])


def test_the_package_is_the_api(ground_session: Path) -> None:
    import analysis

    result = analysis.run([ground_session])
    assert list(result.trials["trial"]) == [1, 2]
    assert set(make_figures(result)) == {
        "scatter_00_ground",
        "topview_00_ground",
        "averaging_00_ground",
        "error_histogram",
        "error_by_trial",
        "error_vs_baseline",
    }


@pytest.mark.slow
@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_trials_with_more_than_two_poses_use_every_view(tmp_path: Path, method: str) -> None:
    from recorder.simulate.one_camera import simulate_session

    out = tmp_path / f"{method}.mcap"
    simulate_session(
        out, method=Method(method), trials=3, frames=2, seed=31, pose_noise=0.0, poses=4
    )
    t = analyse_session(out).trials
    assert list(t["n_views"]) == [4, 4, 4]
    assert (t["status"] == "ok").all()
    if method == "point":
        assert t["err"].max() < 0.05
        assert t["err_optimal"].max() < 0.05
        assert {"x_optimal", "y_optimal", "z_optimal"} <= set(t.columns)
    elif method == "line":
        assert t["dist_err"].max() < 0.05
        assert t["angle_err_deg"].max() < 2.0
        assert t["dist_err_optimal"].max() < 0.05  # the reprojection-optimal line beside it
        assert t["angle_err_optimal_deg"].max() < 2.0
    else:
        assert t["err"].max() < 0.5


def test_degeneracy_margins_and_configurable_warnings(
    ground_session: Path, point_session: Path
) -> None:
    strict = AnalysisOptions(
        estimate=EstimateOptions(
            min_plane_angle_deg=90.0, min_ground_angle_deg=90.0, min_parallax_deg=90.0
        )
    )
    g = analyse_session(ground_session, strict).trials
    assert (g["plane_angle_deg"] > 0).all()
    assert (g["line_plane_angle_deg"] > 0).all()
    assert g["warning"].str.contains("plane angle").all()
    assert g["warning"].str.contains("line-ground angle").all()
    lax = AnalysisOptions(
        estimate=EstimateOptions(
            min_plane_angle_deg=0.0, min_ground_angle_deg=0.0, min_parallax_deg=0.0
        )
    )
    assert (analyse_session(ground_session, lax).trials["warning"] == "").all()
    p = analyse_session(point_session, strict).trials
    np.testing.assert_allclose(np.sin(np.radians(p["parallax_deg"])), p["conditioning"], atol=1e-12)
    assert p["warning"].str.contains("ray parallax").all()
    assert (g["status"] == "ok").all()  # a warning is not a failure


def test_every_estimate_carries_its_uncertainty(
    point_session: Path, line_session: Path, ground_session: Path
) -> None:
    t = run([point_session, line_session, ground_session]).trials
    assert (t["status"] == "ok").all()
    by = dict(list(t.groupby("method")))
    for method, dof in (("point", 3), ("line", 2), ("ground", 2)):
        g = by[method]
        assert (g["nees_dof"] == dof).all(), method
        assert g[["sigma_x", "sigma_z", "semiaxis95", "nees"]].gt(0).all().all(), method
        np.testing.assert_allclose(g["ci95_z"], 1.959964 * g["sigma_z"], rtol=1e-6)
        # The 0.1 in placing error recorded with every pose dominates the pixels.
        assert (g["dominant_input"].str.endswith("translation")).all(), method
        assert g["dominant_share"].between(0.34, 1.0).all()
    assert by["ground"]["sigma_y"].max() < 1e-6  # the ground plane fixes the height


@pytest.mark.slow  # the exact sessions' fixture simulates three sessions (~12 s)
def test_poses_typed_exactly_leave_the_pixels_dominant(
    point_session: Path, exact_sessions: Path
) -> None:
    by = dict(list(run([point_session]).trials.groupby("method")))
    # Poses typed exactly (recorded 1-sigma 1e-9): what remains is the pixels' scatter.
    exact = run([exact_sessions]).trials
    assert (exact["dominant_input"] == "pixels").all()
    exact_points = exact[exact["method"] == "point"]
    assert exact_points["sigma_z"].max() < by["point"]["sigma_z"].min() / 5


def test_outlier_frames_are_rejected_and_reported(tmp_path: Path, point_session: Path) -> None:
    """A frame of another pose slipped into pose 1: robust combining drops it and says so."""
    from twopose.format.reader import SessionReader
    from twopose.format.trials import iter_trials

    with SessionReader(point_session) as reader:
        record = next(iter_trials(reader))
        info, cameras = reader.info, list(reader.cameras.values())
        frames = {pc.entry.pose: [f.decode() for f in pc.frames] for pc in record.poses}
        entries = {pc.entry.pose: pc.entry for pc in record.poses}
    frames[1].append(frames[2][0])  # index 3 of pose 1
    out = tmp_path / "outlier.mcap"
    with SessionWriter(out, info, cameras, start_ns=0) as w:
        assert record.ground_truth is not None
        w.write_ground_truth(record.ground_truth, 1)
        for k, entry in entries.items():
            write_accepted_capture(w, entry, frames[k], 10 * k)
    robust = analyse_session(
        out, AnalysisOptions(estimate=EstimateOptions(combine="robust"))
    ).trials.iloc[0]
    mean = analyse_session(out).trials.iloc[0]
    clean = analyse_session(point_session).trials.iloc[0]
    assert robust["rejected_frames"] == "pose 1: 3"
    assert mean["rejected_frames"] == ""
    assert abs(robust["x"] - clean["x"]) < 0.01 < abs(mean["x"] - clean["x"])


def test_a_line_session_without_ground_truth_still_reports_lines(
    tmp_path: Path, line_session: Path
) -> None:
    """No truth: the line is reported at its point nearest the last camera, with its
    uncertainty; the error columns and NEES stay empty."""
    from twopose.format.reader import SessionReader
    from twopose.format.trials import iter_trials

    out = tmp_path / "no_truth.mcap"
    with SessionReader(line_session) as reader:
        info, cameras, ground = reader.info, list(reader.cameras.values()), reader.ground
        with SessionWriter(out, info, cameras, ground=ground, start_ns=0) as w:
            t = 1
            for record in iter_trials(reader):
                for pc in record.poses:
                    t = write_accepted_capture(w, pc.entry, [f.data for f in pc.frames], t)
    bare = analyse_session(out).trials
    full = analyse_session(line_session).trials
    assert (bare["status"] == "ok").all()
    assert bare[["x", "y", "z", "sigma_x", "sigma_z", "dir_x"]].notna().all().all()
    assert bare[["err", "nees", "angle_err_deg"]].isna().all().all()
    np.testing.assert_allclose(bare[["dir_x", "dir_y", "dir_z"]], full[["dir_x", "dir_y", "dir_z"]])
    # Both points lie on the same line.
    offset = bare[["x", "y", "z"]].to_numpy(float) - full[["x", "y", "z"]].to_numpy(float)
    across = offset - np.sum(offset * bare[["dir_x", "dir_y", "dir_z"]].to_numpy(float), axis=1)[
        :, None
    ] * bare[["dir_x", "dir_y", "dir_z"]].to_numpy(float)
    assert np.abs(across).max() < 1e-6
