"""Every command's ``--help`` and the kinds of ``--source``, as the reference docs/commands.md
includes (not pasted: this script writes it, and ``tests/test_docs.py`` reruns it, so an
option or a source kind added without its docs, or docs of one that is gone, fails the tests).

    .venv/bin/python benchmarks/command_help.py [--write-docs]
"""

from __future__ import annotations

import typer
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]
from typer.testing import CliRunner

from analysis.cli import app as analyze_app
from recorder.cli.app import app as record_app
from recorder.sources.registry import source_kinds_table

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "command_help.txt"
WIDTH = 100


def main() -> int:
    runner = CliRunner()
    for program, app in (("twopose-record", record_app), ("twopose-analyze", analyze_app)):
        group = typer.main.get_command(app)
        for name in sorted(getattr(group, "commands", {})):
            result = runner.invoke(
                app, [name, "--help"], env={"COLUMNS": str(WIDTH), "NO_COLOR": "1"},
                terminal_width=WIDTH, prog_name=program, color=False,
            )  # fmt: skip
            assert result.exit_code == 0, result.output
            print(f"$ {program} {name} --help")
            print(result.output.rstrip())
            print()
    print("Sources (--source), one entry each in recorder/sources/registry.py's SOURCE_KINDS:")
    print(source_kinds_table())
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
