"""A two-camera session's rows in every table where a row means something (issue 58 item 6):
``frames.csv`` (each camera's frames, capture and write time), ``views.csv`` (every frame
pair, used or flagged, its rays meeting at the estimate), ``averaging.csv`` (per touch);
its results.mcap, so that a re-run reuses it and a change re-analyses it; the same tables
from worker processes; a session's parts analysed as one; a continuation read with its pair."""

from __future__ import annotations

import dataclasses
import shutil
import uuid
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import analysis
from analysis.tables.columns import AVERAGING_COLUMNS, FRAME_COLUMNS, VIEW_COLUMNS
from analysis.tables.read_back import read_results_table
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.methods.specs import Method


@pytest.fixture(scope="module")
def folder(mixed_pair_folder: Path) -> Path:
    """A simulated two-camera point session beside a one-camera one (conftest.py)."""
    return mixed_pair_folder


@pytest.fixture(scope="module")
def ran(folder: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[analysis.RunResult, Path]:
    """The folder's run, and the folder it wrote."""
    out = tmp_path_factory.mktemp("pair_out")
    result = analysis.run([folder], out)
    assert result.errors.empty, result.errors
    return result, out


@pytest.fixture(scope="module")
def out(ran: tuple[analysis.RunResult, Path]) -> Path:
    return ran[1]


#: Each table's key: what one row is.
KEYS = {
    "frames.csv": ("session", "trial", "pose", "camera", "frame"),
    "views.csv": ("session", "trial", "pair", "pose"),
    "averaging.csv": ("session", "trial", "n_frames"),
}


def _table(out: Path, name: str) -> pd.DataFrame:
    """A table as ``check`` reads it back: every value inside its declared domain, no key
    twice."""
    return read_results_table(out, name, key=KEYS[name])


def _pair_rows(out: Path, name: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A table read back, split into its one-camera and two-camera rows."""
    table = _table(out, name)
    return table[table["cameras"] == 1], table[table["cameras"] == 2]


def test_frames_are_each_cameras_frames_with_capture_and_write_times(
    folder: Path, out: Path
) -> None:
    one, two = _pair_rows(out, "frames.csv")
    assert list(_table(out, "frames.csv").columns) == FRAME_COLUMNS
    assert len(one) == 2 * 2  # two trials, two poses, a frame each
    with SessionReader(folder / "pair.mcap") as reader:
        (trial,) = read_pair_session(reader).trials
    for stream in trial.cameras:
        mine = two[two["camera"] == stream.camera_id]
        assert list(mine["frame"]) == list(range(len(stream)))
        np.testing.assert_array_equal(mine["capture_ns"], stream.capture_ns)
        np.testing.assert_array_equal(mine["log_time_ns"], stream.log_ns)
        assert (mine["trial"] == 1).all()
        assert (mine["pose"] == 0).all()
        assert mine["found"].mean() > 0.9  # the dot is in view nearly throughout
    assert (two.loc[~two["found"], "reason"] != "").all()


def test_views_are_every_pair_used_or_flagged_its_rays_meeting_at_the_estimate(
    out: Path,
) -> None:
    one, two = _pair_rows(out, "views.csv")
    assert list(one["pair"].unique()) == [0]
    assert one["status"].eq("").all()
    first, second = two[two["pose"] == 1], two[two["pose"] == 2]
    assert list(first["pair"]) == list(second["pair"]) == list(range(1, len(first) + 1))
    assert (first[["t_x", "t_y", "t_z"]] == 0).all().all()  # camera 1: the origin
    assert second["t_x"].iloc[0] > 1  # camera 2 at the pair's baseline
    assert (first["pair_time_ns"].diff().dropna() > 0).all()
    assert (first["skew_ms"].abs() <= 1000 / 30 / 2 + 1e-9).all()  # within the slop
    ok = first["status"].to_numpy() == "ok"
    assert ok.mean() > 0.8
    assert (first.loc[~ok, "reason"] != "").all()  # a pair not used says why
    # Camera 1's ray and camera 2's meet (the estimate): their closest approach is tiny.
    r1 = first.loc[ok, ["ray_x", "ray_y", "ray_z"]].to_numpy()
    r2 = second.loc[ok, ["ray_x", "ray_y", "ray_z"]].to_numpy()
    c2 = second.loc[ok, ["t_x", "t_y", "t_z"]].to_numpy()
    normal = np.cross(r1, r2)
    gap = np.abs(np.sum(c2 * normal, axis=1)) / np.linalg.norm(normal, axis=1)
    assert np.median(gap) < 0.01  # inches
    assert first.loc[ok, "conditioning"].gt(0).all()


def test_averaging_is_per_touch_as_trials_number_them(out: Path) -> None:
    one, two = _pair_rows(out, "averaging.csv")
    assert list(_table(out, "averaging.csv").columns) == AVERAGING_COLUMNS
    assert len(one) == 2  # one frame a pose: n_frames 1 per trial
    trials = read_results_table(out, "trials.csv", key=("session", "method", "trial"))
    touches = trials[trials["cameras"] == 2].set_index("trial")["err"]
    assert set(two["trial"]) == set(touches.index)
    for touch, rows in two.groupby("trial"):
        assert list(rows["n_frames"]) == list(range(1, len(rows) + 1))
        assert len(rows) == 5  # five ok pairs about each touch
        assert (rows["err"] < 0.1).all()  # inches, the dot moving at 10 in/s
        # the estimate at the touch (two pairs interpolated) is near the two nearest's mean
        assert rows["err"].iloc[1] == pytest.approx(touches[touch], abs=0.02)


def test_results_mcap_is_written_reused_and_redone_when_an_option_changes(
    folder: Path, tmp_path: Path
) -> None:
    from mcap.reader import make_reader

    from analysis.session.results_mcap import SCENE_TOPIC, annotations_topic
    from twopose.format.messages import image_topic

    pair = tmp_path / "in" / "pair.mcap"
    pair.parent.mkdir()
    shutil.copy(folder / "pair.mcap", pair)
    out = tmp_path / "out"
    first = analysis.run([pair], out)
    (mcap,) = out.glob("results_*_pair.mcap")
    with mcap.open("rb") as fh:
        counts: dict[str, int] = {}
        for _, channel, _ in make_reader(fh).iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    frames = first.frames
    for camera in ("cam1", "cam2"):
        n = int((frames["camera"] == camera).sum())
        assert counts[image_topic(camera)] == n
        assert counts[annotations_topic(camera)] == n
    ok = int((first.trials["status"] == "ok").sum())
    assert counts[SCENE_TOPIC] == 1 + ok  # the grid, then each touch's scene
    again = analysis.run([pair], out)
    assert [s.analysis_reused for s in again.sessions] == [True]
    assert list(out.glob("results_*_pair.mcap")) == [mcap]
    pd.testing.assert_frame_equal(again.views, first.views)
    stricter = analysis.AnalysisOptions(
        estimate=dataclasses.replace(analysis.AnalysisOptions().estimate, min_parallax_deg=89.0)
    )
    redone = analysis.run([pair], out, options=stricter)
    assert [s.analysis_reused for s in redone.sessions] == [False]
    status = redone.views.loc[redone.views["pose"] == 1, "status"]
    assert "ok" not in set(status)  # every pair flagged now, none used
    assert (status == "near_singular").mean() > 0.8


def test_worker_processes_give_the_same_tables(folder: Path, out: Path) -> None:
    parallel = analysis.run([folder], jobs=2)
    for name, table in (("frames", parallel.frames), ("views", parallel.views),
                        ("averaging", parallel.averaging)):  # fmt: skip
        alone = _table(out, f"{name}.csv")
        pd.testing.assert_frame_equal(
            table.reset_index(drop=True), alone.reset_index(drop=True), check_dtype=False
        )


def _continuation(first: Path, later: Path, simulated: Path, after: int) -> None:
    """``later``: ``simulated``'s bytes re-written as a continuation of ``first`` (the same
    session id, a part of its own continuing ``first``'s), its trials numbered after
    ``after``."""
    from twopose.format.writer import SessionWriter

    with SessionReader(first) as reader:
        info = reader.info
    with SessionReader(simulated) as reader:
        session = read_pair_session(reader)
        cameras = list(reader.cameras.values())
        opening = dataclasses.replace(
            reader.info, session_id=info.session_id, part_id=uuid.uuid4().hex,
            continues_part=info.part_id, continues_after_trial=after,
            continues_file=first.name, continues_sha256="0" * 64,
        )  # fmt: skip
        (trial,) = session.trials
        frames = sorted(
            (int(s.log_ns[k]), s.camera_id, int(s.capture_ns[k]), image)
            for s in trial.cameras
            for k, image in enumerate(s.images())
        )
        shift = frames[-1][0] - frames[0][0] + 10**9  # the continuation starts after it
        start = frames[0][0] + shift
        with (
            SessionWriter(later, opening, cameras, pair=session.pair, start_ns=start) as w,
            w.stream(after + trial.trial, window_s=0.5, start_ns=start) as stream,
        ):
            for log_ns, camera_id, capture_ns, image in frames:
                stream.add_frame(camera_id, image, capture_ns, log_ns + shift)
            for touch in trial.touches:
                stream.touch(touch.point, touch.time_ns, touch.how, frames[-1][0] + shift)


def test_a_two_camera_sessions_parts_are_analysed_as_one(folder: Path, tmp_path: Path) -> None:
    first = tmp_path / "part1.mcap"
    shutil.copy(folder / "pair.mcap", first)
    _continuation(first, tmp_path / "part2.mcap", folder / "pair.mcap", after=1)
    result = analysis.run([tmp_path])
    assert result.errors.empty, result.errors
    (session,) = result.sessions
    assert session.metadata["touches"] == "8 over 2 stream trial(s) in 2 parts"
    t = result.trials
    assert list(t["trial"]) == list(range(1, 9))
    assert list(t["touch"]) == [f"trial {n}, touch {k}" for n in (1, 2) for k in range(1, 5)]
    assert t["part"].iloc[0] != t["part"].iloc[-1]
    assert (t["status"] == "ok").all()
    # the same frames replayed (their JPEGs encoded again): about the first part's errors
    np.testing.assert_allclose(t["err"].iloc[4:], t["err"].iloc[:4], atol=0.01)
    assert sorted(result.frames["trial"].unique()) == [1, 2]
    assert sorted(result.views["trial"].unique()) == [1, 2]
    assert sorted(result.averaging["trial"].unique()) == list(range(1, 9))
    assert list(result.views.columns) == VIEW_COLUMNS


def test_a_one_camera_part_of_a_two_camera_session_is_refused_in_words(
    folder: Path, tmp_path: Path
) -> None:
    from tests.lab import write_part

    first = tmp_path / "pair.mcap"
    shutil.copy(folder / "pair.mcap", first)
    with SessionReader(first) as reader:
        info = reader.info
    one = dataclasses.replace(
        info, camera_ids=("cam0",), clocks=None, part_id=uuid.uuid4().hex,
        continues_part=info.part_id, continues_after_trial=1, continues_file=first.name,
        continues_sha256="0" * 64,
    )  # fmt: skip
    write_part(tmp_path / "one_camera_part.mcap", one, range(2, 3))
    result = analysis.run([tmp_path])
    (error,) = result.errors["error"]
    assert "continues the two-camera session" in error
    assert "records one camera" in error
    assert result.trials.empty


def test_a_two_camera_part_of_a_one_camera_session_is_refused_in_words(
    folder: Path, tmp_path: Path
) -> None:
    from tests.lab import record

    first = tmp_path / "one.mcap"
    record(first, 2)
    _continuation(first, tmp_path / "pair_part.mcap", folder / "pair.mcap", after=2)
    result = analysis.run([tmp_path])
    (error,) = result.errors["error"]
    assert "continues the one-camera session" in error
    assert "records two cameras" in error
    assert result.trials.empty


def test_a_two_camera_session_is_continued_with_its_pair_trials_numbered_on(
    folder: Path,
) -> None:
    """(It was refused before issue 58's continuation: tests/recorder/test_pair_continuation.py
    records them.)"""
    from recorder.setup.continuation import read_continued

    continued = read_continued(folder / "pair.mcap")
    with SessionReader(folder / "pair.mcap") as reader:
        session = read_pair_session(reader)
    assert continued.pair is not None
    assert continued.next_trial == max(t.trial for t in session.trials) + 1


def test_the_figures_draw_no_pairs_as_typed_poses(ran: tuple[analysis.RunResult, Path]) -> None:
    """The charts and figures draw views per trial; a pair session's views are per stream
    trial: none are given to them (no top view of touches from stream trials' pairs)."""
    from analysis.report.figures.cache import FigureJob

    result = ran[0]
    by_cameras = {int(s.trials["cameras"].iloc[0]): s for s in result.sessions}
    assert not by_cameras[2].views.empty
    assert by_cameras[2].pose_views.empty
    assert FigureJob.of(by_cameras[2]).views.empty
    pd.testing.assert_frame_equal(by_cameras[1].pose_views, by_cameras[1].views)
    # the report's running averages of a pair session: per touch, its pairs about it
    import json

    from analysis.report.charts import session_chart

    pair = by_cameras[2]
    spec = session_chart("pair", pair.trials, pair.averaging, pair.pose_views, unit_text="in")
    assert "pair estimates about the touch averaged (number of)" in json.dumps(spec)


@pytest.mark.slow  # a real cluster: make test-all and CI run it
def test_a_dask_cluster_gives_the_same_tables(
    folder: Path, ran: tuple[analysis.RunResult, Path], tmp_path: Path
) -> None:
    pytest.importorskip("distributed")
    from tests.helpers import DaskCluster

    cluster = DaskCluster(tmp_path, workers=1)
    try:
        result = analysis.run([folder], dask_address=cluster.address)
    finally:
        cluster.close()
    assert result.errors.empty, result.errors
    local = ran[0]
    for name in ("trials", "frames", "views", "averaging"):
        pd.testing.assert_frame_equal(getattr(result, name), getattr(local, name), obj=name)


def test_every_frame_is_a_row_in_a_trial_without_touches_or_a_camera(tmp_path: Path) -> None:
    """A stream trial with no touch, and one whose camera 2 gave no frame: no row of
    ``trials.csv`` (the first) or an ``incomplete`` one, but each frame a row of
    ``frames.csv``, said as not found."""
    from tests.twopose.format.pair_examples import pair_cameras
    from twopose.format.entries import SessionInfo
    from twopose.format.writer import SessionWriter
    from twopose.pair.motion import thesis_pair
    from twopose.values.units import Units

    pair = thesis_pair()
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"))
    rng = np.random.default_rng(1)
    path, start = tmp_path / "gaps.mcap", 10**18
    with SessionWriter(path, info, pair_cameras(pair), pair=pair, start_ns=start) as writer:
        for trial, (frames2, touched) in enumerate(((4, False), (0, True)), start=1):
            t0 = start + trial * 10**9
            with writer.stream(trial, window_s=0.1, start_ns=t0) as stream:
                for k in range(4):
                    t1 = trial * 10**9 + k * 33_333_333
                    image = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
                    stream.add_frame("cam1", image, t1, t0 + k * 33_333_333)
                    if k < frames2:
                        stream.add_frame("cam2", image, t1 + 5_000_000, t0 + k * 33_333_333)
                if touched:
                    stream.touch((1.0, 2.0, 14.0), trial * 10**9, "key")
    result = analysis.run([path])
    assert list(result.trials["status"]) == ["incomplete"]
    frames = result.frames
    assert len(frames) == 4 + 4 + 4  # trial 1: both cameras; trial 2: camera 1 alone
    assert list(frames.groupby(["trial", "camera"]).size()) == [4, 4, 4]
    assert (~frames["found"]).all()
    assert (frames["reason"] != "").all()


def test_compare_never_pools_one_cameras_trials_with_two_cameras_touches(
    out: Path, tmp_path: Path
) -> None:
    """Issue 58 (adversarial 10): ``compare`` pooled 15 trials and 7 touches as "point: 22
    shared trial(s)"; each is tested, paired and tabled apart by its ``cameras``."""
    from analysis.gate.comparison import compare, describe_test

    other = tmp_path / "b"
    shutil.copytree(out, other)
    result = compare(out, other, tmp_path / "cmp")
    assert sorted(result.tests["cameras"]) == [1, 2]
    for frame in (result.paired, result.side_by_side):
        assert set(frame["cameras"]) == {1, 2}
    words = [describe_test(row) for _, row in result.tests.iterrows()]
    assert any("two cameras" in w and "touch(es)" in w for w in words), words
    for name in ("paired.csv", "side_by_side.csv", "tests.csv"):
        assert "cameras" in pd.read_csv(tmp_path / "cmp" / name).columns
