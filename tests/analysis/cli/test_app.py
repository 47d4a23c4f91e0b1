"""The two command lines' shared application: each prints its version."""

from __future__ import annotations

from typer.testing import CliRunner

from analysis.cli import app


def test_both_command_lines_print_their_version() -> None:
    from recorder.cli import app as record
    from twopose import __version__
    from twopose.format.entries import FORMAT_VERSION

    for cli in (app, record):
        result = CliRunner().invoke(cli, ["--version"])
        assert result.exit_code == 0
        assert result.output.strip() == f"twopose {__version__} (session format {FORMAT_VERSION})"
