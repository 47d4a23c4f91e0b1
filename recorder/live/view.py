"""Live view: what the recorder captures, served to Foxglove (or Lichtblick) as it happens.

``twopose-record new --live`` starts a Foxglove WebSocket server (the foxglove-sdk's) on
loopback, ws://127.0.0.1:8765 by default. Connect Foxglove with *Open connection → Foxglove
WebSocket*. Per frame it sends the image as it was written to the session, the detection
overlay (the same ``foxglove.ImageAnnotations`` as results.mcap: outline, centroid and
orientation in green, turned-down candidates in red with the reason) and the trial status
as JSON. Off by default; the server only ever binds to a loopback address, and web pages
are kept out of every socket it opens (:mod:`recorder.live.guard`).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from types import TracebackType
from typing import TYPE_CHECKING, Any, Self

from foxglove_schemas_protobuf.CameraCalibration_pb2 import CameraCalibration
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap_protobuf.schema import build_file_descriptor_set

from recorder.console.loopback import is_loopback_host
from twopose.camera.model import Camera
from twopose.display.scene import TrialScene, image_annotations, trial_scene
from twopose.errors import InputValueError, TwoposeError
from twopose.format.messages import (
    calibration_message,
    calibration_topic,
    image_message,
    image_topic,
)
from twopose.values import jsonsafe

if TYPE_CHECKING:
    from recorder.live.trial_result import TrialResult
    from twopose.detect.detection import Detection

__all__ = [
    "DEFAULT_LIVE_PORT",
    "RESULT_TOPIC",
    "SCENE_TOPIC",
    "STATUS_TOPIC",
    "LiveView",
    "annotations_topic",
]

DEFAULT_LIVE_PORT = 8765
STATUS_TOPIC = "/twopose/live/status"
SCENE_TOPIC = "/twopose/live/scene"  # foxglove.SceneUpdate: the trial's live result in 3-D
RESULT_TOPIC = "/twopose/live/result"  # JSON: the trial's live result (TrialResult.to_json)
STATUS_SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "twopose.LiveStatus",
    "description": "The recorder's progress: where it is and what the last frame showed.",
    "type": "object",
    "properties": {
        "trial": {"type": "integer"},
        "pose": {"type": "integer"},
        "frame": {"type": "integer"},
        "n_frames": {"type": "integer"},
        "found": {"type": ["boolean", "null"]},
        "message": {"type": "string"},
    },
    "required": ["trial", "pose", "frame", "n_frames", "message"],
}


def annotations_topic(camera_id: str) -> str:
    return f"/twopose/live/camera/{camera_id}/annotations"


class LiveView:
    """A Foxglove WebSocket server carrying the recorder's frames, overlays and status.

    Parameters
    ----------
    cameras : list of Camera
    port : int
        0 picks a free port (see :attr:`port`).
    host : str
        Must be a loopback address: the live view is for the operator's own machine.
    origins : iterable of str
        Web pages let in (exactly these origins, such as the recorder's own console);
        clients without an ``Origin`` (Foxglove's desktop app, scripts) always are.
    """

    def __init__(
        self,
        cameras: list[Camera],
        *,
        port: int = DEFAULT_LIVE_PORT,
        host: str = "127.0.0.1",
        origins: Iterable[str] = (),
    ):
        if not is_loopback_host(host):
            raise InputValueError(f"the live view only binds to loopback, not {host!r}")
        import foxglove

        from recorder.live.guard import LoopbackGuard
        from recorder.live.tls import UpstreamSecret

        self._context = foxglove.Context()
        secret = UpstreamSecret.generate()
        try:  # the SDK's server, TLS only, on a private port; the guard faces the operator
            self._server = foxglove.start_server(
                name="twopose recorder",
                host="127.0.0.1",
                port=0,
                context=self._context,
                tls_cert=secret.cert_pem,
                tls_key=secret.key_pem,
            )
            self._guard = LoopbackGuard(
                host, port, int(self._server.port), secret=secret, origins=origins
            )
        except Exception as err:  # the SDK raises its own error types for a busy port
            if hasattr(self, "_server"):
                self._server.stop()
            raise TwoposeError(
                f"cannot start the live view on {host}:{port} ({err}); is another recorder "
                "running? Pick another port with --live-port"
            ) from err
        self.host = host

        def proto_channel(topic: str, message: Any) -> Any:
            schema = foxglove.Schema(
                name=message.DESCRIPTOR.full_name,
                encoding="protobuf",
                data=build_file_descriptor_set(message).SerializeToString(),
            )
            return foxglove.Channel(
                topic, schema=schema, message_encoding="protobuf", context=self._context
            )

        self._images = {
            c.camera_id: proto_channel(image_topic(c.camera_id), CompressedImage) for c in cameras
        }
        self._overlays = {
            c.camera_id: proto_channel(annotations_topic(c.camera_id), ImageAnnotations)
            for c in cameras
        }
        self._calibrations = {
            c.camera_id: proto_channel(calibration_topic(c.camera_id), CameraCalibration)
            for c in cameras
        }
        self._cameras = {c.camera_id: c for c in cameras}
        self._scene = proto_channel(SCENE_TOPIC, SceneUpdate)
        self._result = foxglove.Channel(
            RESULT_TOPIC,
            schema=foxglove.Schema(name="twopose.TrialResult", encoding="jsonschema", data=b"{}"),
            message_encoding="json",
            context=self._context,
        )
        self._status = foxglove.Channel(
            STATUS_TOPIC,
            schema=foxglove.Schema(
                name="twopose.LiveStatus",
                encoding="jsonschema",
                data=json.dumps(STATUS_SCHEMA).encode(),
            ),
            message_encoding="json",
            context=self._context,
        )

    @property
    def port(self) -> int:
        return self._guard.port

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def frame(
        self,
        camera_id: str,
        data: bytes,
        image_format: str,
        log_time_ns: int,
        detection: Detection | None,
        label: str,
    ) -> None:
        """One captured frame (already encoded), with its detection overlay if any."""
        cam = self._cameras[camera_id]
        self._calibrations[camera_id].log(
            calibration_message(cam, log_time_ns).SerializeToString(), log_time=log_time_ns
        )
        img = image_message(camera_id, data, image_format, log_time_ns)
        self._images[camera_id].log(img.SerializeToString(), log_time=log_time_ns)
        if detection is not None:
            overlay = image_annotations(detection, log_time_ns, label)
            self._overlays[camera_id].log(overlay.SerializeToString(), log_time=log_time_ns)

    def status(
        self,
        log_time_ns: int,
        *,
        trial: int,
        pose: int,
        frame: int,
        n_frames: int,
        message: str,
        found: bool | None = None,
    ) -> None:
        status = {
            "trial": trial,
            "pose": pose,
            "frame": frame,
            "n_frames": n_frames,
            "found": found,
            "message": message,
        }
        self._status.log(jsonsafe.dumps(status).encode(), log_time=log_time_ns)

    def trial_result(self, result: TrialResult, scene: TrialScene | None, log_time_ns: int) -> None:
        """A trial's live result: as JSON (NaN and infinity as null), and in 3-D
        (cameras, rays or planes, the estimate with its 95% ellipsoid, the truth and the
        error vector)."""
        self._result.log(jsonsafe.dumps(result.to_json()).encode(), log_time=log_time_ns)
        if scene is not None:
            update = trial_scene(scene, log_time_ns)
            self._scene.log(update.SerializeToString(), log_time=log_time_ns)

    def close(self) -> None:
        self._guard.close()
        self._server.stop()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
