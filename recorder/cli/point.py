"""``twopose-record point``: where the finger points on the floor, live, from a pair of
cameras, in the browser (issue 58 item 5); nothing is recorded.

A short layer over :func:`recorder.console.pointing_server.serve_pointing` (one call from
Python). Registered on ``twopose-record``'s app by ``recorder/cli/app.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from recorder.cli.options import read_option as _read
from twopose.errors import handle_errors
from twopose.methods.specs import METHOD_SPECS, Method
from twopose.values.options import registered

__all__ = ["point_command"]


def point_command(
    source: Annotated[
        str,
        typer.Option(
            help="The two cameras: 'pair:camera:0,camera:1' (or two videos: "
            "'pair:video:a.avi,video:b.avi')."
        ),
    ],
    pair: Annotated[
        Path,
        typer.Option(exists=True, dir_okay=False, help="The pair file calibrate-pair wrote."),
    ],
    method: Annotated[
        Method,
        typer.Option(
            **registered(METHOD_SPECS, lambda spec: spec.measures),
            help="What is pointed with: ground (the finger's line on the floor; the pair "
            "file needs its floor), line, or point (the dot).",
        ),
    ] = Method.GROUND,
    clock_offset_ms: Annotated[
        float,
        typer.Option(
            "--clock-offset-ms",
            **_read("CLOCK_OFFSET"),
            help="Camera 2's capture clock minus camera 1's, ms (0: both stamp on this "
            "machine's monotonic clock, as every pair source does).",
        ),
    ] = 0.0,
    port: Annotated[
        int, typer.Option(**_read("PORT"), help="Port of the page (0: a free one).")
    ] = 0,
    host: Annotated[
        str,
        typer.Option(help="Address the page listens on; anything but loopback is warned about."),
    ] = "127.0.0.1",
) -> None:
    """Show where the finger points on the floor, live, in the browser: the point, its 95%
    region, the last second's track and the pair's conditioning (nothing is recorded)."""
    from recorder.console.loopback import is_loopback_host
    from recorder.console.pointing_server import PointRequest, serve_pointing

    if not is_loopback_host(host):
        typer.secho(
            f"warning: --host {host} shows the page beyond this machine",
            err=True,
            fg=typer.colors.YELLOW,
        )
    with handle_errors():
        request = PointRequest(
            source=source, pair=pair, method=method, offset_ms=clock_offset_ms,
            host=host, port=port,
        )  # fmt: skip
        serve_pointing(request)
