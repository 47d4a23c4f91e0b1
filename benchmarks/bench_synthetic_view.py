"""The synthetic camera's cost per new pose, and how long a stop waits for it (issue 55, 2).

    .venv/bin/python benchmarks/bench_synthetic_view.py [--poses 12] [--seed 0] [--write-docs]

The recorder's synthetic source (``--source synthetic``: the default scene, 640x480, rays
supersampled 2x2, six clutter shapes) is placed at seeded poses within the scene's pose
ranges, per method (the board session's scene is the board alone). Per pose: the CPU of
casting the view (``set_pose``), of the first capture's five frames (each exposed when
first read), and the longest stretch of the casting between two points where a stop can
cut in (the bands of rays, ``twopose.sim.render.BAND_RAYS``). Beside it, in the same run,
the same views cast as one band (the whole ray grid at once, as before issue 55: the
images are the same, bit for bit). Before issue 55 a new pose cost 1.0-1.6 s of CPU, all
of it uncut. Targets: a new pose (view and five frames) within 0.5 s of CPU at its 95th
percentile, and no stretch a stop cannot cut longer than 0.1 s. Exits 1 if one is missed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from recorder.sources.registry import SyntheticSource  # noqa: E402
from twopose.methods.specs import Method  # noqa: E402
from twopose.sim import render  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "synthetic_view.txt"
FRAMES = 5  # a capture's frames (``--frames``' default)
POSE_CPU_S = 0.5  # target: a new pose's view and frames, 95th percentile
UNCUT_S = 0.1  # target: the longest stretch a stop cannot cut


def poses(source: SyntheticSource, n: int, rng: np.random.Generator) -> list[tuple[float, ...]]:
    """``n`` camera centres within the scene's pose ranges (its x, y and z)."""
    p = source.scene.poses
    lows, highs = zip(p.x_range, p.y_range, p.z_range, strict=True)
    return [tuple(float(v) for v in rng.uniform(lows, highs)) for _ in range(n)]


def one_pose(source: SyntheticSource, t: tuple[float, ...]) -> tuple[float, float, float]:
    """The CPU of the view and of its capture's frames, and the longest uncut stretch."""
    stamps: list[float] = []
    camera = source._camera  # the stops' points, where the source passes them
    place = camera.place

    def placed(t_grid: object, r_deg: object, **_stop: object) -> None:
        stamp = lambda: stamps.append(time.process_time())  # noqa: E731 - where a stop may cut
        place(t_grid, r_deg, between=stamp)  # type: ignore[arg-type]

    camera.place = placed  # type: ignore[method-assign,assignment]
    started = time.process_time()
    source.set_pose((t[0], t[1], t[2]), (0.0, 0.0, 0.0))
    viewed = time.process_time()
    for _ in range(FRAMES):
        source.read()
    exposed = time.process_time()
    camera.place = place  # type: ignore[method-assign]
    cuts = [started, *stamps, viewed]
    return viewed - started, exposed - viewed, max(np.diff(cuts))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=12)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    banded = render.BAND_RAYS
    print(
        f"the synthetic camera's default scene (640x480, rays 2x2 per pixel), {args.poses} "
        f"seeded poses per method; CPU seconds, median / 95th percentile:"
    )
    worst_pose, worst_uncut = 0.0, 0.0
    for method in (Method.POINT, Method.LINE, Method.GROUND, Method.BOARD):
        source = SyntheticSource(None, method, realtime=False)
        source.open()
        centres = poses(source, args.poses, rng)
        source.set_pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # the rays made once, for all
        runs = np.array([one_pose(source, t) for t in centres])
        render.BAND_RAYS = 1 << 40  # the whole grid as one band, as before
        whole = np.array([one_pose(source, t)[0] for t in centres])
        render.BAND_RAYS = banded
        view, frames, uncut = runs[:, 0], runs[:, 1], runs[:, 2]
        total = view + frames
        q = np.percentile
        print(
            f"  {method}: new pose {q(total, 50):.3f} / {q(total, 95):.3f} (view "
            f"{q(view, 50):.3f} / {q(view, 95):.3f}, {FRAMES} frames {q(frames, 50):.3f} / "
            f"{q(frames, 95):.3f}); a stop waits at most {1000 * uncut.max():.0f} ms; "
            f"one band: view {q(whole, 50):.3f}, {q(whole, 50) / q(view, 50):.1f}x the bands'"
        )
        worst_pose = max(worst_pose, float(q(total, 95)))
        worst_uncut = max(worst_uncut, float(uncut.max()))
    met = worst_pose <= POSE_CPU_S and worst_uncut <= UNCUT_S
    print(
        f"worst new pose {worst_pose:.3f} s (target <= {POSE_CPU_S}), longest uncut "
        f"{1000 * worst_uncut:.0f} ms (target <= {1000 * UNCUT_S:.0f}): "
        f"{'met' if met else 'MISSED'}; before issue 55: 1.0-1.6 s, all uncut"
    )
    return 0 if met else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
