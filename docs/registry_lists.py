"""The docs' lists of what the registries hold, written from them: the frame sources in
docs/recording.md (:data:`recorder.sources.registry.SOURCES`) and the methods in docs/method.md
(:data:`twopose.methods.specs.METHOD_SPECS`: each one's target, truth, plane and solver).

    .venv/bin/python docs/registry_lists.py [--write-docs]

Without ``--write-docs`` it compares what it would write with the pages and exits 1 on a
difference (``tests/test_extensions.py`` runs the comparison in the quick loop), so a
kind of source or a method added to its registry and not to the docs fails there.
"""

from __future__ import annotations

import sys

from marked_table import REPO, write_or_check  # type: ignore[import-not-found]  # docs/ is sys.path[0]


def sources_table() -> str:
    """Every kind of frame source: what the operator types, what it is, whether it calibrates."""
    from recorder.sources.registry import SOURCE_KINDS

    rows = ["| `--source` | what it is | `calibrate` takes it |", "| --- | --- | --- |"]
    rows += [
        f"| `{k.syntax}` | {k.help}{f' (e.g. `{k.example}`)' if k.example else ''} "
        f"| {'yes' if k.calibrates else 'no'} |"
        for k in SOURCE_KINDS
    ]
    return "\n".join(rows) + "\n"


def methods_table() -> str:
    """Every method: its name, label, what is detected, its truth, plane and solver."""
    from twopose.methods.specs import METHOD_SPECS

    rows = [
        "| `--method` | label | detected | ground truth | plane | solved by |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, spec in METHOD_SPECS.items():
        target = spec.target.target if spec.target is not None else "the board's corners"
        truth = {None: "the board's placement", "point": "one point", "line": "two points"}
        plane = f"{spec.plane.name} ({spec.plane.equation})" if spec.plane else "none"
        solver = spec.solver.words if spec.solver is not None else "nothing (the rig's calibration)"
        cells = (f"`{name}`", spec.label, target, truth[spec.truth_kind], plane, solver)
        rows.append(f"| {' | '.join(cells)} |")
    return "\n".join(rows) + "\n"


def main() -> int:
    sys.path.insert(0, str(REPO))
    stale = write_or_check(
        REPO / "docs" / "recording.md", "sources list", sources_table, "registry_lists.py"
    )
    return stale | write_or_check(
        REPO / "docs" / "method.md", "methods list", methods_table, "registry_lists.py"
    )


if __name__ == "__main__":
    sys.exit(main())
