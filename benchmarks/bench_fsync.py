"""What the fsync at every accepted capture costs, against the 33 ms frame interval at
30 fps: a capture of 5 frames (640x480 JPEG), then ``SessionWriter.sync``, repeated.

    python benchmarks/bench_fsync.py [--captures 50]
"""

from __future__ import annotations

import argparse
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

from twopose.camera.model import Camera, Intrinsics  # noqa: E402
from twopose.format.entries import PoseEntry, SessionInfo  # noqa: E402
from twopose.format.writer import SessionWriter  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "fsync.txt"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--captures", type=int, default=50)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 255, (480, 640, 3), dtype=np.uint8) for _ in range(5)]
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    syncs = []
    with tempfile.TemporaryDirectory(dir=REPO) as tmp:  # the disk sessions are written to
        path = Path(tmp) / "s.mcap"
        with SessionWriter(path, SessionInfo(method=Method.POINT, units=Units.IN), [cam]) as w:
            for k in range(args.captures):
                number = w.new_capture_number()
                w.write_pose(
                    PoseEntry(
                        trial=1,
                        pose=k + 1,
                        camera_id="cam0",
                        t_grid=(0.0, 0.0, 0.0),
                        capture=number,
                    )
                )
                with w.capture(1, k + 1, "cam0", number) as cap:
                    for f in frames:
                        cap.add_frame(f)
                started = time.perf_counter()
                w.sync()
                syncs.append(time.perf_counter() - started)
    ms = np.array(syncs) * 1e3
    print(f"python benchmarks/bench_fsync.py --captures {args.captures}")
    print(
        f"fsync per accepted capture: median {np.median(ms):.2f} ms, 95th percentile "
        f"{np.percentile(ms, 95):.2f} ms, max {ms.max():.2f} ms; once per capture of 5 "
        f"frames, i.e. {np.median(ms) / 5 / 33.3 * 100:.1f}% of the frame time at 30 fps"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
