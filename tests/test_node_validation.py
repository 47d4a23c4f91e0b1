"""Every kind of file we write, read by the independent TypeScript MCAP reader (@mcap/core
under Node.js): as a stream and through the index, CRCs checked, message counts per topic
equal to ours, every JSON message valid against its declared JSON schema.

``make test`` installs the npm packages (tests/node/package-lock.json) before pytest runs.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from analysis.batch.runner import results_mcap_name, run
from recorder.recover import recover_session
from recorder.setup.plan import load_plan, record_plan
from recorder.simulate.one_camera import simulate_session
from recorder.sources.registry import SyntheticSource
from twopose.methods.specs import Method
from twopose.values.units import Units

NODE_DIR = Path(__file__).parent / "node"
SESSIONS = Path(__file__).parents[1] / "sessions"

pytestmark = [
    pytest.mark.skipif(shutil.which("node") is None, reason="Node.js is not installed (CI has it)"),
    pytest.mark.slow,  # a Node.js process per check: make test-all and CI run it
]


def _node_reports(files: list[Path]) -> dict[str, Any]:
    if not (NODE_DIR / "node_modules" / "@mcap" / "core").is_dir():
        pytest.fail("npm packages missing: run `make test` (npm ci --prefix tests/node)")
    out = subprocess.run(
        ["node", str(NODE_DIR / "validate.mjs"), *map(str, files)],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    reports: dict[str, Any] = json.loads(out.stdout)
    return reports


def _our_counts(path: Path) -> tuple[Counter[str], int]:
    """Messages per topic and JSON messages, as the Python mcap reader sees them."""
    counts: Counter[str] = Counter()
    n_json = 0
    with path.open("rb") as f:
        for _, channel, _ in make_reader(f).iter_messages():
            counts[channel.topic] += 1
            n_json += channel.message_encoding == "json"
    return counts, n_json


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """The sample sessions, plus one of each kind we write, made fresh."""
    tmp = tmp_path_factory.mktemp("node")
    simulated = tmp / "simulated.mcap"
    simulate_session(simulated, method=Method.LINE, trials=2, frames=2, seed=3)
    plan = tmp / "plan.toml"
    plan.write_text(
        'method = "ground"\nframes = 2\nground_height = 9.625\n[camera]\nfocal = 525.0\n'
        "[[trials]]\nground_truth = [[1.91, 9.625, 8.375]]\n"
        "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.5, 0.0, -1.0] }]\n"
    )
    recorded = tmp / "recorded.mcap"
    record_plan(load_plan(plan), recorded, SyntheticSource(None, Method.GROUND, realtime=False))
    truncated = tmp / "truncated.mcap"
    data = simulated.read_bytes()
    truncated.write_bytes(data[: len(data) * 2 // 3])
    recovered = tmp / "recovered.mcap"
    recover_session(truncated, recovered)
    out = tmp / "results"
    run([recorded], out)
    return [
        *sorted(SESSIONS.glob("*.mcap")),
        simulated,
        recorded,
        recovered,
        _decided(tmp / "decided.mcap"),
        out / results_mcap_name(0, recorded),
    ]


def _decided(path: Path) -> Path:
    """Redo, undo and an undecided last capture, through the real procedure."""
    from recorder.procedure.capture import CaptureSettings
    from recorder.procedure.machine import Procedure
    from twopose.camera.model import Camera, Intrinsics
    from twopose.format.entries import PoseEntry, SessionInfo
    from twopose.format.writer import SessionWriter

    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    with (
        SyntheticSource(None, Method.POINT, realtime=False) as src,
        SessionWriter(path, SessionInfo(method=Method.POINT, units=Units.IN), [cam]) as w,
    ):
        proc = Procedure(w)
        proc.begin_trial(1, 2)
        for step in ("accept", "redo", "accept", "accept", "undo", "accept", None):
            x = float(proc.pose)
            proc.type_pose(
                PoseEntry(trial=proc.trial, pose=proc.pose, camera_id="cam0", t_grid=(x, 0.0, 0.0))
            )
            proc.capture(src, CaptureSettings(frames=2))
            if step is None:
                break
            getattr(proc, step)()
            if proc.state.value == "ready":
                proc.begin_trial(2, 2)
    return path


def _accepted_by_us(path: Path) -> list[list[int]]:
    """[trial, pose, capture, frames] of every capture the analysis is measured from."""
    from twopose.format.reader import SessionReader
    from twopose.format.trials import iter_trials

    with SessionReader(path) as reader:
        return [
            [t.trial, p.entry.pose, p.entry.capture or 0, len(p.frames)]
            for t in iter_trials(reader)
            for p in t.poses
        ]


def test_the_typescript_reader_agrees_with_ours(written: list[Path]) -> None:
    reports = _node_reports(written)
    for path in written:
        report = reports[str(path)]
        assert report["errors"] == [], path
        ours, n_json = _our_counts(path)
        assert report["stream"] == dict(ours), path
        assert report["indexed"] == dict(ours), path
        assert report["statistics_message_count"] == sum(ours.values()), path
        assert report["json_validated"] == n_json, path
    assert any("/twopose/results/scene" in reports[str(p)]["indexed"] for p in written)


def test_the_typescript_reading_of_the_spec_rebuilds_the_accepted_captures(
    written: list[Path],
) -> None:
    """Format 1.1: the captures each trial is measured from, rebuilt in TypeScript from
    docs/session-format.md alone, are exactly the ones our replay hands the analysis."""
    sessions = [p for p in written if not p.name.startswith("results_")]
    reports = _node_reports(sessions)
    decided = next(p for p in sessions if p.name == "decided.mcap")
    assert reports[str(decided)]["accepted"] == [[1, 1, 1, 2], [1, 2, 3, 2], [2, 1, 6, 2]]
    for path in sessions:
        assert reports[str(path)]["accepted"] == _accepted_by_us(path), path


def test_the_typescript_reader_catches_a_corrupt_file(tmp_path: Path) -> None:
    """The check above can fail: one flipped byte inside a (compressed) chunk is refused."""
    data = bytearray((SESSIONS / "stress_line.mcap").read_bytes())
    data[len(data) // 2] ^= 0xFF
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    report = _node_reports([bad])[str(bad)]
    assert report["errors"], "the TypeScript reader accepted a corrupt file"
    assert "stream" not in report  # it stopped at the bad chunk, it did not count past it
