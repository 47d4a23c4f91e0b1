"""Each package's public face, and the API reference showing every public name.

``twopose``, ``recorder`` and ``analysis`` export what a notebook or another program uses,
loaded on first use; every name in a package's ``__all__`` resolves to the object its
module defines. Every name in any module's ``__all__`` is on that module's API page: the
page renders the module with the handler's options (none that filter members), the options
keep undocumented names and names not starting with ``_``, and Griffe (what mkdocstrings
reads) sees the name in the module. The registries and their fields carry their ``#:``
documentation into the pages (``docs/griffe_comments.py``).
"""

from __future__ import annotations

import ast
import importlib
import re
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")
#: The only options a module's page may set: none of them selects or filters members.
PAGE_OPTIONS = {"show_root_heading", "heading_level"}


def _exports(path: Path) -> list[str] | None:
    """The module's ``__all__`` as written (a list or tuple of strings), or None."""
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            targets, value = [node.target], node.value
        else:
            continue
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
            return list(ast.literal_eval(value))
    return None


def _modules() -> dict[str, tuple[Path, list[str]]]:
    """Every module of the three packages that has ``__all__``, by its dotted name."""
    found = {}
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            if path.name == "__main__.py":
                continue
            names = _exports(path)
            if names is None:
                continue
            dotted = ".".join(path.relative_to(REPO).with_suffix("").parts)
            found[dotted.removesuffix(".__init__")] = (path, names)
    return found


def _handler_options() -> str:
    """The python handler's options in mkdocs.yml, as text."""
    config = (REPO / "mkdocs.yml").read_text(encoding="utf-8")
    return config[config.index("        python:\n") : config.index("\nvalidation:")]


def _extension_module() -> ModuleType:
    """docs/griffe_comments.py, the extension mkdocs.yml loads."""
    sys.path.insert(0, str(REPO / "docs"))
    try:
        return importlib.import_module("griffe_comments")
    finally:
        sys.path.remove(str(REPO / "docs"))


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_resolves_to_its_module_object(package: str) -> None:
    """``package.name`` is the object its home module defines, for every name in
    ``__all__``; ``dir(package)`` lists them."""
    module = importlib.import_module(package)
    assert len(module.__all__) >= 9, package
    assert len(set(module.__all__)) == len(module.__all__), package
    homes = getattr(module, "_HOMES", {})
    for name in module.__all__:
        value = getattr(module, name)
        if name in homes:
            assert value is getattr(importlib.import_module(homes[name]), name), name
        assert name in dir(module), name
    submodules = {p.stem for p in (REPO / package).iterdir() if p.suffix == ".py" or p.is_dir()}
    # an imported submodule becomes the package's attribute and would hide a lazy export
    assert not submodules & set(module.__all__), submodules & set(module.__all__)


def test_the_packages_one_call_functions_are_exported() -> None:
    """What the commands run and a notebook reaches for, from the package itself."""
    import analysis
    import recorder
    import twopose

    wanted = {
        twopose: {"Camera", "Intrinsics", "Method", "MethodSpec", "METHOD_SPECS", "METHODS",
                  "spec_of", "Units", "UNIT_SPECS", "TwoposeError", "InputValueError",
                  "SessionReader", "SessionWriter", "find_sessions", "Detection",
                  "triangulate_points", "triangulate_lines", "triangulate_ground",
                  "estimate_session", "Guidance", "ConstraintPlane", "GROUND_PLANE",
                  "CONSTRAINT_PLANES", "TARGET_SPECS", "TargetSpec", "register_method",
                  "register_target", "register_plane", "load_extensions"},
        recorder: {"simulate_session", "load_plan", "record_plan", "record_interactive",
                   "recover_session", "calibrate", "open_source", "SOURCE_KINDS", "SOURCES",
                   "register_source"},
        analysis: {"run", "analyse_session", "make_figures", "check", "compare"},
    }  # fmt: skip
    for package, names in wanted.items():
        assert names <= set(package.__all__), (package.__name__, names - set(package.__all__))


def test_importing_the_packages_stays_light() -> None:
    """The exports load on first use: importing the packages loads no NumPy or OpenCV."""
    code = (
        "import sys, twopose, recorder, analysis; "
        "print(' '.join(m for m in ('numpy', 'cv2', 'mcap', 'pandas', 'matplotlib') "
        "if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO
    )
    assert out.stdout.strip() == ""


def test_the_handler_options_keep_every_public_name() -> None:
    """Undocumented names show, ``#:`` comments are read, and no filter drops a name
    that does not start with ``_``."""
    options = _handler_options()
    assert "show_if_no_docstring: true" in options
    assert "- docs/griffe_comments.py:CommentDocstrings" in options
    assert "members:" not in options
    filters = re.findall(r'"([^"]+)"', re.search(r"filters: \[(.*)\]", options)[1])  # type: ignore[index]
    for name in ("METHOD_SPECS", "spec_of", "MethodSpec", "run"):
        for pattern in filters:
            if pattern.startswith("!"):
                assert not re.search(pattern[1:], name), (pattern, name)
            else:
                assert re.search(pattern, name), (pattern, name)


def test_every_public_name_is_on_its_api_page() -> None:
    """Each module with ``__all__`` has its page, rendering the module with no option that
    selects members, and Griffe finds each exported name in it (defined there, or imported,
    for the type checker too, which the page renders as the name's own entry)."""
    griffe = pytest.importorskip("griffe")
    CommentDocstrings = _extension_module().CommentDocstrings
    extensions = griffe.Extensions(CommentDocstrings())
    loaded = {p: griffe.load(p, search_paths=[str(REPO)], extensions=extensions) for p in PACKAGES}
    problems = []
    modules = _modules()
    assert len(modules) > 80
    for dotted, (_, names) in modules.items():
        package = dotted.split(".")[0]
        page = REPO / "docs" / "api" / package / f"{dotted}.md"
        if not page.exists():
            problems.append(f"{dotted}: no page (docs/api_pages.py --write-docs)")
            continue
        text = page.read_text(encoding="utf-8")
        if f"::: {dotted}\n" not in text:
            problems.append(f"{dotted}: its page does not render it")
        options = set(re.findall(r"^      (\w+):", text, re.M))
        if not options <= PAGE_OPTIONS:
            problems.append(f"{dotted}: its page sets {sorted(options - PAGE_OPTIONS)}")
        module = loaded[package]
        for part in dotted.split(".")[1:]:
            module = module.members[part]
        for name in names:
            if name.startswith("__") and name.endswith("__"):
                continue  # __version__: the filters leave dunders out; it is a string
            if name not in module.members:
                problems.append(f"{dotted}.{name}: not seen by Griffe")
    assert not problems, "\n".join(problems)


def test_the_registries_and_their_fields_are_documented() -> None:
    """The method and unit registries, and every field of their specs, carry a docstring
    (their ``#:`` comments, read by docs/griffe_comments.py) into the pages."""
    griffe = pytest.importorskip("griffe")
    CommentDocstrings = _extension_module().CommentDocstrings
    core = griffe.load(
        "twopose",
        search_paths=[str(REPO)],
        extensions=griffe.Extensions(CommentDocstrings()),
    )
    undocumented = []
    for module, registry, spec in (("methods.specs", "METHOD_SPECS", "MethodSpec"),
                                   ("values.units", "UNIT_SPECS", "UnitSpec")):  # fmt: skip
        for name in (registry, spec):
            if not core[f"{module}.{name}"].docstring:
                undocumented.append(f"{module}.{name}")
        for name, member in core[f"{module}.{spec}"].members.items():
            if member.is_attribute and not name.startswith("_") and not member.docstring:
                undocumented.append(f"{module}.{spec}.{name}")
    assert not undocumented, undocumented


def test_comment_docs_are_read_above_and_beside_an_assignment() -> None:
    comment_doc = _extension_module().comment_doc
    lines = ["x = 1", "#: first", "#: second", "y = 2", "z = 3  #: beside", "w = 4  # plain"]
    assert comment_doc(lines, 4) == "first\nsecond"
    assert comment_doc(lines, 5) == "beside"
    assert comment_doc(lines, 6) is None
    assert comment_doc(lines, 1) is None
