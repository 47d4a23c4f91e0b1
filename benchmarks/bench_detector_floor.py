"""The detectors' systematic error per view, against the registry's floor.

    .venv/bin/python benchmarks/bench_detector_floor.py [--scenes 100] [--frames 3] [--jobs 2]

Each scene is the thesis' (the thesis_* sample sessions' poses: x or x-and-depth moves) with
its clutter drawn anew; two of its poses are rendered, and each pose's frames (sensor noise
drawn per frame) are detected and averaged as a pose's are. The average is set against the
target's true projection: the dot's centre (method 1), and for the gloved finger the axis'
image line (the centroid's offset across it, px, and the orientation's error, degrees).

Printed per detector: the RMS error of the averaged views, the part of it the frames' scatter
explains (the per-frame scatter over the frames averaged), and the systematic rest (RMS
error squared minus that part): what stays however many frames are averaged, and the same
in every frame, so the frame scatter cannot see it. Target: the systematic rest within the
registry's ``detector_floor`` (``twopose.methods.specs``), which every view's covariance adds
(:func:`twopose.uncertainty.propagate.measurement_covariance`). Exits 1 if it is not.
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "sessions"))

from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # noqa: E402 - on sys.path at run time

from recorder.simulate.one_camera import draw_trial_poses  # noqa: E402
from twopose.camera.model import project_points, rotation_from_angles_deg  # noqa: E402
from twopose.detect.detection import detect, wrap_theta_deg  # noqa: E402
from twopose.methods.specs import Method, spec_of  # noqa: E402
from twopose.sim.camera import SyntheticCamera  # noqa: E402
from twopose.sim.layout import build_layout, finger_axis  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "detector_floor.txt"
#: One method per detector: the dot's, and the glove's (line and ground share it).
DETECTORS = (Method.POINT, Method.GROUND)
POSES_PER_SCENE = 2


def _pose_errors(
    camera: SyntheticCamera, method: Method, scene: Scene, t: np.ndarray, r: np.ndarray, frames: int
) -> tuple[float, float, float, float] | None:
    """(centroid error, orientation error, their per-frame scatters) of one pose, or None
    when a frame missed the target. The dot's centroid error is its distance along x and y
    both (two numbers, the orientation's a NaN pair); the finger's, across its image line."""
    intr = scene.cameras[0].intrinsics
    camera.place_camera(t, r)
    R = rotation_from_angles_deg(r)
    target = spec_of(method).target
    assert target is not None  # DETECTORS measure
    found = [detect(camera.expose(), target) for _ in range(frames)]
    if not all(d.found for d in found):
        return None
    centroids = np.array([d.centroid_px for d in found])
    if not spec_of(method).uses_image_lines:
        px = project_points(np.array([scene.point.position]), intr, R, t)[0]
        e = centroids - px  # two components: both are the centroid's error
        return (
            float(e[:, 0].mean()),
            float(e[:, 1].mean()),
            float(e[:, 0].std(ddof=1)),
            float(e[:, 1].std(ddof=1)),
        )
    ends = project_points(np.stack(finger_axis(scene)), intr, R, t)
    d = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    across = (centroids - ends[0]) @ np.array([-d[1], d[0]])
    true_deg = float(np.degrees(np.arctan2(d[1], d[0])))
    theta = wrap_theta_deg(np.array([f.theta_deg for f in found]) - true_deg)
    return (
        float(across.mean()),
        float(theta.mean()),
        float(across.std(ddof=1)),
        float(theta.std(ddof=1)),
    )


def _scene_rows(job: tuple[str, int, int]) -> list[dict[str, float | str]]:
    method_name, seed, frames = job
    method = Method(method_name)
    rng = np.random.default_rng(seed)
    scene = Scene(poses=THESIS_POSES)
    camera = SyntheticCamera(scene, build_layout(scene, method, rng), rng)
    rows: list[dict[str, float | str]] = []
    for _, _, t, r in draw_trial_poses(scene, method, POSES_PER_SCENE, rng):
        errors = _pose_errors(camera, method, scene, t, r, frames)
        if errors is not None:
            a, b, sa, sb = errors
            rows.append({"method": method_name, "a": a, "b": b, "sa": sa, "sb": sb})
    return rows


def floor_table(views: pd.DataFrame, frames: int) -> pd.DataFrame:
    """Per detector: RMS error, the frames' share and the systematic rest, against the floor."""
    rows = []
    for method, g in views.groupby("method", sort=False):
        spec = spec_of(str(method))
        lines = spec.uses_image_lines
        names = ("across px", "orientation deg") if lines else ("centroid x px", "centroid y px")
        floors = spec.detector_floor if lines else (spec.detector_floor[0],) * 2
        for col, scatter, name, floor in zip(("a", "b"), ("sa", "sb"), names, floors, strict=True):
            rms = float(np.sqrt((g[col] ** 2).mean()))
            noise = float(np.sqrt((g[scatter] ** 2).mean() / frames))
            systematic = float(np.sqrt(max(rms**2 - noise**2, 0.0)))
            rows.append(
                {
                    "detector": spec.target,
                    "error": name,
                    "views": len(g),
                    "rms": rms,
                    "frames_part": noise,
                    "systematic": systematic,
                    "floor": floor,
                    "within": systematic <= floor,
                }
            )
    return pd.DataFrame(rows)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=100, help="scenes per detector")
    ap.add_argument("--frames", type=int, default=3, help="frames averaged per pose")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    jobs = [
        (m.value, 9000 + 1000 * k + s, args.frames)
        for k, m in enumerate(DETECTORS)
        for s in range(args.scenes)
    ]
    with ProcessPoolExecutor(args.jobs) as pool:
        views = pd.DataFrame([row for rows in pool.map(_scene_rows, jobs) for row in rows])
    table = floor_table(views, args.frames)
    print(
        f"{args.scenes} rendered scenes per detector, {POSES_PER_SCENE} poses each, "
        f"{args.frames} frames averaged per pose (the thesis' geometry, clutter drawn anew)"
    )
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    ok = bool(table["within"].all())
    verdict = "met" if ok else "MISSED"
    print(f"target (systematic error within the registry's detector_floor): {verdict}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(lambda: main(sys.argv[1:]), FIGURE))
