"""The registry census in a test (issue 45): no method, unit, target or source name is
compared, collected or keyed outside its registry (``benchmarks/census.py`` counts them: in
twopose/, recorder/ and analysis/ ``*.py``, and recorder/*.js).
"""

from __future__ import annotations

import typing
from collections import defaultdict
from pathlib import Path

from recorder.sources import SOURCE_KINDS
from tests.helpers import load_benchmark
from twopose.choices import TARGETS, Target
from twopose.methods import METHODS
from twopose.units import UNITS

census = load_benchmark("census")

#: Files others are rewriting now, whose sites their rewrite removes. Shrinking: the test
#: fails on a file here that has become clean (take it off), and on any site elsewhere.
ALLOWLIST: set[str] = set()  # none left: every file reads its registries


def _by_file() -> dict[str, list[str]]:
    found: dict[str, list[str]] = defaultdict(list)
    for site in census.census_sites():
        found[site.path].append(str(site))
    return found


def test_no_name_is_compared_collected_or_keyed_outside_its_registry() -> None:
    found = _by_file()
    offending = [s for path, sites in found.items() if path not in ALLOWLIST for s in sites]
    assert not offending, (
        f"{len(offending)} site(s) name a method, unit, target or source outside its registry "
        "(read the registry: twopose/methods.py, twopose/units.py, twopose/choices.py, "
        "recorder/sources.py):\n" + "\n".join(offending)
    )


def test_the_allowlist_only_shrinks() -> None:
    """An allowlisted file that has become clean comes off the list (it cannot rot)."""
    found = _by_file()
    clean = sorted(path for path in ALLOWLIST if not found.get(path))
    assert not clean, f"no sites left in {clean}: take them off tests/test_census.py's ALLOWLIST"


def test_the_names_are_the_registries() -> None:
    names = census.registered_names()
    assert names["method"] == set(METHODS)
    assert names["unit"] == set(UNITS)
    assert names["target"] == set(TARGETS) == set(typing.get_args(Target))
    assert names["source"] == {k.name for k in SOURCE_KINDS}
    assert {
        "twopose/methods.py",
        "twopose/units.py",
        "twopose/choices.py",
        "recorder/sources.py",
    } == census.REGISTRIES


_PYTHON = """
def f(x, units, target, kind, d):
    a = x == "in"  # comparison
    b = units not in ("in", "cm")  # collection (2)
    c = {"dot": 1}  # dict key
    e = {"point": f, "line": g}  # dict key (2)
    match target:
        case "glove":  # comparison
            pass
    h = x == Method.GROUND  # comparison (an enum member is its name)
    i = [Units.MM]  # collection
    j = dict(camera=1, video=2)  # dict key (2)
    # not counted: a record's fields, arguments, defaults, subscripts, text
    k = {"trial": 1, "point": [0, 0, 0]}
    m = {"camera": 1, **d}
    open_source("camera", units="in")
    n = d["board"]
    o = "synthetic"
    p = "point " + x
    return kind == "ray"
"""


def test_the_python_census_counts_what_a_stranger_counts(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text(_PYTHON)
    sites = census.python_sites(module, "m.py", census.registered_names())
    got = sorted((s.line, s.category, s.name) for s in sites)
    assert got == [
        (3, "comparison", "in"),
        (4, "collection", "cm"),
        (4, "collection", "in"),
        (5, "dict key", "dot"),
        (6, "dict key", "line"),
        (6, "dict key", "point"),
        (8, "comparison", "glove"),
        (10, "comparison", "ground"),
        (11, "collection", "mm"),
        (12, "dict key", "camera"),
        (12, "dict key", "video"),
    ]


_JS = """
// a comment naming "point" === x is not code
/* nor "line" in a block */
if (method === "board") {}            // comparison
if ("in" !== units) {}                // comparison
const kinds = ["camera", "video"];    // collection (2)
switch (target) { case "dot": break; } // comparison
const table = {point: 1, "line": 2};  // dict key (2)
const record = {trial: 1, point: 3};  // a record's field: not counted
const message = "point";              // not counted
f(rows["ground"]);                    // a subscript: not counted
const t = `in ${units}`;              // a template's text: not counted
"""


def test_the_javascript_census_counts_what_a_stranger_counts(tmp_path: Path) -> None:
    script = tmp_path / "page.js"
    script.write_text(_JS)
    sites = census.js_sites(script, "page.js", census.registered_names())
    got = sorted((s.line, s.category, s.name) for s in sites)
    assert got == [
        (4, "comparison", "board"),
        (5, "comparison", "in"),
        (6, "collection", "camera"),
        (6, "collection", "video"),
        (7, "comparison", "dot"),
        (8, "dict key", "line"),
        (8, "dict key", "point"),
    ]
