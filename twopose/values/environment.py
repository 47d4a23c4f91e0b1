"""Every setting twopose reads from the environment at run time, declared once.

A setting read from the environment is an input like any option: the analysis of a session
depends on the limits it decodes within. So each one is declared here, once, with its
default and whether a result depends on it, and read only through its declaration
(:meth:`EnvironmentSetting.read`): the code that applies a limit and the analysis cache's
key (:func:`results_environment`, read by :mod:`analysis.batch.cache`) read the same
list, so a setting added here is in the key without a second edit, and
``tests/twopose/test_environment.py`` checks that no module of ``twopose/``, ``recorder/``
or ``analysis/`` reads the environment any other way.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

__all__ = [
    "DEBUG",
    "ENVIRONMENT",
    "MAX_CHUNK_MB",
    "MAX_IMAGE_MPIX",
    "NOISE_DIR",
    "XDG_DATA_HOME",
    "EnvironmentSetting",
    "markdown_table",
    "results_environment",
]


@dataclass(frozen=True, kw_only=True)
class EnvironmentSetting:
    """One environment variable twopose reads: its name, its default, what it does.

    ``shapes_results``: whether a session's tables can differ with it (then it is in the
    analysis cache's key: a re-run under another value analyses again). ``numeric``: its
    value is a number (an unreadable one is the default, as if unset); else any text, and
    only whether it is set and not empty counts. ``example``: a value other than the
    default, for the tests that set each setting.
    """

    name: str
    default: float | None
    help: str
    shapes_results: bool
    example: str
    numeric: bool = True
    unit: str = ""  # of a number: how the docs say its default
    #: Of a text setting (a folder): what stands in when it is unset, as the docs say it.
    otherwise: str = ""

    def read(self) -> float | None:
        """Its value now.

        The number given (a typo keeps the default), or, for a switch, 1.0 when set to
        anything but the empty string and None when not.
        """
        text = os.environ.get(self.name)
        if not self.numeric:
            return 1.0 if text else None
        if text is None:
            return self.default
        try:
            return float(text)
        except ValueError:
            return self.default

    def text(self) -> str | None:
        """Its text now, for a setting that names something (a folder).

        None when unset or empty.
        """
        return os.environ.get(self.name) or None


#: The largest image decoded (megapixels): a frame over it is a rejected frame.
MAX_IMAGE_MPIX = EnvironmentSetting(
    name="TWOPOSE_MAX_IMAGE_MPIX",
    default=50.0,
    help="the largest image decoded, in megapixels (a frame declaring more is rejected)",
    shapes_results=True,
    example="0.1",
    unit="megapixels",
)
#: The largest chunk decompressed (MB): a session with a larger one is refused.
MAX_CHUNK_MB = EnvironmentSetting(
    name="TWOPOSE_MAX_CHUNK_MB",
    default=256.0,
    help="the largest chunk of a session file decompressed, in MB (a larger one is refused)",
    shapes_results=True,
    example="0.01",
    unit="MB",
)
#: Show the traceback of an error no check foresaw (for a bug report).
DEBUG = EnvironmentSetting(
    name="TWOPOSE_DEBUG",
    default=None,
    help="show the traceback of an unexpected error (any non-empty value)",
    shapes_results=False,  # what an error prints, never a table
    example="1",
    numeric=False,
)
#: The folder of the operators' noise files (the recorder's live result:
#: recorder.live.operator_noise).
NOISE_DIR = EnvironmentSetting(
    name="TWOPOSE_NOISE_DIR",
    default=None,
    help="the folder of the operators' noise files, the recorder's live result's prior",
    shapes_results=False,  # the recorder's live result; the analysis never reads it
    example="/tmp/twopose-operators",
    numeric=False,
    otherwise="`$XDG_DATA_HOME/twopose/operators`",
)
#: Where a user's data lives (the XDG convention), when ``TWOPOSE_NOISE_DIR`` is unset.
XDG_DATA_HOME = EnvironmentSetting(
    name="XDG_DATA_HOME",
    default=None,
    help="the user's data folder (the XDG convention), under which the noise files go "
    "when `TWOPOSE_NOISE_DIR` is unset",
    shapes_results=False,
    example="/tmp/xdg-data",
    numeric=False,
    otherwise="`~/.local/share`",
)

#: Every environment setting, in the order the docs list them.
ENVIRONMENT: tuple[EnvironmentSetting, ...] = (
    MAX_IMAGE_MPIX,
    MAX_CHUNK_MB,
    DEBUG,
    NOISE_DIR,
    XDG_DATA_HOME,
)


def results_environment() -> dict[str, float | None]:
    """The value of every setting a result depends on, as read now, by name.

    What the analysis cache keys a session's tables by.
    """
    return {s.name: s.read() for s in ENVIRONMENT if s.shapes_results}


def markdown_table() -> str:
    """The table of :data:`ENVIRONMENT` as docs/bad-input.md shows it, one row a setting."""
    head = (
        "| variable | default | what it sets | a re-run under another value |\n"
        "| --- | --- | --- | --- |\n"
    )
    rows = []
    for s in ENVIRONMENT:
        default = f"{s.default:g} {s.unit}" if s.default is not None else s.otherwise or "unset"
        rerun = "analyses again" if s.shapes_results else "reuses the analysis"
        rows.append(f"| `{s.name}` | {default} | {s.help} | {rerun} |")
    return head + "\n".join(rows) + "\n"
