"""twopose recorder, the operator's side: the laptop-on-grid procedure (terminal, plan,
live view), frame sources, camera calibration, recovery of interrupted sessions, and the
simulator that renders what the thesis' webcam would see.

It writes the session format of :mod:`twopose.format` and never imports ``analysis``.

Every command of ``twopose-record`` is one call from Python, exported here and loaded on
first use (``import recorder.cli`` stays light)::

    import recorder
    recorder.simulate_session("sim.mcap", method=twopose.Method.GROUND)  # simulate
    source = recorder.open_source("camera:0")
    recorder.record_plan(recorder.load_plan("plan.toml"), "out.mcap", source)  # new --plan
    recorder.record_interactive(...)  # new, at the terminal, with the questions answered
    recorder.recover_session("cut.mcap", "fixed.mcap")  # recover
    recorder.calibrate(source, (9, 6), 25.0)  # calibrate
    recorder.calibrate_pair(recorder.PairRequest(...))  # calibrate-pair

The frame sources' registry (:data:`SOURCES`, :data:`SOURCE_KINDS`, :func:`open_source`)
and its extension point (:func:`register_source`), the procedure (:class:`Procedure`,
:func:`record`) and reading a session to continue (:func:`read_continued`) are here too.
What the command line runs around them (``record_terminal``, ``record_planned`` and
``serve_console_until_stopped``, which take the command line's ``NewRequest`` and an
``ExitStack``) is in :mod:`recorder.new_session`; the names still resolve here for one
release (docs/changelog.md), not exported.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.camera_calibration import (
        Calibration,
        calibrate,
        load_calibration,
        save_calibration,
    )
    from recorder.continuation import Continued, read_continued
    from recorder.interactive import record_interactive

    # Resolved, not exported (the module docstring): the command line's own.
    from recorder.new_session import NewRequest as NewRequest
    from recorder.new_session import record_planned as record_planned
    from recorder.new_session import record_terminal as record_terminal
    from recorder.new_session import serve_console_until_stopped as serve_console_until_stopped
    from recorder.pair_calibration import (
        PairCalibrationRun,
        PairRequest,
        calibrate_pair,
        calibrate_pair_views,
    )
    from recorder.plan import Plan, load_plan, record_plan
    from recorder.procedure import Procedure
    from recorder.recording import record
    from recorder.recover import RecoveryReport, recover_session
    from recorder.simulate import SimulationSummary, simulate_session
    from recorder.sources import (
        SOURCE_KINDS,
        SOURCES,
        FrameSource,
        SourceKind,
        SourceOptions,
        open_source,
        register_source,
    )
    from recorder.summary import RecordingSummary
    from twopose.installed_version import __version__

__all__ = [
    "SOURCES",
    "SOURCE_KINDS",
    "Calibration",
    "Continued",
    "FrameSource",
    "PairCalibrationRun",
    "PairRequest",
    "Plan",
    "Procedure",
    "RecordingSummary",
    "RecoveryReport",
    "SimulationSummary",
    "SourceKind",
    "SourceOptions",
    "__version__",
    "calibrate",
    "calibrate_pair",
    "calibrate_pair_views",
    "load_calibration",
    "load_plan",
    "open_source",
    "read_continued",
    "record",
    "record_interactive",
    "record_plan",
    "recover_session",
    "register_source",
    "save_calibration",
    "simulate_session",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "SimulationSummary": "recorder.simulate",
    "simulate_session": "recorder.simulate",
    "Plan": "recorder.plan",
    "load_plan": "recorder.plan",
    "record_plan": "recorder.plan",
    # The command line's, not exported: resolved here for one release (docs/changelog.md).
    "NewRequest": "recorder.new_session",
    "record_planned": "recorder.new_session",
    "record_terminal": "recorder.new_session",
    "serve_console_until_stopped": "recorder.new_session",
    "record_interactive": "recorder.interactive",
    "Procedure": "recorder.procedure",
    "record": "recorder.recording",
    "RecordingSummary": "recorder.summary",
    "RecoveryReport": "recorder.recover",
    "recover_session": "recorder.recover",
    "Calibration": "recorder.camera_calibration",
    "calibrate": "recorder.camera_calibration",
    "load_calibration": "recorder.camera_calibration",
    "save_calibration": "recorder.camera_calibration",
    "PairCalibrationRun": "recorder.pair_calibration",
    "PairRequest": "recorder.pair_calibration",
    "calibrate_pair": "recorder.pair_calibration",
    "calibrate_pair_views": "recorder.pair_calibration",
    "SOURCE_KINDS": "recorder.sources",
    "SOURCES": "recorder.sources",
    "register_source": "recorder.sources",
    "FrameSource": "recorder.sources",
    "SourceKind": "recorder.sources",
    "SourceOptions": "recorder.sources",
    "open_source": "recorder.sources",
    "Continued": "recorder.continuation",
    "read_continued": "recorder.continuation",
    "__version__": "twopose.installed_version",
}


__getattr__, __dir__ = lazy_exports("recorder", _HOMES, __all__)
