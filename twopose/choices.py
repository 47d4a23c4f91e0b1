"""The closed sets of names a user picks from, declared once.

For the library and both command lines.

Each is a :data:`~typing.Literal`: the library's option records are typed with it, and
typer turns it into the command lines' choices (``--combine <mean|median|robust>``), so a
new choice is added here and nowhere else. This module imports nothing heavy, so that the
command lines can read it at start-up.
"""

from __future__ import annotations

from typing import Literal

__all__ = ["CombineRule", "Target"]

#: How a pose's frames are combined into one measurement (:func:`twopose.frames.combine_frames`;
#: the thesis averages, section 5.3).
CombineRule = Literal["mean", "median", "robust"]
#: What the detector looks for in a frame: the gloved finger (method 2, the line) or the dot.
Target = Literal["glove", "dot"]
