"""The registry census (issues 35 and 45): where behaviour still dispatches on a name that
has a registry, instead of reading the registry.

    .venv/bin/python benchmarks/census.py [--list] [--write-docs]

Four kinds of name, each read from its registry (so a name added there is counted too):
methods (:data:`twopose.methods.specs.METHODS`), units (:data:`twopose.values.units.UNITS`), targets
(:data:`twopose.values.choices.Target`) and frame sources
(:data:`recorder.sources.registry.SOURCE_KINDS`).
Counted over ``twopose/``, ``recorder/`` and ``analysis/``: the ``*.py`` modules by their
syntax trees, ``recorder/*.js`` by a tokenizer (comments dropped, string literals and the
tokens around them); the registries themselves (``twopose/methods/specs.py``,
``twopose/values/units.py``, ``twopose/values/choices.py``, ``recorder/sources/registry.py``) are
exempt. A site is
one literal name, counted where a stranger counting by hand would count it, anywhere:

- a **comparison**: ``x == "in"`` (or ``x == Units.IN``: an enum member is its name),
  ``!=``, ``is``, ``"dot" in x``, a ``case "dot":`` label (Python's ``match`` or
  JavaScript's ``switch``), JavaScript's ``===``/``!==``;
- a **collection**: a tuple, list or set literal holding the name (``("in", "cm")``,
  ``x in ("line", "ground")``, ``Literal["point", "line"]``, a JavaScript array);
- a **dict key**: the keys of a table over names, a dict whose keys are all registered
  names (``{"dot": ...}``, ``{"point": f, "line": g}``; ``{dot: ...}`` in JavaScript,
  ``dict(dot=...)``).

Not counted, as not dispatch: a name passed as an argument or default, a record's field
that happens to be a name (``{"trial": 1, "point": [...]}``, a JSON object), a field read
by subscript (``row["camera"]``), message text. Also counted, as before: parameters named
``method`` typed ``str`` against those typed ``Method``, and ``units`` typed ``str``
against ``Units``.

``--list`` adds every site (``file:line``). Deterministic: ``tests/test_docs.py`` reruns it
and compares it with the docs' figure; ``tests/test_census.py`` asserts the sites are none.
"""

from __future__ import annotations

import ast
import re
import sys
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "census.txt"
REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("twopose", "recorder", "analysis")
#: The registries: where the names are declared (their declarations alone are not sites:
#: :data:`DECLARING`; every other use in them is counted, as anywhere).
REGISTRIES = frozenset(
    {
        "twopose/methods/specs.py",
        "twopose/values/units.py",
        "twopose/values/choices.py",
        "twopose/methods/planes.py",
        "recorder/sources/registry.py",
    }
)
#: What a site is.
CATEGORIES = ("comparison", "collection", "dict key", "argument", "default")
#: A name's declaration, not a use: ``Method.declare("point")``, the key field of a
#: registry entry (``MethodSpec(method=Method.POINT)``, ``SourceKind(name="camera")``), an
#: enum's member (``IN = "in"``) and the unit registry's table (``UNIT_SPECS``).
DECLARING = {
    "MethodSpec": ("method", "thesis_name", "label", "truth_kind"),
    "MethodPage": ("legend_segments",),
    "TargetSpec": ("target",),
    "SourceKind": ("name",),
    "UnitSpec": ("units",),
    "ConstraintPlane": ("setup_key", "request_key"),
}
#: Reading a record's field by its name is not dispatch, as a subscript is not:
#: ``data.get("board")``, ``getattr(err, "line")``.
FIELD_READERS = ("get", "getattr")


def registered_names() -> dict[str, frozenset[str]]:
    """Each kind's names, read from its registry, then the secondary names its entries hold
    (a segment's kind, a method's thesis name, a plane's setup and request keys)."""
    sys.path.insert(0, str(REPO))
    from recorder.sources.registry import SOURCE_KINDS
    from twopose.methods.planes import CONSTRAINT_PLANES
    from twopose.methods.specs import METHOD_SPECS, METHODS
    from twopose.values.choices import TARGETS
    from twopose.values.units import UNITS

    specs = METHOD_SPECS.values()
    return {
        "method": frozenset(str(m) for m in METHODS),
        "unit": frozenset(str(u) for u in UNITS),
        "target": frozenset(str(t) for t in TARGETS),
        "source": frozenset(k.name for k in SOURCE_KINDS),
        "segment": frozenset(kind for s in specs for kind, _, _ in s.page.legend_segments),
        "thesis": frozenset(s.thesis_name for s in specs),
        "plane": frozenset(
            key
            for p in CONSTRAINT_PLANES.values()
            for key in (p.setup_key, p.request_key)
            if key is not None
        ),
    }


#: The sites left, each with why it is not dispatch on a registered name (by file, name and
#: category): the figure lists every one, and ``tests/test_census.py`` fails on a site not
#: here and on an entry no site uses any more.
_SEGMENTS = (
    "a segment kind declared with its style (SegmentKind: the one place a kind is named; "
    "the page draws each segment by the style it carries)"
)
_TRUTH_KINDS = (
    "TruthKind's words (a trial's truth is one point or a line), spelled as two methods are"
)
_INCHES = "an inch-valued constant converted to the session's unit"
_THESIS = "the thesis' claims, keyed by its own names for the methods it tested"
_LINE_GROUP = 'a column group named "line" (the line\'s columns)'
_SOURCE_METHOD = "a source opened without a method renders method 2's scene (the thesis' main one)"
EXPLAINED: dict[tuple[str, str, str], str] = {
    ("twopose/methods/specs.py", "point", "collection"): _TRUTH_KINDS,
    ("twopose/methods/specs.py", "line", "collection"): _TRUTH_KINDS,
    (
        "twopose/values/bounds.py",
        "in",
        "argument",
    ): "the bounds are declared in inches (Units.IN: the unit their numbers are in) and converted",
    (
        "twopose/values/bounds.py",
        "ground_height",
        "argument",
    ): (
        "the ground height's bound, the key of its Quantity (the plane's setup_key names this "
        "bound)"
    ),
    ("twopose/detect/clutter.py", "in", "argument"): _INCHES,
    ("twopose/guidance/first_pose.py", "in", "argument"): _INCHES,
    ("twopose/guidance/advice.py", "in", "argument"): "the thesis' move, in inches, converted",
    ("twopose/guidance/paper.py", "in", "argument"): "the grid paper's inch-valued sizes converted",
    ("twopose/format/entries.py", "in", "argument"): "the default resolution, in inches, converted",
    (
        "twopose/values/options.py",
        "in",
        "argument",
    ): "the help's range shown in inches, the bounds' own unit",
    ("twopose/pair/motion.py", "in", "argument"): "the thesis' pair simulated in its inches",
    ("twopose/sim/layout.py", "in", "argument"): "the scene's inch-valued sizes converted",
    ("twopose/sim/scene.py", "in", "argument"): "an inch-valued limit converted",
    (
        "twopose/sim/scene.py",
        "in",
        "default",
    ): (
        "a scene file's unit as typed (str: checked against UNITS when the scene is read); the "
        "thesis' inches"
    ),
    (
        "twopose/sim/scene.py",
        "ground_height",
        "argument",
    ): "the scene file's own key, named in its message",
    ("recorder/setup/plan.py", "in", "argument"): _INCHES,
    ("analysis/tools/sensitivity.py", "in", "argument"): "the thesis' sweeps, in its inches",
    ("twopose/solve/hand_check.py", "line", "argument"): 'the solve request\'s field "line"',
    (
        "twopose/format/entries.py",
        "camera",
        "argument",
    ): "the session file's field \"camera\" (a camera's id)",
    ("twopose/format/session_entry.py", "board", "argument"): 'the session file\'s field "board"',
    ("twopose/format/simulation.py", "camera", "argument"): (
        "the session file's field \"camera\" (a camera's id)"
    ),
    ("twopose/format/stream_entries.py", "camera", "argument"): (
        "the session file's field \"camera\" (a camera's id)"
    ),
    ("twopose/format/stream_entries.py", "point", "argument"): (
        'the touch\'s field "point" (the grid point touched) and its message'
    ),
    ("analysis/tables/declared.py", "camera", "argument"): 'frames.csv\'s column "camera"',
    ("analysis/tables/declared.py", "pair", "argument"): (
        "views.csv's column \"pair\" (a frame pair's number)"
    ),
    ("twopose/sim/moving.py", "in", "argument"): "the scene's inch-valued sizes converted",
    ("recorder/simulate/pair.py", "in", "argument"): "one inch in the scene's unit (the lead)",
    ("recorder/simulate/pointing_clip.py", "in", "argument"): "one inch in the scene's unit",
    ("recorder/cli/app.py", "point", "argument"): "the command's name (twopose-record point)",
    ("recorder/cli/point.py", "ground", "default"): "point's --method: the floor's method",
    ("recorder/console/pointing_server.py", "ground", "default"): (
        "point's method when none is given: where the finger points on the floor"
    ),
    ("recorder/console/pointing_server.py", "in", "argument"): (
        "the panel's smallest view, declared in inches and converted"
    ),
    ("recorder/setup/rules.py", "in", "argument"): (
        "a board session's rig check needs no unit (it refuses any rig): the bounds' own"
    ),
    ("analysis/report/plane_axes.py", "point", "default"): (
        "a table with no method column is drawn on a point's plane (the ground's axes)"
    ),
    ("recorder/setup/plan_file.py", "camera", "argument"): "the plan file's table [camera]",
    (
        "recorder/setup/stream_plan.py",
        "point",
        "collection",
    ): "a pair plan's touch key `point` (the grid point), not the method",
    (
        "recorder/setup/stream_plan.py",
        "point",
        "comparison",
    ): "a pair plan's touch key `point` (the grid point), not the method",
    ("recorder/setup/plan_file.py", "board", "argument"): "the plan file's table [board]",
    (
        "recorder/setup/form.py",
        "board",
        "argument",
    ): "the setup's field \"board\" (the board's inner corners)",
    (
        "recorder/sources/synthetic.py",
        "synthetic",
        "argument",
    ): "the source's description, as the file records it",
    ("recorder/sources/registry.py", "ground", "default"): _SOURCE_METHOD,
    ("recorder/sources/synthetic.py", "ground", "default"): _SOURCE_METHOD,
    (
        "twopose/rig/constants.py",
        "ground_height",
        "collection",
    ): "a function's name in __all__ (the rig's ground height)",
    ("twopose/display/scene.py", "ground", "argument"): "the 3-D scene's entity id for the plane",
    (
        "twopose/guidance/prediction.py",
        "line",
        "argument",
    ): (
        "the finger's line, estimated as the line method does (what one more pose predicts of a "
        "finger, for method 2 too)"
    ),
    (
        "twopose/methods/topview.py",
        "board",
        "argument",
    ): "a board session's top view says its method",
    ("twopose/methods/topview.py", "ray", "argument"): _SEGMENTS,
    ("twopose/methods/topview.py", "trace", "argument"): _SEGMENTS,
    ("twopose/methods/topview.py", "estimated_line", "argument"): _SEGMENTS,
    ("twopose/methods/topview.py", "truth_line", "argument"): _SEGMENTS,
    ("twopose/methods/topview.py", "corners", "argument"): _SEGMENTS,
    ("analysis/tables/columns.py", "line", "argument"): _LINE_GROUP,
    ("analysis/tables/trials.py", "line", "argument"): _LINE_GROUP,
    ("analysis/report/thesis.py", "method 1", "dict key"): _THESIS,
    ("analysis/report/thesis.py", "method 2", "dict key"): _THESIS,
}


#: The ``method`` and ``units`` parameters and record fields typed ``str`` (not ``Method``,
#: ``Units``), each with why (by file and the function's or record's name).
EXPLAINED_TYPED: dict[tuple[str, str], str] = {
    ("twopose/methods/specs.py", "label_of"): "any text a table holds, shown as given if unknown",
    ("twopose/format/stream_entries.py", "ClockOffsetEntry"): "how the clocks' offset was "
    "measured (a flash, a moving dot's rays), not a reconstruction method",
    ("twopose/methods/specs.py", "spec_of"): "a name as a file or a table gives it; an unknown one "
    "refused in words",
    (
        "twopose/values/units.py",
        "unit_spec",
    ): "a unit as a file or a table gives it; an unknown one refused in words",
    ("twopose/pair/clock_fit.py", "ClockOffset"): "how the clocks' offset was measured (a flash, "
    "a moving dot's rays), not a reconstruction method",
    ("twopose/pair/pair_file.py", "_PairTable"): "the pair file's text, read by unit_spec",
    ("twopose/sim/scene.py", "Scene"): "a scene file's unit as typed, checked against UNITS "
    "when the scene is read",
    (
        "twopose/display/scene.py",
        "TrialScene",
    ): "built from a table's text by the report's top view "
    "(analysis/report/figures/topview.py, which the plane lane rewrites): typed Method after it",
    (
        "twopose/methods/topview.py",
        "TopView",
    ): "a TrialScene's method (the console's JSON carries the "
    "name); typed Method with TrialScene's",
}


@dataclass(frozen=True, order=True)
class Site:
    """One literal name where a registry should be read."""

    path: str
    line: int
    kind: str
    category: str
    name: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.category} {self.name!r} ({self.kind})"


# --------------------------------------------------------------------------- Python


class _Kinds:
    """Which kind a literal is (None: no registered name)."""

    def __init__(self, names: Mapping[str, frozenset[str]]) -> None:
        self.by_name = {n: kind for kind, ns in names.items() for n in ns}

    def of(self, node: ast.AST | None) -> tuple[str, str] | None:
        """A name's literal, or a registry enum's member (``Method.GROUND``, ``Units.IN``)."""
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            kind = self.by_name.get(node.value)
            return (kind, node.value) if kind else None
        if isinstance(node, ast.Attribute) and ast.unparse(node.value).endswith(_ENUMS):
            name = node.attr.lower()
            kind = self.by_name.get(name)
            return (kind, name) if kind else None
        return None


#: The registries' name types, whose members are their names (``Method.POINT == "point"``).
_ENUMS = ("Method", "Units", "Target")


def python_sites(path: Path, rel: str, names: Mapping[str, frozenset[str]]) -> list[Site]:
    """The sites of one Python module."""
    kinds = _Kinds(names)
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: dict[int, Site] = {}  # by the literal's node, each counted once
    _declarations(tree, found)  # a declaration is none of them
    # Collections first: ``x in ("a", "b")`` is a collection, not also a comparison.
    for node in ast.walk(tree):
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            _add(found, kinds, rel, node.elts, "collection")
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            _add(found, kinds, rel, [node.left, *node.comparators], "comparison")
        elif isinstance(node, ast.MatchValue):
            _add(found, kinds, rel, [node.value], "comparison")
        elif isinstance(node, ast.Dict) and node.keys:  # a None key: ``**spread``, a record
            if all(kinds.of(k) for k in node.keys):  # a table over names, not a record
                _add(found, kinds, rel, node.keys, "dict key")
        elif isinstance(node, ast.Call) and ast.unparse(node.func) == "dict" and node.keywords:
            words = [ast.Constant(k.arg, lineno=k.lineno) for k in node.keywords if k.arg]
            if len(words) == len(node.keywords) and all(kinds.of(w) for w in words):
                _add(found, kinds, rel, words, "dict key")
    _arguments_and_defaults(tree, found, kinds, rel)
    return sorted(s for s in found.values() if s is not _DECLARED)


#: A declaration's node: kept in ``found`` so that nothing counts it, then dropped.
_DECLARED: Any = object()


def _declared_by_call(node: ast.Call, found: dict[int, Site]) -> None:
    """A call's declarations: ``declare``'s name, an entry's key fields, a field read."""
    func = ast.unparse(node.func)
    if func.endswith(".declare"):
        for arg in node.args:
            found[id(arg)] = _DECLARED
    keys = DECLARING.get(func.rsplit(".", 1)[-1], ())
    for keyword in node.keywords:
        if keyword.arg in keys:
            for inner in ast.walk(keyword.value):
                found[id(inner)] = _DECLARED
    if func.rsplit(".", 1)[-1] in FIELD_READERS and len(node.args) >= 1:
        found[id(node.args[-1 if func == "getattr" else 0])] = _DECLARED


def _declarations(tree: ast.AST, found: dict[int, Site]) -> None:
    """Mark each name's declaration (:data:`DECLARING`) as not a site."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            _declared_by_call(node, found)
        elif isinstance(node, ast.Assign) and ast.unparse(node.targets[0]).lstrip("(").startswith(
            _ENUMS
        ):
            for inner in ast.walk(node.targets[0]):  # Method.POINT, ... = Method.declare(...)
                found[id(inner)] = _DECLARED
        elif isinstance(node, ast.ClassDef) and node.name in _ENUMS:
            for statement in node.body:
                if isinstance(statement, ast.Assign):
                    found[id(statement.value)] = _DECLARED
        elif isinstance(node, ast.AnnAssign | ast.Assign) and "UNIT_SPECS" in ast.unparse(
            node.targets[0] if isinstance(node, ast.Assign) else node.target
        ):
            for inner in ast.walk(node.value) if node.value is not None else ():
                found.setdefault(id(inner), _DECLARED)


def _arguments_and_defaults(tree: ast.AST, found: dict[int, Site], kinds: _Kinds, rel: str) -> None:
    """A name passed as an argument (``spec_of("ground")``, ``f(method=Method.GROUND)``)
    or given as a default (a parameter's, a dataclass field's)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            values = [*node.args, *(k.value for k in node.keywords)]
            _add(found, kinds, rel, values, "argument")
        elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            defaults = [*node.args.defaults, *node.args.kw_defaults]
            _add(found, kinds, rel, [d for d in defaults if d is not None], "default")
        elif isinstance(node, ast.ClassDef):
            fields = [s.value for s in node.body if isinstance(s, ast.AnnAssign)]
            _add(found, kinds, rel, [v for v in fields if v is not None], "default")


def _add(found: dict[int, Site], kinds: _Kinds, rel: str, nodes: list[Any], category: str) -> None:
    """Each of ``nodes`` that is a name, as a site (once, whatever else it is part of)."""
    for node in nodes:
        hit = kinds.of(node)
        if hit and id(node) not in found:
            found[id(node)] = Site(rel, getattr(node, "lineno", 0), hit[0], category, hit[1])


# --------------------------------------------------------------------------- JavaScript

_JS_TOKEN = re.compile(
    r"""(?P<comment>//[^\n]*|/\*.*?\*/)
      | (?P<string>"(?:[^"\\\n]|\\.)*"|'(?:[^'\\\n]|\\.)*'|`(?:[^`\\]|\\.)*`)
      | (?P<word>[A-Za-z_$][\w$]*)
      | (?P<number>\d[\w.]*)
      | (?P<op>===|!==|==|!=|=>|\?\.|\.\.\.|[^\s\w])""",
    re.S | re.X,
)
_COMPARE = {"===", "!==", "==", "!="}


def _js_tokens(text: str) -> Iterator[tuple[str, str, int]]:
    """(kind, text, line) of each token, comments dropped; a string's text unquoted.

    A template literal is one string token (its ``${...}`` parts are not looked into); a
    regular expression literal is not told from division, which is harmless here: its
    tokens hold no quoted name followed by a comparison.
    """
    for match in _JS_TOKEN.finditer(text):
        kind = match.lastgroup or ""
        if kind == "comment":
            continue
        value = match.group()
        line = text.count("\n", 0, match.start()) + 1
        if kind == "string":
            yield kind, value[1:-1], line
        else:
            yield kind, value, line


def js_sites(path: Path, rel: str, names: Mapping[str, frozenset[str]]) -> list[Site]:
    """The sites of one JavaScript file."""
    by_name = {n: kind for kind, ns in names.items() for n in ns}
    tokens = list(_js_tokens(path.read_text(encoding="utf-8")))
    sites: list[Site] = []
    brackets: list[str] = []  # "array", "index", "object", "block", "paren"
    keys: list[list[tuple[str, int]]] = []  # each open bracket's object keys: (key, line)
    for i, (kind, text, line) in enumerate(tokens):
        before = tokens[i - 1][1] if i else ""
        after = tokens[i + 1][1] if i + 1 < len(tokens) else ""
        if kind == "op" and text in "([{":
            brackets.append(_opened(text, tokens[i - 1] if i else ("", "", 0)))
            keys.append([])
        elif kind == "op" and text in ")]}" and brackets:
            closed, its_keys = brackets.pop(), keys.pop()
            if closed == "object" and its_keys and all(k in by_name for k, _ in its_keys):
                sites.extend(Site(rel, at, by_name[k], "dict key", k) for k, at in its_keys)
        elif brackets and brackets[-1] == "object" and before in ("{", ",") and after == ":":
            keys[-1].append((text, line))  # an object's key (a table over names or not)
        elif kind == "string" and text in by_name:
            category = _js_category(before, after, brackets[-1] if brackets else "")
            if category:
                sites.append(Site(rel, line, by_name[text], category, text))
    return sites


def _js_category(before: str, after: str, bracket: str) -> str:
    """What a quoted name is, by the tokens around it and the bracket it is in."""
    if before in _COMPARE or after in _COMPARE or before == "case" or after == "in":
        return "comparison"
    return "collection" if bracket == "array" else ""


def _opened(bracket: str, before: tuple[str, str, int]) -> str:
    """What a bracket opens, told by the token before it."""
    kind, text, _ = before
    if bracket == "(":
        return "paren"
    value_before = kind in ("word", "string", "number") and text not in _KEYWORDS
    if bracket == "[":
        return "index" if value_before or text in (")", "]") else "array"
    # ``{`` after a value, ``)`` or ``=>`` opens a block; after an operator, a value (object)
    if text in (")", "=>", ";", "{", "}", "else", "try", "finally", "do") or value_before:
        return "block"
    return "object"


_KEYWORDS = {"return", "case", "in", "of", "typeof", "new", "await", "yield", "throw"}


# --------------------------------------------------------------------------- the census


def sources() -> Iterator[tuple[Path, str]]:
    """The files counted (every one: no module is exempt), in a fixed order."""
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            yield path, path.relative_to(REPO).as_posix()
    for path in sorted((REPO / "recorder").rglob("*.js")):
        yield path, path.relative_to(REPO).as_posix()


def _why(site: Site) -> str:
    """Why ``site`` is left (:data:`EXPLAINED`), or "" when nothing says."""
    return EXPLAINED.get((site.path, site.name, site.category), "")


def census_sites(names: Mapping[str, frozenset[str]] | None = None) -> list[Site]:
    """Every site in twopose/, recorder/ and analysis/ (Python) and recorder/*.js."""
    names = registered_names() if names is None else names
    found: list[Site] = []
    for path, rel in sources():
        scan = js_sites if rel.endswith(".js") else python_sites
        found.extend(scan(path, rel, names))
    return found


def str_typed(path: Path, rel: str) -> list[tuple[str, str]]:
    """``(file:line, where.name)`` of each ``method``/``units`` typed ``str`` in one module:
    ``where`` the function or record (dataclass) it belongs to."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            args = [*node.args.args, *node.args.kwonlyargs]
            found += [(node.lineno, node.name, a.arg) for a in args if _kind(a) == "str"]
        elif isinstance(node, ast.ClassDef):
            for field in node.body:
                if isinstance(field, ast.AnnAssign) and isinstance(field.target, ast.Name):
                    as_arg = ast.arg(arg=field.target.id, annotation=field.annotation)
                    if _kind(as_arg) == "str":
                        found.append((field.lineno, node.name, field.target.id))
    return [(f"{rel}:{line}", f"{where}.{name}") for line, where, name in found]


def typed_parameters(path: Path) -> Counter[str]:
    """``method``/``units`` parameters by their type, in one Python module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found: Counter[str] = Counter()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            for arg in [*node.args.args, *node.args.kwonlyargs]:
                kind = _kind(arg)
                if kind:
                    found[f"{arg.arg}: {kind}"] += 1
        elif isinstance(node, ast.ClassDef):  # a record's field (a dataclass'), as typed
            for field in node.body:
                if isinstance(field, ast.AnnAssign) and isinstance(field.target, ast.Name):
                    as_arg = ast.arg(arg=field.target.id, annotation=field.annotation)
                    kind = _kind(as_arg)
                    if kind:
                        found[f"{field.target.id}: {kind}"] += 1
    return found


def _annotation(arg: ast.arg) -> str:
    """The parameter's type (of ``Annotated[T, ...]``, ``T`` alone: its metadata is not)."""
    node = arg.annotation
    if isinstance(node, ast.Subscript) and ast.unparse(node.value).endswith("Annotated"):
        first = node.slice.elts[0] if isinstance(node.slice, ast.Tuple) else node.slice
        return ast.unparse(first)
    return ast.unparse(node) if node is not None else ""


#: A parameter's registry type: ``method`` is a Method, ``units`` a Units.
_TYPES = {"method": "Method", "units": "Units"}


def _kind(arg: ast.arg) -> str:
    """``Method``/``Units`` when ``arg`` is typed by its registry's type, ``str`` when by a
    string (or anything else), "" when it is not such a parameter (or another ``method``:
    a rule for combining frames)."""
    wanted = _TYPES.get(arg.arg)
    annotation = _annotation(arg)
    if wanted is None or not annotation or "CombineRule" in annotation:
        return ""
    return wanted if wanted in annotation and "str" not in annotation else "str"


def _print_reasons(sites: list[Site]) -> None:
    """Each str-typed method or units, and each site left, with why."""
    print()
    print("each method or units typed str, and why (EXPLAINED_TYPED):")
    for path, rel in sources():
        for at, name in str_typed(path, rel) if rel.endswith(".py") else ():
            why = EXPLAINED_TYPED.get((rel, name.split(".")[0]), "UNEXPLAINED")
            print(f"{at}: {name}: {why}")
    print()
    print("each site left, and why it is not dispatch on a name (benchmarks/census.py EXPLAINED):")
    grouped: dict[tuple[str, str, str], list[int]] = {}
    for site in sites:
        grouped.setdefault((site.path, site.name, site.category), []).append(site.line)
    for (file, name, category), lines in grouped.items():
        why = EXPLAINED.get((file, name, category), "UNEXPLAINED")
        where = ", ".join(str(line) for line in lines)
        print(f"{file}:{where}: {category} {name!r}: {why}")


def main() -> int:
    listing = "--list" in sys.argv[1:]
    names = registered_names()
    sites = census_sites(names)
    table: Counter[tuple[str, str, str]] = Counter()
    for site in sites:
        table[(site.kind, site.category, "js" if site.path.endswith(".js") else "py")] += 1
    print("sites (a registered name compared, collected or keyed outside its registry)")
    width = max(len(", ".join(sorted(n))) for n in names.values())
    print(f"{'kind':<8} {'names':<{width}} " + " ".join(f"{c:>12}" for c in CATEGORIES))
    for kind, kind_names in names.items():
        for lang in ("py", "js"):
            cells = " ".join(f"{table[(kind, c, lang)]:>12}" for c in CATEGORIES)
            label = ", ".join(sorted(kind_names)) if lang == "py" else "  (recorder/*.js)"
            print(f"{kind:<8} {label:<{width}} {cells}")
    print(f"total: {len(sites)}")
    explained = [site for site in sites if _why(site)]
    print(f"explained: {len(explained)}, unexplained: {len(sites) - len(explained)}")
    print()
    params: Counter[str] = Counter()
    for path, rel in sources():
        if rel.endswith(".py"):
            params.update(typed_parameters(path))
    for key in sorted({f"{n}: {k}" for n, t in _TYPES.items() for k in (t, "str")} | {*params}):
        print(f"{key}: {params[key]}")
    _print_reasons(sites)
    if listing:
        print()
        for site in sites:
            print(site)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
