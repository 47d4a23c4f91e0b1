"""twopose recorder: frames, typed poses, ground height and ground truth into MCAP sessions."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("twopose")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+unknown"

from recorder.camera import Intrinsics, rotation_from_angles_deg
from recorder.errors import (
    InputValueError,
    SceneError,
    SessionExistsError,
    SessionFormatError,
    SessionVersionError,
    TwoposeError,
)
from recorder.session import (
    FORMAT_VERSION,
    Camera,
    CaptureWindow,
    Frame,
    GroundPlane,
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
    SessionReader,
    SessionWriter,
    SimulationTruth,
    TruePose,
)

__all__ = [
    "FORMAT_VERSION",
    "Camera",
    "CaptureWindow",
    "Frame",
    "GroundPlane",
    "GroundTruth",
    "InputValueError",
    "Intrinsics",
    "Note",
    "PoseEntry",
    "SceneError",
    "SessionExistsError",
    "SessionFormatError",
    "SessionInfo",
    "SessionReader",
    "SessionVersionError",
    "SessionWriter",
    "SimulationTruth",
    "TruePose",
    "TwoposeError",
    "__version__",
    "rotation_from_angles_deg",
]
