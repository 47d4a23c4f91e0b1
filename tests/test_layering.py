"""The layering the README promises, checked on the source: core <- recorder, core <- analysis.

Every import counts, including those inside functions (lazy ones). For the direction of
the layers, imports under ``if TYPE_CHECKING:`` count too (a type from the other side is a
dependency all the same), and for cycles too (two modules that need each other's types
are one concern split in two).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _runtime_imports(
    tree: ast.AST, module: str, is_package: bool, *, type_checking_too: bool = False
) -> set[str]:
    """Modules imported when the code runs (absolute names, relative ones resolved), and
    with ``type_checking_too`` those imported for the type checker alone."""
    found: set[str] = set()
    type_checking: set[int] = set()
    for node in ast.walk(tree):
        if type_checking_too:
            break
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            type_checking |= {id(n) for child in node.body for n in ast.walk(child)}
    for node in ast.walk(tree):
        if id(node) in type_checking:
            continue
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = module.split(".")[: len(module.split(".")) - node.level + is_package]
                base = ".".join([*parent, base] if base else parent)
            found.add(base)
            found |= {f"{base}.{alias.name}" for alias in node.names}
    return found


def _graph(*, type_checking_too: bool = False) -> dict[str, set[str]]:
    files = [p for pkg in PACKAGES for p in (REPO / pkg).rglob("*.py")]
    modules = {_module_name(p): p for p in files}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        is_package = path.stem == "__init__"
        imports = _runtime_imports(tree, name, is_package, type_checking_too=type_checking_too)
        graph[name] = {m for m in imports if m in modules and m != name}
    return graph


def test_the_graph_covers_every_package() -> None:
    graph = _graph()
    for pkg in PACKAGES:
        assert any(m.startswith(pkg + ".") for m in graph), pkg
    assert len(graph) > 30


@pytest.mark.parametrize(
    ("package", "forbidden"),
    [
        ("twopose", ("recorder", "analysis")),
        ("recorder", ("analysis",)),
        ("analysis", ("recorder",)),
    ],
)
def test_dependencies_point_one_way(package: str, forbidden: tuple[str, ...]) -> None:
    graph = _graph(type_checking_too=True)
    offending = sorted(
        f"{m} imports {dep}"
        for m, deps in graph.items()
        if m == package or m.startswith(package + ".")
        for dep in deps
        if dep.split(".")[0] in forbidden
    )
    assert not offending, offending


def test_the_simulator_stands_on_the_core_and_nothing_in_the_core_needs_it() -> None:
    """Inside the core, ``twopose.sim`` is a layer on top: the camera model, solvers and the
    session format never import the simulator (a measurement must not depend on how a scene
    is rendered); the simulator imports only the core."""
    graph = _graph(type_checking_too=True)
    sim = [m for m in graph if m.startswith("twopose.sim")]
    assert {
        "twopose.sim.camera",
        "twopose.sim.layout",
        "twopose.sim.render",
        "twopose.sim.scene",
    } <= set(sim)
    offending = sorted(
        f"{m} imports {dep}"
        for m, deps in graph.items()
        if m.startswith("twopose") and not m.startswith("twopose.sim")
        for dep in deps
        if dep.startswith("twopose.sim")
    )
    assert not offending, offending
    outside = sorted(
        f"{m} imports {d}" for m in sim for d in graph[m] if d.split(".")[0] != "twopose"
    )
    assert not outside, outside


def test_no_import_cycles() -> None:
    """None, not even through an import for the type checker alone (a type from a module
    that imports this one ties the two as surely)."""
    graph = _graph(type_checking_too=True)
    # A package's __init__ re-exporting its own modules is not a cycle between modules.
    edges = {
        m: {d for d in deps if not m.startswith(d + ".") and not d.startswith(m + ".")}
        for m, deps in graph.items()
    }
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for d in sorted(edges.get(m, ())):
            if state.get(d) == 1:
                cycle = [*stack[stack.index(d) :], d]
                raise AssertionError(f"import cycle: {' -> '.join(cycle)}")
            if d not in state:
                visit(d)
        stack.pop()
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m)
    assert len(state) == len(edges)


def test_cycle_detection_sees_lazy_imports(tmp_path: Path) -> None:
    """The import finder counts an import inside a function, and skips TYPE_CHECKING."""
    code = (
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    import analysis.report.writer\n"
        "def f():\n    from analysis.batch import runner\n"
    )
    found = _runtime_imports(ast.parse(code), "analysis.results", False)
    assert "analysis.batch.runner" in found
    assert "analysis.report.writer" not in found
    both = _runtime_imports(ast.parse(code), "analysis.results", False, type_checking_too=True)
    assert "analysis.report.writer" in both  # the layers' direction counts it


def test_solvers_and_camera_load_no_io_stack() -> None:
    """Importing the solvers, uncertainty and camera model loads no mcap, pandas or plots."""
    code = (
        "import sys, twopose.solve.nview, twopose.camera.model, twopose.uncertainty.propagate, "
        "twopose.detect.detection; "
        "print(' '.join(m for m in ('mcap', 'pandas', 'matplotlib', 'jsonschema', "
        "'analysis', 'recorder') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO
    )
    assert out.stdout.strip() == ""


@pytest.mark.parametrize("module", ["analysis.cli", "recorder.cli.app"])
def test_command_lines_import_light(module: str) -> None:
    """`--help` needs typer only: no mcap, pandas, matplotlib or OpenCV at import."""
    code = (
        f"import sys, {module}; "
        "print(' '.join(m for m in ('mcap', 'pandas', 'matplotlib', 'cv2', 'numpy') "
        "if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO
    )
    assert out.stdout.strip() == ""
