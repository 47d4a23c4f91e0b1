"""The two-camera simulator's cost per frame: the target over a cached background (issue 58, 7).

    .venv/bin/python benchmarks/bench_pair_simulator.py [--frames 6] [--seed 0] [--write-docs]

``simulate --cameras 2`` renders each camera's static scene once and, per frame, casts only
the rays about the moving target, composited over it (:class:`twopose.sim.moving.PairScene`).
Per method, on the default scene (640x480, rays 2x2 a pixel, six clutter shapes), both
cameras of the thesis' pair, ``--frames`` instants spread along the target's path: the CPU
of a frame's radiance so, of the same frame ray cast whole (what rendering every frame
afresh would cost), of its exposure (lighting, noise: the same for both), and the largest
difference between the two radiances. Target: a frame's radiance at least 4 times cheaper
than a whole cast, measured in the same run; exits 1 if missed.
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

from recorder.simulate.pair import DWELL_S, simulated_pair  # noqa: E402
from twopose.methods.specs import Method  # noqa: E402
from twopose.sim.layout import Layout  # noqa: E402
from twopose.sim.moving import PairScene, Trajectory, touch_points  # noqa: E402
from twopose.sim.render import expose, render_radiance  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "pair_simulator.txt"
MIN_RATIO = 4.0  # target: a whole cast over a composited frame, CPU


def one_method(method: Method, n: int, seed: int) -> tuple[float, float, float, float]:
    """Median CPU s of a composited frame, a whole cast and an exposure; the largest
    radiance difference between the two."""
    scene = Scene()
    pair = simulated_pair(scene)
    rng = np.random.default_rng(seed)
    pair_scene = PairScene(scene, method, pair, rng)
    path = Trajectory(touches=touch_points(scene, method, pair), speed=10.0, lead=1.0,
                      dwell_s=DWELL_S)  # fmt: skip
    fast, whole, exposing, worst = [], [], [], 0.0
    poses = ((np.eye(3), np.zeros(3)), (pair.R_2_to_1, pair.t_2_in_1))
    for reference in path.at(np.linspace(0.05, 0.95, n) * path.duration_s):
        for camera, (R, t) in enumerate(poses, start=1):
            started = time.process_time()
            radiance = pair_scene.radiance(camera, reference)
            composited = time.process_time()
            expose(radiance, scene, rng)
            exposed = time.process_time()
            static = pair_scene._static
            moved = Layout(primitives=(pair_scene._moved(reference), *static.primitives),
                           decals=static.decals)  # fmt: skip
            full = render_radiance(scene, moved, pair.intrinsics1, R, t)
            fast.append(composited - started)
            exposing.append(exposed - composited)
            whole.append(time.process_time() - exposed)
            worst = max(worst, float(np.abs(full - radiance).max()))
    return float(np.median(fast)), float(np.median(whole)), float(np.median(exposing)), worst


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=6)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(
        f"simulate --cameras 2, the default scene (640x480, rays 2x2 a pixel), {args.frames} "
        "instants along the path x 2 cameras per method; CPU seconds per frame, median:"
    )
    worst_ratio = np.inf
    for method in (Method.POINT, Method.LINE, Method.GROUND):
        fast, whole, exposing, worst = one_method(method, args.frames, args.seed)
        ratio = whole / fast
        worst_ratio = min(worst_ratio, ratio)
        print(
            f"  {method}: target over the background {fast:.3f}, whole cast {whole:.3f} "
            f"({ratio:.0f}x), exposure {exposing:.3f}; radiance differs by at most "
            f"{worst:.3f} (the target's edge pixels)"
        )
    met = worst_ratio >= MIN_RATIO
    print(
        f"smallest ratio {worst_ratio:.1f}x (target >= {MIN_RATIO:.0f}x): "
        f"{'met' if met else 'MISSED'}"
    )
    return 0 if met else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
