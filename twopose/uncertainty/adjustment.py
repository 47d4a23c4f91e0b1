"""The Gauss-Helmert adjustment of a batch of trials' misclosures (issue 54, G11).

A trial's views agree with an estimate ``theta`` where its conditions ``r(x, theta) = 0``
hold (:mod:`twopose.uncertainty.misclosure_models`). The misclosure is the least
correction ``v`` of every input (pixels, typed poses, the calibration), ``min v^T C^+ v``
over ``v`` and ``theta`` together. Each step linearises the conditions at the inputs and
the parameters the last one adjusted (the typed inputs and the method's own estimate
first): ``B v + A dtheta + w = 0``, ``B`` and ``A`` the derivatives in the inputs and the
parameters, ``w`` the conditions' values referred back to the typed inputs. With
``cov = B C B^T`` (regular: every condition carries its view's pixels' noise) and ``A``
projected out of the conditions whitened by ``cov^-1/2``, ``chi2 = v^T C^+ v`` is
chi-square on exactly ``2 N - parameters`` directions; ``dtheta`` and ``v = C B^T k``
are the step (Koch, *Parameter Estimation and Hypothesis Testing in Linear Models*, the
mixed model).

**Step control**: a step no shorter than the last (the iteration walking off, not closing
in) is halved, at most :data:`HALVINGS` times, and then the adjustment stops where it is;
and one that ends above what closing every view by its own pixels alone to the method's
own estimate costs (:meth:`Adjustment.pixels_alone`: a correction that closes the views
exactly, the conditions being linear in the pixels) has not found the least correction and
gives way to its first step, which never exceeds it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.misclosure_models import TrialConditions
from twopose.uncertainty.propagate import PLACING, Shared, jacobians

__all__ = ["HALVINGS", "RISE", "Adjustment", "Problem", "accepted", "controlled"]

#: Eigen-directions of a covariance under this share of its largest are outside its range.
_RANK_TOLERANCE = 1e-9
#: A step longer than the last (it would walk off) is halved at most this many times,
#: then the adjustment stops at the last step it took.
HALVINGS = 4
#: A step whose chi-square is more than this many times the last's is halved.
RISE = 2.0
#: The parameters' difference step, a share of the estimate's distance from the origin.
_PARAMETER_STEP = 1e-6


def accepted(step: Adjustment, following: Adjustment, length: F64, last: F64) -> Bools:
    """(R,) whether ``following`` (``length`` from ``step``) is a step the adjustment takes.

    Not one no shorter than the last (``last``: the iteration walking off rather than
    closing in), nor one whose linearisation fails, nor one whose chi-square is more than
    :data:`RISE` times the last's (a step into where the conditions bend away: the least
    correction's chi-square can rise as the linearisation closes in, never leap).
    """
    rise = following.chi2 <= RISE * step.chi2 + 1.0
    return np.asarray(np.isfinite(following.chi2) & (length <= last) & rise)


def controlled(step: Adjustment, done: Bools, last: F64) -> tuple[Adjustment, F64, F64]:
    """The adjustment's next step under step control, its length and the full step's.

    A step it would not take (:func:`accepted`) is halved, at most :data:`HALVINGS` times;
    the next step is held to the full step's length (``last``), not the halved one's (a
    halving is no promise that the steps after it close in as fast).
    """
    fraction = np.ones(len(done))
    following = step.toward(fraction)
    length = step.length(following)
    full = length
    for _ in range(HALVINGS):
        redo = ~done & ~accepted(step, following, length, last)
        if not redo.any():
            break
        fraction = np.where(redo, fraction / 2, fraction)
        # the rows halved anew; every other keeps the step it has (not this one's: a row
        # the batch did not halve would stop where it stands, its next step unmade)
        following = following.merged(step.toward(fraction), redo)
        length = np.where(redo, step.length(following), length)
    return following, length, full


@dataclass(frozen=True, kw_only=True)
class Problem:
    """What every step of one adjustment shares.

    The batch's conditions, its typed inputs ``x0`` (R, N, 9) and their covariance ``C``,
    valid views, each trial's ``dof`` and the shared inputs
    (:class:`twopose.uncertainty.propagate.Shared`, or None).
    """

    conditions: TrialConditions
    x0: F64
    C: F64
    valid: Bools
    dof: Ints
    shared: Shared | None


@dataclass(frozen=True, kw_only=True)
class Adjustment:
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

    problem: Problem
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
    def start(cls, problem: Problem) -> Adjustment:
        """The first step: linearised at the typed inputs and the method's estimate."""
        s0 = None if problem.shared is None else problem.shared.values
        x0 = problem.x0
        full = x0 if s0 is None else np.concatenate([x0, s0], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            theta = problem.conditions.estimate(full)
        return cls._at(problem, x0, s0, theta)

    @classmethod
    def _at(cls, problem: Problem, x: F64, s: F64 | None, theta: F64) -> Adjustment:
        conditions, x0, C, shared = problem.conditions, problem.x0, problem.C, problem.shared
        N = x.shape[1]
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
        solved = _solve(w, cov, A, np.repeat(problem.valid, 2, axis=1), problem.dof)
        return cls(problem=problem,
                   x=x, s=s, theta=theta, w=w, J=J, Js=Js, placing=placing, **solved)  # fmt: skip

    def toward(self, fraction: F64) -> Adjustment:
        """The step linearised where this one's solution lies (``fraction`` of the way).

        The inputs ``x0 + v``, ``v = C B^T k`` (the least correction that closes the
        linearised views) and the parameters ``theta + dtheta``.
        """
        f = fraction[:, None, None]
        v = np.nan_to_num(np.einsum("rnjk,rmnk,rm->rnj", self.problem.C, self.J, self.k))
        x = np.where(
            np.isfinite(self.problem.x0),
            self.x + f * (self.problem.x0 + v - self.x),
            self.problem.x0,
        )
        s = self.s
        if self.problem.shared is not None and self.Js is not None and s is not None:
            G = self.problem.shared.cov.shape[1]
            vs = np.einsum("rgsq,rmgq,rm->rgs", self.problem.shared.cov, self.Js, self.k)
            s0 = _per_group(self.problem.shared.values, self.problem.shared.group, G)
            s = s + f * (
                _per_view(s0 + vs, self.problem.shared.group, self.problem.shared.values) - s
            )
        theta = self.problem.conditions.moved(
            self.theta, fraction[:, None] * np.nan_to_num(self.dtheta)
        )
        return Adjustment._at(self.problem, x, s, theta)

    def length(self, other: Adjustment) -> F64:
        """(R,) how far ``other``'s inputs lie from this one's, in the inputs' sigmas."""
        total = _in_sigmas(other.x - self.x, np.diagonal(self.problem.C, axis1=2, axis2=3))
        if self.problem.shared is not None and self.s is not None and other.s is not None:
            G = self.problem.shared.cov.shape[1]
            moved = _per_group(other.s, self.problem.shared.group, G) - _per_group(
                self.s, self.problem.shared.group, G
            )
            total = total + _in_sigmas(
                moved, np.diagonal(self.problem.shared.cov, axis1=2, axis2=3)
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
        S = np.einsum("nrij,rnjk,nrlk->nril", G, self.problem.C[..., :3, :3], G)
        g = np.moveaxis(self.w.reshape(R, N, 2), 1, 0)
        det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
        scale = np.einsum("nrii->nr", S) ** 2
        regular = det > _RANK_TOLERANCE * scale
        inv = np.stack([np.stack([S[..., 1, 1], -S[..., 0, 1]], -1),
                        np.stack([-S[..., 1, 0], S[..., 0, 0]], -1)], -2)  # fmt: skip
        inv = inv / np.where(regular, det, 1.0)[..., None, None]
        cost = np.einsum("nri,nrij,nrj->nr", g, inv, g)
        used = self.problem.valid.T
        cost = np.where(used, np.where(regular, cost, np.inf), 0.0).sum(axis=0)
        return np.asarray(np.where(np.isfinite(self.chi2), cost, np.inf))

    def merged(self, other: Adjustment, take: Bools) -> Adjustment:
        """The step with ``other``'s rows where ``take`` (a failed step keeps its last)."""
        if take.all():
            return other
        rows: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            mine, theirs = getattr(self, f.name), getattr(other, f.name)
            if isinstance(mine, np.ndarray):
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


def _in_sigmas(change: F64, variance: F64) -> F64:
    """(R,) the sum of squares of ``change`` (R, ., .) in sigmas (exact inputs: none)."""
    sigma = np.sqrt(np.clip(variance, 0.0, None))
    d = np.where(sigma > 0, np.nan_to_num(change) / np.where(sigma > 0, sigma, 1.0), 0.0)
    return np.asarray((d**2).sum(axis=(1, 2)))


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
    has = _RANK_TOLERANCE * np.maximum(S[:, :1], 1e-300) < S
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
