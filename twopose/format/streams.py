"""A two-camera session replayed: its pair, clock offset and stream trials (format 1.6).

The replay API the analysis and the console build on. :func:`read_pair_session` reads,
once, everything but the images: the pair (:class:`twopose.pair.calibration.
PairCalibration`, in the session's units), the clock offset (the last measured one,
:class:`twopose.pair.clock.ClockOffset`, and every one), each camera's clock source, and
per stream trial (:class:`StreamTrial`) each camera's frames' capture times and log times
(:class:`CameraStream`), its touches and, in a simulated session, its true trajectory.
The images are read lazily, while the reader is open: :meth:`CameraStream.frames` (in
order, window by window through the index), :meth:`CameraStream.images` (decoded) and
:meth:`CameraStream.image` (one). ::

    with SessionReader(path) as reader:
        session = read_pair_session(reader)
        for trial in session.trials:
            one, two = trial.camera1, trial.camera2
            pairing = pair_captures(one.capture_ns, two.capture_ns,
                                    offset_ns=session.offset.offset_ns)
            for image in one.images(): ...

Which frames a trial holds (docs/session-format.md): per camera, the frames on its image
topic inside the trial's windows (the last entry naming a window counts). A window that
holds fewer frames than it says (a chunk lost to corruption), or was cut short (an
``incomplete`` one: a crash that ``recover`` closed, a camera that stopped), makes its
camera's stream incomplete, with the reason; its frames are still given (each one's
capture time is as good as any other's).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import Ints
from twopose.camera.model import Camera
from twopose.errors import InputValueError, TwoposeError
from twopose.format.entries import (
    ClockOffsetEntry,
    PlaneEntry,
    SessionInfo,
    SimTrajectory,
    StreamWindow,
    Touch,
)
from twopose.format.messages import Frame, image_topic
from twopose.format.pair_convert import clock_offset
from twopose.format.reader import SessionReader

if TYPE_CHECKING:
    from twopose.pair.calibration import PairCalibration
    from twopose.pair.clock import ClockOffset

__all__ = ["CameraStream", "PairSession", "StreamTrial", "read_pair_session"]


@dataclass(frozen=True, kw_only=True, eq=False)
class CameraStream:
    """One camera's frames of a stream trial, their images read lazily.

    ``capture_ns`` (N,) int64 each frame's capture time on this camera's clock (strictly
    increasing), ``log_ns`` (N,) when it was written, ``sequence`` (N,) its sequence on the
    image topic; ``windows`` the trial's windows of this camera; ``reason`` why the stream
    is incomplete ("" when every window closed complete with the frames it says).
    """

    camera: Camera
    capture_ns: Ints
    log_ns: Ints
    sequence: Ints
    windows: tuple[StreamWindow, ...]
    reason: str = ""
    reader: SessionReader = field(repr=False)

    @property
    def camera_id(self) -> str:
        """The camera's id."""
        return self.camera.camera_id

    @property
    def complete(self) -> bool:
        """Whether every window closed complete, holding the frames it says."""
        return not self.reason

    def __len__(self) -> int:
        """How many frames."""
        return int(self.capture_ns.size)

    def frames(self) -> Iterator[Frame]:
        """The frames, in order (the reader must be open): read window by window."""
        topic = image_topic(self.camera_id)
        wanted = set(self.sequence.tolist())
        for w in self.windows:
            if w.n_frames == 0 and w.status != "open":
                continue
            end = None if w.status == "open" else w.end_ns
            for item in self.reader.iter_entries([topic], start_ns=w.start_ns, end_ns=end):
                if isinstance(item, Frame) and item.sequence in wanted:
                    yield item

    def images(self) -> Iterator[NDArray[np.uint8]]:
        """Each frame decoded, in order: (H, W, 3) BGR uint8, its size checked."""
        size = (self.camera.intrinsics.width, self.camera.intrinsics.height)
        for frame in self.frames():
            yield frame.decode(size)

    def image(self, k: int) -> NDArray[np.uint8]:
        """Frame ``k`` (0-based) decoded, read by its log time through the index."""
        if not 0 <= k < len(self):
            raise InputValueError(f"camera {self.camera_id} has {len(self)} frames, no frame {k}")
        t = int(self.log_ns[k])
        topic = image_topic(self.camera_id)
        for item in self.reader.iter_entries([topic], start_ns=t, end_ns=t):
            if isinstance(item, Frame) and item.sequence == int(self.sequence[k]):
                size = (self.camera.intrinsics.width, self.camera.intrinsics.height)
                return item.decode(size)
        raise TwoposeError(f"frame {k} of camera {self.camera_id} is not in the file")


@dataclass(frozen=True, kw_only=True, eq=False)
class StreamTrial:
    """A stream trial: both cameras' frames, the touches, a simulation's true trajectory."""

    trial: int
    camera1: CameraStream
    camera2: CameraStream
    touches: tuple[Touch, ...]
    trajectory: SimTrajectory | None = None

    @property
    def cameras(self) -> tuple[CameraStream, CameraStream]:
        """Camera 1's and camera 2's streams."""
        return self.camera1, self.camera2

    @property
    def complete(self) -> bool:
        """Whether both cameras' streams are complete."""
        return self.camera1.complete and self.camera2.complete


@dataclass(frozen=True, kw_only=True, eq=False)
class PairSession:
    """A two-camera session (:func:`read_pair_session`).

    ``pair`` its calibration (session units; the grid frame is camera 1's), ``offset`` the
    last clock offset recorded (None: never measured; the analysis measures it), every one
    in ``offsets``; ``clocks`` each camera's capture clock (``driver``, ``monotonic at
    grab``, ``simulated``; a camera left out: not said); ``trials`` its stream trials in
    order; ``unassigned`` how many frames lie outside every window (between trials).
    """

    path: Path
    info: SessionInfo
    pair: PairCalibration
    cameras: tuple[Camera, Camera]
    ground: PlaneEntry | None
    clocks: dict[str, str]
    offset: ClockOffset | None
    offsets: tuple[ClockOffset, ...]
    trials: tuple[StreamTrial, ...]
    unassigned: int = 0

    @property
    def touches(self) -> tuple[Touch, ...]:
        """Every trial's touches, in trial order."""
        return tuple(t for trial in self.trials for t in trial.touches)


@dataclass
class _Pass:
    """What one pass over the entries and the frames' headers gathered."""

    windows: dict[tuple[int, str, int], StreamWindow] = field(default_factory=dict)
    touches: dict[int, list[Touch]] = field(default_factory=lambda: defaultdict(list))
    offsets: list[ClockOffsetEntry] = field(default_factory=list)
    trajectories: dict[int, SimTrajectory] = field(default_factory=dict)
    frames: dict[str, list[tuple[int, int, int]]] = field(
        default_factory=lambda: defaultdict(list)
    )  # camera: (log time, capture time, sequence)


def _gather(reader: SessionReader) -> _Pass:
    topics = [c.TOPIC for c in (StreamWindow, Touch, ClockOffsetEntry, SimTrajectory)]
    topics += [image_topic(c) for c in reader.info.camera_ids]
    found = _Pass()
    for item in reader.iter_entries(topics):
        if isinstance(item, Frame):
            capture = item.log_time_ns if item.capture_ns is None else item.capture_ns
            found.frames[item.camera_id].append((item.log_time_ns, capture, item.sequence))
        elif isinstance(item, StreamWindow):  # the last entry naming a window counts
            found.windows[(item.trial, item.camera_id, item.window)] = item
        elif isinstance(item, Touch):
            found.touches[item.trial].append(item)
        elif isinstance(item, ClockOffsetEntry):
            found.offsets.append(item)
        elif isinstance(item, SimTrajectory):
            found.trajectories[item.trial] = item
    return found


def _camera_stream(
    reader: SessionReader, camera: Camera, windows: list[StreamWindow], frames: NDArray[np.int64]
) -> tuple[CameraStream, NDArray[np.bool_]]:
    """One camera's stream of one trial, and which of its frames (rows of ``frames``) it took.

    ``frames`` (F, 3): every frame of the camera, (log time, capture time, sequence), in
    log-time order; a window takes those inside its span (an ``open`` one, never closed:
    those from its start to the next window's).
    """
    taken = np.zeros(len(frames), dtype=bool)
    reasons: list[str] = []
    log = frames[:, 0] if len(frames) else np.zeros(0, dtype=np.int64)
    for k, w in enumerate(windows):
        if w.status == "open":
            later = [v.start_ns for v in windows[k + 1 :]]
            inside = (log >= w.start_ns) & (log < min(later)) if later else log >= w.start_ns
            reasons.append(
                f"window {w.window}'s closing entry is missing (a part of the file was lost)"
                if later
                else f"window {w.window} was never closed (the recording stopped)"
            )
        else:
            inside = (log >= w.start_ns) & (log <= w.end_ns) if w.n_frames else log < 0
            if w.status != "complete":
                reasons.append(f"window {w.window}: {w.reason or 'cut short'}")
            if int(inside.sum()) != w.n_frames:
                reasons.append(
                    f"window {w.window} holds {int(inside.sum())} of the {w.n_frames} frames it "
                    "says (a part of the file was lost)"
                )
        taken |= inside
    mine = frames[taken] if len(frames) else np.zeros((0, 3), dtype=np.int64)
    if mine.size and (np.diff(mine[:, 1]) <= 0).any():
        reasons.append("its capture times do not increase (a clock went back)")
    stream = CameraStream(
        camera=camera,
        capture_ns=mine[:, 1].copy(),
        log_ns=mine[:, 0].copy(),
        sequence=mine[:, 2].copy(),
        windows=tuple(windows),
        reason="; ".join(reasons),
        reader=reader,
    )
    return stream, taken


def read_pair_session(reader: SessionReader) -> PairSession:
    """A two-camera session's pair, offset and stream trials (the module docstring).

    Raises :class:`~twopose.errors.InputValueError` for a session that is not a
    two-camera one (it has no pair).
    """
    pair = reader.pair
    if pair is None:
        raise InputValueError(
            f"{reader.path} is a one-camera session (no pair): its trials are typed poses, "
            "read by twopose.format.trials.iter_trials"
        )
    found = _gather(reader)
    ids = reader.info.camera_ids
    cameras = (reader.cameras[ids[0]], reader.cameras[ids[1]])
    frames = {c: np.array(found.frames.get(c, []), dtype=np.int64).reshape(-1, 3) for c in ids}
    taken = {c: np.zeros(len(frames[c]), dtype=bool) for c in ids}
    trials = []
    for trial in sorted({key[0] for key in found.windows} | set(found.touches)):
        streams = []
        for camera in cameras:
            cid = camera.camera_id
            windows = sorted(
                (w for (t, c, _), w in found.windows.items() if t == trial and c == cid),
                key=lambda w: w.window,
            )
            stream, took = _camera_stream(reader, camera, windows, frames[cid])
            taken[cid] |= took
            streams.append(stream)
        trials.append(
            StreamTrial(
                trial=trial,
                camera1=streams[0],
                camera2=streams[1],
                touches=tuple(sorted(found.touches.get(trial, []), key=lambda t: t.touch)),
                trajectory=found.trajectories.get(trial),
            )
        )
    offsets = tuple(clock_offset(o) for o in found.offsets)
    return PairSession(
        path=reader.path,
        info=reader.info,
        pair=pair,
        cameras=cameras,
        ground=reader.ground,
        clocks=dict(reader.info.clocks or {}),
        offset=offsets[-1] if offsets else None,
        offsets=offsets,
        trials=tuple(trials),
        unassigned=sum(int((~t).sum()) for t in taken.values()),
    )
