"""The pair's calibration (twopose.pair.calibration, board_fit, holdout, floor): a known pair
recovered within its covariance, OpenCV's stereoCalibrate's answer on its own photographs,
an outlier view dropped, degenerate sets refused, the floor, the covariance as typed pose."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from types import ModuleType

import cv2
import numpy as np
import pytest

from recorder.calibration.camera import fit_views
from tests.helpers import load_benchmark
from twopose.camera.model import Intrinsics
from twopose.detect.checkerboard import board_pattern, find_board
from twopose.errors import InputValueError
from twopose.pair.board_fit import BoardCorners, rotation_matrix, rotation_vector
from twopose.pair.calibration import PairCalibration, fit_pair, typed_pose_cov, widening
from twopose.pair.floor import floor_from_board
from twopose.pair.motion import thesis_pair
from twopose.rig.constants import angles_deg_from_rotation
from twopose.values.units import Units

DATA = Path(__file__).resolve().parents[3] / "data" / "opencv-chessboard"
CHI2_6DOF_999 = 22.457744484825323
CHI2_3DOF_999 = 16.26623619623813


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    """The calibration benchmark: its simulated pair (truth known) and views."""
    return load_benchmark("bench_pair_calibration")


def _fit(bench: ModuleType, seed: int, views: int = 6, **kwargs: object) -> PairCalibration:
    left, right = bench.simulated_views(np.random.default_rng(seed), views)
    corners = BoardCorners.of(bench.BOARD, bench.SQUARE_MM, left, right)
    cams = (bench.SIM_INTRINSICS, bench.SIM_INTRINSICS)
    return fit_pair(corners, cams, units=Units.MM, **kwargs)  # type: ignore[arg-type]


def _error(bench: ModuleType, pc: PairCalibration) -> np.ndarray:
    return np.r_[rotation_vector(bench.SIM_R @ pc.R_2_to_1.T), bench.SIM_T - pc.t_2_in_1]


def test_a_known_pair_is_recovered_within_its_covariance(bench: ModuleType) -> None:
    pc = _fit(bench, 1)
    e = _error(bench, pc)
    assert e @ np.linalg.solve(pc.cov_extrinsic, e) <= CHI2_6DOF_999
    assert pc.n_views == 6
    assert pc.view_names == tuple(f"view {k}" for k in range(1, 7))
    assert pc.rms_px == pytest.approx(bench.NOISE_PX * np.sqrt(2), rel=0.15)  # per corner
    check = pc.check
    assert check is not None
    assert check.passed
    assert check.folds == 6
    assert check.spacings == 6 * 93
    assert pc.cov_factor == widening(check) >= 1.0
    # Without the check: the fit's own covariance, not widened.
    plain = _fit(bench, 1, check=False)
    assert plain.check is None
    assert plain.cov_factor == 1.0
    assert np.allclose(plain.cov_extrinsic * pc.cov_factor, pc.cov_extrinsic)


@pytest.fixture(scope="module")
def photographs() -> tuple[list[np.ndarray], list[np.ndarray], list[Intrinsics]]:
    """Five of OpenCV's pairs: both cameras' corners and intrinsics fitted on them."""
    names = ["01", "03", "05", "07", "09"]
    left: list[np.ndarray] = []
    right: list[np.ndarray] = []
    for n in names:
        for side, out in (("left", left), ("right", right)):
            image = np.asarray(cv2.imread(str(DATA / f"{side}{n}.jpg")), np.uint8)
            corners = find_board(image, (9, 6))
            assert corners is not None
            out.append(corners)
    obj = board_pattern((9, 6), 25.0)
    cams = [fit_views(c, names, (640, 480), obj).intrinsics for c in (left, right)]
    return left, right, cams


def test_opencvs_photographs_give_stereo_calibrates_answer(
    photographs: tuple[list[np.ndarray], list[np.ndarray], list[Intrinsics]],
) -> None:
    left, right, cams = photographs
    corners = BoardCorners.of((9, 6), 25.0, left, right)
    pc = fit_pair(corners, (cams[0], cams[1]), units=Units.MM)
    K1, K2 = cams[0].K, cams[1].K
    d1, d2 = np.array(cams[0].distortion), np.array(cams[1].distortion)
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    rms, *_, R, T, _, _ = cv2.stereoCalibrate(
        [board_pattern((9, 6), 25.0)] * 5, left, right, K1, d1, K2, d2, (640, 480),
        flags=cv2.CALIB_FIX_INTRINSIC, criteria=criteria,
    )  # fmt: skip
    assert np.linalg.norm(rotation_vector(pc.R_2_to_1 @ R)) < 1e-6  # rad
    assert np.linalg.norm(pc.t_2_in_1 + R.T @ np.ravel(T)) < 1e-3  # mm
    assert pc.rms_px == pytest.approx(rms, abs=1e-6)
    assert 80 < pc.baseline < 90  # about 84 mm, as two_camera.py measures
    check = pc.check
    assert check is not None
    assert check.passed  # every held-out spacing within 3 of its sigma
    assert check.worst_sigmas <= 3.0
    assert check.beyond == 0


def test_a_view_whose_corners_run_backwards_in_one_camera_is_dropped_and_named(
    bench: ModuleType,
) -> None:
    left, right = bench.simulated_views(np.random.default_rng(4), 6)
    right[2] = right[2][::-1]  # the corner finder's order reversed in camera 2
    corners = BoardCorners.of(bench.BOARD, bench.SQUARE_MM, left, right)
    cams = (bench.SIM_INTRINSICS, bench.SIM_INTRINSICS)
    pc = fit_pair(corners, cams, units=Units.MM, names=[f"pair {k}" for k in range(6)], check=False)
    assert len(pc.dropped) == 1
    assert pc.dropped[0].startswith("pair 2 (its own relative pose")
    assert pc.n_views == 5
    assert "pair 2" not in pc.view_names
    e = _error(bench, pc)
    assert e @ np.linalg.solve(pc.cov_extrinsic, e) <= CHI2_6DOF_999


def test_degenerate_sets_are_refused_in_words(bench: ModuleType) -> None:
    left, right = bench.simulated_views(np.random.default_rng(5), 4)
    cams = (bench.SIM_INTRINSICS, bench.SIM_INTRINSICS)

    def fit(a: list[np.ndarray], b: list[np.ndarray]) -> PairCalibration:
        return fit_pair(BoardCorners.of((9, 6), 25.0, a, b), cams, units=Units.MM, check=False)

    with pytest.raises(InputValueError, match="in 2 view"):
        fit(left[:2], right[:2])
    with pytest.raises(InputValueError, match="same place in both cameras"):
        fit([*left[:3], left[0]], [*right[:3], right[0]])
    with pytest.raises(InputValueError, match="share a centre"):
        fit(left, left)  # one camera's stills given as both
    # a baseline a pair file may not state (under 1 mm), however fine the board: what
    # calibrate-pair writes, the reader reads (a 0.001 mm square: a 0.003 mm baseline)
    with pytest.raises(InputValueError, match="share a centre"):
        fit_pair(BoardCorners.of((9, 6), 0.001, left, right), cams, units=Units.MM, check=False)
    with pytest.raises(InputValueError, match="outside its 640x480 image"):
        fit([*left[:3], left[3] + 700], right)
    with pytest.raises(InputValueError, match="4 views of the board in camera 1 but 3"):
        fit(left, right[:3])
    with pytest.raises(InputValueError, match="54"):
        fit([*left[:3], left[3][:10]], right)


def test_the_floor_from_a_board_lying_on_it(bench: ModuleType) -> None:
    pc = _fit(bench, 6, check=False)
    rng = np.random.default_rng(8)
    for _ in range(3):
        assert bench._floor_inside(pc, rng)  # within its 95% region, 3 of 3
    # Camera 1 alone: the same floor, from its corners only.
    obj = board_pattern((9, 6), 25.0).astype(np.float64)
    R = rotation_matrix([np.pi / 2, 0.0, 0.0])
    points = (obj - obj.mean(axis=0)) @ R.T + [0.0, 500.0, 1000.0]
    left = bench._project(points, np.eye(3), np.zeros(3), bench.SIM_INTRINSICS)
    floor = floor_from_board(pc, left, None, (9, 6), 25.0, thickness=3.0)
    e = np.r_[floor.normal - [0, 1, 0], floor.height - 503.0]  # 3 mm under the board
    assert np.abs(e).max() < 1e-4  # noise-free: to the fit's precision (mm)
    with pytest.raises(InputValueError, match="thickness"):
        floor_from_board(pc, left, None, (9, 6), 25.0, thickness=-1.0)


def test_the_extrinsic_covariance_as_a_typed_pose() -> None:
    """typed_pose_cov: the angles' covariance agrees with rotations drawn from it."""
    cov = np.diag([np.radians(0.5) ** 2, np.radians(1.0) ** 2, np.radians(0.2) ** 2, 1, 4, 9])
    pair = thesis_pair(cov_extrinsic=cov)
    typed = typed_pose_cov(pair)
    assert np.allclose(np.diag(typed)[:3], [1, 4, 9])  # t as it is
    rng = np.random.default_rng(0)
    d = rng.multivariate_normal(np.zeros(3), cov[:3, :3], 20000)
    angles = angles_deg_from_rotation(rotation_matrix(d) @ pair.R_2_to_1)
    sample = np.cov((angles - pair.angles_deg).T)
    assert np.allclose(sample, typed[3:, 3:], rtol=0.05, atol=2e-3)  # 20000 draws


def test_a_pair_calibration_checks_itself() -> None:
    pair = thesis_pair()
    with pytest.raises(InputValueError, match="not a rotation"):
        dataclasses.replace(pair, R_2_to_1=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InputValueError, match="symmetric"):
        dataclasses.replace(pair, cov_extrinsic=np.triu(np.ones((6, 6))))
    with pytest.raises(InputValueError, match="positive semi-definite"):
        dataclasses.replace(pair, cov_extrinsic=-np.eye(6))
    with pytest.raises(InputValueError, match="three finite"):
        dataclasses.replace(pair, t_2_in_1=np.array([1.0, np.nan, 0.0]))
    with pytest.raises(InputValueError, match="units must be one of"):
        dataclasses.replace(pair, units="ft")  # type: ignore[arg-type]
    with pytest.raises(InputValueError, match="cov_factor"):
        dataclasses.replace(pair, cov_factor=0.5)
    cov = np.diag([1e-6] * 3 + [0.01] * 3)
    inches = thesis_pair(cov_extrinsic=cov)
    mm = inches.in_units(Units.MM)
    assert mm.t_2_in_1[0] == pytest.approx(152.4)
    assert mm.cov_extrinsic[3, 3] == pytest.approx(0.01 * 25.4**2)
    assert mm.cov_extrinsic[0, 0] == pytest.approx(1e-6)  # radians stay radians
    assert mm.floor is not None
    assert mm.floor.height == pytest.approx(9.625 * 25.4)
    back = mm.in_units(Units.IN)
    assert np.allclose(back.t_2_in_1, inches.t_2_in_1)
    assert np.allclose(back.cov_extrinsic, inches.cov_extrinsic)
