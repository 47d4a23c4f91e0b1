"""The one loopback rule (recorder/console/loopback.py), and that the console, the live view and
its guard all use it."""

from __future__ import annotations

import pytest

from recorder.console.loopback import host_name, is_loopback_host, split_host

LOOPBACK = (
    "localhost",
    "LOCALHOST",
    "LocalHost:8080",
    "127.0.0.1",
    "127.0.0.1:8765",
    "127.255.3.4:1",
    " 127.0.0.1 ",
    "::1",
    "[::1]",
    "[::1]:8765",
    "[0:0:0:0:0:0:0:1]:80",
    "::ffff:127.0.0.1",
    "[::ffff:127.0.0.1]:80",
)
FOREIGN = (
    "",
    "evil.example",
    "rebind.evil.example:8765",
    "localhost.evil.example",
    "127.0.0.1.nip.io",
    "foo.localhost",
    "localhost.",
    "0.0.0.0",
    "[::]:80",
    "192.168.1.2",
    "::ffff:192.168.1.2",
    "128.0.0.1",
    "127.1",
    "0x7f000001",
    "2130706433",
    "127.0.0.1:99999",
    "127.0.0.1:abc",
    "127.0.0.1:",
    "localhost:\uff18\uff10",  # fullwidth digits are not a port
    "[::1",
    "::1]",
    "[::1]x",
    "[127.0.0.1]",
    ":8765",
)


@pytest.mark.parametrize("host", LOOPBACK)
def test_loopback_hosts(host: str) -> None:
    assert is_loopback_host(host)


@pytest.mark.parametrize("host", FOREIGN)
def test_foreign_or_malformed_hosts(host: str) -> None:
    assert not is_loopback_host(host)


def test_host_names_and_ports() -> None:
    assert split_host("LOCALHOST:8080") == ("localhost", 8080)
    assert split_host("[::1]:80") == ("::1", 80)
    assert split_host("[::1]") == ("::1", None)
    assert split_host("::1") == ("::1", None)
    assert split_host("evil.example") == ("evil.example", None)
    assert split_host("a:b:c]") == ("", None)
    assert host_name("127.0.0.1:65536") == ""


def test_one_rule_everywhere() -> None:
    """The live view, its guard and the console's guard hold no copy of their own."""
    import recorder.console.guard
    import recorder.console.server
    import recorder.live.guard
    import recorder.live.view

    users = (
        recorder.live.view,
        recorder.live.guard,
        recorder.console.server,
        recorder.console.guard,
    )
    for module in users:
        assert vars(module)["is_loopback_host"] is is_loopback_host, module.__name__
    for module in (recorder.live.view, recorder.live.guard, recorder.console.server):
        assert "ipaddress" not in vars(module), module.__name__
