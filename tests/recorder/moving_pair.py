"""A pair of cameras watching a moving dot, as two video files and a pair file (tests).

The simulator's scene seen by its pair (:func:`recorder.simulate.pair.simulated_pair`, at
320x240 so that it renders fast), the dot moved through the scene's four touch points
(:func:`twopose.sim.moving.touch_points`), staying :data:`DWELL_S` on each; camera 2 takes
its frame k :data:`PHASE_S` after camera 1's but its file stamps it k / fps as camera 1's
does, so its clock runs :data:`PHASE_S` behind: the clock offset is ``-PHASE_S``. The
files are MJPG AVIs played at their rate by ``--source pair:video:A,video:B``. Their
timeline: the dot still for :data:`LEAD_S`, then the path; ``touch_s`` the middle of each
stay, from the files' start.
"""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from recorder.simulate.pair import simulated_pair
from twopose.arrays import F64
from twopose.camera.model import Intrinsics
from twopose.methods.specs import Method
from twopose.pair.calibration import PairCalibration
from twopose.pair.pair_file import write_pair_file
from twopose.sim.moving import PairScene, Trajectory, touch_points
from twopose.sim.scene import Scene

FPS = 10.0
PHASE_S = 0.030
DWELL_S = 1.0
LEAD_S = 0.5
SPEED = 4.0  # in/s between the touches


@dataclass(frozen=True, kw_only=True)
class MovingPair:
    folder: Path
    pair_file: Path
    videos: tuple[Path, Path]
    touches: F64  # (4, 3) grid points, inches, camera 1's frame
    touch_s: F64  # (4,) the middle of each stay, from the files' start

    @property
    def source(self) -> str:
        return f"pair:video:{self.videos[0]},video:{self.videos[1]}"

    @staticmethod
    def plan(path: Path, trials: str) -> Path:
        """A pair's plan of method point in inches with ``trials`` (its [[trials]] tables),
        written at ``path`` (a test's own: the pair's folder is shared)."""
        path.write_text(f'method = "point"\nunits = "in"\noperator = "Ada"\n{trials}')
        return path


def _scene() -> tuple[Scene, PairCalibration, F64, Trajectory]:
    scene = Scene()
    k = scene.cameras[0].intrinsics
    half = Intrinsics(width=320, height=240, fx=k.fx / 2, fy=k.fy / 2, cx=k.cx / 2, cy=k.cy / 2)
    scene = scene.with_intrinsics(half)
    pair = simulated_pair(scene)
    touches = touch_points(scene, Method.POINT, pair)
    return scene, pair, touches, Trajectory(touches=touches, speed=SPEED, lead=1.0, dwell_s=DWELL_S)


def moving_pair(folder: Path) -> MovingPair:
    """The pair :func:`write_moving_pair` wrote into ``folder``: its files and timeline."""
    _, _, touches, path = _scene()
    return MovingPair(
        folder=folder, pair_file=folder / "PAIR.toml",
        videos=(folder / "cam1.avi", folder / "cam2.avi"), touches=touches,
        touch_s=path.touch_s + LEAD_S,
    )  # fmt: skip


def write_moving_pair(folder: Path, *, seconds: float | None = None) -> MovingPair:
    """Write the two videos (``seconds`` long: the path's whole time unless given) and the
    pair file into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    scene, pair, _, path = _scene()
    pair_scene = PairScene(scene, Method.POINT, pair, np.random.default_rng(0))
    n = round((seconds if seconds is not None else LEAD_S + path.duration_s + 0.5) * FPS)
    made = moving_pair(folder)
    for camera, (video, phase) in enumerate(zip(made.videos, (0.0, PHASE_S), strict=True), 1):
        writer = cv2.VideoWriter(str(video), cv2.VideoWriter.fourcc(*"MJPG"), FPS, (320, 240))
        for i in range(n):
            where = path.at(np.array([i / FPS + phase - LEAD_S]))[0]
            writer.write(pair_scene.frame(camera, where))
        writer.release()
    write_pair_file(made.pair_file, pair)
    return made


def timed_keys(keys: Sequence[tuple[float, str]]) -> Callable[[], str]:
    """An operator's lines for :class:`recorder.procedure.stream_terminal.KeyReader`: each
    ``(pause_s, line)`` given after its pause; then the input's end."""
    lines = iter(keys)

    def readline() -> str:
        pause, line = next(lines, (0.0, ""))
        time.sleep(pause)
        return line + "\n" if pause else ""

    return readline


def killed_while_streaming(process: subprocess.Popen[str], after_s: float = 3.0) -> float:
    """kill -9 ``process`` (a recording) ``after_s`` into its trial's stream; how long
    after the stream began it died (s)."""
    from tests.helpers import read_line_when_printed

    read_line_when_printed(process, "streaming", "the trial's stream")
    streamed = time.monotonic()
    time.sleep(after_s)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=30)
    return time.monotonic() - streamed


@dataclass(frozen=True)
class ConsoleOf:
    """A recording's console over HTTP (``new ... --ui`` run as ``process``)."""

    client: Any

    @classmethod
    def of(cls, process: subprocess.Popen[str]) -> ConsoleOf:
        """The console whose address ``process`` prints, its page read (the session's token)."""
        import httpx

        from tests.helpers import read_line_when_printed

        line, _ = read_line_when_printed(process, "http://", "the console's address")
        client = httpx.Client(base_url=line.split()[2], timeout=10)
        client.get("/")
        return cls(client)

    def state_when(self, waiting: str) -> dict[str, object]:
        """The console's state once it waits for ``waiting`` (fails after 10 s)."""
        state: dict[str, object] = {}
        for _ in range(400):
            state = self.client.get("/api/state").json()
            if state["waiting"] == waiting:
                return state
            time.sleep(0.025)
        raise AssertionError(f"never offered {waiting}: {state}")
