"""twopose recorder, the operator's side: the laptop-on-grid procedure (terminal, plan,
live view), frame sources, camera calibration, recovery of interrupted sessions, and the
simulator that renders what the thesis' webcam would see.

It writes the session format of :mod:`twopose.format` and never imports ``analysis``.
"""

from __future__ import annotations

from twopose import __version__

__all__ = ["__version__"]
