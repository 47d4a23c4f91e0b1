"""A session's top view: every ok trial seen face on its method's plane (from above for
the ground and the methods on no plane; from in front for a wall), drawn by the core's
geometry (:func:`twopose.methods.topview.top_view`), so that what the report shows is what the
solver did: rays through the dot meeting at the estimate (method 1), each view plane's
trace on the plane meeting at the estimate, not at the finger (method 2), the estimated
line (lines). The axes are the plane's two in-plane axes
(:class:`twopose.methods.planes.ConstraintPlane`: the ground's x across and z in depth).

One artist per kind, whatever the number of trials; a colour per trial (the session's, as
in its other figures) with its key; warned trials dashed; the truth drawn over the rays;
the axes framed by the trials the statistics use; legends below the axes, never on the
data.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from analysis.report.figures.style import (
    KEY_MARGIN,
    TrialColours,
    beyond_note,
    equal_scales,
    frame,
    key,
    layout,
    legend_below,
    mark_beyond,
    style,
)
from analysis.session.metrics import used_trials, warned
from twopose.camera.model import rotation_from_angles_deg
from twopose.display.scene import TrialScene
from twopose.methods.specs import Method, spec_of
from twopose.methods.topview import TopView, top_view

__all__ = ["VIEW_GEOMETRY", "plot_top_view", "top_views"]

#: views.csv columns a top view needs beyond the camera centre and the pixel.
VIEW_GEOMETRY = ["fx", "fy", "cx", "cy", "r_x_deg", "r_y_deg", "r_z_deg"]

#: views.csv columns a trial's scene is built from, in this order.
_VIEW_ARRAY = ["fx", "fy", "cx", "cy", "r_x_deg", "r_y_deg", "r_z_deg", "t_x", "t_y", "t_z",
               "col", "row", "theta_deg"]  # fmt: skip


def _scene(row: dict[str, object], views: np.ndarray) -> TrialScene:
    """A trial's scene from its trials.csv values and its views (rows of
    :data:`_VIEW_ARRAY`), as arrays: a session's hundred trials in milliseconds."""
    n = len(views)
    line = spec_of(str(row["method"])).estimates_line
    truth = np.full((2, 3), np.nan)  # a line's true segment is not in trials.csv
    if not line:
        truth[:] = row["truth"]
    return TrialScene(
        trial=int(row["trial"]),  # type: ignore[call-overload]
        method=str(row["method"]),
        status=str(row["status"]),
        intrinsics=views[:, 0:4],
        width_height=np.full((n, 2), np.nan),
        R_cam_to_grid=rotation_from_angles_deg(views[:, 4:7]),
        t_grid=views[:, 7:10],
        px=views[:, 10:12],
        theta_deg=views[:, 12],
        estimate=np.asarray(row["estimate"], dtype=np.float64),
        direction=np.asarray(row["direction"], dtype=np.float64) if line else None,
        truth=truth,
        cov=np.full((3, 3), np.nan),
    )


class Drawn(NamedTuple):
    view: TopView
    warned: bool
    truth: tuple[float, float]  # in the plane's axes; a line's: its true segment's midpoint


def top_views(trials: pd.DataFrame, views: pd.DataFrame) -> list[Drawn]:
    """The top view of each ok trial with two views or more (a trial number recorded twice:
    its last), whether it is warned, and its truth."""
    if views.empty or not set(VIEW_GEOMETRY) <= set(views):
        return []
    ok = used_trials(trials, include_warned=True).drop_duplicates("trial", keep="last")
    arrays = views[_VIEW_ARRAY].to_numpy(dtype=np.float64)
    rows_of = views.groupby("trial").indices  # trial -> positions in views
    doubted = warned(ok).to_numpy()
    estimate = ok[["x", "y", "z"]].to_numpy(dtype=np.float64)
    truth = ok[["gt_x", "gt_y", "gt_z"]].to_numpy(dtype=np.float64)
    dirs = (
        ok[["dir_x", "dir_y", "dir_z"]].to_numpy(dtype=np.float64)
        if "dir_x" in ok
        else np.full((len(ok), 3), np.nan)
    )
    out = []
    columns = zip(ok["trial"], ok["method"].astype(str), ok["status"].astype(str), strict=True)
    for k, (trial, method, status) in enumerate(columns):
        positions = rows_of.get(trial)
        if positions is None or len(positions) < 2:
            continue
        row = {"trial": trial, "method": method, "status": status, "estimate": estimate[k],
               "direction": dirs[k], "truth": truth[k]}  # fmt: skip
        scene = _scene(row, arrays[positions])
        a, b = spec_of(method).seen_on.in_plane(truth[k])
        out.append(Drawn(top_view(scene), bool(doubted[k]), (a, b)))
    return out


def plot_top_view(
    fig: Figure,
    trials: pd.DataFrame,
    views: pd.DataFrame,
    title: str,
    palette: TrialColours | None = None,
    *,
    include_warned: bool = False,
) -> None:
    """Looking along the normal of the method's plane (the ground's: down the y axis, x-z):
    each ok trial's typed camera centres, what each view measured (the method's
    :attr:`~twopose.methods.specs.MethodSpec.view_segment`), the estimate and the truth (on top of
    the rays), each trial in its colour (``palette``: the session's, the same in its other
    figures). The axes are the plane's in-plane axes, framed by the trials the statistics
    use; a left-out (warned) trial is dashed, and its estimate beyond the frame is drawn at
    the edge with its value."""
    drawn = top_views(trials, views)
    units = str(trials["units"].iloc[0]) if len(trials) else "session units"
    spec = spec_of(str(trials["method"].iloc[0]) if len(trials) else Method.POINT)
    palette = palette or TrialColours.of([d.view.trial for d in drawn])
    ax = fig.add_subplot()
    _draw(ax, drawn, palette)
    across, up = spec.seen_on.titles  # the ground's "x" and "z, depth"
    style(ax, title, f"{across} ({units})", f"{up} ({units})")
    used = [d for d in drawn if include_warned or not d.warned]
    right = 0.2 if palette.named else KEY_MARGIN
    box = (float(fig.get_size_inches()[0]) - _LEFT - right, _BOX_HEIGHT)
    frame(ax, _framed_points(used), pad=0.1, least=1.0)
    equal_scales(ax, box)  # the frame widened, never cut, to one scale on both axes
    left_out = [
        (d.view.trial, d.view.estimate)
        for d in drawn
        if d.warned and not include_warned and d.view.estimate is not None
    ]
    xz = np.array([e for _, e in left_out], dtype=np.float64).reshape(-1, 2)
    beyond = mark_beyond(ax, xz, palette.colours(t for t, _ in left_out))
    listed = [
        f"{palette.unit.noun} {t} ({x:+.3g}, {z:+.3g} {units})"
        for (t, _), (x, z), b in zip(left_out, xz, beyond, strict=True)
        if b
    ]
    handles = [
        key("camera (typed)", marker="^", color="0.3"),
        key(spec.view_segment, color="0.3", lw=0.8, linestyle="-"),
        key("estimate", marker="x", color="0.3"),
        key(spec.truth_name, marker="o", mfc="white", mec="k", mew=1.2),
    ]
    if any(d.warned for d in drawn):
        fate = "included" if include_warned else "left out"
        said = f"warned {palette.unit.noun} ({fate})"
        handles.append(key(said, color="0.3", lw=0.8, linestyle="--"))
    handles += palette.legend(marker="s", ms=6) if palette.named else []
    bottom = legend_below(fig, handles, 2, beyond_note(listed))
    fig.set_size_inches(fig.get_size_inches()[0], _TOP + box[1] + 0.5 + bottom)
    layout(fig, left=_LEFT, right=right, top=_TOP, bottom=0.5 + bottom)
    if not palette.named:
        palette.colour_key(fig, ax)


_LEFT, _TOP = 0.75, 0.35  # margins (inches)
_BOX_HEIGHT = 3.4  # the axes' height (inches): the figure grows with its legend


def _framed_points(drawn: list[Drawn]) -> np.ndarray:
    """What sets the scale: the cameras, estimates and truths of ``drawn``."""
    points: list[object] = []
    for d in drawn:
        points += list(d.view.cameras)
        points += [d.truth] + ([d.view.estimate] if d.view.estimate is not None else [])
    return np.array(points, dtype=np.float64).reshape(-1, 2)


def _draw(ax: Axes, drawn: list[Drawn], palette: TrialColours) -> None:
    """One collection per kind: segments, cameras, estimates, then the truths on top."""
    segments, seg_colour, seg_style = [], [], []
    cameras, cam_colour = [], []
    for d in drawn:
        colour = palette.colour(d.view.trial)
        for _kind, a, b in d.view.segments:
            segments.append([a, b])
            seg_colour.append(colour)
            seg_style.append((0, (4, 2)) if d.warned else "solid")
        cameras += list(d.view.cameras)
        cam_colour += [colour] * len(d.view.cameras)
    if segments:
        ax.add_collection(
            LineCollection(
                segments, colors=seg_colour, linestyles=seg_style, linewidths=0.8, alpha=0.8
            ),
            autolim=False,
        )
    if cameras:
        xy = np.array(cameras)
        ax.scatter(xy[:, 0], xy[:, 1], marker="^", s=25, c=cam_colour, zorder=3)
    if not drawn:
        return
    colours = palette.colours(d.view.trial for d in drawn)
    nowhere = (np.nan, np.nan)
    est = np.array([d.view.estimate if d.view.estimate is not None else nowhere for d in drawn])
    ax.scatter(est[:, 0], est[:, 1], marker="x", s=45, c=colours, zorder=4)
    truth = np.array([d.truth for d in drawn])
    ax.scatter(truth[:, 0], truth[:, 1], marker="o", s=42, facecolors="white",
               edgecolors="k", linewidths=1.2, zorder=6)  # fmt: skip
    ax.scatter(truth[:, 0], truth[:, 1], marker="o", s=10, c=colours, zorder=7)
