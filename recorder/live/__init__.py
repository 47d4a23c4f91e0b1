"""The live view and each trial's live result while recording.

The Foxglove WebSocket view (``view``) behind its loopback guard (``guard``) and its TLS
upstream (``tls``), each trial's live result (``result``, ``trial_result``), the
operator's noise file that gives it a prior (``operator_noise``), and with two cameras the
live pointing: one estimate per frame pair (``pointing``) and the feed that pushes them to
the console's panel (``pointing_feed``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.live.pointing import LivePointing, PointingEstimate
    from recorder.live.pointing_feed import PointingFeed
    from recorder.live.result import LiveResults, MappedAdvice, live_results
    from recorder.live.trial_result import TrialResult
    from recorder.live.view import LiveView

__all__ = [
    "LivePointing",
    "LiveResults",
    "LiveView",
    "MappedAdvice",
    "PointingEstimate",
    "PointingFeed",
    "TrialResult",
    "live_results",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "LivePointing": "recorder.live.pointing",
    "LiveResults": "recorder.live.result",
    "LiveView": "recorder.live.view",
    "MappedAdvice": "recorder.live.result",
    "PointingEstimate": "recorder.live.pointing",
    "PointingFeed": "recorder.live.pointing_feed",
    "TrialResult": "recorder.live.trial_result",
    "live_results": "recorder.live.result",
}

__getattr__, __dir__ = lazy_exports("recorder.live", _HOMES, __all__)
