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
    "RANGE_GAP",
    "RAYS",
    "Misclosure",
    "MisclosureModel",
    "PoseTests",
    "misclosures",
    "pose_tests",
]

#: Each view's residuals from the (perturbed) inputs ``x`` (R, N, 9[+S]), their cameras
#: ``P`` (R, N, 3, 4) and valid views (R, N): (R, N, 2), zero in a padding view.
Residuals = Callable[[F64, F64, Bools], F64]
#: Eigen-directions of Cov(r) under this share of its largest are outside its range.
_RANK_TOLERANCE = 1e-9
#: The adjustment's steps at most, and when it has converged (chi2's relative change).
ITERATIONS = 6
_CONVERGED = 1e-6
#: The range of Cov(r) is known when its smallest kept eigenvalue is this many times the
#: largest one left out. A trial whose views nearly coincide (method 2's planes about one
#: line) leaks its estimate's ill-determined directions into Cov(r) at the size of its
#: noise: 1.4 times apart on a clean trial whose misclosure then read 1780, and after
#: diverging steps 70,610, on 2 dof (its views' least correction gives about 60: a new
#: #: user's r6 G11). Such a trial is not tested (no misclosure: "I can't"), and a step that
#: reaches such inputs is not taken. Over the benchmark's sessions the gap is 12 or more
#: (point: 390); over a new user's clean sessions at 1.6x typed, under 2 in 0.6% of method
#: 2's adjustments' steps, none of the line's.
RANGE_GAP = 2.0


@dataclass(frozen=True, kw_only=True)
class MisclosureModel:
    """What a solver's estimate predicts of each view, and how many parameters it has."""

    residuals: Residuals
    #: The estimate's degrees of freedom: a point 3, a 3-D line 4.
    parameters: int


def _project(P: F64, X: F64) -> F64:
    """(R, N, 2) the points ``X`` (R, 3) (or (R, N, 3)) in each view's pixels."""
    Xh = np.concatenate([X, np.ones((*X.shape[:-1], 1))], axis=-1)
    if Xh.ndim == 2:
        Xh = np.broadcast_to(Xh[:, None], (*P.shape[:2], 4))
    h = np.einsum("rnij,rnj->rni", P, Xh)
    return np.asarray(h[..., :2] / h[..., 2:3])


def ray_residuals(x: F64, P: F64, valid: Bools) -> F64:
    """Each view's measured pixel minus the thesis' point projected there (R, N, 2)."""
    X = triangulate_points(x[..., :2], P, valid=valid).point_grid
    r = x[..., :2] - _project(P, X)
    return np.asarray(np.where(valid[..., None], r, 0.0))


def plane_residuals(x: F64, P: F64, valid: Bools) -> F64:
    """Each view's centroid across, and angle against, the thesis' 3-D line projected.

    (R, N, 2): the measured centroid's signed distance (px) from the projected line and
    the measured angle minus the projected line's (degrees, lines have no arrow).
    """
    line = triangulate_lines(image_lines(x[..., :2], x[..., 2]), P, valid=valid)
    a = _project(P, line.point_grid)
    b = _project(P, line.point_grid[:, None] + line.direction_grid[:, None])
    d = b - a
    length = np.linalg.norm(d, axis=-1, keepdims=True)
    normal = np.stack([-d[..., 1], d[..., 0]], axis=-1) / length
    across = np.einsum("rni,rni->rn", x[..., :2] - a, normal)
    angle = wrap_theta_deg(x[..., 2] - np.degrees(np.arctan2(d[..., 1], d[..., 0])))
    r = np.stack([across, angle], axis=-1)
    return np.asarray(np.where(valid[..., None], r, 0.0))


#: A point's rays: its projection in every view.
RAYS = MisclosureModel(residuals=ray_residuals, parameters=3)
#: A line's planes (the fixed line, method 2's finger): the line projected in every view.
PLANES = MisclosureModel(residuals=plane_residuals, parameters=4)


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
    residuals: Callable[[F64], F64],
    inputs: F64,
    input_cov: F64,
    valid: Bools,
    parameters: int,
    *,
    shared: Shared | None = None,
    iterations: int = ITERATIONS,
) -> Misclosure:
    """Every trial's misclosure at its adjusted inputs, vectorized over trials.

    ``residuals`` maps stacked (perturbed) inputs (R T, N, 9[+S]) to (R T, N, 2) as
    :func:`twopose.uncertainty.propagate.propagate` calls an estimate; ``inputs`` (T, N, 9),
    ``input_cov`` (T, N, 9, 9), ``shared`` as there; ``parameters``: the estimate's own.
    ``iterations``: the adjustment's steps at most (1: linearised at the typed inputs).
    """
    T, N, _ = inputs.shape
    M = 2 * N
    dof = np.clip(2 * valid.sum(axis=1) - parameters, 0, None).astype(np.int_)
    out = Misclosure.none(T, N)
    if not (dof > 0).any():
        return out
    # every row goes through (``residuals`` is bound to the whole batch); one without
    # redundancy is done from the start
    step = _Adjustment.start(residuals, inputs, input_cov, dof, shared)
    done = dof == 0
    count = np.ones(T, dtype=np.int_)
    for _ in range(max(iterations, 1) - 1):
        following = step.next()
        count[~done] += 1
        moved = np.abs(following.chi2 - step.chi2) > _CONVERGED * (1 + np.abs(step.chi2))
        # a step whose range is not known (RANGE_GAP) has no chi2: the one before is kept
        usable = np.isfinite(following.chi2) & ~done
        step = step.merged(following, usable)
        done |= ~usable | ~moved
        if done.all():
            break
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


@dataclass(frozen=True, kw_only=True)
class _Adjustment:
    """One step of the Gauss-Helmert adjustment of a batch of trials (R rows).

    ``x``/``s``: the inputs and shared values it linearises at (the typed ones first);
    ``w``: the misclosure referred back to the observations, ``r(x) + J (x0 - x)``;
    ``cov`` its covariance ``J C J^T`` (+ the shared part), ``placing`` that of the typed
    translations alone; ``chi2 = w^T cov^+ w`` over the trial's ``dof`` directions.
    """

    residuals: Callable[[F64], F64]
    x0: F64
    C: F64
    dof: Ints
    shared: Shared | None
    x: F64
    s: F64 | None
    w: F64
    J: F64
    Js: F64 | None
    cov: F64
    placing: F64
    chi2: F64

    @classmethod
    def start(
        cls, residuals: Callable[[F64], F64], x0: F64, C: F64, dof: Ints, shared: Shared | None
    ) -> _Adjustment:
        """The first step: linearised at the typed inputs."""
        s0 = None if shared is None else shared.values
        return cls._at(residuals, x0, C, dof, shared, x0, s0)

    @classmethod
    def _at(
        cls,
        residuals: Callable[[F64], F64],
        x0: F64,
        C: F64,
        dof: Ints,
        shared: Shared | None,
        x: F64,
        s: F64 | None,
    ) -> _Adjustment:
        R, N, _ = x.shape
        M = 2 * N
        here = None if shared is None or s is None else dataclasses.replace(shared, values=s)

        def flat(values: F64) -> F64:
            return residuals(values).reshape(values.shape[0], M)

        full = x if s is None else np.concatenate([x, s], axis=-1)
        r = flat(full)
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
        finite = np.isfinite(w).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
        chi2 = np.full(R, np.nan)
        if finite.any():
            pinv = _range_inverse(cov[finite], dof[finite])
            known = np.einsum("rij->r", np.abs(pinv)) > 0  # its range known (_range)
            said = np.einsum("ri,rij,rj->r", w[finite], pinv, w[finite])
            chi2[finite] = np.where(known, said, np.nan)
        return cls(residuals=residuals, x0=x0, C=C, dof=dof, shared=shared, x=x, s=s, w=w,
                   J=J, Js=Js, cov=cov, placing=placing, chi2=chi2)  # fmt: skip

    def next(self) -> _Adjustment:
        """The step linearised at the inputs this one adjusts.

        They are ``x0 + v``, ``v = -C J^T cov^+ w``: the least correction that closes the
        linearised views.
        """
        good = np.isfinite(self.chi2)
        lam = np.zeros_like(self.w)
        if good.any():
            lam[good] = np.einsum(
                "rij,rj->ri", _range_inverse(self.cov[good], self.dof[good]), self.w[good]
            )
        v = np.nan_to_num(-np.einsum("rnjk,rmnk,rm->rnj", self.C, self.J, lam))
        x = np.where(np.isfinite(self.x0), self.x0 + v, self.x0)
        s = self.s
        if self.shared is not None and self.Js is not None and s is not None:
            G = self.shared.cov.shape[1]
            vs = -np.einsum("rgsq,rmgq,rm->rgs", self.shared.cov, self.Js, lam)
            s0 = _per_group(self.shared.values, self.shared.group, G)
            s = _per_view(s0 + vs, self.shared.group, self.shared.values)
        return _Adjustment._at(self.residuals, self.x0, self.C, self.dof, self.shared, x, s)

    def merged(self, other: _Adjustment, take: Bools) -> _Adjustment:
        """The step with ``other``'s rows where ``take`` (a failed step keeps its last)."""
        if take.all():
            return other
        rows: dict[str, Any] = {}
        for name in ("x", "s", "w", "J", "Js", "cov", "placing", "chi2"):
            mine, theirs = getattr(self, name), getattr(other, name)
            if isinstance(mine, np.ndarray):
                shape = (-1,) + (1,) * (mine.ndim - 1)
                rows[name] = np.where(take.reshape(shape), theirs, mine)
        return dataclasses.replace(self, **rows)

    def components(self) -> tuple[F64, F64, F64, F64, Ints]:
        """The misclosure in the basis that whitens ``cov`` and diagonalizes ``placing``.

        ``chi2``, the placing's share of each direction, the signed component there, each
        typed translation's unit error's components (R, N * 3, M), and the directions kept.
        """
        R, M = self.w.shape
        N = M // 2
        bias_cols = np.moveaxis(self.J[..., PLACING], 1, -1).reshape(R, N * 3, M)
        out_share, out_z = np.zeros((R, M)), np.zeros((R, M))
        out_bias, kept = np.zeros((R, N * 3, M)), np.zeros(R, dtype=np.int_)
        chi2 = np.full(R, np.nan)
        good = np.isfinite(self.chi2)
        if good.any():
            parts = _components(self.w[good], self.cov[good], self.placing[good], self.dof[good],
                                bias_cols[good])  # fmt: skip
            chi2[good], out_share[good], out_z[good], out_bias[good], kept[good] = parts
        chi2[kept == 0] = np.nan
        return chi2, out_share, out_z, out_bias, kept


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
    nothing to test there); none where the range is not known (:data:`RANGE_GAP`): the
    trial is not tested, rather than tested along directions its noise does not span.
    """
    w, V = np.linalg.eigh(cov)  # ascending
    M = w.shape[1]
    rank = np.arange(M)[None, :] >= (M - dof)[:, None]
    keep = rank & (w > _RANK_TOLERANCE * np.abs(w[:, -1:])) & (w > 0)
    # the range known: its smallest kept eigenvalue well above the largest left out
    rows = np.arange(len(w))
    first = np.clip(M - dof, 0, M - 1)
    kept_min = w[rows, first]
    left_max = np.where(M - dof > 0, np.maximum(w[rows, np.clip(M - dof - 1, 0, M - 1)], 0), 0)
    keep &= (kept_min > RANGE_GAP * left_max)[:, None]
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
