"""results.mcap: what the analysis saw and built, for Foxglove (or Lichtblick) to show.

Per session, an MCAP file with the session's images, calibrations and camera poses on the
session's own topics (so a layout made for sessions works here), plus:

* ``/twopose/results/camera/<id>/annotations`` (``foxglove.ImageAnnotations``, one per frame,
  stamped like its image): the detected blob's outline, centroid and orientation line in
  green; candidates the filters turned down in red, each with the reason.
* ``/twopose/results/scene`` (``foxglove.SceneUpdate``, in the ``grid`` frame): once, the
  grid the poses are typed on (``y = 0``) and the ground plane (``y = h``); then per trial,
  stamped at its last frame, the camera frustums, the back-projected rays (points) or
  planes (lines, method 2), the estimate with its 95% ellipsoid, the ground truth and the
  error vector. Entity ids repeat from trial to trial, so scrubbing shows one trial at a time.

The builders (:func:`image_annotations`, :func:`trial_scene`) are pure; the writer streams,
so memory stays flat whatever the session length. The geometry is the solver's grid frame:
``p_grid = R_cam_to_grid p_cam + t_grid``, y down.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Self

from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from twopose.camera.model import Camera
from twopose.detect.detection import Detection
from twopose.display.scene import TrialScene, image_annotations, static_scene, trial_scene
from twopose.format.entries import PlaneEntry, PoseEntry
from twopose.format.messages import (
    RESULTS_TOPIC_PREFIX,
    SESSION_PROTOBUF,
    TF_TOPIC,
    Channels,
    Frame,
    calibration_message,
    calibration_topic,
    image_message,
    image_topic,
    transform_message,
)

if TYPE_CHECKING:
    from twopose.format.reader import SessionReader

__all__ = [
    "SCENE_TOPIC",
    "ResultsWriter",
    "annotations_topic",
    "results_writer",
]

SCENE_TOPIC = RESULTS_TOPIC_PREFIX + "scene"


def annotations_topic(camera_id: str) -> str:
    return f"{RESULTS_TOPIC_PREFIX}camera/{camera_id}/annotations"


# --------------------------------------------------------------------------- the writer


class ResultsWriter:
    """Stream a session's results.mcap: frames as they are detected, scenes at the end.

    Use as a context manager; :meth:`add_pose` before that pose's frames.
    """

    def __init__(self, path: str | Path, cameras: list[Camera], ground: PlaneEntry | None):
        self.path = Path(path)
        self._file = self.path.open("wb")
        writer = McapWriter(self._file, compression=CompressionType.LZ4)
        writer.start(profile="", library="twopose")
        self._channels = Channels(writer)
        calibration, image, transform = SESSION_PROTOBUF
        self._channels.protobuf_schemas(*SESSION_PROTOBUF, ImageAnnotations, SceneUpdate)
        self._channels.protobuf(TF_TOPIC, transform)
        self._channels.protobuf(SCENE_TOPIC, SceneUpdate)
        for cam in cameras:
            self._channels.protobuf(calibration_topic(cam.camera_id), calibration)
            self._channels.protobuf(image_topic(cam.camera_id), image)
            self._channels.protobuf(annotations_topic(cam.camera_id), ImageAnnotations)
        self._sequence = 0
        self._cameras = cameras
        self._ground = ground
        self._started = False

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return dict(self._channels.counts)

    def _write(self, topic: str, msg: Any, log_time_ns: int) -> None:
        self._channels.write(topic, msg.SerializeToString(), log_time_ns, self._sequence)
        self._sequence += 1

    def _start(self, log_time_ns: int) -> None:
        if not self._started:
            self._started = True
            for cam in self._cameras:
                self._write(
                    calibration_topic(cam.camera_id),
                    calibration_message(cam, log_time_ns),
                    log_time_ns,
                )
            self._write(SCENE_TOPIC, static_scene(self._ground), log_time_ns)

    def add_pose(self, entry: PoseEntry, log_time_ns: int) -> None:
        self._start(log_time_ns)
        self._write(TF_TOPIC, transform_message(entry, log_time_ns), log_time_ns)

    def add_frame(self, frame: Frame, det: Detection, label: str) -> None:
        t = frame.log_time_ns
        self._start(t)
        img = image_message(frame.camera_id, frame.data, frame.format, t)
        self._write(image_topic(frame.camera_id), img, t)
        self._write(annotations_topic(frame.camera_id), image_annotations(det, t, label), t)

    def add_trial(self, scene: TrialScene, log_time_ns: int) -> None:
        self._start(log_time_ns)
        self._write(SCENE_TOPIC, trial_scene(scene, log_time_ns), log_time_ns)

    def close(self) -> None:
        if not self._file.closed:
            try:
                self._channels.writer.finish()
            finally:
                self._file.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


@contextlib.contextmanager
def results_writer(out: Path, reader: SessionReader) -> Iterator[ResultsWriter]:
    """The session's results.mcap (its cameras and ground as ``reader`` has them), written
    under a temporary name and renamed into place only when the analysis succeeds (a failure
    or a full disk leaves no half file), by the one atomic writer
    (:func:`twopose.atomic_write.replacing`: synced, renamed, folder synced)."""
    from twopose.atomic_write import replacing

    with replacing(out) as tmp:
        writer = ResultsWriter(tmp, list(reader.cameras.values()), reader.ground)
        try:
            yield writer
        finally:
            writer.close()
