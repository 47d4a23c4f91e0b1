"""Sensitivity sweeps in the thesis' geometry, and its x-translation claim."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.tools.sensitivity import (
    SENSITIVITY_COLUMNS,
    Geometry,
    sensitivity,
    x_translation_effect,
)
from twopose.methods.planes import GROUND_PLANE
from twopose.methods.specs import METHOD_SPECS, Method


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    return sensitivity(samples=400, seed=1)


def _curve(table: pd.DataFrame, method: str, sweep: str) -> np.ndarray:
    g = table[(table["method"] == method) & (table["sweep"] == sweep)].sort_values("value")
    return g["rmse"].to_numpy()


def test_table_shape(table: pd.DataFrame) -> None:
    assert list(table.columns) == SENSITIVITY_COLUMNS
    assert set(table["method"]) == {"point", "ground"}
    assert (table["n_ok"] > 0).all()


@pytest.mark.parametrize("method", ["point", "ground"])
def test_error_grows_with_noise_and_shrinks_with_baseline(table: pd.DataFrame, method: str) -> None:
    assert np.all(np.diff(_curve(table, method, "pixel noise")) > 0)
    assert np.all(np.diff(_curve(table, method, "pose error x")) > 0)
    assert np.all(np.diff(_curve(table, method, "baseline length")) < 0)
    # With the baseline along x, an error in the typed x moves the estimate most.
    assert _curve(table, method, "pose error x")[-1] > _curve(table, method, "pose error z")[-1]


def test_x_translation_effect_is_first_order_and_zero_without_error() -> None:
    assert x_translation_effect(0.0) == pytest.approx(0.0, abs=1e-9)
    small, double = x_translation_effect(0.05), x_translation_effect(0.1)
    assert double == pytest.approx(2 * small, rel=0.05)
    # A sideways error in a camera centre shifts its plane sideways: the x effect barely
    # depends on the baseline (the depth effect does; see the baseline-length sweep).
    assert x_translation_effect(0.1, Geometry(baseline=(3.0, 0.0, 0.0))) == pytest.approx(
        double, rel=0.2
    )


def test_sensitivity_command(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["sensitivity", "--out", str(tmp_path), "--samples", "200"])
    assert result.exit_code == 0, result.output
    assert "thesis claim" in result.output
    assert (tmp_path / "sensitivity.png").stat().st_size > 10_000
    assert len(pd.read_csv(tmp_path / "sensitivity.csv")) == 65


def test_a_method_on_a_wall_is_swept_on_its_wall() -> None:
    """A method on another plane (docs/development.md's wall ``x = c``, its spec built as an
    extension builds it) is swept by its geometry on its own plane: the finger points at the
    wall, the solver cuts with the wall, the errors are the wall's. Noise-free, the estimate
    is the point on the wall; the thesis' hard-coded ground would put it far off."""
    wall = dataclasses.replace(
        GROUND_PLANE, name="the wall", normal_grid=(1.0, 0.0, 0.0),
        in_plane_grid=((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), setup_key="wall_x",
    )  # fmt: skip
    spec = dataclasses.replace(METHOD_SPECS[Method.GROUND], plane=wall)
    base = Geometry(ground_height=3.0, ground_point=(1.0, 12.0), pixel_sigma=1e-6)
    table = sensitivity(samples=20, seed=2, base=base, methods=[spec])
    assert set(table["method"]) == {"ground"}
    assert (table["n_ok"] == 20).all()
    quiet = table[(table["sweep"] == "pixel noise")].sort_values("value")
    assert np.all(np.diff(quiet["rmse"].to_numpy()) > 0)  # noise moves it, as on the ground
    exact = sensitivity(
        samples=5, seed=2, base=dataclasses.replace(base, pixel_sigma=0.0, theta_sigma_deg=0.0),
        methods=[spec],
    )  # fmt: skip
    first = exact[exact["sweep"] == "target distance"]
    assert first["rmse"].max() < 1e-6  # the truth is the wall's point, the cut the wall's
    assert "finger tilt" in set(table["sweep"])  # a finger pointing at a plane: its tilt


def test_the_line_has_no_sweep() -> None:
    """The line's error is not a point's: asked for, it is refused in words."""
    with pytest.raises(ValueError, match="no sensitivity sweep"):
        sensitivity(samples=5, methods=[METHOD_SPECS[Method.LINE]])
