"""twopose analysis: replay sessions through detection and solvers into error tables and reports.

The whole job is one call::

    import analysis
    result = analysis.run(["sessions/"], "results/", jobs=2)
    result.trials, result.summary, result.averaging, result.frames, result.errors
"""

from __future__ import annotations

from analysis.pipeline import AnalysisOptions, RunResult, SessionResult, analyse_session, run

__all__ = ["AnalysisOptions", "RunResult", "SessionResult", "analyse_session", "run"]
