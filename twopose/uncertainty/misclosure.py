"""Each trial's misclosure: how far its views disagree with its own estimate (issues 46, 54).

A trial with more measurements than its estimate has parameters carries **redundancy**: a
point seen from N poses has 2N pixel coordinates for 3 unknowns (2N - 3 redundant), a line
or the finger's line from N image lines has 2N numbers for 4 unknowns (2N - 4, so N >= 3).
Where its views agree with an estimate ``theta`` is stated by **condition equations**
``r(x, theta) = 0`` with the estimate's parameters explicit, two a view
(:mod:`twopose.uncertainty.misclosure_models`: the point projected; the 3-D line projected,
the centroid's distance across it and its angle), under the noise model's input
covariance ``C`` (the one the regions assume: frame scatter and detector floor, placing
sigma, calibration sigma).

**Evaluated where the adjusted inputs agree, not linearised at the typed poses** (issue
54): the misclosure is the least correction ``v`` of every input (pixels, typed poses, the
calibration) that makes the views agree with one estimate, ``min v^T C^+ v`` over ``v``
and ``theta`` together: the Gauss-Helmert adjustment, iterated from the typed inputs and
the method's own estimate, each step linearising the conditions where the last one
adjusted inputs and parameters, under step control (:mod:`twopose.uncertainty.adjustment`).
Its ``chi2 = v^T C^+ v`` is chi-square on exactly ``2 N - parameters`` degrees of freedom
when the model holds, and follows the placing error where the conditions bend (method 2's
planes at a grazing angle), where one linearisation at the typed poses does not. The
first step is the linear test at the typed poses. (Before, each step's residuals were
taken at the method's estimate re-solved from the adjusted inputs, and the directions kept
of their covariance picked ones beyond the trial's redundancy: a new user's clean trial
came out 70,610 on 2 dof where its least correction is 78, G11.)

Per trial the misclosure is kept as what every later rule needs (:class:`Misclosure`): in
the basis that whitens its covariance (``A + B``) and diagonalizes ``B`` (``B`` the placing
sigma's share, ``A`` the rest) the placing's share ``beta`` of each direction and the
misclosure's signed component ``z`` there, so that the likelihood of the placing variance's
multiplier ``lambda`` (``A + lambda B``) is a sum of scalars
(:mod:`twopose.uncertainty.placing_variance`), and each typed translation component's
effect on the misclosure in the same basis, for Baarda's w-test of a single mistyped
component (:func:`pose_tests`). What a solver predicts of a view (rays or planes) is named
by the solver table (:mod:`twopose.solve.estimate`), never by a method's name.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.adjustment import Adjustment, Problem, accepted, controlled
from twopose.uncertainty.misclosure_models import (  # the models' home; here as before
    PLANES,
    RAYS,
    MisclosureModel,
    TrialConditions,
)
from twopose.uncertainty.propagate import Shared

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

#: The adjustment's steps at most, and when it has converged (chi2's relative change).
ITERATIONS = 12
_CONVERGED = 1e-6
#: A step refused while the chi-square still changes by more than this share of itself
#: leaves the adjustment short of where the views agree.
_STALLED = 1e-3


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
    step = first = Adjustment.start(
        Problem(conditions=conditions, x0=inputs, C=input_cov, valid=valid, dof=dof, shared=shared)
    )
    done = (dof == 0) | ~np.isfinite(step.chi2)
    count = np.ones(T, dtype=np.int_)
    last = np.full(T, np.inf)  # the last step's length (in the inputs' sigmas)
    refused = np.zeros(T, dtype=bool)
    for _ in range(max(iterations, 1) - 1):
        following, length, full = controlled(step, done, last)
        took = ~done & accepted(step, following, length, last)
        change = np.abs(following.chi2 - step.chi2) / (1 + np.abs(step.chi2))
        moved = change > _CONVERGED
        # stopped short of where its views agree (not a converged step's rounding)
        refused |= ~done & ~took & ~(change <= _STALLED)
        count[took] += 1
        step = step.merged(following, took)
        last = np.where(took, full, last)
        done |= ~took | ~moved
        if done.all():
            break
    # an adjustment step control stopped short, or one that ended above what correcting
    # the pixels alone to the method's own estimate costs, has not found the least
    # correction: the first step's (the linear test at the typed poses, never above it)
    fallback = (refused | ~(step.chi2 <= first.pixels_alone())) & np.isfinite(first.chi2)
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
