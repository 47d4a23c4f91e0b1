"""twopose.methods.planes: a plane's in-plane axes, what every drawing and bias line reads.

Over planes of every orientation: a point of the plane reads back as the in-plane
coordinates it was made from and its offset along the normal; the in-plane covariance is
the marginal of the points' scatter; a grid axis is named by its letter and read as that
coordinate exactly (the ground's x and z, a wall's y and z), another is ``u``/``v``; and
the tables' in-plane columns (:func:`analysis.report.plane_axes.with_in_plane`) are those axes.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.report.plane_axes import covariance_column, covariances, with_in_plane
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import METHOD_SPECS
from twopose.values.bounds import GROUND_HEIGHT

_finite = st.floats(-50.0, 50.0, allow_nan=False)


def _plane(rotation: np.ndarray) -> ConstraintPlane:
    """A plane whose normal and in-plane axes are ``rotation``'s columns."""
    n, u, v = (tuple(float(x) for x in rotation[:, i]) for i in range(3))
    return ConstraintPlane(
        name="the slope", normal_grid=n, in_plane_grid=(u, v), setup_key="slope_offset",  # type: ignore[arg-type]
        label="slope", measured="the slope's offset", equation="n . p = c", axis="n",
        bound=GROUND_HEIGHT,
    )  # fmt: skip


@st.composite
def planes(draw: st.DrawFn) -> ConstraintPlane:
    """A plane of any orientation (a random rotation's columns), or one on grid axes."""
    if draw(st.booleans()):
        q, _ = np.linalg.qr(np.array(draw(st.lists(_finite, min_size=9, max_size=9))).reshape(3, 3)
                            + np.eye(3) * 60.0)  # fmt: skip
        return _plane(q)
    axes = draw(st.permutations([0, 1, 2]))
    return _plane(np.eye(3)[:, axes])


@settings(max_examples=60, deadline=None)
@given(planes(), _finite, st.lists(st.tuples(_finite, _finite), min_size=1, max_size=5))
def test_a_point_of_the_plane_reads_back_as_its_in_plane_coordinates(
    plane: ConstraintPlane, offset: float, coordinates: list[tuple[float, float]]
) -> None:
    points = np.array([plane.point(c, offset) for c in coordinates])
    assert plane.in_plane(points) == pytest.approx(np.array(coordinates), abs=1e-9)
    assert plane.along_normal(points) == pytest.approx(offset, abs=1e-9)
    gaps = [plane.gap(p, offset) for p in points]
    assert gaps == pytest.approx([0.0] * len(points), abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(planes(), st.integers(0, 2**32 - 1))
def test_the_in_plane_covariance_is_the_scatters_marginal(
    plane: ConstraintPlane, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(3, 3))
    cloud = rng.normal(size=(400, 3)) @ a.T
    cov = np.cov(cloud.T)
    assert plane.in_plane_cov(cov) == pytest.approx(np.cov(plane.in_plane(cloud).T), abs=1e-9)


def test_a_grid_axis_is_named_and_read_by_its_letter() -> None:
    wall = _plane(np.eye(3))  # normal x, in-plane y and z
    assert GROUND_PLANE.axis_names == ("x", "z")
    assert wall.axis_names == ("y", "z")
    assert _plane(np.eye(3)[:, [0, 2, 1]] * [1, -1, 1]).axis_names == ("u", "y")
    points = np.array([[1.0, np.nan, 3.0], [4.0, 5.0, np.inf]])
    assert np.array_equal(GROUND_PLANE.in_plane(points), [[1.0, 3.0], [4.0, np.inf]])
    # a method on no plane is drawn on the ground; method 2 on its own
    assert {s.seen_on for s in METHOD_SPECS.values()} == {GROUND_PLANE}


def test_the_tables_in_plane_columns_are_its_axes() -> None:
    """A tilted plane's ``err_u``/``err_v`` and ``sigma_u``/``cov_uv`` are computed from the
    grid's columns; a grid-axis plane's are the table's own columns, untouched."""
    rng = np.random.default_rng(3)
    tilted = _plane(np.linalg.qr(rng.normal(size=(3, 3)))[0])
    assert tilted.axis_names == ("u", "v")
    a = rng.normal(size=(4, 3, 3))
    cov = a @ a.transpose(0, 2, 1)
    err = rng.normal(size=(4, 3))
    table = pd.DataFrame(
        {f"err_{x}": err[:, i] for i, x in enumerate("xyz")}
        | {f"sigma_{x}": np.sqrt(cov[:, i, i]) for i, x in enumerate("xyz")}
        | {
            f"cov_{x}{y}": cov[:, i, j]
            for i, j, x, y in ((0, 1, "x", "y"), (0, 2, "x", "z"), (1, 2, "y", "z"))
        }
    )
    read = with_in_plane(table, tilted)
    assert read[["err_u", "err_v"]].to_numpy() == pytest.approx(tilted.in_plane(err))
    assert covariances(read, tilted) == pytest.approx(tilted.in_plane_cov(cov))
    assert covariance_column(tilted) == "cov_uv"
    assert with_in_plane(table, GROUND_PLANE) is table
    assert covariances(table, GROUND_PLANE) == pytest.approx(GROUND_PLANE.in_plane_cov(cov))
