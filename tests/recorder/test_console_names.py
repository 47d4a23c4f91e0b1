"""The console's scripts name no method, unit, target or source (issue 45): what differs by
method reaches the page from the method registry (:class:`twopose.methods.specs.MethodPage`, the
state's ``page``), so a string literal in ``recorder/*.js`` equal to a registered name is a
rule that belongs on a registry."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.console.state import ConsoleSession
from recorder.sources.registry import SOURCE_KINDS
from twopose.methods.specs import METHOD_SPECS, METHODS, Method, MethodPage
from twopose.values.choices import TARGETS
from twopose.values.units import UNITS

SCRIPTS = sorted((Path(__file__).resolve().parents[2] / "recorder").rglob("*.js"))

#: Every name a registry holds: methods, units, targets, sources.
NAMES = frozenset(
    [str(m) for m in METHODS]
    + [str(u) for u in UNITS]
    + [str(t) for t in TARGETS]
    + [k.name for k in SOURCE_KINDS]
)

#: A ``/`` after one of these (or at the start) begins a regular expression, not a division.
_BEFORE_REGEX = set("(,=:[!&|?{};+-*%<>~^")


def _comment_end(source: str, i: int) -> int:
    """Where the comment at ``i`` ends (``i`` itself when none starts there)."""
    if source.startswith("//", i):
        end = source.find("\n", i)
        return len(source) if end < 0 else end
    if source.startswith("/*", i):
        end = source.find("*/", i + 2)
        return len(source) if end < 0 else end + 2
    return i


def _regex_end(source: str, i: int) -> int:
    """Where the regular expression literal starting at ``i`` ends (after its flags' /)."""
    j, in_class = i + 1, False
    while j < len(source) and (in_class or source[j] != "/") and source[j] != "\n":
        if source[j] == "\\":
            j += 1
        elif source[j] in "[]":
            in_class = source[j] == "["
        j += 1
    return j + 1


def _string_end(source: str, i: int) -> int:
    """Where the string literal starting at ``i`` ends (after its closing quote)."""
    j = i + 1
    while j < len(source) and source[j] != source[i]:
        j += 2 if source[j] == "\\" else 1
    return j + 1


def string_literals(source: str) -> list[tuple[int, str]]:
    """Every string literal of a script (its line and its text, escapes as written):
    quoted, and template literals without ``${...}``; comments and regular expressions are
    skipped."""
    found: list[tuple[int, str]] = []
    i, last = 0, ""
    while i < len(source):
        c = source[i]
        if (end := _comment_end(source, i)) > i:
            i = end
        elif c == "/" and (not last or last in _BEFORE_REGEX):
            i, last = _regex_end(source, i), "regex"
        elif c in "'\"`":
            end = _string_end(source, i)
            text = source[i + 1 : end - 1]
            if c != "`" or "${" not in text:
                found.append((source.count("\n", 0, i) + 1, text))
            i, last = end, "string"
        else:
            last = last if c.isspace() else c
            i += 1
    return found


def test_the_literal_reader_finds_strings_and_skips_comments_and_regexes() -> None:
    script = (
        '// "point" in a comment\nconst a = "line"; /* "ground" */\n'
        "const b = x.replace(/^line \"/, '');\nconst c = `board`, d = `${e} in`;\n"
        "const f = y / 2 / 3, g = 'in';\n"
    )
    assert string_literals(script) == [(2, "line"), (3, ""), (4, "board"), (5, "in")]


def test_the_names_come_from_the_registries() -> None:
    assert {"point", "line", "ground", "board", "in", "mm", "dot", "glove", "camera"} <= NAMES


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_no_script_names_a_method_unit_target_or_source(script: Path) -> None:
    named = [
        f"{script.name}:{line}: {text!r}"
        for line, text in string_literals(script.read_text(encoding="utf-8"))
        if text in NAMES
    ]
    assert not named, "what differs by these belongs on a registry: " + "; ".join(named)


def test_the_scripts_are_found() -> None:
    assert {p.name for p in SCRIPTS} >= {"main.js", "topview.js"}


@pytest.mark.parametrize("method", METHODS)
def test_the_state_carries_the_methods_page_from_its_spec(method: Method, tmp_path: Path) -> None:
    """The page's panels and words are the spec's (the board's: the rig, not the trials)."""
    session = ConsoleSession(tmp_path / "s.mcap")
    assert session.snapshot()["page"] == MethodPage().to_json()  # before the setup
    session.update(method=method)
    page = session.snapshot()["page"]
    assert page == METHOD_SPECS[method].page.to_json()
    assert page["reports_rig"] == (not METHOD_SPECS[method].measures)


def test_a_board_sessions_page_says_the_board() -> None:
    page = METHOD_SPECS[Method.BOARD].page
    assert (page.sought, page.objects_header) == ("the board", "the board")
    assert not page.detection_columns
    assert [kind for kind, _, _ in page.legend_segments] == ["corners"]
    assert METHOD_SPECS[Method.GROUND].page.estimate_label == "ground point (estimate)"
    assert METHOD_SPECS[Method.LINE].page.estimate_label == "line's point (estimate)"
    assert METHOD_SPECS[Method.POINT].page.estimate_label == "estimate"


def test_every_legend_kind_is_one_the_top_view_draws() -> None:
    """The legend's segment kinds are those twopose.methods.topview draws (and none a method's
    name)."""
    from twopose.methods.topview import SEGMENT_KINDS

    for spec in METHOD_SPECS.values():
        for kind, _, _ in spec.page.legend_segments:
            assert kind in SEGMENT_KINDS, kind
            assert kind not in NAMES
