"""The trials a rig's constants are fitted on (:mod:`analysis.rig.fit`): each session's ok
trials with ground truth, prepared once (detections combined per pose, the propagated
covariance and its whitening), and several sessions combined, each trial keeping its own
session's ground plane, intrinsics and units."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.methods.truth import Reported, reported
from twopose.rig.constants import ground_height, plausible_bounds
from twopose.solve.estimate import EstimateOptions, GroundSpec, ViewBatch
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session
from twopose.values.units import Units

__all__ = [
    "RigData",
    "combine",
    "prepare",
    "prepare_session",
    "prepare_trials",
    "require_trusted",
]


@dataclass(frozen=True, kw_only=True)
class RigData:
    """Sessions' ok trials with ground truth, ready for fitting: their detections
    combined into one measurement per pose (the constants do not change them), the typed
    batch, the truth, each trial's session (``origin``, an index into ``grounds``: every
    trial is solved on its own session's ground plane), each trial's whitening (from its
    propagated covariance) and whether it is trusted (no near-degeneracy warning): only
    trusted trials inform the constants, since a near-degenerate trial's linearized
    covariance understates its error and would steer the fit; every trial is corrected.
    ``units`` are the sessions' (one for all), ``image_size`` the smallest image."""

    method: Method
    trial_ids: tuple[int, ...]
    batch: ViewBatch
    truth: F64  # (T, 2, 3)
    grounds: tuple[GroundSpec | None, ...]  # per session
    origin: NDArray[np.int_]  # (T,): each trial's session, an index into grounds
    whiten: F64  # (T, 3, 3): residual -> whitened residual (pseudo-inverse square root)
    cov: F64  # (T, 3, 3): each trial's propagated (random) covariance
    trusted: NDArray[np.bool_]  # (T,): no near-degeneracy warning
    options: EstimateOptions = field(default_factory=EstimateOptions)
    units: Units | None = None
    image_size: tuple[int, int] | None = None
    sessions: tuple[str, ...] = ()  # the sessions' names, where known

    def subset(self, rows: Sequence[int]) -> RigData:
        idx = np.asarray(rows, dtype=int)
        return dataclasses.replace(
            self,
            trial_ids=tuple(self.trial_ids[i] for i in idx),
            batch=self.batch.rows(idx),
            truth=self.truth[idx],
            origin=self.origin[idx],
            whiten=self.whiten[idx],
            cov=self.cov[idx],
            trusted=self.trusted[idx],
        )

    def fitting(self) -> RigData:
        """The trials that inform the constants (the trusted ones)."""
        return self.subset([int(i) for i in np.flatnonzero(self.trusted)])

    def bounds(self) -> tuple[F64, F64]:
        """Where the fit may look: the plausible constants (:func:`twopose.rig.
        plausible_bounds`) for these sessions' units, lowest ground and smallest image
        (lengths taken in inches when the units are not known)."""
        heights = [h for h in (ground_height(g) for g in self.grounds) if h is not None]
        return plausible_bounds(
            self.units or Units.IN, min(heights) if heights else None, self.image_size
        )


def prepare(estimate: SessionEstimate, reported_: Reported | None = None) -> RigData:
    """The trials of one session's estimate that can inform the constants: ok, with
    ground truth (at least 2 trusted)."""
    return require_trusted(prepare_session(estimate, reported_))


def require_trusted(data: RigData | None) -> RigData:
    """``data``, if it has the 2 trusted trials a fit needs."""
    trusted = 0 if data is None else int(data.trusted.sum())
    if data is None or trusted < 2:
        which = "these sessions have" if data and len(data.grounds) > 1 else "this session has"
        raise InputValueError(
            "the rig needs at least 2 ok trials with ground truth and without a "
            f"near-degeneracy warning, {which} {trusted}"
        )
    return data


def prepare_session(estimate: SessionEstimate, reported_: Reported | None = None) -> RigData | None:
    """A session's ok trials with ground truth (None: it has none), from its one estimate
    (:func:`twopose.solve.session.estimate_session`), each with its reported point's
    covariance (``reported_``, computed here when not given:
    :func:`twopose.methods.truth.reported`)."""
    trials, est = estimate.trials, estimate.estimates
    if not trials.views:
        return None
    truth = trials.truth
    keep = [i for i in range(len(trials)) if est.status[i] == "ok" and np.isfinite(truth[i]).all()]
    if not keep:
        return None
    cov = (reported_ or reported(estimate)).cov
    sizes = [v.width_height for i in keep for v in trials.views[i]]
    return RigData(
        method=trials.method,
        trial_ids=tuple(int(trials.trial_ids[i]) for i in keep),
        batch=ViewBatch.of(
            [estimate.measurements[i] for i in keep], [trials.views[i] for i in keep]
        ),
        truth=truth[keep],
        grounds=(trials.ground,),
        origin=np.zeros(len(keep), dtype=int),
        whiten=np.stack([_whitening(cov[i]) for i in keep]),
        cov=cov[keep],
        trusted=np.array([estimate.warnings[i] == "" for i in keep], dtype=bool),
        options=estimate.options,
        units=Units(trials.units),
        image_size=(min(w for w, _ in sizes), min(h for _, h in sizes)),
    )


def prepare_trials(trials: SessionTrials, options: EstimateOptions | None = None) -> RigData:
    """:func:`prepare` of a session's trials, estimated here (the rig fit from a notebook)."""
    return prepare(estimate_session(trials, options or EstimateOptions()))


def combine(parts: Sequence[RigData]) -> RigData:
    """One :class:`RigData` of several sessions' (one method, one units), in the order
    given; each trial keeps its own session's ground plane."""
    if len({p.method for p in parts}) != 1 or len({p.units for p in parts}) != 1:
        raise InputValueError("the rig's sessions must share their method and units")
    width = max(p.batch.valid.shape[1] for p in parts)
    batches = [_padded(p.batch, width) for p in parts]
    grounds = tuple(g for p in parts for g in p.grounds)
    offsets = np.cumsum([0] + [len(p.grounds) for p in parts])
    sizes = [p.image_size for p in parts if p.image_size is not None]
    return dataclasses.replace(
        parts[0],
        trial_ids=tuple(t for p in parts for t in p.trial_ids),
        batch=ViewBatch(
            inputs=np.concatenate([b.inputs for b in batches]),
            intrinsics=np.concatenate([b.intrinsics for b in batches]),
            valid=np.concatenate([b.valid for b in batches]),
        ),
        truth=np.concatenate([p.truth for p in parts]),
        grounds=grounds,
        origin=np.concatenate([p.origin + o for p, o in zip(parts, offsets, strict=False)]),
        whiten=np.concatenate([p.whiten for p in parts]),
        cov=np.concatenate([p.cov for p in parts]),
        trusted=np.concatenate([p.trusted for p in parts]),
        image_size=(min(w for w, _ in sizes), min(h for _, h in sizes)) if sizes else None,
        sessions=tuple(s for p in parts for s in p.sessions),
    )


def _padded(batch: ViewBatch, width: int) -> ViewBatch:
    """The batch padded to ``width`` views per row (as :meth:`ViewBatch.of` pads)."""
    T, N, K = batch.inputs.shape
    inputs = np.zeros((T, width, K))
    inputs[..., :3] = np.nan
    intrinsics = np.tile([1.0, 1.0, 0.0, 0.0], (T, width, 1))
    valid = np.zeros((T, width), dtype=bool)
    inputs[:, :N], intrinsics[:, :N], valid[:, :N] = batch.inputs, batch.intrinsics, batch.valid
    return ViewBatch(inputs=inputs, intrinsics=intrinsics, valid=valid)


#: The variance a direction without any gets, relative to the largest: a method 2
#: estimate has none along the ground's normal (it lies on the typed plane), yet its truth
#: can sit off that plane (a ground height error), and that must count. (10% of the
#: largest sigma)^2 weighs the normal, without letting the true points' own placing error
#: there outweigh the plane's. Directions the covariance spans keep their own variance.
_NULL_VARIANCE = 1e-2


def _whitening(cov: F64) -> F64:
    """``W`` with ``W r`` of unit covariance (null directions: see above)."""
    if not np.isfinite(cov).all():
        return np.zeros((3, 3))
    w, V = np.linalg.eigh(cov)
    largest = max(float(w.max()), 1e-300)
    w = np.where(w > 1e-9 * largest, w, _NULL_VARIANCE * largest)
    return np.asarray((V / np.sqrt(w)).T)
