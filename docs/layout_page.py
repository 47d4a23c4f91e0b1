"""docs/layout.md's tables of the packages, drawn from the folders and their docstrings.

    .venv/bin/python docs/layout_page.py [--write-docs]

Per package, a row per folder (its face's docstring: the folder's role) and under it a row
per file: a module's docstring's first sentence, a script's or style sheet's first comment,
what a data file is. Without ``--write-docs`` it compares what it would write with the page
and exits 1 on a difference (``tests/test_layout_page.py`` runs it so: a file or folder
added, moved or described anew without the page rewritten fails the quick loop).
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from api_pages import first_sentence
from marked_table import write_or_check

REPO = Path(__file__).resolve().parents[1]
PACKAGES = {
    "twopose": "the core (imports neither side)",
    "recorder": "the operator's side (never imports `analysis`)",
    "analysis": "the analyst's side",
}
#: What a file that says nothing of itself is, by how its name ends.
DATA = {
    ".min.js": "a vendored script, minified (its licence and version beside it)",
    ".woff": "a font subset the pages carry",
    ".txt": "a licence",
    "VERSIONS": "the vendored scripts' versions",
    "LICENSE.": "a vendored script's licence",
    "py.typed": "the package's types are checked (PEP 561)",
}


def folders(package: str) -> list[Path]:
    """The package and every folder under it holding files, the package first."""
    root = REPO / package
    found = {p.parent for p in root.rglob("*") if p.is_file() and _shipped(p)}
    return sorted(found, key=lambda d: (d != root, d.relative_to(REPO).as_posix()))


def _shipped(path: Path) -> bool:
    return "__pycache__" not in path.parts and not path.name.endswith((".pyc", ".pyo"))


def _oneline(text: str) -> str:
    """One line of Markdown: reST's roles and double backticks as code, pipes escaped."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", " ".join(text.split()))
    return text.replace("``", "`").replace("|", "\\|")


def _docstring(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""


def role(folder: Path) -> str:
    """A folder's role: its face's docstring, its paragraphs joined (the first sentence of a
    data folder's files otherwise)."""
    init = folder / "__init__.py"
    if init.exists():
        doc = _docstring(init)
        return _oneline(" ".join(doc.split("\n\n")[:2]))
    return "data the package ships (no code)"


def describe(path: Path) -> str:
    """A file in a few words: a module's first sentence, a script's first comment."""
    name = path.name
    if name == "__init__.py":
        return "the folder's face: its role (above) and what it offers the rest (`__all__`)"
    if path.suffix == ".py":
        return _oneline(first_sentence(_docstring(path))) or "(no docstring)"
    for end, words in DATA.items():
        if name.endswith(end) or name.startswith(end):
            return words
    text = path.read_text(encoding="utf-8", errors="replace")
    match = re.match(r"\s*(?://(.*(?:\n//.*)*)|/\*(.*?)\*/|.*?<!--(.*?)-->)", text, re.S)
    if match:
        comment = next(g for g in match.groups() if g is not None)
        return _oneline(first_sentence(re.sub(r"^\s*//", "", comment, flags=re.M)))
    return {".html": "the page's markup", ".css": "the page's style"}.get(path.suffix, name)


def table() -> str:
    """The packages' tables: per package, its folders, each with its files."""
    out = []
    for package, words in PACKAGES.items():
        out.append(f"### `{package}/`: {words}\n\n| folder or file | role |\n| --- | --- |\n")
        for folder in folders(package):
            rel = folder.relative_to(REPO).as_posix()
            out.append(f"| **`{rel}/`** | {role(folder)} |\n")
            for f in sorted(p for p in folder.iterdir() if p.is_file() and _shipped(p)):
                out.append(f"| `{f.relative_to(REPO).as_posix()}` | {describe(f)} |\n")
        out.append("\n")
    return "".join(out)


def main() -> int:
    return write_or_check(REPO / "docs" / "layout.md", "packages' layout", table, "layout_page.py")


if __name__ == "__main__":
    raise SystemExit(main())
