"""The size rules, checked (issue 45): every module of the three packages, and the console's
scripts, at most 600 lines; every Python function at most 120 lines, its decorators and
signature included. A file over the rule is split by concern, not allowed here, unless it
is on the commented allowlist below while its split is under way.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 120

#: Files allowed over the module rule for now, each with why (a comment beside it, e.g.
#: ``"recorder/x.js",  # split by concern: issue N, in progress``). Nothing else is.
ALLOWED_LONG: set[str] = set()


def _lines(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def _modules() -> list[Path]:
    found = [p for package in PACKAGES for p in sorted((REPO / package).rglob("*.py"))]
    return found + sorted((REPO / "recorder").rglob("*.js"))


def _functions(path: Path) -> list[tuple[str, int]]:
    """Every function's name (dotted by its classes and functions) and its length in lines,
    from its first decorator to its last line."""
    out: list[tuple[str, int]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                start = min([child.lineno] + [d.lineno for d in child.decorator_list])
                end = child.end_lineno if child.end_lineno is not None else child.lineno
                out.append((f"{prefix}{child.name}", end - start + 1))
                visit(child, f"{prefix}{child.name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return out


def test_the_checks_see_the_packages_and_the_scripts() -> None:
    names = {p.relative_to(REPO).as_posix() for p in _modules()}
    assert {
        "recorder/cli/app.py",
        "twopose/detect/detection.py",
        "analysis/batch/runner.py",
    } <= names
    assert {"recorder/console/page/main.js", "recorder/console/page/topview.js"} <= names
    assert names >= ALLOWED_LONG, "an allowlisted file is gone: take it off the list"


def test_no_module_is_over_600_lines() -> None:
    long = {
        p.relative_to(REPO).as_posix(): n for p in _modules() if (n := _lines(p)) > MAX_MODULE_LINES
    }
    over = {name: n for name, n in long.items() if name not in ALLOWED_LONG}
    assert not over, f"split these by concern (at most {MAX_MODULE_LINES} lines): {over}"


#: A module this close to the rule (within 10% of it) says why in its docstring.
NEAR_MODULE_LINES = int(0.9 * MAX_MODULE_LINES)


def test_a_module_near_the_rule_says_why_it_stays_whole() -> None:
    """A module pressed against the check was cut where a count fell, not where a concern
    ends (issue 57): within 10% of it, its docstring says why it is one module
    ("Near 600 lines: ...")."""
    silent = [
        f"{p.relative_to(REPO).as_posix()} ({n} lines)"
        for p in _modules()
        if p.suffix == ".py" and (n := _lines(p)) > NEAR_MODULE_LINES
        if "Near 600 lines" not in (ast.get_docstring(ast.parse(p.read_text("utf-8"))) or "")
    ]
    assert not silent, (
        f"within 10% of {MAX_MODULE_LINES} lines: cut these by concern or say why each is "
        f"one ('Near 600 lines: ...' in its docstring): {silent}"
    )


def test_no_function_is_over_120_lines() -> None:
    over = {
        f"{p.relative_to(REPO).as_posix()}:{name}": n
        for p in _modules()
        if p.suffix == ".py"
        for name, n in _functions(p)
        if n > MAX_FUNCTION_LINES
    }
    assert not over, f"at most {MAX_FUNCTION_LINES} lines, signature included: {over}"


def test_the_function_rule_counts_decorators_and_signature(tmp_path: Path) -> None:
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES - 3))
    source = f"@decorated\ndef f(\n    a: int,\n) -> None:\n{body}\n"
    path = tmp_path / "m.py"
    path.write_text(source, encoding="utf-8")
    assert _functions(path) == [("f", MAX_FUNCTION_LINES + 1)]
