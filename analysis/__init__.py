"""twopose analysis, the analyst's side: replay sessions through detection and solvers into
error tables, figures and a report.

The whole job is one call::

    import analysis
    result = analysis.run(["sessions/"], "results/", jobs=2)
    result.trials, result.summary, result.averaging, result.frames, result.errors
    analysis.make_figures(result)  # the run's matplotlib Figures, by name

The names below load on first use, so ``import analysis.cli`` stays fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.batch.runner import run
    from analysis.gate.baseline import check
    from analysis.gate.comparison import compare
    from analysis.report.figures.draw import make_figures
    from analysis.results import AnalysisOptions, RunResult, SessionFailure, SessionResult
    from analysis.session.pipeline import analyse_session

__all__ = [
    "AnalysisOptions",
    "RunResult",
    "SessionFailure",
    "SessionResult",
    "analyse_session",
    "check",
    "compare",
    "make_figures",
    "run",
]

_HOMES = {
    "run": "analysis.batch.runner",
    "check": "analysis.gate.baseline",
    "compare": "analysis.gate.comparison",
    "make_figures": "analysis.report.figures.draw",
    "analyse_session": "analysis.session.pipeline",
    "AnalysisOptions": "analysis.results",
    "RunResult": "analysis.results",
    "SessionFailure": "analysis.results",
    "SessionResult": "analysis.results",
}


__getattr__, __dir__ = lazy_exports("analysis", _HOMES, __all__)
