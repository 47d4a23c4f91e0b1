"""The documentation keeps up with the code: every module of the three packages has its
page in the API reference (docs/api/<package>/<module>.md) and a whole sentence on its
package's overview, docs/layout.md names every file of the packages and every script, every
command's Python call documents its parameters, no docstring says its summary twice, and the
README's links resolve."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def test_the_api_reference_has_a_page_per_module_and_is_current() -> None:
    """docs/api_pages.py writes one page per module and the nav; a new module
    without its page, or a page of a module gone, fails here."""
    done = subprocess.run(
        [sys.executable, str(REPO / "docs" / "api_pages.py")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    pages = list((REPO / "docs" / "api").rglob("*.md"))
    assert len(pages) > 80  # one per module, and an overview per package
    assert max(p.stat().st_size for p in pages) < 20_000


def _overview_rows() -> list[tuple[str, str]]:
    """Each package overview's (module, summary) rows (docs/api/<package>/index.md)."""
    rows = []
    for package in ("twopose", "recorder", "analysis"):
        page = (REPO / "docs" / "api" / package / "index.md").read_text(encoding="utf-8")
        rows += re.findall(r"^- \[`([\w.]+)`\]\([\w.]+\.md\): (.*)$", page, re.M)
    return rows


def test_the_api_overviews_summaries_are_whole_sentences() -> None:
    """Each module's summary on its package's overview is its docstring's first sentence,
    whole: it ends a sentence (``.``, ``?``, ``!``, possibly inside a closing bracket or
    quote), its brackets and backticks close, and the first paragraph goes on, if at all,
    with a new sentence, never mid-sentence (as a first line cut at its line break did)."""
    import ast

    rows = _overview_rows()
    assert len(rows) > 80
    cut = []
    for module, summary in rows:
        path = REPO / Path(*module.split("."))
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
        text = " ".join(doc.split("\n\n")[0].split())  # the first paragraph's lines joined
        rest = text.removeprefix(summary)
        whole = (
            re.search(r"[.?!][)\]\"'`]*$", summary)
            and summary.count("(") == summary.count(")")
            and summary.count("`") % 2 == 0
            and text.startswith(summary)
            and (not rest or re.match(r" [A-Z`(\[]", rest))
        )
        if not whole:
            cut.append(f"{module}: {summary!r}")
    assert not cut, "not a whole sentence:\n" + "\n".join(cut)


def _package_files() -> list[str]:
    """Every file of the packages (Python, JavaScript, CSS, HTML) and the scripts beside
    them (benchmarks/, docs/, sessions/, .ci/run), as paths from the repository's root."""
    found = [
        p
        for package in ("twopose", "recorder", "analysis")
        for p in (REPO / package).rglob("*")
        if p.suffix in {".py", ".js", ".css", ".html"} and "__pycache__" not in p.parts
    ]
    for folder in ("benchmarks", "docs", "sessions"):
        found += (REPO / folder).glob("*.py")
    found.append(REPO / ".ci" / "run")
    return sorted(str(p.relative_to(REPO).as_posix()) for p in found)


def test_the_layout_names_every_file_of_the_packages() -> None:
    """docs/layout.md names every module, script, style sheet and page: a file added (or a
    module split in two) without its line in the layout fails here."""
    layout = (REPO / "docs" / "layout.md").read_text(encoding="utf-8")
    files = _package_files()
    assert len(files) > 150
    assert "recorder/console/page/main.js" in files
    unnamed = [f for f in files if f"`{f}`" not in layout]
    assert not unnamed, "not named in docs/layout.md: " + ", ".join(unnamed)


#: The Python call of every command (``Everything the CLI does is one call from Python``).
ENTRY_POINTS = [
    "analysis.batch.runner:run",
    "analysis.session.pipeline:analyse_session",
    "analysis.report.figures.draw:make_figures",
    "analysis.gate.baseline:check",
    "analysis.gate.comparison:compare",
    "analysis.rig.calibrate:calibrate_rig",
    "analysis.tools.sensitivity:sensitivity",
    "analysis.tools.solve_request:solve_request",
    "recorder.simulate.one_camera:simulate_session",
    "recorder.setup.plan:load_plan",
    "recorder.setup.plan:record_plan",
    "recorder.recover:recover_session",
    "recorder.calibration.camera:calibrate",
    "recorder.calibration.pair:calibrate_pair",
    "recorder.calibration.pair:calibrate_pair_views",
    "twopose.pair.calibration:fit_pair",
    "twopose.pair.stream:estimate_stream",
    "twopose.detect.detection:detect",
    "twopose.solve.session:estimate_session",
]


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_every_entry_point_documents_its_parameters(entry: str) -> None:
    """numpydoc sections: every parameter named under Parameters, and what it returns."""
    import importlib
    import inspect

    module, name = entry.split(":")
    function = getattr(importlib.import_module(module), name)
    doc = inspect.getdoc(function) or ""
    assert "Parameters\n----------" in doc, entry
    assert "Returns\n-------" in doc, entry
    documented = doc.split("Parameters\n----------")[1]
    for parameter in inspect.signature(function).parameters:
        assert re.search(rf"^{parameter}\b|, {parameter}\b", documented, re.M), (entry, parameter)


def _repeated_summaries() -> list[str]:
    import ast

    found = []
    for package in ("twopose", "recorder", "analysis"):
        for path in sorted((REPO / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if not isinstance(node, ast.FunctionDef | ast.ClassDef | ast.Module):
                    continue
                paragraphs = (ast.get_docstring(node) or "").split("\n\n")
                if len(paragraphs) < 2:
                    continue
                summary, description = paragraphs[0].split(), paragraphs[1].split()
                if len(summary) >= 3 and summary[:4] == description[:4]:
                    found.append(f"{path.relative_to(REPO)}:{getattr(node, 'name', '')}")
    return found


def test_no_docstring_repeats_its_summary_line() -> None:
    assert not _repeated_summaries()


def test_the_readmes_links_point_at_files_that_exist() -> None:
    readme = (REPO / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", readme)
    assert len(targets) > 10
    missing = [t for t in targets if not t.startswith("http") and not (REPO / t).exists()]
    assert not missing, missing


@pytest.mark.parametrize(
    ("script", "figure", "page"),
    [
        ("merton_check.py", "merton_check.md", "real-data.md"),
        ("two_camera.py", "two_camera.txt", "real-data.md"),
        ("thesis_reproduced.py", "thesis_reproduced.txt", "sample-sessions.md"),
        ("command_help.py", "command_help.txt", "commands.md"),
        ("census.py", "census.txt", "layout.md"),
    ],
)
def test_the_docs_deterministic_figures_are_what_their_scripts_print(
    script: str, figure: str, page: str
) -> None:
    """The docs include docs/figures/<figure>, written by ``<script> --write-docs``: the
    deterministic scripts (real data, the bundled sessions) are rerun here and must print
    it exactly."""
    printed = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / script)],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    ).stdout
    assert printed.strip(), script
    assert printed == (REPO / "docs" / "figures" / figure).read_text(encoding="utf-8")
    assert f'--8<-- "figures/{figure}"' in (REPO / "docs" / page).read_text()


def _figure_of(script: Path) -> str:
    """The figure a benchmark records (its ``FIGURE``, under docs/figures/)."""
    found = re.search(r'^FIGURE = "([^"]+)"$', script.read_text(), re.M)
    assert found, f"{script.name} has no FIGURE"
    return found.group(1)


def test_every_benchmark_writes_the_figure_a_docs_page_includes() -> None:
    """No pasted benchmark output: each script records its figure (``--write-docs``), the file
    is there, and exactly one page includes it next to the command that made it."""
    scripts = sorted(p for p in (REPO / "benchmarks").glob("*.py") if p.stem != "doc_figures")
    assert len(scripts) >= 20
    pages = {p.name: p.read_text() for p in (REPO / "docs").glob("*.md")}
    for script in scripts:
        assert "raise SystemExit(run_recorded(" in script.read_text(), script.name
        figure = _figure_of(script)
        assert (REPO / "docs" / "figures" / figure).is_file(), f"run {script.name} --write-docs"
        including = [
            name
            for name, text in pages.items()
            if f'--8<-- "figures/{figure}"' in text and f"benchmarks/{script.name}" in text
        ]
        assert len(including) == 1, (script.name, including)


def test_the_readmes_figures_are_lines_of_their_benchmarks_figures() -> None:
    """Each output block of the README that follows a ``benchmarks/<script>.py`` command is
    an excerpt of the figure that script last wrote (docs/figures/<its FIGURE>), line for
    line: a rerun that changes a figure fails here until the README says the same."""
    readme = (REPO / "README.md").read_text()
    pairs = re.findall(
        r"```bash\n[^`]*?benchmarks/(\w+)\.py[^`]*?```\n\n```\n(.*?)```", readme, re.S
    )
    assert len(pairs) >= 3, "the README's benchmark excerpts"
    for script, block in pairs:
        figure = _figure_of(REPO / "benchmarks" / f"{script}.py")
        printed = (REPO / "docs" / "figures" / figure).read_text().splitlines()
        lines = [line for line in block.splitlines() if line.strip()]
        assert lines, script
        stale = [line for line in lines if line not in printed]
        assert not stale, f"{script}: not in docs/figures/{figure}: {stale}"


def test_the_docs_screenshots_are_the_browser_tests_and_the_pages_show_them() -> None:
    """Every image in docs/images is one a browser test writes and checks
    (tests/doc_images.py), and the home, recording and analysis pages each show one."""
    images = {p.name for p in (REPO / "docs" / "images").glob("*.png")}
    tests = "".join(p.read_text() for p in (REPO / "tests").rglob("test_*browser*.py"))
    tests += (REPO / "tests" / "recorder" / "test_console_layout.py").read_text()
    assert images
    assert all(f'"{name}"' in tests for name in images), images
    for page in ("index.md", "recording.md", "analysis.md"):
        text = (REPO / "docs" / page).read_text()
        assert re.search(r"!\[[^\]]+\]\(images/[\w-]+\.png\)", text), page
    shown = "".join(p.read_text() for p in (REPO / "docs").glob("*.md"))
    assert all(f"images/{name}" in shown for name in images)


def test_a_marked_table_is_refused_when_stale_and_written_with_write_docs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/marked_table.py, the one --write-docs mechanism of the docs' generated tables."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("marked_table", REPO / "docs" / "marked_table.py")
    assert spec is not None
    assert spec.loader is not None
    marked = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(marked)
    monkeypatch.setattr(marked, "REPO", tmp_path)
    page = tmp_path / "page.md"
    begin, end = "<!-- t: written by docs/s.py --write-docs -->\n", "<!-- end of the t -->\n"
    page.write_text(f"before\n{begin}old\n{end}after\n", "utf-8")
    monkeypatch.setattr(sys, "argv", ["s.py"])
    assert marked.write_or_check(page, "t", lambda: "new\n", "s.py") == 1
    assert "page.md: its t are not the code's; run: " in capsys.readouterr().out
    assert "old" in page.read_text("utf-8")  # a check writes nothing
    monkeypatch.setattr(sys, "argv", ["s.py", "--write-docs"])
    assert marked.write_or_check(page, "t", lambda: "new\n", "s.py") == 0
    assert page.read_text("utf-8") == f"before\n{begin}new\n{end}after\n"
    monkeypatch.setattr(sys, "argv", ["s.py"])
    assert marked.write_or_check(page, "t", lambda: "new\n", "s.py") == 0
