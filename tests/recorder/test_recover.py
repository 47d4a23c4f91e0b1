"""Crash safety: truncation, corruption, kill -9 at random moments, Ctrl-C, and recover."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from typer.testing import CliRunner

from analysis.session.pipeline import analyse_session
from recorder.cli.app import app
from recorder.recover import RECOVERED_REASON, recover_session
from twopose.errors import EXIT_ERROR, SessionExistsError, SessionFormatError, TwoposeError
from twopose.format.entries import CaptureWindow
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

RECORDING_SCRIPT = """
import sys, time
import numpy as np
from twopose.camera.model import Intrinsics
from twopose.camera.model import Camera
from twopose.format.entries import PlaneEntry, GroundTruth, PoseEntry, SessionInfo
from twopose.format.writer import SessionWriter

out = sys.argv[1]
intrinsics = Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0)
cam = Camera(camera_id="cam0", intrinsics=intrinsics)
rng = np.random.default_rng(0)
info = SessionInfo(method="ground", units="in")
with SessionWriter(out, info, [cam], ground=PlaneEntry(offset=9.625), image_format="png") as w:
    print("open", flush=True)
    for trial in range(1, 1000):
        truth = GroundTruth(trial=trial, kind="point", points_grid=((1.0, 9.625, 8.0),))
        w.write_ground_truth(truth)
        for pose in (1, 2):
            t_grid = (float(pose), 0.0, 0.0)
            w.write_pose(PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=t_grid))
            with w.capture(trial, pose, "cam0") as cap:
                for _ in range(3):
                    cap.add_frame(rng.integers(0, 255, (48, 64, 3), dtype=np.uint8))
                    time.sleep(0.002)
            print(f"done {trial} {pose}", flush=True)
"""


def _completed(stdout: str) -> set[tuple[int, int]]:
    return {
        (int(t), int(p))
        for line in stdout.splitlines()
        if line.startswith("done ")
        for t, p in [line.split()[1:3]]
    }


def _windows(path: Path) -> dict[tuple[int, int], CaptureWindow]:
    with SessionReader(path) as r:
        return {(w.trial, w.pose): w for w in r.iter_entries() if isinstance(w, CaptureWindow)}


@pytest.mark.slow
@pytest.mark.slow
def test_kill_9_at_random_moments_then_recover(tmp_path: Path) -> None:
    """20 recordings killed at random: every capture reported complete survives, whole."""
    script = tmp_path / "record.py"
    script.write_text(RECORDING_SCRIPT)
    rng = np.random.default_rng(42)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    runs_with_captures = 0
    for i in range(20):
        out = tmp_path / f"s{i}.mcap"
        proc = subprocess.Popen(
            [sys.executable, str(script), str(out)], stdout=subprocess.PIPE, text=True, env=env
        )
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "open"  # the file exists and is flushed
        time.sleep(float(rng.uniform(0.0, 0.6)))
        proc.send_signal(signal.SIGKILL)
        rest, _ = proc.communicate()
        completed = _completed(rest)
        runs_with_captures += bool(completed)
        fixed = tmp_path / f"fixed{i}.mcap"
        report = recover_session(out, fixed)
        windows = _windows(fixed)
        for key in completed:
            assert key in windows, f"run {i}: completed capture {key} lost"
            assert windows[key].status == "complete"
            assert windows[key].n_frames == 3
        assert report.complete_captures >= len(completed)
        # What was not completed is at most the capture in progress (kept as incomplete).
        incomplete = [w for w in windows.values() if w.status != "complete"]
        assert len(incomplete) <= 1
        assert all(w.reason == RECOVERED_REASON for w in incomplete)
        with SessionReader(fixed) as r:  # a valid, indexed session
            assert r.info.method == "ground"
            frames = r.message_counts().get("/twopose/camera/cam0/image", 0)
        assert frames >= 3 * len(completed)
    # The sweep means something only if kills landed after captures had completed.
    assert runs_with_captures >= 10, f"only {runs_with_captures} of 20 kills came after a capture"


def test_ctrl_c_finishes_the_file_cleanly(tmp_path: Path) -> None:
    script = tmp_path / "record.py"
    script.write_text(RECORDING_SCRIPT)
    out = tmp_path / "s.mcap"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.Popen(
        [sys.executable, str(script), str(out)],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
        # SIGINT may be inherited ignored (a background job of a non-interactive shell).
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.stdout is not None
    proc.stdout.readline()
    proc.stdout.readline()  # at least one capture done
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)
    assert proc.returncode != 0
    with SessionReader(out) as r:  # no recover needed: the summary and index were written
        windows = [w for w in r.iter_entries() if isinstance(w, CaptureWindow)]
    assert len(windows) >= 1
    assert windows[-1].status in ("complete", "incomplete")


def _small_session(path: Path, trials: int = 4) -> None:
    from twopose.camera.model import Camera, Intrinsics
    from twopose.format.entries import GroundTruth, PlaneEntry, PoseEntry, SessionInfo

    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
    )
    rng = np.random.default_rng(1)
    t = 1_000
    with SessionWriter(
        path,
        SessionInfo(method=Method.GROUND, units=Units.IN),
        [cam],
        ground=PlaneEntry(offset=9.625),
        image_format="png",
        start_ns=t,
    ) as w:
        for trial in range(1, trials + 1):
            w.write_ground_truth(
                GroundTruth(trial=trial, kind="point", points_grid=((1.0, 9.625, 8.0),)),
                t := t + 10,
            )
            for pose in (1, 2):
                w.write_pose(
                    PoseEntry(
                        trial=trial, pose=pose, camera_id="cam0", t_grid=(float(pose), 0.0, 0.0)
                    ),
                    t := t + 10,
                )
                with w.capture(trial, pose, "cam0") as cap:
                    for _ in range(3):
                        cap.add_frame(
                            rng.integers(0, 255, (48, 64, 3), dtype=np.uint8), t := t + 10
                        )


def test_truncation_anywhere_recovers_every_capture_before_the_cut(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    _small_session(whole)
    data = whole.read_bytes()
    full = _windows(whole)
    metadata_end = data.index(b"start_ns") + 40  # the metadata record's last field
    for i, cut in enumerate(range(100, len(data), max(len(data) // 40, 1))):
        broken = tmp_path / f"cut{i}.mcap"
        broken.write_bytes(data[:cut])
        fixed = tmp_path / f"fixed{i}.mcap"
        if cut < metadata_end:  # nothing to rebuild a session from: a clear error
            with pytest.raises(SessionFormatError, match="metadata"):
                recover_session(broken, fixed)
            continue
        recover_session(broken, fixed)
        got = _windows(fixed)
        complete = {k for k, w in got.items() if w.status == "complete"}
        assert complete <= set(full)
        # Captures are contiguous from the start: whatever survived is a prefix.
        order = sorted(full)
        assert sorted(complete) == order[: len(complete)]
    # The whole file (no truncation) recovers to the same captures and an identical count.
    fixed = tmp_path / "fixed_whole.mcap"
    report = recover_session(whole, fixed)
    assert set(_windows(fixed)) == set(full)
    assert not report.truncated


def test_a_corrupt_chunk_is_skipped_and_the_rest_kept(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    _small_session(whole, trials=6)
    data = bytearray(whole.read_bytes())
    mid = len(data) // 2
    data[mid : mid + 64] = bytes(64)  # zero a run inside a chunk's compressed payload
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(bytes(data))
    fixed = tmp_path / "fixed.mcap"
    report = recover_session(broken, fixed)
    assert report.chunks_lost == 1
    assert report.chunks_kept > 5
    assert len(_windows(fixed)) >= 10


def test_losing_the_first_chunk_restores_the_session_from_metadata(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    _small_session(whole)
    with SessionReader(whole) as r:
        info, cameras, ground = r.info, r.cameras, r.ground
    with open(whole, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    first = min(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    data = bytearray(whole.read_bytes())
    # Damage the middle of the first chunk's payload (its schemas, channels, session entry).
    middle = first.chunk_start_offset + first.chunk_length // 2
    data[middle : middle + 30] = bytes(30)
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(bytes(data))
    fixed = tmp_path / "fixed.mcap"
    report = recover_session(broken, fixed)
    assert report.chunks_lost >= 1
    with SessionReader(fixed) as r:
        assert r.info == info
        assert r.cameras == cameras
        assert r.ground == ground


def test_analysis_accepts_a_recovered_session(tmp_path: Path, ground_session: Path) -> None:
    data = ground_session.read_bytes()
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(data[: int(len(data) * 0.8)])
    with pytest.raises(SessionFormatError, match="recover"):
        analyse_session(broken)
    fixed = tmp_path / "fixed.mcap"
    recover_session(broken, fixed)
    result = analyse_session(fixed)
    assert len(result.trials) >= 1
    assert (result.trials["status"] == "ok").sum() >= 1
    with SessionReader(fixed) as r:
        assert len(list(iter_trials(r, with_frames=False))) == len(result.trials)


def test_recover_refuses_overwrite_and_non_sessions(tmp_path: Path, ground_session: Path) -> None:
    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"keep")
    with pytest.raises(SessionExistsError):
        recover_session(ground_session, existing)
    assert existing.read_bytes() == b"keep"
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"\x89MCAP0\r\n" + bytes(100))
    with pytest.raises(SessionFormatError):
        recover_session(junk, tmp_path / "out.mcap")


def test_recover_cli(tmp_path: Path, ground_session: Path) -> None:
    data = ground_session.read_bytes()
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(data[: int(len(data) * 0.7)])
    runner = CliRunner()
    result = runner.invoke(app, ["recover", str(broken), "-o", str(tmp_path / "fixed.mcap")])
    assert result.exit_code == 0, result.output
    assert "the file ended early" in result.output
    assert "complete captures" in result.output
    again = runner.invoke(app, ["recover", str(broken), "-o", str(tmp_path / "fixed.mcap")])
    assert again.exit_code == EXIT_ERROR
    assert "already exists" in again.output


@pytest.mark.slow
def test_kill_9_of_the_recorder_keeps_exactly_what_was_accepted(tmp_path: Path) -> None:
    """The real recorder (plan mode), killed right after its third capture ended: after
    recover, the analysis gets the captures accepted before the kill, whole, and never the
    one whose decision had not reached the disk."""
    plan = tmp_path / "plan.toml"
    plan.write_text(
        'method = "point"\nframes = 3\n[camera]\nfocal = 525.0\n'
        + "[[trials]]\nground_truth = [[0.5, 1.5, 11.0]]\n"
        "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.1, 0.0, 0.0] }]\n" * 3
    )
    out, fixed = tmp_path / "s.mcap", tmp_path / "fixed.mcap"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "recorder", "new", out, "--plan", plan, "--source", "synthetic"],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("trial 2 pose 1:"):  # the third capture ended; undecided yet?
            break
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=30)
    recover_session(out, fixed)
    with SessionReader(fixed) as r:
        pairs = [
            (t.trial, p.entry.pose, p.entry.t_grid[0], len(p.frames))
            for t in iter_trials(r)
            for p in t.poses
        ]
    plan_order = [(1, 1, 0.0, 3), (1, 2, 1.1, 3), (2, 1, 0.0, 3), (2, 2, 1.1, 3)]
    assert pairs in (plan_order[:2], plan_order[:3])  # the third: if its accept was flushed
    trials = analyse_session(fixed).trials.set_index("trial")
    assert trials.loc[1, "status"] == "ok"
    assert float(trials["err"].loc[1]) < 0.05


def test_recover_answers_every_cut_and_a_garbled_length_without_a_crash(
    tmp_path: Path, ground_session: Path
) -> None:
    """Cuts every 397 bytes (many land inside a record header) and a chunk whose length
    field claims 2**62 bytes: each is recovered or refused with a message, and a refused
    one leaves no output behind."""
    from twopose.errors import TwoposeError

    data = ground_session.read_bytes()
    garbled = bytearray(data)
    first_chunk = data.index(b"\x06", 8 + 9 + 100)  # an opcode byte after header+metadata
    garbled[first_chunk + 1 : first_chunk + 9] = (1 << 62).to_bytes(8, "little")
    cases = [data[:cut] for cut in range(0, len(data), 397)] + [bytes(garbled)]
    outcomes = {"recovered": 0, "refused": 0}
    for i, case in enumerate(cases):
        broken, fixed = tmp_path / f"b{i}.mcap", tmp_path / f"f{i}.mcap"
        broken.write_bytes(case)
        try:
            recover_session(broken, fixed)
        except TwoposeError:
            outcomes["refused"] += 1
            assert not fixed.exists()
            continue
        with SessionReader(fixed) as r:
            assert r.info.method == "ground"
        outcomes["recovered"] += 1
    assert outcomes["recovered"] > 100
    assert outcomes["refused"] >= 1  # a cut inside the opening: nothing to recover


def test_recover_into_a_missing_folder_is_a_clear_error(
    tmp_path: Path, ground_session: Path
) -> None:
    with pytest.raises(TwoposeError, match="cannot create"):
        recover_session(ground_session, tmp_path / "no" / "such" / "fixed.mcap")
