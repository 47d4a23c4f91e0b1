"""The web console (``new --ui``): its state, server, front door and page.

The shared state the page shows and the server takes (``state``), the driver (``driver``),
the server (``server``), the camera stream (``frames``), the live pointing panel's push
stream (``pointing_route``) and its page alone (``pointing_server``: ``twopose-record
point``), the front door that lets only the operator in (``guard`` for requests,
``transport`` for the socket, ``loopback`` the one rule) and the page itself (``page/``: its
markup, style and scripts, one per concern).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.console.loopback import is_loopback_host
    from recorder.console.pointing_server import PointRequest, serve_pointing
    from recorder.console.server import ConsoleOptions, serve_console

__all__ = [
    "ConsoleOptions",
    "PointRequest",
    "is_loopback_host",
    "serve_console",
    "serve_pointing",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "ConsoleOptions": "recorder.console.server",
    "is_loopback_host": "recorder.console.loopback",
    "serve_console": "recorder.console.server",
    "PointRequest": "recorder.console.pointing_server",
    "serve_pointing": "recorder.console.pointing_server",
}

__getattr__, __dir__ = lazy_exports("recorder.console", _HOMES, __all__)
