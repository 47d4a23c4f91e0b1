"""The API reference's pages: one per public module of the three packages, each package with
an overview page listing its modules, each by its docstring's first sentence (whole), and the
site's nav to them.

    .venv/bin/python docs/api_pages.py [--write-docs]

Without ``--write-docs`` it only compares what it would write with the docs and exits 1 on
a difference (``tests/test_docs.py`` runs it so; a new module without its page fails the
quick loop). Every page renders its module with mkdocstrings from the docstrings.
"""

from __future__ import annotations

import ast
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
API = REPO / "docs" / "api"
MKDOCS = REPO / "mkdocs.yml"
NAV_START = "  - API:\n"  # the nav's last section: this script writes it to the file's end
PACKAGES = {
    "twopose": "The core: errors, camera model, detection, solvers, uncertainty, the method "
    "and unit registries, the session format and the simulator. It imports neither "
    "`recorder` nor `analysis`.",
    "recorder": "The operator's side: frame sources, the recording procedure (terminal, "
    "plans, the web console), camera calibration, recovery and simulated sessions.",
    "analysis": "The analyst's side: replay, tables, metrics, figures, the report, the CI "
    "gate, the rig's constants.",
}


def modules(package: str) -> list[str]:
    """The package's modules, dotted, the package itself first."""
    found = [
        ".".join(p.relative_to(REPO).with_suffix("").parts).removesuffix(".__init__")
        for p in sorted((REPO / package).rglob("*.py"))
        if p.name != "__main__.py"
    ]
    return sorted(found, key=lambda m: (m != package, m))


#: Words that end in a full stop without ending a sentence.
ABBREVIATIONS = ("e.g.", "i.e.", "etc.", "vs.", "cf.", "resp.", "approx.", "Fig.", "Eq.")


def first_sentence(doc: str) -> str:
    """The first sentence of a docstring, whole: its first paragraph up to the first ``.``,
    ``?`` or ``!`` outside brackets and backticks, not an abbreviation's, that ends the
    paragraph or is followed by a space and a capital, a backtick or a bracket (the whole
    paragraph when none does), its lines joined."""
    text = " ".join(line.strip() for line in doc.strip().split("\n\n")[0].splitlines())
    depth, code = 0, False
    for i, char in enumerate(text):
        if char == "`":
            code = not code
        elif code:
            continue
        elif char in "([":
            depth += 1
        elif char in ")]":
            depth = max(0, depth - 1)
        elif char in ".?!" and depth == 0 and text[i + 1 : i + 2] in ("", " "):
            after = text[i + 2 : i + 3]
            if text[: i + 1].rsplit(" ", 1)[-1] in ABBREVIATIONS:
                continue
            if not after or after.isupper() or after in "`([":
                return text[: i + 1]
    return text


def docstring(module: str) -> str:
    path = REPO / Path(*module.split("."))
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    return ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""


def summary(module: str) -> str:
    """The module's summary on its package's overview: its docstring's first sentence."""
    return first_sentence(docstring(module))


def module_page(module: str) -> str:
    return (
        f"# `{module}`\n\n::: {module}\n    options:\n      show_root_heading: false\n"
        "      heading_level: 2\n"
    )


def overview_page(package: str) -> str:
    rows = [f"- [`{m}`]({m}.md): {summary(m)}" for m in modules(package)]
    return f"# `{package}`\n\n{PACKAGES[package]}\n\n" + "\n".join(rows) + "\n"


def pages() -> dict[Path, str]:
    """Every page, by its path under ``docs/api``."""
    out: dict[Path, str] = {}
    for package in PACKAGES:
        out[Path(package) / "index.md"] = overview_page(package)
        for m in modules(package):
            out[Path(package) / f"{m}.md"] = module_page(m)
    return out


def nav() -> str:
    """The nav's API section: per package its overview, then its modules."""
    lines = [NAV_START]
    for package in PACKAGES:
        lines.append(f"      - {package}:\n")
        lines.append(f"          - Overview: api/{package}/index.md\n")
        lines += [f"          - {m}: api/{package}/{m}.md\n" for m in modules(package)]
    return "".join(lines)


def differences() -> list[str]:
    """What differs between the docs and what this script writes."""
    wanted = pages()
    have = {p.relative_to(API): p.read_text(encoding="utf-8") for p in API.rglob("*.md")}
    out = [f"docs/api/{p}: missing or stale" for p, t in wanted.items() if have.get(p) != t]
    out += [f"docs/api/{p}: no module of that name" for p in have if p not in wanted]
    config = MKDOCS.read_text(encoding="utf-8")
    if NAV_START not in config or config[config.index(NAV_START) :] != nav():
        out.append("mkdocs.yml: the API nav is stale")
    return out


def write() -> None:
    shutil.rmtree(API, ignore_errors=True)
    for path, text in pages().items():
        (API / path).parent.mkdir(parents=True, exist_ok=True)
        (API / path).write_text(text, encoding="utf-8")
    config = MKDOCS.read_text(encoding="utf-8")
    MKDOCS.write_text(config[: config.index(NAV_START)] + nav(), encoding="utf-8")


def main() -> int:
    if "--write-docs" in sys.argv[1:]:
        write()
    stale = differences()
    for line in stale:
        print(line)
    if stale:
        print("run: .venv/bin/python docs/api_pages.py --write-docs")
    return 1 if stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
