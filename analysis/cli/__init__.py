"""``twopose-analyze``: the analyst's command line (a thin layer over the library).

Each command is a short layer over one library call, grouped by concern: ``describe``
(info), ``run`` (the main job), ``gate`` (check, compare), ``tools`` (rig, sensitivity,
detect, solve). They register on the one app (``analysis.cli.app``) in that order, which
is the order ``--help`` lists them in.
"""

from __future__ import annotations

import importlib

from analysis.cli.app import app
from twopose.errors import run_command_line

# Imported for their commands, in the order --help lists them.
for _module in ("describe", "run", "gate", "tools"):
    importlib.import_module(f"analysis.cli.{_module}")

__all__ = ["app", "main"]


def main() -> None:
    """The command line's entry point (``[project.scripts]``, ``python -m``)."""
    run_command_line(app)
