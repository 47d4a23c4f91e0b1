"""A session's errors in its method's plane (matplotlib): the scatter of estimate minus
truth with each trial's 95% ellipse (the thesis' Figures 11 and 21) and the running
averages' errors against the frames averaged (Figures 22-23), each in the plane's two
in-plane axes (:mod:`analysis.report.plane_axes`: the ground's x and z, a wall's y and z).

Drawn by the rules of :mod:`analysis.report.figures.draw`: the trials the statistics use frame the
axes, a warned trial left out is drawn distinctly (hollow, dashed) and at the frame's edge
when beyond it, one colour per trial, one collection per kind.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection, LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from analysis.report.figures.style import (
    LABEL,
    TrialColours,
    beyond_note,
    frame,
    key,
    mark_beyond,
    style,
)
from analysis.report.plane_axes import covariances, plane_of, with_in_plane
from analysis.session.metrics import used_trials, warned
from analysis.tables.labels import table_units, unit_label
from analysis.tables.row_units import row_units_of
from twopose.methods.planes import ConstraintPlane
from twopose.uncertainty.propagate import CHI2_95
from twopose.values.units import Units

__all__ = ["error_ellipses", "plot_error_scatter", "plot_running_averages", "running_errors"]


def _errors(on: ConstraintPlane) -> list[str]:
    """The columns of the errors along the plane's two in-plane axes (``err_x, err_z``)."""
    return [f"err_{a}" for a in on.axis_names]


def error_ellipses(
    trials: pd.DataFrame,
    chi2: float = CHI2_95[2],
    colours: object = "C0",
    on: ConstraintPlane | None = None,
) -> EllipseCollection:
    """The in-plane marginal 95% ellipse of each trial's covariance (``on``: the plane of
    the trials' method, :func:`~analysis.report.plane_axes.plane_of`), centred on its error: the
    truth (the origin) lies inside about 95% of them when the uncertainty is honest."""
    on = on or plane_of(trials)
    trials = with_in_plane(trials, on)
    w, V = np.linalg.eigh(covariances(trials, on))
    angle = np.degrees(np.arctan2(V[:, 1, 1], V[:, 0, 1]))  # of the major axis
    size = 2.0 * np.sqrt(chi2 * np.clip(w, 0.0, None))
    return EllipseCollection(
        size[:, 1],
        size[:, 0],
        angle,
        units="xy",
        offsets=trials[_errors(on)].to_numpy(dtype=np.float64),
        offset_transform=None,
        facecolors="none",
        edgecolors=colours,
        linewidths=0.7,
        alpha=0.55,
    )


def _ellipse_bounds(
    trials: pd.DataFrame, on: ConstraintPlane, chi2: float = CHI2_95[2]
) -> np.ndarray:
    """[[a_min, b_min], [a_max, b_max]] covering every 95% ellipse and every point: an
    ellipse's half-extent along an axis is sqrt(chi2 * variance along it)."""
    C = covariances(trials, on)
    half = np.sqrt(chi2 * np.stack([C[:, 0, 0], C[:, 1, 1]], axis=1))
    centre = trials[_errors(on)].to_numpy(dtype=np.float64)
    finite = np.isfinite(centre).all(axis=1) & np.isfinite(half).all(axis=1)
    if not finite.any():
        return np.array([[-1.0, -1.0], [1.0, 1.0]])
    lo = (centre - half)[finite].min(axis=0)
    hi = (centre + half)[finite].max(axis=0)
    return np.array([np.minimum(lo, 0.0), np.maximum(hi, 0.0)])  # the truth is in view


def plot_error_scatter(
    ax: Axes,
    trials: pd.DataFrame,
    title: str,
    *,
    include_warned: bool = False,
    palette: TrialColours | None = None,
    units: Units | None = None,
) -> tuple[list[Line2D], str]:
    """Estimate minus truth in the plane of the trials' method (the ground's x and z: the
    thesis' Figures 11 and 21), ok trials, each in its trial's colour with its 95% error
    ellipse. The axes are framed by the trials the statistics use (their points and
    ellipses, and the truth at the origin); a warned trial left out is hollow, without its
    (degenerate) ellipse, and when it lies beyond the frame it is drawn at the edge with
    an arrowhead. Returns the legend's entries (the trials' own when ``palette`` names
    them) and the note that lists what lies beyond the frame."""
    on = plane_of(trials)
    a, b = _errors(on)
    ok = with_in_plane(used_trials(trials, include_warned=True, measured=True), on)
    palette = palette or TrialColours.of(ok["trial"], row_units_of(trials)[0])
    doubted = warned(ok)
    used, left_out = (ok, ok.head(0)) if include_warned else (ok[~doubted], ok[doubted])
    label = unit_label(table_units(trials) or units)
    ax.axhline(0, color="0.75", lw=0.8, zorder=0)
    ax.axvline(0, color="0.75", lw=0.8, zorder=0)
    handles = []
    spread = len(used) and f"sigma_{on.axis_names[0]}" in used
    if spread:
        ellipses = error_ellipses(used, colours=palette.colours(used["trial"]), on=on)
        ellipses.set_offset_transform(ax.transData)
        ax.add_collection(ellipses, autolim=False)
        handles.append(key("95% ellipses", color="0.3", lw=0.7, linestyle="-"))
    ax.scatter(used[a], used[b], s=20, c=palette.colours(used["trial"]), zorder=3)
    handles.append(key(f"{len(used)} trials used", marker="o", color="0.3", ms=5))
    if len(left_out):
        colours = palette.colours(left_out["trial"])
        ax.scatter(left_out[a], left_out[b], s=24, facecolors="none",
                   edgecolors=colours, zorder=3)  # fmt: skip
        handles.append(key(f"{len(left_out)} warned (left out)", marker="o", mfc="none", mec="0.3"))
    if len(used):
        ax.scatter([used[a].mean()], [used[b].mean()], marker="x", s=60,
                   color="k", zorder=4)  # fmt: skip
        handles.append(key("bias (mean error)", marker="x", color="k", ms=7))
    ax.scatter([0.0], [0.0], marker="+", s=90, color="k", linewidths=1.4, zorder=5)
    handles.append(key("truth (zero error)", marker="+", color="k", ms=9, mew=1.4))
    bounds = _ellipse_bounds(used, on) if spread else np.zeros((2, 2))
    frame(ax, np.vstack([bounds, used[[a, b]].to_numpy(dtype=np.float64)]),
          least=1e-3 if len(used) else 2.0)  # fmt: skip
    note = _mark_left_out(ax, left_out, [a, b], palette, label)
    names = on.axis_names
    style(ax, title, f"{names[0]} error ({label})", f"{names[1]} error ({label})")
    ax.xaxis.set_major_locator(MaxNLocator(nbins=5))  # tick labels that never touch
    return [*handles, *(palette.legend(marker="o", ms=5) if palette.named else [])], note


def _mark_left_out(
    ax: Axes, left_out: pd.DataFrame, columns: list[str], palette: TrialColours, label: str
) -> str:
    """Left-out trials beyond the frame: drawn at its edge, and listed with their value
    (the note returned)."""
    xy = left_out[columns].to_numpy(dtype=np.float64)
    beyond = mark_beyond(ax, xy, palette.colours(left_out["trial"]))
    return beyond_note(
        [
            f"{palette.unit.noun} {t} ({x:+.3g}, {y:+.3g} {label})"
            for t, (x, y), b in zip(left_out["trial"], xy, beyond, strict=True)
            if b
        ]
    )


def running_errors(averaging: pd.DataFrame, trials: pd.DataFrame) -> pd.DataFrame:
    """The running averages of the ok trials as errors along the plane's axes of their
    method: ``trial, n_frames, err_<a>, err_<b>`` (the ground's ``err_x, err_z``:
    estimate minus truth, session units) and ``warned``."""
    on = plane_of(trials)
    ok = used_trials(trials, include_warned=True).drop_duplicates("trial", keep="last")
    truth = with_in_plane(ok, on, ("gt_",)).set_index("trial")
    picked = with_in_plane(averaging[averaging["trial"].isin(truth.index)], on, ("",))
    gt = truth.reindex(picked["trial"])
    errors = {
        f"err_{a}": picked[a].to_numpy(dtype=np.float64) - gt[f"gt_{a}"].to_numpy(np.float64)
        for a in on.axis_names
    }
    return pd.DataFrame(
        {
            "trial": picked["trial"].to_numpy(),
            "n_frames": picked["n_frames"].to_numpy(),
            **errors,
            "warned": warned(gt).to_numpy(),
        }
    )


def _running_axes(fig: Figure, label: str, names: tuple[str, str]) -> tuple[Axes, Axes]:
    """The running averages' two panels, one per in-plane axis' error, on one y scale."""
    ax_a, ax_b = fig.subplots(1, 2, sharey=True, squeeze=False)[0]
    for ax, axis in zip((ax_a, ax_b), names, strict=True):
        ax.axhline(0.0, color="0.6", lw=0.8)
        style(ax, f"{axis} error", "", "")
    ax_a.set_ylabel(f"error of the running average ({label})", fontsize=LABEL)
    return ax_a, ax_b


def plot_running_averages(
    fig: Figure,
    errors: pd.DataFrame,
    units: Units | None,
    palette: TrialColours | None = None,
    *,
    include_warned: bool = False,
) -> tuple[list[Line2D], str]:
    """The error along each in-plane axis (``errors``' two ``err_*`` columns, from
    :func:`running_errors`: the ground's x and z) of each trial's running average against
    the frames averaged (Figures 22-23, as errors), one line per trial in its colour (a
    warned one dashed), one collection per panel, the two panels on one y scale framed by
    the trials the statistics use; a left-out trial's line beyond the frame ends at its
    edge with an arrowhead. Returns the legend's entries and the note listing what lies
    beyond."""
    first, second = (c.removeprefix("err_") for c in errors.columns if c.startswith("err_"))
    names = (first, second)
    palette = palette or TrialColours.of(errors["trial"])
    label = unit_label(units)
    axes = _running_axes(fig, label, names)
    by_trial = list(errors.groupby("trial", sort=True))
    colours = palette.colours(t for t, _ in by_trial)
    doubt = [bool(g["warned"].any()) for _, g in by_trial]
    styles = [(0, (4, 2)) if d else "solid" for d in doubt]
    used = errors if include_warned else errors[~errors["warned"].astype(bool)]
    spread = used[[f"err_{a}" for a in names]].to_numpy(dtype=np.float64).ravel()
    top = float(errors["n_frames"].max()) if len(errors) else 1.0
    for ax, axis in zip(axes, names, strict=True):
        lines = [g[["n_frames", f"err_{axis}"]].to_numpy(dtype=np.float64) for _, g in by_trial]
        ax.add_collection(
            LineCollection(lines, colors=colours, linestyles=styles, linewidths=1.0),
            autolim=False,
        )
        points = np.column_stack([np.full(len(spread) + 1, 1.0), [*spread, 0.0]])
        frame(ax, np.vstack([points, [[top, 0.0]]]), pad=0.06, least=1e-6)
        ax.set_xlim(0.0, top * 1.04)
    listed: list[str] = []
    if not include_warned:  # a left-out trial's last running average, beyond the frame
        last = [(t, g.iloc[-1]) for (t, g), d in zip(by_trial, doubt, strict=True) if d]
        for ax, axis in zip(axes, names, strict=True):
            xy = np.array([[r["n_frames"], r[f"err_{axis}"]] for _, r in last]).reshape(-1, 2)
            beyond = mark_beyond(ax, xy, palette.colours(t for t, _ in last))
            listed += [
                f"{palette.unit.noun} {t} {axis} {r[f'err_{axis}']:+.3g} {label}"
                for (t, r), b in zip(last, beyond, strict=True)
                if b
            ]
    handles = palette.legend(linestyle="-") if palette.named else []
    if any(doubt):
        fate = "included" if include_warned else "left out"
        handles.append(key(f"warned {palette.unit.noun} ({fate})", color="0.3", linestyle="--"))
    handles.append(key("truth (zero error)", color="0.6", linestyle="-"))
    return handles, beyond_note(listed)
