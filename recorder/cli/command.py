"""``twopose-record``'s entry point (``[project.scripts]``, ``python -m recorder``): a stop
signal is an interrupt from the command's first instruction on, and a stopped command
exits as soon as its file is closed.

The command line's modules take a few tenths of a second to import (typer, NumPy, the
session format). A Ctrl-C then printed a ``KeyboardInterrupt`` traceback from an import,
and SIGTERM or SIGHUP killed the process (exit 143, 129). This module imports only the
standard library's signal handling (:func:`twopose.errors.watch_interrupts`; the package
loads nothing on import) before it handles them, then imports and runs the command line: a
stop before the command begins exits 130 with one line, ``interrupted``, and no traceback;
one while it records is the recording's (:mod:`recorder.procedure.stops`: the file closed, the
summary printed).

Once a stopped command has said so, nothing is left to do but Python's own teardown of its
modules, which took 0.5-1.2 s of the two seconds a stop may take on a loaded machine (the
file is closed, every stream flushed): the process ends then and there.
"""

from __future__ import annotations

import contextlib
import os
import sys
from typing import NoReturn

from twopose.errors import EXIT_INTERRUPTED, say_interrupted, watch_interrupts

__all__ = ["main"]


def main() -> None:
    """Run ``twopose-record`` (:func:`recorder.cli.app.main`) with the stops handled first."""
    watch_interrupts(hangup=True)  # the script's first step: it imported only this module
    try:
        from recorder.cli.app import main as command_line
    except KeyboardInterrupt:  # a stop while the command line's modules were imported
        say_interrupted()
        _exit_now(EXIT_INTERRUPTED)
    try:
        command_line()
    except SystemExit as done:
        if done.code == EXIT_INTERRUPTED:  # stopped: its file closed, its summary said
            _exit_now(EXIT_INTERRUPTED)
        raise


def _exit_now(code: int) -> NoReturn:
    """End the process with ``code`` once what it printed is out, without Python's teardown
    of the modules (nothing of the command's is open: it was closed before it said so)."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing more to say
            stream.flush()
    os._exit(code)
