"""The rig's constants' covariance carried into every region (issue 54, item 5).

``run --rig`` and ``twopose-record new --rig`` correct every view by constants a board (or
target trials) estimated, and an estimate is only as good as they are: each trial's point
moves with them. To first order the estimate ``x(theta)`` of the constants ``theta`` has
the covariance ``J C J^T`` beside the views' own, ``J = dx / dtheta`` and ``C`` the
constants' covariance (:class:`twopose.rig.RigCovariance`, the rig file's
``[covariance]``: a board finds ``offset_x`` and ``principal_dx_px`` strongly correlated,
so the whole matrix is carried, never its diagonal alone).

``J`` is the derivative of the very estimate a region is drawn for (the thesis' solver,
:func:`twopose.solve.estimate.thesis_estimate`, a line's point nearest its reference), by
central differences: each fitted scalar moved by a small multiple of its sigma, the
batch's views corrected by that change (:meth:`twopose.rig.RigConstants.true_poses`,
``true_intrinsics``; the ground moved by a ground height error), all copies solved in
one vectorised call. The views given are already corrected by the constants themselves
(or typed, for guidance's predictions): the change is applied about them, which is the
derivative at the constants to first order (the constants are small: a degree, a few
per cent). No I/O.
"""

from __future__ import annotations

import numpy as np

from twopose.arrays import F64
from twopose.methods.specs import Method
from twopose.rig.constants import (
    SCALARS,
    RigConstants,
    RigCovariance,
    angles_deg_from_rotation,
    true_ground,
)
from twopose.solve.estimate import EstimateOptions, GroundSpec, ViewBatch, thesis_estimate
from twopose.uncertainty.propagate import Propagated

__all__ = [
    "REL_STEP",
    "RIG_INPUT",
    "carried_covariance",
    "corrected_batch",
    "corrected_inputs",
    "rig_carried",
    "with_carried",
    "with_rig_dominance",
]

#: The central differences' step, in each scalar's own sigma.
REL_STEP = 1e-2
_GROUND = SCALARS.index("ground_height_error")


def corrected_batch(batch: ViewBatch, rig: RigConstants) -> ViewBatch:
    """The batch with every view's typed pose and intrinsics corrected by ``rig``."""
    x = corrected_inputs(batch, rig)
    return ViewBatch(inputs=x[..., :9], intrinsics=x[..., 9:], valid=batch.valid)


def corrected_inputs(batch: ViewBatch, rig: RigConstants) -> F64:
    """(T, N, 13) each view's inputs and then its intrinsics, corrected by ``rig``.

    The layout :func:`twopose.solve.estimate.thesis_estimate` takes with the intrinsics as shared
    inputs (padding views keep theirs).
    """
    inputs = batch.inputs.copy()
    t, R = rig.true_poses(inputs[..., 3:6], inputs[..., 6:9])
    inputs[..., 3:6] = t
    inputs[..., 6:9] = angles_deg_from_rotation(R)
    intrinsics = np.where(
        batch.valid[..., None], rig.true_intrinsics(batch.intrinsics), batch.intrinsics
    )
    return np.concatenate([inputs, intrinsics], axis=-1)


def carried_covariance(
    method: Method,
    batch: ViewBatch,
    ground: GroundSpec | None,
    options: EstimateOptions,
    covariance: RigCovariance,
    reference: F64,
) -> F64:
    """(T, 3, 3) the constants' covariance carried to each row's estimate, ``J C J^T``.

    ``batch`` (T rows) and ``ground`` as the estimate was solved; ``reference`` (T, 3)
    where a line reports its point (points and ground points ignore it). A row whose
    perturbed estimate fails is NaN (a region that cannot be drawn, never a narrow one).
    """
    T = batch.valid.shape[0]
    names = covariance.names
    C = covariance.array()
    sigma = np.sqrt(np.clip(np.diag(C), 0.0, None))
    J = np.zeros((T, 3, len(names)))
    steps = REL_STEP * sigma
    moved = [k for k, s in enumerate(steps) if s > 0]
    views = [k for k in moved if SCALARS.index(names[k]) != _GROUND]
    if views:
        estimate = thesis_estimate(method, batch, ground, options, reference)
        copies = []
        for sign in (1.0, -1.0):
            for k in views:
                copies.append(corrected_inputs(batch, _delta(names[k], sign * steps[k])))
        solved = estimate(np.concatenate(copies)).reshape(2, len(views), T, 3)
        with np.errstate(invalid="ignore"):
            for j, k in enumerate(views):
                J[:, :, k] = (solved[0, j] - solved[1, j]) / (2.0 * steps[k])
    for k in moved:
        if SCALARS.index(names[k]) == _GROUND and ground is not None:
            J[:, :, k] = _ground_column(method, batch, ground, options, reference, steps[k])
    carried: F64 = np.einsum("tik,kl,tjl->tij", J, C, J)
    return carried


def _delta(name: str, value: float) -> RigConstants:
    """Nominal constants but ``name`` moved by ``value``."""
    v = RigConstants().vector()
    v[SCALARS.index(name)] += value
    return RigConstants.from_vector(v)


def _ground_column(
    method: Method,
    batch: ViewBatch,
    ground: GroundSpec,
    options: EstimateOptions,
    reference: F64,
    step: float,
) -> F64:
    """(T, 3) the estimate's derivative with respect to the ground height error."""
    x = np.concatenate([batch.inputs, batch.intrinsics], axis=-1)
    ends = []
    for sign in (1.0, -1.0):
        moved = true_ground(ground, _delta("ground_height_error", sign * step))
        ends.append(thesis_estimate(method, batch, moved, options, reference)(x))
    column: F64 = (ends[0] - ends[1]) / (2.0 * step)
    return column


def rig_carried(
    options: EstimateOptions,
    method: Method,
    batch: ViewBatch,
    ground: GroundSpec | None,
    reference: F64,
) -> F64 | None:
    """(T, 3, 3) :func:`carried_covariance` of the options' rig (``noise.rig``).

    None without one: what :mod:`twopose.solve.session` asks of every region.
    """
    if options.noise.rig is None:
        return None
    return carried_covariance(method, batch, ground, options, options.noise.rig, reference)


def with_carried(
    cov: F64, model: F64, carried: F64 | None, direction: F64 | None
) -> tuple[F64, F64, F64 | None]:
    """A region's covariance (and its model's) with the carried covariance added.

    A line's across the line, as its point's; returns the part added too (unchanged
    without a rig).
    """
    if carried is None:
        return cov, model, None
    if direction is not None:
        across = np.eye(3) - np.einsum("ti,tj->tij", direction, direction)
        carried = across @ carried @ across
    return cov + carried, model + carried, carried


#: What ``dominant_input`` says when the rig's constants dominate a region.
RIG_INPUT = "rig constants"


def with_rig_dominance(
    names: list[str], share: F64, propagated: Propagated, carried: F64 | None
) -> tuple[list[str], F64]:
    """The dominant input and its share, the rig's constants competing with the views'.

    ``names`` and ``share`` as :func:`twopose.uncertainty.propagate.dominant_input` gives them over
    the views' inputs (``propagated``); ``carried`` (T, 3, 3) the constants' part: its
    trace against the largest input group's variance, every share of the whole (None: no
    rig, unchanged).
    """
    if carried is None:
        return names, share
    random = propagated.variance_by_group.sum(axis=(1, 2))
    if propagated.shared_variance is not None:
        random = random + propagated.shared_variance
    rig = np.trace(carried, axis1=1, axis2=2)
    best = np.nan_to_num(share) * random
    wins = np.isfinite(rig) & (rig > best)
    with np.errstate(invalid="ignore", divide="ignore"):
        total = random + np.where(np.isfinite(rig), rig, 0.0)
        new_share = np.where(wins, rig, best) / total
    out_names = [RIG_INPUT if w else n for n, w in zip(names, wins, strict=True)]
    return out_names, np.where(np.isfinite(share) | wins, new_share, np.nan)
