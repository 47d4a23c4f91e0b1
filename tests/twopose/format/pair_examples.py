"""A two-camera session's entries (format 1.6) and a session written with them, for tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twopose.camera.model import Camera
from twopose.format.entries import (
    ClockOffsetEntry,
    SessionInfo,
    SimTrajectory,
    StreamWindow,
    Touch,
)
from twopose.format.pair_convert import pair_entry
from twopose.format.simulation import SimClock, SimFrames
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.pair.calibration import FloorPlane, PairCalibration
from twopose.pair.clock import ClockOffset
from twopose.pair.holdout import HoldoutCheck
from twopose.pair.motion import thesis_pair
from twopose.values.units import Units


def calibrated_pair() -> PairCalibration:
    """The thesis' pair in mm with every optional part: sigmas, a floor, a check, views."""
    cov = np.diag([1e-7, 2e-7, 3e-7, 0.01, 0.02, 0.03])
    cov[0, 3] = cov[3, 0] = 5e-6
    floor = FloorPlane(
        normal=np.array([0.0, 0.6, 0.8]), height=250.0, cov=np.diag([1e-6, 1e-6, 1e-6, 0.04])
    )
    check = HoldoutCheck(
        folds=13, spacings=1209, worst_sigmas=1.4, beyond=0, median_error=0.09,
        median_sigma=0.48, jackknife_ratio=(1.2, 2.4, 2.3, 2.1, 1.3, float("nan")),
    )  # fmt: skip
    base = thesis_pair().in_units(Units.MM)
    return PairCalibration(
        intrinsics1=base.intrinsics1, intrinsics2=base.intrinsics2, R_2_to_1=base.R_2_to_1,
        t_2_in_1=base.t_2_in_1, cov_extrinsic=cov, rms_px=0.45, n_views=13, units=Units.MM,
        floor=floor, sigma1={"fx": 0.9, "k1": 0.01}, sigma2={"cy": 1.1},
        intrinsics_from="fitted on each camera's own stills", view_names=("a", "b"),
        view_rms_px=(0.3, 0.5), dropped=("c (RMS 4 px)",), check=check, cov_factor=4.2,
    )  # fmt: skip


PAIR_SESSION_EXAMPLES = [
    pair_entry(calibrated_pair(), ("left", "right")),
    ClockOffsetEntry(offset_ns=-1.25e7, sigma_ns=3.1e5, method="ray gap", n=412),
    StreamWindow(
        trial=3,
        camera_id="left",
        window=2,
        start_ns=100,
        end_ns=900,
        n_frames=24,
        status="incomplete",
        reason="the camera stopped",
        dropped_frames=1,
    ),
    Touch(trial=3, touch=2, time_ns=450, point=(3.0, 9.625, 24.0), how="button"),
    SimTrajectory(
        trial=3,
        t_ns=(100, 200),
        points=((0.0, 2.0, 14.0), (0.1, 2.0, 14.0)),
        directions=((0.0, 0.6, 0.8), (0.0, 0.6, 0.8)),
        length=3.0,
        frames=(SimFrames(camera_id="left", true_ns=(100, 200)),),
        clocks=(
            SimClock(
                camera_id="left",
                fps=30.0,
                phase_ns=1e6,
                drift_ppm=0.0,
                jitter_ns=0.0,
                drop=0.0,
                offset_ns=0.0,
                latency_ns=4e7,
            ),
        ),
        R_2_to_1=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
        t_2_in_1=(6.0, 0.0, 0.0),
    ),
]


def pair_cameras(pair: PairCalibration, ids: tuple[str, str] = ("cam1", "cam2")) -> list[Camera]:
    """The session's two cameras, the pair's intrinsics."""
    return [
        Camera(camera_id=ids[0], intrinsics=pair.intrinsics1),
        Camera(camera_id=ids[1], intrinsics=pair.intrinsics2),
    ]


def write_pair_session(
    path: Path,
    *,
    trials: int = 2,
    frames: int = 12,
    window_s: float = 0.1,
    offset_ns: int = 7_000_000,
    pair: PairCalibration | None = None,
) -> dict[str, object]:
    """A small two-camera session: ``trials`` streams of ``frames`` frames a camera (30 fps),
    camera 2's clock ``offset_ns`` ahead, a touch mid-stream; returns what went in."""
    pair = pair or thesis_pair()
    cameras = pair_cameras(pair)
    info = SessionInfo(
        method=Method.GROUND, units=Units.IN, camera_ids=("cam1", "cam2"),
        clocks={"cam1": "driver", "cam2": "monotonic at grab"},
    )  # fmt: skip
    rng = np.random.default_rng(5)
    captures: dict[tuple[int, str], list[int]] = {}
    t0 = 1_700_000_000_000_000_000
    offset = ClockOffset(offset_ns=float(offset_ns), sigma_ns=4e5, method="flash", n=60)
    with SessionWriter(path, info, cameras, pair=pair, start_ns=t0) as writer:
        writer.write_clock_offset(offset, t0)
        for trial in range(1, trials + 1):
            start = t0 + trial * 10**9
            with writer.stream(trial, window_s=window_s, start_ns=start) as stream:
                for k in range(frames):
                    t1 = 5 * 10**9 + trial * 10**9 + k * 33_333_333  # camera 1's clock
                    for cid, capture in (("cam1", t1), ("cam2", t1 + offset_ns + 11_000_000)):
                        image = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
                        stream.add_frame(cid, image, capture, start + k * 33_333_333 + 40_000_000)
                        captures.setdefault((trial, cid), []).append(capture)
                    if k == frames // 2:
                        stream.touch((1.0, 9.625, 24.0), t1, "schedule")
    return {"captures": captures, "offset": offset, "pair": pair}
