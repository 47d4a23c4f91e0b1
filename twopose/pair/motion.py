"""A moving finger seen by a pair of free-running cameras, projected analytically.

The stream's benchmarks and tests measure against it, and the two-camera simulator can
render over it: a pointing finger (its tip, its axis) moving at a constant speed on a
circle (:class:`FingerMotion`) or vibrating along a line (:class:`VibratingMotion`: at a
harmonic of the frame rate, the cameras' frames alias it), each camera's frames taken on
its own clock (:class:`CameraClock`: frame rate, phase, rate drift, the stamps' jitter,
dropped frames, the clock's offset), and what each camera measures of it at its capture
times
(:func:`observe`: the tip as a dot's centroid, or the finger's axis as an image line
through its middle), with the detector's noise drawn from a seeded generator. The thesis'
geometry (:func:`thesis_pair`): camera 2 six inches to the right of camera 1 and toed in
10 degrees, f = 525 px at 640x480, the floor 9.625 in below camera 1, the fingertip about
14 in ahead. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.camera.model import Intrinsics, rotation_from_angles_deg
from twopose.pair.calibration import FloorPlane, PairCalibration
from twopose.pair.stream import CameraTrack
from twopose.values.units import Units

__all__ = [
    "THESIS_FLOOR_IN",
    "CameraClock",
    "FingerMotion",
    "Frames",
    "VibratingMotion",
    "observe",
    "thesis_pair",
]

#: The thesis' ground height: camera centre to table top (in).
THESIS_FLOOR_IN = 9.625
#: The thesis' webcam.
THESIS_INTRINSICS = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)


def thesis_pair(
    cov_extrinsic: ArrayLike | None = None, floor_cov: ArrayLike | None = None
) -> PairCalibration:
    """The thesis' two-camera geometry as a calibrated pair (inches).

    Camera 2 at (6, 0, 0) in camera 1's frame, turned -10 degrees about y (toed in, toward
    camera 1's axis), the floor y = 9.625 in; exact unless covariances are given.
    """
    return PairCalibration(
        intrinsics1=THESIS_INTRINSICS,
        intrinsics2=THESIS_INTRINSICS,
        R_2_to_1=rotation_from_angles_deg([0.0, -10.0, 0.0]),
        t_2_in_1=np.array([6.0, 0.0, 0.0]),
        cov_extrinsic=np.zeros((6, 6)) if cov_extrinsic is None else np.asarray(cov_extrinsic),
        rms_px=0.0,
        n_views=0,
        units=Units.IN,
        floor=FloorPlane(
            normal=np.array([0.0, 1.0, 0.0]),
            height=THESIS_FLOOR_IN,
            cov=np.zeros((4, 4)) if floor_cov is None else np.asarray(floor_cov),
        ),
        intrinsics_from="the thesis' webcam (f = 525 px)",
    )


@dataclass(frozen=True, kw_only=True)
class FingerMotion:
    """A pointing finger whose tip moves on a circle at a constant speed.

    ``centre`` (3,) the circle's centre, ``radius`` and ``speed`` (length, length/s) in
    camera 1's frame; the circle lies in the plane of camera 1's x axis and ``tilt``'s
    direction (the (y, z) direction, normalised); the finger points along ``pointing``
    (from the knuckle to the tip and on to the floor), ``length`` long.
    """

    centre: tuple[float, float, float] = (0.0, 2.0, 14.0)
    radius: float = 3.0
    speed: float = 10.0
    tilt: tuple[float, float] = (0.5, 0.866)
    pointing: tuple[float, float, float] = (0.0, 0.6, 0.8)
    length: float = 3.0

    def tip(self, t_s: ArrayLike) -> F64:
        """(N, 3) the fingertip at times ``t_s`` (seconds)."""
        t = np.asarray(t_s, dtype=np.float64).reshape(-1)
        w = self.speed / self.radius
        e1 = np.array([1.0, 0.0, 0.0])
        e2 = np.array([0.0, *self.tilt]) / np.hypot(*self.tilt)
        circle = np.cos(w * t)[:, None] * e1 + np.sin(w * t)[:, None] * e2
        return np.asarray(np.asarray(self.centre) + self.radius * circle)

    @property
    def direction(self) -> F64:
        """(3,) the finger's unit direction, toward the tip."""
        d = np.asarray(self.pointing, dtype=np.float64)
        return np.asarray(d / np.linalg.norm(d))

    def middle(self, t_s: ArrayLike) -> F64:
        """(N, 3) the middle of the finger (the point its image line is measured through)."""
        return np.asarray(self.tip(t_s) - 0.5 * self.length * self.direction)

    def floor_point(self, t_s: ArrayLike, floor: FloorPlane) -> F64:
        """(N, 3) where the finger's axis meets the floor (what method 2 measures)."""
        tip, d = self.tip(t_s), self.direction
        s = (floor.height - tip @ floor.normal) / float(d @ floor.normal)
        return np.asarray(tip + s[:, None] * d)


@dataclass(frozen=True, kw_only=True)
class VibratingMotion(FingerMotion):
    """A pointing finger whose tip vibrates along a line.

    The tip is ``centre + amplitude sin(2 pi frequency_hz t + phase) d``, ``d`` the unit
    (x, y, z) ``along``. At a harmonic or subharmonic of the frame rate (30, 15, 10 Hz at
    30 fps) each camera sees its frames repeat (stroboscopic aliasing); near one, a slow
    motion whose shift in time between the cameras is many times the true one.
    """

    frequency_hz: float = 15.0
    amplitude: float = 0.5
    phase: float = 0.0
    along: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def tip(self, t_s: ArrayLike) -> F64:
        """(N, 3) the fingertip at times ``t_s`` (seconds)."""
        t = np.asarray(t_s, dtype=np.float64).reshape(-1)
        d = np.asarray(self.along, dtype=np.float64)
        swing = self.amplitude * np.sin(2 * np.pi * self.frequency_hz * t + self.phase)
        return np.asarray(np.asarray(self.centre) + swing[:, None] * (d / np.linalg.norm(d)))


@dataclass(frozen=True, kw_only=True, eq=False)
class Frames:
    """One camera's frames: true capture instants (s) and the stamps its clock gives (ns)."""

    true_s: F64
    stamps_ns: F64


@dataclass(frozen=True, kw_only=True)
class CameraClock:
    """One free-running camera's clock.

    Frames every ``1 / fps`` seconds (times ``1 + drift_ppm 1e-6``) from ``phase_s``;
    each stamp is the true instant plus ``offset_s`` (this clock minus the true time) plus
    Gaussian jitter of ``jitter_s``; a ``drop`` share of frames is lost at random.
    """

    fps: float = 30.0
    phase_s: float = 0.0
    drift_ppm: float = 0.0
    jitter_s: float = 0.0
    drop: float = 0.0
    offset_s: float = 0.0

    def frames(self, duration_s: float, rng: np.random.Generator) -> Frames:
        """The frames of ``duration_s`` seconds (seeded by ``rng``)."""
        interval = (1.0 + 1e-6 * self.drift_ppm) / self.fps
        n = int(np.floor((duration_s - self.phase_s) / interval)) + 1
        true = self.phase_s + interval * np.arange(max(n, 0))
        kept = rng.random(true.size) >= self.drop
        true = true[kept]
        stamps = (true + self.offset_s + rng.normal(0.0, self.jitter_s, true.size)) * 1e9
        order = np.argsort(stamps, kind="stable")  # jitter beyond an interval would reorder
        return Frames(true_s=np.asarray(true[order], np.float64), stamps_ns=stamps[order])


def _project(pair: PairCalibration, points: F64, camera: int) -> F64:
    """(N, 2) pixels of camera-1-frame points in camera 1 or 2 (pinhole)."""
    q = points if camera == 1 else (points - pair.t_2_in_1) @ pair.R_2_to_1
    i = pair.intrinsics1 if camera == 1 else pair.intrinsics2
    return np.column_stack([i.fx * q[:, 0] / q[:, 2] + i.cx, i.fy * q[:, 1] / q[:, 2] + i.cy])


def observe(
    pair: PairCalibration,
    motion: FingerMotion,
    frames: Frames,
    camera: int,
    *,
    line: bool,
    noise: tuple[float, float] = (0.0, 0.0),
    rng: np.random.Generator | None = None,
) -> CameraTrack:
    """What ``camera`` (1 or 2) measures of the finger at its frames' true instants.

    ``line`` False: the tip as a dot's centroid; True: the finger's axis as an image line
    (through the projected middle, at the projected axis' angle). ``noise``: the detector's
    1-sigma (centroid px, angle deg), drawn from ``rng``. Times are the frames' stamps.
    """
    t = frames.true_s
    if line:
        middle = _project(pair, motion.middle(t), camera)
        tip = _project(pair, motion.tip(t), camera)
        d = tip - middle
        theta = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
        centroid = middle
    else:
        centroid, theta = _project(pair, motion.tip(t), camera), None
    if rng is not None and (noise[0] > 0 or noise[1] > 0):
        centroid = centroid + rng.normal(0.0, noise[0], centroid.shape)
        if theta is not None:
            theta = theta + rng.normal(0.0, noise[1], theta.shape)
    return CameraTrack.of(frames.stamps_ns, centroid, theta)
