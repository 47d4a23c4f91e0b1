"""A two-camera session with every typed entry, for the format tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import (
    GroundTruth,
    Note,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
    TruePose,
)
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

CAM0 = Camera(
    camera_id="cam0",
    intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
)


CAM1 = Camera(
    camera_id="right",
    intrinsics=Intrinsics(
        width=320,
        height=240,
        fx=300.0,
        fy=301.0,
        cx=161.0,
        cy=119.5,
        distortion=(-0.1, 0.01, 0.0, 0.0, 0.0),
    ),
)


def image(seed: int, shape: tuple[int, int] = (480, 640)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    # Smooth content so JPEG round trips stay close.
    small = rng.integers(0, 255, size=(shape[0] // 16, shape[1] // 16, 3), dtype=np.uint8)
    import cv2

    return np.asarray(cv2.resize(small, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR))


def write_full_session(path: Path, image_format: str) -> dict[str, object]:
    """A two-camera session with every typed entry; returns what went in."""
    info = SessionInfo(
        method=Method.GROUND,
        units=Units.IN,
        camera_ids=("cam0", "right"),
        operator="Ada",
        notes="round trip",
        created_utc="2026-11-22T00:00:00+00:00",
    )
    ground = PlaneEntry(offset=9.625)
    poses = [
        PoseEntry(
            trial=1,
            pose=1,
            camera_id="cam0",
            t_grid=(0.0, 0.0, 0.0),
            r_deg=(0.0, 0.0, 0.0),
            translation_resolution=0.0625,
            rotation_resolution_deg=0.5,
        ),
        PoseEntry(
            trial=1,
            pose=2,
            camera_id="right",
            t_grid=(1.1, 0.0, -0.5),
            r_deg=(0.0, 5.0, -2.0),
            translation_resolution=0.125,
            rotation_resolution_deg=1.0,
        ),
    ]
    gt = GroundTruth(trial=1, kind="point", points_grid=((1.91, 9.625, 8.375),))
    note = Note(text="glove slipped a little", trial=1)
    truth = SimulationTruth(
        trial=1,
        poses=(
            TruePose(pose=1, camera_id="cam0", t_grid=(0.01, 0.0, -0.02), r_deg=(0.0, 0.0, 0.0)),
            TruePose(pose=2, camera_id="right", t_grid=(1.12, 0.0, -0.45), r_deg=(0.0, 5.0, -2.0)),
        ),
        kind="point",
        points_grid=((1.91, 9.625, 8.375),),
    )
    images = {"cam0": [image(1), image(2)], "right": [image(3, (240, 320))]}
    t = 1_000_000_000
    with SessionWriter(
        path, info, [CAM0, CAM1], ground=ground, image_format=image_format, start_ns=t
    ) as w:
        w.write_ground_truth(gt, t + 1)
        for k, pose in enumerate(poses):
            w.write_pose(pose, t + 10 + 100 * k)
            with w.capture(1, pose.pose, pose.camera_id) as cap:
                for j, img in enumerate(images[pose.camera_id]):
                    cap.add_frame(img, t + 20 + 100 * k + j)
        w.write_note(note, t + 500)
        w.write_entry(truth, t + 600)
    return {
        "info": info,
        "ground": ground,
        "poses": poses,
        "gt": gt,
        "note": note,
        "truth": truth,
        "images": images,
    }
