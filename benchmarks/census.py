"""The registry census (issues 35 and 45): where behaviour still dispatches on a name that
has a registry, instead of reading the registry.

    .venv/bin/python benchmarks/census.py [--list] [--write-docs]

Four kinds of name, each read from its registry (so a name added there is counted too):
methods (:data:`twopose.methods.METHODS`), units (:data:`twopose.units.UNITS`), targets
(:data:`twopose.choices.Target`) and frame sources (:data:`recorder.sources.SOURCE_KINDS`).
Counted over ``twopose/``, ``recorder/`` and ``analysis/``: the ``*.py`` modules by their
syntax trees, ``recorder/*.js`` by a tokenizer (comments dropped, string literals and the
tokens around them); the registries themselves (``twopose/methods.py``,
``twopose/units.py``, ``twopose/choices.py``, ``recorder/sources.py``) are exempt. A site is
one literal name, counted where a stranger counting by hand would count it, anywhere:

- a **comparison**: ``x == "in"`` (or ``x == Units.IN``: an enum member is its name),
  ``!=``, ``is``, ``"dot" in x``, a ``case "dot":`` label (Python's ``match`` or
  JavaScript's ``switch``), JavaScript's ``===``/``!==``;
- a **collection**: a tuple, list or set literal holding the name (``("in", "cm")``,
  ``x in ("line", "ground")``, ``Literal["point", "line"]``, a JavaScript array);
- a **dict key**: the keys of a table over names, a dict whose keys are all registered
  names (``{"dot": ...}``, ``{"point": f, "line": g}``; ``{dot: ...}`` in JavaScript,
  ``dict(dot=...)``).

Not counted, as not dispatch: a name passed as an argument or default, a record's field
that happens to be a name (``{"trial": 1, "point": [...]}``, a JSON object), a field read
by subscript (``row["camera"]``), message text. Also counted, as before: parameters named
``method`` typed ``str`` against those typed ``Method``, and ``units`` typed ``str``
against ``Units``.

``--list`` adds every site (``file:line``). Deterministic: ``tests/test_docs.py`` reruns it
and compares it with the docs' figure; ``tests/test_census.py`` asserts the sites are none.
"""

from __future__ import annotations

import ast
import re
import sys
import typing
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "census.txt"
REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")
#: The registries: where the names are declared, so exempt.
REGISTRIES = frozenset(
    {"twopose/methods.py", "twopose/units.py", "twopose/choices.py", "recorder/sources.py"}
)
#: What a site is.
CATEGORIES = ("comparison", "collection", "dict key")


def registered_names() -> dict[str, frozenset[str]]:
    """Each kind's names, read from its registry."""
    sys.path.insert(0, str(REPO))
    from recorder.sources import SOURCE_KINDS
    from twopose.choices import Target
    from twopose.methods import METHODS
    from twopose.units import UNITS

    return {
        "method": frozenset(str(m) for m in METHODS),
        "unit": frozenset(str(u) for u in UNITS),
        "target": frozenset(typing.get_args(Target)),
        "source": frozenset(k.name for k in SOURCE_KINDS),
    }


@dataclass(frozen=True, order=True)
class Site:
    """One literal name where a registry should be read."""

    path: str
    line: int
    kind: str
    category: str
    name: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.category} {self.name!r} ({self.kind})"


# --------------------------------------------------------------------------- Python


class _Kinds:
    """Which kind a literal is (None: no registered name)."""

    def __init__(self, names: Mapping[str, frozenset[str]]) -> None:
        self.by_name = {n: kind for kind, ns in names.items() for n in ns}

    def of(self, node: ast.AST | None) -> tuple[str, str] | None:
        """A name's literal, or a registry enum's member (``Method.GROUND``, ``Units.IN``)."""
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            kind = self.by_name.get(node.value)
            return (kind, node.value) if kind else None
        if isinstance(node, ast.Attribute) and ast.unparse(node.value).endswith(_ENUMS):
            name = node.attr.lower()
            kind = self.by_name.get(name)
            return (kind, name) if kind else None
        return None


#: The registries' enums, whose members are their names (``Method.POINT == "point"``).
_ENUMS = ("Method", "Units")


def python_sites(path: Path, rel: str, names: Mapping[str, frozenset[str]]) -> list[Site]:
    """The sites of one Python module."""
    kinds = _Kinds(names)
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: dict[int, Site] = {}  # by the literal's node, each counted once
    # Collections first: ``x in ("a", "b")`` is a collection, not also a comparison.
    for node in ast.walk(tree):
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            _add(found, kinds, rel, node.elts, "collection")
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            _add(found, kinds, rel, [node.left, *node.comparators], "comparison")
        elif isinstance(node, ast.MatchValue):
            _add(found, kinds, rel, [node.value], "comparison")
        elif isinstance(node, ast.Dict) and node.keys:  # a None key: ``**spread``, a record
            if all(kinds.of(k) for k in node.keys):  # a table over names, not a record
                _add(found, kinds, rel, node.keys, "dict key")
        elif isinstance(node, ast.Call) and ast.unparse(node.func) == "dict" and node.keywords:
            words = [ast.Constant(k.arg, lineno=k.lineno) for k in node.keywords if k.arg]
            if len(words) == len(node.keywords) and all(kinds.of(w) for w in words):
                _add(found, kinds, rel, words, "dict key")
    return sorted(found.values())


def _add(found: dict[int, Site], kinds: _Kinds, rel: str, nodes: list[Any], category: str) -> None:
    """Each of ``nodes`` that is a name, as a site (once, whatever else it is part of)."""
    for node in nodes:
        hit = kinds.of(node)
        if hit and id(node) not in found:
            found[id(node)] = Site(rel, getattr(node, "lineno", 0), hit[0], category, hit[1])


# --------------------------------------------------------------------------- JavaScript

_JS_TOKEN = re.compile(
    r"""(?P<comment>//[^\n]*|/\*.*?\*/)
      | (?P<string>"(?:[^"\\\n]|\\.)*"|'(?:[^'\\\n]|\\.)*'|`(?:[^`\\]|\\.)*`)
      | (?P<word>[A-Za-z_$][\w$]*)
      | (?P<number>\d[\w.]*)
      | (?P<op>===|!==|==|!=|=>|\?\.|\.\.\.|[^\s\w])""",
    re.S | re.X,
)
_COMPARE = {"===", "!==", "==", "!="}


def _js_tokens(text: str) -> Iterator[tuple[str, str, int]]:
    """(kind, text, line) of each token, comments dropped; a string's text unquoted.

    A template literal is one string token (its ``${...}`` parts are not looked into); a
    regular expression literal is not told from division, which is harmless here: its
    tokens hold no quoted name followed by a comparison.
    """
    for match in _JS_TOKEN.finditer(text):
        kind = match.lastgroup or ""
        if kind == "comment":
            continue
        value = match.group()
        line = text.count("\n", 0, match.start()) + 1
        if kind == "string":
            yield kind, value[1:-1], line
        else:
            yield kind, value, line


def js_sites(path: Path, rel: str, names: Mapping[str, frozenset[str]]) -> list[Site]:
    """The sites of one JavaScript file."""
    by_name = {n: kind for kind, ns in names.items() for n in ns}
    tokens = list(_js_tokens(path.read_text(encoding="utf-8")))
    sites: list[Site] = []
    brackets: list[str] = []  # "array", "index", "object", "block", "paren"
    keys: list[list[tuple[str, int]]] = []  # each open bracket's object keys: (key, line)
    for i, (kind, text, line) in enumerate(tokens):
        before = tokens[i - 1][1] if i else ""
        after = tokens[i + 1][1] if i + 1 < len(tokens) else ""
        if kind == "op" and text in "([{":
            brackets.append(_opened(text, tokens[i - 1] if i else ("", "", 0)))
            keys.append([])
        elif kind == "op" and text in ")]}" and brackets:
            closed, its_keys = brackets.pop(), keys.pop()
            if closed == "object" and its_keys and all(k in by_name for k, _ in its_keys):
                sites.extend(Site(rel, at, by_name[k], "dict key", k) for k, at in its_keys)
        elif brackets and brackets[-1] == "object" and before in ("{", ",") and after == ":":
            keys[-1].append((text, line))  # an object's key (a table over names or not)
        elif kind == "string" and text in by_name:
            category = _js_category(before, after, brackets[-1] if brackets else "")
            if category:
                sites.append(Site(rel, line, by_name[text], category, text))
    return sites


def _js_category(before: str, after: str, bracket: str) -> str:
    """What a quoted name is, by the tokens around it and the bracket it is in."""
    if before in _COMPARE or after in _COMPARE or before == "case" or after == "in":
        return "comparison"
    return "collection" if bracket == "array" else ""


def _opened(bracket: str, before: tuple[str, str, int]) -> str:
    """What a bracket opens, told by the token before it."""
    kind, text, _ = before
    if bracket == "(":
        return "paren"
    value_before = kind in ("word", "string", "number") and text not in _KEYWORDS
    if bracket == "[":
        return "index" if value_before or text in (")", "]") else "array"
    # ``{`` after a value, ``)`` or ``=>`` opens a block; after an operator, a value (object)
    if text in (")", "=>", ";", "{", "}", "else", "try", "finally", "do") or value_before:
        return "block"
    return "object"


_KEYWORDS = {"return", "case", "in", "of", "typeof", "new", "await", "yield", "throw"}


# --------------------------------------------------------------------------- the census


def sources() -> Iterator[tuple[Path, str]]:
    """The files counted (the registries excepted), in a fixed order."""
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            rel = path.relative_to(REPO).as_posix()
            if rel not in REGISTRIES:
                yield path, rel
    for path in sorted((REPO / "recorder").glob("*.js")):
        yield path, path.relative_to(REPO).as_posix()


def census_sites(names: Mapping[str, frozenset[str]] | None = None) -> list[Site]:
    """Every site in twopose/, recorder/ and analysis/ (Python) and recorder/*.js."""
    names = registered_names() if names is None else names
    found: list[Site] = []
    for path, rel in sources():
        scan = js_sites if rel.endswith(".js") else python_sites
        found.extend(scan(path, rel, names))
    return found


def typed_parameters(path: Path) -> Counter[str]:
    """``method``/``units`` parameters by their type, in one Python module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: Counter[str] = Counter()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            for arg in [*node.args.args, *node.args.kwonlyargs]:
                kind = _kind(arg)
                if kind:
                    found[f"{arg.arg}: {kind}"] += 1
    return found


def _annotation(arg: ast.arg) -> str:
    """The parameter's type (of ``Annotated[T, ...]``, ``T`` alone: its metadata is not)."""
    node = arg.annotation
    if isinstance(node, ast.Subscript) and ast.unparse(node.value).endswith("Annotated"):
        first = node.slice.elts[0] if isinstance(node.slice, ast.Tuple) else node.slice
        return ast.unparse(first)
    return ast.unparse(node) if node is not None else ""


#: A parameter's registry type: ``method`` is a Method, ``units`` a Units.
_TYPES = {"method": "Method", "units": "Units"}


def _kind(arg: ast.arg) -> str:
    """``Method``/``Units`` when ``arg`` is typed by its registry's type, ``str`` when by a
    string (or anything else), "" when it is not such a parameter (or another ``method``:
    a rule for combining frames)."""
    wanted = _TYPES.get(arg.arg)
    annotation = _annotation(arg)
    if wanted is None or not annotation or "CombineRule" in annotation:
        return ""
    return wanted if wanted in annotation and "str" not in annotation else "str"


def main() -> int:
    listing = "--list" in sys.argv[1:]
    names = registered_names()
    sites = census_sites(names)
    table: Counter[tuple[str, str, str]] = Counter()
    for site in sites:
        table[(site.kind, site.category, "js" if site.path.endswith(".js") else "py")] += 1
    print("sites (a registered name compared, collected or keyed outside its registry)")
    width = max(len(", ".join(sorted(n))) for n in names.values())
    print(f"{'kind':<8} {'names':<{width}} " + " ".join(f"{c:>12}" for c in CATEGORIES))
    for kind, kind_names in names.items():
        for lang in ("py", "js"):
            cells = " ".join(f"{table[(kind, c, lang)]:>12}" for c in CATEGORIES)
            label = ", ".join(sorted(kind_names)) if lang == "py" else "  (recorder/*.js)"
            print(f"{kind:<8} {label:<{width}} {cells}")
    print(f"total: {len(sites)}")
    print()
    params: Counter[str] = Counter()
    for path, rel in sources():
        if rel.endswith(".py"):
            params.update(typed_parameters(path))
    for key in sorted({f"{n}: {k}" for n, t in _TYPES.items() for k in (t, "str")} | {*params}):
        print(f"{key}: {params[key]}")
    by_file = Counter(site.path for site in sites)
    if by_file:
        print()
        for name, count in sorted(by_file.items()):
            print(f"{name}: {count}")
    if listing:
        print()
        for site in sites:
            print(site)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
