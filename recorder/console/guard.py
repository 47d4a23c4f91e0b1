"""The web console's front door: only the operator drives it, only the operator sees it.

The console listens on loopback, but that keeps out other machines, not web pages: any
page open in the operator's browser can send requests to ``http://127.0.0.1:PORT`` (a
``fetch`` with ``Content-Type: text/plain`` needs no CORS preflight), and a DNS-rebinding
page reaches it under a host name of its own. :class:`ConsoleGuard`, an ASGI middleware
wrapped around the whole app, refuses before any route runs:

- **403** unless ``Host`` is loopback (:mod:`recorder.console.loopback`, the one rule) or the
  address the operator chose with ``--host`` (for ``0.0.0.0`` or ``::``: any IP address,
  never a name, since a rebinding page needs a name);
- **403** when ``Origin`` is present and not the console's own origin (``null``, the
  origin of sandboxed frames and files, is foreign), or when ``Sec-Fetch-Site`` says the
  API or the stream was asked for by another site;
- **403** for ``/api/...`` and ``/stream.mjpg`` without the session's token: a random
  value, set as a ``SameSite=Strict; HttpOnly`` cookie when the page (``/``) loads, so
  the operator's page carries it and no other site's can;
- **415** for a request with a body that is not ``Content-Type: application/json`` (which
  a cross-site page cannot send without a preflight, and none is granted);
- **413** for a body over :data:`MAX_BODY_BYTES`: refused on its ``Content-Length``
  before a byte is read, and counted while it streams otherwise;
- **408** for a body that does not arrive within :data:`BODY_TIMEOUT_S`;
- **400** for a body that is not a JSON object of distinct fields holding text or
  numbers of sane size (deeper than :data:`MAX_DEPTH`, a list, an object, NaN or a
  400-digit number anywhere; numbers are judged as the text they were sent as, by the one
  grammar, :func:`twopose.values.checks.read_number`, and passed on as that text: the field's
  quantity judges its bound in the words the page's form gets, ``1e309`` included), or
  with text that is too long or holds control characters;
- no WebSocket handshake at all (the console has none).

Every response carries ``X-Frame-Options: DENY`` and a ``Content-Security-Policy`` with
``frame-ancestors 'none'`` and scripts, styles and connections from the console only,
errors included: a failure inside the console answers a 500 with them, never bare. The
socket itself (header deadlines, a bound on connections, oversized headers) is guarded in
:mod:`recorder.console.transport`.
"""

from __future__ import annotations

import asyncio
import ipaddress
import json
import logging
import secrets
from typing import Any
from urllib.parse import urlsplit

from starlette.datastructures import Headers, MutableHeaders
from starlette.requests import cookie_parser
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from recorder.console.loopback import is_loopback_host, split_host
from twopose.errors import InputValueError
from twopose.values import jsonsafe
from twopose.values.checks import read_number
from twopose.values.text import first_control

__all__ = [
    "MAX_BODY_BYTES",
    "MAX_DEPTH",
    "MAX_TEXT_CHARS",
    "SECURITY_HEADERS",
    "ConsoleGuard",
    "ConsoleJSONResponse",
    "NumberText",
    "body_refusal",
    "parsed_body",
    "text_refusal",
]

MAX_BODY_BYTES = 64 * 1024
MAX_DEPTH = 2  # the API's bodies are flat objects: {"field": "text"}
MAX_TEXT_CHARS = 2000  # any one field; the note and the operator have their own, smaller
PROTECTED = ("/api/", "/stream.mjpg")  # prefixes that need the session's token
BODY_TIMEOUT_S = 10.0  # a request's body, once its headers came (the socket times those)

_log = logging.getLogger("twopose.console")

SECURITY_HEADERS = {
    "X-Frame-Options": "DENY",
    "Content-Security-Policy": (
        "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self'; "
        "connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; "
        "frame-ancestors 'none'"
    ),
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cross-Origin-Resource-Policy": "same-origin",  # no <img> of the stream on other sites
    "Cross-Origin-Opener-Policy": "same-origin",
}


class ConsoleJSONResponse(JSONResponse):
    """Every JSON the console answers: NaN and infinity as ``null`` (the one encoder,
    :func:`twopose.values.jsonsafe.dumps`), and anything it cannot encode as its text, so no
    state of the recorder can make the page's poll a 500."""

    def render(self, content: Any) -> bytes:
        text = jsonsafe.dumps(content, ensure_ascii=False, separators=(",", ":"), default=str)
        return text.encode("utf-8")


def text_refusal(text: str, limit: int = MAX_TEXT_CHARS) -> str:
    """Why a typed text is refused (empty: it is not): longer than ``limit`` characters,
    or holding a control character (a terminal would obey it where the text is printed)."""
    if len(text) > limit:
        return f"at most {limit} characters, please (this has {len(text)})"
    char = first_control(text)
    if char is not None:
        return f"a control character (U+{ord(char):04X}) cannot be part of it; retype it"
    return ""


def _depth(text: str) -> int:
    """The deepest nesting of JSON text, without parsing it (no recursion to overflow)."""
    depth = deepest = 0
    in_string = escaped = False
    for char in text:
        if in_string:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                in_string = False
        elif char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    return deepest


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number JSON allows")


class NumberText(str):
    """A JSON number as the text it was sent as: judged by the one number grammar
    (:func:`twopose.values.checks.read_number`), never converted by :mod:`json` first (a
    400-digit integer overflows the float ``math.isfinite`` would make of it); its field's
    quantity reads that text as the form's text is read."""

    __slots__ = ()


def _fields(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object's fields; a field given twice is refused (judged by one copy, the
    other would pass)."""
    fields: dict[str, Any] = {}
    for key, value in pairs:
        if key in fields:
            raise ValueError(f"the field {key[:40]!r} is given twice")
        fields[key] = value
    return fields


def _parse_json(text: str) -> Any:
    return json.loads(
        text,
        parse_int=NumberText,
        parse_float=NumberText,
        parse_constant=_no_constant,
        object_pairs_hook=_fields,
    )


def _value_refusal(key: str, value: Any) -> str:
    """Why one field's value is refused (empty: it is not)."""
    if isinstance(value, NumberText):
        try:
            read_number(value, key[:40])
        except InputValueError as err:
            return str(err).removeprefix(f"{key[:40]}: ").removeprefix(key[:40] + " ")
        return ""
    if isinstance(value, str):
        return text_refusal(value)
    return f"must be text, not {type(value).__name__.replace('NoneType', 'null')}"


def body_refusal(body: bytes) -> tuple[str, dict[str, str]]:
    """Why a request body is refused (an empty message: it is not), and which fields:
    it must be a JSON object of distinct fields, at most :data:`MAX_DEPTH` deep, whose
    values are text of at most :data:`MAX_TEXT_CHARS` characters without control
    characters, or numbers of sane size (:func:`twopose.values.checks.read_number`)."""
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError:
        return "the request is not UTF-8 text", {}
    if _depth(text) > MAX_DEPTH:
        return f"the request is nested deeper than {MAX_DEPTH} levels", {}
    try:
        data = _parse_json(text) if text.strip() else {}
    except ValueError as err:
        return f"the request is not valid JSON ({err})", {}
    if not isinstance(data, dict):
        return "the request must be a JSON object of fields", {}
    errors = {key[:40]: why for key, value in data.items() if (why := _value_refusal(key, value))}
    if errors:
        return "; ".join(f"{k}: {v}" for k, v in errors.items()), errors
    return "", {}


def parsed_body(body: bytes) -> dict[str, Any]:
    """A body :func:`body_refusal` let through, parsed as it judged it: numbers as their
    text (:class:`NumberText`)."""
    data = _parse_json(body.decode("utf-8")) if body.strip() else {}
    return data if isinstance(data, dict) else {}


class ConsoleGuard:
    """The ASGI middleware described in the module docstring. ``host``: the address the
    console listens on (``--host``); ``token``: the session's (random by default)."""

    def __init__(self, app: ASGIApp, host: str = "127.0.0.1", token: str | None = None) -> None:
        self.app = app
        self.token = token or secrets.token_urlsafe(32)
        self.bound = _normal_name(split_host(host)[0] or host)
        try:
            self.wildcard = ipaddress.ip_address(self.bound).is_unspecified
        except ValueError:
            self.wildcard = False

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "lifespan":
            await self.app(scope, receive, send)
            return
        if scope["type"] != "http":  # the console has no WebSocket: refuse every handshake
            await send({"type": "websocket.close", "code": 1008})
            return
        headers = Headers(scope=scope)
        cookie = self._cookie_name(scope)
        page = scope["path"] == "/" and scope["method"] in ("GET", "HEAD")
        started = False

        async def send_guarded(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
                out = MutableHeaders(scope=message)
                for name, value in SECURITY_HEADERS.items():
                    out[name] = value
                if page and message["status"] == 200:
                    out.append(
                        "set-cookie", f"{cookie}={self.token}; Path=/; HttpOnly; SameSite=Strict"
                    )
            await send(message)

        try:
            await self._answer(scope, receive, send_guarded, headers, cookie)
        except Exception:  # a bug: said in the log, and a 500 with the headers, never bare
            _log.exception("the console failed on %s %s", scope["method"], scope["path"][:80])
            if not started:
                failed = {"error": "the recorder failed on this request (see its terminal)"}
                await ConsoleJSONResponse({**failed, "errors": {}}, 500)(
                    scope, receive, send_guarded
                )

    async def _answer(
        self, scope: Scope, receive: Receive, send: Send, headers: Headers, cookie: str
    ) -> None:
        status, message = self._refusal(scope, headers, cookie)
        if status:
            await ConsoleJSONResponse({"error": message, "errors": {}}, status)(
                scope, receive, send
            )
            return
        if scope["method"] in ("GET", "HEAD", "OPTIONS"):
            await self.app(scope, receive, send)
            return
        await self._with_body(scope, receive, send)

    def _cookie_name(self, scope: Scope) -> str:
        """The token's cookie, named by the port (cookies ignore ports: two consoles on one
        machine must not overwrite each other's)."""
        server = scope.get("server") or (None, None)
        return f"twopose_console_{server[1] or 0}"

    def _refusal(self, scope: Scope, headers: Headers, cookie: str) -> tuple[int, str]:
        """(status, why) of a request refused on its headers alone; (0, "") if not."""
        hosts, origins = headers.getlist("host"), headers.getlist("origin")
        if len(hosts) > 1 or len(origins) > 1:  # judged by one copy, the other would pass
            return 403, "the console refuses a request that gives Host or Origin twice"
        host = headers.get("host", "")
        if not self._host_allowed(host):
            return 403, f"the console answers only its own address, not Host {host[:80]!r}"
        origin = headers.get("origin")
        if origin is not None and not _same_origin(origin, scope["scheme"], host):
            return 403, f"the console refuses requests from other pages ({origin[:80]!r})"
        path = scope["path"]
        if not path.startswith(PROTECTED):
            return 0, ""
        if headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
            return 403, "the console refuses requests from other sites"
        given = cookie_parser(headers.get("cookie", "")).get(cookie, "")
        if not secrets.compare_digest(given.encode(), self.token.encode()):
            return 403, "this page has no valid session token: reload the console's page"
        if scope["method"] in ("GET", "HEAD", "OPTIONS"):
            return 0, ""
        media = headers.get("content-type", "").split(";")[0].strip().lower()
        if media != "application/json":
            return 415, "send the request as Content-Type: application/json"
        length = headers.get("content-length")
        if length is not None and not (length.isascii() and length.isdigit()):
            return 400, "the request's Content-Length is not a number"
        if length is not None and int(length) > MAX_BODY_BYTES:
            return 413, f"the request is larger than {MAX_BODY_BYTES // 1024} KB"
        return 0, ""

    def _host_allowed(self, host: str) -> bool:
        if is_loopback_host(host):
            return True
        name = _normal_name(split_host(host)[0])
        if not name:
            return False
        if name == self.bound:
            return True
        if self.wildcard:  # --host 0.0.0.0: any address of this machine, never a name
            try:
                ipaddress.ip_address(name)
            except ValueError:
                return False
            return True
        return False

    async def _with_body(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Read the body (at most MAX_BODY_BYTES, counted as it arrives), check it, and
        hand it to the app as if it had not been read."""
        chunks: list[bytes] = []
        size = 0
        more = True
        while more:
            try:
                message = await asyncio.wait_for(receive(), BODY_TIMEOUT_S)
            except TimeoutError:
                slow = {"error": f"the request's body did not arrive within {BODY_TIMEOUT_S:g} s"}
                await ConsoleJSONResponse({**slow, "errors": {}}, 408)(scope, receive, send)
                return
            if message["type"] == "http.disconnect":
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > MAX_BODY_BYTES:
                refused = {"error": f"the request is larger than {MAX_BODY_BYTES // 1024} KB"}
                await ConsoleJSONResponse({**refused, "errors": {}}, 413)(scope, receive, send)
                return
            chunks.append(chunk)
            more = bool(message.get("more_body", False))
        body = b"".join(chunks)
        why, errors = body_refusal(body)
        if why:
            await ConsoleJSONResponse({"error": why, "errors": errors}, 400)(scope, receive, send)
            return
        delivered = False

        async def replay() -> Message:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)


def _normal_name(name: str) -> str:
    """A host name lowercased, an address in its one spelling (``0:0::1`` -> ``::1``)."""
    name = name.strip().lower()
    try:
        return str(ipaddress.ip_address(name))
    except ValueError:
        return name


def _same_origin(origin: str, scheme: str, host: str) -> bool:
    """Whether ``Origin`` is the console's own: its scheme, and the host and port the
    request was sent to (``Host``, already checked)."""
    default = {"http": 80, "https": 443}
    try:
        parts = urlsplit(origin.strip())
        port = parts.port
    except ValueError:
        return False
    if parts.scheme != scheme or not parts.hostname or parts.path or parts.query:
        return False
    name, host_port = split_host(host)
    own = (_normal_name(name), host_port or default.get(scheme))
    return (_normal_name(parts.hostname), port or default.get(scheme)) == own
