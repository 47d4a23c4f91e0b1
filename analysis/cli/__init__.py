"""``twopose-analyze``: the analyst's command line (a thin layer over the library).

Each command is a short layer over one library call, grouped by concern: ``describe``
(info), ``run`` (the main job), ``gate`` (check, compare), ``tools`` (rig, sensitivity,
detect, solve). They register on the one app (``analysis.cli.app``) in that order, which
is the order ``--help`` lists them in.
"""

from __future__ import annotations

import importlib

from analysis.cli.app import app
from twopose.errors import EXIT_INTERRUPTED, run_command_line

# Imported for their commands, in the order --help lists them.
for _module in ("describe", "run", "gate", "tools"):
    importlib.import_module(f"analysis.cli.{_module}")

__all__ = ["app", "main"]


def main() -> None:
    """The command line's entry point (``[project.scripts]``, ``python -m``).

    A command stopped by Ctrl-C (130) has closed its files and ended its child processes
    by the time it returns here; it then ends at once, without the interpreter's teardown
    of the libraries a run loaded (pandas, NumPy, OpenCV: 0.6 to 1 s on a busy machine, so
    that a Ctrl-C took over a second to give the prompt back)."""
    try:
        run_command_line(app)
    except SystemExit as done:
        if done.code == EXIT_INTERRUPTED:
            _end_now(EXIT_INTERRUPTED)
        raise


def _end_now(code: int) -> None:
    """End this process with ``code`` at once, its output flushed first."""
    import contextlib
    import os
    import sys

    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing more to say
            stream.flush()
    os._exit(code)
