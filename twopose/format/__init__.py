"""The twopose session format (v1): one MCAP file per session.

Specified for other implementers in ``docs/session-format.md``; this package is the
reference implementation, in layers:

* :mod:`~twopose.format.entries`: the typed JSON entries, each field declared once
* :mod:`~twopose.format.messages`: topics, the Foxglove messages (images, calibrations,
  /tf) and schema and channel registration for every MCAP writer
* :mod:`~twopose.format.writer`: :class:`SessionWriter`
* :mod:`~twopose.format.reader`: :class:`SessionReader`, :func:`find_sessions`
* :mod:`~twopose.format.trials`: a session replayed trial by trial (:func:`iter_trials`)
"""

from __future__ import annotations

from twopose.format.entries import (
    FORMAT_VERSION,
    METHODS,
    UNITS,
    CaptureWindow,
    GroundPlane,
    GroundTruth,
    Method,
    Note,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
    TruePose,
    TruthKind,
    TypedEntry,
)
from twopose.format.messages import Frame
from twopose.format.reader import SessionReader, find_sessions
from twopose.format.writer import SessionWriter

__all__ = [
    "FORMAT_VERSION",
    "METHODS",
    "UNITS",
    "CaptureWindow",
    "Frame",
    "GroundPlane",
    "GroundTruth",
    "Method",
    "Note",
    "PlaneEntry",
    "PoseEntry",
    "SessionInfo",
    "SessionReader",
    "SessionWriter",
    "SimulationTruth",
    "TruePose",
    "TruthKind",
    "TypedEntry",
    "find_sessions",
]
