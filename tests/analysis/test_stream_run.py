"""``run`` on a folder mixing one-camera and two-camera sessions (issue 58 item 6): one row
per touch, told apart by ``cameras``, errors at the simulator's truth, the skew's share,
the one-camera rows unchanged; ``info`` describes the pair; bad pair sessions said in words."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import analysis
from analysis.cli import app
from analysis.tables.columns import SUMMARY_COLUMNS, TRIAL_TABLE_COLUMNS
from analysis.tables.trials import violations
from recorder.simulate.pair import PairTiming, simulate_pair_session
from tests.helpers import SMALL_SCENE
from twopose.format.entries import SessionInfo
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.pair.motion import thesis_pair
from twopose.sim.scene import load_scene
from twopose.values.units import Units

#: The stream columns a one-camera row leaves empty.
STREAM = ["touch", "clock_offset_ms", "err_uninterpolated", "skew_share"]


@pytest.fixture(scope="module")
def mixed(mixed_pair_folder: Path) -> Path:
    """A simulated two-camera point session beside a one-camera one (conftest.py)."""
    return mixed_pair_folder


@pytest.fixture(scope="module")
def ran(mixed: Path) -> analysis.RunResult:
    return analysis.run([mixed])


def test_a_pair_session_is_one_row_per_touch_at_the_simulators_truth(
    ran: analysis.RunResult,
) -> None:
    assert ran.errors.empty, ran.errors
    pair = ran.trials[ran.trials["cameras"] == 2]
    assert len(pair) == 4  # the simulator's four touches
    assert list(pair["trial"]) == [1, 2, 3, 4]  # unique: check and compare key on it
    assert list(pair["touch"]) == [f"trial 1, touch {k}" for k in range(1, 5)]
    assert (pair["status"] == "ok").all()
    assert (pair["err"] < 0.05).all()  # inches (0.017-0.023 measured)
    assert (pair["clock_offset_source"] == "measured").all()
    assert (pair["clock_offset_ms"] - 12.5).abs().max() < 1.0
    # the skew's share is exactly max(0, 1 - err / err_uninterpolated)
    expected = np.maximum(0.0, 1.0 - pair["err"] / pair["err_uninterpolated"])
    np.testing.assert_allclose(pair["skew_share"], expected, rtol=1e-12)
    # each touch's region is the nearest pair's, sized by the session's own pixel noise
    # (tests/analysis/test_stream_noise.py checks it against the truth); once every touch
    # was inside it, the 0.25 px assumed making the regions three times too wide
    assert pair["nees"].gt(0).all()
    assert pair["within95"].notna().all()
    assert violations(ran.trials) == []  # every value in its declared domain
    assert list(ran.trials.columns) == [c for c in TRIAL_TABLE_COLUMNS if c in ran.trials]


def test_the_summary_tells_the_cameras_apart(ran: analysis.RunResult) -> None:
    by = ran.summary.sort_values("cameras")
    assert list(by["cameras"]) == [1, 2]
    assert list(by["n_trials"]) == [2, 4]
    raw = by["rmse_uninterpolated"].to_numpy(dtype=np.float64)
    share = by["skew_share"].to_numpy(dtype=np.float64)
    assert np.isnan(raw[0])  # one camera: no skew
    assert np.isnan(share[0])
    assert np.isfinite(raw[1])
    assert 0 <= share[1] <= 1
    assert list(ran.summary.columns) == SUMMARY_COLUMNS
    # the verdicts never set the pair's touches against the thesis' one-camera figures
    assert any("two cameras, per touch" in v and "thesis tested one" in v for v in ran.verdict)
    # nor does the thesis table: its method 1 row is over the one-camera session's 2 trials
    assert re.match(r"\d of 2 trials within 1 in", str(ran.thesis["twopose"].iloc[0]))


def test_one_camera_rows_are_as_without_the_pair_session(
    ran: analysis.RunResult, mixed: Path
) -> None:
    alone = analysis.run([mixed / "one.mcap"]).trials
    mine = ran.trials[ran.trials["cameras"] == 1].reset_index(drop=True)
    assert (alone["cameras"] == 1).all()
    assert mine[STREAM].isna().all().all() or (mine["touch"] == "").all()
    pd.testing.assert_frame_equal(mine[alone.columns], alone, check_dtype=False)


def test_the_command_line_runs_reports_checks_and_describes_it(mixed: Path, tmp_path: Path) -> None:
    runner = CliRunner()
    out = tmp_path / "out"
    done = runner.invoke(app, ["run", str(mixed), "--out", str(out), "--no-scene"])
    assert done.exit_code == 0, done.output
    assert "two-camera sessions, one row per touch" in done.output
    assert "pair.mcap (point, in, two cameras, per touch): 4/4 ok" in done.output
    assert "skew's share" in done.output
    trials = pd.read_csv(out / "trials.csv")
    assert sorted(trials["cameras"].unique()) == [1, 2]
    report = (out / "report.html").read_text()
    assert "the skew&#x27;s share" in report  # the session's metadata, in words
    assert "trial 1, touch 4" in report  # its trial table: which touch each row is
    assert "2 trial(s) and 4 touch(es)" in report  # each kind of row by its word
    assert "Touches (every column" in report
    checked = runner.invoke(app, ["check", str(out), "--baseline", str(out)])
    assert checked.exit_code == 0, checked.output
    assert "no regression" in checked.output
    compared = runner.invoke(app, ["compare", str(out), str(out), "--out", str(tmp_path / "c")])
    assert compared.exit_code == 0, compared.output
    info = runner.invoke(app, ["info", str(mixed)])
    assert info.exit_code == 0, info.output
    assert "two cameras in" in info.output
    assert "touches: 4 over 1 stream trial(s)" in info.output
    assert "not analysed here yet" not in info.output


def _pair_session(path: Path, *, frames2: int, touch: bool, t0: int) -> Path:
    """A small two-camera session of noise images started at ``t0`` (its identity):
    camera 2 with ``frames2`` frames, one touch or none."""
    from tests.twopose.format.pair_examples import pair_cameras

    pair = thesis_pair()
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"))
    rng = np.random.default_rng(1)
    start = t0 + 10**9
    with (
        SessionWriter(path, info, pair_cameras(pair), pair=pair, start_ns=t0) as writer,
        writer.stream(1, window_s=0.1, start_ns=start) as stream,
    ):
        for k in range(6):
            t1 = 5 * 10**9 + k * 33_333_333
            image = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
            stream.add_frame("cam1", image, t1, start + k * 33_333_333)
            if k < frames2:
                stream.add_frame("cam2", image, t1 + 5_000_000, start + k * 33_333_333)
            if touch and k == 3:
                stream.touch((1.0, 2.0, 14.0), t1, "key")
    return path


def test_bad_pair_sessions_are_said_never_a_traceback(tmp_path: Path) -> None:
    t0 = 10**18
    silent = _pair_session(tmp_path / "no_touch.mcap", frames2=6, touch=False, t0=t0)
    blind = _pair_session(tmp_path / "camera2_empty.mcap", frames2=0, touch=True, t0=t0 + 1)
    noise = _pair_session(tmp_path / "nothing_seen.mcap", frames2=6, touch=True, t0=t0 + 2)
    result = analysis.run([silent, blind, noise])
    (error,) = result.errors["error"]
    assert str(silent) in error
    assert "no touch marked" in error
    rows = result.trials.set_index("label")
    assert rows.loc["camera2_empty.mcap", "status"] == "incomplete"
    assert "cam2" in str(rows.loc["camera2_empty.mcap", "reason"])
    assert rows.loc["nothing_seen.mcap", "status"] != "ok"
    assert rows.loc["nothing_seen.mcap", "reason"]
    assert violations(result.trials) == []


def test_a_broken_pair_entry_fails_its_session_in_words(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A pair entry whose rotation is no rotation (another writer's): the session fails,
    saying where, and the run goes on with the others."""
    import dataclasses

    from twopose.format.pair_convert import pair_entry

    bad = dataclasses.replace(
        pair_entry(thesis_pair(), ("cam1", "cam2")),
        R_2_to_1=((2.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    )
    good = _pair_session(tmp_path / "good.mcap", frames2=0, touch=True, t0=10**18)
    monkeypatch.setattr("twopose.format.writer.pair_entry", lambda *_: bad)
    broken = _pair_session(tmp_path / "broken.mcap", frames2=6, touch=True, t0=10**18 + 1)
    result = analysis.run([broken, good])
    (error,) = result.errors["error"]
    assert error.startswith(f"{broken}: its pair on /twopose/pair:")
    assert "rotation" in error
    assert list(result.trials["label"]) == ["good.mcap"]


def test_the_line_and_ground_methods_take_the_same_path(tmp_path: Path) -> None:
    """A line and a finger pointing at the floor, simulated: a row per touch, each at the
    simulator's truth (a line's error its distance from the line, as ``dist_err``)."""
    (tmp_path / "small.toml").write_text(SMALL_SCENE)
    scene = load_scene(tmp_path / "small.toml")
    timing = PairTiming(speed=10.0, clock_offset_ms=8.0, flash=False)
    paths = [tmp_path / f"{m}.mcap" for m in (Method.LINE, Method.GROUND)]
    for path, method in zip(paths, (Method.LINE, Method.GROUND), strict=True):
        simulate_pair_session(path, method=method, timing=timing, trials=1, seed=0, scene=scene)
    result = analysis.run(paths)
    assert result.errors.empty, result.errors
    t = result.trials
    assert list(t.groupby("method").size()) == [4, 4]  # ground, line: four touches each
    assert (t["status"] == "ok").all()
    assert (t["err"] < 0.25).all()  # inches (0.18 the largest measured)
    line = t[t["method"] == "line"]
    np.testing.assert_allclose(line["dist_err"], line["err"])
    assert violations(t) == []
    # A run of two-camera sessions alone has every column the docs list for every method
    # (a new user's finding: rig_file and rig_sha256 were missing, a KeyError in a script
    # that worked on a folder holding a one-camera session too); no rig file applies.
    assert (t[["rig_file", "rig_sha256"]] == "").all().all()


def test_a_touch_outside_the_stream_is_a_row_saying_so(mixed: Path) -> None:
    import dataclasses

    from analysis.results import AnalysisOptions
    from analysis.session.stream_tables import touch_rows
    from twopose.format.reader import SessionReader
    from twopose.format.streams import read_pair_session

    with SessionReader(mixed / "pair.mcap") as reader:
        session = read_pair_session(reader)
        (trial,) = session.trials
        after = int(trial.camera1.capture_ns[-1]) + 10**9  # a second after its last frame
        late = dataclasses.replace(trial.touches[-1], touch=5, time_ns=after)
        trial = dataclasses.replace(trial, touches=(*trial.touches, late))
        rows = touch_rows("pair.mcap", dataclasses.replace(session, trials=(trial,)),
                          AnalysisOptions())  # fmt: skip
    # No frame about it: nothing failed to detect the target (issue 58: the words).
    assert list(rows["status"]) == ["ok"] * 4 + ["incomplete"]
    assert "no frame of camera 1 (1000 ms) nor of camera 2" in rows["reason"].iloc[-1]
    assert "outside the trial's stream" in rows["reason"].iloc[-1]
    assert np.isnan(rows["err"].iloc[-1])
    assert violations(rows) == []


def test_a_touch_both_cameras_saw_but_without_pairs_says_so(mixed: Path) -> None:
    # Camera 1's frames within 50 ms of touch 2 lost: camera 2's frames there have no
    # partner, so no pair brackets the touch; both cameras saw the target about it all the
    # same. It was `no_detection`, "no frame pair" (issue 58, a new user's finding).
    import dataclasses

    from analysis.results import AnalysisOptions
    from analysis.session.stream_tables import touch_rows
    from twopose.format.reader import SessionReader
    from twopose.format.streams import read_pair_session

    with SessionReader(mixed / "pair.mcap") as reader:
        session = read_pair_session(reader)
        (trial,) = session.trials
        one = trial.camera1
        keep = np.abs(one.capture_ns - trial.touches[1].time_ns) > 50_000_000
        one = dataclasses.replace(
            one, capture_ns=one.capture_ns[keep], log_ns=one.log_ns[keep],
            sequence=one.sequence[keep],
        )  # fmt: skip
        trial = dataclasses.replace(trial, camera1=one)
        rows = touch_rows("pair.mcap", dataclasses.replace(session, trials=(trial,)),
                          AnalysisOptions())  # fmt: skip
    assert list(rows["status"]) == ["ok", "incomplete", "ok", "ok"]
    reason = rows["reason"].iloc[1]
    assert "though both cameras saw the target about it" in reason
    assert "camera 1 in 2 of 2 frames, its nearest" in reason
    assert "lighten the machine's load" in reason
    assert violations(rows) == []


def test_the_rig_is_not_fitted_from_a_two_camera_session(mixed: Path) -> None:
    from analysis.rig.calibrate import calibrate_rig

    said: list[str] = []
    fitted = calibrate_rig([mixed], on_note=said.append)
    assert fitted.sessions == (str(mixed / "one.mcap"),)
    assert any("pair.mcap: a two-camera session (no typed pose)" in s for s in said)


def test_a_rig_file_above_a_two_camera_session_applies_to_the_others_only(
    mixed: Path, tmp_path: Path
) -> None:
    """A rig.toml fitted for the thesis' webcam, above its session and a two-camera one
    (other cameras): the run corrects the first, leaves the pair as it is, refuses nothing."""
    import shutil

    from analysis.rig.scope import rig_scope
    from tests.analysis.rig_helpers import rig_file

    thesis = Path(__file__).parents[2] / "sessions" / "thesis_method1_point.mcap"
    folder = tmp_path / "lab"
    folder.mkdir()
    shutil.copy(thesis, folder / thesis.name)
    shutil.copy(mixed / "pair.mcap", folder / "pair.mcap")
    rig_file(tmp_path, folder / thesis.name)
    shutil.copy(next(tmp_path.glob("rig_*.toml")), folder / "rig.toml")
    result = analysis.run([folder], rigs="scope")
    assert result.errors.empty, result.errors
    rows = result.trials.groupby("cameras")["rig_file"].unique()
    assert list(rows[1]) == [str(folder / "rig.toml")]
    assert list(rows[2]) == [""]  # no typed pose to correct
    assert rig_scope(analysis.batch.inputs.resolve_inputs([folder / "pair.mcap"])).uses == ()


def test_a_two_camera_sessions_rows_are_touches_in_every_word(ran: analysis.RunResult) -> None:
    """The verdicts, the terminal, the report's words and figures, check and compare call
    a two-camera session's rows touches and a one-camera session's trials, each its own in
    a run of both (analysis.tables.row_units)."""
    import json

    from analysis.gate.baseline import describe
    from analysis.gate.comparison import describe_one_sided
    from analysis.gate.match import trial_changes
    from analysis.report.captions import session_captions
    from analysis.report.charts import session_chart
    from analysis.report.figures.style import TrialColours
    from analysis.report.terminal import summary_lines
    from analysis.report.thesis import unusable
    from analysis.tables.row_units import ROW_UNITS, rows_counted

    pair = ran.trials[ran.trials["cameras"] == 2]
    one = ran.trials[ran.trials["cameras"] == 1]
    (two_cameras,) = [v for v in ran.verdict if "two cameras" in v]
    assert "of 4 touches within 1 in" in two_cameras
    assert any("of 2 trials within 1 in" in v for v in ran.verdict if v != two_cameras)
    lines = summary_lines(ran.trials, ran.summary, width=None)
    assert lines[0] == "per method, over ok trials and touches without a warning:"
    block = lines.index(next(line for line in lines if "one row per touch" in line))
    assert " touches " in lines[block + 1]
    assert " trials " in next(line for line in lines[:block] if line.startswith("method"))
    assert rows_counted(ran.trials) == "2 trial(s) and 4 touch(es)"
    failed = pair.assign(status="incomplete")
    assert unusable(failed, include_warned=False) == (
        "no touch usable: none of its 4 touch(es) is ok"
    )
    assert "each ok touch" in session_captions(pair, include_warned=False)["scatter"]
    # the overview's words over touches alone (a new user's pair-only report said trials)
    from analysis.report.captions import overview_caption, run_captions

    said = overview_caption(pair, include_warned=False) + " ".join(
        run_captions(pair, include_warned=False).values()
    )
    assert "trial" not in said.replace("error by trial", "").replace("error_by_trial", "")
    assert "the pair's two cameras'" in said
    assert "each ok trial" in session_captions(one, include_warned=False)["scatter"]
    spec = session_chart("pair", pair, ran.averaging[ran.averaging["cameras"] == 2],
                         ran.views.head(0), unit_text="in")  # fmt: skip
    assert '"title": "touch"' in json.dumps(spec)  # the running averages' colour legend
    keys = TrialColours.of(pair["trial"], ROW_UNITS[2]).legend()
    assert [k.get_label() for k in keys] == [f"touch {t}" for t in pair["trial"]]
    # check and compare: a touch the baseline used and the run left out, by its name
    worse = pair.assign(status=["ok", "no_detection", "ok", "ok"], reason="no pair there")
    changes = trial_changes(worse, pair, (False, False))
    assert changes.left_out == ("trial 1, touch 2 (no_detection: no pair there)",)
    lost = pd.Series({"session": "pair.mcap", "method": "point", "metric": "(trials)",
                      "baseline": 2.0, "status": "missing", "unit": "touch(es)"})  # fmt: skip
    assert "2 touch(es) of the baseline not in this run" in describe(lost)
    only = pd.DataFrame({"session": ["pair.mcap", "one.mcap"], "branch": ["", ""],
                         "part": ["", ""], "method": ["point", "point"], "cameras": [2, 1],
                         "trial": [3, 2], "held_by": ["A", "A"]})  # fmt: skip
    assert describe_one_sided(only) == [
        "only in A: one.mcap (point): trial 2",
        "only in A: pair.mcap (point): touch 3",
    ]


def test_the_reports_rig_line_says_a_pairs_poses_are_the_pair_files(
    ran: analysis.RunResult,
) -> None:
    """No rig file: a run of typed views says its views are as typed; a run of two-camera
    touches alone types no view (a new user's pair-only report said it did)."""
    import dataclasses

    from analysis.report.writer import _rig_used

    assert _rig_used(ran) == ["<p class='rig-used'>No rig file: the views are as typed.</p>"]
    pair = dataclasses.replace(ran, trials=ran.trials[ran.trials["cameras"] == 2])
    assert _rig_used(pair) == [
        "<p class='rig-used'>No rig file: the poses are the pair file's.</p>"
    ]


@pytest.mark.parametrize("passed", [False, True])
def test_a_pairs_leave_one_out_check_is_said_where_its_covariance_is_used(
    mixed: Path, tmp_path: Path, passed: bool
) -> None:
    """A new user's finding: a pair whose check FAILED (calibrate-pair: "the covariance is
    not confirmed") was recorded, described and analysed without a word, its regions
    resting on the covariance the tool itself declined to vouch for."""
    import dataclasses

    from tests.helpers import rewrite_session
    from twopose.format.entries import decode_entry, encode_entry
    from twopose.format.stream_entries import PairEntry

    worst = 2.1 if passed else 9.5
    check = {"folds": 13, "spacings": 624, "beyond_3_sigma": 0 if passed else 40,
             "worst_sigmas": worst, "median_error": 0.01, "median_sigma": 0.02,
             "jackknife_ratio": [1.0] * 6, "passed": passed}  # fmt: skip

    def checked(topic: str, data: bytes) -> bytes:
        if topic != "/twopose/pair":
            return data
        entry = decode_entry(PairEntry.SCHEMA_NAME, data)
        assert isinstance(entry, PairEntry)
        return encode_entry(dataclasses.replace(entry, check=check))

    session = rewrite_session(mixed / "pair.mcap", tmp_path / "checked.mcap", edit=checked)
    result = analysis.run([session])
    assert result.errors.empty, result.errors
    notes = result.trials["notes"]
    said = CliRunner().invoke(app, ["info", str(session)], env={"COLUMNS": "200"}).output
    row = next(line for line in said.splitlines() if "checked.mcap" in line and "│" in line)
    cells = [c.strip() for c in row.split("│")]
    # stream trials type no pose and open no capture (it read "poses 0, captures 12")
    assert cells[6:8] == ["-", "-"], row
    if passed:
        assert not notes.str.contains("not confirmed").any()
        assert "its covariance confirmed by leave-one-out" in " ".join(said.split())
    else:
        sentence = "the pair's covariance is not confirmed (its leave-one-out check found a "
        sentence += "held-out spacing 9.5 sigma off, 40 of 624 beyond 3)"
        assert notes.str.contains(sentence, regex=False).all()
        assert sentence in " ".join(said.split())
        assert sentence in result.sessions[0].metadata["two_cameras"]


def test_a_touch_far_from_its_truth_is_flagged_by_its_truth(mixed: Path, tmp_path: Path) -> None:
    """A new user's finding: a touch marked 0.3 s late (the target already on its way to the
    next point) lay 45 sigma from its grid point and nothing flagged it; a one-camera trial
    that far is flagged by its truth."""
    import dataclasses

    from tests.helpers import rewrite_session
    from twopose.format.entries import decode_entry, encode_entry
    from twopose.format.stream_entries import Touch

    def late(topic: str, data: bytes) -> bytes:
        if topic != "/twopose/touch":
            return data
        touch = decode_entry(Touch.SCHEMA_NAME, data)
        assert isinstance(touch, Touch)
        if touch.touch != 2:
            return data
        return encode_entry(dataclasses.replace(touch, time_ns=touch.time_ns + 300_000_000))

    session = rewrite_session(mixed / "pair.mcap", tmp_path / "late.mcap", edit=late)
    result = analysis.run([session])
    t = result.trials.set_index("trial")
    assert t.loc[2, "status"] == "ok"
    assert t.loc[2, "flagged"]
    assert t.loc[2, "flagged_by"] == "truth"
    assert str(t.loc[2, "disagreement"]).startswith("this touch's estimate lies ")
    assert "check when and where the touch was marked" in str(t.loc[2, "disagreement"])
    assert t.loc[2, "nees"] > 100 * t.drop(index=2)["nees"].max()
    assert t["flagged"].notna().all()  # every touch tested: it has a truth and a region
    assert int(result.summary["n_flagged"].iloc[0]) == int(t["flagged"].sum())
    printed = CliRunner().invoke(app, ["run", str(session), "--out", str(tmp_path / "r")])
    assert "flagged: trial 1, touch 2 (by its truth): this touch's estimate" in " ".join(
        printed.output.split()
    )


def test_a_touch_lost_to_a_cut_file_says_the_stream_ends_there(mixed: Path, tmp_path: Path) -> None:
    """A two-camera file cut short and recovered: a touch the cut took says the trial's
    stream ends there, with the trial's reason (recovered), not the machine's load or its
    stamps' jitter (a new user's r5 F6); the touches before the cut keep their estimates."""
    from recorder.recover import RECOVERED_REASON, recover_session

    whole = (mixed / "pair.mcap").read_bytes()
    cut, fixed = tmp_path / "cut.mcap", tmp_path / "fixed.mcap"
    cut.write_bytes(whole[: len(whole) * 3 // 4])
    recover_session(cut, fixed)
    rows = analysis.run([fixed]).trials
    lost = rows[rows["status"] != "ok"]
    assert len(lost), "the cut took no touch: cut earlier"
    assert (rows["status"] == "ok").any(), "the cut took every touch: cut later"
    for reason in lost["reason"]:
        assert "the trial's stream ends there" in reason, reason
        assert reason.count(RECOVERED_REASON) == 1, reason  # once, not once a camera
        assert "load" not in reason
        assert "jitter" not in reason


@pytest.mark.parametrize("recorded", [False, True])
def test_a_pair_file_not_these_cameras_is_said_at_every_touch(
    tmp_path: Path, recorded: bool
) -> None:
    """A new user's r7 K11: a dot session recorded with another rig's pair file gave every
    touch 41-51 sigma off, blamed on the moment it was marked. The dot's rays miss each
    other where it stood still (twopose.pair.rays_miss): with the offset recorded every
    touch is warned, saying so; measured, the trial's offset is refused, saying so; with
    the right pair nothing is said."""
    from tests.recorder.test_pointing import _dot_frames, resting_then_moving
    from tests.twopose.format.pair_examples import pair_cameras
    from tests.twopose.pair.test_rays_miss import another_rig
    from twopose.pair.clock import ClockOffset

    frames = _dot_frames(thesis_pair(), resting_then_moving())
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"))
    paths = []
    for name, pair, t0 in (("right", thesis_pair(), 10**18), ("other", another_rig(), 10**18 + 1)):
        path = tmp_path / f"{name}.mcap"
        with SessionWriter(path, info, pair_cameras(pair), pair=pair, start_ns=t0) as writer:
            if recorded:
                writer.write_clock_offset(
                    ClockOffset(offset_ns=0.0, sigma_ns=1e5, method="flash", n=60)
                )
            with writer.stream(1, window_s=0.1, start_ns=t0 + 10**9) as stream:
                for f in frames:
                    stream.add_frame(
                        f"cam{f.camera}",
                        f.image,
                        f.t_capture_ns,
                        t0 + f.t_capture_ns - frames[0].t_capture_ns + 10**9,
                    )
                stream.touch((1.0, 2.0, 14.0), frames[40].t_capture_ns, "key")
        paths.append(path)
    result = analysis.run(paths)
    rows = result.trials.set_index("label")
    right = rows.loc["right.mcap"]
    assert right["status"] == "ok", right.to_dict()
    assert not right["warning"], right.to_dict()
    other = rows.loc["other.mcap"]
    said = str(other["warning"]) if recorded else str(other["reason"])
    assert "miss each other" in said, other.to_dict()
    assert "calibrate this pair" in said
    if recorded:  # the terminal says why the touch is warned, not trials.csv alone (r8 F8)
        from analysis.report.terminal import summary_lines

        text = " ".join(summary_lines(result.trials, result.summary, width=None))
        assert "warned: 1 of 1 touches: the cameras' rays to the dot miss each other" in text
        assert text.count("warned: ") == 1  # the right pair's session: nothing
