"""twopose.solve.nview's conditioning measures directly: the pairwise measures against a
brute-force loop over pairs (also across the blocks the rows are cut into), the parallax a
known baseline subtends, and the one no-baseline rule."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np
import pytest

from twopose.camera.model import rotation_from_angles_deg
from twopose.solve.nview import (
    flag_no_baseline,
    pairwise_max_abs_dot,
    pairwise_max_sine,
    parallax_sine,
    projection_matrices,
)


def _brute(
    u: np.ndarray,
    v: np.ndarray,
    valid: np.ndarray,
    pair_value: Callable[[np.ndarray, np.ndarray], float],
) -> np.ndarray:
    out = np.zeros(len(u))
    for t in range(len(u)):
        values = [
            pair_value(u[t, i], v[t, j])
            for i, j in itertools.product(range(u.shape[1]), repeat=2)
            if valid[t, i] and valid[t, j]
        ]
        out[t] = max(values, default=0.0)
    return out


@pytest.mark.parametrize(("trials", "views"), [(7, 4), (3, 600)])  # 600 views: rows in blocks
def test_the_pairwise_measures_match_a_loop_over_pairs(trials: int, views: int) -> None:
    rng = np.random.default_rng(trials)
    u, v = rng.normal(size=(trials, views, 3)), rng.normal(size=(trials, views, 3))
    valid = rng.random((trials, views)) < 0.7
    valid[0] = False  # no valid pair: 0
    valid[1, :] = False
    valid[1, :2] = True
    u[1, 1] = 3 * u[1, 0]  # parallel: sine 0

    def sine(a: np.ndarray, b: np.ndarray) -> float:
        c = a @ b / np.linalg.norm(a) / np.linalg.norm(b)
        return float(np.sqrt(max(0.0, 1 - c * c)))

    np.testing.assert_allclose(pairwise_max_sine(u, valid), _brute(u, u, valid, sine), atol=1e-7)
    dot = pairwise_max_abs_dot(u, v, valid)
    np.testing.assert_allclose(dot, _brute(u, v, valid, lambda a, b: abs(a @ b)))
    assert dot[0] == 0.0
    assert pairwise_max_sine(u, valid)[1] == pytest.approx(0.0, abs=1e-7)


def test_the_parallax_is_the_angle_the_baseline_subtends() -> None:
    K = np.array([525.0, 525.0, 320.0, 240.0])
    R = rotation_from_angles_deg(np.zeros((1, 2, 3)))
    t = np.array([[[0.0, 0, 0], [2.0, 0, 0]]])  # a 2-inch baseline
    P = projection_matrices(np.tile(K, (1, 2, 1)), R, t)
    point = np.array([[1.0, 0.0, 10.0]])  # on the baseline's bisector, 10 inches away
    expected = np.sin(2 * np.arctan(1.0 / 10.0))
    np.testing.assert_allclose(parallax_sine(P, np.ones((1, 2), bool), point), [expected])
    assert np.isnan(parallax_sine(P, np.ones((1, 2), bool), np.full((1, 3), np.nan))).all()


def test_views_from_one_centre_are_flagged_whatever_the_solver_said() -> None:
    centres = np.array(
        [
            [[1.0, 2, 3], [1.0, 2, 3], [9.0, 9, 9]],  # the third view is not valid
            [[1.0, 2, 3], [1.5, 2, 3], [0.0, 0, 0]],
            [[0.0, 0, 0], [0.0, 0, 0], [0.0, 0, 0]],  # nothing detected: left as it is
        ]
    )
    ok = np.array([[True, True, False], [True, True, False], [True, True, True]])
    status = np.array(["ok", "ok", "no_detection"], dtype="<U32")
    reason = np.array(["", "", "no target"], dtype="<U64")
    flag_no_baseline(centres, ok, status, reason)
    assert status.tolist() == ["degenerate", "ok", "no_detection"]
    assert reason[0].startswith("no baseline")
    assert reason[2] == "no target"
