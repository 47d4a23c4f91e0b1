"""One rule for typed text a terminal will print.

One rule for text a person typed that a terminal will print: which characters are control
characters (C0, DEL, C1 and the bidirectional overrides, which a terminal obeys instead of
showing: an ESC sequence can clear the screen or retitle the window, U+202E reverses what
follows), and how to show them harmlessly (escaped, as Python writes them).

The web console refuses such text (:func:`recorder.console.guard.text_refusal`); a session
file may hold it anyway (typed at a terminal, or written by another tool), so everything
that prints a session's free text goes through :func:`for_terminal`.
"""

from __future__ import annotations

__all__ = ["BIDI_CONTROLS", "first_control", "for_terminal", "is_control"]

#: Bidirectional embedding, override and isolate characters (and the marks).
BIDI_CONTROLS = frozenset(
    "\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069"
)


def is_control(char: str) -> bool:
    """Whether a terminal would obey ``char`` rather than show it."""
    code = ord(char)
    return code < 0x20 or 0x7F <= code < 0xA0 or char in BIDI_CONTROLS


def first_control(text: str) -> str | None:
    """The first control character in ``text`` (None: there is none)."""
    return next((char for char in text if is_control(char)), None)


def for_terminal(text: str) -> str:
    r"""``text`` with every control character written as its escape.

    Escapes such as ``\x1b`` and ``\u202e``; everything else as it is (accents, CJK, emoji).
    """
    if first_control(text) is None:
        return text
    return "".join(
        char.encode("unicode_escape").decode("ascii") if is_control(char) else char for char in text
    )
