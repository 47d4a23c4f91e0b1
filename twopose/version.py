"""``--version`` of the command lines: the package and the session format it writes."""

from __future__ import annotations

__all__ = ["show_version"]


def show_version(value: bool) -> None:
    """The command lines' ``--version``: print the package and session format versions."""
    if not value:
        return
    import typer

    from twopose import __version__
    from twopose.format.entries import FORMAT_VERSION

    typer.echo(f"twopose {__version__} (session format {FORMAT_VERSION})")
    raise typer.Exit()
