"""Calibration from live cameras: one camera's intrinsics, a pair's relative pose.

A camera's intrinsics from a checkerboard (``camera``) and the pair's calibration from
stills of a board both cameras see (``pair``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.calibration.camera import (
        Calibration,
        calibrate,
        load_calibration,
        load_calibration_sigma,
        save_calibration,
    )
    from recorder.calibration.pair import (
        PairCalibrationRun,
        PairRequest,
        calibrate_pair,
        calibrate_pair_views,
    )
    from recorder.calibration.pair_live import LIVE_VIEWS

__all__ = [
    "LIVE_VIEWS",
    "Calibration",
    "PairCalibrationRun",
    "PairRequest",
    "calibrate",
    "calibrate_pair",
    "calibrate_pair_views",
    "load_calibration",
    "load_calibration_sigma",
    "save_calibration",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "LIVE_VIEWS": "recorder.calibration.pair_live",
    "Calibration": "recorder.calibration.camera",
    "PairCalibrationRun": "recorder.calibration.pair",
    "PairRequest": "recorder.calibration.pair",
    "calibrate": "recorder.calibration.camera",
    "calibrate_pair": "recorder.calibration.pair",
    "calibrate_pair_views": "recorder.calibration.pair",
    "load_calibration": "recorder.calibration.camera",
    "load_calibration_sigma": "recorder.calibration.camera",
    "save_calibration": "recorder.calibration.camera",
}

__getattr__, __dir__ = lazy_exports("recorder.calibration", _HOMES, __all__)
