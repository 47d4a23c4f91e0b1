"""The twopose exception hierarchy, the exit codes, and the one place that maps one to the other.

Every error a user can cause (a bad file, a bad typed value, a bad scene, a camera that
stops) is a :class:`TwoposeError` whose message says what went wrong and what to do about
it. Library code only raises; :func:`handle_errors`, used by both command lines, alone
turns these into messages and exit codes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = [
    "EXIT_CLOSED_PIPE",
    "EXIT_ERROR",
    "EXIT_INTERRUPTED",
    "EXIT_SOME_INPUTS_FAILED",
    "EXIT_USAGE",
    "InputValueError",
    "SceneError",
    "SessionExistsError",
    "SessionFormatError",
    "SessionVersionError",
    "SourceError",
    "TwoposeError",
    "end_on_closed_pipe",
    "handle_errors",
    "safe_console",
    "say_interrupted",
]


class TwoposeError(Exception):
    """Base class of every error twopose raises on purpose."""


class SessionFormatError(TwoposeError):
    """A session file is unreadable, corrupt, truncated or not a twopose session."""


class SessionVersionError(SessionFormatError):
    """A session file was written by a newer, incompatible format version."""


class SessionExistsError(TwoposeError):
    """Refusing to overwrite an existing session file."""


class SceneError(TwoposeError):
    """A simulator scene file has an unknown key, a wrong type or an impossible value."""


class InputValueError(TwoposeError):
    """A typed or requested value is malformed, non-finite or implausible."""


class SourceError(TwoposeError):
    """A frame source failed to open, stopped delivering frames, or timed out."""


#: Exit codes of the command-line tools (documented in the README and docs/commands.md).
EXIT_SOME_INPUTS_FAILED = 1
EXIT_USAGE = 2  # click/typer's own code for a malformed command line
EXIT_ERROR = 3
EXIT_INTERRUPTED = 130
#: The shell's code for a process whose output pipe closed (128 + SIGPIPE): ``run ... |
#: head -1`` stopped once ``head`` had its line.
EXIT_CLOSED_PIPE = 141


@contextmanager
def handle_errors() -> Iterator[None]:
    """Turn twopose errors into a one-line message and an exit code (the CLIs' only place)."""
    import typer  # only the command lines need it

    global _said_interrupted
    _said_interrupted = False  # a new command (CliRunner and notebooks run many a process)
    try:
        yield
    except TwoposeError as err:
        typer.secho(f"error: {err}", err=True, fg=typer.colors.RED)
        raise typer.Exit(EXIT_ERROR) from None
    except KeyboardInterrupt:
        say_interrupted()
        raise typer.Exit(EXIT_INTERRUPTED) from None
    except BrokenPipeError:  # stdout's reader is gone (`... | head -1`): nothing to say
        end_on_closed_pipe()
    except (MemoryError, RecursionError, OverflowError, ArithmeticError, ValueError) as err:
        # Last resort: an input no check foresaw. Say what happened, never a traceback;
        # TWOPOSE_DEBUG=1 shows it for a bug report.
        from twopose.values.environment import DEBUG

        if DEBUG.read():
            raise
        typer.secho(
            f"error: unexpected {type(err).__name__}: {err} (an input twopose does not check "
            "yet: please report it with the command; TWOPOSE_DEBUG=1 shows the details)",
            err=True,
            fg=typer.colors.RED,
        )
        raise typer.Exit(EXIT_ERROR) from None


def end_on_closed_pipe() -> None:
    """End a command whose stdout nobody reads any more with :data:`EXIT_CLOSED_PIPE`.

    Quietly: stdout is pointed at /dev/null, so that Python's last flush of what is left
    unprinted cannot fail again with a traceback.
    """
    import os
    import sys

    import typer

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is no file (a test runner): nothing to flush
        pass
    raise typer.Exit(EXIT_CLOSED_PIPE)


_interrupted = False
_said_interrupted = False


def say_interrupted(text: str = "interrupted") -> None:
    """Say on stderr, once per command, that a Ctrl-C stopped it (``text``: what it left)."""
    import sys

    global _said_interrupted
    if not _said_interrupted:
        _said_interrupted = True
        sys.stderr.write(f"{text}\n")
        sys.stderr.flush()


def _on_interrupt(_signum: int, _frame: object) -> None:
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def watch_interrupts(*, hangup: bool = False) -> None:
    """Remember a Ctrl-C (or SIGTERM) even where Python swallows its KeyboardInterrupt.

    Remember a Ctrl-C even where Python swallows the KeyboardInterrupt it raises (in a
    finalizer or weakref callback it is printed and ignored, and the command would then
    finish with 0): :func:`interrupted` tells the command line to exit with 130. Such a
    KeyboardInterrupt is raised again in the main thread (without its traceback), so the
    command stops there and then, not at its end. ``hangup``: SIGHUP (the terminal closed)
    too, unless the process was started ignoring it (``nohup``); ``twopose-record``'s.
    """
    import signal
    import sys

    signal.signal(signal.SIGINT, _on_interrupt)
    # SIGTERM (kill, a CI runner's timeout, a service manager) stops a command as Ctrl-C
    # does: files closed, a run's staged outputs discarded, exit 130; never a process
    # ended mid-write.
    signal.signal(signal.SIGTERM, _on_interrupt)
    if hangup and hasattr(signal, "SIGHUP") and signal.getsignal(signal.SIGHUP) != signal.SIG_IGN:
        signal.signal(signal.SIGHUP, _on_interrupt)
    sys.unraisablehook = _unraisable


def _unraisable(info: object) -> None:
    """Raise again a Ctrl-C that Python could only print (``sys.unraisablehook``).

    ``sys.unraisablehook``: a Ctrl-C raised where Python can only print it is raised again
    where it can stop the command; anything else is printed as Python would.
    """
    import sys

    if isinstance(getattr(info, "exc_value", None), KeyboardInterrupt):
        import _thread
        import threading

        # Our SIGINT handler runs again in the main thread, once this hook has returned
        # (raised from within the hook, it would be swallowed all the same). A second
        # interrupt landing inside this hook must not stop it from doing so: Python would
        # ignore the hook's own exception, and the command would finish 0 (seen once in CI).
        try:
            threading.Timer(0.01, _thread.interrupt_main).start()
        except BaseException:
            _thread.interrupt_main()
        return
    sys.__unraisablehook__(info)  # type: ignore[arg-type]


def interrupted() -> bool:
    return _interrupted


def safe_console() -> None:
    """Make the output streams escape what they cannot encode.

    The command lines' output streams escape what they cannot encode (a file name that is
    not valid UTF-8 is printed escaped, never a crash).
    """
    import sys

    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            reconfigure(errors="backslashreplace")


def run_command_line(app: Callable[[], object]) -> None:
    """The one ``main`` of both command lines.

    For ``twopose-record`` and ``twopose-analyze``: output streams that never crash on a file name,
    a Ctrl-C anywhere exits 130 with one line (even one Python swallowed in a finalizer,
    :func:`watch_interrupts`), and every other exit is the command's own (:func:`handle_errors`
    turns a :class:`TwoposeError` into its message and exit code inside each command).
    """
    global _said_interrupted
    _said_interrupted = False
    safe_console()
    watch_interrupts()
    try:
        app()
    except KeyboardInterrupt:  # Ctrl-C outside a command's own handling: still 130
        say_interrupted()
        raise SystemExit(EXIT_INTERRUPTED) from None
    except SystemExit as done:
        # A Ctrl-C swallowed along the way (exit 0), or one typer turned into a silent 130
        # (outside handle_errors): 130, and said, once.
        if interrupted() and done.code in (0, None, EXIT_INTERRUPTED):
            say_interrupted()
            raise SystemExit(EXIT_INTERRUPTED) from None
        raise
