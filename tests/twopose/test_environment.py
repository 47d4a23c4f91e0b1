"""Every setting read from the environment is declared once (twopose.values.environment), and no
module reads the environment another way: so the analysis cache's key, which reads the
same list, knows every setting a result depends on."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from twopose.values.environment import ENVIRONMENT, EnvironmentSetting, results_environment

ROOT = Path(__file__).resolve().parents[2]
#: The one module that reads the environment for a setting.
DECLARED = Path("twopose/values/environment.py")
#: Reads that are not settings: (file, what), with why.
PASSED_ON = {
    # The figure drawer's child gets this process's environment whole (so it applies the
    # same settings), with this package first on its PYTHONPATH.
    (Path("analysis/report/figures/drawer.py"), "environ"): 2,
}


def _reads(tree: ast.AST) -> list[str]:
    """Every ``os.environ``, ``os.getenv``, ``os.putenv`` (and their bare names) in a tree."""
    names = {"environ", "getenv", "environb", "getenvb", "putenv", "unsetenv"}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in names:
            found.append(node.attr)
        elif isinstance(node, ast.Name) and node.id in names:
            found.append(node.id)
        elif isinstance(node, ast.ImportFrom) and node.module == "os":
            found += [a.name for a in node.names if a.name in names]
    return found


def test_no_module_reads_the_environment_but_through_its_declaration() -> None:
    counted: dict[tuple[Path, str], int] = {}
    for package in ("twopose", "recorder", "analysis"):
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT)
            if rel == DECLARED:
                continue
            for what in _reads(ast.parse(path.read_text(encoding="utf-8"))):
                counted[(rel, what)] = counted.get((rel, what), 0) + 1
    assert counted == PASSED_ON, (
        "read the environment only through twopose.values.environment (declare the setting there: "
        f"then the analysis cache keys on it): {counted}"
    )


def test_the_scan_sees_a_read() -> None:
    """The scan above is not blind: each way of reading the environment is seen."""
    for code in (
        "import os\nos.environ.get('X')",
        "import os\nos.getenv('X')",
        "from os import environ\nenviron['X']",
        "from os import getenv",
    ):
        assert _reads(ast.parse(code)), code


@pytest.mark.parametrize("setting", ENVIRONMENT, ids=lambda s: s.name)
def test_each_setting_reads_its_value_and_keeps_its_default_on_a_typo(
    setting: EnvironmentSetting, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(setting.name, raising=False)
    assert setting.read() == setting.default
    monkeypatch.setenv(setting.name, setting.example)
    assert setting.read() != setting.default
    if setting.numeric:
        assert setting.read() == float(setting.example)
        monkeypatch.setenv(setting.name, "many")  # a typo keeps the default, as unset
        assert setting.read() == setting.default
    else:
        monkeypatch.setenv(setting.name, "")
        assert setting.read() is None


def test_the_results_environment_is_every_setting_a_result_depends_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    shaping = [s for s in ENVIRONMENT if s.shapes_results]
    assert {s.name for s in shaping} == {"TWOPOSE_MAX_IMAGE_MPIX", "TWOPOSE_MAX_CHUNK_MB"}
    for s in ENVIRONMENT:
        monkeypatch.delenv(s.name, raising=False)
    before = results_environment()
    for s in shaping:
        monkeypatch.setenv(s.name, s.example)
        assert results_environment() != before
        monkeypatch.delenv(s.name)
    for s in ENVIRONMENT:
        if not s.shapes_results:
            monkeypatch.setenv(s.name, s.example)
    assert results_environment() == before


def test_the_docs_table_is_the_declared_list() -> None:
    """docs/bad-input.md lists every setting from the declaration (run
    ``.venv/bin/python docs/environment_table.py --write-docs`` after changing it)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "environment_table.py")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    page = (ROOT / "docs" / "bad-input.md").read_text(encoding="utf-8")
    assert all(f"| `{s.name}` |" in page for s in ENVIRONMENT)
