"""The documentation keeps up with the code: every module of the three packages has its
section in the API reference (docs/api/<package>.md), and the README's links resolve."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("package", ["twopose", "recorder", "analysis"])
def test_every_module_is_in_the_api_reference(package: str) -> None:
    page = (REPO / "docs" / "api" / f"{package}.md").read_text()
    modules = [
        ".".join(p.relative_to(REPO).with_suffix("").parts).removesuffix(".__init__")
        for p in sorted((REPO / package).rglob("*.py"))
        if p.name != "__main__.py"
    ]
    assert len(modules) > 10
    missing = [m for m in modules if f"::: {m}\n" not in page]
    assert not missing, f"add to docs/api/{package}.md: {missing}"


def test_the_readmes_links_point_at_files_that_exist() -> None:
    readme = (REPO / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", readme)
    assert len(targets) > 10
    missing = [t for t in targets if not t.startswith("http") and not (REPO / t).exists()]
    assert not missing, missing
