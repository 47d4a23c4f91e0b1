"""The one loopback rule: which host names and addresses are the operator's own machine.

The web console (``recorder/console/guard.py``), the live view (``recorder/live/view.py``) and
its handshake guard (``recorder/live/guard.py``) all ask this module, so they cannot
disagree. Loopback is ``localhost`` (any case), an IPv4 address in 127.0.0.0/8, ``::1``,
or an IPv4-mapped IPv6 address of either (``::ffff:127.0.0.1``). Anything else, including
``*.localhost``, names that merely resolve to loopback, ``0.0.0.0`` and malformed text, is
not: a DNS-rebinding page reaches loopback under a name of its own choosing, so only the
names above are trusted.
"""

from __future__ import annotations

import ipaddress

__all__ = [
    "host_name",
    "is_loopback_host",
    "is_loopback_name",
    "split_host",
]


def split_host(host: str) -> tuple[str, int | None]:
    """The name (lowercased) and the port of an HTTP ``Host`` header or a host.

    The name or address and the port of an HTTP ``Host`` header or a bare host, the name
    lowercased and without brackets: ``"LOCALHOST:8080"`` -> ``("localhost", 8080)``,
    ``"[::1]"`` -> ``("::1", None)``, ``"::1"`` -> ``("::1", None)``. ``("", None)`` when
    the text is malformed (a bad port, a stray bracket).
    """
    host = host.strip().lower()
    if host.startswith("["):
        end = host.find("]")
        rest = host[end + 1 :] if end > 0 and ":" in host[1:end] else "!"  # [IPv6] only
        if not rest:
            return host[1:end], None
        if rest.startswith(":") and _is_port(rest[1:]):
            return host[1:end], int(rest[1:])
        return "", None
    if host.count(":") == 1:  # name:port (more colons: a bare IPv6 address)
        name, port = host.split(":")
        return (name, int(port)) if _is_port(port) and name else ("", None)
    return ("", None) if "]" in host else (host, None)


def host_name(host: str) -> str:
    """The name or address of a ``Host`` header (:func:`split_host`), empty if malformed."""
    return split_host(host)[0]


def _is_port(text: str) -> bool:
    return text.isascii() and text.isdigit() and len(text) <= 5 and int(text) <= 65535


def is_loopback_name(name: str) -> bool:
    """Whether a bare name or address (no port, no brackets) is loopback."""
    name = name.strip().lower()
    if name == "localhost":
        return True
    try:
        address = ipaddress.ip_address(name)
    except ValueError:
        return False
    if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped is not None:
        return address.ipv4_mapped.is_loopback
    return address.is_loopback


def is_loopback_host(host: str) -> bool:
    """Whether a ``Host`` header or a bare name or address is loopback.

    Whether an HTTP ``Host`` header (``name[:port]``, ``[v6][:port]``) or a bare name or
    address is loopback (see the module docstring).
    """
    name = host_name(host)
    return bool(name) and is_loopback_name(name)
