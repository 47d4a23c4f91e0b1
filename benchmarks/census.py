"""The registry census (issue 35): where behaviour still dispatches on a method's or a unit's
name instead of the registry (:mod:`twopose.methods`, :mod:`twopose.units`).

    .venv/bin/python benchmarks/census.py [--write-docs]

Counted over ``twopose/``, ``recorder/`` and ``analysis/`` by their syntax trees (the
registries themselves, ``twopose/methods.py`` and ``twopose/units.py``, excepted):

- comparisons of a value with a method's name (``== "point"``, ``!= "line"``, ``in
  ("line", "ground")``): target at most 6;
- dicts keyed by two methods' names or more (a dispatch table, not a JSON field that
  happens to be called ``point``): target 0;
- parameters named ``method`` typed ``str`` against those typed ``Method``, and ``units``
  typed ``str`` against ``Units``.

Deterministic: ``tests/test_docs.py`` reruns it and compares it with the docs' figure.
"""

from __future__ import annotations

import ast
from collections import Counter
from pathlib import Path

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "census.txt"
REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")
REGISTRIES = {"twopose/methods.py", "twopose/units.py"}
NAMES = {"point", "line", "ground", "board"}


def _is_name(node: ast.AST) -> bool:
    return isinstance(node, ast.Constant) and node.value in NAMES


def _names(node: ast.AST) -> bool:
    """A literal method name, or a tuple, list or set of them."""
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return bool(node.elts) and all(_is_name(e) for e in node.elts)
    return _is_name(node)


def _annotation(arg: ast.arg) -> str:
    """The parameter's type (of ``Annotated[T, ...]``, ``T`` alone: its metadata is not)."""
    node = arg.annotation
    if isinstance(node, ast.Subscript) and ast.unparse(node.value).endswith("Annotated"):
        first = node.slice.elts[0] if isinstance(node.slice, ast.Tuple) else node.slice
        return ast.unparse(first)
    return ast.unparse(node) if node is not None else ""


def census(path: Path) -> Counter[str]:
    """The counts of one module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: Counter[str] = Counter()
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            parts = [node.left, *node.comparators]
            if any(_names(p) for p in parts):
                found["comparisons with a method's name"] += 1
        elif isinstance(node, ast.Dict):
            keys = [k for k in node.keys if k is not None]  # a table over two methods or more
            if len(keys) >= 2 and all(_is_name(k) for k in keys):
                found["dicts keyed by methods' names"] += 1
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            for arg in [*node.args.args, *node.args.kwonlyargs]:
                kind = _kind(arg)
                if kind:
                    found[f"{arg.arg}: {kind}"] += 1
    return found


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
    totals: Counter[str] = Counter()
    by_file: dict[str, Counter[str]] = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            name = path.relative_to(REPO).as_posix()
            if name in REGISTRIES:
                continue
            counts = census(path)
            if counts:
                by_file[name] = counts
                totals.update(counts)
    keys = {
        "comparisons with a method's name",
        "dicts keyed by methods' names",
        *(f"{name}: {kind}" for name, typed in _TYPES.items() for kind in (typed, "str")),
        *totals,
    }
    for key in sorted(keys):
        print(f"{key}: {totals[key]}")
    print()
    for name, counts in by_file.items():
        shown = {k: v for k, v in counts.items() if not k.endswith((": Method", ": Units"))}
        if shown:
            print(f"{name}: " + ", ".join(f"{k} {v}" for k, v in sorted(shown.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
