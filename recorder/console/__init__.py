"""The web console (``new --ui``): its state, server, front door and page.

The shared state the page shows and the server takes (``state``), the driver (``driver``),
the server (``server``), the camera stream (``frames``), the front door that lets only the
operator in (``guard`` for requests, ``transport`` for the socket, ``loopback`` the one
rule) and the page itself (``page/``: its markup, style and scripts, one per concern).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.console.loopback import is_loopback_host
    from recorder.console.server import ConsoleOptions, serve_console

__all__ = [
    "ConsoleOptions",
    "is_loopback_host",
    "serve_console",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "ConsoleOptions": "recorder.console.server",
    "is_loopback_host": "recorder.console.loopback",
    "serve_console": "recorder.console.server",
}

__getattr__, __dir__ = lazy_exports("recorder.console", _HOMES, __all__)
