"""What every frame source is (:class:`FrameSource`), what it delivers (:class:`SourceInfo`),
and the camera's clock that file and synthetic sources keep (:class:`Pacer`): the one
interface the recorder reads frames through; and how a pair of sources is written
(``pair:A,B``: :func:`parse_pair`, :func:`pair_spec`). The kinds of source and how the
operator names them are in :mod:`recorder.sources.registry`.
"""

from __future__ import annotations

import csv
import filecmp
import io
import os
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, Self

from twopose.errors import SourceError

if TYPE_CHECKING:
    from collections.abc import Sequence
    from pathlib import Path

    import numpy as np
    from numpy.typing import NDArray

    from twopose.detect.clutter import Clutter

    Image = NDArray[np.uint8]

__all__ = [
    "FrameSource",
    "Kind",
    "Pacer",
    "SourceInfo",
    "open_camera",
    "open_video",
    "pair_spec",
    "parse_pair",
    "refuse_same",
]


@dataclass(frozen=True, kw_only=True)
class SourceInfo:
    """What the source actually delivers (a camera may not honour the request)."""

    description: str
    width: int
    height: int
    fps: float


class FrameSource(ABC):
    """A source of BGR uint8 frames. Use as a context manager.

    ``dropped`` counts frames the source delivered (or, paced like a camera, would have)
    that the reader was too late to take. The recorder counts them only while a capture
    runs: :meth:`start_capture` marks its start.
    """

    info: SourceInfo
    dropped: int = 0
    _pacer: Pacer | None = None
    #: Distinct still images (a folder), not a moving stream: each frame is its own view.
    stills = False

    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @abstractmethod
    def open(self) -> SourceInfo: ...

    @abstractmethod
    def read(self, timeout_s: float = 2.0) -> Image:
        """The next frame, (H, W, 3) BGR uint8; raises SourceError when none comes."""

    def close(self) -> None:
        return None

    #: What it reads, in words (a pair given one of them twice is refused naming it).
    what_it_reads: ClassVar[str] = "source"

    def origin(self) -> tuple[object, ...] | None:
        """What this source reads (a device, a file, a folder and its pattern), so that a
        pair's two sources can be told apart; None: nothing to compare (a rendered camera)."""
        return None

    def file_paths(self) -> list[Path]:
        """The files it reads (a video, a folder's stills), to compare their bytes; none."""
        return []

    def frame_name(self, index: int) -> str:
        """How to name frame ``index`` (from 0) to the operator."""
        return f"frame {index + 1}"

    def start_capture(self) -> None:
        """A capture begins: a paced source restarts its clock, so that the operator's
        pause since the last frame is not counted as dropped frames."""
        if self._pacer is not None:
            self._pacer.due = None

    def set_pose(
        self,
        t_grid: tuple[float, float, float],  # noqa: ARG002 - a camera ignores where it is
        r_deg: tuple[float, float, float],  # noqa: ARG002
    ) -> None:
        """Tell the source where the camera is (only the synthetic camera uses it)."""
        return

    def clutter(self) -> Clutter | None:
        """The clutter in its scene, where the source knows it (only the synthetic camera
        does: guidance keeps the target from being seen over it, :mod:`twopose.detect.clutter`)."""
        return None


class Pacer:
    """Emulates a camera's clock for file and synthetic sources.

    ``wait`` sleeps until the next frame is due and returns how many frame intervals the
    reader was late by (those frames a camera would have dropped).
    """

    def __init__(self, fps: float) -> None:
        self.interval = 1.0 / fps
        self.due: float | None = None

    def wait(self) -> int:
        now = time.monotonic()
        if self.due is None:
            self.due = now
        if now < self.due:
            time.sleep(self.due - now)
            missed = 0
        else:
            missed = int((now - self.due) / self.interval)
        self.due += (missed + 1) * self.interval
        return missed


def open_video(path: Path) -> tuple[Any, SourceInfo]:
    """``path`` opened by OpenCV (its ``VideoCapture``) and what it delivers; a file that is
    missing or that OpenCV cannot read refused in words."""
    import cv2

    if not path.is_file():
        raise SourceError(f"video {path} does not exist")
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise SourceError(f"OpenCV cannot read the video {path} (unknown format or codec?)")
    info = SourceInfo(
        description=f"video:{path}",
        width=int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
        height=int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
        fps=float(cap.get(cv2.CAP_PROP_FPS)) or 30.0,
    )
    return cap, info


def open_camera(
    device: int | str, width: int, height: int, fps: float, *, fourcc: str = ""
) -> tuple[Any, SourceInfo]:
    """Camera ``device`` opened by OpenCV with the size and rate asked (and the pixel format
    ``fourcc``, asked first: a camera gives 640x480 at 30 fps often only in MJPG), and what
    it delivers; a camera that does not open refused in words."""
    import cv2

    cap = cv2.VideoCapture(device)
    if not cap.isOpened():
        raise SourceError(
            f"camera {device} did not open: is it connected, and not in use by another "
            "program? Try another index (camera:1) or check the device permissions."
        )
    if fourcc:
        cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter.fourcc(*fourcc))
    cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
    cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
    cap.set(cv2.CAP_PROP_FPS, fps)
    info = SourceInfo(
        description=f"camera:{device}",
        width=int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
        height=int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
        fps=float(cap.get(cv2.CAP_PROP_FPS)) or fps,
    )
    return cap, info


class Kind(Protocol):
    """What :func:`parse_pair` reads of a kind of source
    (:class:`recorder.sources.registry.SourceKind`)."""

    @property
    def cameras(self) -> int: ...

    @property
    def syntax(self) -> str: ...

    def matches(self, spec: str) -> bool: ...


def parse_pair(arg: str, kinds: Sequence[Kind]) -> tuple[str, str]:
    """The two sources of ``pair:ARG`` (the text after ``pair:``), each a one-camera kind of
    ``kinds`` (the registry's: :func:`recorder.sources.registry.open_pair`); refused in words."""
    try:
        rows = list(csv.reader(io.StringIO(arg, newline=""), strict=True, skipinitialspace=True))
    except csv.Error as err:
        raise SourceError(f"pair:{arg}: {err} (a quoted source ends with its quote)") from err
    parts = rows[0] if len(rows) == 1 else []
    if len(parts) != 2:
        raise SourceError(
            f"pair:{arg}: give two sources, camera 1's and camera 2's, separated by a comma "
            "(pair:camera:0,camera:1); a source whose text holds a comma goes in double "
            'quotes: pair:"video:take 1,2.mp4",video:b.mp4'
        )
    for n, part in enumerate(parts, start=1):
        if not part:
            raise SourceError(f"pair:{arg}: camera {n}'s source is empty")
        kind = next((k for k in kinds if k.matches(part)), None)
        if kind is None:
            ones = ", ".join(k.syntax for k in kinds if k.cameras == 1)
            raise SourceError(f"pair:{arg}: camera {n}'s source {part!r} is unknown; use {ones}")
        if kind.cameras != 1:
            raise SourceError(f"pair:{arg}: camera {n}'s source {part} is not one camera")
    return parts[0], parts[1]


def pair_spec(first: str, second: str) -> str:
    """``pair:A,B`` for two sources, each quoted where it must be (:func:`parse_pair`)."""
    out = io.StringIO()
    csv.writer(out, lineterminator="").writerow([first, second])
    return f"pair:{out.getvalue()}"


def refuse_same(first: str, second: str, one: FrameSource, two: FrameSource) -> str:
    """A pair whose two cameras read one thing refused in words: the same device, file or
    folder given twice (however spelled): camera 2 would see what camera 1 sees, and the
    rays of one image through two centres meet nowhere near the target, yet measure a
    clock offset. Files identical byte for byte (two copies of one recording; every still
    of two folders) are warned of: the warning returned ("": none), said with camera 2."""
    what = one.origin()
    if what is not None and what == two.origin():
        raise SourceError(
            f"pair:{first},{second}: both cameras read the same {one.what_it_reads} "
            f"({what[1]}): a pair needs two cameras, each its own device, file or folder"
        )
    files = one.file_paths(), two.file_paths()
    read = [sorted(os.path.realpath(f) for f in side) for side in files]
    if read[0] and read[0] == read[1]:  # one folder, spelled with and without a pattern
        raise SourceError(
            f"pair:{first},{second}: both cameras read the same files ({len(read[0])}, "
            f"from {os.path.dirname(read[0][0])}): a pair needs two cameras, each its own "
            "device, file or folder"
        )
    if (
        files[0]
        and len(files[0]) == len(files[1])
        and all(filecmp.cmp(a, b, shallow=False) for a, b in zip(*files, strict=True))
    ):
        return (
            f"camera 2's files ({second}) are camera 1's ({first}), byte for byte (two "
            "copies of one recording?): a pair needs two cameras' own frames; what it "
            "measures of them (points, the clock offset) means nothing"
        )
    return ""
