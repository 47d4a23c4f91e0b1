"""A Griffe extension for the API reference: an attribute's ``#:`` comments are its docstring.

The code documents module constants and dataclass fields the Sphinx way, with ``#:`` lines
just above the assignment (or one after it on the same line)::

    #: What the detector looks for in each frame.
    target: Target | None

Griffe reads only a string literal under the attribute; this extension gives every
attribute that has none the text of its ``#:`` comments, so the registries and their fields
show in the pages. ``mkdocs.yml`` loads it (the python handler's ``extensions``), and
``tests/test_public_api.py`` loads it to check what the pages show.
"""

from __future__ import annotations

import ast
from typing import Any

import griffe


def comment_doc(lines: list[str], lineno: int) -> str | None:
    """The ``#:`` comment over line ``lineno`` (1-based), or after it on that line."""
    above: list[str] = []
    index = lineno - 2
    while index >= 0 and lines[index].lstrip().startswith("#:"):
        above.insert(0, lines[index].lstrip()[2:].strip())
        index -= 1
    if above:
        return "\n".join(above)
    line = lines[lineno - 1] if 0 < lineno <= len(lines) else ""
    if "#:" in line:
        return line.split("#:", 1)[1].strip() or None
    return None


class CommentDocstrings(griffe.Extension):
    """Sets an attribute's docstring from its ``#:`` comments when it has no docstring."""

    def on_attribute_instance(
        self,
        *,
        node: ast.AST | griffe.ObjectNode,
        attr: griffe.Attribute,
        agent: griffe.Visitor | griffe.Inspector,
        **kwargs: Any,
    ) -> None:
        del node, kwargs  # griffe passes them; the comments are read from the source
        if attr.docstring is not None or not isinstance(agent, griffe.Visitor):
            return
        if attr.lineno is None:
            return
        text = comment_doc(agent.code.splitlines(), attr.lineno)
        if text:
            attr.docstring = griffe.Docstring(text, lineno=attr.lineno, parent=attr)
