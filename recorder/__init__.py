"""twopose recorder, the operator's side: the laptop-on-grid procedure (terminal, plan,
live view), frame sources, camera calibration, recovery of interrupted sessions, and the
simulator that renders what the thesis' webcam would see.

It writes the session format of :mod:`twopose.format` and never imports ``analysis``.

Every command of ``twopose-record`` is one call from Python, exported here and loaded on
first use (``import recorder.cli.app`` stays light)::

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
``ExitStack``) is in :mod:`recorder.procedure.new_session`; the names still resolve here for one
release (docs/changelog.md), not exported.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.calibration.camera import (
        Calibration,
        calibrate,
        load_calibration,
        save_calibration,
    )
    from recorder.calibration.pair import (
        PairCalibrationRun,
        PairRequest,
        calibrate_pair,
        calibrate_pair_views,
    )
    from recorder.procedure.machine import Procedure

    # Resolved, not exported (the module docstring): the command line's own.
    from recorder.procedure.new_session import NewRequest as NewRequest
    from recorder.procedure.new_session import record_planned as record_planned
    from recorder.procedure.new_session import record_terminal as record_terminal
    from recorder.procedure.new_session import (
        serve_console_until_stopped as serve_console_until_stopped,
    )
    from recorder.procedure.recording import record
    from recorder.procedure.summary import RecordingSummary
    from recorder.procedure.terminal import record_interactive
    from recorder.recover import RecoveryReport, recover_session
    from recorder.setup.continuation import Continued, read_continued
    from recorder.setup.plan import Plan, load_plan, record_plan
    from recorder.simulate.one_camera import SimulationSummary, simulate_session
    from recorder.sources.registry import (
        SOURCE_KINDS,
        SOURCES,
        FrameSource,
        SourceKind,
        SourceOptions,
        open_source,
        register_source,
    )
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
    "SimulationSummary": "recorder.simulate.one_camera",
    "simulate_session": "recorder.simulate.one_camera",
    "Plan": "recorder.setup.plan",
    "load_plan": "recorder.setup.plan",
    "record_plan": "recorder.setup.plan",
    # The command line's, not exported: resolved here for one release (docs/changelog.md).
    "NewRequest": "recorder.procedure.new_session",
    "record_planned": "recorder.procedure.new_session",
    "record_terminal": "recorder.procedure.new_session",
    "serve_console_until_stopped": "recorder.procedure.new_session",
    "record_interactive": "recorder.procedure.terminal",
    "Procedure": "recorder.procedure.machine",
    "record": "recorder.procedure.recording",
    "RecordingSummary": "recorder.procedure.summary",
    "RecoveryReport": "recorder.recover",
    "recover_session": "recorder.recover",
    "Calibration": "recorder.calibration.camera",
    "calibrate": "recorder.calibration.camera",
    "load_calibration": "recorder.calibration.camera",
    "save_calibration": "recorder.calibration.camera",
    "PairCalibrationRun": "recorder.calibration.pair",
    "PairRequest": "recorder.calibration.pair",
    "calibrate_pair": "recorder.calibration.pair",
    "calibrate_pair_views": "recorder.calibration.pair",
    "SOURCE_KINDS": "recorder.sources.registry",
    "SOURCES": "recorder.sources.registry",
    "register_source": "recorder.sources.registry",
    "FrameSource": "recorder.sources.registry",
    "SourceKind": "recorder.sources.registry",
    "SourceOptions": "recorder.sources.registry",
    "open_source": "recorder.sources.registry",
    "Continued": "recorder.setup.continuation",
    "read_continued": "recorder.setup.continuation",
    "__version__": "twopose.installed_version",
}


__getattr__, __dir__ = lazy_exports("recorder", _HOMES, __all__)
