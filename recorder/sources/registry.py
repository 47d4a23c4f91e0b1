"""Frame sources behind one interface (:mod:`recorder.sources.base`): a camera, a video file,
a folder of images, or the synthetic camera that renders the simulator's scene from the pose
the operator types (:mod:`recorder.sources.synthetic`); the kinds as the operator names them.

``open_source("camera:0" | "video:PATH" | "images:DIR[/PATTERN]" | "synthetic[:SCENE.toml]")``
gives a :class:`FrameSource`; use it as a context manager and call
:meth:`FrameSource.read`. A source that cannot open, stops delivering, or times out raises
:class:`SourceError` with a message saying which and what to try. The kinds are registered
(:data:`SOURCES`); an extension adds its own with :func:`register_source`.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from typing_extensions import override

from recorder.sources.base import (
    FrameSource,
    Pacer,
    SourceInfo,
    open_camera,
    open_video,
    pair_spec,
    parse_pair,
    refuse_same,
)
from recorder.sources.pair_feeds import CameraFeed, Feed, PacedFeed, StillsFeed, VideoFeed
from recorder.sources.synthetic import SyntheticSource
from twopose.errors import InputValueError, SourceError
from twopose.methods.specs import Method
from twopose.registry import Listing, Registry, load_extensions
from twopose.values.units import Units

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    import numpy as np
    from numpy.typing import NDArray

    from recorder.sources.pair import PairSource, QueueBound
    from twopose.camera.model import Camera

    Image = NDArray[np.uint8]

__all__ = [
    "FEEDS",
    "SOURCES",
    "SOURCE_KINDS",
    "CameraSource",
    "FrameSource",
    "ImagesSource",
    "SourceInfo",
    "SourceKind",
    "SourceOptions",
    "SyntheticSource",
    "VideoSource",
    "kind_of",
    "one_camera",
    "open_from",
    "open_pair",
    "open_source",
    "open_video",
    "pair_spec",
    "parse_pair",
    "register_feed",
    "register_source",
    "source_help",
    "source_kinds_table",
]

# OpenCV and NumPy are imported where a source opens or reads (Image is NumPy's array, for
# the type checker alone), so that the command line's --help, which lists the SOURCE_KINDS,
# loads neither (tests/test_layering.py).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


class CameraSource(FrameSource):
    """An OpenCV capture device; frames are grabbed on a thread so ``read`` can time out.

    ``device`` is a camera index, or anything else ``cv2.VideoCapture`` opens (a stream URL).
    """

    what_it_reads = "camera device"

    def __init__(
        self, device: int | str, width: int = 640, height: int = 480, fps: float = 30.0
    ) -> None:
        self.device, self.width, self.height, self.fps = device, width, height, fps
        self._cap: Any = None
        self._frames: queue.Queue[Image | None] = queue.Queue(maxsize=2)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def origin(self) -> tuple[object, ...]:
        device = self.device
        return (type(self), device if isinstance(device, int) else _resolved(Path(device)))

    def open(self) -> SourceInfo:

        self._cap, self.info = open_camera(self.device, self.width, self.height, self.fps)
        self._thread = threading.Thread(target=self._grab, daemon=True)
        self._thread.start()
        return self.info

    def _grab(self) -> None:
        import numpy as np

        while not self._stop.is_set():
            ok, frame = self._cap.read()
            if not ok:
                self._frames.put(None)  # the camera stopped delivering
                return
            if self._frames.full():  # keep the newest: drop the oldest unread frame
                with contextlib.suppress(queue.Empty):
                    self._frames.get_nowait()
                    self.dropped += 1
            self._frames.put(np.asarray(frame, dtype=np.uint8))

    def start_capture(self) -> None:
        """Frames queued before the capture are stale (the laptop was being moved): drop
        them without counting them."""
        while True:
            try:
                self._frames.get_nowait()
            except queue.Empty:
                return

    def read(self, timeout_s: float = 2.0) -> Image:
        try:
            frame = self._frames.get(timeout=timeout_s)
        except queue.Empty as err:
            raise SourceError(f"camera {self.device} sent no frame for {timeout_s:g} s") from err
        if frame is None:
            raise SourceError(f"camera {self.device} stopped delivering frames (unplugged?)")
        return frame

    def close(self) -> None:
        self._stop.set()
        if self._cap is not None:
            self._cap.release()
        if self._thread is not None:
            self._thread.join(timeout=2.0)


class VideoSource(FrameSource):
    """Frames of a video file, in order; with ``realtime``, paced like a camera at the
    file's frame rate (frames a late reader misses are skipped and counted as dropped)."""

    what_it_reads = "video file"

    def __init__(self, path: str | Path, *, realtime: bool = False) -> None:
        self.path = Path(path)
        self.realtime = realtime
        self._cap: Any = None

    def origin(self) -> tuple[object, ...]:
        return (type(self), _resolved(self.path))

    def file_paths(self) -> list[Path]:
        return [self.path] if self.path.is_file() else []

    def open(self) -> SourceInfo:
        self._cap, self.info = open_video(self.path)
        self._pacer = Pacer(self.info.fps) if self.realtime else None
        return self.info

    @override
    def read(self, timeout_s: float = 2.0) -> Image:
        import numpy as np

        if self._pacer is not None:
            missed = self._pacer.wait()
            for _ in range(missed):  # the camera moved on without us
                self._cap.grab()
            self.dropped += missed
        ok, frame = self._cap.read()
        if not ok:
            raise SourceError(f"video {self.path} has no more frames")
        return np.asarray(frame, dtype=np.uint8)

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()


class ImagesSource(FrameSource):
    """The images of a folder, in file-name order: ``DIR`` (every image in it) or
    ``DIR/PATTERN`` (a shell pattern such as ``photos/left*.jpg``: a folder often holds
    more than one camera's views)."""

    what_it_reads = "folder of images"

    stills = True

    def __init__(self, folder: str | Path) -> None:
        self.spelled = Path(folder)
        name = self.spelled.name
        self.pattern = name if any(c in name for c in "*?[") else None
        self.folder = self.spelled.parent if self.pattern else self.spelled
        self._files: list[Path] = []
        self._next = 0

    def origin(self) -> tuple[object, ...]:
        return (type(self), _resolved(self.folder), self.pattern)

    def file_paths(self) -> list[Path]:
        if not self.folder.is_dir():
            return []
        names = self.folder.glob(self.pattern) if self.pattern else self.folder.iterdir()
        return sorted(p for p in names if p.suffix.lower() in IMAGE_SUFFIXES)

    def open(self) -> SourceInfo:
        if not self.folder.is_dir():
            raise SourceError(f"image folder {self.folder} does not exist")
        self._files = self.file_paths()
        if not self._files and self.pattern:
            raise SourceError(f"no image in {self.folder} matches {self.pattern}")
        if not self._files:
            raise SourceError(f"{self.spelled} holds no images ({', '.join(IMAGE_SUFFIXES)})")
        first = self._load(self._files[0])
        self.info = SourceInfo(
            description=f"images:{self.spelled}",
            width=first.shape[1],
            height=first.shape[0],
            fps=30.0,
        )
        return self.info

    def _load(self, path: Path) -> Image:
        from twopose.camera.images import decode_image

        try:
            return decode_image(path.read_bytes(), str(path))
        except (OSError, InputValueError) as err:
            raise SourceError(str(err)) from err

    @override
    def read(self, timeout_s: float = 2.0) -> Image:
        if self._next >= len(self._files):
            raise SourceError(f"no more images in {self.spelled} ({len(self._files)} used)")
        path = self._files[self._next]
        self._next += 1
        return self._load(path)

    def frame_name(self, index: int) -> str:
        return self._files[index].name if index < len(self._files) else super().frame_name(index)


@dataclass(frozen=True, kw_only=True)
class SourceOptions:
    """What the session asks of a source; each kind's opener takes what it uses."""

    method: Method = Method.GROUND
    width: int = 640
    height: int = 480
    fps: float = 30.0
    realtime: bool = True
    units: Units | None = None
    cameras: Sequence[Camera] | None = None


@dataclass(frozen=True, kw_only=True)
class SourceKind:
    """One kind of frame source, as the operator types it: ``NAME`` or ``NAME:ARG``.

    Registered once in :data:`SOURCE_KINDS`; :func:`open_source`, the CLI's ``--source``
    help (:func:`source_help`) and the docs' list of sources all read it from there.
    """

    #: What the operator types before the colon (``camera``).
    name: str
    #: The syntax as the operator types it (``camera:N``), for help and error messages.
    syntax: str
    #: One line saying what it is, for the docs' list.
    help: str
    #: Opens the kind from the text after the colon ("" when none) and the session's options.
    opener: Callable[[str, SourceOptions], FrameSource]
    #: Whether the text after the colon is required (``video:PATH``).
    needs_arg: bool = False
    #: Whether ``twopose-record calibrate`` takes it (a camera's checkerboard views).
    calibrates: bool = True
    #: An example the calibrate help shows, if any.
    example: str = ""
    #: Whether ``--fps`` is asked of it (a camera's; others keep their own rate).
    takes_fps: bool = False
    #: How many cameras' frames it gives (a pair's two: only the pair's commands take it).
    cameras: int = 1

    def matches(self, spec: str) -> bool:
        """Whether ``spec`` (as typed) names this kind."""
        kind, _, arg = spec.partition(":")
        return kind == self.name and (bool(arg) or not self.needs_arg)


def _open_camera(arg: str, o: SourceOptions) -> FrameSource:
    try:
        return CameraSource(int(arg or "0"), o.width, o.height, o.fps)
    except ValueError as err:
        raise SourceError(f"camera:{arg}: the device must be a number, e.g. camera:0") from err


def _open_synthetic(arg: str, o: SourceOptions) -> FrameSource:
    return SyntheticSource(
        arg or None, o.method, realtime=o.realtime, units=o.units, cameras=o.cameras
    )


def _open_pair(arg: str, o: SourceOptions) -> FrameSource:
    return open_pair(*parse_pair(arg, SOURCE_KINDS), o)


_BUILT_IN: tuple[SourceKind, ...] = (
    SourceKind(
        name="camera",
        syntax="camera:N",
        help="OpenCV device N (0 if omitted); --width/--height/--fps are requested",
        opener=_open_camera,
        takes_fps=True,
    ),
    SourceKind(
        name="video",
        syntax="video:PATH",
        help="a video file's frames in order, paced like a camera at its frame rate",
        opener=lambda arg, o: VideoSource(arg, realtime=o.realtime),
        needs_arg=True,
    ),
    SourceKind(
        name="images",
        syntax="images:DIR[/PATTERN]",
        help="a folder's images in file-name order, or those a shell pattern matches",
        opener=lambda arg, _: ImagesSource(arg),
        needs_arg=True,
        example="images:photos/left*.jpg",
    ),
    SourceKind(
        name="synthetic",
        syntax="synthetic[:SCENE.toml]",
        help="the simulator's camera, rendering its scene from the typed pose",
        opener=_open_synthetic,
        calibrates=False,
    ),
    SourceKind(
        name="pair",
        syntax="pair:A,B",
        help="two cameras at once, any two of the above (pair:camera:0,camera:1), each "
        "frame with its capture time; for calibrate-pair, new --pair and point",
        opener=_open_pair,
        needs_arg=True,
        calibrates=False,
        cameras=2,
    ),
)
#: The frame sources' registry, by the name the operator types before the colon: twopose's
#: own (camera, video, images, synthetic, pair), then those registered (:func:`register_source`).
SOURCES: Registry[str, SourceKind] = Registry("source", lambda kind: kind.name, _BUILT_IN)
#: Every kind of frame source, in the order help and docs list them (the registry's, as
#: it is now).
SOURCE_KINDS: Listing[SourceKind] = Listing(lambda: tuple(SOURCES.values()), SOURCES)


def register_source(kind: SourceKind) -> SourceKind:
    """Add a kind of frame source to the registry, and return it.

    ``--source NAME:ARG`` then opens it by its opener (``new``, ``calibrate`` if it
    calibrates), and ``--help`` and the docs' list name it. A name already registered is
    refused (:class:`ValueError`).
    """
    if not kind.name or ":" in kind.name or kind.name != kind.name.strip():
        raise ValueError(f"a source's name is one word before the colon, got {kind.name!r}")
    return SOURCES.register(kind)


def _listed(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} or {items[-1]}"


def source_help(kinds: Sequence[SourceKind] = SOURCE_KINDS, *, calibration: bool = False) -> str:
    """The ``--source`` help of a one-camera command: the one-camera kinds' syntaxes (only
    those a calibration takes, with their examples, when ``calibration``); an installed
    extension's kinds too."""
    load_extensions()
    chosen = [k for k in kinds if k.cameras == 1 and (k.calibrates or not calibration)]
    text = _listed([k.syntax for k in chosen])
    examples = [k.example for k in chosen if k.example] if calibration else []
    return f"{text} (e.g. {', '.join(examples)})." if examples else f"{text}."


def source_kinds_table(kinds: Sequence[SourceKind] = SOURCE_KINDS) -> str:
    """The docs' list of source kinds, one a line: syntax, then what it is."""
    width = max(len(k.syntax) for k in kinds)
    return "\n".join(f"  {k.syntax:<{width}}  {k.help}" for k in kinds)


def open_source(
    spec: str,
    *,
    method: Method = Method.GROUND,
    width: int = 640,
    height: int = 480,
    fps: float = 30.0,
    realtime: bool = True,
    units: Units | None = None,
    cameras: Sequence[Camera] | None = None,
) -> FrameSource:
    """A source from its command-line spelling (not yet opened).

    ``camera:N`` (device N), ``video:PATH``, ``images:DIR`` or ``images:DIR/PATTERN``,
    ``synthetic`` or
    ``synthetic:SCENE.toml`` (the kinds of :data:`SOURCE_KINDS`: :func:`open_from`);
    the synthetic camera renders its scene in the session's
    ``units`` (converted from the scene's own) and through the session's ``cameras``'
    intrinsics (focal, principal point, image size, distortion; the scene's own camera
    when they are its). Intrinsics it cannot render raise :class:`InputValueError`.
    """
    options = SourceOptions(
        method=method,
        width=width,
        height=height,
        fps=fps,
        realtime=realtime,
        units=units,
        cameras=cameras,
    )
    one_camera(spec)
    return open_from(SOURCE_KINDS, spec, options)


def one_camera(spec: str, kinds: Sequence[SourceKind] = SOURCE_KINDS) -> SourceKind:
    """The kind ``spec`` names, refused in words unless it is one camera's (a command that
    records or calibrates one camera cannot take a pair; an unknown one is told the
    one-camera kinds)."""
    try:
        kind = kind_of(spec, kinds)
    except SourceError:
        kind_of(spec, [k for k in kinds if k.cameras == 1])  # raises, naming those kinds
        raise
    if kind.cameras != 1:
        raise SourceError(
            f"{spec} gives {kind.cameras} cameras' frames and this takes one camera's: give "
            "one of them (--source camera:0); the pair's calibration takes both "
            f"(twopose-record calibrate-pair PAIR.toml --source {spec}), and so does "
            f"recording their stream trials (twopose-record new OUT.mcap --pair PAIR.toml "
            f"--source {spec})"
        )
    return kind


def open_from(kinds: Sequence[SourceKind], spec: str, options: SourceOptions) -> FrameSource:
    """The source ``spec`` names among ``kinds`` (not yet opened), by its kind's opener."""
    return kind_of(spec, kinds).opener(spec.partition(":")[2], options)


def kind_of(spec: str, kinds: Sequence[SourceKind] = SOURCE_KINDS) -> SourceKind:
    """The kind ``spec`` names among ``kinds``; raises :class:`SourceError` for none."""
    for kind in kinds:
        if kind.matches(spec):
            return kind
    raise SourceError(f"unknown source {spec!r}; use {_listed([k.syntax for k in kinds])}")


#: How each type of one-camera source is read as one camera of a pair (the nearest type
#: wins): its :class:`recorder.sources.pair_feeds.Feed`, which stamps each frame's capture time.
FEEDS: dict[type[FrameSource], Callable[[Any], Feed]] = {
    CameraSource: CameraFeed,
    VideoSource: VideoFeed,
    ImagesSource: StillsFeed,
    SyntheticSource: PacedFeed,
}


def register_feed(kind: type[FrameSource], factory: Callable[[Any], Feed]) -> None:
    """Read sources of type ``kind`` (a kind registered in :data:`SOURCE_KINDS` later) as
    one camera of a pair by ``factory(source)``."""
    FEEDS[kind] = factory


def open_pair(
    first: str,
    second: str,
    options: SourceOptions | None = None,
    *,
    queue_frames: int | None = None,
    bound: QueueBound | None = None,
) -> PairSource:
    """Two one-camera sources as a pair (``pair:FIRST,SECOND``; not yet opened): each opened
    by the registry, read by its type's feed (:data:`FEEDS`); a camera's queue bounded by
    ``bound`` (default :class:`recorder.sources.pair.QueueBound`: 10 s, 256 MiB), or
    ``queue_frames`` frames."""
    from recorder.sources.pair import PairSource, QueueBound

    options = replace(options or SourceOptions(), realtime=False)  # paced by their feeds
    feeds, sources = [], []
    for spec in (first, second):
        source = open_from(SOURCE_KINDS, spec, options)
        factory = next((FEEDS[t] for t in type(source).__mro__ if t in FEEDS), None)
        if factory is None:
            raise SourceError(
                f"{spec}: a pair cannot stamp this source's frames with their capture time "
                "(its kind has no feed: recorder.sources.registry.register_feed)"
            )
        feeds.append(factory(source))
        sources.append(source)
    same = refuse_same(first, second, sources[0], sources[1])
    bound = bound or QueueBound(frames=queue_frames or 0)
    return PairSource((feeds[0], feeds[1]), (first, second), bound=bound, note2=same)


def _resolved(path: Path) -> str:
    """A path as the file system names it (symbolic links and ``..`` followed)."""
    return os.path.realpath(path)
