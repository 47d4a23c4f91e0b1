"""twopose.errors: the exception hierarchy's exit codes and the one main of both command
lines (a Ctrl-C exits 130 with one line, even one Python swallowed)."""

from __future__ import annotations

import gc
import signal
import sys
import time
import weakref

import pytest
import typer

import analysis.cli
import recorder.cli.app
from twopose import errors
from twopose.errors import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    InputValueError,
    handle_errors,
    run_command_line,
)


@pytest.fixture(autouse=True)
def _restore_sigint() -> object:
    """watch_interrupts installs a SIGINT handler and sys.unraisablehook: put both back."""
    before, hook = signal.getsignal(signal.SIGINT), sys.unraisablehook
    yield None
    signal.signal(signal.SIGINT, before)
    sys.unraisablehook = hook
    errors._interrupted = False


def test_an_error_is_its_message_and_exit_code(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(typer.Exit) as done, handle_errors():
        raise InputValueError("frames must be >= 1, got 0")
    assert done.value.exit_code == EXIT_ERROR
    assert capsys.readouterr().err.strip() == "error: frames must be >= 1, got 0"


def test_ctrl_c_anywhere_exits_130_with_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    def app() -> None:
        raise KeyboardInterrupt

    with pytest.raises(SystemExit) as done:
        run_command_line(app)
    assert done.value.code == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "interrupted\n"


def test_a_ctrl_c_python_swallowed_still_exits_130(capsys: pytest.CaptureFixture[str]) -> None:
    """A KeyboardInterrupt raised in a weakref callback is printed and ignored by Python;
    the command would finish with 0. The one main remembers it."""

    class Thing:
        pass

    def app() -> None:
        thing = Thing()
        weakref.finalize(thing, lambda: signal.raise_signal(signal.SIGINT))
        try:
            del thing
            gc.collect()
            for _ in range(500):  # the interrupt is raised again here, in the main thread
                time.sleep(0.01)
        except KeyboardInterrupt:  # a command that swallows it too, exiting 0
            raise SystemExit(0) from None
        pytest.fail("the swallowed Ctrl-C was not raised again in the main thread")

    with pytest.raises(SystemExit) as done:
        run_command_line(app)
    assert done.value.code == EXIT_INTERRUPTED
    assert "interrupted" in capsys.readouterr().err


def test_both_command_lines_share_the_one_main(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[object] = []
    monkeypatch.setattr(analysis.cli, "run_command_line", seen.append)
    monkeypatch.setattr(recorder.cli.app, "run_command_line", seen.append)
    analysis.cli.main()
    recorder.cli.app.main()
    assert seen == [analysis.cli.app, recorder.cli.app.app]


def test_a_ctrl_c_typer_turns_into_a_silent_130_is_said_once(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Typer turns a KeyboardInterrupt outside handle_errors into exit 130 without a word
    (an analyst's Ctrl-C while a run prints its summary): the one main says it."""
    app = typer.Typer()

    @app.command()
    def printing() -> None:
        typer.echo("twopose: 2 session(s)")
        signal.raise_signal(signal.SIGINT)  # a real Ctrl-C, through our handler

    with pytest.raises(SystemExit) as done:
        run_command_line(lambda: app(args=[], prog_name="twopose-analyze"))
    assert done.value.code == EXIT_INTERRUPTED
    said = capsys.readouterr()
    assert said.out == "twopose: 2 session(s)\n"
    assert said.err == "interrupted\n"


def test_a_ctrl_c_handle_errors_said_is_not_said_again(capsys: pytest.CaptureFixture[str]) -> None:
    app = typer.Typer()

    @app.command()
    def analysing() -> None:
        with handle_errors():
            signal.raise_signal(signal.SIGINT)

    with pytest.raises(SystemExit) as done:
        run_command_line(lambda: app(args=[], prog_name="twopose-analyze"))
    assert done.value.code == EXIT_INTERRUPTED
    assert capsys.readouterr().err == "interrupted\n"
