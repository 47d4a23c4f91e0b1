"""twopose.values.text: which characters a terminal obeys, and how they are shown instead."""

from __future__ import annotations

import re

from hypothesis import given
from hypothesis import strategies as st

from twopose.values.text import BIDI_CONTROLS, first_control, for_terminal, is_control

CONTROLS = [chr(c) for c in [*range(0x20), *range(0x7F, 0xA0)]] + sorted(BIDI_CONTROLS)


def test_every_control_character_is_one_and_nothing_printable_is() -> None:
    assert all(is_control(c) for c in CONTROLS)
    assert len(CONTROLS) == 32 + 33 + 12
    for char in "aZ09 ~é北😀\u00a0\u200b":
        assert not is_control(char), repr(char)


def test_escapes_are_what_python_writes() -> None:
    assert for_terminal("a\x1b[2Jb") == "a\\x1b[2Jb"
    assert for_terminal("\r\n\t\x07") == "\\r\\n\\t\\x07"
    assert for_terminal("x\u202ey") == "x\\u202ey"
    assert for_terminal("Zoë 北京") == "Zoë 北京"


@given(st.text())
def test_what_is_shown_holds_no_control_and_keeps_the_rest_in_order(text: str) -> None:
    shown = for_terminal(text)
    assert first_control(shown) is None
    assert (shown == text) == (first_control(text) is None)
    if "\\" not in text:  # then every backslash in what is shown starts an escape
        kept = "".join(c for c in text if not is_control(c))
        assert re.sub(r"\\(x[0-9a-f]{2}|u[0-9a-f]{4}|[rnt])", "", shown) == kept
