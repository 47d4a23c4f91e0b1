"""The registry census in a test (issues 45, 57): no registered name (a method, unit,
target, source or plane, or a secondary name its entry holds) is compared, collected, keyed,
passed or defaulted outside its registry's declarations without a reason written beside it
(``benchmarks/census.py`` counts them: in twopose/, recorder/ and analysis/ ``*.py``, the
registries included, and recorder/*.js; ``EXPLAINED`` says why each one left is not
dispatch), nor a ``method`` or ``units`` typed ``str`` without one.
"""

from __future__ import annotations

from pathlib import Path

from recorder.sources.registry import SOURCE_KINDS
from tests.helpers import load_benchmark
from twopose.methods.planes import GROUND_PLANE
from twopose.methods.specs import METHOD_SPECS, METHODS
from twopose.values.choices import TARGETS
from twopose.values.units import UNITS

census = load_benchmark("census")


def test_every_site_left_says_why() -> None:
    sites = census.census_sites()
    unexplained = [str(s) for s in sites if not census._why(s)]
    assert not unexplained, (
        f"{len(unexplained)} site(s) name a registered name outside its registry (read the "
        "registry: twopose/methods/specs.py, units.py, choices.py, planes.py, "
        "recorder/sources/registry.py), "
        "or say why in benchmarks/census.py's EXPLAINED:\n" + "\n".join(unexplained)
    )
    used = {(s.path, s.name, s.category) for s in sites}
    stale = sorted(set(census.EXPLAINED) - used)
    assert not stale, f"take these off benchmarks/census.py's EXPLAINED (no site left): {stale}"


def test_every_str_typed_method_or_units_says_why() -> None:
    typed = [
        (rel, name) for path, rel in census.sources() if rel.endswith(".py")
        for _, name in census.str_typed(path, rel)
    ]  # fmt: skip
    unexplained = [t for t in typed if (t[0], t[1].split(".")[0]) not in census.EXPLAINED_TYPED]
    assert not unexplained, f"type these Method/Units, or say why (EXPLAINED_TYPED): {unexplained}"
    stale = set(census.EXPLAINED_TYPED) - {(rel, name.split(".")[0]) for rel, name in typed}
    assert not stale, f"take these off EXPLAINED_TYPED (typed now): {sorted(stale)}"


def test_the_names_are_the_registries() -> None:
    names = census.registered_names()
    assert names["method"] == set(METHODS)
    assert names["unit"] == set(UNITS)
    assert names["target"] == set(TARGETS) == {"glove", "dot"}
    assert names["source"] == {k.name for k in SOURCE_KINDS}
    assert names["thesis"] == {s.thesis_name for s in METHOD_SPECS.values()}
    assert {"ray", "trace", "corners"} <= names["segment"]
    assert names["plane"] == {GROUND_PLANE.setup_key, GROUND_PLANE.request_key}
    assert "twopose/methods/planes.py" in census.REGISTRIES
    counted = {rel for _, rel in census.sources()}
    assert counted >= census.REGISTRIES  # no module exempt as a whole


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
    open_source("camera", units="in")  # argument (2)
    spec_of(Method.LINE)  # argument
    # not counted: a record's fields, subscripts, a field read, text, declarations
    k = {"trial": 1, "point": [0, 0, 0]}
    m = {"camera": 1, **d}
    n = d["board"]
    q = d.get("board")
    o = "synthetic"
    p = "point " + x
    GLOVE = Target.declare("glove")
    return kind == "gray"


def g(units="cm", method=Method.POINT):  # default (2)
    return MethodSpec(method=Method.POINT, thesis_name="method 1")  # a declaration
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
        (13, "argument", "camera"),
        (13, "argument", "in"),
        (14, "argument", "line"),
        (26, "default", "cm"),
        (26, "default", "point"),
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
