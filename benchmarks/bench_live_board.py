"""The recorder's live board check at every pose docs/rig.md recommends (issue 44, item 6).

    python benchmarks/bench_live_board.py [--frames 8]

The synthetic camera renders the default board (9x6 inner corners, 1 in squares, at z = 24
in) from each typed pose of ``twopose.sim.layout.BOARD_POSES``, ``--frames`` frames each
(each with its own lighting and noise), stored as the recorder stores them (JPEG) and
decoded again. Per pose: how many frames OpenCV's fast check finds, how many the live check
(:func:`twopose.detect.checkerboard.find_board_live`: the fast check, then the rig's full search
in a worker, bounded by ``LIVE_BOARD_BUDGET_S``) and the rig's search
(:func:`twopose.detect.checkerboard.find_board`) find, and the full search's time on the frames the
fast check turned down (median and largest), against the bound; and the same at a pose too
near for the whole board, where the full search finds nothing (what the bound is for). Exits 1 if
the live check misses a frame the rig finds, or the full search reaches the bound.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from recorder.sources.registry import SyntheticSource  # noqa: E402
from twopose.camera.images import decode_image  # noqa: E402
from twopose.detect.checkerboard import (  # noqa: E402
    BOARD_FLAGS,
    LIVE_BOARD_BUDGET_S,
    find_board,
    find_board_live,
)
from twopose.methods.specs import Method  # noqa: E402
from twopose.sim.layout import BOARD_POSES  # noqa: E402

#: Beside them, a pose too near for the whole board (its lower rows out of view): what a
#: frame the full search turns down costs.
TOO_NEAR = (0.0, 0.0, 12.0)

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "live_board.txt"


def main() -> int:
    """Time the live board check at every recommended pose; 0 if it finds what the rig finds."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=8)
    args = parser.parse_args()
    source = SyntheticSource(method=Method.BOARD, realtime=False, bank=args.frames)
    inner = source.scene.board.inner_corners
    ok = True
    print(f"python benchmarks/bench_live_board.py --frames {args.frames}")
    print(f"board {inner[0]}x{inner[1]}, 640x480 JPEG frames, bound {LIVE_BOARD_BUDGET_S:g} s")
    print("| typed pose (in) | fast check | live check | rig | full search (ms) |")
    print("| --- | ---: | ---: | ---: | --- |")
    with source:
        for t in (*BOARD_POSES, TOO_NEAR):
            source.set_pose(t, (0.0, 0.0, 0.0))
            fast = live = rig = 0
            full_ms: list[float] = []
            for _ in range(args.frames):
                encoded = cv2.imencode(".jpg", source.read(), [cv2.IMWRITE_JPEG_QUALITY, 85])[1]
                image = decode_image(encoded.tobytes(), "frame")
                grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
                flags = BOARD_FLAGS + cv2.CALIB_CB_FAST_CHECK
                fast += bool(cv2.findChessboardCorners(grey, inner, flags=flags)[0])
                answer = find_board_live(image, inner)
                live += answer.corners is not None
                if not answer.fast:  # the full search ran, in the worker
                    full_ms.append(answer.full_s * 1e3)
                found = find_board(image, inner, window_px=None) is not None
                rig += found
                ok &= (answer.corners is not None) == found and not answer.timed_out
            times = (
                f"median {np.median(full_ms):.1f}, max {max(full_ms):.1f}" if full_ms else "not run"
            )
            ok &= not full_ms or max(full_ms) < LIVE_BOARD_BUDGET_S * 1e3
            where = ", ".join(f"{v:g}" for v in t) + (", too near" if t == TOO_NEAR else "")
            n = args.frames
            print(f"| ({where}) | {fast}/{n} | {live}/{n} | {rig}/{n} | {times} |")
    print("the live check finds what the rig finds" if ok else "MISSED: see the rows above")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
