"""The analysis job: sessions in, per-trial error, bias and averaging tables out.

``analyse_session`` replays one file through detection and the solver; ``run`` does it for
any mix of files and folders (in worker processes or on a Dask cluster), gathers the tables
in input order (so results never depend on ``jobs``), and optionally writes them with the
figures and the report. Everything the CLI's ``run`` does is this one call.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import multiprocessing
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from analysis.detect import (
    CombineMethod,
    Detection,
    DotParams,
    GloveParams,
    PoseMeasurement,
    combine_frames,
    detect,
)
from analysis.metrics import (
    LINE_COLUMNS,
    MARGIN_COLUMNS,
    OPTIMAL_COLUMNS,
    TRIAL_COLUMNS,
    UNCERTAINTY_COLUMNS,
    WEIGHTED_COLUMNS,
    line_errors,
    summarize,
    uncertainty_columns,
)
from analysis.replay import TrialRecord, find_sessions, iter_trials
from analysis.results_mcap import ResultsWriter, TrialScene
from analysis.solve import (
    DEFAULT_MIN_CONDITIONING,
    image_lines,
    projection_matrices,
    triangulate_ground,
    triangulate_lines,
    triangulate_points,
)
from analysis.uncertainty import (
    INPUTS_PER_VIEW,
    dominant_input,
    frame_scatter,
    measurement_covariance,
    pooled_scatter,
    propagate,
)
from recorder.camera import rotation_from_angles_deg
from recorder.errors import SessionFormatError, TwoposeError
from recorder.session import GroundTruth, SessionReader

__all__ = ["AnalysisOptions", "RunResult", "SessionResult", "analyse_session", "run"]

F64 = NDArray[np.float64]

FRAME_COLUMNS = [
    "session",
    "trial",
    "pose",
    "camera",
    "frame",
    "log_time_ns",
    "found",
    "col",
    "row",
    "theta_deg",
    "area_px",
    "eccentricity",
    "pi_estimate",
    "n_blobs",
    "n_candidates",
    "reason",
]
AVERAGING_COLUMNS = ["session", "trial", "n_frames", "x", "y", "z", "err"]
#: One row per used pose: its typed camera centre, combined measurement and the unit ray
#: through the measured pixel, grid frame (``views.csv``; the top-view plots).
VIEW_COLUMNS = [
    "session",
    "trial",
    "pose",
    "t_x",
    "t_y",
    "t_z",
    "col",
    "row",
    "theta_deg",
    "ray_x",
    "ray_y",
    "ray_z",
]


@dataclass(frozen=True)
class AnalysisOptions:
    """How frames become measurements and measurements become estimates."""

    combine: CombineMethod = "mean"
    glove: GloveParams = field(default_factory=GloveParams)
    dot: DotParams = field(default_factory=DotParams)
    min_conditioning: float = DEFAULT_MIN_CONDITIONING
    # Degeneracy margins: an ok trial under one of these gets a warning (degrees).
    min_parallax_deg: float = 1.0  # ray parallax, points
    min_plane_angle_deg: float = 5.0  # between back-projected planes, lines and method 2
    min_ground_angle_deg: float = 10.0  # between the line and the ground, method 2


@dataclass(frozen=True)
class SessionResult:
    """One session's tables and what the report says about it."""

    session: str
    metadata: dict[str, str]
    frames: pd.DataFrame
    trials: pd.DataFrame
    averaging: pd.DataFrame
    images: dict[str, bytes] = field(default_factory=dict)  # PNGs by figure kind, if asked
    views: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=VIEW_COLUMNS))


@dataclass(frozen=True)
class _TrialKey:
    trial: int
    ground_truth: GroundTruth | None
    last_ns: int  # the trial's last frame (0 when it has none)


@dataclass
class _View:
    """One usable pose of a trial: camera, pose and its per-frame detections."""

    pose: int
    intrinsics: F64  # (4,) fx, fy, cx, cy
    width_height: tuple[int, int]
    t_grid: F64  # (3,) typed camera centre
    r_deg: F64  # (3,) typed angles, R_cam_to_grid = Rx Ry Rz
    t_sigma: float  # 1-sigma of each typed translation component (session units)
    r_sigma_deg: float  # 1-sigma of each typed angle
    centroids: F64  # (K, 2)
    thetas: F64  # (K,)
    found: NDArray[np.bool_]  # (K,)


def _detect_trial(
    record: TrialRecord,
    session: str,
    target: str,
    options: AnalysisOptions,
    rows: list[dict[str, Any]],
    results: ResultsWriter | None = None,
) -> list[_View]:
    views: list[_View] = []
    params = options.dot if target == "dot" else options.glove
    for pc in record.poses:
        dets: list[Detection] = []
        if results is not None and pc.frames:
            results.add_pose(pc.entry, pc.frames[0].log_time_ns)
        for j, frame in enumerate(pc.frames):
            try:
                det = detect(frame.decode(), target, params)
            except SessionFormatError as err:  # one undecodable frame is a rejected frame
                det = Detection(False, reason=str(err))
            dets.append(det)
            if results is not None:
                label = f"trial {record.trial} pose {pc.entry.pose} frame {j}"
                results.add_frame(frame, det, label)
            rows.append(
                {
                    "session": session,
                    "trial": record.trial,
                    "pose": pc.entry.pose,
                    "camera": pc.entry.camera_id,
                    "frame": j,
                    "log_time_ns": frame.log_time_ns,
                    "found": det.found,
                    "col": det.centroid_px[0],
                    "row": det.centroid_px[1],
                    "theta_deg": det.theta_deg,
                    "area_px": det.area_px,
                    "eccentricity": det.eccentricity,
                    "pi_estimate": det.pi_estimate,
                    "n_blobs": det.n_blobs,
                    "n_candidates": det.n_candidates,
                    "reason": det.reason,
                }
            )
        if not pc.complete:
            continue
        i = pc.camera.intrinsics
        views.append(
            _View(
                pc.entry.pose,
                np.array([i.fx, i.fy, i.cx, i.cy]),
                (i.width, i.height),
                np.array(pc.entry.t_grid),
                np.array(pc.entry.r_deg),
                pc.entry.translation_resolution,
                pc.entry.rotation_resolution_deg,
                np.array([d.centroid_px for d in dets], dtype=np.float64).reshape(-1, 2),
                np.array([d.theta_deg for d in dets], dtype=np.float64),
                np.array([d.found for d in dets], dtype=bool),
            )
        )
    return views


@dataclass(frozen=True)
class _Batch:
    """Rows of N >= 2 pose measurements as arrays, padded to the longest row."""

    inputs: F64  # (T, N, 9) in the uncertainty.INPUTS_PER_VIEW layout
    intrinsics: F64  # (T, N, 4); padding views get (1, 1, 0, 0): P = [I | 0]
    valid: NDArray[np.bool_]  # (T, N)

    def P(self, inputs: F64 | None = None) -> F64:
        """Projection matrices (T, N, 3, 4) of these (or perturbed) inputs."""
        x = self.inputs if inputs is None else inputs
        R = rotation_from_angles_deg(x[..., 6:9])
        return projection_matrices(self.intrinsics, R, x[..., 3:6])


def _batch(measurements: list[list[PoseMeasurement]], views: list[list[_View]]) -> _Batch:
    T = len(measurements)
    N = max(len(row) for row in measurements)
    x = np.zeros((T, N, len(INPUTS_PER_VIEW)))
    x[..., :3] = np.nan
    intr = np.tile([1.0, 1.0, 0.0, 0.0], (T, N, 1))
    valid = np.zeros((T, N), dtype=bool)
    for i, (row, row_views) in enumerate(zip(measurements, views, strict=True)):
        for j, (m, v) in enumerate(zip(row, row_views, strict=True)):
            x[i, j] = [*m.centroid_px, m.theta_deg, *v.t_grid, *v.r_deg]
            intr[i, j], valid[i, j] = v.intrinsics, True
    return _Batch(x, intr, valid)


@dataclass(frozen=True)
class _Solved:
    point: F64  # (T, 3)
    direction: F64 | None  # (T, 3), lines only
    optimal: F64 | None  # (T, 3), points only: the reprojection-optimal estimate
    conditioning: F64
    status: NDArray[np.str_]
    reason: NDArray[np.str_]
    margins: dict[str, F64] = field(default_factory=dict)  # degrees, by column name


def _solve(
    method: str, batch: _Batch, ground: tuple[F64, float] | None, options: AnalysisOptions
) -> _Solved:
    """Batch-solve rows of N >= 2 pose measurements with every estimator."""
    px, th, valid, P = batch.inputs[..., :2], batch.inputs[..., 2], batch.valid, batch.P()
    mc = options.min_conditioning
    if method == "point":
        s = triangulate_points(px, P, valid=valid, min_conditioning=mc)
        o = triangulate_points(px, P, valid=valid, estimator="optimal", min_conditioning=mc)
        margins = {"parallax_deg": _degrees(s.conditioning)}
        return _Solved(
            s.point_grid, None, o.point_grid, s.conditioning, s.status, s.reason, margins
        )
    lines = image_lines(px, th)
    ls = triangulate_lines(lines, P, valid=valid, min_conditioning=mc)
    margins = {"plane_angle_deg": _degrees(ls.conditioning)}
    if method == "line":
        return _Solved(
            ls.point_grid, ls.direction_grid, None, ls.conditioning, ls.status, ls.reason, margins
        )
    assert ground is not None
    g = triangulate_ground(lines, P, ground[0], ground[1], valid=valid, min_conditioning=mc)
    n3 = ground[0] / np.linalg.norm(ground[0])
    margins["line_ground_angle_deg"] = _degrees(np.abs(ls.direction_grid @ n3))
    return _Solved(g.point_grid, None, None, g.conditioning, g.status, g.reason, margins)


def _thesis_estimate(
    method: str,
    batch: _Batch,
    ground: tuple[F64, float] | None,
    options: AnalysisOptions,
    reference: F64,
) -> Callable[[F64], F64]:
    """The thesis' estimate as a function of the (perturbed) inputs, for propagation.

    Lines report their point nearest ``reference`` (T, 3), held fixed.
    """
    mc, valid = options.min_conditioning, batch.valid

    def estimate(x: F64) -> F64:
        P = batch.P(x)
        if method == "point":
            return triangulate_points(x[..., :2], P, valid=valid, min_conditioning=mc).point_grid
        lines = image_lines(x[..., :2], x[..., 2])
        if method == "ground":
            assert ground is not None
            return triangulate_ground(
                lines, P, ground[0], ground[1], valid=valid, min_conditioning=mc
            ).point_grid
        ls = triangulate_lines(lines, P, valid=valid, min_conditioning=mc)
        return _nearest_on_line(ls.point_grid, ls.direction_grid, reference)

    return estimate


def _nearest_on_line(point: F64, direction: F64, reference: F64) -> F64:
    s = np.einsum("ti,ti->t", reference - point, direction)
    return np.asarray(point + s[:, None] * direction)


def _degrees(sine: F64) -> F64:
    """An angle in degrees from its sine (NaN stays NaN)."""
    with np.errstate(invalid="ignore"):
        return np.asarray(np.degrees(np.arcsin(np.clip(sine, 0.0, 1.0))))


def _warnings(
    status: NDArray[np.str_], margins: dict[str, F64], options: AnalysisOptions
) -> list[str]:
    """Per trial, the margins under their thresholds (empty when none, or not ok)."""
    limits = {
        "parallax_deg": ("ray parallax", options.min_parallax_deg),
        "plane_angle_deg": ("plane angle", options.min_plane_angle_deg),
        "line_ground_angle_deg": ("line-ground angle", options.min_ground_angle_deg),
    }
    out = []
    for i in range(len(status)):
        notes = [
            f"{label} {margins[key][i]:.2f} deg < {limit:g}"
            for key, (label, limit) in limits.items()
            if key in margins and status[i] == "ok" and margins[key][i] < limit
        ]
        out.append("; ".join(notes))
    return out


def analyse_session(
    path: str | Path,
    options: AnalysisOptions | None = None,
    *,
    render_images: bool = False,
    results_path: str | Path | None = None,
) -> SessionResult:
    """Replay one session through detection and the solver.

    Trials with fewer than two complete captures are ``incomplete``; a pose where no frame
    was detected makes its trial ``no_detection``. Every complete pose of a trial is used
    (N >= 2 views); point trials also get the reprojection-optimal estimate (``*_optimal``).

    With ``results_path``, also writes the session's results.mcap there (images with the
    detections drawn on them, and each trial's geometry as a 3-D scene; see
    :mod:`analysis.results_mcap`); a session that fails leaves no half-written file.

    Raises
    ------
    SessionFormatError
        The file is not a readable session (the batch lists it and goes on).
    """
    with contextlib.ExitStack() as stack:
        results = None
        if results_path is not None:
            results = stack.enter_context(_results_writer(Path(results_path), path))
        return _analyse(path, options or AnalysisOptions(), render_images, results)


@contextlib.contextmanager
def _results_writer(out: Path, session: str | Path) -> Iterator[ResultsWriter]:
    with SessionReader(session) as reader:
        cameras, ground = list(reader.cameras.values()), reader.ground
    writer = ResultsWriter(out, cameras, ground)
    try:
        yield writer
    except BaseException:
        writer.close()
        out.unlink(missing_ok=True)
        raise
    writer.close()


def _analyse(
    path: str | Path,
    options: AnalysisOptions,
    render_images: bool,
    results: ResultsWriter | None,
) -> SessionResult:
    keep_frame_buffers()
    session = str(path)
    frame_rows: list[dict[str, Any]] = []
    with SessionReader(path) as reader:
        info = reader.info
        method = info.method
        ground = None
        if method == "ground":
            if reader.ground is None:
                raise SessionFormatError(
                    f"{path}: a ground session without a /twopose/ground plane"
                )
            ground = (np.array(reader.ground.normal_grid), reader.ground.offset)
        target = "dot" if method == "point" else "glove"
        # Keep only what the tables need; a trial's frames are dropped once detected, so
        # memory does not grow with session length.
        records: list[tuple[_TrialKey, list[_View]]] = []
        for record in iter_trials(reader):
            views = _detect_trial(record, session, target, options, frame_rows, results)
            last = max((pc.frames[-1].log_time_ns for pc in record.poses if pc.frames), default=0)
            records.append((_TrialKey(record.trial, record.ground_truth, last), views))
        metadata = {
            "method": method,
            "units": info.units,
            "operator": info.operator,
            "notes": info.notes,
            "cameras": ", ".join(
                f"{c.camera_id} (fx={c.intrinsics.fx:g}, fy={c.intrinsics.fy:g}, "
                f"{c.intrinsics.width}x{c.intrinsics.height})"
                for c in reader.cameras.values()
            ),
            "format_version": reader.format_version,
            "simulated": str(info.simulated),
        }

    trial_ids = [r.trial for r, _ in records]
    T = len(records)
    used = [views for _, views in records]  # every complete pose: N >= 2 views
    complete = np.array([len(v) >= 2 for v in used], dtype=bool)
    measurements = [
        [combine_frames(v.centroids, v.thetas, v.found, options.combine) for v in views]
        if ok
        else []
        for views, ok in zip(used, complete, strict=True)
    ]
    detected = np.array(
        [ok and all(m.found for m in ms) for ms, ok in zip(measurements, complete, strict=True)]
    )
    solvable = np.flatnonzero(detected)
    point = np.full((T, 3), np.nan)
    direction = np.full((T, 3), np.nan)
    optimal = np.full((T, 3), np.nan)
    conditioning = np.full(T, np.nan)
    margin_names = {
        "point": ["parallax_deg"],
        "line": ["plane_angle_deg"],
        "ground": ["plane_angle_deg", "line_ground_angle_deg"],
    }[method]
    margins = {name: np.full(T, np.nan) for name in margin_names}
    status = np.where(complete, "no_detection", "incomplete").astype("<U12")
    reason = np.where(
        complete, "no frame of a pose was detected", "fewer than two complete captures"
    ).astype("<U64")
    gt = _ground_truth(records, method)
    weighted_line = np.full((T, 2, 3), np.nan)  # point, direction
    cov = np.full((T, 3, 3), np.nan)
    dominant, dominant_share = np.full(T, "", dtype=object), np.full(T, np.nan)
    if solvable.size:
        batch = _batch([measurements[i] for i in solvable], [used[i] for i in solvable])
        solved = _solve(method, batch, ground, options)
        # Lines are reported at their point nearest the true segment's midpoint (or, with
        # no truth, nearest the last camera); that reference is held fixed in propagation.
        mid = gt[solvable].mean(axis=1)
        reference = np.where(np.isfinite(mid), mid, solved.point)
        # Each pose's frame scatter, once (incomplete trials are not combined: none).
        scatters = [
            [_scatter(v, m) for v, m in zip(views, ms, strict=False)]
            for views, ms in zip(used, measurements, strict=True)
        ]
        pooled = pooled_scatter([s for row in scatters for s in row])
        input_cov = _input_covariance(
            [measurements[i] for i in solvable],
            [used[i] for i in solvable],
            [scatters[i] for i in solvable],
            pooled,
            batch,
            median=options.combine == "median",
        )
        propagated = propagate(
            _thesis_estimate(method, batch, ground, options, reference), batch.inputs, input_cov
        )
        if method == "line":  # the weighted/robust fit beside the thesis' one
            mc = options.min_conditioning
            weighted = triangulate_lines(
                image_lines(batch.inputs[..., :2], batch.inputs[..., 2]),
                batch.P(),
                valid=batch.valid,
                estimator="weighted",
                sigma_px=_across_line_sigma_px(batch.inputs[..., 2], input_cov),
                sigma_pose=np.stack(
                    [
                        np.sqrt(input_cov[..., 3, 3]),
                        np.deg2rad(np.sqrt(input_cov[..., 6, 6])),
                    ],
                    axis=-1,
                ),
                min_conditioning=mc,
            )
            weighted_line[solvable, 0] = weighted.point_grid
            weighted_line[solvable, 1] = weighted.direction_grid
        ok = solved.status == "ok"
        C = propagated.cov_grid
        if solved.direction is not None:
            # A line's reported point moves only across the line to first order (its error
            # is perpendicular by construction): keep the covariance of that offset.
            across = np.eye(3) - np.einsum("ti,tj->tij", solved.direction, solved.direction)
            C = across @ C @ across
        cov[solvable[ok]] = C[ok]
        names, share = dominant_input(propagated.variance_by_group)
        dominant[solvable[ok]] = np.array(names, dtype=object)[ok]
        dominant_share[solvable[ok]] = share[ok]
        point[solvable], conditioning[solvable] = solved.point, solved.conditioning
        status[solvable], reason[solvable] = solved.status, solved.reason
        if solved.direction is not None:
            direction[solvable] = solved.direction
        if solved.optimal is not None:
            optimal[solvable] = solved.optimal
        for name, values in solved.margins.items():
            margins[name][solvable] = values
    n_views = np.array([len(v) if ok else 0 for v, ok in zip(used, complete, strict=True)])
    view_table = _view_table(session, trial_ids, used, measurements)

    trials = _trial_table(
        session,
        method,
        info.units,
        trial_ids,
        status,
        reason,
        conditioning,
        point,
        direction,
        gt,
        n_views,
        optimal,
    )
    for name, values in margins.items():
        trials[name] = values
    trials["warning"] = _warnings(status, margins, options)
    trials["baseline"] = [
        max(
            (np.linalg.norm(a.t_grid - b.t_grid) for a, b in itertools.combinations(v, 2)),
            default=np.nan,
        )
        for v in used
    ]
    if method == "line":
        with np.errstate(invalid="ignore"):
            est, mid, angle, dist = line_errors(
                weighted_line[:, 0], weighted_line[:, 1], gt[:, 0], gt[:, 1]
            )
        est = np.where(np.isfinite(mid), est, weighted_line[:, 0])
        for i, a in enumerate("xyz"):
            trials[f"{a}_weighted"] = est[:, i]
        trials["angle_err_weighted_deg"], trials["dist_err_weighted"] = angle, dist
    err = trials[["err_x", "err_y", "err_z"]].to_numpy(dtype=np.float64)
    for name, values in uncertainty_columns(err, cov).items():
        trials[name] = values
    trials["dominant_input"], trials["dominant_share"] = dominant, dominant_share
    trials["rejected_frames"] = [
        _rejected(ms, views) if ms else "" for ms, views in zip(measurements, used, strict=True)
    ]
    if results is not None:
        for i, ((key, views), ms) in enumerate(zip(records, measurements, strict=True)):
            if views:
                estimate = trials.loc[i, ["x", "y", "z"]].to_numpy(dtype=np.float64)
                line_dir = direction[i] if method == "line" else None
                scene = _trial_scene(
                    key.trial, method, str(status[i]), views, ms, estimate, line_dir, gt[i], cov[i]
                )
                results.add_trial(scene, key.last_ns)
    averaging = _averaging(session, method, records, used, detected, ground, gt, options)
    frames = pd.DataFrame(frame_rows, columns=FRAME_COLUMNS)
    images: dict[str, bytes] = {}
    if render_images:  # here, so that a batch renders its figures in parallel too
        from analysis.report import png_bytes, session_figures

        images = {
            k: png_bytes(f)
            for k, f in session_figures(session, trials, averaging, view_table).items()
        }
    return SessionResult(session, metadata, frames, trials, averaging, images, view_table)


def _scatter(view: _View, m: PoseMeasurement) -> tuple[F64, int]:
    used = view.found.copy()
    used[list(m.rejected)] = False
    return frame_scatter(view.centroids, view.thetas, used)


def _input_covariance(
    measurements: list[list[PoseMeasurement]],
    views: list[list[_View]],
    scatters: list[list[tuple[F64, int]]],
    pooled: F64,
    batch: _Batch,
    *,
    median: bool,
) -> F64:
    """(T, N, 9, 9): each view's pixel covariance from its frame scatter, and its typed
    pose's 1-sigma resolutions on the diagonal (padding views: zero)."""
    T, N, D = batch.inputs.shape
    C = np.zeros((T, N, D, D))
    for i, (row, row_views, row_scatter) in enumerate(
        zip(measurements, views, scatters, strict=True)
    ):
        for j, (m, v, (S, dof)) in enumerate(zip(row, row_views, row_scatter, strict=True)):
            C[i, j, :3, :3] = measurement_covariance(S, dof, pooled, m.n_used, median=median)
            C[i, j, 3:6, 3:6] = np.eye(3) * v.t_sigma**2
            C[i, j, 6:9, 6:9] = np.eye(3) * v.r_sigma_deg**2
    return C


def _across_line_sigma_px(theta_deg: F64, input_cov: F64) -> F64:
    """(T, N) 1-sigma pixel error across each view's image line, from its covariance."""
    t = np.deg2rad(theta_deg)
    n = np.stack([-np.sin(t), np.cos(t)], axis=-1)
    var = np.einsum("tni,tnij,tnj->tn", n, input_cov[..., :2, :2], n)
    return np.asarray(np.sqrt(np.where(np.isfinite(var) & (var > 0), var, 1.0)))


def _rejected(measurements: list[PoseMeasurement], views: list[_View]) -> str:
    """Frames dropped as outliers, per pose: ``"pose 2: 3, 4"`` (frame indices as in
    frames.csv; empty when none)."""
    return "; ".join(
        f"pose {v.pose}: {', '.join(str(i) for i in m.rejected)}"
        for m, v in zip(measurements, views, strict=True)
        if m.rejected
    )


def _view_table(
    session: str,
    trial_ids: Sequence[int],
    used: list[list[_View]],
    measurements: list[list[PoseMeasurement]],
) -> pd.DataFrame:
    rows = []
    for trial, views, ms in zip(trial_ids, used, measurements, strict=True):
        for v, m in zip(views, ms, strict=False):  # incomplete trials have no measurements
            fx, fy, cx, cy = v.intrinsics
            cam = np.array([(m.centroid_px[0] - cx) / fx, (m.centroid_px[1] - cy) / fy, 1.0])
            ray = rotation_from_angles_deg(v.r_deg) @ cam
            ray /= np.linalg.norm(ray)
            rows.append(
                {
                    "session": session,
                    "trial": trial,
                    "pose": v.pose,
                    **{f"t_{a}": v.t_grid[i] for i, a in enumerate("xyz")},
                    "col": m.centroid_px[0],
                    "row": m.centroid_px[1],
                    "theta_deg": m.theta_deg,
                    **{f"ray_{a}": ray[i] for i, a in enumerate("xyz")},
                }
            )
    return pd.DataFrame(rows, columns=VIEW_COLUMNS)


def _trial_scene(
    trial: int,
    method: str,
    status: str,
    views: list[_View],
    measurements: list[PoseMeasurement],
    estimate: F64,
    direction: F64 | None,
    truth: F64,
    cov: F64,
) -> TrialScene:
    """What results.mcap draws for a trial (measurements NaN where a pose had none)."""
    n = len(views)
    px = np.full((n, 2), np.nan)
    theta = np.full(n, np.nan)
    for j, m in enumerate(measurements):
        px[j], theta[j] = m.centroid_px, m.theta_deg
    return TrialScene(
        trial=trial,
        method=method,
        status=status,
        intrinsics=np.array([v.intrinsics for v in views]),
        width_height=np.array([v.width_height for v in views], dtype=np.float64),
        R_cam_to_grid=rotation_from_angles_deg(np.array([v.r_deg for v in views])),
        t_grid=np.array([v.t_grid for v in views]),
        px=px,
        theta_deg=theta,
        estimate=estimate,
        direction=direction,
        truth=truth,
        cov=cov,
    )


def _ground_truth(records: list[tuple[_TrialKey, list[_View]]], method: str) -> F64:
    """(T, 2, 3) truth per trial: the point twice, or the two line points; NaN when missing."""
    gt = np.full((len(records), 2, 3), np.nan)
    for i, (record, _) in enumerate(records):
        if record.ground_truth is not None:
            pts = np.array(record.ground_truth.points_grid)
            gt[i] = pts if len(pts) == 2 else np.stack([pts[0], pts[0]])
    return gt


def _trial_table(
    session: str,
    method: str,
    units: str,
    trial_ids: Sequence[int],
    status: NDArray[np.str_],
    reason: NDArray[np.str_],
    conditioning: F64,
    point: F64,
    direction: F64,
    gt: F64,
    n_views: NDArray[np.int_],
    optimal: F64,
) -> pd.DataFrame:
    T = len(trial_ids)
    extra: dict[str, Any] = {}
    if method == "line":
        with np.errstate(invalid="ignore"):
            est, truth, angle, dist = line_errors(point, direction, gt[:, 0], gt[:, 1])
        est = np.where(np.isfinite(truth), est, point)  # no truth: nearest the last camera
        extra = {"dir_x": direction[:, 0], "dir_y": direction[:, 1], "dir_z": direction[:, 2]}
        extra |= {"angle_err_deg": angle, "dist_err": dist}
    else:
        est, truth = point, gt[:, 0]
    if method == "point":  # the estimators side by side
        opt_err = optimal - truth
        extra = {
            "x_optimal": optimal[:, 0],
            "y_optimal": optimal[:, 1],
            "z_optimal": optimal[:, 2],
            "err_optimal": np.linalg.norm(opt_err, axis=1),
        }
    err = est - truth
    table = pd.DataFrame(
        {
            "session": [session] * T,
            "trial": list(trial_ids),
            "method": [method] * T,
            "units": [units] * T,
            "status": status,
            "reason": reason,
            "n_views": n_views,
            "conditioning": conditioning,
            "x": est[:, 0],
            "y": est[:, 1],
            "z": est[:, 2],
            "gt_x": truth[:, 0],
            "gt_y": truth[:, 1],
            "gt_z": truth[:, 2],
            "err_x": err[:, 0],
            "err_y": err[:, 1],
            "err_z": err[:, 2],
            "err": np.linalg.norm(err, axis=1),
            **extra,
        }
    )
    extra_columns = (
        LINE_COLUMNS if method == "line" else OPTIMAL_COLUMNS if method == "point" else []
    )
    return table[TRIAL_COLUMNS + extra_columns]


def _averaging(
    session: str,
    method: str,
    records: list[tuple[_TrialKey, list[_View]]],
    used: list[list[_View]],
    detected: NDArray[np.bool_],
    ground: tuple[F64, float] | None,
    gt: F64,
    options: AnalysisOptions,
) -> pd.DataFrame:
    """The estimate from the first 1..K frames of each pose (the thesis' Figures 22-23)."""
    rows_m: list[list[PoseMeasurement]] = []
    rows_v: list[list[_View]] = []
    keys: list[tuple[int, int, int]] = []
    for i, ((record, _), views) in enumerate(zip(records, used, strict=True)):
        if not detected[i]:
            continue
        k_max = min(len(v.found) for v in views)
        for n in range(1, k_max + 1):
            ms = [
                combine_frames(v.centroids[:n], v.thetas[:n], v.found[:n], options.combine)
                for v in views
            ]
            if all(m.found for m in ms):
                rows_m.append(ms)
                rows_v.append(views)
                keys.append((i, record.trial, n))
    if not keys:
        return pd.DataFrame(columns=AVERAGING_COLUMNS)
    solved = _solve(method, _batch(rows_m, rows_v), ground, options)
    p, d = solved.point, solved.direction
    idx = np.array([k[0] for k in keys])
    if d is not None:
        with np.errstate(invalid="ignore"):
            p, mid, _, _ = line_errors(p, d, gt[idx, 0], gt[idx, 1])
        truth = mid
    else:
        truth = gt[idx, 0]
    return pd.DataFrame(
        {
            "session": session,
            "trial": [k[1] for k in keys],
            "n_frames": [k[2] for k in keys],
            "x": p[:, 0],
            "y": p[:, 1],
            "z": p[:, 2],
            "err": np.linalg.norm(p - truth, axis=1),
        },
        columns=AVERAGING_COLUMNS,
    )


# --------------------------------------------------------------------------- the batch


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced (tables as DataFrames, figures as matplotlib Figures)."""

    trials: pd.DataFrame
    summary: pd.DataFrame
    averaging: pd.DataFrame
    frames: pd.DataFrame
    errors: pd.DataFrame
    sessions: tuple[SessionResult, ...]
    views: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=VIEW_COLUMNS))

    @property
    def failed(self) -> bool:
        return not self.errors.empty

    @functools.cached_property
    def figures(self) -> dict[str, Any]:
        """Named matplotlib Figures of the run (built on first use, for notebooks)."""
        from analysis.report import make_figures

        return make_figures(self)


_CLAIMS: Any = None  # in worker processes: the shared claim flags of the batch


def _worker_init(claims: Any) -> None:
    """One OpenCV thread per worker: the processes already fill the cores."""
    import cv2

    global _CLAIMS
    _CLAIMS = claims
    cv2.setNumThreads(1)
    keep_frame_buffers()


def _claim(claims: Any, index: int) -> bool:
    """Take session ``index`` for this process unless another already did."""
    with claims.get_lock():
        if claims[index]:
            return False
        claims[index] = 1
        return True


def _worker_task(
    index: int, path: str, options: AnalysisOptions, images: bool, results: str | None
) -> SessionResult | str | None:
    """A worker's session, or None when the main process took it first."""
    if not _claim(_CLAIMS, index):
        return None
    return _analyse_or_error(path, options, images, results)


def _run_processes(
    files: list[str],
    results: list[str | None],
    options: AnalysisOptions,
    images: bool,
    jobs: int,
    on_session_done: Callable[[str, bool], None] | None,
) -> list[SessionResult | str]:
    """``jobs`` processes: ``jobs - 1`` spawned workers take sessions from the front of the
    list, this (already warm) process from the back, each claiming a session through a
    shared flag; so no session runs twice and no core waits for a worker to start."""
    # Spawned, not forked: a fork after OpenCV has started its thread pool can deadlock.
    context = multiprocessing.get_context("spawn")
    claims = context.Array("b", len(files))
    outcomes: list[SessionResult | str | None] = [None] * len(files)

    def done(i: int, outcome: SessionResult | str) -> None:
        outcomes[i] = outcome
        if on_session_done:
            on_session_done(files[i], not isinstance(outcome, str))

    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # this process is one of the ``jobs``, like each worker
    try:
        with ProcessPoolExecutor(
            max_workers=jobs - 1, mp_context=context, initializer=_worker_init, initargs=(claims,)
        ) as pool:
            futures = [
                pool.submit(_worker_task, i, f, options, images, results[i])
                for i, f in enumerate(files)
            ]
            for i in reversed(range(len(files))):
                if not _claim(claims, i):
                    break  # the workers, going forward, have reached this one
                done(i, _analyse_or_error(files[i], options, images, results[i]))
            for i, fut in enumerate(futures):
                if outcomes[i] is not None:
                    continue
                try:
                    outcome = fut.result()
                except BrokenProcessPool as err:  # a worker died (killed, out of memory)
                    outcome = f"{files[i]}: the worker process analysing it died ({err})"
                if outcome is not None:
                    done(i, outcome)
    finally:
        cv2.setNumThreads(threads)
    missing = [f for f, o in zip(files, outcomes, strict=True) if o is None]
    assert not missing, f"sessions neither the workers nor this process analysed: {missing}"
    return [o for o in outcomes if o is not None]


_ALLOCATOR_TUNED = False


def keep_frame_buffers() -> None:
    """Let glibc reuse freed frame-sized buffers instead of returning them to the kernel.

    Every frame allocates a few 0.3-1 MB temporaries; above glibc's default 128 KiB mmap
    threshold each is a fresh mmap, page-faulted and zeroed, then unmapped. That costs
    memory bandwidth that two workers on two cores share: with the threshold at 32 MiB,
    a batch with ``jobs=2`` ran ~1.5x faster here. glibc only; a no-op elsewhere.
    """
    global _ALLOCATOR_TUNED
    if _ALLOCATOR_TUNED:
        return
    _ALLOCATOR_TUNED = True
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold = -1, -3  # from glibc's malloc.h
    mallopt(m_mmap_threshold, 32 * 1024 * 1024)
    mallopt(m_trim_threshold, 128 * 1024 * 1024)


def _analyse_or_error(
    path: str, options: AnalysisOptions, images: bool, results: str | None = None
) -> SessionResult | str:
    """Worker entry point: a result, or the reason this file failed (never raises)."""
    try:
        return analyse_session(path, options, render_images=images, results_path=results)
    except TwoposeError as err:
        return str(err)
    except Exception as err:  # one bad file never stops the batch; the reason is kept
        return f"{path}: unexpected {type(err).__name__}: {err}"


def run(
    paths: Sequence[str | Path],
    out_dir: str | Path | None = None,
    *,
    jobs: int = 1,
    dask_address: str | None = None,
    options: AnalysisOptions | None = None,
    on_session_done: Callable[[str, bool], None] | None = None,
    scene: bool = True,
) -> RunResult:
    """Analyse every session under ``paths`` and (with ``out_dir``) write the results.

    Parameters
    ----------
    paths : sequence of path-like
        Session files and folders (searched recursively for ``*.mcap``).
    out_dir : path-like, optional
        Where to write ``trials.csv``, ``summary.csv``, ``averaging.csv``, ``frames.csv``,
        ``errors.csv``, the figures and ``report.html``, and (with ``scene``) one
        ``results_<index>_<session>.mcap`` per session for Foxglove
        (:mod:`analysis.results_mcap`).
    jobs : int
        Worker processes; results are identical whatever the number.
    dask_address : str, optional
        Run the per-session tasks on this existing Dask distributed scheduler instead.
    on_session_done : callable(path, ok), optional
        Called as each session finishes (progress bars).
    """
    from recorder.errors import InputValueError

    options = options or AnalysisOptions()
    if jobs < 1:
        raise InputValueError(f"jobs must be >= 1, got {jobs}")
    files = [str(p) for p in find_sessions([str(p) for p in paths])]
    results_mcap: list[str | None] = [None] * len(files)
    if out_dir is not None and scene:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        results_mcap = [
            str(Path(out_dir) / f"{results_mcap_name(i, f)}") for i, f in enumerate(files)
        ]
    images = out_dir is not None
    outcomes: list[SessionResult | str]
    if dask_address is not None:
        outcomes = _run_dask(files, results_mcap, options, images, dask_address, on_session_done)
    elif jobs == 1 or len(files) <= 1:
        outcomes = []
        for f, r in zip(files, results_mcap, strict=True):
            outcomes.append(_analyse_or_error(f, options, images, r))
            if on_session_done:
                on_session_done(f, not isinstance(outcomes[-1], str))
    else:
        outcomes = _run_processes(files, results_mcap, options, images, jobs, on_session_done)
    results = tuple(o for o in outcomes if not isinstance(o, str))
    errors = pd.DataFrame(
        [
            {"session": f, "error": o}
            for f, o in zip(files, outcomes, strict=True)
            if isinstance(o, str)
        ],
        columns=["session", "error"],
    )
    trials = _concat(
        [r.trials for r in results],
        TRIAL_COLUMNS
        + LINE_COLUMNS
        + WEIGHTED_COLUMNS
        + OPTIMAL_COLUMNS
        + MARGIN_COLUMNS
        + UNCERTAINTY_COLUMNS,
    )
    result = RunResult(
        trials=trials,
        summary=summarize(trials),
        averaging=_concat([r.averaging for r in results], AVERAGING_COLUMNS),
        frames=_concat([r.frames for r in results], FRAME_COLUMNS),
        errors=errors,
        sessions=results,
        views=_concat([r.views for r in results], VIEW_COLUMNS),
    )
    if out_dir is not None:
        from analysis.report import write_outputs

        write_outputs(result, Path(out_dir))
    return result


def _concat(frames: list[pd.DataFrame], columns: list[str]) -> pd.DataFrame:
    present = [f for f in frames if not f.empty]
    if not present:
        return pd.DataFrame(columns=columns)
    table = pd.concat(present, ignore_index=True)
    return table[[c for c in columns if c in table.columns]]


def _analyse_to(
    path: str, results: str | None, options: AnalysisOptions, images: bool
) -> SessionResult | str:
    """:func:`_analyse_or_error` with the per-session argument second, for ``client.map``."""
    return _analyse_or_error(path, options, images, results)


def results_mcap_name(index: int, session: str | Path) -> str:
    """File name of a session's results.mcap in a run's output folder."""
    return f"results_{index:02d}_{Path(session).stem}.mcap"


def _run_dask(
    files: list[str],
    results: list[str | None],
    options: AnalysisOptions,
    images: bool,
    address: str,
    on_session_done: Callable[[str, bool], None] | None,
) -> list[SessionResult | str]:
    from recorder.errors import InputValueError

    try:
        from distributed import Client
    except ImportError as err:
        raise InputValueError(
            "--dask needs the optional Dask extra: pip install 'twopose[dask]'"
        ) from err
    try:
        client = Client(address, timeout=10)
    except OSError as err:
        raise InputValueError(f"cannot reach the Dask scheduler at {address}: {err}") from err
    try:
        futures = client.map(
            _analyse_to, files, results, options=options, images=images, pure=False
        )
        outcomes: list[SessionResult | str] = []
        for f, fut in zip(files, futures, strict=True):
            outcomes.append(fut.result())
            if on_session_done:
                on_session_done(f, not isinstance(outcomes[-1], str))
        return outcomes
    finally:
        client.close()
