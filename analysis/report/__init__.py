"""The report: what a reader sees of a run, on a page and at a terminal.

The files it writes (``writer``), the HTML page (``html``) with its Vega-Lite charts
(``charts``, ``run_charts``) and the scripts they need (``js/``), captions, the answer per
session set and method (``answer``), the terminal's lines (``terminal``), the noise said
(``noise``), the thesis' figures against a run (``thesis``); the matplotlib figures are in
``figures/``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.report.answer import number, share, with_branch
    from analysis.report.html import page_html, table_html
    from analysis.report.terminal import closing_lines, summary_lines, wrap_phrases
    from analysis.report.thesis import Verdicts, thesis_table, verdict_lines, verdicts_by_set
    from analysis.report.writer import write_outputs

__all__ = [
    "Verdicts",
    "closing_lines",
    "number",
    "page_html",
    "share",
    "summary_lines",
    "table_html",
    "thesis_table",
    "verdict_lines",
    "verdicts_by_set",
    "with_branch",
    "wrap_phrases",
    "write_outputs",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "Verdicts": "analysis.report.thesis",
    "closing_lines": "analysis.report.terminal",
    "number": "analysis.report.answer",
    "page_html": "analysis.report.html",
    "share": "analysis.report.answer",
    "summary_lines": "analysis.report.terminal",
    "table_html": "analysis.report.html",
    "thesis_table": "analysis.report.thesis",
    "verdict_lines": "analysis.report.thesis",
    "verdicts_by_set": "analysis.report.thesis",
    "with_branch": "analysis.report.answer",
    "wrap_phrases": "analysis.report.terminal",
    "write_outputs": "analysis.report.writer",
}

__getattr__, __dir__ = lazy_exports("analysis.report", _HOMES, __all__)
