"""An operator's other sessions as each session's prior on the placing multiplier (issue 54).

The same operator's sessions of one method in a run (or the recorder's per-operator noise
file) pool their trials' likelihoods (:mod:`twopose.uncertainty.placing_variance`), robust
first (:func:`twopose.uncertainty.robust_flags.flag_trials` over all of them), into each
session's prior from the others: their pooled maximum on their degrees of freedom, shrunk
for the spread between the sessions (:func:`operator_priors`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Ints
from twopose.uncertainty.anchor_conflict import as_guess, group_anchor
from twopose.uncertainty.hand import pooled_trials
from twopose.uncertainty.noise import MIN_PLACING_DOF, PlacingPrior
from twopose.uncertainty.placing_variance import GRID, LOG_GRID, inv_chi2, trial_loglik
from twopose.uncertainty.robust_flags import flag_trials

__all__ = ["SessionNoise", "operator_priors"]

#: Between-session spread (type II maximum likelihood of the prior's dof over these).
_SPREAD_DOF = np.array([1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384,
                        512, 768, 1024, np.inf])  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class SessionNoise:
    """What one session's misclosures say of its operator's placing.

    A run's first pass, or the recorder's noise file: per redundant trial its chi-square,
    dof and components.
    """

    #: Whose sessions pool: the operator and the method (``""``: no operator named, alone).
    group: str
    chi2: F64  # (T,)
    dof: Ints  # (T,)
    share: F64  # (T, M)
    z2: F64  # (T, M)
    #: The session's id (``""``: not known), named in the priors that pool it.
    name: str = ""
    #: Its base, the placing sigma its multiplier is relative to, in inches (NaN: not
    #: known): sessions of other bases pool as placing variances (:mod:`~twopose.uncertainty.hand`).
    placing_in: float = math.nan


def operator_priors(
    sessions: Sequence[SessionNoise], anchor: PlacingPrior, *, who: str = "operator"
) -> list[PlacingPrior | None]:
    """Each session's prior from the other sessions of its group (None: none to pool).

    Robust first: every trial of the group is tested against all the others
    (:func:`flag_trials`) and a flagged one is left out. Then per session the others'
    pooled likelihood's maximum ``lambda0`` on its degrees of freedom ``F``, shrunk for
    the spread between the group's sessions: the prior's dof is ``min(d0, F)``, ``d0`` the
    type II maximum-likelihood dof of a scaled inverse chi-square at ``lambda0`` that the
    group's sessions' multipliers are drawn from (infinite: they share one). Sessions of
    other bases (typed resolutions) pool as placing variances, each one's prior a multiplier
    of its own base (:func:`twopose.uncertainty.hand.on_one_base`).
    """
    out: list[PlacingPrior | None] = [None] * len(sessions)
    groups: dict[str, list[int]] = {}
    for i, s in enumerate(sessions):
        if s.group:
            groups.setdefault(s.group, []).append(i)
    from twopose.uncertainty.hand import on_one_base, prior_on_own_base

    for group, members in groups.items():
        if len(members) < 2:
            continue
        mine, back, converted = on_one_base([sessions[i] for i in members])
        used, p = _group_anchor(mine, anchor)  # the board tested once, over all of them
        priors = [
            None if prior is None else dataclasses.replace(prior, anchor_p=p)
            for prior in _group_priors(mine, used, group, who)
        ]
        for i, prior, factor in zip(members, priors, back, strict=True):
            out[i] = prior_on_own_base(prior, factor) if converted else prior
    return out


def _group_anchor(sessions: list[SessionNoise], anchor: PlacingPrior) -> tuple[PlacingPrior, float]:
    """:func:`~twopose.uncertainty.anchor_conflict.group_anchor` over ``sessions``' trials."""
    if not anchor.measured or not any(s.share.size for s in sessions):
        return anchor, math.nan
    _, chi2, dof, share, z2 = pooled_trials(sessions)
    return group_anchor(
        chi2, dof, flag_trials(chi2, dof, share, z2, as_guess(anchor)).flagged, anchor
    )


def _group_priors(
    sessions: list[SessionNoise], anchor: PlacingPrior, group: str, who: str
) -> list[PlacingPrior | None]:
    if not any(s.share.size for s in sessions):
        return [None] * len(sessions)
    owner, chi2, dof, share, z2 = pooled_trials(sessions)
    flags = flag_trials(chi2, dof, share, z2, anchor)
    use = (dof > 0) & np.isfinite(chi2) & ~flags.flagged
    L, clean = flags.kept, use.astype(float)
    # the spread from the pooled trials' untruncated likelihoods (a truncated one is flat up)
    raw = np.where(use[:, None] & (L != 0).any(axis=1)[:, None], trial_loglik(share, z2), 0.0)
    per_session = np.stack([raw[owner == k].sum(axis=0) for k in range(len(sessions))])
    spread = _spread_dof(per_session, raw.sum(axis=0))
    out: list[PlacingPrior | None] = []
    for k in range(len(sessions)):
        others = use & (owner != k)
        if not others.any():
            out.append(None)
            continue
        curve = L[others].sum(axis=0)
        lam0 = _maximum(curve)
        info = (clean[others, None] * flags.info[others]).sum(axis=0)
        g = int(np.clip(np.argmax(curve), 1, len(GRID) - 2))  # the curve's own dof: 2x its bend
        bend = (curve[g - 1] - 2 * curve[g] + curve[g + 1]) / (LOG_GRID[1] - LOG_GRID[0]) ** 2
        own = max(-2.0 * float(bend), 0.0) if math.isfinite(anchor.dof) else math.inf  # cut at 5%
        f = min(float(np.interp(math.log(lam0), LOG_GRID, info)), own)  # it tells less
        if round(f) < MIN_PLACING_DOF:
            out.append(None)
            continue
        pooled = {int(o) for o in owner[others]}
        n, names = len(pooled), tuple(sorted({sessions[o].name for o in pooled} - {""}))
        out.append(
            PlacingPrior(scale=lam0, dof=min(f, spread), source=f"{n} other session"
                         f"{'s' if n > 1 else ''} of {who} {group}", sessions=n, pooled=names)
        )  # fmt: skip
    return out


def _maximum(curve: F64) -> float:
    """The log-likelihood ``curve``'s maximum on the grid, refined by a parabola in log."""
    g = int(np.argmax(curve))
    if 0 < g < len(GRID) - 1:
        a, b, c = curve[g - 1], curve[g], curve[g + 1]
        denom = a - 2 * b + c
        shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
        return float(np.exp(LOG_GRID[g] + shift * (LOG_GRID[1] - LOG_GRID[0])))
    return float(GRID[g])


def _spread_dof(per_session: F64, pooled: F64) -> float:
    """The dof ``d0`` that best explains the sessions' multipliers' spread.

    By type II maximum likelihood over :data:`_SPREAD_DOF` (infinite: they share one
    multiplier) jointly with the spread's scale about the pooled maximum: each session's
    likelihood integrated over a scaled inverse chi-square of the sessions' multipliers.
    """
    lam0 = _maximum(pooled)
    best, best_dof = -math.inf, math.inf
    top = per_session.max(axis=1, keepdims=True)
    like = np.exp(per_session - top)  # (S, G), each session's own scale
    for scale in lam0 * np.exp(np.linspace(-0.7, 0.7, 15)):
        for d0 in _SPREAD_DOF:
            if math.isfinite(d0):
                prior = inv_chi2(scale, float(d0)) + LOG_GRID
                prior = np.exp(prior - prior.max())
                prior /= prior.sum()
                marginal = float(np.log(np.clip(like @ prior, 1e-300, None)).sum())
            else:  # one shared multiplier: each session's likelihood at it
                logs = np.log(np.clip(like, 1e-300, None))
                marginal = float(sum(np.interp(math.log(scale), LOG_GRID, r) for r in logs))
            if marginal > best + 1e-9:
                best, best_dof = marginal, float(d0)
    return best_dof
