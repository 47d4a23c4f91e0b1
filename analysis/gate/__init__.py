"""The CI gate: a run against a baseline, and two runs compared.

``check`` against a baseline with JUnit XML (``baseline``), what it checks and how much
worse each may get (``tolerance``), which rows of two runs hold the same measurements
(``match``), the noise models and the settings two runs assumed (``noise``, ``settings``)
and two runs side by side (``comparison``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.gate.baseline import check, check_cases, check_lines, junit_xml, run_cases
    from analysis.gate.comparison import compare, describe_one_sided, describe_test

__all__ = [
    "check",
    "check_cases",
    "check_lines",
    "compare",
    "describe_one_sided",
    "describe_test",
    "junit_xml",
    "run_cases",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "check": "analysis.gate.baseline",
    "check_cases": "analysis.gate.baseline",
    "check_lines": "analysis.gate.baseline",
    "compare": "analysis.gate.comparison",
    "describe_one_sided": "analysis.gate.comparison",
    "describe_test": "analysis.gate.comparison",
    "junit_xml": "analysis.gate.baseline",
    "run_cases": "analysis.gate.baseline",
}

__getattr__, __dir__ = lazy_exports("analysis.gate", _HOMES, __all__)
