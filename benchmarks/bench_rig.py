"""The rig's constants, estimated from each session's own ground truth (issue 15).

    .venv/bin/python benchmarks/bench_rig.py [--seeds 3] [--methods point ground]

Simulated sessions of 15 trials in the thesis' geometry and typing (the thesis_* sample
sessions' poses: x or x-and-depth moves, 1/8 in typing, 0.04 in placing error, 5 frames),
each seed simulated twice: with the constants (mount rotation (0.8, -0.5, 0.3) deg, camera
offset (0.3, 0.2, 0.4) in, focal scale 1.03) and without. Per session, ``run
--rig-calibration loo`` (each trial corrected by constants selected and fitted without
it). Targets:

1. with constants: the leave-one-out corrected RMSE <= 1.15x the RMSE of the same seed
   simulated without them;
2. without constants: the corrected RMSE <= 1.05x the uncorrected one;
3. the constants, fitted (mount, offset, focal) on all trials, within their 95% intervals
   of the truth.

Prints one line per session and a summary; exits 1 if a target is missed.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "sessions"))

from make_sessions import THESIS_POSES  # noqa: E402

from analysis.batch import run  # noqa: E402
from analysis.calibration import calibrate  # noqa: E402
from analysis.results import AnalysisOptions  # noqa: E402
from recorder.scene import Scene  # noqa: E402
from recorder.simulate import simulate_session  # noqa: E402
from twopose.rig import RigConstants  # noqa: E402

RIG = RigConstants(
    mount_rotation_deg=(0.8, -0.5, 0.3), camera_offset=(0.3, 0.2, 0.4), focal_scale=1.03
)
TRUE_GROUPS = ["mount_rotation_deg", "camera_offset", "focal_scale"]


def rmse(values: np.ndarray) -> float:
    v = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(v**2)))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--methods", nargs="+", default=["point", "ground"])
    args = parser.parse_args()
    ok = True
    within, fitted = 0, 0
    covered: list[float] = []
    print("method seed  rmse_without  rmse_with  with_loo (ratio, <= 1.15)", end="")
    print("  without_loo (ratio, <= 1.05)")
    with tempfile.TemporaryDirectory() as tmp:
        for method in args.methods:
            for seed in range(args.seeds):
                paths = {}
                for name, rig in (("with", RIG), ("without", RigConstants())):
                    paths[name] = Path(tmp) / f"{method}_{seed}_{name}.mcap"
                    scene = Scene(poses=THESIS_POSES, systematic=rig)
                    simulate_session(
                        paths[name], method=method, trials=15, frames=5, seed=100 + seed,
                        scene=scene,
                    )  # fmt: skip
                options = AnalysisOptions(rig_calibration="loo")
                trials = run(list(paths.values()), None, options=options).trials
                by = {Path(s).stem.rsplit("_", 1)[1]: g for s, g in trials.groupby("session")}
                ok_with = by["with"][by["with"]["status"] == "ok"]
                ok_without = by["without"][by["without"]["status"] == "ok"]
                base = rmse(ok_without["err"].to_numpy())
                loo_with = rmse(ok_with["err_rig"].to_numpy())
                loo_without = rmse(ok_without["err_rig"].to_numpy())
                r1, r2 = loo_with / base, loo_without / base
                for g in (ok_with, ok_without):
                    covered += [float(v) for v in g["within95_rig"] if np.isfinite(v)]
                ok &= r1 <= 1.15 and r2 <= 1.05
                print(
                    f"{method:6} {seed:4}  {base:12.3f}  {rmse(ok_with['err'].to_numpy()):9.3f}  "
                    f"{loo_with:8.3f} ({r1:.2f})            {loo_without:8.3f} ({r2:.2f})"
                )
                fit, _ = calibrate([str(paths["with"])], TRUE_GROUPS)
                for row in fit.rows(RIG):
                    if row["fitted"]:
                        fitted += 1
                        gap = abs(float(row["value"]) - float(row["truth"]))  # type: ignore[arg-type]
                        within += gap <= 1.96 * float(row["sigma"])  # type: ignore[arg-type]
    coverage = float(np.mean(covered)) if covered else float("nan")
    print(
        f"95% coverage after correction (leave-one-out): {coverage:.0%} of {len(covered)} "
        "trials (target 90-99% over >= 500 trials)"
    )
    share = within / max(fitted, 1)
    print(f"constants within their 95% intervals of the truth: {within} of {fitted} ({share:.0%})")
    ok &= share >= 0.9
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
