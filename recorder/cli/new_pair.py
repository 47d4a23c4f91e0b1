"""``twopose-record new OUT.mcap --pair PAIR.toml --source pair:A,B``: stream trials of a pair.

What ``new`` runs when given ``--pair`` (:func:`new_pair`): the options that have no effect
with a pair are refused in words (the pair file gives both cameras; a stream types no pose;
a plan sets the setup), the setup asked at the terminal for what was not given
(:func:`recorder.procedure.stream_terminal.ask_pair_setup`), then the recording at the
terminal (with ``--plan``: its trials and scheduled touches) or in the browser (``--ui``).
``new --continue S.mcap`` of a two-camera session comes here too, with or without
``--pair``: its pair and setup are the session's (:mod:`recorder.setup.pair_continuation`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from twopose.errors import EXIT_ERROR, EXIT_INTERRUPTED, InputValueError

if TYPE_CHECKING:
    from recorder.setup.continuation import Continued

__all__ = ["PAIR_IDLE", "is_pair_session", "new_pair"]

#: The options of ``new`` without effect with ``--pair``, and why.
PAIR_IDLE: dict[str, str] = {
    **dict.fromkeys(
        ("--calibration", "--focal", "--principal", "--width", "--height"),
        "the pair file gives both cameras' intrinsics and image size",
    ),
    **dict.fromkeys(
        ("--frames", "--adaptive-frames", "--poses", "--max-poses", "--target-precision"),
        "a stream trial types no pose: its frames flow at the cameras' rate",
    ),
    **dict.fromkeys(
        ("--reach", "--grid", "--target-distance", "--min-gain"),
        "a stream trial types no pose: its frames flow at the cameras' rate",
    ),
    "--ground-truth": "a stream trial's truth is its touches' grid points",
    **dict.fromkeys(
        ("--board", "--square", "--board-corner"),
        "a pair is calibrated by calibrate-pair, not by a board session",
    ),
    "--plane-offset": "give the floor's height as --ground-height (or the pair file's floor)",
    "--rig": "a rig corrects one camera's typed poses; a pair has none",
    **dict.fromkeys(("--live", "--live-port"), "the Foxglove live view is for one camera"),
}
#: The setup options a continuation takes from its session (given, they are refused).
_SETUP = ("--method", "--units", "--ground-height", "--plane-offset")
#: What a pair's plan sets itself (given with ``--plan`` they would be ignored).
_PLAN_SETS = ("--method", "--units", "--ground-height", "--operator", "--notes")


def is_pair_session(path: Path) -> bool:
    """Whether ``path`` is a two-camera session (it stores a pair): what its continuation
    records (False for anything else, which the continuation's own checks then say)."""
    from twopose.errors import TwoposeError
    from twopose.format.reader import SessionReader

    try:
        with SessionReader(path) as reader:
            return reader.pair is not None
    except (TwoposeError, OSError):
        return False


def new_pair(
    out: Path, pair: Path | None, source: str, given: dict[str, Any], *, plan: Path | None,
    ui: bool,
) -> int:  # fmt: skip
    """``new --pair`` (the module docstring), or ``new --continue S.mcap`` of a two-camera
    session (``pair`` then None, or checked to be the session's); ``given`` every option of
    ``new`` by its name (None, False or []: not given). Its exit code: 0, 3 when a camera
    stopped (an error), 130 when interrupted."""
    from recorder.procedure.new_session import _prompt, continued_session, say_fork
    from recorder.procedure.stream_terminal import record_pair
    from recorder.procedure.terminal import Operator
    from recorder.setup.pair_continuation import ONE_CAMERA_WITH_PAIR, refuse_one_camera_source
    from recorder.sources.registry import kind_of

    named = {k for k, v in given.items() if v not in (None, False, [])}
    continued = continued_session(
        given.get("--continue"), operator=given.get("--operator"),
        **{k.lstrip("-").replace("-", "_"): given.get(k) for k in _SETUP if k in named},
    )  # fmt: skip
    if continued is not None and continued.pair is None:
        raise InputValueError(f"--continue {continued.path}: {ONE_CAMERA_WITH_PAIR}")
    if continued is not None and kind_of(source).cameras != 2:
        refuse_one_camera_source(continued, source)
    parts = _parts(source)  # a pair source, its two parts found, before any question
    idle = [k for k in PAIR_IDLE if k in named]
    if idle:
        raise InputValueError(f"{', '.join(idle)}: not with --pair ({PAIR_IDLE[idle[0]]})")
    if plan is not None:
        planned = [k for k in _PLAN_SETS if k in named]
        if planned:
            raise InputValueError(
                f"{', '.join(planned)}: the plan sets these itself (method, units, "
                "ground_height, operator, notes): leave them out or write them in the plan"
            )
        if ui:
            raise InputValueError("--plan records at the terminal; --ui in the browser: one")
    if "--fps" in named and not any(kind_of(part).takes_fps for part in parts):
        raise InputValueError(
            "--fps: a frame rate is asked of a camera (pair:camera:0,camera:1); these "
            "sources keep their own: leave it out"
        )
    for option in ("--port", "--host"):
        if option in named and not ui:
            raise InputValueError(f"{option}: where the console listens, which --ui serves")
    op = Operator(_prompt, typer.echo)
    asked = {
        "method": given.get("--method"), "units": given.get("--units"),
        "ground_height": given.get("--ground-height"), "operator": given.get("--operator"),
    }  # fmt: skip
    if ui:
        say_fork(continued)
        _serve(out, pair, source, op, asked, given, continued)
        return 0
    summary = record_pair(
        out, pair, source, op, plan_path=plan, given=asked, notes=given.get("--notes") or "",
        fps=given.get("--fps"), continued=continued,
    )  # fmt: skip
    typer.echo(summary.line())
    if summary.interrupted:
        typer.secho("interrupted", err=True)
        return EXIT_INTERRUPTED
    return EXIT_ERROR if summary.stopped else 0


def _parts(source: str) -> tuple[str, str]:
    """The pair's two sources, each one the registry knows (not opened: a file that is not
    there is said now); a source that is not a pair is refused."""
    from recorder.sources.registry import (
        SOURCE_KINDS,
        SourceOptions,
        kind_of,
        open_pair,
        parse_pair,
    )

    if kind_of(source).cameras != 2:
        raise InputValueError(
            f"--pair records two cameras: give --source pair:A,B (pair:camera:0,camera:1), "
            f"not {source}"
        )
    parts = parse_pair(source.partition(":")[2], SOURCE_KINDS)
    open_pair(*parts, SourceOptions())  # made, not opened: each part's own checks
    return parts


def _serve(
    out: Path, pair_path: Path | None, source: str, op: Any, asked: dict[str, Any],
    given: dict[str, Any], continued: Continued | None,
) -> None:  # fmt: skip
    """``new --pair --ui``: the setup asked here (a continuation's: its session's), then
    the console's stream trials."""
    from recorder.console.server import ConsoleOptions, serve_console
    from recorder.procedure.machine import refuse_existing
    from recorder.procedure.stream_terminal import PairSetup, ask_pair_setup
    from twopose.pair.pair_file import read_pair_file

    refuse_existing(out)
    if continued is not None:
        setup = PairSetup.continuing(continued, pair_path, operator=asked["operator"])
        pair = setup.session_pair(None)
    else:
        assert pair_path is not None  # new --pair: the one way here without --continue
        pair = read_pair_file(pair_path)
        setup = ask_pair_setup(op, pair, **asked)
        pair = setup.session_pair(pair)
    options = ConsoleOptions(
        source=source, given={}, fps=given.get("--fps") or 30.0,
        notes=given.get("--notes") or "", pair=pair, pair_setup=setup,
    )  # fmt: skip
    serve_console(
        out, options, host=given.get("--host") or "127.0.0.1", port=given.get("--port") or 0
    )
