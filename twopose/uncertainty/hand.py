"""An operator's hand, pooled across sessions typed at different resolutions (issue 54).

A session's multiplier ``lambda`` is relative to the placing sigma its regions start from,
its **base**: the poses' typed resolution, or a board's ``[placing]``. The operator's hand
is the placing variance itself, ``lambda * base^2``, in one unit (inches) whatever each
session typed. So an operator's sessions pool as placing variances: each one's misclosure
components are re-expressed relative to one reference base (:func:`rebased`, exact: a
direction's variance ``1 - beta + lambda beta`` is the same variance at ``lambda' =
lambda (s / r)^2``, renormalised), and each session's prior is the pooled hand as a
multiplier of its own base (:func:`on_one_base`). Pooling the multipliers themselves
made a 0.16 in hand typed 0.04 in on two days take the 1x of the days typed right, and
flagged every clean trial of those two days as a typo (the new user's r5 F1).

A session whose base is not known (an older noise file's entry, ``NaN``) cannot be
converted: beside sessions whose base is known it is left out of the pool, never
misused (the caller says so).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol, TypeVar

import numpy as np

if TYPE_CHECKING:
    from twopose.arrays import F64, Ints
    from twopose.uncertainty.noise import PlacingPrior


class _Statistics(Protocol):
    """What is read of a session's statistics.

    Those of :class:`twopose.uncertainty.operator_pool.SessionNoise` (a dataclass; not
    imported: it imports this module).
    """

    @property
    def chi2(self) -> F64: ...
    @property
    def dof(self) -> Ints: ...
    @property
    def share(self) -> F64: ...
    @property
    def z2(self) -> F64: ...
    @property
    def placing_in(self) -> float: ...


SessionNoise = TypeVar("SessionNoise", bound=_Statistics)

__all__ = [
    "base_placing_in",
    "on_one_base",
    "pooled_trials",
    "prior_on_own_base",
    "rebased",
    "same_base",
]

#: Two bases closer than this (relative) are one: no conversion.
_SAME = 1e-9


def base_placing_in(sigmas: Sequence[float], inches_per_unit: float) -> float:
    """A session's base in inches: the RMS of its poses' placing sigmas (``NaN``: none).

    Exact when every pose typed one resolution (the common case); a session whose poses
    typed several is pooled as if its hand were their RMS.
    """
    values = np.asarray([s for s in sigmas if s is not None], dtype=np.float64)
    values = values[np.isfinite(values) & (values > 0)]
    if not values.size:
        return math.nan
    return float(math.sqrt(float(np.mean(values**2))) * inches_per_unit)


def rebased(stats: SessionNoise, base_in: float) -> SessionNoise:
    """``stats`` with its components relative to ``base_in`` (inches) instead of its own.

    ``c = (base_in / own)^2``; each direction's share ``beta`` becomes ``c beta / n`` and
    its squared component ``z^2 / n``, ``n = 1 - beta + c beta``: the same likelihood of the
    placing variance (up to a constant). ``chi2`` (its own typed model's test) is kept.
    """
    own = stats.placing_in
    if not (math.isfinite(own) and math.isfinite(base_in)) or abs(own / base_in - 1) < _SAME:
        return stats
    c = (base_in / own) ** 2
    n = 1.0 - stats.share + c * stats.share
    return dataclasses.replace(  # type: ignore[type-var]
        stats, share=c * stats.share / n, z2=stats.z2 / n, placing_in=base_in
    )


def same_base(sessions: Sequence[SessionNoise]) -> bool:
    """Whether the sessions share one base (or none of them knows its own)."""
    known = [s.placing_in for s in sessions if math.isfinite(s.placing_in)]
    if len(known) < len(sessions) and known:
        return False
    return all(abs(k / known[0] - 1) < _SAME for k in known)


def on_one_base(
    sessions: Sequence[SessionNoise],
) -> tuple[list[SessionNoise], list[float], bool]:
    """The sessions on one reference base, each one's factor back to its own, converted.

    The third value: whether any was converted.
    The reference is the first known base; a session's prior on the reference scale times
    its factor ``(reference / own)^2`` is its prior as a multiplier of its own base. A
    session of unknown base beside known ones is emptied (no trials: it pools nothing, and
    its factor is NaN: no prior).
    """
    if same_base(sessions):
        return list(sessions), [1.0] * len(sessions), False
    ref = next(s.placing_in for s in sessions if math.isfinite(s.placing_in))
    out, back = [], []
    for s in sessions:
        if not math.isfinite(s.placing_in):
            M = s.share.shape[1] if s.share.ndim == 2 else 1
            out.append(dataclasses.replace(  # type: ignore[type-var]
                s, chi2=np.zeros(0), dof=np.zeros(0, dtype=np.int_),
                share=np.zeros((0, M)), z2=np.zeros((0, M)),
            ))  # fmt: skip
            back.append(math.nan)
            continue
        out.append(rebased(s, ref))
        back.append((ref / s.placing_in) ** 2)
    return out, back, True


def prior_on_own_base(prior: PlacingPrior | None, factor: float) -> PlacingPrior | None:
    """A prior pooled on the reference base as a multiplier of the session's own base.

    None: none, or the session's base unknown.
    """
    if prior is None or not math.isfinite(factor):
        return None
    return dataclasses.replace(
        prior,
        scale=prior.scale * factor,
        source=f"{prior.source}, pooled as placing sigmas across their typed resolutions",
    )


def pooled_trials(sessions: Sequence[SessionNoise]) -> tuple[Ints, F64, Ints, F64, F64]:
    """The sessions' trials as one set (an operator's, on one base).

    Each one's session index, ``chi2``, ``dof``, and ``share``, ``z2`` padded to the widest
    session's directions (a direction of no placing share adds nothing).
    """
    M = max((s.share.shape[1] for s in sessions if s.share.size), default=0)
    owner = np.concatenate([np.full(len(s.chi2), k) for k, s in enumerate(sessions)])
    share = np.concatenate([np.pad(s.share, ((0, 0), (0, M - s.share.shape[1]))) for s in sessions])
    z2 = np.concatenate([np.pad(s.z2, ((0, 0), (0, M - s.z2.shape[1]))) for s in sessions])
    chi2 = np.concatenate([s.chi2 for s in sessions])
    dof = np.concatenate([s.dof for s in sessions])
    return owner.astype(np.int_), chi2, dof, share, z2
