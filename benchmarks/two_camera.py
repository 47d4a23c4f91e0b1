"""Two real cameras: OpenCV's stereo photographs measured with twopose's point solver.

    .venv/bin/python benchmarks/two_camera.py [--data data/opencv-chessboard]

The 13 left/right photographs of a 9x6 checkerboard with 25 mm squares (two real cameras
side by side). Leave-one-out over the pairs: each camera calibrated on the other 12 views
(``recorder.calibration.camera.fit_views``, the fit of ``twopose-record calibrate``), their relative
pose by ``cv2.stereoCalibrate`` (intrinsics fixed) on the other 12 pairs; the held-out
pair's 54 corners undistorted, reconstructed from the two views by
``twopose.solve.two_view.triangulate_two_views`` (the thesis' midpoint and the reprojection-optimal
pair), and every adjacent corner spacing (93 a pair) compared with the true 25 mm. OpenCV's
own ``triangulatePoints`` on the same pixels is the reference column.

Each spacing's error is also predicted to first order from the pixel errors the data show:
each corner's 1-sigma is the larger of the stereo fit's RMS and that corner's residual in
its own photograph (the board's single-view pose by ``solvePnP`` with the fold's
intrinsics, large where the corner finder misplaced a corner), carried through the
two-view geometry. Prints one line per held-out pair and the summary; exits 1 if a spacing
error is beyond 3 of its sigmas or the median beyond the median sigma.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]
from numpy.typing import NDArray

from recorder.calibration.camera import fit_views
from twopose.camera.model import Intrinsics
from twopose.detect.checkerboard import board_pattern
from twopose.pair.board_fit import LensModel
from twopose.pair.holdout import corner_sigma_px, spacing_sigma, spacings
from twopose.solve.nview import projection_matrices
from twopose.solve.two_view import triangulate_two_views

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "two_camera.txt"
DEFAULT = Path(__file__).resolve().parents[1] / "data" / "opencv-chessboard"
BOARD = (9, 6)  # inner corners, (cols, rows)
SQUARE_MM = 25.0
SIZE = (640, 480)
ESTIMATORS = ("thesis", "optimal")

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]


def pattern() -> F32:
    """The board's corners (54, 3) in mm, row by row (OpenCV's corner order)."""
    return board_pattern(BOARD, SQUARE_MM)


def _corners(path: Path) -> F32:
    gray = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if gray is None:
        raise FileNotFoundError(path)
    found, corners = cv2.findChessboardCorners(gray, BOARD)
    if not found:
        raise ValueError(f"no {BOARD[0]}x{BOARD[1]} board in {path}")
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    return np.asarray(cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), criteria), np.float32)


def detect(folder: Path) -> dict[str, tuple[F32, F32]]:
    """Each pair's corners (54, 1, 2) in the left and right photographs, by pair number."""
    names = sorted(p.name[len("left") : -len(".jpg")] for p in folder.glob("left*.jpg"))
    return {
        n: (_corners(folder / f"left{n}.jpg"), _corners(folder / f"right{n}.jpg")) for n in names
    }


@dataclass(frozen=True)
class Fold:
    """One held-out pair: its spacings' errors (mm) per estimator and their prediction."""

    held: str
    stereo_rms_px: float
    baseline_mm: float
    depth_mm: float  # median corner depth in the left camera
    errors: dict[str, F64]  # estimator (and "opencv") -> (93,) spacing - 25 mm
    sigma_mm: F64  # (93,) first-order 1-sigma of each spacing (thesis estimator)
    corner_sigma_px: F64  # (54,) the per-corner pixel 1-sigma used


def _camera(i: Intrinsics) -> tuple[F64, F64]:
    K = np.array([[i.fx, 0.0, i.cx], [0.0, i.fy, i.cy], [0.0, 0.0, 1.0]])
    return K, np.array(i.distortion, np.float64)


def _spacings(points: F64) -> F64:
    """(93,) distances between row and column neighbours of the (54, 3) grid."""
    return spacings(points, BOARD)


def held_out(pairs: dict[str, tuple[F32, F32]], held: str) -> Fold:
    """Calibrate on every pair but ``held``, measure ``held``'s board."""
    train = [n for n in pairs if n != held]
    obj = pattern()
    K1, d1 = _camera(fit_views([pairs[n][0] for n in train], train, SIZE, obj).intrinsics)
    K2, d2 = _camera(fit_views([pairs[n][1] for n in train], train, SIZE, obj).intrinsics)
    rms, *_, R, T, _, _ = cv2.stereoCalibrate(
        [obj] * len(train),
        [pairs[n][0] for n in train],
        [pairs[n][1] for n in train],
        K1,
        d1,
        K2,
        d2,
        SIZE,
        flags=cv2.CALIB_FIX_INTRINSIC,
    )
    T = np.asarray(T, np.float64).ravel()  # x2 = R x1 + T: camera 2 at -R^T T, camera 1's frame
    left, right = pairs[held]
    u1 = cv2.undistortPoints(left, K1, d1, P=K1).reshape(-1, 2).astype(np.float64)
    u2 = cv2.undistortPoints(right, K2, d2, P=K2).reshape(-1, 2).astype(np.float64)
    P1 = projection_matrices([K1[0, 0], K1[1, 1], K1[0, 2], K1[1, 2]], np.eye(3), np.zeros(3))
    P2 = projection_matrices([K2[0, 0], K2[1, 1], K2[0, 2], K2[1, 2]], R.T, -R.T @ T)
    errors, points = {}, {}
    for estimator in ESTIMATORS:
        solved = triangulate_two_views(u1, u2, P1, P2, estimator=estimator)
        points[estimator] = solved.point_grid
        errors[estimator] = _spacings(solved.point_grid) - SQUARE_MM
    X = cv2.triangulatePoints(P1, P2, u1.T, u2.T)
    errors["opencv"] = _spacings((X[:3] / X[3]).T) - SQUARE_MM
    # d(point)/d(pixels) (54, 3, 4) by central differences through the solver.
    jac = np.zeros((len(u1), 3, 4))
    h = 1e-3
    for k in range(4):
        step = np.zeros((len(u1), 4))
        step[:, k] = h
        ends = [
            triangulate_two_views(u1 + s[:, :2], u2 + s[:, 2:], P1, P2).point_grid
            for s in (step, -step)
        ]
        jac[:, :, k] = (ends[0] - ends[1]) / (2 * h)
    lenses = (LensModel(K=K1, distortion=d1), LensModel(K=K2, distortion=d2))
    corner_sigma = corner_sigma_px(float(rms), left, right, obj, lenses)
    return Fold(
        held=held,
        stereo_rms_px=float(rms),
        baseline_mm=float(np.linalg.norm(T)),
        depth_mm=float(np.median(points["thesis"][:, 2])),
        errors=errors,
        sigma_mm=spacing_sigma(points["thesis"], jac, corner_sigma, BOARD),
        corner_sigma_px=corner_sigma,
    )


def leave_one_out(pairs: dict[str, tuple[F32, F32]]) -> list[Fold]:
    return [held_out(pairs, n) for n in pairs]


def summary(folds: list[Fold]) -> dict[str, float]:
    """Median and worst |spacing error| (mm) over every held-out spacing, per estimator;
    the largest error in sigmas; the median sigma."""
    out: dict[str, float] = {}
    for name in (*ESTIMATORS, "opencv"):
        e = np.abs(np.concatenate([f.errors[name] for f in folds]))
        out[f"{name}_median_mm"] = float(np.median(e))
        out[f"{name}_worst_mm"] = float(e.max())
        out[f"{name}_mean_mm"] = float(np.mean(np.concatenate([f.errors[name] for f in folds])))
    z = np.concatenate([np.abs(f.errors["thesis"]) / f.sigma_mm for f in folds])
    out["worst_sigmas"] = float(z.max())
    out["sigma_median_mm"] = float(np.median(np.concatenate([f.sigma_mm for f in folds])))
    # Spacings between corners that fit their own photograph's pose to 1 px.
    clean = np.concatenate([_clean_spacings(f) for f in folds])
    e = np.abs(np.concatenate([f.errors["thesis"] for f in folds]))[clean]
    out["clean_worst_mm"] = float(e.max())
    out["clean_share"] = float(clean.mean())
    return out


def _clean_spacings(fold: Fold) -> NDArray[np.bool_]:
    cols, rows = BOARD
    ok = (fold.corner_sigma_px <= 1.0).reshape(rows, cols)
    return np.concatenate([(ok[:, :-1] & ok[:, 1:]).ravel(), (ok[:-1] & ok[1:]).ravel()])


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    return _report(parser.parse_args())


def _report(args: argparse.Namespace) -> int:
    folds = leave_one_out(detect(args.data))
    print("held-out pair | stereo RMS px | depth mm | median |err| mm | worst |err| mm | in sigmas")
    for f in folds:
        e = np.abs(f.errors["thesis"])
        print(
            f"{f.held:>13} | {f.stereo_rms_px:13.3f} | {f.depth_mm:8.0f} | {np.median(e):15.3f} "
            f"| {e.max():14.2f} | {(e / f.sigma_mm).max():9.2f}"
        )
    s = summary(folds)
    n = sum(len(f.errors["thesis"]) for f in folds)
    print(
        f"{len(folds)} held-out pairs, {n} spacings of {SQUARE_MM:g} mm, baseline "
        f"{np.median([f.baseline_mm for f in folds]):.1f} mm:"
    )
    for name in (*ESTIMATORS, "opencv"):
        label = {"opencv": "OpenCV triangulatePoints"}.get(name, f"twopose {name}")
        print(
            f"  {label}: median |error| {s[f'{name}_median_mm']:.3f} mm "
            f"({s[f'{name}_median_mm'] / SQUARE_MM:.2%}), worst {s[f'{name}_worst_mm']:.2f} mm, "
            f"mean {s[f'{name}_mean_mm']:+.3f} mm"
        )
    print(
        f"  worst {s['worst_sigmas']:.2f} sigma (median sigma {s['sigma_median_mm']:.2f} mm; "
        f"target <= 3); corners within 1 px of their own photograph's pose "
        f"({s['clean_share']:.0%} of the spacings): worst {s['clean_worst_mm']:.2f} mm"
    )
    ok = s["worst_sigmas"] <= 3.0 and s["thesis_median_mm"] <= s["sigma_median_mm"]
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
