"""Does the calibration's uncertainty keep the 95% regions honest? Coverage with it and without.

    .venv/bin/python benchmarks/bench_intrinsics_coverage.py [--trials 400] [--sigma 2] [--jobs 2]

Simulated sessions in the thesis' geometry and typing (the thesis_* sample sessions' poses: x
or x-and-depth moves, 1/8 in typing, 0.04 in placing error), 2 trials of 3 frames per pose,
whose camera has a calibration 1-sigma of 2 px on fx, fy, cx and cy (about twice OpenCV's fit
of its 13 sample photographs, 0.9-1.1 px: a quick calibration's). Each session is rendered
with true intrinsics drawn once from that sigma (the scene's ``calibration_sigma``,
:func:`recorder.simulate.one_camera.calibrated_cameras`) and records the nominal intrinsics with the
sigma, so every trial of a session shares one calibration error, as a real camera's do.

Each session is analysed twice: by ``run`` (the sigma propagated into every trial's
covariance), and by the same replay and estimation with the cameras' sigma set aside (the
intrinsics taken as exact, as before format 1.2). Printed per method and over all: the
share of ok trials whose truth lies inside the reported 95% region, and its standard error
with each session one sample (a session's trials share its calibration draw, so they miss
together). Two trials a session keep the sharing and give 200 draws a method: with five
(80 draws for 400 trials) the standard error of one method's coverage was 1.6 points, too
coarse to place it in a 4-point target. Targets: with the sigma, every method 93-97% over
>= 500 trials; without it, fewer (the intrinsics' error is not covered). Sessions are kept
in --workdir, so a second run only re-analyses. Exits 1 if a target is missed.

``--sigma 0`` is the control: the same seeds (the same poses, placing errors and noise: the
calibration's error has its own random stream) rendered with the nominal intrinsics, so
both columns are the coverage without any calibration error.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "sessions"))

from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # noqa: E402 - on sys.path at run time

from analysis import run  # noqa: E402
from analysis.batch.outputs import replacing  # noqa: E402
from analysis.results import AnalysisOptions  # noqa: E402
from analysis.session.pipeline import replay_views  # noqa: E402
from recorder.simulate.one_camera import simulate_session  # noqa: E402
from twopose.methods.truth import reported  # noqa: E402
from twopose.sim.scene import CameraParams, Scene  # noqa: E402
from twopose.solve.session import estimate_session  # noqa: E402
from twopose.uncertainty.propagate import uncertainty_columns  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "intrinsics_coverage.txt"

METHODS = ("point", "line", "ground")
#: The calibration's 1-sigma (px) of fx, fy, cx and cy, each.
CALIBRATION_SIGMA = 2.0
TRIALS_PER_SESSION = 2
FRAMES = 3


def scene(sigma: float) -> Scene:
    camera = CameraParams(calibration_sigma=(sigma, sigma, sigma, sigma))
    return Scene(poses=THESIS_POSES, cameras=(camera,))


def _simulate(job: tuple[str, int, float, str]) -> str:
    method, seed, sigma, out = job
    if not Path(out).exists():  # written under another name first: a kill leaves no half file
        with replacing(Path(out)) as partial:
            simulate_session(
                partial,
                method=Method(method),
                trials=TRIALS_PER_SESSION,
                frames=FRAMES,
                seed=seed,
                scene=scene(sigma),
            )
    return out


def without_sigma(path: str) -> pd.DataFrame:
    """The session's ok trials' ``within95`` with its cameras' sigma set aside: the same
    replay and estimation as ``run``, the intrinsics taken as exact."""
    options = AnalysisOptions()
    replay = replay_views(path, options)
    views = [
        [dataclasses.replace(v, intrinsics_sigma=np.zeros(4)) for v in row] for row in replay.views
    ]
    estimate = estimate_session(dataclasses.replace(replay, views=views), options.estimate)
    rep = reported(estimate)
    within = uncertainty_columns(rep.error, rep.cov)["within95"]
    return pd.DataFrame(
        {
            "session": Path(path).name,
            "trial": replay.trial_ids,
            "status": estimate.estimates.status,
            "within95_without": within,
        }
    )


def coverage_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Per method and over all: ok trials with a truth, coverage with and without."""
    ok = trials[(trials["status"] == "ok") & trials["within95"].notna()]
    rows = []
    for method, g in [*ok.groupby("method", sort=False), ("all", ok)]:
        rows.append(
            {
                "method": method,
                "sessions": g["session"].nunique(),
                "trials": len(g),
                "coverage95_with_sigma": float(g["within95"].mean()),
                "se": session_se(g),
                "coverage95_without": float(g["within95_without"].mean()),
            }
        )
    return pd.DataFrame(rows)


def session_se(trials: pd.DataFrame) -> float:
    """The coverage's standard error with a session's trials as one sample (their
    calibration error is one draw, so they miss together): a ratio estimator's, over the
    sessions' within-counts."""
    per = trials.groupby("session")["within95"].agg(["sum", "count"])
    n, total = len(per), float(per["count"].sum())
    if n < 2:
        return float("nan")
    p = float(per["sum"].sum()) / total
    residual = per["sum"] - p * per["count"]
    return float(np.sqrt(n / (n - 1) * float((residual**2).sum())) / total)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=400, help="trials per method")
    ap.add_argument(
        "--sigma",
        type=float,
        default=CALIBRATION_SIGMA,
        help="the calibration's 1-sigma of fx, fy, cx and cy (px); 0: the control",
    )
    ap.add_argument("--workdir", type=Path, default=REPO / "benchmarks/.calibration/intrinsics")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    args.workdir.mkdir(parents=True, exist_ok=True)
    jobs = []
    for m, method in enumerate(METHODS):
        for s in range(int(np.ceil(args.trials / TRIALS_PER_SESSION))):
            seed = 5000 + 1000 * m + s
            name = f"{method}_{seed}_t{TRIALS_PER_SESSION}_sigma{args.sigma:g}.mcap"
            out = args.workdir / name
            jobs.append((method, seed, args.sigma, str(out)))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        files = list(pool.map(_simulate, jobs))
    t1 = time.perf_counter()
    trials = run(files, jobs=args.jobs).trials
    with ProcessPoolExecutor(args.jobs) as pool:
        without = pd.concat(list(pool.map(without_sigma, files)), ignore_index=True)
    t2 = time.perf_counter()
    names = trials["session"].map(lambda s: Path(str(s)).name)
    merged = trials.assign(session=names).merge(
        without, on=["session", "trial", "status"], how="left", validate="one_to_one"
    )
    assert len(merged) == len(trials), "the replay found other trials than run"
    table = coverage_table(merged)
    print(f"simulated in {t1 - t0:.0f} s, analysed (twice) in {t2 - t1:.0f} s")
    print(
        f"calibration sigma of fx, fy, cx, cy: {args.sigma:g} px each; intrinsics drawn "
        f"once per session; {TRIALS_PER_SESSION} trials per session, {FRAMES} frames per pose"
    )
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    overall = table[table["method"] == "all"].iloc[0]
    per_method = table[table["method"] != "all"]
    # Issue 36: every method's regions honest, 93-97%, with the detector's floor and the
    # calibration's sigma propagated; without the sigma they must under-cover.
    ok = bool(
        overall["trials"] >= 500
        and per_method["coverage95_with_sigma"].between(0.93, 0.97).all()
        and (
            args.sigma == 0
            or overall["coverage95_without"] < overall["coverage95_with_sigma"] - 0.02
        )
    )
    print(
        "target (with: every method 93-97%, >= 500 trials; without: under-covers): "
        + ("met" if ok else "MISSED")
    )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(lambda: main(sys.argv[1:]), FIGURE))
