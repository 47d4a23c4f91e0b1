"""Peak memory and time of every entry point on small files that declare huge contents.

* a session whose frame is a 634-byte JPEG declaring 32000 x 32000 pixels (3 GB decoded);
* a session holding a 300 MB note that zstd compresses to ~10 kB (a chunk bomb; the
  default limit is 256 MB uncompressed per chunk);
* the same JPEG given to ``detect``.

Each command runs in its own process; its peak RSS comes from ``getrusage``.

    python benchmarks/bench_bombs.py
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method
from twopose.values.units import Units

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from tests.helpers import jpeg_declaring, write_accepted_capture  # noqa: E402
from twopose.camera.model import Camera, Intrinsics  # noqa: E402
from twopose.format.entries import GroundTruth, Note, PoseEntry, SessionInfo  # noqa: E402
from twopose.format.writer import SessionWriter  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "bombs.txt"

CAM = Camera(
    camera_id="cam0",
    intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
)


def frame_bomb(path: Path) -> None:
    good = np.full((480, 640, 3), 200, np.uint8)
    with SessionWriter(
        path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM], start_ns=0
    ) as w:
        w.write_ground_truth(GroundTruth(trial=1, kind="point", points_grid=((0.5, 1.5, 11.0),)), 1)
        t = 10
        for pose in (1, 2):
            frames = [w.encode_image(good), jpeg_declaring(32000, 32000)]
            t = write_accepted_capture(
                w, PoseEntry(trial=1, pose=pose, camera_id="cam0", t_grid=(pose, 0, 0)), frames, t
            )


def chunk_bomb(path: Path) -> None:
    with SessionWriter(
        path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM], start_ns=0
    ) as w:
        w.write_note(Note(text="x" * 300_000_000), 1)


def measure(args: list[str]) -> tuple[int, float, float]:
    """Exit code, peak RSS (MB) and seconds of one command in a fresh process (its own
    getrusage, read by a launcher: the parent's memory does not count)."""
    launcher = (
        "import resource, runpy, sys; sys.argv = sys.argv[1:]; code = 0\n"
        "try:\n    runpy.run_module(sys.argv[0], run_name='__main__')\n"
        "except SystemExit as e:\n    code = e.code if isinstance(e.code, int) else 1\n"
        "sys.stderr.write(f'PEAK_KB={resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}')\n"
        "sys.exit(code)"
    )
    started = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", launcher, *args],
        capture_output=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    seconds = time.perf_counter() - started
    err = proc.stderr.decode()
    assert "Traceback" not in err, err[-2000:]
    peak_kb = int(err.rsplit("PEAK_KB=", 1)[1])
    return proc.returncode, peak_kb / 1024, seconds


def make_inputs(folder: Path) -> None:
    frame_bomb(folder / "frame_bomb.mcap")
    (folder / "bomb.jpg").write_bytes(jpeg_declaring(32000, 32000))
    chunk_bomb(folder / "chunk_bomb.mcap")


def main() -> int:
    if sys.argv[1:2] == ["--make"]:  # in a child: its 300 MB must not inflate the parent
        make_inputs(Path(sys.argv[2]))
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        subprocess.run([sys.executable, __file__, "--make", str(folder)], check=True)
        cases = [
            ["analysis", "detect", str(folder / "bomb.jpg"), "--target", "dot"],
            ["analysis", "info", str(folder / "frame_bomb.mcap")],
            ["analysis", "run", str(folder / "frame_bomb.mcap"), "--out", str(folder / "o1")],
            ["analysis", "info", str(folder / "chunk_bomb.mcap")],
            ["analysis", "run", str(folder / "chunk_bomb.mcap"), "--out", str(folder / "o2")],
            ["recorder", "recover", str(folder / "chunk_bomb.mcap"), "-o", str(folder / "f.mcap")],
        ]
        sizes = {p.name: p.stat().st_size for p in folder.glob("*") if p.is_file()}
        print("python benchmarks/bench_bombs.py")
        print("inputs: " + ", ".join(f"{k} {v / 1e3:.1f} kB" for k, v in sorted(sizes.items())))
        for args in cases:
            code, peak_mb, seconds = measure(args)
            shown = " ".join(Path(a).name if "/" in a else a for a in args)
            print(f"{shown:55s} exit {code}  peak RSS {peak_mb:5.0f} MB  {seconds:5.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
