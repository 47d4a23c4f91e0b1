"""A two-camera session's rows of ``frames.csv``, ``views.csv`` and ``averaging.csv``, and
its results.mcap, as a one-camera session has them (issue 58 item 6).

:class:`PairOutputs` is told each frame as it is detected and each stream trial as it is
replayed (:func:`analysis.session.stream.replay_trial`), and gathers, told apart from a
one-camera session's by ``cameras`` = 2:

- **frames**: each camera's frames of each stream trial (``trial`` the stream trial's
  number, ``pose`` 0: no typed pose; ``frame`` its number in its camera's stream), with
  the detection, its write time (``log_time_ns``) and its capture time (``capture_ns``, its
  camera's clock);
- **views**: every frame pair of each stream trial (``pair`` from 1), one row per camera
  (``pose`` 1 and 2: camera 1 at the origin, camera 2 at the pair's pose), what the solver
  was given (:attr:`twopose.pair.stream.StreamEstimate.measured`: each detection with the
  lens' distortion removed, camera 1's brought to the pair's time, camera 2's at its
  capture), the rays through them, and the pair's
  ``status``, ``reason`` (a near-singular pair flagged, with why), ``conditioning``, time
  (``pair_time_ns``, camera 1's clock) and skew;
- **averaging**: per touch (``trial`` the touch's row of ``trials.csv``), the mean of the
  ``n_frames`` = 1 .. :data:`AVERAGING_PAIRS` ok pair estimates nearest its time (within
  :data:`AVERAGING_WINDOW_INTERVALS` frame intervals), and its error: what averaging pairs
  about a touch buys against the target's motion (a line's: the mean of each line's point
  nearest the touched point);
- **results.mcap** (:class:`analysis.session.results_mcap.ResultsWriter`): every frame with
  its detection drawn, and per touch its scene (both cameras, the rays, the estimate at the
  touch with its 95% ellipsoid, the touched point), stamped at the nearest pair's write time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from analysis.session.results_mcap import ResultsWriter
from analysis.session.stream import FrameSeen, TrialReplay
from analysis.tables.columns import AVERAGING_COLUMNS, FRAME_COLUMNS, VIEW_COLUMNS, typed
from twopose.arrays import F64, Bools, Ints
from twopose.camera.model import grid_rays, rotation_from_angles_deg
from twopose.detect.detection import Detection
from twopose.display.scene import TrialScene
from twopose.format.messages import Frame
from twopose.format.streams import StreamTrial
from twopose.methods.specs import Method, spec_of
from twopose.pair.calibration import PairCalibration
from twopose.pair.frame_noise import CameraNoise
from twopose.pair.stream import StreamEstimate
from twopose.values.units import Units

__all__ = ["AVERAGING_PAIRS", "AVERAGING_WINDOW_INTERVALS", "PairOutputs", "nearest_ok"]

#: A touch's running average goes up to this many pair estimates about it.
AVERAGING_PAIRS = 5
#: ... each within this many frame intervals of the touch's time.
AVERAGING_WINDOW_INTERVALS = 3.5


@dataclass(kw_only=True)
class PairOutputs:
    """A two-camera session's frames, views and averaging rows and results.mcap, gathered
    as its trials are replayed (the module docstring)."""

    session: str
    method: Method
    units: Units
    pair: PairCalibration
    results: ResultsWriter | None = None
    #: each camera's pixel noise the session's regions carry (told by the replay)
    noise: tuple[CameraNoise, CameraNoise] | None = None
    frames: list[dict[str, Any]] = field(default_factory=list)
    views: list[pd.DataFrame] = field(default_factory=list)
    averaging: list[dict[str, Any]] = field(default_factory=list)

    def seen(self, trial: int) -> tuple[FrameSeen, FrameSeen]:
        """Camera 1's and camera 2's callbacks for stream trial ``trial``'s frames."""
        return self._camera_seen(trial, 1), self._camera_seen(trial, 2)

    def _camera_seen(self, trial: int, camera: int) -> FrameSeen:
        counter = iter(range(2**62))

        def seen(frame: Frame, det: Detection) -> None:
            self.frames.append(_frame_row(self.session, trial, next(counter), frame, det))
            if self.results is not None:
                self.results.add_frame(frame, det, f"trial {trial}, camera {camera}")

        return seen

    def add_trial(
        self, trial: StreamTrial, replay: TrialReplay, first_touch: int,
        pair: PairCalibration | None = None,
    ) -> None:  # fmt: skip
        """A replayed stream trial: its pairs' views, its touches' running averages (the
        touches numbered from ``first_touch`` as ``trials.csv`` numbers them) and their
        scenes; ``pair`` its part's pair (default: :attr:`pair`, the first part's)."""
        pair = pair or self.pair
        est, interval = replay.estimate, replay.interval_ns
        self.views.append(self._views(trial.trial, replay, pair))
        touched = np.array([t.time_ns for t in replay.touches], dtype=np.float64)
        for k, touch in enumerate(replay.touches):
            q = np.asarray(touch.point, dtype=np.float64)
            for n, mean in enumerate(_running(est, touch.time_ns, q, interval), start=1):
                self.averaging.append(
                    {"session": self.session, "trial": first_touch + k, "n_frames": n,
                     "units": str(self.units), **dict(zip("xyz", map(float, mean), strict=True)),
                     "err": float(np.linalg.norm(mean - q)), "cameras": 2}
                )  # fmt: skip
        if self.results is not None:
            nearest = nearest_ok(est.t_ns, touched, est.ok)
            self._scenes(trial, replay, nearest, first_touch, pair)

    def _poses(self, pair: PairCalibration) -> tuple[F64, F64, F64, F64]:
        """Both cameras' (2, 4) intrinsics, (2, 2) sizes, (2, 3) centres, (2, 3) angles, as
        the solver took them (``pair``'s)."""
        both = (pair.intrinsics1, pair.intrinsics2)
        intr = np.array([[k.fx, k.fy, k.cx, k.cy] for k in both])
        size = np.array([[k.width, k.height] for k in both], dtype=np.float64)
        t = np.array([np.zeros(3), pair.t_2_in_1])
        angles = np.array([np.zeros(3), pair.angles_deg])
        return intr, size, t, angles

    def _views(self, trial: int, replay: TrialReplay, pair: PairCalibration) -> pd.DataFrame:
        """Two rows per frame pair (module docstring), camera 1's then camera 2's."""
        est = replay.estimate
        intr, _, t, angles = self._poses(pair)
        P = est.t_ns.size
        tables = []
        lines = spec_of(self.method).uses_image_lines
        for c in range(2):
            said = None if replay.noise is None else replay.noise[c]
            px, theta = est.measured[:, c, :2], est.measured[:, c, 2]
            ray = grid_rays(px, intr[c], rotation_from_angles_deg(angles[c]))
            columns: dict[str, Any] = {
                "session": self.session, "trial": trial, "pose": c + 1, "units": str(self.units),
                **{f"t_{a}": t[c, i] for i, a in enumerate("xyz")},
                "col": px[:, 0], "row": px[:, 1], "theta_deg": theta,  # NaN for a dot
                **{f"ray_{a}": ray[:, i] for i, a in enumerate("xyz")},
                **dict(zip(("fx", "fy", "cx", "cy"), intr[c], strict=True)),
                **{f"r_{a}_deg": angles[c, i] for i, a in enumerate("xyz")},
                "cameras": 2, "pair": np.arange(1, P + 1),
                "pair_time_ns": est.t_ns.astype(np.int64), "skew_ms": est.skew_ns / 1e6,
                "status": est.status.astype(str), "reason": est.reason.astype(str),
                "conditioning": est.conditioning,
                **_noise_columns(said, lines=lines),
            }  # fmt: skip
            tables.append(pd.DataFrame(columns, index=np.arange(P) * 2 + c))
        return pd.concat(tables).sort_index() if P else pd.DataFrame(columns=VIEW_COLUMNS)

    def _scenes(
        self, trial: StreamTrial, replay: TrialReplay, nearest: Ints, first_touch: int,
        pair: PairCalibration,
    ) -> None:  # fmt: skip
        """Each touch's scene into results.mcap, from the ok pair nearest its time."""
        assert self.results is not None
        est = replay.estimate
        intr, size, t, angles = self._poses(pair)
        R = rotation_from_angles_deg(angles)
        for k, j in enumerate(nearest):
            if j < 0:
                continue
            q = np.asarray(replay.touches[k].point, dtype=np.float64)
            px, theta = est.measured[j, :, :2], est.measured[j, :, 2]
            scene = TrialScene(
                trial=first_touch + k, method=self.method, status="ok", intrinsics=intr,
                width_height=size, R_cam_to_grid=R, t_grid=t, px=px, theta_deg=theta,
                estimate=replay.at_touch[k],
                direction=None if est.direction is None else est.direction[j],
                truth=np.array([q, q]), cov=est.cov[j],
            )  # fmt: skip
            self.results.add_trial(scene, int(trial.camera2.log_ns[est.i2[j]]))

    def tables(self) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
        """``frames.csv``, ``views.csv`` and ``averaging.csv``'s rows, typed."""
        present = [v for v in self.views if not v.empty]
        views = pd.concat(present, ignore_index=True) if present else None
        return (
            typed(pd.DataFrame(self.frames, columns=FRAME_COLUMNS)),
            typed(pd.DataFrame(views, columns=VIEW_COLUMNS)),
            typed(pd.DataFrame(self.averaging, columns=AVERAGING_COLUMNS)),
        )


def _noise_columns(noise: CameraNoise | None, *, lines: bool) -> dict[str, Any]:
    """A camera's detection noise in ``views.csv``: the 1-sigmas its region carries, its
    frames' own scatter about a smooth fit with its dof, and where they came from in words."""
    if noise is None:
        return {}
    scatter = noise.scatter
    return {
        "noise_px": noise.noise.centroid_px,
        "noise_deg": noise.noise.theta_deg if lines else np.nan,
        "scatter_px": np.nan if scatter is None else scatter.centroid_px,
        "scatter_deg": np.nan if scatter is None or not lines else scatter.theta_deg,
        "scatter_dof": 0.0 if scatter is None else noise.dof_px,
        "noise_source": noise.said(lines=lines),
    }


def _frame_row(
    session: str, trial: int, index: int, frame: Frame, det: Detection
) -> dict[str, Any]:
    """One frame of a stream trial, a row of ``frames.csv``."""
    return {
        "session": session, "trial": trial, "pose": 0, "camera": frame.camera_id,
        "frame": index, "log_time_ns": frame.log_time_ns, "found": det.found,
        "col": det.centroid_px[0], "row": det.centroid_px[1], "theta_deg": det.theta_deg,
        "area_px": det.area_px, "eccentricity": det.eccentricity,
        "pi_estimate": det.pi_estimate, "n_blobs": det.n_blobs,
        "n_candidates": det.n_candidates, "reason": det.reason, "cameras": 2,
        "capture_ns": frame.capture_ns or 0,
    }  # fmt: skip


def _running(est: StreamEstimate, time_ns: int, q: F64, interval: float) -> list[F64]:
    """The mean of the 1 .. :data:`AVERAGING_PAIRS` ok estimates nearest ``time_ns``
    (within :data:`AVERAGING_WINDOW_INTERVALS` intervals); a line's points nearest ``q``."""
    ok = np.flatnonzero(est.ok)
    dt = np.abs(est.t_ns[ok] - time_ns)
    near = ok[np.argsort(dt, kind="stable")][:AVERAGING_PAIRS]
    near = near[np.abs(est.t_ns[near] - time_ns) <= AVERAGING_WINDOW_INTERVALS * interval]
    points = est.point[near]
    if est.direction is not None:  # each line's point nearest the touched point
        d = est.direction[near]
        points = points + np.sum((q - points) * d, axis=1)[:, None] * d
    return list(np.cumsum(points, axis=0) / np.arange(1, near.size + 1)[:, None])


def nearest_ok(t_ns: F64, at: F64, ok: Bools) -> Ints:
    """(K,) per time of ``at``, the index of the ok estimate nearest it (-1: none)."""
    index = np.flatnonzero(ok)
    if not index.size:
        return np.full(at.size, -1)
    nearest: Ints = index[np.argmin(np.abs(t_ns[index][None, :] - at[:, None]), axis=1)]
    return nearest
