"""Estimating a rig's hidden constants (:mod:`twopose.rig`) from a session's own ground
truth, and judging them honestly.

The likelihood is the analysis' own, linearized: every trial with ground truth is solved
again with the typed poses, intrinsics and ground height corrected by the constants, and
its estimate is compared with its truth, weighted by the inverse of the trial's
propagated covariance (the measured frame scatter and the typed resolution,
:func:`twopose.estimate.estimate_trials`). Minimizing the sum of the whitened residuals
(``scipy.optimize.least_squares``) is maximum likelihood under the first-order Gaussian
model the uncertainty columns already use. The constants' covariance is the inverse of
the whitened normal matrix (inflated by the reduced chi-square when that exceeds 1).

Identifiability: before fitting, the whitened Jacobian's columns (scaled by each
constant's typical size) are checked by SVD; a constant that no trial depends on, or that
moves the estimates the way others do (a near-null direction), is fixed at its nominal
value, and :attr:`RigFit.fixed` says which and why. Model selection
(:func:`select_constants`): groups of constants are added one at a time while the
leave-one-out prediction error (PRESS of the linearized fit) drops by more than 5%, so a
session without systematic error keeps none.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from twopose.errors import InputValueError
from twopose.estimate import (
    EstimateOptions,
    EstimateSettings,
    GroundSpec,
    PoseView,
    ViewBatch,
    estimate_trials,
    measure,
)
from twopose.rig import RIG_PARAMETERS, RigConstants
from twopose.solve import image_lines, triangulate_ground, triangulate_lines, triangulate_points
from twopose.trial_result import reported_point
from twopose.uncertainty import CHI2_95, nees

__all__ = [
    "GROUPS",
    "RIG_COLUMNS",
    "RIG_TABLE_COLUMNS",
    "RigData",
    "RigFit",
    "fit_constants",
    "leave_one_out",
    "loo_calibration",
    "prepare",
    "rig_toml",
    "select_constants",
]

F64 = NDArray[np.float64]

#: The constants' groups (what model selection adds or leaves out), in RIG_PARAMETERS order.
GROUPS = tuple(RIG_PARAMETERS)
_NAMES = [name for group in GROUPS for name in RIG_PARAMETERS[group]]
#: A typical size of each scalar (its column scale in the identifiability check).
_SCALE = np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 0.02, 5.0, 5.0, 0.01, 0.1])
_NOMINAL = RigConstants().vector()
_MIN_SINGULAR = 1e-3  # relative: below it, a direction of the constants is not identifiable
#: Where a fit may look (beyond: not a laptop on grid paper): lower and upper per scalar.
_LOWER = np.array([-20.0, -20.0, -20.0, -5.0, -5.0, -5.0, 0.7, -100.0, -100.0, 0.8, -5.0])
_UPPER = np.array([20.0, 20.0, 20.0, 5.0, 5.0, 5.0, 1.4, 100.0, 100.0, 1.25, 5.0])


@dataclass(frozen=True)
class RigData:
    """A session's trials with ground truth, ready for fitting: their detections combined
    into one measurement per pose (the constants do not change them), the typed batch,
    the truth and each trial's whitening (from its propagated covariance)."""

    method: str
    trial_ids: tuple[int, ...]
    batch: ViewBatch
    truth: F64  # (T, 2, 3)
    ground: GroundSpec | None
    whiten: F64  # (T, 3, 3): residual -> whitened residual (pseudo-inverse square root)
    cov: F64  # (T, 3, 3): each trial's propagated (random) covariance
    options: EstimateSettings = field(default_factory=EstimateOptions)

    def subset(self, rows: Sequence[int]) -> RigData:
        idx = np.asarray(rows, dtype=int)
        batch = ViewBatch(self.batch.inputs[idx], self.batch.intrinsics[idx], self.batch.valid[idx])
        return dataclasses.replace(
            self,
            trial_ids=tuple(self.trial_ids[i] for i in idx),
            batch=batch,
            truth=self.truth[idx],
            whiten=self.whiten[idx],
            cov=self.cov[idx],
        )


def prepare(
    method: str,
    trial_ids: Sequence[int],
    views: list[list[PoseView]],
    truth: F64,
    ground: GroundSpec | None,
    options: EstimateSettings | None = None,
) -> RigData:
    """The trials that can inform the constants: ok, with ground truth."""
    options = options or EstimateOptions()
    measurements, complete, detected = measure(views, options)
    est = estimate_trials(method, views, measurements, complete, detected, truth, ground, options)
    known = [bool(np.isfinite(truth[i]).all()) for i in range(len(views))]
    keep = [i for i in range(len(views)) if est.status[i] == "ok" and known[i]]
    if len(keep) < 2:
        raise InputValueError(
            f"the rig needs at least 2 ok trials with ground truth, this session has {len(keep)}"
        )
    batch = ViewBatch.of([measurements[i] for i in keep], [views[i] for i in keep])
    whiten = np.stack([_whitening(est.cov[i]) for i in keep])
    return RigData(
        method,
        tuple(int(trial_ids[i]) for i in keep),
        batch,
        truth[keep],
        ground,
        whiten,
        est.cov[keep],
        options,
    )


def _whitening(cov: F64) -> F64:
    """``W`` with ``W r`` of unit covariance on the directions ``cov`` spans."""
    if not np.isfinite(cov).all():
        return np.zeros((3, 3))
    w, V = np.linalg.eigh(cov)
    keep = w > 1e-12 * max(float(w.max()), 1e-300)
    scale = np.where(keep, 1.0 / np.sqrt(np.where(keep, w, 1.0)), 0.0)
    return np.asarray((V * scale).T)


def corrected_batch(batch: ViewBatch, rig: RigConstants) -> ViewBatch:
    """The batch with every view's typed pose and intrinsics corrected by ``rig``."""
    from twopose.rig import angles_deg_from_rotation

    inputs = batch.inputs.copy()
    t, R = rig.true_poses(inputs[..., 3:6], inputs[..., 6:9])
    inputs[..., 3:6] = t
    flat = R.reshape(-1, 3, 3)
    inputs[..., 6:9] = np.array([angles_deg_from_rotation(m) for m in flat]).reshape(R.shape[:-1])
    intrinsics = np.where(
        batch.valid[..., None], rig.true_intrinsics(batch.intrinsics), batch.intrinsics
    )
    return ViewBatch(inputs, intrinsics, batch.valid)


def solve_corrected(data: RigData, rig: RigConstants) -> F64:
    """Every trial's reported point (T, 3) with the constants applied."""
    batch = corrected_batch(data.batch, rig)
    P, valid, mc = batch.P(), batch.valid, data.options.min_conditioning
    px, th = batch.inputs[..., :2], batch.inputs[..., 2]
    if data.method == "point":
        return np.asarray(triangulate_points(px, P, valid=valid, min_conditioning=mc).point_grid)
    lines = image_lines(px, th)
    if data.method == "ground":
        assert data.ground is not None
        height = rig.true_ground_height(data.ground[1])
        g = triangulate_ground(lines, P, data.ground[0], height, valid=valid, min_conditioning=mc)
        return np.asarray(g.point_grid)
    solved = triangulate_lines(lines, P, valid=valid, min_conditioning=mc)
    est = _LineEstimate(solved.point_grid, solved.direction_grid)
    point, _ = reported_point("line", est, data.truth)  # type: ignore[arg-type]
    return point


@dataclass(frozen=True)
class _LineEstimate:
    point: F64
    direction: F64


def residuals(data: RigData, rig: RigConstants) -> F64:
    """Whitened residuals (T * 3,) of the corrected estimates against the truth."""
    reference = data.truth.mean(axis=1)
    r = solve_corrected(data, rig) - reference
    r = np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6)  # a trial the rig breaks
    whitened: F64 = np.einsum("tij,tj->ti", data.whiten, r).ravel()
    return whitened


@dataclass(frozen=True)
class RigFit:
    """Estimated constants: their values (fixed ones nominal), 1-sigma of each scalar
    (NaN: fixed), what was fitted, what was fixed and why, the fit's chi-square and its
    degrees of freedom, and the leave-one-out prediction error (PRESS, whitened)."""

    constants: RigConstants
    sigma: F64  # (11,) RIG_PARAMETERS order
    free: tuple[str, ...]
    fixed: dict[str, str]
    chi2: float
    dof: int
    press: float
    cov_scaled: F64 = field(default_factory=lambda: np.zeros((0, 0)))  # free, scaled units

    def rows(self, truth: RigConstants | None = None) -> list[dict[str, object]]:
        """One row per scalar: ``constant, value, sigma, fitted, why_fixed, truth``."""
        values = self.constants.vector()
        true = truth.vector() if truth is not None else np.full(len(_NAMES), np.nan)
        return [
            {
                "constant": name,
                "value": float(values[k]),
                "sigma": float(self.sigma[k]),
                "fitted": name in self.free,
                "why_fixed": self.fixed.get(name, ""),
                "truth": float(true[k]),
            }
            for k, name in enumerate(_NAMES)
        ]


def _vector(x: F64, free: NDArray[np.bool_]) -> F64:
    v = _NOMINAL.copy()
    v[free] += _SCALE[free] * x
    return v


def _jacobian(data: RigData, free: NDArray[np.bool_], x: F64, step: float = 1e-3) -> F64:
    """Central differences of the whitened residuals in scaled units (columns: free)."""
    columns = []
    for k in range(int(free.sum())):
        dx = np.zeros(len(x))
        dx[k] = step
        plus = residuals(data, RigConstants.from_vector(_vector(x + dx, free)))
        minus = residuals(data, RigConstants.from_vector(_vector(x - dx, free)))
        columns.append((plus - minus) / (2 * step))
    return (
        np.stack(columns, axis=1)
        if columns
        else np.zeros((len(residuals(data, RigConstants())), 0))
    )


def identifiable(
    data: RigData, wanted: NDArray[np.bool_]
) -> tuple[NDArray[np.bool_], dict[str, str]]:
    """Of the ``wanted`` scalars, those the session determines; the rest with the reason."""
    free = wanted.copy()
    fixed: dict[str, str] = {}
    while free.any():
        J = _jacobian(data, free, np.zeros(int(free.sum())))
        names = [n for n, f in zip(_NAMES, free, strict=True) if f]
        norms = np.linalg.norm(J, axis=0)
        if norms.max() <= 0:
            for n in names:
                fixed[n] = "no trial of this session depends on it"
            free[:] = False
            break
        dead = norms < _MIN_SINGULAR * norms.max()
        if dead.any():
            k = int(np.argmin(norms))
            fixed[names[k]] = "no trial of this session depends on it"
        else:
            _, s, Vt = np.linalg.svd(J / norms, full_matrices=False)
            if s[-1] >= _MIN_SINGULAR * s[0] and J.shape[0] > J.shape[1]:
                break
            k = int(np.argmax(np.abs(Vt[-1])))
            partners = [names[j] for j in np.argsort(-np.abs(Vt[-1]))[1:3]]
            fixed[names[k]] = "not separable from " + " and ".join(partners) + " with these trials"
        free[_NAMES.index(names[k])] = False
    return free, fixed


def fit_constants(data: RigData, groups: Sequence[str] = GROUPS) -> RigFit:
    """Maximum likelihood (linearized, see the module docstring) of the constants in
    ``groups``, the rest nominal; unidentifiable scalars are fixed and named."""
    from scipy.optimize import least_squares

    unknown = sorted(set(groups) - set(GROUPS))
    if unknown:
        raise InputValueError(f"unknown rig constant(s) {unknown}; known: {', '.join(GROUPS)}")
    wanted = np.array([any(n in RIG_PARAMETERS[g] for g in groups) for n in _NAMES])
    free, fixed = identifiable(data, wanted)
    x0 = np.zeros(int(free.sum()))
    if free.any():
        bounds = (
            (_LOWER - _NOMINAL)[free] / _SCALE[free],
            (_UPPER - _NOMINAL)[free] / _SCALE[free],
        )
        solution = least_squares(
            lambda x: residuals(data, RigConstants.from_vector(_vector(x, free))), x0, bounds=bounds
        )
        x = solution.x
    else:
        x = x0
    constants = RigConstants.from_vector(_vector(x, free))
    r = residuals(data, constants)
    J = _jacobian(data, free, x)
    dof = max(len(r) - int(free.sum()), 1)
    chi2 = float(r @ r)
    sigma = np.full(len(_NAMES), np.nan)
    press = _press(r, J)
    cov: F64 = np.zeros((0, 0))
    if free.any():
        cov = np.asarray(np.linalg.pinv(J.T @ J) * max(1.0, chi2 / dof), dtype=np.float64)
        sigma[free] = np.sqrt(np.diag(cov)) * _SCALE[free]
    names = tuple(n for n, f in zip(_NAMES, free, strict=True) if f)
    return RigFit(constants, sigma, names, fixed, chi2, dof, press, cov)


def _press(r: F64, J: F64) -> float:
    """Leave-one-trial-out prediction error of the linearized fit: each trial's 3
    residuals divided by ``(I - H_tt)`` (H the hat matrix), squared and summed."""
    if J.shape[1] == 0:
        return float(r @ r)
    H = J @ np.linalg.pinv(J.T @ J) @ J.T
    total = 0.0
    for t in range(len(r) // 3):
        block = slice(3 * t, 3 * t + 3)
        loo = np.linalg.lstsq(np.eye(3) - H[block, block], r[block], rcond=None)[0]
        total += float(loo @ loo)
    return total


def select_constants(data: RigData, *, margin: float = 0.05) -> RigFit:
    """The constants leave-one-out cross-validation supports: groups added one at a time
    while the PRESS drops by more than ``margin`` (none, if none helps)."""
    chosen: list[str] = []
    best = fit_constants(data, chosen)
    while True:
        trials = [fit_constants(data, [*chosen, g]) for g in GROUPS if g not in chosen]
        if not trials:
            return best
        candidate = min(trials, key=lambda f: f.press)
        if candidate.press >= (1.0 - margin) * best.press or set(candidate.free) == set(best.free):
            return best
        chosen = [g for g in GROUPS if any(n in RIG_PARAMETERS[g] for n in candidate.free)]
        best = candidate


def rig_toml(fit: RigFit, sources: Sequence[str]) -> str:
    """The rig file: ``[rig]`` (what ``--rig`` reads), ``[sigma]`` (1-sigma, 0 if fixed),
    ``[fixed]`` (why a constant was not estimated)."""
    c = fit.constants
    sigma = dict(zip(_NAMES, np.nan_to_num(fit.sigma), strict=True))

    def vec(values: Sequence[float]) -> str:
        return "[" + ", ".join(f"{float(v):.6g}" for v in values) + "]"

    lines = [
        "# twopose rig constants, estimated by `twopose-analyze rig` from:",
        *(f"#   {s}" for s in sources),
        f"# chi-square {fit.chi2:.1f} on {fit.dof} degrees of freedom; fitted: "
        + (", ".join(fit.free) or "nothing (none supported)"),
        "[rig]",
        f"mount_rotation_deg = {vec(c.mount_rotation_deg)}",
        f"camera_offset = {vec(c.camera_offset)}",
        f"focal_scale = {c.focal_scale:.6g}",
        f"principal_offset_px = {vec(c.principal_offset_px)}",
        f"tape_scale = {c.tape_scale:.6g}",
        f"ground_height_error = {c.ground_height_error:.6g}",
        "",
        "[sigma]",
        *(f"{name} = {value:.6g}" for name, value in sigma.items()),
    ]
    if fit.fixed:
        lines += ["", "[fixed]", *(f'{k} = "{v}"' for k, v in fit.fixed.items())]
    return "\n".join(lines) + "\n"


RIG_COLUMNS = ["x_rig", "y_rig", "z_rig", "err_rig", "within95_rig"]
RIG_TABLE_COLUMNS = ["session", "constant", "value", "sigma", "fitted", "why_fixed", "truth"]


def leave_one_out(data: RigData) -> tuple[F64, F64]:
    """Each trial's reported point (T, 3) corrected by constants estimated without it
    (the selection too runs without it, so the trial never informs its own correction),
    and whether its truth is inside the 95% region of the corrected estimate (T,; NaN if
    unknown): the trial's random covariance plus the fitted constants' covariance carried
    through the correction, ``C + J C_rig J^T``."""
    T = len(data.trial_ids)
    points = np.full((T, 3), np.nan)
    inside = np.full(T, np.nan)
    for i in range(T):
        others = [j for j in range(T) if j != i]
        if len(others) < 2:
            continue
        fit = select_constants(data.subset(others))
        trial = data.subset([i])
        points[i] = solve_corrected(trial, fit.constants)[0]
        cov = trial.cov[0] + _carried(trial, fit)
        score, dof = nees((points[i] - trial.truth[0].mean(axis=0))[None], cov[None])
        if dof[0] > 0 and np.isfinite(score[0]):
            inside[i] = float(score[0] <= CHI2_95[int(dof[0])])
    return points, inside


def _carried(trial: RigData, fit: RigFit, step: float = 1e-3) -> F64:
    """The constants' covariance carried to the trial's corrected point: ``J C J^T``."""
    free = np.array([n in fit.free for n in _NAMES])
    if not free.any():
        return np.zeros((3, 3))
    base = fit.constants.vector()
    columns = []
    for k in np.flatnonzero(free):
        dv = np.zeros(len(base))
        dv[k] = step * _SCALE[k]
        plus = solve_corrected(trial, RigConstants.from_vector(base + dv))[0]
        minus = solve_corrected(trial, RigConstants.from_vector(base - dv))[0]
        columns.append((plus - minus) / (2 * step))
    J = np.stack(columns, axis=1)
    carried: F64 = J @ fit.cov_scaled @ J.T
    return carried


def loo_calibration(
    session: str,
    method: str,
    trial_ids: Sequence[int],
    views: list[list[PoseView]],
    truth: F64,
    ground: GroundSpec | None,
    options: EstimateSettings,
    rig_truth: RigConstants | None = None,
) -> tuple[dict[int, F64], list[dict[str, object]]]:
    """``run --rig-calibration loo`` for one session: per trial its leave-one-out corrected
    point and whether the truth is inside its 95% region (trial id -> (x, y, z, inside)),
    and the session's constants (selected on all its trials) as rig.csv rows. A session
    that cannot inform the rig gets neither, and says why."""
    try:
        data = prepare(method, trial_ids, views, truth, ground, options)
    except InputValueError as err:
        return {}, [{"session": session, "constant": "", "why_fixed": str(err)}]
    points, inside = leave_one_out(data)
    fit = select_constants(data)
    rows = [{"session": session, **row} for row in fit.rows(rig_truth)]
    corrected = {t: np.append(p, w) for t, p, w in zip(data.trial_ids, points, inside, strict=True)}
    return corrected, rows
