"""The twopose exception hierarchy.

Every error a user can cause (a bad file, a bad typed value, a bad scene) is a
:class:`TwoposeError` whose message says what went wrong and what to do about it.
Only the command-line layers turn these into exit codes.
"""

from __future__ import annotations

__all__ = [
    "InputValueError",
    "SceneError",
    "SessionExistsError",
    "SessionFormatError",
    "SessionVersionError",
    "TwoposeError",
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


#: Exit codes of the command-line tools (documented in the README).
EXIT_OK = 0
EXIT_SOME_INPUTS_FAILED = 1
EXIT_USAGE = 2  # click/typer's own code for a malformed command line
EXIT_ERROR = 3
EXIT_INTERRUPTED = 130
