"""``twopose-record point``: where the finger points, live, from a pair of cameras; nothing
is recorded (issue 58 item 5; one call from Python: :func:`serve_pointing`).

The pair source (``--source pair:A,B``) is read on a thread (:func:`run_pointing`): each
frame goes to :class:`recorder.live.pointing.LivePointing` as it comes, and each pair's
estimate is published to the panel's feed (:class:`recorder.live.pointing_feed.PointingFeed`)
as soon as it is made. The page (``pointing.html``: the console's live pointing panel,
alone) is served by the console's server machinery (:mod:`recorder.console.server`: its
guard, its socket's limits, its stops) on one port: ``/`` the page, ``/api/pointing`` the
push stream, ``/api/clock`` the clock (:mod:`recorder.console.pointing_route`). A two-camera
recording shows the same panel in the console (``console_app(pointing=feed)``), fed by
the same loop's two calls (``LivePointing.add_frame``, ``PointingFeed.publish``).
"""

from __future__ import annotations

import contextlib
import socket
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import uvicorn
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, Response
from starlette.routing import Route
from typing_extensions import override

from recorder.console.guard import ConsoleGuard
from recorder.console.pointing_route import pointing_routes
from recorder.console.transport import ACCEPT_BURST, MAX_HEADER_BYTES, GuardedH11Protocol
from recorder.live.pointing import FloorView, LivePointing, PointingSettings
from recorder.live.pointing_feed import PointingFeed
from recorder.procedure import stops
from recorder.procedure.stream_source import check_sizes
from twopose.display import fonts as webfonts
from twopose.errors import InputValueError, SourceError, TwoposeError
from twopose.methods.specs import Method, spec_of
from twopose.values.units import Units, unit_factor

if TYPE_CHECKING:
    from recorder.sources.pair import CameraStream, PairSource
    from twopose.pair.calibration import PairCalibration

__all__ = [
    "PointRequest", "about", "freeze_garbage", "pointing_app", "run_pointing", "serve_pointing",
]  # fmt: skip

#: The panel's smallest view: this many inches either side of the point (in the units).
_SPAN_IN = 3.0
_PAGE_FILES = {
    "style.css": "text/css; charset=utf-8",
    "util.js": "text/javascript; charset=utf-8",
    "pointing.js": "text/javascript; charset=utf-8",
}


@dataclass(frozen=True, kw_only=True)
class PointRequest:
    """What ``point`` was given: the pair source, the pair file, the method, the clock
    offset (ms, camera 2's clock minus camera 1's) and where to serve the page."""

    source: str
    pair: Path
    method: Method = Method.GROUND
    offset_ms: float = 0.0
    host: str = "127.0.0.1"
    port: int = 0


def about(
    method: Method, pair: PairCalibration, cameras: tuple[CameraStream, CameraStream] | None = None
) -> dict[str, Any]:
    """The feed's status while the pair runs: what the panel says it shows, and how
    (``cameras``: what each delivers, where known)."""
    spec = spec_of(method)
    units = pair.units
    said: dict[str, Any] = {
        "about": f"{spec.label}, seen on {FloorView.of(pair).name} from above ({units.value})",
        "units": units.value,
        "axes": ["across", "ahead"],
        "span": _SPAN_IN * unit_factor(Units.IN, units),
        "method": spec.method.value,
    }
    # a pair whose covariance its check did not confirm: every region here carries it
    # (docs: "said wherever its covariance is used"; a new user's r7 K8: `point` said nothing)
    unconfirmed = pair.check.unconfirmed() if pair.check is not None else ""
    if unconfirmed:
        said["about"] += f"; warning: {unconfirmed}"
    if cameras is not None:
        said["cameras"] = [c.text() for c in cameras]
        said["fps"] = min(c.info.fps for c in cameras)
        # What makes every point meaningless (two copies of one recording): said on the
        # page in place of "conditioning: ok", never only in the terminal.
        said["warnings"] = [c.warning for c in cameras if c.warning]  # each names its camera
    return said


def run_pointing(
    source: PairSource, live: LivePointing, feed: PointingFeed, stop: threading.Event,
    *, opened: bool = False,
) -> None:  # fmt: skip
    """Frames in, estimates published, until the streams end, a camera fails or ``stop``;
    the feed is told why the pair stopped (never a traceback). ``opened``: the source was
    opened (and the estimate warmed up) by the caller; it is closed here either way."""
    why = "the pair stopped"
    try:
        if not opened:
            live.warm_up()
            source.open()
        with contextlib.closing(source):
            feed.start(about(live.method, live.pair, source.cameras))
            for frame in source.frames():
                if stop.is_set():
                    why = "stopped"
                    break
                # the other camera's file or folder ended: the pairs end with it, said
                # (a new user's r7 K10: its last point stayed green 2.4 s, then "the
                # cameras' streams ended", camera 1's file played to its end)
                if ran_out := source.ran_out(frame):
                    feed.publish(live.end())
                    why = f"the pair stopped: {ran_out}"
                    break
                feed.publish(live.add_frame(frame))
            else:
                feed.publish(live.end())
                said = "; ".join(source.ended_by())
                why = "the cameras' streams ended" + (f" ({said})" if said else "")
    except KeyboardInterrupt:
        why = "stopped"
    except TwoposeError as err:
        why = f"the pair stopped: {err}"
    except Exception as err:  # the page must say it, not a thread's traceback
        why = f"the pair stopped: {type(err).__name__}: {err}"
    if live.voids.kept:  # the amber not lost when the streams end (a new user's r8 F8)
        why += f"; the points were not to be trusted: {live.voids.kept}"
    feed.stop(why)


def pointing_app(
    feed: PointingFeed,
    closing: threading.Event,
    *,
    host: str = "127.0.0.1",
    token: str | None = None,
) -> Starlette:
    """The pointing page and its push stream behind the console's guard."""

    async def page(_request: Request) -> Response:
        html = resources.files("recorder.console").joinpath("page", "pointing.html")
        return HTMLResponse(html.read_text("utf-8"), headers={"Cache-Control": "no-store"})

    def asset(name: str, media: str) -> Any:
        async def serve(_request: Request) -> Response:
            text = resources.files("recorder.console").joinpath("page", name).read_text("utf-8")
            return Response(text, media_type=media, headers={"Cache-Control": "no-store"})

        return serve

    def font(file: str) -> Any:
        async def serve(_request: Request) -> Response:
            return Response(webfonts.font_bytes(file), media_type=webfonts.FONT_MEDIA_TYPE)

        return serve

    routes = [
        Route("/", page),
        *pointing_routes(feed, closing),
        *(Route(f"/{name}", asset(name, media)) for name, media in _PAGE_FILES.items()),
        *(Route(f"/fonts/{f.file}", font(f.file)) for f in webfonts.FONTS),
    ]
    return Starlette(routes=routes, middleware=[Middleware(ConsoleGuard, host=host, token=token)])


def _opened(request: PointRequest) -> tuple[PairSource, LivePointing]:
    """The pair source (not yet opened) and the live estimate; refused in words."""
    from recorder.sources.pair import PairSource
    from recorder.sources.registry import SOURCE_KINDS, SourceOptions, kind_of, open_from
    from twopose.pair.clock import ClockOffset
    from twopose.pair.pair_file import read_pair_file

    pair = read_pair_file(request.pair)
    spec = spec_of(request.method)
    if spec.needs_ground and pair.floor is None:
        raise InputValueError(
            f"{spec.label} needs the floor: calibrate the pair with a board lying on the floor "
            f"(calibrate-pair --floor-left, --floor-right), or point with --method point or line"
        )
    if kind_of(request.source).cameras != 2:
        raise SourceError(f"--source {request.source}: point takes two cameras: pair:A,B")
    source = open_from(SOURCE_KINDS, request.source, SourceOptions(method=spec.method))
    assert isinstance(source, PairSource)  # the kind of two cameras opens a pair
    offset = ClockOffset(offset_ns=request.offset_ms * 1e6, sigma_ns=0.0, method="given", n=0)
    return source, LivePointing(spec.method, pair, PointingSettings(offset=offset))


def freeze_garbage() -> None:
    """Move every object made so far (the modules, the app, the warmed-up estimate) out of
    the garbage collector's reach (``gc.freeze``): its full collections, which scan them,
    took ~55 ms once in a 30 s run, a pair's point that late; now they scan only what the
    pairs make."""
    import gc

    gc.collect()
    gc.freeze()


def _listening(host: str, port: int) -> socket.socket:
    """A socket listening on ``host:port`` (its URL printed); refused in words."""
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(ACCEPT_BURST)
    except OSError as err:
        sock.close()
        raise TwoposeError(f"cannot listen on {host}:{port} ({err.strerror}); pick --port") from err
    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{sock.getsockname()[1]}/"
    print(f"twopose pointing: {url}  (Ctrl-C to stop)", flush=True)
    return sock


class _Server(uvicorn.Server):
    """uvicorn's server, its signals left to the recording's stops (as the console's)."""

    @override
    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield  # the handlers are stops.handled's, in place before and after


def serve_pointing(request: PointRequest) -> None:
    """Serve the pointing page until Ctrl-C or SIGTERM; prints its URL first.

    Stopped by a signal (the only way it stops), it raises KeyboardInterrupt once the page
    and the cameras are closed, as every stopped command does: the command line says
    ``interrupted`` and exits 130 (:func:`twopose.errors.handle_errors`)."""
    source, live = _opened(request)
    live.warm_up()
    feed, closing = PointingFeed(), threading.Event()
    config = uvicorn.Config(
        pointing_app(feed, closing, host=request.host), log_level="warning", lifespan="off",
        timeout_graceful_shutdown=2, http=GuardedH11Protocol,
        h11_max_incomplete_event_size=MAX_HEADER_BYTES, backlog=ACCEPT_BURST, ws="none",
    )  # fmt: skip
    server = _Server(config)
    freeze_garbage()  # before the cameras run: their first pairs are not held up by it
    try:  # a camera that is not there is said here, before the page is served
        source.open()
    except TwoposeError as err:
        raise SourceError(f"--source {request.source}: {err}") from err
    try:  # and one whose frames are not the size its calibration was made at
        check_sizes(source, (live.pair.intrinsics1, live.pair.intrinsics2))
    except BaseException:
        source.close()
        raise
    for n, camera in enumerate(source.cameras, start=1):
        print(f"camera {n}: {camera.text()}", flush=True)
    if live.pair.check is not None and live.pair.check.unconfirmed():
        print(f"warning: {live.pair.check.unconfirmed()}", flush=True)
    try:
        sock = _listening(request.host, request.port)
    except BaseException:  # refused, or a stop before the page was served
        source.close()
        raise
    loop = threading.Thread(
        target=run_pointing, args=(source, live, feed, closing), kwargs={"opened": True},
        daemon=True,
    )  # fmt: skip

    def stopping() -> None:
        closing.set()
        feed.close()
        server.should_exit = True

    with stops.handled() as stop:
        stop.on_request(stopping)
        loop.start()
        server.run(sockets=[sock])
    closing.set()
    loop.join(timeout=3.0)
    if loop.is_alive():
        sys.stderr.write("the cameras did not stop within 3 s\n")
    if stop.requested:
        raise KeyboardInterrupt
