"""docs/layout.md is drawn from the folders: every folder and file of the packages is on it,
with its role, and the page is what docs/layout_page.py writes now."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")


def _script():
    spec = importlib.util.spec_from_file_location("layout_page", REPO / "docs" / "layout_page.py")
    assert spec
    assert spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_layout_page_is_current() -> None:
    done = subprocess.run(
        [sys.executable, str(REPO / "docs" / "layout_page.py")],
        capture_output=True, text=True, check=False, cwd=REPO,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr


def test_every_folder_and_file_is_on_the_page_with_its_role() -> None:
    page = (REPO / "docs" / "layout.md").read_text(encoding="utf-8")
    missing = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*")):
            if "__pycache__" in path.parts or path.suffix in (".pyc", ".pyo"):
                continue
            rel = path.relative_to(REPO).as_posix()
            if path.is_dir() and any(p.is_file() for p in path.iterdir()):
                if f"| **`{rel}/`** |" not in page:
                    missing.append(rel + "/")
            elif path.is_file() and f"| `{rel}` |" not in page:
                missing.append(rel)
    assert not missing, "not on docs/layout.md: " + ", ".join(missing)


def test_each_folder_says_its_role_and_what_it_offers() -> None:
    """Every folder of code has a face: a docstring of its role (on the page) and __all__."""
    import ast

    layout = _script()
    page = (REPO / "docs" / "layout.md").read_text(encoding="utf-8")
    for package in PACKAGES:
        for folder in layout.folders(package):
            if not any(folder.glob("*.py")):
                continue
            init = folder / "__init__.py"
            assert init.exists(), f"{folder}: no face"
            tree = ast.parse(init.read_text(encoding="utf-8"))
            assert ast.get_docstring(tree), f"{init}: no docstring of its role"
            if folder.name not in ("rig", "sim", "pair"):
                names = [
                    t.id
                    for node in tree.body
                    if isinstance(node, ast.Assign | ast.AnnAssign)
                    for t in (node.targets if isinstance(node, ast.Assign) else [node.target])
                    if isinstance(t, ast.Name)
                ]
                assert "__all__" in names, f"{init}: no __all__"
            assert layout.role(folder) in page


def test_a_stale_page_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A file's row gone from the page (or a role said anew in the code): the check sees it."""
    layout = _script()
    monkeypatch.setitem(layout.write_or_check.__globals__, "REPO", tmp_path)
    page = (REPO / "docs" / "layout.md").read_text(encoding="utf-8")
    row = next(line for line in page.splitlines(keepends=True) if line.startswith("| `recorder/"))
    stale = tmp_path / "layout.md"
    stale.write_text(page.replace(row, "", 1), encoding="utf-8")
    assert layout.write_or_check(stale, "packages' layout", layout.table, "layout_page.py") == 1
    stale.write_text(page, encoding="utf-8")
    assert layout.write_or_check(stale, "packages' layout", layout.table, "layout_page.py") == 0
