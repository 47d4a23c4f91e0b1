"""The analyst's hand checks and sweeps.

The ``solve`` hand-check request (``solve_request``) and the sensitivity sweeps in the
thesis' geometry (``sensitivity``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.tools.sensitivity import (
        plot_sensitivity,
        worst_x_translation_effect,
        x_translation_effect,
    )

__all__ = [
    "plot_sensitivity",
    "worst_x_translation_effect",
    "x_translation_effect",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "plot_sensitivity": "analysis.tools.sensitivity",
    "worst_x_translation_effect": "analysis.tools.sensitivity",
    "x_translation_effect": "analysis.tools.sensitivity",
}

__getattr__, __dir__ = lazy_exports("analysis.tools", _HOMES, __all__)
