"""One session's analysis: replay, detection, estimation, metrics.

The pipeline from a session file to its tables (``pipeline``), the frames' detection pass
(``detection``), the errors against the truth and their summaries (``metrics``) and the
session's results file for Foxglove (``results_mcap``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.session.detection import Detections
    from analysis.session.metrics import (
        MIN_INTERVAL_TRIALS,
        SESSION_SETS,
        by_session_set,
        paired_difference,
        session_set,
        summarize,
        t95,
        too_few_for_interval,
        used_trials,
        warned,
    )
    from analysis.session.pipeline import (
        analyse_session,
        corrected_trials,
        keep_frame_buffers,
        replay_views,
    )
    from analysis.session.stream_tables import pair_lines

__all__ = [
    "MIN_INTERVAL_TRIALS",
    "SESSION_SETS",
    "Detections",
    "analyse_session",
    "by_session_set",
    "corrected_trials",
    "keep_frame_buffers",
    "pair_lines",
    "paired_difference",
    "replay_views",
    "session_set",
    "summarize",
    "t95",
    "too_few_for_interval",
    "used_trials",
    "warned",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "MIN_INTERVAL_TRIALS": "analysis.session.metrics",
    "SESSION_SETS": "analysis.session.metrics",
    "Detections": "analysis.session.detection",
    "analyse_session": "analysis.session.pipeline",
    "by_session_set": "analysis.session.metrics",
    "corrected_trials": "analysis.session.pipeline",
    "keep_frame_buffers": "analysis.session.pipeline",
    "pair_lines": "analysis.session.stream_tables",
    "paired_difference": "analysis.session.metrics",
    "replay_views": "analysis.session.pipeline",
    "session_set": "analysis.session.metrics",
    "summarize": "analysis.session.metrics",
    "t95": "analysis.session.metrics",
    "too_few_for_interval": "analysis.session.metrics",
    "used_trials": "analysis.session.metrics",
    "warned": "analysis.session.metrics",
}

__getattr__, __dir__ = lazy_exports("analysis.session", _HOMES, __all__)
