"""Each trial's misclosure: how far its views disagree with its own estimate (issues 46, 54).

A trial with more measurements than its estimate has parameters carries **redundancy**: a
point seen from N poses has 2N pixel coordinates for 3 unknowns (2N - 3 redundant), a line
or the finger's line from N image lines has 2N numbers for 4 unknowns (2N - 4, so N >= 3).
Its **residuals** are each view's measurement minus what the estimate predicts there (the
point projected; the 3-D line projected: the centroid's distance across it and its
angle). Under the noise model (the same input covariance ``C`` the regions assume: frame
scatter and detector floor, placing sigma, calibration sigma) they have the covariance
``Cov(r) = J_r C J_r^T``, ``J_r`` by the perturbation machinery of
:func:`twopose.uncertainty.propagate.propagate` (:func:`twopose.uncertainty.propagate.jacobians`).

**Evaluated at the trial's estimate, not linearised at the typed poses** (issue 54): the
misclosure is the least correction ``v`` of every input (pixels, typed poses, the
calibration) that makes the views agree, ``min v^T C^+ v`` with ``r(x + v) = 0``: the
Gauss-Helmert adjustment, iterated, each step linearising the residuals at the inputs the
last one adjusted (:func:`misclosures`). Its ``chi2 = v^T C^+ v`` is chi-square on the
trial's ``dof`` redundant directions when the model holds, and follows the placing error
where the residuals bend (method 2's planes at a grazing angle), where one linearisation at
the typed poses does not. The first step is the linear test at the typed poses.

Per trial the misclosure is kept as what every later rule needs (:class:`Misclosure`): in
the basis that whitens ``A + B`` and diagonalizes ``B`` (``B`` the placing sigma's share of
``Cov(r)``, ``A`` the rest) the placing's share ``beta`` of each direction and the
misclosure's signed component ``z`` there, so that the likelihood of the placing variance's
multiplier ``lambda`` (``Cov(r) = A + lambda B``) is a sum of scalars
(:mod:`twopose.uncertainty.placing_variance`), and each typed translation component's effect on the
misclosure in the same basis, for Baarda's w-test of a single mistyped component
(:func:`pose_tests`). What a solver predicts of a view (rays or planes) is named by the
solver table (:mod:`twopose.solve.estimate`), never by a method's name.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.detect.detection import wrap_theta_deg
from twopose.solve.nview import image_lines, triangulate_lines, triangulate_points
from twopose.uncertainty.propagate import PLACING, Shared, jacobians

__all__ = [
    "ITERATIONS",
    "PLANES",
    "RAYS",
    "Misclosure",
    "MisclosureModel",
    "PoseTests",
    "TrialConditions",
    "misclosures",
    "pose_tests",
]

#: A model's condition equations ``r(x, theta) = 0``: each view's residuals from the
#: (perturbed) inputs ``x`` (R, N, 9[+S]), the estimate's parameters ``theta`` (R, K), the
#: cameras ``P`` (R, N, 3, 4) and valid views (R, N): (R, N, 2), zero in a padding view.
Conditions = Callable[[F64, F64, F64, Bools], F64]
#: Eigen-directions of a covariance under this share of its largest are outside its range.
_RANK_TOLERANCE = 1e-9
#: The adjustment's steps at most, and when it has converged (chi2's relative change).
ITERATIONS = 8
_CONVERGED = 1e-6
#: A step longer than the last (it would walk off) is halved at most this many times,
#: then the adjustment stops at the last step it took.
_HALVINGS = 4
#: The parameters' difference step, a share of the estimate's distance from the origin.
_PARAMETER_STEP = 1e-6


@dataclass(frozen=True, kw_only=True)
class MisclosureModel:
    """What a solver's estimate predicts of each view, with its parameters explicit."""

    #: Where the views agree with an estimate ``theta``: ``conditions(x, theta) = 0``.
    conditions: Conditions
    #: The method's own estimate from the inputs (x, P, valid) -> theta (R, K): the start.
    estimate: Callable[[F64, F64, Bools], F64]
    #: ``theta`` (R, K) moved by a step (R, parameters) in its own tangent directions.
    moved: Callable[[F64, F64], F64]
    #: The estimate's degrees of freedom: a point 3, a 3-D line 4.
    parameters: int


@dataclass(frozen=True, kw_only=True)
class TrialConditions:
    """A batch's :class:`MisclosureModel` bound to its views (:func:`misclosures` takes it).

    ``conditions(x, theta)``: stacked (perturbed) inputs (R T, N, 9[+S]) and ``theta``
    (T, K) -> (R T, N, 2) as :func:`twopose.uncertainty.propagate.propagate` calls an
    estimate; ``estimate(x)``: inputs (T, N, 9[+S]) -> the method's own ``theta`` (T, K).
    """

    conditions: Callable[[F64, F64], F64]
    estimate: Callable[[F64], F64]
    moved: Callable[[F64, F64], F64]
    parameters: int


def _project(P: F64, X: F64) -> F64:
    """(R, N, 2) the points ``X`` (R, 3) (or (R, N, 3)) in each view's pixels."""
    Xh = np.concatenate([X, np.ones((*X.shape[:-1], 1))], axis=-1)
    if Xh.ndim == 2:
        Xh = np.broadcast_to(Xh[:, None], (*P.shape[:2], 4))
    h = np.einsum("rnij,rnj->rni", P, Xh)
    return np.asarray(h[..., :2] / h[..., 2:3])


def ray_conditions(x: F64, theta: F64, P: F64, valid: Bools) -> F64:
    """Each view's measured pixel minus the point ``theta`` (R, 3) projected (R, N, 2)."""
    r = x[..., :2] - _project(P, theta)
    return np.asarray(np.where(valid[..., None], r, 0.0))


def _thesis_point(x: F64, P: F64, valid: Bools) -> F64:
    """The thesis' point of the views' rays (R, 3)."""
    return triangulate_points(x[..., :2], P, valid=valid).point_grid


def _shifted(theta: F64, step: F64) -> F64:
    return np.asarray(theta + step)


def plane_conditions(x: F64, theta: F64, P: F64, valid: Bools) -> F64:
    """Each view's centroid across, and angle against, the 3-D line ``theta`` projected.

    ``theta`` (R, 6): a point of the line and its unit direction. (R, N, 2): the measured
    centroid's signed distance (px) from the projected line and the measured angle minus
    the projected line's (degrees, lines have no arrow).
    """
    a = _project(P, theta[:, :3])
    b = _project(P, theta[:, :3] + theta[:, 3:])
    d = b - a
    length = np.linalg.norm(d, axis=-1, keepdims=True)
    normal = np.stack([-d[..., 1], d[..., 0]], axis=-1) / length
    across = np.einsum("rni,rni->rn", x[..., :2] - a, normal)
    angle = wrap_theta_deg(x[..., 2] - np.degrees(np.arctan2(d[..., 1], d[..., 0])))
    r = np.stack([across, angle], axis=-1)
    return np.asarray(np.where(valid[..., None], r, 0.0))


def _thesis_line(x: F64, P: F64, valid: Bools) -> F64:
    """The thesis' line of the views' planes (R, 6): its point and unit direction."""
    line = triangulate_lines(image_lines(x[..., :2], x[..., 2]), P, valid=valid)
    return np.concatenate([line.point_grid, line.direction_grid], axis=-1)


def _line_moved(theta: F64, step: F64) -> F64:
    """The line ``theta`` (R, 6) moved across itself by ``step[:, :2]`` (session units) and
    turned by ``step[:, 2:]`` (radians), both along two directions square to it."""
    p, d = theta[:, :3], theta[:, 3:]
    axis = np.eye(3)[np.argmin(np.abs(np.nan_to_num(d)), axis=1)]
    e1 = np.cross(d, axis)
    e1 = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(d, e1)
    p = p + step[:, :1] * e1 + step[:, 1:2] * e2
    d = d + step[:, 2:3] * e1 + step[:, 3:4] * e2
    return np.concatenate([p, d / np.linalg.norm(d, axis=1, keepdims=True)], axis=-1)


#: A point's rays: its projection in every view.
RAYS = MisclosureModel(
    conditions=ray_conditions, estimate=_thesis_point, moved=_shifted, parameters=3
)
#: A line's planes (the fixed line, method 2's finger): the line projected in every view.
PLANES = MisclosureModel(
    conditions=plane_conditions, estimate=_thesis_line, moved=_line_moved, parameters=4
)


@dataclass(frozen=True, kw_only=True)
class Misclosure:
    """Per trial: the misclosure's chi-square under the typed model and its components.

    ``chi2`` (T,) is NaN where the trial has no redundancy or no finite residual, ``dof``
    (T,) then 0. In the basis that whitens ``Cov(r)`` and diagonalizes its placing part
    (M = 2N directions, zero outside its range): ``placing_share`` (T, M) the placing's
    share ``beta`` of each direction (0..1), ``z`` (T, M) the misclosure's signed
    component (``chi2 = sum z^2``), and ``bias`` (T, N, 3, M) the component of a unit
    error of each pose's typed x, y, z (session units), for :func:`pose_tests`.
    """

    chi2: F64
    dof: Ints
    placing_share: F64
    z: F64
    bias: F64
    #: (T,) the adjustment's steps (1: the linear test at the typed poses sufficed).
    iterations: Ints

    @property
    def z2(self) -> F64:
        """(T, M) the squared components (their sum is ``chi2``)."""
        return np.asarray(self.z**2)

    def rows(self, which: Ints | Bools) -> Misclosure:
        """The misclosure of some of its trials."""
        return Misclosure(
            **{f.name: getattr(self, f.name)[which] for f in dataclasses.fields(self)}
        )

    @classmethod
    def none(cls, T: int, N: int) -> Misclosure:
        """``T`` trials of ``N`` views without a test."""
        M = 2 * N
        return cls(
            chi2=np.full(T, np.nan),
            dof=np.zeros(T, dtype=np.int_),
            placing_share=np.zeros((T, M)),
            z=np.zeros((T, M)),
            bias=np.zeros((T, N, 3, M)),
            iterations=np.zeros(T, dtype=np.int_),
        )


def misclosures(
    conditions: TrialConditions,
    inputs: F64,
    input_cov: F64,
    valid: Bools,
    parameters: int,
    *,
    shared: Shared | None = None,
    iterations: int = ITERATIONS,
) -> Misclosure:
    """Every trial's misclosure, the Gauss-Helmert adjustment's, vectorized over trials.

    ``conditions`` the batch's (:class:`TrialConditions`); ``inputs`` (T, N, 9),
    ``input_cov`` (T, N, 9, 9), ``shared`` as :func:`twopose.uncertainty.propagate.propagate`
    takes them; ``parameters``: the estimate's own. ``iterations``: the adjustment's steps
    at most (1: linearised at the typed inputs and the method's own estimate).
    """
    T, N, _ = inputs.shape
    M = 2 * N
    dof = np.clip(2 * valid.sum(axis=1) - parameters, 0, None).astype(np.int_)
    out = Misclosure.none(T, N)
    if not (dof > 0).any():
        return out
    # every row goes through (``conditions`` is bound to the whole batch); one without
    # redundancy, or whose estimate failed, is done from the start
    step = first = _Adjustment.start(conditions, inputs, input_cov, valid, dof, shared)
    done = (dof == 0) | ~np.isfinite(step.chi2)
    count = np.ones(T, dtype=np.int_)
    last = np.full(T, np.inf)  # the last step's length (in the inputs' sigmas)
    for _ in range(max(iterations, 1) - 1):
        following, length = _controlled(step, done, last)
        took = ~done & np.isfinite(following.chi2) & (length <= last)
        moved = np.abs(following.chi2 - step.chi2) > _CONVERGED * (1 + np.abs(step.chi2))
        count[took] += 1
        step = step.merged(following, took)
        last = np.where(took, length, last)
        done |= ~took | ~moved
        if done.all():
            break
    # an adjustment that ended above what correcting the pixels alone to the method's own
    # estimate costs has not found the least correction: the first step's (never above it)
    fallback = ~(step.chi2 <= first.pixels_alone()) & np.isfinite(first.chi2)
    step = step.merged(first, fallback)
    count[fallback] = 1
    chi2, share, z, bias, kept = step.components()
    good = np.isfinite(chi2) & (dof > 0)
    return dataclasses.replace(
        out,
        chi2=np.where(good, chi2, np.nan),
        dof=np.where(good, kept, 0),
        placing_share=np.where(good[:, None], share, 0.0),
        z=np.where(good[:, None], z, 0.0),
        bias=np.where(good[:, None, None, None], bias.reshape(T, N, 3, M), 0.0),
        iterations=np.where(good, count, 0),
    )


def _controlled(step: _Adjustment, done: Bools, last: F64) -> tuple[_Adjustment, F64]:
    """The adjustment's next step, and its length, under step control.

    A step no shorter than the last (the iteration walking off rather than closing in) or
    one whose linearisation fails is halved, at most :data:`_HALVINGS` times.
    """
    fraction = np.ones(len(done))
    following = step.toward(fraction)
    length = step.length(following)
    for _ in range(_HALVINGS):
        redo = ~done & ~(np.isfinite(following.chi2) & (length <= last))
        if not redo.any():
            break
        fraction = np.where(redo, fraction / 2, fraction)
        following = step.merged(step.toward(fraction), redo)
        length = np.where(redo, step.length(following), length)
    return following, length


@dataclass(frozen=True, kw_only=True)
class _Adjustment:
    """One step of the Gauss-Helmert adjustment of a batch of trials (R rows).

    The conditions ``r(x, theta) = 0`` linearised at the inputs ``x`` (and shared values
    ``s``) and parameters ``theta`` (the typed inputs and the method's own estimate first):
    ``B v + A dtheta + w = 0`` with ``B`` (``J``, ``Js``) and ``A`` their derivatives,
    ``w = r(x, theta) + B (x0 - x)`` the misclosure referred back to the typed inputs and
    ``cov = B C B^T`` its covariance (``placing`` that of the typed translations alone).
    Whitened by ``cov^-1/2`` (``white``) and with what ``dtheta`` absorbs projected out
    (``proj``), ``chi2 = |proj white w|^2 = v^T C^+ v`` over ``2 N - parameters``
    directions; ``dtheta`` and the multipliers ``k`` (``v = C B^T k``) are the step.
    """

    conditions: TrialConditions
    x0: F64
    C: F64
    valid: Bools
    dof: Ints
    shared: Shared | None
    x: F64
    s: F64 | None
    theta: F64
    w: F64
    J: F64
    Js: F64 | None
    placing: F64
    white: F64
    proj: F64
    kept: Ints
    dtheta: F64
    k: F64
    chi2: F64

    @classmethod
    def start(
        cls,
        conditions: TrialConditions,
        x0: F64,
        C: F64,
        valid: Bools,
        dof: Ints,
        shared: Shared | None,
    ) -> _Adjustment:
        """The first step: linearised at the typed inputs and the method's estimate."""
        s0 = None if shared is None else shared.values
        full = x0 if s0 is None else np.concatenate([x0, s0], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            theta = conditions.estimate(full)
        return cls._at(conditions, x0, C, valid, dof, shared, x0, s0, theta)

    @classmethod
    def _at(
        cls,
        conditions: TrialConditions,
        x0: F64,
        C: F64,
        valid: Bools,
        dof: Ints,
        shared: Shared | None,
        x: F64,
        s: F64 | None,
        theta: F64,
    ) -> _Adjustment:
        R, N, _ = x.shape
        M = 2 * N
        here = None if shared is None or s is None else dataclasses.replace(shared, values=s)

        def flat(values: F64) -> F64:
            return conditions.conditions(values, theta).reshape(values.shape[0], M)

        full = x if s is None else np.concatenate([x, s], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = flat(full)
            A = _parameter_columns(conditions, full, theta, M)
        J, Js = jacobians(flat, x, C, M, shared=here)
        w = r + np.einsum("rmnd,rnd->rm", J, np.nan_to_num(x0 - x))
        cov = np.einsum("rinj,rnjk,rlnk->ril", J, C, J)
        if Js is not None and here is not None and shared is not None:
            s0 = _per_group(shared.values, shared.group, shared.cov.shape[1])
            s1 = _per_group(
                s if s is not None else shared.values, shared.group, shared.cov.shape[1]
            )
            w = w + np.einsum("rmgs,rgs->rm", Js, s0 - s1)
            cov = cov + np.einsum("rigs,rgsq,rjgq->rij", Js, shared.cov, Js)
        Jp = J[..., PLACING]
        placing = np.einsum("rinj,rnjk,rlnk->ril", Jp, C[..., PLACING, PLACING], Jp)
        solved = _solve(w, cov, A, np.repeat(valid, 2, axis=1), dof)
        return cls(conditions=conditions, x0=x0, C=C, valid=valid, dof=dof, shared=shared,
                   x=x, s=s, theta=theta, w=w, J=J, Js=Js, placing=placing, **solved)  # fmt: skip

    def toward(self, fraction: F64) -> _Adjustment:
        """The step linearised where this one's solution lies (``fraction`` of the way).

        The inputs ``x0 + v``, ``v = C B^T k`` (the least correction that closes the
        linearised views) and the parameters ``theta + dtheta``.
        """
        f = fraction[:, None, None]
        v = np.nan_to_num(np.einsum("rnjk,rmnk,rm->rnj", self.C, self.J, self.k))
        x = np.where(np.isfinite(self.x0), self.x + f * (self.x0 + v - self.x), self.x0)
        s = self.s
        if self.shared is not None and self.Js is not None and s is not None:
            G = self.shared.cov.shape[1]
            vs = np.einsum("rgsq,rmgq,rm->rgs", self.shared.cov, self.Js, self.k)
            s0 = _per_group(self.shared.values, self.shared.group, G)
            s = s + f * (_per_view(s0 + vs, self.shared.group, self.shared.values) - s)
        theta = self.conditions.moved(self.theta, fraction[:, None] * np.nan_to_num(self.dtheta))
        return _Adjustment._at(self.conditions, self.x0, self.C, self.valid, self.dof,
                               self.shared, x, s, theta)  # fmt: skip

    def length(self, other: _Adjustment) -> F64:
        """(R,) how far ``other``'s inputs lie from this one's, in the inputs' sigmas."""
        sigma = np.sqrt(np.clip(np.diagonal(self.C, axis1=2, axis2=3), 0.0, None))
        d = np.where(sigma > 0, np.nan_to_num(other.x - self.x) / np.where(sigma > 0, sigma, 1), 0)
        total = (d**2).sum(axis=(1, 2))
        if self.shared is not None and self.s is not None and other.s is not None:
            sd = np.sqrt(np.clip(np.diagonal(self.shared.cov, axis1=2, axis2=3), 0.0, None))
            G = sd.shape[1]
            ds = _per_group(other.s, self.shared.group, G) - _per_group(
                self.s, self.shared.group, G
            )
            total += np.where(sd > 0, ds / np.where(sd > 0, sd, 1.0), 0.0).__pow__(2).sum(
                axis=(1, 2)
            )
        return np.asarray(np.sqrt(total))

    def pixels_alone(self) -> F64:
        """(R,) the chi-square of closing each view by its own pixels alone (inf: none do).

        The models' conditions are linear in a view's pixels (centroid and angle), so
        correcting them alone to the parameters ``theta`` closes the views exactly: a
        correction the least one never exceeds, and the first step's never does.
        """
        R, M = self.w.shape
        N = M // 2
        rows = np.arange(N)
        G = self.J.reshape(R, N, 2, N, -1)[:, rows, :, rows, :3]  # (N, R, 2, 3) own pixels
        S = np.einsum("nrij,rnjk,nrlk->nril", G, self.C[..., :3, :3], G)
        g = np.moveaxis(self.w.reshape(R, N, 2), 1, 0)
        det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
        scale = np.einsum("nrii->nr", S) ** 2
        regular = det > _RANK_TOLERANCE * scale
        inv = np.stack([np.stack([S[..., 1, 1], -S[..., 0, 1]], -1),
                        np.stack([-S[..., 1, 0], S[..., 0, 0]], -1)], -2)  # fmt: skip
        inv = inv / np.where(regular, det, 1.0)[..., None, None]
        cost = np.einsum("nri,nrij,nrj->nr", g, inv, g)
        used = self.valid.T
        cost = np.where(used, np.where(regular, cost, np.inf), 0.0).sum(axis=0)
        return np.asarray(np.where(np.isfinite(self.chi2), cost, np.inf))

    def merged(self, other: _Adjustment, take: Bools) -> _Adjustment:
        """The step with ``other``'s rows where ``take`` (a failed step keeps its last)."""
        if take.all():
            return other
        rows: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            mine, theirs = getattr(self, f.name), getattr(other, f.name)
            if f.name not in _FIXED and isinstance(mine, np.ndarray):
                shape = (-1,) + (1,) * (mine.ndim - 1)
                rows[f.name] = np.where(take.reshape(shape), theirs, mine)
        return dataclasses.replace(self, **rows)

    def components(self) -> tuple[F64, F64, F64, F64, Ints]:
        """The misclosure in the basis that whitens its covariance and diagonalizes ``placing``.

        ``chi2``, the placing's share of each direction, the signed component there, each
        typed translation's unit error's components (R, N * 3, M), and the directions kept.
        """
        R, M = self.w.shape
        N = M // 2
        Q = np.einsum("rij,rjk->rik", self.proj, self.white)  # whitened, dtheta's out
        r = np.einsum("rij,rj->ri", Q, self.w)
        placing = np.einsum("rij,rjk,rlk->ril", Q, self.placing, Q)
        bias_cols = np.moveaxis(self.J[..., PLACING], 1, -1).reshape(R, N * 3, M)
        bias_cols = np.einsum("rij,rcj->rci", Q, bias_cols)
        out_share, out_z = np.zeros((R, M)), np.zeros((R, M))
        out_bias, kept = np.zeros((R, N * 3, M)), np.zeros(R, dtype=np.int_)
        chi2 = np.full(R, np.nan)
        good = np.isfinite(self.chi2)
        if good.any():
            parts = _components(r[good], self.proj[good], placing[good], self.kept[good],
                                bias_cols[good])  # fmt: skip
            chi2[good], out_share[good], out_z[good], out_bias[good], kept[good] = parts
        chi2[kept == 0] = np.nan
        return chi2, out_share, out_z, out_bias, kept


#: What every step of one adjustment shares (never merged row by row).
_FIXED = frozenset({"x0", "C", "valid", "dof"})


def _parameter_columns(conditions: TrialConditions, full: F64, theta: F64, M: int) -> F64:
    """(R, M, p) the conditions' derivatives in the parameters' steps (central differences)."""
    R = full.shape[0]
    p = conditions.parameters
    h = _PARAMETER_STEP * (1.0 + np.linalg.norm(np.nan_to_num(theta[:, :3]), axis=1))
    steps = np.zeros((2 * p, R, p))
    for j in range(p):
        steps[j, :, j], steps[p + j, :, j] = h, -h
    moved = np.concatenate([conditions.moved(theta, steps[i]) for i in range(2 * p)])
    r = conditions.conditions(np.tile(full, (2 * p, 1, 1)), moved)
    r = r.reshape(2, p, R, M)
    return np.asarray(np.moveaxis((r[0] - r[1]) / (2 * h[None, :, None]), 0, -1))


def _solve(w: F64, cov: F64, A: F64, rows: Bools, dof: Ints) -> dict[str, Any]:
    """The linearised adjustment's solution per row (NaN where it has none).

    ``rows`` (R, M): the conditions of the trial's views (the others are zero and given a
    unit weight, so every solve is regular). Returns ``white`` (``cov^-1/2``), ``proj``
    (the whitened conditions' projector away from the parameters), the directions
    ``kept``, ``dtheta``, the multipliers ``k`` and ``chi2``.
    """
    R, M = w.shape
    p = A.shape[2]
    scale = np.max(np.where(rows, np.diagonal(cov, axis1=1, axis2=2), 0.0), axis=1)
    cov = cov + np.where(~rows, np.nan_to_num(scale)[:, None], 0.0)[:, :, None] * np.eye(M)
    out: dict[str, Any] = {
        "white": np.zeros((R, M, M)),
        "proj": np.zeros((R, M, M)),
        "kept": np.zeros(R, dtype=np.int_),
        "dtheta": np.full((R, p), np.nan),
        "k": np.zeros((R, M)),
        "chi2": np.full(R, np.nan),
    }
    ok = np.isfinite(w).all(axis=1) & np.isfinite(cov).all(axis=(1, 2)) & (scale > 0)
    ok &= np.isfinite(A).all(axis=(1, 2)) & (dof > 0)
    if not ok.any():
        return out
    e, V = np.linalg.eigh(cov[ok])
    regular = e[:, 0] > _RANK_TOLERANCE * e[:, -1]
    ok[ok] = regular
    e, V = e[regular], V[regular]
    white = np.einsum("rij,rj,rkj->rik", V, 1.0 / np.sqrt(e), V)
    Aw = np.einsum("rij,rjk->rik", white, A[ok])
    ww = np.einsum("rij,rj->ri", white, w[ok])
    U, S, Vt = np.linalg.svd(Aw, full_matrices=False)
    has = S > _RANK_TOLERANCE * np.maximum(S[:, :1], 1e-300)
    U = U * has[:, None, :]
    proj = np.where(rows[ok][:, :, None], np.eye(M), 0.0) - np.einsum("rik,rjk->rij", U, U)
    left = np.einsum("rij,rj->ri", proj, ww)
    inv_s = np.where(has, 1.0 / np.where(has, S, 1.0), 0.0)
    out["white"][ok], out["proj"][ok] = white, proj
    out["kept"][ok] = np.minimum(dof[ok], rows[ok].sum(axis=1) - has.sum(axis=1))
    out["dtheta"][ok] = -np.einsum("rkj,rk,rik,ri->rj", Vt, inv_s, U, ww)
    out["k"][ok] = -np.einsum("rij,rj->ri", white, left)
    out["chi2"][ok] = (left**2).sum(axis=1)
    return out


def _per_group(values: F64, group: Ints, G: int) -> F64:
    """(R, G, S) each group's value (its first view's) from the views' (R, N, S)."""
    R, _, S = values.shape
    out = np.zeros((R, G, S))
    for g in range(G):
        mask = group == g
        first = np.argmax(mask, axis=1)
        has = mask.any(axis=1)
        out[has, g] = values[has, first[has]]
    return out


def _per_view(per_group: F64, group: Ints, base: F64) -> F64:
    """(R, N, S) the views' values: their group's (a view in no group keeps ``base``)."""
    out = base.copy()
    rows, cols = np.nonzero(group >= 0)
    out[rows, cols] = per_group[rows, group[rows, cols]]
    return out


def _range(cov: F64, dof: Ints) -> tuple[F64, F64, Bools]:
    """Each covariance's eigen-decomposition and its kept directions.

    Its ``dof`` largest (the range: directions the model gives no noise are left out,
    nothing to test there).
    """
    w, V = np.linalg.eigh(cov)  # ascending
    M = w.shape[1]
    rank = np.arange(M)[None, :] >= (M - dof)[:, None]
    keep = rank & (w > _RANK_TOLERANCE * np.abs(w[:, -1:])) & (w > 0)
    return w, V, keep


def _range_inverse(cov: F64, dof: Ints) -> F64:
    """The pseudo-inverse of each covariance over its range (:func:`_range`)."""
    w, V, keep = _range(cov, dof)
    inv = np.where(keep, 1.0 / np.where(keep, w, 1.0), 0.0)
    return np.asarray(np.einsum("rij,rj,rkj->rik", V, inv, V))


def _components(
    r: F64, cov: F64, placing: F64, dof: Ints, bias: F64
) -> tuple[F64, F64, F64, F64, Ints]:
    """Each residual in the basis that whitens ``cov`` and diagonalizes its ``placing`` part.

    Over each covariance's range (:func:`_range`), their count the chi-square's degrees of
    freedom. Returns ``chi2 = r^T Cov^+ r``, the placing's share of each direction (0..1),
    the residual's signed component there (their squares sum to ``chi2``), the columns of
    ``bias`` (R, K, M) in the same basis, and the count.
    """
    w, V, keep = _range(cov, dof)
    along = np.einsum("tji,tj->ti", V, r)
    safe = np.where(keep, w, 1.0)
    chi2 = np.where(keep, along**2 / safe, 0.0).sum(axis=1)
    scale = np.where(keep, 1.0 / np.sqrt(safe), 0.0)
    Q = V * scale[:, None, :]  # whitening of the range, zero outside it
    beta, U = np.linalg.eigh(np.einsum("tji,tjk,tkl->til", Q, placing, Q))
    z = np.einsum("tki,tk->ti", U, along * scale)
    b = np.einsum("tki,tck->tci", U, np.einsum("tji,tcj->tci", V, bias) * scale[:, None, :])
    return chi2, np.clip(beta, 0.0, 1.0), z, b, keep.sum(axis=1).astype(np.int_)


@dataclass(frozen=True, kw_only=True)
class PoseTests:
    """Baarda's w-test of every typed translation component of a trial's poses.

    Per trial, pose and component (T, N, 3): ``w2``, how much of the misclosure's
    chi-square an error in that one typed component alone explains (chi-square on 1 dof
    when none is mistyped), and ``offset``, the error it would be (session units, the
    typed minus the estimate of where the laptop stood).
    """

    w2: F64
    offset: F64


def pose_tests(m: Misclosure, lam: float | F64 = 1.0) -> PoseTests:
    """Every trial's w-tests (:class:`PoseTests`) with the placing variance times ``lam``.

    In :class:`Misclosure`'s basis the misclosure's covariance is diagonal,
    ``1 + (lam - 1) beta``: for a component's effect ``g``, ``w = g' D^-1 z /
    sqrt(g' D^-1 g)`` and the error ``g' D^-1 z / g' D^-1 g`` (Baarda's data snooping).
    """
    lam_t = np.broadcast_to(np.asarray(lam, dtype=np.float64), m.chi2.shape)
    d = 1.0 + (lam_t[:, None] - 1.0) * m.placing_share  # (T, M)
    d = np.where(d > 0, d, np.inf)
    num = np.einsum("tncm,tm->tnc", m.bias, m.z / d)
    den = np.einsum("tncm,tm->tnc", m.bias**2, 1.0 / d)
    with np.errstate(invalid="ignore", divide="ignore"):
        w2 = np.where(den > 0, num**2 / den, 0.0)
        offset = np.where(den > 0, num / den, np.nan)
    return PoseTests(w2=w2, offset=offset)
