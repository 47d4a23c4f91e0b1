"""A run over many sessions: inputs, workers, cache and outputs.

The run itself (``runner``), its inputs resolved once (``inputs``), the worker processes
(``workers``) and their parent watch (``parent_watch``), the first pass of the operators'
noise (``noise_pass``), the cache of each session's analysis (``cache``), the output folder
(``outputs``); the allocator a decoding process wants is the session pipeline's
(:func:`analysis.session.pipeline.keep_frame_buffers`, re-exported here).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.batch.inputs import InputSet, SessionIdentity, resolve_inputs, sessions_said
    from analysis.batch.outputs import (
        Inputs,
        OutputFolder,
        check_run_outputs,
        printable_stem,
        run_inputs,
        write_atomically,
        write_file,
    )
    from analysis.batch.parent_watch import end_quietly_on_closed_pipe, watch_parent
    from analysis.batch.runner import run
    from analysis.session.pipeline import keep_frame_buffers

__all__ = [
    "InputSet",
    "Inputs",
    "OutputFolder",
    "SessionIdentity",
    "check_run_outputs",
    "end_quietly_on_closed_pipe",
    "keep_frame_buffers",
    "printable_stem",
    "resolve_inputs",
    "run",
    "run_inputs",
    "sessions_said",
    "watch_parent",
    "write_atomically",
    "write_file",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "InputSet": "analysis.batch.inputs",
    "Inputs": "analysis.batch.outputs",
    "OutputFolder": "analysis.batch.outputs",
    "SessionIdentity": "analysis.batch.inputs",
    "check_run_outputs": "analysis.batch.outputs",
    "end_quietly_on_closed_pipe": "analysis.batch.parent_watch",
    "keep_frame_buffers": "analysis.session.pipeline",
    "printable_stem": "analysis.batch.outputs",
    "resolve_inputs": "analysis.batch.inputs",
    "run": "analysis.batch.runner",
    "run_inputs": "analysis.batch.outputs",
    "sessions_said": "analysis.batch.inputs",
    "watch_parent": "analysis.batch.parent_watch",
    "write_atomically": "analysis.batch.outputs",
    "write_file": "analysis.batch.outputs",
}

__getattr__, __dir__ = lazy_exports("analysis.batch", _HOMES, __all__)
