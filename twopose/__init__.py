"""twopose core: what the recorder and the analysis share.

The exception hierarchy (:mod:`twopose.errors`), the camera model (:mod:`twopose.camera`),
the detectors (:mod:`twopose.detect`), the solvers and their uncertainty
(:mod:`twopose.solve`, :mod:`twopose.uncertainty`), the detection overlay
(:mod:`twopose.overlay`), the TOML reader (:mod:`twopose.config`) and the session file
format (:mod:`twopose.format`). It imports neither ``recorder`` nor ``analysis``; importing
this package loads nothing heavy.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("twopose")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
