"""A two-camera session continued: ``new S2.mcap --continue S.mcap --source pair:A,B``.

The continuation records stream trials as ``S`` did, with what ``S`` stored: its pair
(camera 2's pose in camera 1's frame with its covariance, both cameras' intrinsics and
their sigmas, the floor: the pair file's or the typed ground height), its method, units and
ground plane, and its session id (:class:`recorder.setup.continuation.Continued`); its
stream trials are numbered after the last one ``S`` mentions. ``--pair`` is not needed: a
pair file given beside it must be the pair ``S`` stored (the same calibration, in the
session's units; a file without a floor beside a typed one is the same pair), and another
is refused in words, naming what differs: a continuation is one session, measured through
one pair (recalibrated cameras are a new session).

Each camera's capture clock is this recording's own (the session entry says each part's;
where it differs from the part continued, the file's notes say so), and the clock offset is
measured from this part's frames, per trial, as in the first part: cameras started again
start at a new phase, so the offset of the part continued is not this one's. The analysis
uses each part's own. A one-camera session is not continued by a pair, nor a pair session by
one camera: refused in words, before anything is asked or recorded.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twopose.errors import InputValueError
from twopose.values.bounds import shown

if TYPE_CHECKING:
    from recorder.setup.continuation import Continued
    from recorder.setup.stream_plan import StreamPlan
    from twopose.pair.calibration import PairCalibration

__all__ = [
    "ONE_CAMERA_WITH_PAIR",
    "check_continuation",
    "pair_differs",
    "refuse_one_camera_source",
]

#: Why a one-camera session is not continued by a pair (``--pair`` or a pair source).
ONE_CAMERA_WITH_PAIR = (
    "a one-camera session (typed poses): its continuation records one camera's poses, and "
    "a pair records stream trials; a session is one or the other: leave --pair and the "
    "pair source out to continue it, or record the pair as a new session"
)
#: Relative differences below this are the same number (a JSON round trip is exact; a
#: unit conversion done twice the same way is too: this only absorbs a last bit).
_SAME = 1e-12


def refuse_one_camera_source(continued: Continued, source: str) -> None:
    """A two-camera session's continuation given a one-camera source: refused in words."""
    raise InputValueError(
        f"--continue {continued.path}: a two-camera session (stream trials of a pair): its "
        f"continuation records both cameras: give --source pair:A,B (pair:camera:0,camera:1), "
        f"not {source}"
    )


def pair_differs(stored: PairCalibration, given: PairCalibration) -> str:
    """What of ``given`` (a pair file's) is not the pair ``stored`` (a session's), in words
    ("": the same pair). A floor the file lacks is no difference (the session's was typed)."""
    other = given.in_units(stored.units)
    said = []
    if (other.intrinsics1, other.intrinsics2) != (stored.intrinsics1, stored.intrinsics2):
        said.append("the cameras' intrinsics")
    if not (_same(other.R_2_to_1, stored.R_2_to_1) and _same(other.t_2_in_1, stored.t_2_in_1)):
        moved = float(np.linalg.norm(other.t_2_in_1 - stored.t_2_in_1))
        turn = other.R_2_to_1 @ stored.R_2_to_1.T
        angle = float(np.degrees(np.arccos(np.clip((np.trace(turn) - 1) / 2, -1.0, 1.0))))
        said.append(f"camera 2's pose (by {moved:.3g} {stored.units} and {angle:.3g} deg)")
    if not _same(other.cov_extrinsic, stored.cov_extrinsic):
        said.append("the pose's covariance")
    floor, kept = other.floor, stored.floor
    if floor is not None and (
        kept is None
        or not _same(np.append(floor.normal, floor.height), np.append(kept.normal, kept.height))
        or not _same(floor.cov, kept.cov)
    ):
        said.append("the floor")
    return ", ".join(said)


def _same(a: object, b: object) -> bool:
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    scale = max(float(np.abs(y).max(initial=0.0)), 1e-300)
    return x.shape == y.shape and float(np.abs(x - y).max(initial=0.0)) <= _SAME * scale


def check_continuation(
    continued: Continued, pair_path: Path | None = None, *, plan: StreamPlan | None = None
) -> PairCalibration:
    """The pair a continuation of ``continued`` records with: the one it stored (the module
    docstring); ``pair_path`` a pair file given beside it (checked to be that pair), ``plan``
    a plan recording it (its method and units must be the session's; its ground height, if
    it gives one, the session's floor's). Refused in words otherwise, and for a one-camera
    session."""
    from twopose.pair.pair_file import read_pair_file

    stored = continued.pair
    if stored is None:
        raise InputValueError(f"--continue {continued.path}: {ONE_CAMERA_WITH_PAIR}")
    if pair_path is not None:
        differs = pair_differs(stored, read_pair_file(pair_path))
        if differs:
            raise InputValueError(
                f"--pair {pair_path} is not the pair {continued.path.name} recorded: "
                f"{differs} differ; a continuation keeps its session's pair (leave --pair out: "
                "the session's is used), or record a new session with this pair"
            )
    if plan is not None:
        continued.check_plan(plan.method, plan.units)
        _check_plan_floor(continued, plan)
    return stored


def _check_plan_floor(continued: Continued, plan: StreamPlan) -> None:
    """A plan's ground height beside a continuation must be the session's floor's."""
    ground = continued.ground
    if plan.plane_offset is None or (
        ground is not None and abs(plan.plane_offset - ground.offset) <= _SAME * abs(ground.offset)
    ):
        return
    kept = "none" if ground is None else f"{shown(ground.offset)} {continued.info.units}"
    raise InputValueError(
        f"plan: its ground height {shown(plan.plane_offset)} is not the floor of "
        f"{continued.path.name} ({kept}): a continuation keeps its session's floor; leave it "
        "out of the plan"
    )
