"""The recording procedure: one loop, whoever drives it.

The state machine (``loop``), a recording driven through it (``recording``), the ``Driver``
interface every decider implements (``driver``), the capture step (``capture``), the guided
dialogue at the terminal (``terminal``), what ``new`` runs from its options
(``new_session``), the one summary line (``summary``) and every stop that closes the file
(``stops``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.procedure.capture import (
        CaptureResult,
        CaptureSettings,
        FrameFeedback,
        LiveSink,
        LiveSinks,
        Shortfall,
        detection_shortfall,
    )
    from recorder.procedure.driver import (
        Decision,
        Driver,
        LowDetectionError,
        Placement,
        ProcedureRefusedError,
        QuitRecording,
    )
    from recorder.procedure.machine import Procedure, refuse_existing
    from recorder.procedure.new_session import (
        CameraMode,
        NewRequest,
        continued_given,
        continued_session,
        guidance_asked,
        record_planned,
        record_terminal,
        rig_file,
        say_fork,
        serve_console_until_stopped,
    )
    from recorder.procedure.recording import record
    from recorder.procedure.summary import RecordingSummary
    from recorder.procedure.terminal import record_interactive

__all__ = [
    "CameraMode",
    "CaptureResult",
    "CaptureSettings",
    "Decision",
    "Driver",
    "FrameFeedback",
    "LiveSink",
    "LiveSinks",
    "LowDetectionError",
    "NewRequest",
    "Placement",
    "Procedure",
    "ProcedureRefusedError",
    "QuitRecording",
    "RecordingSummary",
    "Shortfall",
    "continued_given",
    "continued_session",
    "detection_shortfall",
    "guidance_asked",
    "record",
    "record_interactive",
    "record_planned",
    "record_terminal",
    "refuse_existing",
    "rig_file",
    "say_fork",
    "serve_console_until_stopped",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "CameraMode": "recorder.procedure.new_session",
    "CaptureResult": "recorder.procedure.capture",
    "CaptureSettings": "recorder.procedure.capture",
    "Decision": "recorder.procedure.driver",
    "Driver": "recorder.procedure.driver",
    "FrameFeedback": "recorder.procedure.capture",
    "LiveSink": "recorder.procedure.capture",
    "LiveSinks": "recorder.procedure.capture",
    "LowDetectionError": "recorder.procedure.driver",
    "NewRequest": "recorder.procedure.new_session",
    "Placement": "recorder.procedure.driver",
    "Procedure": "recorder.procedure.machine",
    "ProcedureRefusedError": "recorder.procedure.driver",
    "QuitRecording": "recorder.procedure.driver",
    "RecordingSummary": "recorder.procedure.summary",
    "Shortfall": "recorder.procedure.capture",
    "continued_given": "recorder.procedure.new_session",
    "continued_session": "recorder.procedure.new_session",
    "say_fork": "recorder.procedure.new_session",
    "detection_shortfall": "recorder.procedure.capture",
    "guidance_asked": "recorder.procedure.new_session",
    "record": "recorder.procedure.recording",
    "record_interactive": "recorder.procedure.terminal",
    "record_planned": "recorder.procedure.new_session",
    "record_terminal": "recorder.procedure.new_session",
    "refuse_existing": "recorder.procedure.machine",
    "rig_file": "recorder.procedure.new_session",
    "serve_console_until_stopped": "recorder.procedure.new_session",
}

__getattr__, __dir__ = lazy_exports("recorder.procedure", _HOMES, __all__)
