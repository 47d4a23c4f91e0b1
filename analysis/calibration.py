"""``twopose-analyze rig``: the rig's constants from calibration sessions (sessions with
known targets), in one call: replay them (:mod:`analysis.pipeline`), then estimate
(:mod:`analysis.rig`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from analysis.pipeline import replay_views
from analysis.rig import RigData, RigFit, fit_constants, prepare, select_constants
from twopose.errors import InputValueError

__all__ = ["calibrate"]


def calibrate(paths: Sequence[str], groups: Sequence[str] | None = None) -> tuple[RigFit, RigData]:
    """``twopose-analyze rig``: the constants of the sessions' rig (one method, every trial
    with ground truth), the groups given or those cross-validation supports."""
    replays = [replay_views(p) for p in paths]
    methods = {r.method for r in replays}
    if len(methods) != 1:
        raise InputValueError(
            f"calibrate the rig with sessions of one method, got {sorted(methods)}"
        )
    first = replays[0]
    views = [v for r in replays for v in r.views]
    truth = np.concatenate([r.truth for r in replays])
    ids = [t for r in replays for t in r.trial_ids]
    data = prepare(first.method, ids, views, truth, first.ground)
    fit = select_constants(data) if groups is None else fit_constants(data, groups)
    return fit, data
