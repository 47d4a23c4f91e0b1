"""Operators' names as they are matched: spaces around them aside, case folded (issue 54).

An operator names themselves in a session's entry (``--operator``), a rig file's
``[placing]`` lists the board's operators, and the recorder keeps a noise file per
operator. ``"Ada"``, ``" ada"`` and ``"ADA"`` are one person: matched case-sensitively,
they were three operators, so a board was not applied to two of them and none of their
sessions pooled (a second new user's r5 F2b). Each name is still shown as typed.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["operator_key", "operators_of", "spelled_apart"]


def operator_key(operator: str) -> str:
    """Who an operator's name is, to match it: spaces around it aside and case folded."""
    return operator.strip().casefold()


def operators_of(names: Iterable[str]) -> tuple[str, ...]:
    """The operators ``names`` name, once each in order, as first typed (unnamed left out)."""
    out: dict[str, str] = {}
    for name in names:
        if name.strip():
            out.setdefault(operator_key(name), name.strip())
    return tuple(out.values())


def spelled_apart(names: Iterable[str]) -> list[tuple[str, ...]]:
    """Each operator ``names`` spells in more than one way: the spellings, first typed first."""
    spelled: dict[str, dict[str, None]] = {}
    for name in names:
        if name.strip():
            spelled.setdefault(operator_key(name), {})[name.strip()] = None
    return [tuple(s) for s in spelled.values() if len(s) > 1]
