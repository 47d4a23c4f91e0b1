"""analysis.tables.trials: each column of trials.csv is one declaration, every layer reads it.

Every column the run writes has exactly one declaration and its values keep to the
declared domain; the docs' table is the declarations'; which columns a method's trials
have is read from its spec; a column added by one declaration (in a copy of the packages)
reaches trials.csv and the report's labels with nothing else changed; and no module of the
columns' layer names a method.
"""

from __future__ import annotations

import ast
import dataclasses
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from analysis.tables.columns import DTYPES, TRIAL_TABLE_COLUMNS
from analysis.tables.labels import LABELS, readable_columns
from analysis.tables.read_back import read_table
from analysis.tables.trials import (
    TRIAL_TABLE,
    UNIT_KINDS,
    Column,
    column_named,
    columns_of,
    violations,
)
from twopose.methods.specs import METHOD_SPECS, METHODS, spec_of
from twopose.values.units import Units

REPO = Path(__file__).resolve().parents[2]
SESSIONS = REPO / "sessions"
#: The columns' layer: none of it may dispatch on a method's name.
LAYER = ("tables/columns.py", "tables/rows.py", "tables/labels.py", "tables/trials.py")


def test_every_column_of_trials_csv_has_exactly_one_declaration(bundled_run: Path) -> None:
    names = [c.name for c in TRIAL_TABLE]
    assert len(names) == len(set(names))
    assert names == TRIAL_TABLE_COLUMNS
    written = pd.read_csv(bundled_run / "trials.csv", nrows=0).columns
    assert [names.count(c) for c in written] == [1] * len(written)
    for c in TRIAL_TABLE:
        assert c.unit in UNIT_KINDS, c.name
        assert DTYPES[c.name] == c.dtype, c.name
        assert column_named(c.name) is c


def test_the_sample_sessions_output_keeps_every_declared_domain(bundled_run: Path) -> None:
    trials = read_table(bundled_run / "trials.csv")
    assert not violations(trials)
    assert set(trials["status"]) >= {"ok"}
    # each domain refuses what it does not hold
    broken = trials.assign(err=-trials["err"] - 1.0, status="lost", dominant_share=2.0)
    assert [v.split(":")[0] for v in violations(broken)] == ["status", "err", "dominant_share"]


def test_the_docs_table_of_columns_is_the_declarations() -> None:
    """docs/analysis.md's reference of trials.csv's columns is what the declarations state
    (regenerate it with ``.venv/bin/python docs/trial_columns_table.py --write-docs``)."""
    done = subprocess.run(
        [sys.executable, str(REPO / "docs" / "trial_columns_table.py")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stdout
    page = (REPO / "docs" / "analysis.md").read_text(encoding="utf-8")
    for c in TRIAL_TABLE:
        assert f"| `{c.name}` | {c.label} |" in page, c.name


def test_a_methods_columns_come_from_its_spec() -> None:
    for method in METHODS:
        spec = spec_of(method)
        names = {c.name for c in columns_of(spec)}
        assert set(spec.extra_columns) <= names, method
        assert set(spec.margins) <= names, method
        others = {m for s in METHOD_SPECS.values() for m in s.margins} - set(spec.margins)
        assert not names & others, method
    # a spec naming a column nobody declares is refused, not silently dropped
    made_up = dataclasses.replace(spec_of(METHODS[0]), extra_columns=("made_up",))
    with pytest.raises(KeyError, match="made_up"):
        columns_of(made_up)


def test_the_report_labels_are_the_declarations() -> None:
    for c in TRIAL_TABLE:
        assert LABELS[c.name].name == c.label, c.name
    table = pd.DataFrame({"err": [0.5], "angle_err_deg": [1.25], "x": [0.5]})
    assert list(readable_columns(table, Units("cm")).columns) == [
        "error (cm)",
        "direction error (°)",
        "estimate x (cm)",
    ]
    assert readable_columns(table, Units("cm"))["estimate x (cm)"].tolist() == ["+0.50"]


NEW_COLUMN = """
TRIAL_TABLE = (
    *TRIAL_TABLE,
    Column(
        name="err_xz", label="error in x-z", unit="length", domain=NON_NEGATIVE,
        group="notes", fill=lambda t: np.hypot(t.reported.error[:, 0], t.reported.error[:, 2]),
    ),
)
"""
ANCHOR = "\n\ndef column_named("


def test_a_column_declared_once_reaches_the_table_and_the_report(tmp_path: Path) -> None:
    """A copy of the packages with one more declaration, and nothing else changed: the run
    writes the column (after the others) and the report's tables label it."""
    for package in ("twopose", "recorder", "analysis"):
        shutil.copytree(
            REPO / package, tmp_path / package, ignore=shutil.ignore_patterns("__pycache__")
        )
    module = tmp_path / "analysis" / "tables" / "trials.py"
    text = module.read_text(encoding="utf-8")
    assert text.count(ANCHOR) == 1, "the module's layout changed: update this test"
    module.write_text(text.replace(ANCHOR, NEW_COLUMN + ANCHOR), encoding="utf-8")
    script = f"""
import pandas as pd
import analysis
from analysis.tables.labels import readable_columns
run = analysis.run([{str(SESSIONS / "thesis_method1_point.mcap")!r}], {str(tmp_path / "out")!r},
                   scene=False)
trials = pd.read_csv({str(tmp_path / "out" / "trials.csv")!r})
print(list(trials.columns)[-2:])
print((abs(trials["err_xz"] ** 2 - trials["err_x"] ** 2 - trials["err_z"] ** 2) < 1e-9).all())
print(list(readable_columns(trials[["err_xz"]], "in").columns))
"""
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, env=env, capture_output=True,
        text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        "['notes', 'err_xz']",
        "True",
        "['error in x-z (in)']",
    ], done.stdout


def _method_names_used(tree: ast.AST) -> list[str]:
    """Where ``tree`` compares with a method's name, lists it (tuple, list, set), keys a
    dict by it, or names a ``Method`` member."""
    names = {str(m) for m in METHODS}
    found = []

    def is_name(node: ast.AST) -> bool:
        return isinstance(node, ast.Constant) and node.value in names

    for node in ast.walk(tree):
        if isinstance(node, ast.Compare) and any(
            is_name(n) for n in (node.left, *node.comparators)
        ):
            found.append(f"line {node.lineno}: a comparison")
        elif isinstance(node, ast.Tuple | ast.List | ast.Set) and any(map(is_name, node.elts)):
            found.append(f"line {node.lineno}: a collection")
        elif isinstance(node, ast.Dict) and any(k is not None and is_name(k) for k in node.keys):
            found.append(f"line {node.lineno}: a dict key")
        elif (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id == "Method"
        ):
            found.append(f"line {node.lineno}: Method.{node.attr}")
    return found


def test_the_scan_finds_a_method_name() -> None:
    source = 'a == "line"\nb = ("point", 1)\nc = {"ground": 1}\nd = Method.BOARD\ne = "lines"'
    assert len(_method_names_used(ast.parse(source))) == 4


@pytest.mark.parametrize("name", LAYER)
def test_no_module_of_the_columns_layer_names_a_method(name: str) -> None:
    tree = ast.parse((REPO / "analysis" / name).read_text(encoding="utf-8"))
    assert not _method_names_used(tree), f"analysis/{name}: {_method_names_used(tree)}"


def test_a_declaration_is_frozen() -> None:
    column = TRIAL_TABLE[0]
    assert isinstance(column, Column)
    with pytest.raises(AttributeError):
        column.name = "other"  # type: ignore[misc]
