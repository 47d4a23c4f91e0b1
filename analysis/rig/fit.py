"""Estimating a rig's hidden constants (:mod:`twopose.rig.constants`) from a session's own ground
truth, and judging them honestly.

The likelihood is the analysis' own, linearized: every trial with ground truth is solved
again with the typed poses, intrinsics and ground height corrected by the constants, and
its estimate is compared with its truth, weighted by the inverse of the trial's
propagated covariance (the measured frame scatter and the typed resolution,
:func:`twopose.solve.session.estimate_session`). Minimizing the sum of the whitened residuals
(``scipy.optimize.least_squares``) is maximum likelihood under the first-order Gaussian
model the uncertainty columns already use. The constants' covariance is the inverse of
the whitened normal matrix (inflated by the reduced chi-square when that exceeds 1).

Identifiability: before fitting, the whitened Jacobian's columns (scaled by each
constant's typical size) are checked by SVD; a constant that no trial depends on, or that
moves the estimates the way others do (a near-null direction), is fixed at its nominal
value, and :attr:`RigFit.fixed` says which and why. Model selection
(:func:`select_constants`): groups of constants are added one at a time while the
leave-one-out prediction error (PRESS of the linearized, whitened fit) drops and the drop
in chi-square passes an F-test at 1%, so a session without systematic error keeps none.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from analysis.rig.data import RigData, combine, prepare, prepare_session, require_trusted
from analysis.tables.columns import RIG_COLUMNS
from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.methods.specs import spec_of
from twopose.methods.truth import Reported, line_errors, reported_line_point
from twopose.rig.carried import corrected_batch
from twopose.rig.constants import (
    RIG_PARAMETERS,
    RigConstants,
    RigCovariance,
    against_priors,
    prior_sigma,
    true_ground,
)
from twopose.rig.file import RIG_FILE_FORMAT, camera_tables, covariance_table, placing_table
from twopose.solve.estimate import solve_batch
from twopose.solve.session import SessionEstimate
from twopose.uncertainty.noise import PlacingSigma
from twopose.uncertainty.propagate import CHI2_95, nees
from twopose.values.units import Units

__all__ = [
    "GROUPS",
    "LeaveOneOut",
    "RigData",
    "RigFit",
    "combine",
    "corrected_estimates",
    "fit_constants",
    "leave_one_out",
    "loo_calibration",
    "prepare",
    "prepare_session",
    "require_trusted",
    "rig_toml",
    "select_constants",
]


#: The constants' groups (what model selection adds or leaves out), in RIG_PARAMETERS order.
GROUPS = tuple(RIG_PARAMETERS)
_NAMES = [name for group in GROUPS for name in RIG_PARAMETERS[group]]
#: A typical size of each scalar (its column scale in the identifiability check).
_SCALE = np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 0.02, 5.0, 5.0, 0.01, 0.1])
_NOMINAL = RigConstants().vector()
_MIN_SINGULAR = 1e-3  # relative: below it, a direction of the constants is not identifiable


def solve_corrected(data: RigData, rig: RigConstants) -> F64:
    """Every trial's reported point (T, 3) with the constants applied."""
    return corrected_estimates(data, rig)[0]


def corrected_estimates(data: RigData, rig: RigConstants) -> tuple[F64, F64]:
    """Every trial's reported point and, for lines, the line's unit direction (T, 3)
    each (NaN for the other methods), with the constants applied: the estimation's own
    solver (:func:`twopose.solve.estimate.solve_batch`), each session on its own ground plane."""
    batch = corrected_batch(data.batch, rig)
    point = np.full((len(data.trial_ids), 3), np.nan)
    direction = np.full_like(point, np.nan)
    spec = spec_of(data.method)
    needs_ground = spec.needs_ground
    for s in np.unique(data.origin):
        rows = data.origin == s
        ground = data.grounds[int(s)]
        corrected = true_ground(ground, rig) if needs_ground and ground is not None else None
        solved = solve_batch(data.method, batch.rows(rows), corrected, data.options)
        point[rows] = solved.point
        if solved.direction is not None:
            direction[rows] = solved.direction
    if spec.estimates_line:
        point, _ = reported_line_point(point, direction, data.truth)
    return point, direction


def raw_residuals(data: RigData, rig: RigConstants) -> F64:
    """The corrected estimates minus the truth (T * 3,), in the session's units."""
    r = solve_corrected(data, rig) - data.truth.mean(axis=1)
    flat: F64 = np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6).ravel()  # a trial the rig breaks
    return flat


def _whitened(data: RigData, raw: F64) -> F64:
    """Per-trial whitening of stacked (T * 3, ...) residuals or Jacobian rows."""
    blocks = raw.reshape(len(data.trial_ids), 3, -1)
    out: F64 = np.einsum("tij,tjk->tik", data.whiten, blocks).reshape(raw.shape)
    return out


def residuals(data: RigData, rig: RigConstants) -> F64:
    """Whitened residuals (T * 3,) of the corrected estimates against the truth."""
    return _whitened(data, raw_residuals(data, rig))


@dataclass(frozen=True, kw_only=True)
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
    #: Constants the fit pushed more than two prior sigmas from nominal, or to a bound of
    #: the plausible (there the value is the bound's, not the data's).
    warnings: tuple[str, ...] = ()

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
    """Central differences of the raw residuals in scaled units (columns: free)."""
    columns = []
    for k in range(int(free.sum())):
        dx = np.zeros(len(x))
        dx[k] = step
        plus = raw_residuals(data, RigConstants.from_vector(_vector(x + dx, free)))
        minus = raw_residuals(data, RigConstants.from_vector(_vector(x - dx, free)))
        columns.append((plus - minus) / (2 * step))
    if not columns:
        return np.zeros((3 * len(data.trial_ids), 0))
    return np.stack(columns, axis=1)


def identifiable(
    data: RigData, wanted: NDArray[np.bool_]
) -> tuple[NDArray[np.bool_], dict[str, str]]:
    """Of the ``wanted`` scalars, those the session determines; the rest with the reason."""
    free = wanted.copy()
    fixed: dict[str, str] = {}
    while free.any():
        J = _whitened(data, _jacobian(data, free, np.zeros(int(free.sum()))))
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
    data = data.fitting()
    wanted = np.array([any(n in RIG_PARAMETERS[g] for g in groups) for n in _NAMES])
    free, fixed = identifiable(data, wanted)
    # The physical priors (twopose.rig.RIG_PRIORS), in the fit's scaled units: each free
    # constant's (value - nominal) / prior sigma joins the residuals (maximum a posteriori).
    prior = prior_sigma(data.units)[free] / _SCALE[free]
    x0 = np.zeros(int(free.sum()))
    lower, upper = data.bounds()
    bounds = ((lower - _NOMINAL)[free] / _SCALE[free], (upper - _NOMINAL)[free] / _SCALE[free])
    if free.any():
        solution = least_squares(
            lambda x: np.concatenate(
                [residuals(data, RigConstants.from_vector(_vector(x, free))), x / prior]
            ),
            x0,
            bounds=bounds,
        )
        x = solution.x
    else:
        x = x0
    constants = RigConstants.from_vector(_vector(x, free), data.units)
    r, J = residuals(data, constants), _whitened(data, _jacobian(data, free, x))
    dof = max(len(r) - int(free.sum()), 1)
    chi2 = float(r @ r)
    sigma = np.full(len(_NAMES), np.nan)
    press = _press(r, J)
    cov: F64 = np.zeros((0, 0))
    if free.any():
        information = J.T @ J + np.diag(1.0 / prior**2)
        cov = np.asarray(np.linalg.pinv(information) * max(1.0, chi2 / dof), dtype=np.float64)
        sigma[free] = np.sqrt(np.diag(cov)) * _SCALE[free]
    names = tuple(n for n, f in zip(_NAMES, free, strict=True) if f)
    if free.any():  # the whole covariance, in the constants' own units (the rig file's)
        scale = _SCALE[free]
        covariance = RigCovariance.of(names, cov * np.outer(scale, scale))
        constants = dataclasses.replace(constants, covariance=covariance)
    at_bound = tuple(
        f"{name} = {value:.4g} is at the bound of the plausible: the value is the bound's, "
        "not the data's; check the rig, the typed poses and the targets"
        for name, value, xi, lo, hi in zip(names, _vector(x, free)[free], x, *bounds, strict=True)
        if min(xi - lo, hi - xi) < 1e-6 * max(1.0, abs(hi - lo))
    )
    delta = _vector(x, free) - _NOMINAL
    return RigFit(
        constants=constants,
        sigma=sigma,
        free=names,
        fixed=fixed,
        chi2=chi2,
        dof=dof,
        press=press,
        cov_scaled=cov,
        warnings=against_priors(delta, data.units, names) + at_bound,
    )


def _press(r: F64, J: F64) -> float:
    """Leave-one-trial-out prediction error of the linearized (whitened) fit: each
    trial's 3 residuals divided by ``(I - H_tt)`` (H the hat matrix), squared and summed.
    Whitened, as the likelihood is: in raw units the few poorly conditioned trials (a
    ground trial's nearly parallel planes) decide alone, and spurious constants follow."""
    if J.shape[1] == 0:
        return float(r @ r)
    inverse = np.linalg.pinv(J.T @ J)
    total = 0.0
    for t in range(len(r) // 3):
        block = slice(3 * t, 3 * t + 3)
        H_tt = J[block] @ inverse @ J[block].T
        loo = np.linalg.lstsq(np.eye(3) - H_tt, r[block], rcond=None)[0]
        total += float(loo @ loo)
    return total


def select_constants(data: RigData, *, margin: float = 0.0, alpha: float = 0.01) -> RigFit:
    """The constants the session supports: groups added one at a time (the one with the
    lowest leave-one-out prediction error first) while each addition both lowers the
    PRESS (by more than ``margin``, relative) and passes an F-test at level ``alpha`` (its
    drop in chi-square against the residual chi-square: forward selection with an
    F-to-enter, so that a session without systematic error keeps none)."""
    chosen: list[str] = []
    best = fit_constants(data, chosen)
    while True:
        trials = [fit_constants(data, [*chosen, g]) for g in GROUPS if g not in chosen]
        trials = [f for f in trials if len(f.free) > len(best.free)]
        if not trials:
            return best
        candidate = min(trials, key=lambda f: f.press)
        if candidate.press >= (1.0 - margin) * best.press or _f_test(best, candidate) >= alpha:
            return best
        chosen = [g for g in GROUPS if any(n in RIG_PARAMETERS[g] for n in candidate.free)]
        best = candidate


def _f_test(smaller: RigFit, larger: RigFit) -> float:
    """The p-value of the larger model's drop in chi-square (an F-test: the drop per
    added constant against the larger fit's residual chi-square per degree of freedom)."""
    from scipy import special

    added = len(larger.free) - len(smaller.free)
    if larger.chi2 <= 0:
        return 0.0
    statistic = ((smaller.chi2 - larger.chi2) / added) / (larger.chi2 / larger.dof)
    return float(special.fdtrc(added, larger.dof, statistic))  # F's upper tail


def rig_toml(
    fit: RigFit,
    sources: Sequence[str],
    warnings: Sequence[str] = (),
    basis: str = "",
    placing: PlacingSigma | None = None,
) -> str:
    """The rig file (docs/rig-file.md, :mod:`twopose.rig.file`): its ``format``, ``[rig]``
    (what ``--rig`` reads), ``[sigma]`` (1-sigma, 0 if fixed), ``[covariance]`` (the fitted
    scalars', which every ``--rig`` region carries), ``[fixed]`` (why a constant was not
    estimated), ``[[camera]]`` (each camera it was fitted for), ``[placing]`` (the
    operator's placing sigma a board measured, or bounded; target sessions measure none,
    and the file says so); what it was fitted on and the fit's warnings as comments."""
    c = fit.constants
    sigma = dict(zip(_NAMES, np.nan_to_num(fit.sigma), strict=True))

    def vec(values: Sequence[float]) -> str:
        return "[" + ", ".join(f"{float(v):.6g}" for v in values) + "]"

    lines = [
        "# twopose rig constants, estimated by `twopose-analyze rig` from:",
        *(f"#   {s}" for s in sources),
        f"# chi-square {fit.chi2:.1f} on {fit.dof} degrees of freedom; fitted: "
        + (", ".join(fit.free) or "nothing (none supported)"),
        *([f"# fitted on {basis}"] if basis else []),
        *(f"# warning: {w}" for w in warnings),
        f"format = {RIG_FILE_FORMAT}  # of this file (docs/rig-file.md)",
        "",
        "[rig]",
        *([f'units = "{c.units}"  # of camera_offset and ground_height_error'] if c.units else []),
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
    if c.covariance is not None:
        lines += ["", *covariance_table(c.covariance)]
    if fit.fixed:
        lines += ["", "[fixed]", *(f'{k} = "{v}"' for k, v in fit.fixed.items())]
    if c.cameras:
        lines += ["", *camera_tables(c.cameras)]
    if placing is not None:
        lines += ["", *placing_table(placing, c.units or Units.IN)]
    else:
        lines += [
            "",
            "# no [placing]: only a board session measures the operator's placing error;",
            "# the regions take each pose's typed resolution",
        ]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True, kw_only=True)
class LeaveOneOut:
    """Each trial corrected by constants estimated without it: its reported point and
    (lines) direction (T, 3) each, and whether its truth is inside the corrected 95%
    region (T,; 1.0, 0.0 or NaN)."""

    points: F64
    directions: F64
    within95: F64


def leave_one_out(data: RigData) -> LeaveOneOut:
    """Each trial corrected by constants estimated without it (the selection too runs
    without it, so the trial never informs its own correction), and whether its truth is
    inside the 95% region of the corrected estimate: the trial's random covariance plus
    the fitted constants' covariance carried through the correction, ``C + J C_rig J^T``."""
    T = len(data.trial_ids)
    points, directions = np.full((T, 3), np.nan), np.full((T, 3), np.nan)
    inside = np.full(T, np.nan)
    for i in range(T):
        others = [j for j in range(T) if j != i]
        if data.trusted[others].sum() < 2:
            continue
        fit = select_constants(data.subset(others))
        trial = data.subset([i])
        point, direction = corrected_estimates(trial, fit.constants)
        points[i], directions[i] = point[0], direction[0]
        cov = trial.cov[0] + _carried(trial, fit)
        score, dof = nees((points[i] - trial.truth[0].mean(axis=0))[None], cov[None])
        if dof[0] > 0 and np.isfinite(score[0]):
            inside[i] = float(score[0] <= CHI2_95[int(dof[0])])
    return LeaveOneOut(points=points, directions=directions, within95=inside)


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
    estimate: SessionEstimate,
    reported_: Reported | None = None,
    rig_truth: RigConstants | None = None,
) -> tuple[pd.DataFrame, list[dict[str, object]]]:
    """``run --rig-calibration loo`` for one session, from its one estimate: its trials'
    :data:`RIG_COLUMNS` (indexed by trial id; trials that could not inform the rig are
    absent), and the session's constants (selected on all its trials) as rig.csv rows. A
    session that cannot inform the rig gets no columns, and its one row says why. The
    session's units scale the plausible lengths the fit may reach."""
    try:
        data = prepare(estimate, reported_)
    except InputValueError as err:
        empty = pd.DataFrame(columns=RIG_COLUMNS, index=pd.Index([], name="trial"))
        return empty, [{"session": session, "constant": "", "why_fixed": str(err)}]
    loo = leave_one_out(data)
    fit = select_constants(data)
    rows = [{"session": session, **row} for row in fit.rows(rig_truth)]
    return _loo_columns(data, loo), rows


def _loo_columns(data: RigData, loo: LeaveOneOut) -> pd.DataFrame:
    """The trials' :data:`RIG_COLUMNS`, compared with the truth as trials.csv compares
    the uncorrected estimate (lines: the true segment's midpoint, and the angle)."""
    reference = data.truth.mean(axis=1)
    columns: dict[str, F64] = {f"{a}_rig": loo.points[:, i] for i, a in enumerate("xyz")}
    columns["err_rig"] = np.linalg.norm(loo.points - reference, axis=1)
    columns["within95_rig"] = loo.within95
    if spec_of(data.method).estimates_line:
        with np.errstate(invalid="ignore"):
            _, _, angle, dist = line_errors(
                loo.points, loo.directions, data.truth[:, 0], data.truth[:, 1]
            )
        columns |= {f"dir_{a}_rig": loo.directions[:, i] for i, a in enumerate("xyz")}
        columns |= {"angle_err_rig_deg": angle, "dist_err_rig": dist}
    index = pd.Index(data.trial_ids, name="trial")
    return pd.DataFrame(columns, index=index).reindex(columns=RIG_COLUMNS)
