"""The extension points (issue 57 item 4), used in-process as a stranger would use them.

Each ``register_*`` (method, target, source, plane) is called from outside the packages
and what it registered is then found by every stage that reads its registry; each
snippet of docs/development.md ("Adding a method / a target / a source / a column") runs
as written and passes ruff; the docs' lists of methods and sources are the registries'
(docs/registry_lists.py); an installed extension (an entry point) is loaded with the
registries, and one that fails is said. Every registration is taken out again when its
test ends (``Registry.unregister``).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import re
import subprocess
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
import typer

from analysis.results import AnalysisOptions
from analysis.tools.solve_request import solve_request
from recorder.sources.registry import SOURCES, kind_of, open_source, source_help
from tests.helpers import install_extension
from twopose import registry
from twopose.detect.detection import detect
from twopose.methods.planes import CONSTRAINT_PLANES, GROUND_PLANE, register_plane
from twopose.methods.specs import (
    MEASURING_METHODS,
    METHOD_SPECS,
    METHODS,
    PLANES,
    Method,
    Solver,
    register_method,
)
from twopose.solve.entries import RAYS, SolverEntry
from twopose.values.choices import TARGET_SPECS, Target
from twopose.values.options import registered

REPO = Path(__file__).resolve().parents[1]
DEVELOPMENT = REPO / "docs" / "development.md"


def snippet(name: str) -> str:
    """The Python block of docs/development.md marked ``<!-- snippet: name -->``, as written."""
    text = DEVELOPMENT.read_text(encoding="utf-8")
    found = re.search(rf"<!-- snippet: {name} -->\n```python\n(.*?)```\n", text, re.S)
    assert found, f"docs/development.md has no snippet {name!r}"
    return found.group(1)


@pytest.fixture
def registered_here() -> Iterator[None]:
    """Whatever a test registers is taken out when it ends (the registries as before)."""
    before = [(r, list(r)) for r in (METHOD_SPECS, TARGET_SPECS, SOURCES, CONSTRAINT_PLANES)]
    yield
    for r, names in before:
        for name in [n for n in r if n not in names]:
            r.unregister(name)


def run_snippet(name: str) -> dict[str, Any]:
    """Run docs/development.md's snippet ``name`` as a module would; its namespace."""
    module = ModuleType(f"snippet_{name}")
    sys.modules[module.__name__] = module  # as an imported module is (dataclasses reads it)
    try:
        exec(compile(snippet(name), f"docs/development.md:{name}", "exec"), module.__dict__)
    finally:
        del sys.modules[module.__name__]
    return module.__dict__


@pytest.mark.parametrize("name", ["wall", "target", "source", "column"])
def test_each_snippet_pastes_clean(name: str, tmp_path: Path) -> None:
    """As pasted into a file of its own: ruff finds nothing and would not reformat it
    (the wall's raised NameError, ``dataclasses`` not imported, and failed ruff)."""
    path = tmp_path / f"{name}_ext.py"
    path.write_text(snippet(name), encoding="utf-8")
    ruff = str(Path(sys.executable).parent / "ruff")
    config = ["--config", str(REPO / "pyproject.toml")]
    for args in (["check", "--no-cache", "--isolated"], ["format", "--check", "--no-cache"]):
        done = subprocess.run(
            [ruff, *args, *([] if "--isolated" in args else config), str(path)],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stdout + done.stderr


def _two_views(
    px: list[list[float]], theta_deg: tuple[float, float] = (60.0, 120.0)
) -> dict[str, Any]:
    """A solve request of two views, the camera moved 1 along x, each seeing ``px``."""
    camera = {"K": [525, 525, 320, 240]}
    return {
        "views": [
            {**camera, "pose": {"t": [0, 0, 0]}, "line": {"px": px[0], "theta_deg": theta_deg[0]}},
            {**camera, "pose": {"t": [1, 0, 0]}, "line": {"px": px[1], "theta_deg": theta_deg[1]}},
        ]
    }


@pytest.mark.usefixtures("registered_here")
def test_the_wall_snippet_registers_a_method_and_its_plane() -> None:
    """The wall method and its plane, from the docs as written: listed, a choice of the
    command lines, and ``solve wall`` cuts the planes' line with the wall ``x = c``."""
    ns = run_snippet("wall")
    wall = Method("wall")
    assert wall is ns["WALL"]
    assert wall.spec.plane is ns["WALL_PLANE"] is CONSTRAINT_PLANES["wall_x"]
    assert list(METHODS)[-1] == wall
    assert wall in MEASURING_METHODS
    assert ns["WALL_PLANE"] in PLANES
    assert registered(METHOD_SPECS)["parser"]("wall") is wall
    # a finger whose line meets the wall at (9.625, 0.5, 20), in front of both cameras
    request = _two_views([[572.66, 253.12], [546.41, 253.12]], (136.74, 139.9))
    answer = solve_request(wall, request | {"wall_x": 9.625})
    assert answer["status"] == "ok"
    assert answer["point"] == pytest.approx([9.625, 0.5, 20.0], abs=1e-3)  # on the wall
    with pytest.raises(ValueError, match="already registered"):
        run_snippet("wall")  # the name is taken


def _dot_image(colour: tuple[int, int, int], at: tuple[int, int]) -> np.ndarray:
    import cv2

    image = np.full((120, 160, 3), 230, dtype=np.uint8)
    cv2.circle(image, at, 6, colour, -1)
    return image


@pytest.mark.usefixtures("registered_here")
def test_the_target_snippet_registers_a_detector_and_its_thresholds() -> None:
    """The red dot, from the docs: detected by name and by entry, its thresholds read from
    a run's options by their type, a choice of ``detect --target``."""
    ns = run_snippet("target")
    red, params = ns["RED"], ns["RedParams"]
    assert Target("red").spec is red is TARGET_SPECS[Target("red")]
    image = _dot_image((0, 0, 255), (100, 40))  # BGR: red
    found = detect(image, "red")
    assert found.found
    assert found.centroid_px == pytest.approx((100.0, 40.0), abs=0.5)
    assert not detect(_dot_image((255, 0, 0), (100, 40)), red).found  # a blue dot is not
    strict = params(min_red=256)  # no pixel is that red
    assert AnalysisOptions(thresholds=(strict,)).thresholds_for(red) is strict
    assert AnalysisOptions().thresholds_for(red) == params()  # its defaults
    assert not detect(image, red, strict).found
    assert registered(TARGET_SPECS)["parser"]("red") == "red"


@pytest.mark.usefixtures("registered_here")
def test_a_methods_target_is_registered_with_it() -> None:
    """A method on a target of its own registers the target too (``detect --target`` then
    lists it); a second target under a taken name is refused, and nothing is registered."""
    ns = run_snippet("target")
    TARGET_SPECS.unregister("red")  # as if the method brought its target itself
    point = METHOD_SPECS[Method.POINT]
    red_point = dataclasses.replace(point, method=Method.declare("red_point"), target=ns["RED"])
    register_method(red_point)
    assert TARGET_SPECS[Target("red")] is ns["RED"]
    other = dataclasses.replace(ns["RED"], image_line=True)
    clash = dataclasses.replace(point, method=Method.declare("red_line"), target=other)
    with pytest.raises(ValueError, match="another target is registered as 'red'"):
        register_method(clash)
    assert "red_line" not in METHOD_SPECS


@pytest.mark.usefixtures("registered_here")
def test_the_source_snippet_registers_a_kind_of_source() -> None:
    """The grey source, from the docs: opened by its spelling, listed in ``--help`` and
    in the docs' list (which is then stale until rewritten)."""
    run_snippet("source")
    assert kind_of("grey:7").name == "grey"
    with open_source("grey:7", width=64, height=48) as source:
        frame = source.read()
    assert frame.shape == (48, 64, 3)
    assert (frame == 7).all()
    assert "grey[:LEVEL]" in source_help()
    assert "grey[:LEVEL]" not in source_help(calibration=True)  # it does not calibrate
    lists = _registry_lists()
    assert "`grey[:LEVEL]`" in lists.sources_table()


def test_the_column_snippet_declares_and_checks_a_column() -> None:
    run_snippet("column")  # its asserts: a good table passes, a negative length is named


def _registry_lists() -> ModuleType:
    sys.path.insert(0, str(REPO / "docs"))
    try:
        spec = importlib.util.spec_from_file_location(
            "registry_lists", REPO / "docs" / "registry_lists.py"
        )
        assert spec is not None
        assert spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(REPO / "docs"))
    return module


def test_the_docs_lists_of_methods_and_sources_are_the_registries() -> None:
    """docs/registry_lists.py finds docs/method.md's and docs/recording.md's lists current
    (``--write-docs`` rewrites them); the recording page no longer lists them by hand."""
    done = subprocess.run(
        [sys.executable, str(REPO / "docs" / "registry_lists.py")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    lists = _registry_lists()
    method_md = (REPO / "docs" / "method.md").read_text(encoding="utf-8")
    assert lists.methods_table() in method_md
    for name in METHODS:
        assert f"| `{name}` |" in method_md


@pytest.mark.usefixtures("registered_here")
def test_a_method_with_a_solver_of_its_own_is_solved_by_it_everywhere(tmp_path: Path) -> None:
    """A registered method whose solver is its own (the rays', counted): ``simulate`` and
    ``run`` estimate with it, and ``solve`` answers with it (``solve`` died with a
    KeyError on such a method: its answers were a second table keyed by hand)."""
    from analysis import run
    from recorder.simulate.one_camera import simulate_session

    calls: list[str] = []

    def counted(name: str, fn: Any) -> Any:
        def call(*args: Any) -> Any:
            calls.append(name)
            return fn(*args)

        return call

    entry = SolverEntry(
        solve=counted("solve", RAYS.solve),
        thesis=counted("thesis", RAYS.thesis),
        misclosure=RAYS.misclosure,
        answer=counted("answer", RAYS.answer),
    )
    own = Solver(words="the rays, counted (a test's)", load=lambda: entry)
    method = Method.declare("counted")
    registry_method = dataclasses.replace(
        METHOD_SPECS[Method.POINT], method=method, solver=own, label="counted", colour="C6"
    )
    from twopose.methods.specs import register_method

    assert register_method(registry_method) is method
    session = tmp_path / "counted.mcap"
    simulate_session(session, method=method, trials=2, frames=1, seed=3)
    result = run([session], jobs=1)
    assert list(result.trials["method"]) == ["counted", "counted"]
    assert (result.trials["status"] == "ok").all()
    assert {"solve", "thesis"} <= set(calls)
    request = {
        "views": [
            {"K": [525, 525, 320, 240], "pose": {"t": [0, 0, 0]}, "px": [346.25, 318.75]},
            {"K": [525, 525, 320, 240], "pose": {"t": [1, 0, 0]}, "px": [293.75, 318.75]},
        ]
    }
    calls.clear()
    answer = solve_request(method, request)
    assert calls == ["answer"]
    assert answer["point"] == pytest.approx([0.5, 1.5, 10.0], abs=1e-9)


@pytest.mark.usefixtures("registered_here")
def test_a_plane_is_registered_once_under_its_key() -> None:
    wall = dataclasses.replace(
        GROUND_PLANE, name="the wall", normal_grid=(1.0, 0.0, 0.0),
        in_plane_grid=((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), setup_key="wall_x",
        equation="x = c", axis="x", request_key=None,
    )  # fmt: skip
    assert register_plane(wall) is wall
    assert CONSTRAINT_PLANES["wall_x"] is wall
    assert register_plane(dataclasses.replace(wall)) is wall  # the same plane: the one held
    assert list(PLANES) == [GROUND_PLANE, wall]
    with pytest.raises(ValueError, match="already registered"):
        register_plane(dataclasses.replace(wall, name="another wall"))  # its key taken
    with pytest.raises(ValueError, match="orthogonal"):
        dataclasses.replace(wall, in_plane_grid=((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)))


def test_an_unknown_name_is_refused_listing_the_registered_ones() -> None:
    with pytest.raises(ValueError, match="method must be one of point, line, ground, board"):
        Method("wal")
    parse = registered(METHOD_SPECS, lambda spec: spec.measures, argument=True)["parser"]
    with pytest.raises(typer.BadParameter, match=r"not one of point, line, ground$"):
        parse("wal")
    assert parse("board") == "board"  # left out of the choices: the command says why


@pytest.mark.usefixtures("registered_here")
def test_an_installed_extension_is_loaded_and_a_broken_one_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Entry points of the group ``twopose.extensions`` are imported once, their
    registrations made; one that raises is named in a warning and left out."""
    install_extension(tmp_path, "grey_ext", snippet("source"))
    install_extension(tmp_path, "broken_ext", "raise RuntimeError('a typo')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "_loaded", [])
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        loaded = registry.load_extensions()
    assert loaded == ("grey_ext",)
    assert "grey" in SOURCES
    assert any("'broken_ext'" in str(w.message) and "a typo" in str(w.message) for w in said)
    assert registry.load_extensions() == ("grey_ext",)  # once
    SOURCES.unregister("grey")
    sys.modules.pop("grey_ext", None)


#: An extension with two missing pieces: a detector given another target's thresholds,
#: and a caller's cases for each geometry that forgets one (a point on a plane).
_MISTAKES = """
import numpy as np
from numpy.typing import NDArray

from twopose.values.choices import Target, TargetSpec
from twopose.detect.detection import Detection
from twopose.methods.specs import METHOD_SPECS, Method
from twopose.detect.thresholds import DotParams, GloveParams


def detect_glove_like(image_bgr: NDArray[np.uint8], params: GloveParams) -> Detection:
    return Detection(found=params.use_otsu)


WRONG = TargetSpec(
    target=Target.declare("odd"), detector=detect_glove_like, params=DotParams, image_line=True
)


class Truths:
    def rays_to_point(self) -> int:
        return 1

    def planes_to_line(self) -> int:
        return 2


MISSING: int = METHOD_SPECS[Method.POINT].geometry_cases(Truths())
"""


def test_the_type_checker_catches_a_missing_piece(tmp_path: Path) -> None:
    """mypy (strict, as ``make check``) refuses a target whose detector takes another
    type's thresholds and a geometry's cases that miss one; the docs' target and source
    snippets pass, so the refusals are the mistakes'."""
    from mypy import api

    mistakes, target, source = (tmp_path / f"{n}.py" for n in ("mistakes", "target", "source"))
    mistakes.write_text(_MISTAKES, encoding="utf-8")
    target.write_text(snippet("target"), encoding="utf-8")
    source.write_text(snippet("source"), encoding="utf-8")
    cache = str(REPO / ".mypy_cache")
    out, _, status = api.run(
        ["--strict", "--no-error-summary", "--cache-dir", cache, str(mistakes), str(target),
         str(source)]
    )  # fmt: skip
    assert status == 1, out
    errors = [line for line in out.splitlines() if ": error:" in line]
    assert all(Path(line.split(":")[0]).name == "mistakes.py" for line in errors), out
    assert any(":16: error:" in e and '"detector"' in e and "GloveParams" in e for e in errors)
    assert any(":28: error:" in e and "geometry_cases" in e for e in errors), out
