"""``--version`` of the command lines: the package and the session format it writes."""

from __future__ import annotations

from typing import Annotated

import typer

__all__ = ["VersionOption", "show_version"]


def show_version(*, value: bool) -> None:
    """The command lines' ``--version``: print the package and session format versions."""
    if not value:
        return
    from twopose import __version__
    from twopose.format.entries import FORMAT_VERSION

    typer.echo(f"twopose {__version__} (session format {FORMAT_VERSION})")
    raise typer.Exit()


#: The ``--version`` option both command lines declare on their group.
VersionOption = Annotated[
    bool,
    typer.Option(
        "--version", callback=show_version, is_eager=True, help="Print the version and exit."
    ),
]
