"""Frame sources: where the frames come from.

The registry of source kinds, each with its syntax, help and opener (``registry``), the one
interface every source implements (``base``) and the synthetic camera's source
(``synthetic``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.sources.base import FrameSource, SourceInfo
    from recorder.sources.pair import CameraStream, FramePair, PairSource
    from recorder.sources.pair_feeds import CLOCK_GRAB
    from recorder.sources.registry import (
        IMAGE_SUFFIXES,
        SOURCE_KINDS,
        SOURCES,
        SourceKind,
        SourceOptions,
        kind_of,
        one_camera,
        open_from,
        open_source,
        register_source,
        source_help,
    )

__all__ = [
    "CLOCK_GRAB",
    "IMAGE_SUFFIXES",
    "SOURCES",
    "SOURCE_KINDS",
    "CameraStream",
    "FramePair",
    "FrameSource",
    "PairSource",
    "SourceInfo",
    "SourceKind",
    "SourceOptions",
    "kind_of",
    "one_camera",
    "open_from",
    "open_source",
    "register_source",
    "source_help",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "CLOCK_GRAB": "recorder.sources.pair_feeds",
    "IMAGE_SUFFIXES": "recorder.sources.registry",
    "SOURCES": "recorder.sources.registry",
    "SOURCE_KINDS": "recorder.sources.registry",
    "CameraStream": "recorder.sources.pair",
    "FramePair": "recorder.sources.pair",
    "FrameSource": "recorder.sources.base",
    "PairSource": "recorder.sources.pair",
    "SourceInfo": "recorder.sources.base",
    "SourceKind": "recorder.sources.registry",
    "SourceOptions": "recorder.sources.registry",
    "kind_of": "recorder.sources.registry",
    "one_camera": "recorder.sources.registry",
    "open_from": "recorder.sources.registry",
    "open_source": "recorder.sources.registry",
    "register_source": "recorder.sources.registry",
    "source_help": "recorder.sources.registry",
}

__getattr__, __dir__ = lazy_exports("recorder.sources", _HOMES, __all__)
