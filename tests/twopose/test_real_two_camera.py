"""Two real cameras (OpenCV's stereo photographs): the held-out pair's board, reconstructed
by twopose's two-view point solver, has its 25 mm squares within what its pixels allow.

Leave-one-out over the 13 pairs (``benchmarks/two_camera.py`` prints the table); the
corners are detected once for the module.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from tests.helpers import load_benchmark

DATA = Path(__file__).resolve().parents[2] / "data" / "opencv-chessboard"


def _bench() -> ModuleType:
    return load_benchmark("two_camera")


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return _bench()


@pytest.fixture(scope="module")
def folds(bench: ModuleType) -> list[Any]:
    pairs = bench.detect(DATA)
    assert len(pairs) == 13  # the board is found in both photographs of every pair
    return list(bench.leave_one_out(pairs))


def test_held_out_boards_keep_their_squares(bench: ModuleType, folds: list[Any]) -> None:
    s = bench.summary(folds)
    # Every spacing within 3 sigma of its first-order prediction from the pixel errors the
    # data show (the stereo fit's RMS, or a corner's misfit in its own photograph).
    assert s["worst_sigmas"] <= 3.0
    # The typical spacing is better than the stereo fit's RMS carried to the board predicts.
    assert s["thesis_median_mm"] <= s["sigma_median_mm"]
    assert s["thesis_median_mm"] <= 0.01 * bench.SQUARE_MM
    # No scale error: the mean spacing within 1% of the true 25 mm.
    assert abs(s["thesis_mean_mm"]) <= 0.01 * bench.SQUARE_MM


def test_twopose_agrees_with_opencv_triangulation(bench: ModuleType, folds: list[Any]) -> None:
    for f in folds:
        # Same pixels, same cameras: the optimal pair is OpenCV's answer where the rays meet
        # and close to it where they do not; the midpoint differs from both only by a small
        # share of each spacing's own uncertainty (where a misplaced corner's rays miss).
        assert (np.abs(f.errors["optimal"] - f.errors["opencv"]) <= 0.01 * f.sigma_mm).all()
        assert (np.abs(f.errors["thesis"] - f.errors["opencv"]) <= 0.1 * f.sigma_mm).all()
        assert np.median(np.abs(f.errors["thesis"] - f.errors["opencv"])) < 0.01
    s = bench.summary(folds)
    assert s["optimal_median_mm"] <= 1.05 * s["opencv_median_mm"]
