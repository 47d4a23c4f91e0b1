"""twopose.format.writer directly: it never overwrites, keeps a capture an error interrupted
(marked incomplete), refuses unknown cameras, and invalid typed values never reach a file."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from tests.twopose.format.full_session import CAM0, image
from twopose.errors import (
    InputValueError,
    SessionExistsError,
)
from twopose.format.entries import (
    CaptureWindow,
    GroundTruth,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
)
from twopose.format.reader import SessionReader
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units


def _capture_then_fail(w: SessionWriter) -> None:
    with w.capture(1, 1, "cam0") as cap:
        cap.add_frame(image(1), 2)
        raise RuntimeError("camera stopped delivering frames")


def test_writer_refuses_to_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    path.write_bytes(b"precious data")
    with (
        pytest.raises(SessionExistsError, match="never overwrites"),
        SessionWriter(path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM0]),
    ):
        pass
    assert path.read_bytes() == b"precious data"


def test_capture_interrupted_by_an_error_is_kept_and_marked_incomplete(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    with SessionWriter(
        path, SessionInfo(method=Method.POINT, units=Units.IN), [CAM0], start_ns=0
    ) as w:
        w.write_pose(PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0)), 1)
        with pytest.raises(RuntimeError):
            _capture_then_fail(w)
    with SessionReader(path) as r:
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert len(windows) == 1
    assert windows[0].status == "incomplete"
    assert "camera stopped delivering frames" in windows[0].reason
    assert windows[0].n_frames == 1


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, math.nan, 0.0)),
            "finite",
        ),
        (lambda: PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, 1.0)), "3 numbers"),  # type: ignore[arg-type]
        (lambda: PoseEntry(trial=-1, pose=1, camera_id="cam0", t_grid=(0.0, 0.0, 0.0)), "trial"),
        (
            lambda: PoseEntry(trial=1, pose=1, camera_id="cam 0", t_grid=(0.0, 0.0, 0.0)),
            "camera id",
        ),
        (
            lambda: PoseEntry(
                trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0), translation_resolution=0.0
            ),
            "positive",
        ),
        (lambda: SessionInfo(method="triangle", units=Units.IN), "method"),  # type: ignore[arg-type]
        (lambda: SessionInfo(method=Method.POINT, units="furlong"), "units"),  # type: ignore[arg-type]
        (lambda: GroundTruth(trial=1, kind="line", points_grid=((0, 0, 0),)), "needs 2"),
        (
            lambda: GroundTruth(trial=1, kind="line", points_grid=((1, 2, 3), (1, 2, 3))),
            "must differ",
        ),
        (lambda: PlaneEntry(offset=math.inf), "finite"),
        (lambda: PlaneEntry(offset=1.0, normal_grid=(0, 0, 0)), "zero"),
        (
            lambda: CaptureWindow(
                trial=1, pose=1, camera_id="cam0", start_ns=10, end_ns=5, n_frames=0
            ),
            "before it starts",
        ),
    ],
)
def test_invalid_typed_values_never_reach_a_file(make: object, message: str) -> None:
    with pytest.raises(InputValueError, match=message):
        make()  # type: ignore[operator]


def test_writer_rejects_unknown_camera(tmp_path: Path) -> None:
    with (
        SessionWriter(
            tmp_path / "s.mcap", SessionInfo(method=Method.POINT, units=Units.IN), [CAM0]
        ) as w,
        pytest.raises(InputValueError, match="not in this session"),
    ):
        w.write_pose(PoseEntry(trial=1, pose=1, camera_id="right", t_grid=(0, 0, 0)))


def test_ground_plane_is_normalised() -> None:
    g = PlaneEntry(offset=19.25, normal_grid=(0.0, 2.0, 0.0))
    assert g.normal_grid == (0.0, 1.0, 0.0)
    assert g.offset == pytest.approx(9.625)
