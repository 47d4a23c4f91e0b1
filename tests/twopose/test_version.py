"""twopose.version directly: both command lines' --version prints the package and the
session format it writes, and exits 0 before any command runs."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from analysis.cli import app as analyze
from recorder.cli.app import app as record
from twopose import __version__
from twopose.format.entries import FORMAT_VERSION


@pytest.mark.parametrize("app", [analyze, record], ids=["twopose-analyze", "twopose-record"])
def test_version(app: object) -> None:
    result = CliRunner().invoke(app, ["--version"])  # type: ignore[arg-type]
    assert result.exit_code == 0
    assert result.output == f"twopose {__version__} (session format {FORMAT_VERSION})\n"
