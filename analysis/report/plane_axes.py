"""A session's trials read in its method's plane: the two in-plane axes every drawing and
the terminal's bias lines use (:class:`twopose.methods.planes.ConstraintPlane`).

A method's trials are drawn face on its plane (:attr:`twopose.methods.specs.MethodSpec.seen_on`:
method 2's ground from above, x across and z in depth; a wall ``x = c`` from in front, y
and z; a method on no plane, the grid paper from above). An in-plane axis that is a grid
axis is read from the table's own column of its letter (``err_x``, ``t_z``, ``sigma_y``,
``cov_yz``), so that what the ground's drawings show is exactly what they showed; another
axis (a tilted plane's ``u`` and ``v``) is computed from the three columns
(:func:`with_in_plane`).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import pandas as pd

from twopose.methods.planes import GRID_AXES, ConstraintPlane
from twopose.methods.specs import Method, spec_of

__all__ = ["STEMS", "covariances", "plane_of", "with_in_plane"]

#: The tables' columns that hold a point's three coordinates, by the stem before the axis
#: letter: trials.csv's estimate, truth and error, views.csv's camera centre,
#: averaging.csv's running estimate.
STEMS = ("", "gt_", "err_", "t_", "bias_")


def plane_of(trials: pd.DataFrame, default: str = Method.POINT) -> ConstraintPlane:
    """The plane ``trials`` (one method's: a session's) are drawn on; ``default``'s when
    the table has no trial."""
    method = str(trials["method"].iloc[0]) if len(trials) and "method" in trials else default
    return spec_of(method).seen_on


def with_in_plane(
    table: pd.DataFrame, on: ConstraintPlane, stems: Iterable[str] = STEMS
) -> pd.DataFrame:
    """``table`` with its points' in-plane coordinates as columns ``<stem><axis>`` for each
    axis of ``on`` that is no grid axis (``err_u``, ``t_v``), computed from ``<stem>x``,
    ``<stem>y``, ``<stem>z``, with the in-plane variances (``sigma_u``, ``cov_uv``) when it
    has the covariance's columns; ``table`` itself when both axes are grid axes."""
    grid = {name for name, _ in GRID_AXES}
    computed = [(i, name) for i, name in enumerate(on.axis_names) if name not in grid]
    if not computed:
        return table
    added: dict[str, np.ndarray] = {}
    for stem in stems:
        columns = [f"{stem}{a}" for a, _ in GRID_AXES]
        if set(columns) <= set(table.columns):
            uv = on.in_plane(table[columns].to_numpy(dtype=np.float64))
            added |= {f"{stem}{name}": uv[:, i] for i, name in computed}
    if {"sigma_x", "sigma_y", "sigma_z", "cov_xy", "cov_xz", "cov_yz"} <= set(table.columns):
        C = on.in_plane_cov(_grid_covariances(table))
        added |= {f"sigma_{name}": np.sqrt(C[:, i, i]) for i, name in computed}
        added[covariance_column(on)] = C[:, 0, 1]
    return table.assign(**added)


def covariances(table: pd.DataFrame, on: ConstraintPlane) -> np.ndarray:
    """(n, 2, 2) in-plane marginal covariances of ``table``'s trials (NaN read as 0), from
    their ``sigma_*`` and ``cov_*`` columns (:func:`with_in_plane` adds a tilted plane's)."""
    a, b = on.axis_names
    C = np.zeros((len(table), 2, 2))
    C[:, 0, 0] = table[f"sigma_{a}"].to_numpy(dtype=np.float64) ** 2
    C[:, 1, 1] = table[f"sigma_{b}"].to_numpy(dtype=np.float64) ** 2
    C[:, 0, 1] = C[:, 1, 0] = table[covariance_column(on)].to_numpy(dtype=np.float64)
    return np.nan_to_num(C, posinf=0.0, neginf=0.0)


def covariance_column(on: ConstraintPlane) -> str:
    """The column of the in-plane axes' covariance (``cov_xz`` for the ground)."""
    a, b = on.axis_names
    return f"cov_{''.join(sorted(a + b))}"


def _grid_covariances(table: pd.DataFrame) -> np.ndarray:
    """(n, 3, 3) each trial's covariance in the grid frame from its columns."""
    C = np.empty((len(table), 3, 3))
    for i, a in enumerate("xyz"):
        C[:, i, i] = table[f"sigma_{a}"].to_numpy(dtype=np.float64) ** 2
    for (i, a), (j, b) in (((0, "x"), (1, "y")), ((0, "x"), (2, "z")), ((1, "y"), (2, "z"))):
        C[:, i, j] = C[:, j, i] = table[f"cov_{a}{b}"].to_numpy(dtype=np.float64)
    return C
