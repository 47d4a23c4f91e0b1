"""The web console's live image: how many frames a page receives per second while the
recorder captures 640x480 at 30 fps, with the detection drawn on them; and whether the
capture drops frames, and the recorder's own overhead meanwhile.

    .venv/bin/python benchmarks/bench_console.py [--frames 90]

A method-2 session is simulated and its frames written to a 640x480, 30 fps video; the
console records from that video (paced like a camera) while a client reads the MJPEG
stream as a page does. Targets (issue 14): >= 25 fps at the page, 0 dropped frames,
recorder overhead < 40% of the frame interval. Exits 1 if one is missed.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import cv2
import httpx
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from recorder.simulate.one_camera import simulate_session  # noqa: E402
from twopose.format.messages import Frame  # noqa: E402
from twopose.format.reader import SessionReader  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "console.txt"

RECORD = Path(sys.executable).with_name("twopose-record")


def make_video(folder: Path, n_frames: int) -> Path:
    """Real synthetic frames of the thesis' finger, as a 30 fps video."""
    session = folder / "frames.mcap"
    simulate_session(session, method=Method.GROUND, trials=1, frames=max(2, n_frames // 2), seed=5)
    video = folder / "frames.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (640, 480))
    with SessionReader(session) as reader:
        for entry in reader.iter_entries():
            if isinstance(entry, Frame):
                writer.write(entry.decode())
    writer.release()
    return video


def count_stream(client: httpx.Client, stop: threading.Event, stamps: list[float]) -> None:
    """Read the MJPEG stream as a page does, stamping every frame received."""
    with client.stream("GET", "/stream.mjpg") as response:
        for chunk in response.iter_bytes():
            stamps.extend(time.monotonic() for _ in range(chunk.count(b"Content-Type: image/jpeg")))
            if stop.is_set():
                return


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=90, help="frames per capture")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        video = make_video(folder, args.frames + 30)
        process = subprocess.Popen(
            [str(RECORD), "new", str(folder / "s.mcap"), "--ui", "--source", f"video:{video}",
             "--frames", str(args.frames), "--method", "ground", "--ground-height", "9.625",
             "--ground-truth", "1.91, 9.625, 8.375", "--operator", "bench", "--focal", "525",
             "--principal", "320,240", "--units", "in"],
            stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        assert process.stdout is not None
        url = process.stdout.readline().split()[2]
        client = httpx.Client(base_url=url, timeout=30)
        try:
            client.get("/")  # the page sets the session's token (a cookie); the API needs it
            while client.get("/api/state").json()["waiting"] != "pose":
                time.sleep(0.05)
            stamps: list[float] = []
            stop = threading.Event()
            reader = threading.Thread(target=count_stream, args=(client, stop, stamps), daemon=True)
            reader.start()
            time.sleep(0.5)
            started = time.monotonic()
            client.post("/api/pose", json={"x": "0", "y": "0", "z": "0"})
            while client.get("/api/state").json()["waiting"] != "decision":
                time.sleep(0.02)
            ended = time.monotonic()
            stop.set()
            state = client.get("/api/state").json()
        finally:
            process.terminate()
            process.wait(timeout=30)
    during = [t for t in stamps if started <= t <= ended]
    fps = (len(during) - 1) / (during[-1] - during[0]) if len(during) > 1 else 0.0
    capture = state["last_capture"]
    dropped = int(re.search(r"(\d+) dropped", capture).group(1))  # type: ignore[union-attr]
    overhead = int(re.search(r"overhead (\d+)%", capture).group(1))  # type: ignore[union-attr]
    print(
        f"640x480 at 30 fps, {args.frames} frames: live image at the page {fps:.1f} fps "
        f"(target >= 25) with the detection drawn; {dropped} dropped (target 0); recorder "
        f"overhead {overhead}% of the frame interval (target < 40%)"
    )
    return 0 if fps >= 25 and dropped == 0 and overhead < 40 else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
