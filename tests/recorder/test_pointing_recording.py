"""The live pointing panel while a pair records (``new --pair --ui``): the recording's
frames reach the panel's push stream pair by pair (the moving dot of
tests/recorder/moving_pair.py, played from two video files)."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.conftest import built_once
from tests.helpers import RECORD, read_line_when_printed
from tests.recorder.moving_pair import MovingPair, moving_pair, write_moving_pair


def _write(folder: Path) -> None:
    write_moving_pair(folder)


@pytest.fixture(scope="module")
def moving(tmp_path_factory: pytest.TempPathFactory) -> MovingPair:
    return moving_pair(built_once(tmp_path_factory, "moving-pair", _write))


def test_a_pair_recording_in_the_console_pushes_its_pairs_to_the_panel(
    moving: MovingPair, tmp_path: Path
) -> None:
    import subprocess

    out = tmp_path / "console.mcap"
    process = subprocess.Popen(
        [str(RECORD), "new", str(out), "--pair", str(moving.pair_file), "--source",
         moving.source, "--ui", "--method", "point", "--units", "in", "--operator", "Ada"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        line, _ = read_line_when_printed(process, "http://", "the console's address")
        client = httpx.Client(base_url=line.split()[2], timeout=10)
        client.get("/")  # the page: the session's token
        messages: list[dict[str, Any]] = []
        with client.stream("GET", "/api/pointing") as stream:
            lines = stream.iter_lines()
            first = json.loads(next(x for x in lines if x.startswith("data: "))[6:])
            assert first["running"] is False  # nothing streams before a trial starts
            for _ in range(400):
                if client.get("/api/state").json()["waiting"] == "trial":
                    break
                time.sleep(0.025)
            # the baseline as calibrate-pair says it (4 digits), not a float's 16 (r8 F8)
            camera = client.get("/api/state").json()["setup"]["camera"]
            assert re.fullmatch(r"a pair: camera 1 \d+x\d+, baseline \d+(\.\d{1,3})? in", camera)
            assert client.post("/api/stream", json={"action": "start"}).json() == {"ok": True}
            deadline = time.monotonic() + 15
            for text in lines:
                if text.startswith("data: "):
                    messages.append(json.loads(text[6:]))
                if sum(m["kind"] == "estimate" and m["point"] is not None for m in messages) >= 8:
                    break
                assert time.monotonic() < deadline, messages
        assert client.post("/api/stream", json={"action": "stop"}).json() == {"ok": True}
        process.terminate()
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    status = next(m for m in messages if m["kind"] == "status")
    assert status["running"] is True
    assert status["about"].startswith("point (method 1)")
    pairs = [m for m in messages if m["kind"] == "estimate"]
    assert [m["seq"] for m in pairs] == list(range(len(pairs)))
    ok = [m for m in pairs if m["point"] is not None]
    assert all(m["words"] == "ok" and m["region"]["major"] > 0 for m in ok)
    assert all(m["sent_ns"] >= m["t_capture_ns"] for m in pairs)  # one monotonic clock
