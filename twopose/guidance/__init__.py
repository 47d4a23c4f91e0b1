"""Guidance: the next pose that shrinks the 95% region most, and when to stop.

The advice and the stop rule (``advice``), the suggestion as the operator is told it
(``suggestion``), what keeps the target in view from the grid paper (``paper``), the
lattice of poses on it and the search on it (``search``), what one more pose would give
(``prediction``), the first pose (``first_pose``) and the operator's map of every
reachable pose (``region_map``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.guidance.advice import MIN_GAIN, THESIS_MOVE_IN, Advice, Guidance, advise, suggest
    from twopose.guidance.paper import Reach, project, view_checks

__all__ = [
    "MIN_GAIN",
    "THESIS_MOVE_IN",
    "Advice",
    "Guidance",
    "Reach",
    "advise",
    "project",
    "suggest",
    "view_checks",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "MIN_GAIN": "twopose.guidance.advice",
    "THESIS_MOVE_IN": "twopose.guidance.advice",
    "Advice": "twopose.guidance.advice",
    "Guidance": "twopose.guidance.advice",
    "Reach": "twopose.guidance.paper",
    "advise": "twopose.guidance.advice",
    "project": "twopose.guidance.paper",
    "suggest": "twopose.guidance.advice",
    "view_checks": "twopose.guidance.paper",
}

__getattr__, __dir__ = lazy_exports("twopose.guidance", _HOMES, __all__)
