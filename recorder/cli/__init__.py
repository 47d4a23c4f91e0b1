"""``twopose-record``'s command line: its entry point, options and rules.

The entry point that handles stop signals from its first instruction (``command``), the
typer app (``app``), the options read and checked by their bounds (``options``), the options
refused where they have no effect (``option_rules``) and ``calibrate-pair``'s,
``point``'s and ``simulate``'s commands (``pair``, ``point``, ``simulate``). Each command is
a short layer over one call of the library.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.cli.command import main

__all__ = [
    "main",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "main": "recorder.cli.command",
}

__getattr__, __dir__ = lazy_exports("recorder.cli", _HOMES, __all__)
