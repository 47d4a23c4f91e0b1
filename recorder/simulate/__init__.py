"""Simulated sessions: the synthetic operator and cameras (``twopose-record simulate``).

One camera moved by a simulated operator through a method's procedure (``one_camera``), and
a pair of cameras seeing a moving target, each on its own clock (``pair``, when present),
and a pointing clip (``pointing_clip``: a finger moving over the floor, both cameras'
frames, for the live pointing's tests and benchmark); all render with the core's simulator
(:mod:`twopose.sim`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.simulate.one_camera import SimulationSummary, poses_per_trial, simulate_session
    from recorder.simulate.pair import refuse_idle_options, simulate_pair_with_progress

__all__ = [
    "SimulationSummary",
    "poses_per_trial",
    "refuse_idle_options",
    "simulate_pair_with_progress",
    "simulate_session",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "SimulationSummary": "recorder.simulate.one_camera",
    "poses_per_trial": "recorder.simulate.one_camera",
    "refuse_idle_options": "recorder.simulate.pair",
    "simulate_pair_with_progress": "recorder.simulate.pair",
    "simulate_session": "recorder.simulate.one_camera",
}

__getattr__, __dir__ = lazy_exports("recorder.simulate", _HOMES, __all__)
