"""The synthetic camera as a frame source (``--source synthetic[:SCENE.toml]``): the
simulator's scene rendered from the pose the operator types, in the session's units and
through the session's camera. Opening renders nothing; a new pose's view is cut between two
bands of rays when the recording is asked to stop (:mod:`recorder.procedure.stops`).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

from typing_extensions import override

from recorder.procedure import stops
from recorder.sources.base import FrameSource, Pacer, SourceInfo
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.values.units import Units

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np
    from numpy.typing import NDArray

    from twopose.camera.model import Camera
    from twopose.detect.clutter import Clutter
    from twopose.sim.scene import Scene

    Image = NDArray[np.uint8]

__all__ = ["SyntheticSource"]


class SyntheticSource(FrameSource):
    """The simulator's camera: renders the scene from the pose last given to ``set_pose``.

    Setting a pose renders it (ray casting: a stop cuts in between two bands of rays,
    :mod:`twopose.sim.render`); ``read`` gives a bank of ``bank`` frames made from it, each
    with its own lighting and noise, each exposed when it is first read and then cycled
    through, paced like a camera at the scene's fps when ``realtime``, so even 1280x720
    streams at 30 fps. Opening renders nothing: the first frame read before any pose is
    typed shows the camera at the grid's origin.
    """

    def __init__(
        self,
        scene_path: str | Path | None = None,
        method: Method = Method.GROUND,
        *,
        seed: int = 0,
        realtime: bool = True,
        bank: int = 8,
        units: Units | None = None,
        cameras: Sequence[Camera] | None = None,
    ) -> None:
        import numpy as np

        from twopose.sim.scene import load_scene

        self.scene = load_scene(scene_path)
        if units is not None and self.scene.units != units:
            # The session's units (issue 44, 4): the typed poses are read in them, so the
            # same scene is rendered with its lengths converted (twopose.values.units' factors).
            self.scene = self.scene.in_units(units)
        if cameras:
            # The session's camera (issue 44, 4): its intrinsics are what the analysis
            # reads the frames with, so the scene is seen through them.
            self.scene = _seen_through(self.scene, cameras, scene_path)
        self.method = method
        self.realtime = realtime
        self.bank_size = bank
        self._rng = np.random.default_rng(seed)
        self._bank: list[Image] = []
        self._next = 0
        self._pose: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None

    def open(self) -> SourceInfo:
        from twopose.sim.camera import SyntheticCamera
        from twopose.sim.layout import build_layout

        layout = build_layout(self.scene, Method(self.method), self._rng)
        self._camera = SyntheticCamera(self.scene, layout, self._rng)
        cam = self.scene.cameras[0]
        self.info = SourceInfo(
            description="synthetic", width=cam.width, height=cam.height, fps=self.scene.sensor.fps
        )
        self._pacer = Pacer(self.info.fps) if self.realtime else None
        stops.check()  # a stop asked while it opened: nothing is recorded
        return self.info

    def set_pose(
        self, t_grid: tuple[float, float, float], r_deg: tuple[float, float, float]
    ) -> None:
        """The operator typed this pose and placed the laptop there: the camera renders
        from where the scene's rig (``[systematic]``) really puts it, as ``simulate``
        does (one synthetic camera: :class:`twopose.sim.camera.SyntheticCamera`). A stop
        asked meanwhile raises KeyboardInterrupt between two bands of rays
        (:mod:`recorder.procedure.stops`); the pose before stays the one shown."""
        import numpy as np

        if (t_grid, r_deg) == self._pose:
            return
        self._camera.place(
            np.asarray(t_grid, dtype=np.float64), np.asarray(r_deg), between=stops.check
        )
        self._pose, self._bank, self._next = (t_grid, r_deg), [], 0

    @override
    def clutter(self) -> Clutter | None:
        from twopose.detect.clutter import scene_clutter

        return scene_clutter(
            self._camera.layout.decals, self.scene.ground_height, self.scene.wall_z
        )

    @override
    def read(self, timeout_s: float = 2.0) -> Image:
        if self._pose is None:  # nothing typed yet: the camera at the origin
            self.set_pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        if self._pacer is not None:
            self.dropped += self._pacer.wait()
        k = self._next % self.bank_size
        if k == len(self._bank):  # this frame's first reading: exposed now
            started = time.monotonic()
            self._bank.append(self._camera.expose())
            if self._pacer is not None and self._pacer.due is not None:
                # A camera's sensor works beside its reader: the time this one takes to
                # make a frame is not the reader's delay, nor a frame it missed.
                self._pacer.due += time.monotonic() - started
        self._next += 1
        return self._bank[k]


def _seen_through(scene: Scene, cameras: Sequence[Camera], scene_path: object) -> Scene:
    """``scene`` seen through the session's camera, or an :class:`InputValueError` saying
    why it cannot be (before anything is recorded)."""
    from twopose.errors import SceneError

    first = cameras[0]
    differ = [c.camera_id for c in cameras[1:] if c.intrinsics != first.intrinsics]
    if differ:
        raise InputValueError(
            f"the synthetic camera renders one camera, and the session's cameras "
            f"{first.camera_id} and {', '.join(differ)} have different intrinsics: record "
            "each camera's poses as a session of its own, or give them the same intrinsics"
        )
    k = first.intrinsics
    try:
        return scene.with_intrinsics(k)
    except SceneError as err:
        where = f"the scene {scene_path}" if scene_path else "the default scene"
        raise InputValueError(
            f"the synthetic camera cannot render the session's camera {first.camera_id} "
            f"({k.width}x{k.height}, fx {k.fx:g}, fy {k.fy:g}, principal {k.cx:g}, {k.cy:g} px) "
            f"with {where}: {err}; change the session's camera (the plan's [camera], "
            "--focal/--principal/--width/--height) or the scene's [[cameras]]"
        ) from err
