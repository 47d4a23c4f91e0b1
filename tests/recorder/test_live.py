"""The live view, for real: a WebSocket client speaking the Foxglove protocol connects to the
recorder's server, subscribes, and checks that frames, overlays and status arrive."""

from __future__ import annotations

import json
import struct
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from websockets.sync.client import ClientConnection, connect

from analysis.session.pipeline import analyse_session
from recorder.live.view import RESULT_TOPIC, SCENE_TOPIC, STATUS_TOPIC, LiveView, annotations_topic
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from twopose.errors import InputValueError
from twopose.format.messages import image_topic
from twopose.methods.specs import Method

PLAN = """
method = "ground"
frames = 2
ground_height = 9.625
[camera]
focal = 525.0
[[trials]]
ground_truth = [[1.91, 9.625, 8.375]]
poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.5, 0.0, -1.0] }]
"""
SUBPROTOCOLS: Any = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


def _subscribe(ws: ClientConnection, topics: set[str]) -> dict[int, str]:
    """Wait for the server to advertise ``topics``, subscribe; subscription id -> topic."""
    channels: dict[str, int] = {}
    deadline = time.monotonic() + 10
    while not topics <= set(channels) and time.monotonic() < deadline:
        msg = ws.recv(timeout=5)
        if isinstance(msg, str):
            data = json.loads(msg)
            if data.get("op") == "advertise":
                channels |= {c["topic"]: c["id"] for c in data["channels"]}
    assert topics <= set(channels), f"not advertised: {topics - set(channels)}"
    subscriptions = dict(enumerate(sorted(topics), start=1))
    ws.send(
        json.dumps(
            {
                "op": "subscribe",
                "subscriptions": [
                    {"id": i, "channelId": channels[t]} for i, t in subscriptions.items()
                ],
            }
        )
    )
    return subscriptions


def _collect(
    ws: ClientConnection, subscriptions: dict[int, str], want: dict[str, int]
) -> dict[str, list[tuple[int, bytes]]]:
    """Binary message-data frames (opcode 1) by topic, until ``want`` counts or a timeout."""
    got: dict[str, list[tuple[int, bytes]]] = {t: [] for t in subscriptions.values()}
    deadline = time.monotonic() + 20
    while any(len(got[t]) < n for t, n in want.items()) and time.monotonic() < deadline:
        try:
            msg = ws.recv(timeout=2)
        except TimeoutError:
            continue
        if isinstance(msg, bytes) and msg[0] == 1:
            sub_id, log_time = struct.unpack_from("<IQ", msg, 1)
            got[subscriptions[sub_id]].append((log_time, msg[13:]))
    return got


def test_a_client_sees_frames_overlays_and_status(tmp_path: Path) -> None:
    plan = load_plan(_plan_file(tmp_path))
    with LiveView(list(plan.cameras), port=0) as view:
        assert view.url.startswith("ws://127.0.0.1:")
        with connect(view.url, subprotocols=SUBPROTOCOLS, open_timeout=10) as ws:
            per_frame = {image_topic("cam0"), annotations_topic("cam0"), STATUS_TOPIC}
            topics = per_frame | {SCENE_TOPIC, RESULT_TOPIC}
            subscriptions = _subscribe(ws, topics)
            time.sleep(0.5)  # the server takes the subscription asynchronously
            out = tmp_path / "s.mcap"
            record_plan(plan, out, SyntheticSource(None, Method.GROUND, realtime=False), live=view)
            want = dict.fromkeys(per_frame, 4) | {SCENE_TOPIC: 1, RESULT_TOPIC: 1}
            got = _collect(ws, subscriptions, want)
    session = analyse_session(out)
    frames = session.frames
    assert {t: len(got[t]) for t in topics} == want
    # The trial's live result: as JSON, the analysis' estimate; in 3-D, its entities.
    (_, result_bytes), (_, scene_bytes) = got[RESULT_TOPIC][0], got[SCENE_TOPIC][0]
    live = json.loads(result_bytes)
    row = session.trials.iloc[0]
    np.testing.assert_allclose(live["point"], row[["x", "y", "z"]].to_numpy(float), atol=1e-9)
    assert live["error"] == pytest.approx(row["err"], abs=1e-9)
    entities = {e.id for e in SceneUpdate.FromString(scene_bytes).entities}
    assert {"cameras", "measurements", "estimate", "truth", "error"} <= entities
    for (t_img, img_bytes), (t_ann, ann_bytes), (_, row) in zip(
        got[image_topic("cam0")], got[annotations_topic("cam0")], frames.iterrows(), strict=True
    ):
        image = CompressedImage.FromString(img_bytes)
        overlay = ImageAnnotations.FromString(ann_bytes)
        assert t_img == t_ann == row["log_time_ns"]  # the very frames the session holds
        assert image.format == "jpeg"
        assert image.data[:2] == b"\xff\xd8"
        centre = overlay.circles[0].position
        # Live detection sees the frame as stored, as the analysis does: the same centroid.
        np.testing.assert_allclose([centre.x, centre.y], [row["col"], row["row"]], atol=1e-6)
    status = [json.loads(b) for _, b in got[STATUS_TOPIC]]
    assert [(s["trial"], s["pose"], s["frame"]) for s in status] == [
        (1, 1, 1),
        (1, 1, 2),
        (1, 2, 1),
        (1, 2, 2),
    ]
    assert all(s["found"] for s in status)


def _plan_file(tmp_path: Path) -> Path:
    path = tmp_path / "plan.toml"
    path.write_text(PLAN)
    return path


def test_the_live_view_only_binds_to_loopback() -> None:
    with pytest.raises(InputValueError, match="loopback"):
        LiveView([], host="0.0.0.0", port=0)


def test_a_busy_port_is_a_clear_error() -> None:
    from twopose.errors import TwoposeError

    with LiveView([], port=0) as first, pytest.raises(TwoposeError, match="--live-port"):
        LiveView([], port=first.port)


def test_record_new_live_serves_while_recording(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from recorder.cli.app import app

    out = tmp_path / "s.mcap"
    args = ["new", str(out), "--plan", str(_plan_file(tmp_path)), "--source", "synthetic"]
    result = CliRunner().invoke(app, [*args, "--live", "--live-port", "0"])
    assert result.exit_code == 0, result.output
    assert "live view on ws://127.0.0.1:" in result.output
    assert analyse_session(out).trials["status"].tolist() == ["ok"]


def _handshake(port: int, host: str, origin: str | None) -> str:
    """The status line the server answers a raw WebSocket upgrade with (a real client: a
    socket speaking HTTP, so that Host and Origin can be anything a browser might send)."""
    import base64
    import os
    import socket

    key = base64.b64encode(os.urandom(16)).decode()
    lines = [
        "GET / HTTP/1.1",
        f"Host: {host}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        f"Sec-WebSocket-Key: {key}",
        "Sec-WebSocket-Version: 13",
        "Sec-WebSocket-Protocol: foxglove.websocket.v1",
    ]
    if origin is not None:
        lines.append(f"Origin: {origin}")
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
        return sock.recv(4096).decode(errors="replace").split("\r\n", 1)[0]


@pytest.mark.parametrize(
    ("host", "origin", "allowed"),
    [
        ("127.0.0.1:{port}", None, True),  # Foxglove desktop, scripts: no Origin
        ("localhost:{port}", "http://localhost:3000", False),  # another local page
        ("[::1]:{port}", "http://127.0.0.1:8080", False),  # a notebook, a dev server
        ("127.0.0.1:{port}", "http://127.0.0.1:8799", True),  # the console's own page
        ("127.0.0.1:{port}", "http://127.0.0.1:8799/", True),
        ("127.0.0.1:{port}", "http://127.0.0.1:87990", False),
        ("127.0.0.1:{port}", "https://evil.example", False),  # a web page elsewhere
        ("127.0.0.1:{port}", "null", False),  # a sandboxed or file page
        ("evil.example:{port}", None, False),  # DNS rebinding: a foreign Host
        ("evil.example:{port}", "http://evil.example", False),
    ],
)
def test_the_live_view_refuses_handshakes_from_web_pages(
    host: str, origin: str | None, allowed: bool
) -> None:
    from twopose.camera.model import Camera, Intrinsics

    with LiveView(
        [
            Camera(
                camera_id="cam0",
                intrinsics=Intrinsics(width=64, height=48, fx=50, fy=50, cx=32, cy=24),
            )
        ],
        port=0,
        origins=["http://127.0.0.1:8799"],
    ) as view:
        status = _handshake(view.port, host.format(port=view.port), origin)
        if allowed:
            assert " 101 " in status + " ", status
        else:
            assert " 403 " in status + " ", status
        if origin is None and allowed:  # and a real client still talks through the guard
            with connect(view.url, subprotocols=SUBPROTOCOLS, open_timeout=10) as ws:
                assert json.loads(ws.recv(timeout=10))["op"] == "serverInfo"


def _listening_ports() -> set[int]:
    """The loopback TCP ports this process listens on."""
    import os

    import psutil

    return {
        c.laddr.port
        for c in psutil.Process(os.getpid()).net_connections(kind="tcp")
        if c.status == psutil.CONN_LISTEN
    }


def test_no_socket_of_the_live_view_lets_a_foreign_page_in() -> None:
    """Every port the live view opens (the guard's and the SDK server's behind it) gets a
    foreign page's handshake: none answers 101, and the guard answers 403."""
    from twopose.camera.model import Camera, Intrinsics

    before = _listening_ports()
    cam = Camera(
        camera_id="cam0", intrinsics=Intrinsics(width=64, height=48, fx=50, fy=50, cx=32, cy=24)
    )
    with LiveView([cam], port=0) as view:
        opened = _listening_ports() - before
        assert view.port in opened
        assert len(opened) == 2, opened  # the guard and the SDK's server
        for port in opened:
            for host, origin in [
                ("evil.test:8799", "http://evil.test:8799"),  # DNS rebinding
                (f"127.0.0.1:{port}", "http://127.0.0.1:8080"),  # another local page
                (f"127.0.0.1:{port}", "https://evil.example"),
            ]:
                try:
                    status = _handshake(port, host, origin)
                except (ConnectionError, TimeoutError):
                    status = "dropped"
                assert " 101 " not in status + " ", (port, status)
                if port == view.port:
                    assert " 403 " in status + " ", status
