"""The run's matplotlib figures, drawn off the critical path.

The figures (``draw``), their shared style (``style``), the top view (``topview``), a
session's figures as a job with a digest, reused when nothing changed (``cache``), and the
drawer process that draws them (``drawer``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.report.figures.cache import FIGURE_INDEX, FigureCache, FigureJob, index_document
    from analysis.report.figures.draw import figure_key, make_figures, png_bytes, run_figures, saved
    from analysis.report.figures.drawer import FigureDrawer, note, session_pngs, sigint_blocked

__all__ = [
    "FIGURE_INDEX",
    "FigureCache",
    "FigureDrawer",
    "FigureJob",
    "figure_key",
    "index_document",
    "make_figures",
    "note",
    "png_bytes",
    "run_figures",
    "saved",
    "session_pngs",
    "sigint_blocked",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "FIGURE_INDEX": "analysis.report.figures.cache",
    "FigureCache": "analysis.report.figures.cache",
    "FigureDrawer": "analysis.report.figures.drawer",
    "FigureJob": "analysis.report.figures.cache",
    "figure_key": "analysis.report.figures.draw",
    "index_document": "analysis.report.figures.cache",
    "make_figures": "analysis.report.figures.draw",
    "note": "analysis.report.figures.drawer",
    "png_bytes": "analysis.report.figures.draw",
    "run_figures": "analysis.report.figures.draw",
    "saved": "analysis.report.figures.draw",
    "session_pngs": "analysis.report.figures.drawer",
    "sigint_blocked": "analysis.report.figures.drawer",
}

__getattr__, __dir__ = lazy_exports("analysis.report.figures", _HOMES, __all__)
