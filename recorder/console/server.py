"""The web console's server (see :mod:`recorder.console.state` for the routes): a Starlette
app served by uvicorn, the recording thread, and the live image as MJPEG with the
detection drawn on it (:mod:`recorder.console.frames`, per viewer frame, so the capture
thread only hands the stored JPEG over)."""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import uvicorn
from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, Response, StreamingResponse
from starlette.routing import Route
from typing_extensions import override

from recorder.console.driver import WebDriver, said_ended, said_failed
from recorder.console.frames import BOUNDARY, mjpeg, preview
from recorder.console.guard import (
    ConsoleGuard,
    ConsoleJSONResponse,
    parsed_body,
    text_refusal,
)
from recorder.console.loopback import is_loopback_host
from recorder.console.pointing_route import pointing_routes
from recorder.console.state import DECISIONS, ConsoleSession
from recorder.console.stream_driver import STREAM_LIMITS, start_pair_recording, stream_answer
from recorder.console.transport import ACCEPT_BURST, MAX_HEADER_BYTES, GuardedH11Protocol
from recorder.live.pointing_feed import PointingFeed
from recorder.procedure import stops
from recorder.setup.form import SETUP_FIELDS, FormRefusedError, parse_pose_form, setup_from_answers
from recorder.setup.rules import Setup, check_rig
from twopose.display import fonts as webfonts
from twopose.errors import InputValueError, SourceError, TwoposeError
from twopose.methods.specs import Method

if TYPE_CHECKING:
    from recorder.live.view import LiveView
    from recorder.procedure.stream_terminal import PairSetup
    from recorder.setup.continuation import Continued
    from recorder.setup.rules import GuidanceAsked
    from twopose.pair.calibration import PairCalibration
    from twopose.rig.constants import RigConstants
    from twopose.uncertainty.noise import PlacingSigma

__all__ = ["ConsoleOptions", "console_app", "serve_console"]

MAX_NOTE_CHARS = 500  # a note about a trial
MAX_OPERATOR_CHARS = 80  # who records
_SETUP_LIMITS = {f.name: 200 for f in SETUP_FIELDS} | {"operator": MAX_OPERATOR_CHARS}
_POSE_LIMITS = {"x": 50, "y": 50, "z": 50, "rotation": 100}
_CLOSE_TIMEOUT_S = 10.0  # after the first second: the recording thread is stuck


@dataclass(kw_only=True)
class ConsoleOptions:
    """What the command line gave (``given``: ask_setup's arguments) and how to record."""

    source: str
    given: dict[str, Any]
    frames: int = 5
    adaptive_frames: bool = False  # --adaptive-frames: frames is then the most
    poses: int = 2
    size: tuple[int, int] = (640, 480)
    fps: float = 30.0
    notes: str = ""
    rig: RigConstants | None = None
    placing: PlacingSigma | None = None  # the rig file's measured placing sigma
    live_port: int | None = None  # --live: the Foxglove live view too, on this port
    origin: str = ""  # the console's own page (the live view lets it in), once served
    guidance: GuidanceAsked | None = None  # --max-poses and the suggestions' reach
    continued: Continued | None = None  # --continue: the session this one continues
    #: ``--pair``: the pair, its setup (asked at the terminal): stream trials, no form.
    pair: PairCalibration | None = None
    pair_setup: PairSetup | None = None


def _recording(
    session: ConsoleSession,
    setup: Setup,
    options: ConsoleOptions,
    stopping: threading.Event,
    view: LiveView | None,
) -> None:
    """The recording thread: the procedure with the page as its driver (and the live view,
    with ``--live``). It prints the summary, once, when the procedure ends (the page's
    quit, or the server stopping)."""
    from recorder.procedure.capture import CaptureSettings, LiveSinks
    from recorder.procedure.recording import record
    from recorder.setup.rules import GuidanceAsked, PoseTyping
    from recorder.sources.registry import open_source

    try:
        asked = options.guidance or GuidanceAsked()
        guidance = asked.guidance(setup.units, options.poses, setup.target95)
        continued = options.continued
        camera, info = setup.camera(), setup.info(options.notes)
        if continued is not None:  # the same session: its id, cameras, trials numbered on
            camera = continued.cameras[0]
            info = continued.info_for(options.notes, operator=setup.operator)
        width, height = camera.intrinsics.width, camera.intrinsics.height  # the size recorded
        src = open_source(
            options.source, method=setup.method, width=width, height=height, fps=options.fps,
            units=setup.units,  # the synthetic scene in the session's units, through its camera
            cameras=[camera],
        )  # fmt: skip
        typing = PoseTyping(poses_per_trial=guidance.max_poses)
        driver = WebDriver(session, src, camera.camera_id, setup.ground_truth, typing, preview)
        live = session if view is None else LiveSinks(session, view)
        capture = CaptureSettings.live_detection(
            info,
            frames=options.frames,
            live=live,
            rig=options.rig,
            placing=options.placing,
            guidance=guidance,
            adaptive_frames=options.adaptive_frames,
        )
        summary = record(
            session.out, info, [camera], src, driver, ground=setup.ground(), capture=capture,
            after_trial=continued.last_trial if continued is not None else 0,
        )  # fmt: skip
        said_ended(summary.line(), stopped=stopping.is_set() or stops.requested())
    except Exception as err:  # the page must say it, not a thread's traceback
        said_failed(session, err)
    finally:
        if view is not None:
            view.close()


class _Console:
    """The routes of one recording session (see :mod:`recorder.console.state`)."""

    def __init__(
        self, session: ConsoleSession, options: ConsoleOptions, ready: Setup | None = None
    ) -> None:
        self.session, self.options, self.ready = session, options, ready
        self.threads: list[threading.Thread] = []
        self.stopping = threading.Event()  # the server is stopping (Ctrl-C, SIGTERM)
        self.pointing = PointingFeed()  # the live pointing panel's (a pair's recording's)

    def start(self, setup: Setup) -> None:
        """Record ``setup`` (checked: :func:`checked_setup`); the live view is opened here,
        so a busy ``--live-port`` is said before the recording starts."""
        view = _open_live_view(setup, self.options)
        self.session.begin(setup, self.options.rig)
        thread = threading.Thread(
            target=_recording,
            args=(self.session, setup, self.options, self.stopping, view),
            name="recording",
        )
        thread.daemon = True
        self.threads.append(thread)
        thread.start()

    async def stream_action(self, request: Request) -> Response:
        """``POST /api/stream`` (:mod:`recorder.console.stream_driver`)."""
        at_ns = time.monotonic_ns()  # the button's moment, before anything else
        form, refused = await _form(request, STREAM_LIMITS)
        if refused is not None:
            return refused
        why, errors = stream_answer(self.session, form, at_ns)
        return _refused(why, errors) if why else ConsoleJSONResponse({"ok": True})

    async def page(self, _request: Request) -> Response:
        html = resources.files("recorder.console").joinpath("page", "index.html").read_text("utf-8")
        return HTMLResponse(html, headers={"Cache-Control": "no-store"})

    async def state(self, _request: Request) -> Response:
        return ConsoleJSONResponse(self.session.snapshot(), headers={"Cache-Control": "no-store"})

    async def setup(self, request: Request) -> Response:
        form, refused = await _form(request, _SETUP_LIMITS)
        if self.session.phase != "setup":
            return _refused("the session is already set up")
        # Every refusal at once: a field too long is judged beside the others, not first.
        too_long = _field_errors(form, _SETUP_LIMITS)
        if refused is not None and not too_long:
            return refused
        try:
            setup = checked_setup(
                {k: v for k, v in form.items() if k not in too_long}, self.options
            )
        except FormRefusedError as err:
            errors = {**err.errors, **too_long}
            return _refused(str(FormRefusedError(errors)), errors)
        if too_long:
            return _refused(str(FormRefusedError(too_long)), too_long)
        try:
            self.start(setup)
        except TwoposeError as err:  # a busy --live-port
            return _refused(str(err), {"setup": str(err)})
        return ConsoleJSONResponse({"ok": True})

    async def pose(self, request: Request) -> Response:
        form, refused = await _form(request, _POSE_LIMITS)
        if refused is not None:
            return refused
        units = self.session.units
        if self.session.waiting != "pose" or units is None:  # said before the form's errors
            return _refused(self.session.take("pose") or "not now: no pose is asked for")
        try:
            t, r = parse_pose_form(form, units)
        except FormRefusedError as err:
            return _refused(str(err), err.errors)
        why = self.session.take("pose", (t, r))
        return _refused(why) if why else ConsoleJSONResponse({"ok": True})

    async def decide(self, request: Request) -> Response:
        form, refused = await _form(request, {"decision": 20, "offer": 20})
        if refused is not None:
            return refused
        choice = form.get("decision", "")
        seen = form.get("offer")  # the decision offer the page answers (optional)
        if seen is not None and not seen.isdigit():
            return _refused(f"offer must be the state's offer number, not {seen!r}")
        if choice != "quit" and choice not in DECISIONS:
            return _refused(
                "decision must be accept, accept_anyway, redo, undo or quit, not " + repr(choice)
            )
        if choice == "quit":
            why = self.session.take("quit")
        else:
            answer = (choice, DECISIONS[choice])
            why = self.session.take("decision", answer, seen=None if seen is None else int(seen))
        if why:
            if self.session.phase == "recording":  # next to the button pressed
                self.session.refuse(choice, why)
            return _refused(why, {choice: why})
        return ConsoleJSONResponse({"ok": True})

    async def note(self, request: Request) -> Response:
        form, refused = await _form(request, {"text": MAX_NOTE_CHARS})
        if refused is not None:
            return refused
        text = form.get("text", "").strip()
        if not text:
            return _refused("the note is empty", {"text": "type the note first"})
        why = self.session.take("note", text)
        return _refused(why) if why else ConsoleJSONResponse({"ok": True})

    async def stream(self, request: Request) -> Response:
        return StreamingResponse(
            mjpeg(self.session, request),
            media_type=f"multipart/x-mixed-replace; boundary={BOUNDARY}",
            headers={"Cache-Control": "no-store"},
        )

    @contextlib.asynccontextmanager
    async def lifespan(self, _app: Starlette) -> AsyncIterator[None]:
        if self.ready is not None:  # all given on the command line: no form to fill
            self.start(self.ready)
        elif (pair := self.options.pair) and (setup := self.options.pair_setup):
            # A pair's stream trials, the setup asked at the terminal.
            run = start_pair_recording(self.session, self.options, pair, setup, self.pointing)
            self.threads.append(run)
        yield
        self.stopping.set()
        # The server stops (Ctrl-C, SIGTERM, SIGHUP): the session is interrupted, its file
        # closed (the recording thread saw the stop already: recorder/procedure/stops.py).
        stop = stops.active()
        if stop is not None:
            stop.request()
        self.session.interrupt()
        await asyncio.to_thread(_join_recording, self.threads, self.session.out)


def console_app(
    session: ConsoleSession,
    options: ConsoleOptions,
    *,
    host: str = "127.0.0.1",
    token: str | None = None,
    ready: Setup | None = None,
    pointing: PointingFeed | None = None,
) -> Starlette:
    """The ASGI app of one recording session, behind its guard (``host``: the address it
    listens on, ``--host``; ``token``: the session's, random by default; see
    :mod:`recorder.console.guard`). ``ready``: a setup the command line gave whole
    (:func:`checked_setup`), recorded at once. ``pointing``: the pointing panel's feed
    (:mod:`recorder.live.pointing_feed`; None: the console's own, a pair's recording's)."""
    c = _Console(session, options, ready)
    c.pointing = pointing or c.pointing
    routes = [
        Route("/", c.page),
        Route("/api/state", c.state),
        Route("/api/setup", c.setup, methods=["POST"]),
        Route("/api/pose", c.pose, methods=["POST"]),
        Route("/api/decide", c.decide, methods=["POST"]),
        Route("/api/note", c.note, methods=["POST"]),
        Route("/api/stream", c.stream_action, methods=["POST"]),
        Route("/stream.mjpg", c.stream),
        *pointing_routes(c.pointing, session.closing),
        *(Route(f"/{name}", _asset(name, media)) for name, media in PAGE_FILES.items()),
        *(Route(f"/fonts/{font.file}", _font(font.file)) for font in webfonts.FONTS),
    ]
    guard = Middleware(ConsoleGuard, host=host, token=token)
    return Starlette(routes=routes, lifespan=c.lifespan, middleware=[guard])


#: The page's files beside ``index.html``, each served at ``/NAME``: its style and its
#: scripts, one per concern (``index.html`` loads them in this order; ``main.js``,
#: last, polls the state and wires the controls).
PAGE_FILES: dict[str, str] = {
    "style.css": "text/css; charset=utf-8",
    **{
        f"{script}.js": "text/javascript; charset=utf-8"
        for script in ("util", "setup", "capture", "topview", "stream", "pointing")
    },
    "main.js": "text/javascript; charset=utf-8",
}


def _asset(name: str, media_type: str) -> Any:
    """A route serving one of the page's files from the package (the page's script and
    style are files, not inline, so the Content-Security-Policy can forbid inline code)."""

    async def serve(_request: Request) -> Response:
        text = resources.files("recorder.console").joinpath("page", name).read_text("utf-8")
        return Response(text, media_type=media_type, headers={"Cache-Control": "no-store"})

    return serve


def _font(file: str) -> Any:
    """A route serving one of the page's fonts (style.css names them: the screen is drawn
    the same whatever fonts the machine has)."""

    async def serve(_request: Request) -> Response:
        data = webfonts.font_bytes(file)
        return Response(
            data, media_type=webfonts.FONT_MEDIA_TYPE, headers={"Cache-Control": "max-age=86400"}
        )

    return serve


def _given(options: ConsoleOptions) -> dict[str, Any]:
    return dict(options.given, size=options.size)


def checked_setup(form: dict[str, str], options: ConsoleOptions) -> Setup:
    """The setup the form and the command line describe, with the rig file checked
    against it as the terminal and a plan check it (:func:`recorder.setup.rules.check_rig`);
    raises :class:`FormRefusedError` holding every refusal, by field."""
    setup = setup_from_answers(form, _given(options))
    if options.guidance is not None:  # the guidance options' bounds in these units
        refused = options.guidance.refusals(setup.method, setup.units, setup.target95)
        if refused:
            raise FormRefusedError(refused)
    try:
        check_rig(options.rig, setup.method, setup.units, [setup.camera()], setup.ground())
    except InputValueError as err:
        raise FormRefusedError({"rig": str(err).removeprefix("the rig file: ")}) from err
    return setup


def _complete_setup(options: ConsoleOptions) -> Setup | None:
    """The setup when the command line gave every answer (None: the page asks); refused
    here, at the terminal, when it is wrong: the page could not change what was given."""
    given = _given(options)
    optional = ("intrinsics", "target_precision")  # no stop rule unless one is given
    if any(v is None for k, v in given.items() if k not in optional):
        return None
    return checked_setup({}, options)


def _open_live_view(setup: Setup, options: ConsoleOptions) -> LiveView | None:
    """``--live``: the Foxglove live view for this setup's camera (None without it)."""
    if options.live_port is None:
        return None
    import sys

    from recorder.live.view import LiveView

    view = LiveView([setup.camera()], port=options.live_port, origins=[options.origin])
    print(
        f"live view on {view.url}: in Foxglove, Open connection > Foxglove WebSocket",
        file=sys.stderr,
        flush=True,
    )
    return view


async def _form(request: Request, limits: dict[str, int]) -> tuple[dict[str, str], Response | None]:
    """The request's fields named in ``limits`` (others are ignored), as text, and a 400
    naming each field whose text is too long or holds control characters (None: none).
    The guard has already refused bodies that are not a flat JSON object of text or
    numbers (:mod:`recorder.console.guard`)."""
    try:
        data = parsed_body(await request.body())
    except ValueError:  # the guard judged it already; a body read twice would differ
        return {}, _refused("the request must be a JSON object of fields")
    form = {k: str(v) for k, v in data.items() if k in limits and isinstance(v, str)}
    errors = _field_errors(form, limits)
    if errors:
        return form, _refused("; ".join(f"{k}: {v}" for k, v in errors.items()), errors)
    return form, None


def _field_errors(form: dict[str, str], limits: dict[str, int]) -> dict[str, str]:
    """Each field whose text is too long or holds a control character, and why."""
    return {k: why for k, v in form.items() if (why := text_refusal(v, limits[k]))}


def _refused(message: str, errors: dict[str, str] | None = None) -> Response:
    """400 with the message, and each refusal by the field or button it belongs to."""
    return ConsoleJSONResponse({"error": message, "errors": errors or {}}, status_code=400)


class _Server(uvicorn.Server):
    """uvicorn's server, stopped by the recording's stop (:mod:`recorder.procedure.stops`: Ctrl-C,
    SIGTERM or SIGHUP; told what the session was doing when it came). It stops gracefully,
    as uvicorn does, but a second signal never forces it (that would cancel the closing of
    the file), and the signals are not raised again afterwards: :func:`serve_console`
    reports them."""

    def __init__(self, config: uvicorn.Config, session: ConsoleSession) -> None:
        super().__init__(config)
        self.session = session
        self.phase_at_signal = ""  # the session's phase when the first signal came

    @override
    @contextlib.contextmanager
    def capture_signals(self) -> Iterator[None]:
        yield  # the handlers are the recording's (stops.handled), in place before and after

    def stop(self) -> None:
        """The recording is asked to stop: the page's streams end, the server stops."""
        if not self.phase_at_signal:
            self.phase_at_signal = self.session.phase
        self.session.closing.set()  # the live image's streams end: nothing left to cancel
        with self.session.lock:  # reentrant: safe where the signal lands in this thread
            self.session.lock.notify_all()  # a stream waiting for a frame ends now
        self.should_exit = True


def _join_recording(threads: list[threading.Thread], out: Path) -> None:
    """Wait for the recording thread to close the file (it stops within a frame, or at
    once when it waits for the page or a suggestion); said once if it takes long, and
    what to do if it never ends (a camera stuck in its driver)."""
    import sys

    for thread in threads:
        thread.join(timeout=1.0)
        if thread.is_alive():
            stop = stops.active()
            if stop is not None:
                stop.say_closing()
            thread.join(timeout=_CLOSE_TIMEOUT_S)
        if thread.is_alive():
            sys.stderr.write(
                f"the recording did not stop within {_CLOSE_TIMEOUT_S + 1:.0f} s; what reached "
                f"the disk can be salvaged: twopose-record recover {out} -o FIXED.mcap\n"
            )


def serve_console(
    out: Path, options: ConsoleOptions, *, host: str = "127.0.0.1", port: int = 0
) -> ConsoleSession:
    """Serve the console until Ctrl-C or SIGTERM; prints the URL. The source is opened
    first (a missing camera is said before the setup, naming ``--source``). Raises
    KeyboardInterrupt if the session was interrupted (the recording thread has closed
    the file and printed the summary), TwoposeError if the recording failed."""
    import socket

    import typer

    if options.pair is None:
        _check_source(options)
    ready = _complete_setup(options) if options.pair is None else None
    if not is_loopback_host(host):
        typer.secho(
            f"warning: --host {host} exposes the console beyond this machine; anyone who "
            "can reach it can drive the recording",
            err=True,
            fg=typer.colors.YELLOW,
        )
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(ACCEPT_BURST)  # connections queue from the moment the URL is printed
    except OSError as err:
        raise TwoposeError(f"cannot listen on {host}:{port} ({err.strerror}); pick --port") from err
    session = ConsoleSession(out, _given(options))
    bound = sock.getsockname()[1]
    shown = f"[{host}]" if ":" in host else host
    options.origin = f"http://{shown}:{bound}"
    typer.echo(f"twopose console: {options.origin}/  (Ctrl-C to stop)", err=False)
    config = uvicorn.Config(
        console_app(session, options, host=host, ready=ready),
        log_level="warning",
        lifespan="on",
        timeout_graceful_shutdown=2,
        http=GuardedH11Protocol,  # the socket's limits (recorder/console/transport.py)
        h11_max_incomplete_event_size=MAX_HEADER_BYTES,
        backlog=ACCEPT_BURST,  # accepted per wake-up: evictions keep pace, descriptors last
        ws="none",  # no WebSocket route: an upgrade is a request like any other, guarded
    )
    server = _Server(config, session)
    with stops.handled() as stop:
        stop.on_request(server.stop)
        server.run(sockets=[sock])
    if session.phase == "failed":
        raise TwoposeError(session.message)
    if server.phase_at_signal in ("setup", "recording"):
        if server.phase_at_signal == "setup":
            typer.echo("nothing recorded: the setup was not finished")
        raise KeyboardInterrupt
    return session


def _check_source(options: ConsoleOptions) -> None:
    """Open the source and close it again, before the page asks anything: a camera that
    is not there is an error now, naming ``--source``, not after the whole setup."""
    from recorder.sources.registry import open_source

    width, height = options.size
    method = Method(options.given.get("method") or Method.POINT)
    try:
        source = open_source(options.source, method=method, width=width, height=height)
        with source:
            pass
    except TwoposeError as err:
        raise SourceError(f"--source {options.source}: {err}") from err
