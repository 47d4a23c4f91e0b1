"""A pointing clip: a gloved finger (or the dot) moving over the floor, rendered for both
cameras of the simulated pair (:func:`recorder.simulate.pair.simulated_pair`), frame by
frame, for the live pointing's tests and benchmark (``benchmarks/bench_pointing.py`` writes
two video files of it and plays them through ``--source pair:``).

The target moves at ``speed`` through the method's touch points
(:func:`twopose.sim.moving.touch_points`), back and forth for as long as the clip lasts.
Camera 1 takes frame ``k`` at ``k / fps``, camera 2 ``phase_s`` later (a free-running pair's
phase). Deterministic for a seed; no I/O.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from recorder.simulate.pair import DWELL_S, simulated_pair
from twopose.arrays import F64
from twopose.methods.specs import Method
from twopose.pair.calibration import PairCalibration
from twopose.sim.moving import PairScene, Trajectory, touch_points
from twopose.sim.scene import Scene
from twopose.values.units import Units, unit_factor

__all__ = ["ClipFrame", "PointingClip"]


@dataclass(frozen=True, slots=True)
class ClipFrame:
    """Frame pair ``k``: each camera's true capture instant (s from the clip's start) and
    image (BGR), and the target's reference point then (camera 1's frame: the floor point
    the finger points at, the dot's centre)."""

    k: int
    t1_s: float
    image1: NDArray[np.uint8]
    t2_s: float
    image2: NDArray[np.uint8]
    truth1: F64
    truth2: F64


class PointingClip:
    """The clip's scene, pair and path (the module docstring)."""

    def __init__(
        self,
        method: Method,
        *,
        seed: int = 1,
        fps: float = 30.0,
        speed: float = 10.0,
        phase_s: float = 0.0,
        scene: Scene | None = None,
        pair: PairCalibration | None = None,
    ) -> None:
        self.scene = scene or Scene()
        self.pair = pair or simulated_pair(self.scene)
        self.method, self.fps, self.phase_s = method, fps, phase_s
        self._scene = PairScene(self.scene, method, self.pair, np.random.default_rng(seed))
        touches = touch_points(self.scene, method, self.pair)
        lead = unit_factor(Units.IN, Units(self.scene.units))
        self.path = Trajectory(touches=touches, speed=speed, lead=lead, dwell_s=DWELL_S)

    def reference_at(self, t_s: float) -> F64:
        """(3,) the target's reference point at ``t_s``: the path there and back again."""
        d = self.path.duration_s
        u = t_s % (2 * d)
        return np.asarray(self.path.at(np.array([u if u <= d else 2 * d - u]))[0])

    def frames(self, n: int, start: int = 0) -> Iterator[ClipFrame]:
        """Frame pairs ``start`` .. ``start + n - 1``, rendered one at a time."""
        for k in range(start, start + n):
            t1, t2 = k / self.fps, k / self.fps + self.phase_s
            r1, r2 = self.reference_at(t1), self.reference_at(t2)
            yield ClipFrame(
                k=k, t1_s=t1, image1=self._scene.frame(1, r1), t2_s=t2,
                image2=self._scene.frame(2, r2), truth1=r1, truth2=r2,
            )  # fmt: skip
