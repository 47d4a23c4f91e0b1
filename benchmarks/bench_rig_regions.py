"""The regions with ``--rig`` from one board session (issue 54, item 5): the rig's constants'
covariance carried, and the placing sigma a board measures when the laptop is also turned.

    .venv/bin/python benchmarks/bench_rig_regions.py [--seeds 30] [--trials 30] [--write-docs]

**(a) The board.** Per seed, one simulated board session of the size docs/rig.md recommends
(``twopose-record simulate --method board --trials 2``: the 8 typed poses of
``twopose.sim.layout.BOARD_POSES`` twice, 16 captures of 1 frame) rendered through
``bench_rig.py``'s rig (mount rotation (0.8, -0.5, 0.3) deg, camera offset (0.3, 0.2, 0.4)
in, focal scale 1.03), the laptop placed off each typed pose by **0.1 in** per axis while
1/16 in is typed, and **turned** by 0.05, 0.1 or 0.2 degrees per angle (the seeds in turn),
typed honestly (the entries' rotation resolution); then ``twopose-analyze rig``'s fit
(:func:`analysis.rig.board.calibrate_board`), written to a rig file and read back
(:func:`twopose.rig.file.load_rig_file`). Reported: the placing sigma against the truth,
the share of seeds within ±25%, with the board's first 8 captures alone beside it, and the
fit without the rotation errors (what the fit did before issue 54).

**(b) The regions.** Per method and seed, ``--trials`` trials of 3 poses (the thesis'
moves, ``bench_guidance``'s targets, frames and detector floor), seen through the same rig,
the laptop placed with 0.1 in and turned as the board's was (typed honestly), the views
corrected by the seed's rig file as ``run --rig`` corrects them: the truth inside each
trial's 95% region (``within95``), NEES/dof and the median ``semiaxis95``, (1) with the
board's constants taken as exact (before issue 54), (2) with their covariance carried
(``J C J^T``, :mod:`twopose.rig.carried`), both with the board's placing sigma, and (3) the
floor: the true constants and the true placing sigma. The variance factor's test (sigma0)
is off throughout, so that the rows show the rig's effect alone.

Targets (exit 1 if one is missed): (a) the 16-capture board's placing sigma within ±25% of
the truth in at least 85% of the seeds; (b) per method, coverage with the covariance
carried within 93-97%.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from bench_board_rig import board_scene  # type: ignore[import-not-found]
from bench_guidance import FRAMES, PIXEL_SIGMA, THETA_SIGMA, K, Truth  # type: ignore[import-not-found]
from bench_placing import honesty as placing_honesty  # type: ignore[import-not-found]
from bench_placing import region_table
from bench_placing import session as placing_session
from bench_rig import RIG  # type: ignore[import-not-found]
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from analysis.rig.board import calibrate_board, read_board_session  # noqa: E402
from analysis.rig.fit import rig_toml  # noqa: E402
from recorder.simulate.one_camera import simulate_session  # noqa: E402
from twopose.methods.specs import Method, spec_of  # noqa: E402
from twopose.rig.board import fit_board_rig  # noqa: E402
from twopose.rig.constants import RigConstants, corrected_ground, corrected_view  # noqa: E402
from twopose.rig.file import RigFile, load_rig_file  # noqa: E402
from twopose.solve.estimate import PoseView  # noqa: E402
from twopose.solve.nview import projection_matrices  # noqa: E402
from twopose.solve.session import SessionTrials  # noqa: E402
from twopose.uncertainty.noise import NoiseModel, PlacingSigma  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "rig_regions.txt"
REAL_IN, TYPED_IN = 0.1, 0.0625
ROTATIONS_DEG = (0.05, 0.1, 0.2)
BOARD_TRIALS, POSES = 2, 3
METHODS = (Method.POINT, Method.LINE, Method.GROUND)
#: The board's target (issue 54); the regions' is bench_placing's (93-97%).
WITHIN, WITHIN_SHARE = 0.25, 0.85


def board(seed: int, folder: Path) -> tuple[RigFile, dict[str, float]]:
    """One board session's rig file, and its placing sigma over the truth three ways: the
    16 captures, the first 8, and the 16 fitted without rotation errors."""
    rotation = ROTATIONS_DEG[seed % len(ROTATIONS_DEG)]
    scene = board_scene()  # bench_board_rig's: the board, seen through bench_rig's rig
    operator = dataclasses.replace(
        scene.poses, noise_sigma=REAL_IN, typed_resolution=TYPED_IN, rotation_noise_deg=rotation
    )
    scene = dataclasses.replace(scene, poses=operator)
    path = folder / f"board_{seed}.mcap"
    simulate_session(path, method=Method.BOARD, trials=BOARD_TRIALS, frames=1, seed=seed,
                     scene=scene)  # fmt: skip
    found = calibrate_board([path])
    rig_file = path.with_suffix(".toml")
    rig_file.write_text(
        rig_toml(found.fit, found.sessions, found.board.warnings, placing=found.board.placing)
    )
    c = read_board_session(path)
    half = len(c.t_typed) // BOARD_TRIALS

    def placing(n: int, r_sigma: np.ndarray) -> float:
        fit = fit_board_rig(
            c.corners_grid[:n], c.observed_px[:n], c.t_typed[:n], c.r_typed_deg[:n],
            c.intrinsics[:n], t_sigma=c.t_sigma, r_sigma_deg=r_sigma[:n],
        )  # fmt: skip
        assert fit.placing is not None
        return fit.placing.sigma_in / REAL_IN

    assert found.board.placing is not None
    ratios = {
        "rotation": rotation,
        "16": found.board.placing.sigma_in / REAL_IN,
        "8": placing(half, c.r_sigma_deg),
        "16, rotation unmodelled": placing(len(c.t_typed), np.zeros(len(c.t_typed))),
        "bound": float(found.board.placing.upper_bound),
    }
    return load_rig_file(rig_file), ratios


def view(method: Method, truth: Truth, typed: np.ndarray, pose: int, rng: np.random.Generator,
         rotation: float) -> PoseView | None:  # fmt: skip
    """The pose's frames seen from where the laptop really stands and turns, through the rig
    (None when the target is out of the image)."""
    placed = typed + REAL_IN * rng.standard_normal(3)
    t_true, R = RIG.true_poses(placed, rotation * rng.standard_normal(3))
    P = projection_matrices(RIG.true_intrinsics(K), R, t_true)
    ends = np.column_stack([truth.points, np.ones(2)]) @ P.T
    px = ends[:, :2] / ends[:, 2:3]
    lines = spec_of(method).uses_image_lines
    inside = (px[:, 0] > 0) & (px[:, 0] < 640) & (px[:, 1] > 0) & (px[:, 1] < 480)
    if not (np.isfinite(px).all() and inside.all() and (ends[:, 2] > 0).all()):
        return None
    centroid = px.mean(axis=0) if lines else px[0]
    d = px[1] - px[0]
    theta = math.degrees(math.atan2(d[1], d[0])) if lines else math.nan
    floor_px, floor_deg = spec_of(method).detector_floor  # one draw a view
    centroid = centroid + floor_px * rng.standard_normal(2)
    theta += floor_deg * rng.standard_normal()
    return PoseView(
        pose=pose, intrinsics=K, width_height=(640, 480), t_grid=typed, r_deg=np.zeros(3),
        t_sigma=TYPED_IN, r_sigma_deg=rotation,
        centroids=centroid + PIXEL_SIGMA * rng.standard_normal((FRAMES, 2)),
        thetas=theta + THETA_SIGMA * rng.standard_normal(FRAMES),
        found=np.ones(FRAMES, dtype=bool), camera_id="cam0", intrinsics_sigma=np.zeros(4),
    )  # fmt: skip


def session(method: Method, seed: int, trials: int) -> SessionTrials:
    """``trials`` trials of :data:`POSES` poses each, the thesis' moves, one operator
    placing and turning the laptop as on the seed's board (``bench_placing``'s trials)."""
    rotation = ROTATIONS_DEG[seed % len(ROTATIONS_DEG)]

    def seen(m: Method, truth: Truth, typed: np.ndarray, pose: int,
             rng: np.random.Generator) -> PoseView | None:  # fmt: skip
        return view(m, truth, typed, pose, rng, rotation)

    trials_: SessionTrials = placing_session(method, seed, trials, REAL_IN, seen)
    return trials_


def honesty(trials: SessionTrials, rig: RigConstants, noise: NoiseModel) -> pd.DataFrame:
    """Per ok trial, its views corrected by ``rig`` (as ``run --rig``): its truth inside its
    95% region, NEES/dof, semiaxis95 (``bench_placing``'s)."""
    corrected = SessionTrials(
        method=trials.method, units=trials.units, trial_ids=trials.trial_ids,
        views=[[corrected_view(v, rig) for v in row] for row in trials.views],
        truth=trials.truth, ground=corrected_ground(trials.ground, rig),
    )  # fmt: skip
    table: pd.DataFrame = placing_honesty(corrected, noise)
    return table


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--trials", type=int, default=30, help="trials per method and seed")
    args = parser.parse_args()
    start = time.process_time()
    with tempfile.TemporaryDirectory() as folder:
        boards = [board(seed, Path(folder)) for seed in range(args.seeds)]
    board_cpu = time.process_time() - start
    missed = _print_boards(pd.DataFrame([r for _, r in boards]), board_cpu)
    truth = PlacingSigma(sigma_in=REAL_IN)
    rows = []
    for method in METHODS:
        for seed, (found, _) in enumerate(boards):
            trials = session(method, seed, args.trials)
            exact = NoiseModel(placing=found.placing, test_redundancy=False)
            carried = NoiseModel(placing=found.placing, rig=found.constants.covariance,
                                 test_redundancy=False)  # fmt: skip
            for case, rig, noise in (
                ("board's rig as exact", found.constants, exact),
                ("board's rig + covariance", found.constants, carried),
                ("true rig, true placing", RIG, NoiseModel(placing=truth, test_redundancy=False)),
            ):
                rows.append(honesty(trials, rig, noise).assign(method=method.value, case=case))
    missed += _print_regions(pd.concat(rows), args)
    print(f"\n{args.seeds} board sessions ({board_cpu:.0f} s CPU) and {len(METHODS)} x "
          f"{args.seeds} sessions of {args.trials} trials: "
          f"{time.process_time() - start:.0f} s CPU")  # fmt: skip
    for line in missed:
        print(f"MISSED: {line}")
    return 1 if missed else 0


def _print_boards(table: pd.DataFrame, cpu_s: float) -> list[str]:
    print(
        f"(a) one board session ({BOARD_TRIALS} x 8 poses, 1 frame each) through the rig, real "
        f"placing {REAL_IN} in (typed {TYPED_IN} in), turned 0.05/0.1/0.2 deg (typed "
        f"honestly); {len(table)} seeds ({cpu_s:.0f} s CPU)"
    )
    print(f"  {'fit':<32} {'median':>7} {'range':>12} {'within ±25%':>12}")
    missed = []
    names = {"16": "16 captures", "8": "the first 8 captures",
             "16, rotation unmodelled": "16, rotations not modelled"}  # fmt: skip
    for fit, name in names.items():
        ratio = table[fit].to_numpy()
        within = float(np.mean(np.abs(ratio - 1) <= WITHIN))
        print(f"  {name:<32} {np.median(ratio):>6.2f}x {ratio.min():>5.2f}-{ratio.max():.2f}x "
              f"{within:>11.0%}")  # fmt: skip
        if fit == "16" and within < WITHIN_SHARE:
            missed.append(f"board: placing sigma within ±25% in {within:.0%} of the seeds")
    for rotation, g in table.groupby("rotation"):
        within = float(np.mean(np.abs(g["16"] - 1) <= WITHIN))
        unmodelled = g["16, rotation unmodelled"].median()
        print(f"  turned {rotation:.2f} deg: 16 captures median {g['16'].median():.2f}x, within "
              f"±25% {within:.0%} of {len(g)}; not modelled {unmodelled:.2f}x")  # fmt: skip
    if table["bound"].any():
        print(f"  {int(table['bound'].sum())} seed(s) gave only an upper bound")
    return missed


def _print_regions(table: pd.DataFrame, args: argparse.Namespace) -> list[str]:
    print(f"\n(b) 95% regions with each seed's rig file: {args.seeds} sessions x {args.trials} "
          f"trials of {POSES} poses per method and case (sigma0's test off)")  # fmt: skip
    missed: list[str] = region_table(table, lambda case: case == "board's rig + covariance")
    return missed


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
