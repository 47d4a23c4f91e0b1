"""What ``twopose-record new`` runs once its options are read: the terminal's dialogue, a
plan, or the browser console, each from one :class:`NewRequest` (one call from Python too)."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from recorder.procedure import stops
from twopose.errors import InputValueError
from twopose.values.bounds import shown

if TYPE_CHECKING:
    from recorder.live.view import LiveView
    from recorder.procedure.capture import CaptureResult
    from recorder.procedure.summary import RecordingSummary
    from recorder.setup.continuation import Continued
    from recorder.setup.rules import GuidanceAsked
    from twopose.camera.model import Camera
    from twopose.rig.constants import RigConstants
    from twopose.uncertainty.noise import PlacingSigma

__all__ = [
    "CameraMode",
    "NewRequest",
    "continued_given",
    "continued_session",
    "guidance_asked",
    "record_planned",
    "record_terminal",
    "rig_file",
    "say_fork",
    "serve_console_until_stopped",
]


@dataclass(frozen=True, kw_only=True)
class CameraMode:
    """What ``new`` asks of the camera (``--width``, ``--height``, ``--fps``)."""

    width: int = 640
    height: int = 480
    fps: float = 30.0


@dataclass(frozen=True, kw_only=True)
class NewRequest:
    """What ``new`` records, whichever way it runs (terminal, ``--plan``, ``--ui``)."""

    out: Path
    source: str
    frames: int = 5
    adaptive_frames: bool = False  # --adaptive-frames: ``frames`` is then the most
    poses: int = 2
    camera: CameraMode = CameraMode()
    notes: str = ""
    rig: RigConstants | None = None
    #: The rig file's measured placing sigma (its ``[placing]``; None: typed).
    placing: PlacingSigma | None = None
    live_port: int | None = None  # --live: serve the Foxglove live view on this port
    guidance: GuidanceAsked | None = None  # the next pose suggested; the stop rule
    continued: Continued | None = None  # --continue: the session this one continues


def guidance_asked(
    max_poses: int | None = None, reach: float | None = None, spacing: float | None = None,
    target_distance: float | None = None, min_gain: float | None = None,
) -> GuidanceAsked:  # fmt: skip
    from recorder.setup.rules import GuidanceAsked

    return GuidanceAsked(
        max_poses=max_poses, reach=reach, spacing=spacing, target_distance=target_distance,
        min_gain=min_gain,
    )  # fmt: skip


def continued_session(
    path: Path | None, *, operator: str | None = None, **setup: object
) -> Continued | None:
    """``--continue``: the session continued, read once; the setup options are its.

    ``--operator`` is who records the continuation (a part of its own, perhaps another
    day or another laptop): recorded as this file's operator, the session's otherwise.
    When a file beside it already continues the same part, :func:`say_fork` says so once
    the command's checks have passed (a refused command announces no branch).
    """
    if path is None:
        return None
    given = [f"--{k.replace('_', '-')}" for k, v in setup.items() if v not in (None, [])]
    if given:
        raise InputValueError(
            f"{', '.join(given)}: a continuation keeps the setup of {path}; leave them out"
        )
    from recorder.setup.continuation import read_continued

    return read_continued(path, operator=operator)


def say_fork(continued: Continued | None) -> None:
    """Say, once, that this recording starts a branch of the session (another file
    already continues the same part): on every path (terminal, ``--plan``, ``--ui``, a
    pair's), after its checks and before it asks or records."""
    if continued is not None and continued.fork_warning is not None:
        typer.secho(f"warning: {continued.fork_warning}", fg=typer.colors.YELLOW, err=True)


def continued_given(
    continued: Continued, target_precision: float | None, *, guidance: str = ""
) -> dict[str, Any]:
    """The browser's setup form, filled with the continued session's setup (read-only,
    each field said to come from its file); the stop rule (the file's unless
    ``--target-precision`` is given) and the operator (``--operator``, else the file's)
    are the continuation's own, the page's to change unless the command line gave them.
    ``guidance``: the guidance settings taken from the session, in words (the page says
    them with what it continues)."""
    from recorder.setup.form import SETUP_FIELDS
    from recorder.setup.rules import Setup

    setup = Setup.of(continued)
    k = setup.intrinsics
    name = continued.path.name
    own = {"operator": continued.operator, "target_precision": target_precision}
    prefill = {"operator": setup.operator, "target_precision": continued.target95}
    return {
        "method": setup.method.value, "units": setup.units, "intrinsics": k,
        "intrinsics_sigma": setup.intrinsics_sigma, "focal": None, "principal": None,
        **setup.plane_offsets(), "ground_truth": list(setup.ground_truth),
        "board": setup.board, **own,
        # Where each fixed field comes from, and what the page fills in for the others.
        "given_from": {f.name: name for f in SETUP_FIELDS if f.name not in own},
        "prefill": {k: (v, name) for k, v in prefill.items() if v is not None},
        "continuing": {
            "file": name, "path": str(continued.path), "after_trial": continued.last_trial,
            "next_trial": continued.next_trial, "target95": continued.target95,
            "guidance": guidance,  # the guidance settings taken from it, in words
        },
    }  # fmt: skip


def rig_file(path: Path | None) -> dict[str, Any]:
    """``--rig``: the :class:`NewRequest` fields the rig file gives (its constants, ``rig``,
    and its measured placing sigma, ``placing``; None without a file)."""
    from twopose.rig.file import load_rig_file

    if path is None:
        return {"rig": None, "placing": None}
    found = load_rig_file(path)
    return {"rig": found.constants, "placing": found.placing}


def _live_view(stack: contextlib.ExitStack, cameras: list[Camera], port: int) -> LiveView:
    from recorder.live.view import LiveView

    view = stack.enter_context(LiveView(cameras, port=port))
    typer.echo(
        f"live view on {view.url}: in Foxglove, Open connection > Foxglove WebSocket", err=True
    )
    return view


def _report_capture(trial: int, pose: int, result: CaptureResult) -> None:
    from recorder.procedure.terminal import capture_lines

    for fb in result.feedback:
        typer.echo(fb.line())
    from recorder.procedure.machine import Shortfall, detection_shortfall

    head, *rest = capture_lines(pose, result)
    typer.echo(f"trial {trial} {head}")
    for line in rest:
        typer.echo(line)
    if detection_shortfall(result) is not Shortfall.OK:
        typer.echo("  a plan cannot ask: this capture is recorded as accepted all the same")


def record_terminal(
    request: NewRequest, given: dict[str, Any], stack: contextlib.ExitStack
) -> RecordingSummary:
    """Ask for whatever the options did not give (``given``: :func:`console_given`), then
    run the guided procedure."""
    stack.enter_context(stops.handled())  # every stop closes the file
    from recorder.procedure.capture import AdaptiveFrames, CaptureSettings
    from recorder.procedure.terminal import Operator, ask_setup, record_interactive
    from recorder.setup.rules import PoseTyping, Setup, check_rig
    from recorder.sources.registry import open_source

    mode = request.camera
    op = Operator(_prompt, typer.echo)
    if request.continued is not None:
        c = request.continued
        typer.echo(
            f"continuing {c.path} after trial {c.last_trial}: the next trial is {c.next_trial}"
        )
        # The continued session's setup, with the continuation's own stop rule (the
        # file's unless --target-precision gives another).
        target = given["target_precision"]
        if target is None:
            target = request.continued.target95
        setup = replace(Setup.of(request.continued), target95=target)
        rule = "none" if target is None else f"95% within {shown(target)} {setup.units}"
        kept = target is not None and given["target_precision"] is None
        said = f" ({c.path.name}'s)" if kept else ""
        typer.echo(f"  operator {setup.operator or '(none)'}; stop rule: {rule}{said}")
    else:
        setup = ask_setup(
            op, size=(mode.width, mode.height), guidance=request.guidance, rig=request.rig,
            **given,
        )  # fmt: skip
    check_rig(request.rig, setup.method, setup.units, [setup.camera()], setup.ground())
    asked = request.guidance or guidance_asked()
    refused = asked.refusals(setup.method, setup.units)  # a continued board session's
    if refused:
        raise InputValueError("; ".join(refused.values()))
    guidance = asked.guidance(setup.units, request.poses, setup.target95)
    size = setup.intrinsics  # --width/--height, a calibration's or a continued session's
    src = open_source(
        request.source, method=setup.method, width=size.width, height=size.height,
        fps=mode.fps, units=setup.units,  # the scene in the session's units, through its camera
        cameras=[setup.camera()],
    )  # fmt: skip
    port = request.live_port
    view = _live_view(stack, [setup.camera()], port) if port is not None else None
    capture = CaptureSettings(
        frames=request.frames, live=view, rig=request.rig, placing=request.placing,
        guidance=guidance,
        adaptive=AdaptiveFrames.asked(setup.method, asked=request.adaptive_frames),
    )  # fmt: skip
    return record_interactive(
        request.out,
        src,
        op,
        setup=setup,
        notes=request.notes,
        capture=capture,
        typing=PoseTyping(poses_per_trial=guidance.max_poses),
        continued=request.continued,
    )


def record_planned(
    request: NewRequest, plan: Path, stack: contextlib.ExitStack
) -> RecordingSummary:
    """``new --plan``: the plan recorded, each capture and live result printed."""
    stack.enter_context(stops.handled())  # every stop closes the file
    from recorder.setup.plan import load_plan, record_plan
    from recorder.setup.rules import check_rig
    from recorder.sources.registry import open_source

    the_plan = load_plan(plan)
    if request.continued is not None:  # the session's guidance, where the plan gives none
        from recorder.setup.plan_file import continued_plan

        the_plan, said = continued_plan(the_plan, request.continued.guidance)
        if said:
            typer.echo(f"guidance from {request.continued.path.name}: {', '.join(said)}")
    check_rig(request.rig, the_plan.method, the_plan.units, the_plan.cameras, the_plan.ground())
    mode = request.camera
    recorded = request.continued.cameras if request.continued else the_plan.cameras
    size = recorded[0].intrinsics  # the size recorded is the size asked of a camera
    src = open_source(
        request.source, method=the_plan.method, width=size.width, height=size.height,
        fps=mode.fps, units=the_plan.units,  # the scene in the plan's units, through its cameras
        cameras=recorded,
    )  # fmt: skip
    if request.continued is not None:
        request.continued.check_plan(the_plan.method, the_plan.units)
        say_fork(request.continued)
    cameras = list(the_plan.cameras)
    view = _live_view(stack, cameras, request.live_port) if request.live_port is not None else None
    return record_plan(
        the_plan,
        request.out,
        src,
        on_capture=_report_capture,
        live=view,
        on_result=lambda result: typer.echo(f"  result: {result.text()}"),
        rig=request.rig,
        placing=request.placing,
        on_advice=lambda trial, advice: typer.echo(f"  guidance: trial {trial}: {advice.text}"),
        continued=request.continued,
    )


def serve_console_until_stopped(
    request: NewRequest, given: dict[str, Any], *, host: str, port: int
) -> None:
    """The web console until Ctrl-C or SIGTERM. The recording thread prints the summary,
    once, when the session ends; an interrupted session exits 130 (KeyboardInterrupt, as
    the terminal's), a failed one 3."""
    from recorder.console.server import ConsoleOptions, serve_console
    from recorder.setup.rules import check_rig_early
    from twopose.values.units import Units

    mode = request.camera
    # What the command line gave refuses a rig before the page is served (the rest: the form).
    units = given.get("units")
    check_rig_early(
        request.rig, units=Units(units) if units else None, size=(mode.width, mode.height),
        intrinsics=given.get("intrinsics"),
    )  # fmt: skip
    options = ConsoleOptions(
        source=request.source, given=given, frames=request.frames, poses=request.poses,
        adaptive_frames=request.adaptive_frames,
        size=(mode.width, mode.height), fps=mode.fps, notes=request.notes, rig=request.rig,
        placing=request.placing,
        live_port=request.live_port, guidance=request.guidance, continued=request.continued,
    )  # fmt: skip
    serve_console(request.out, options, host=host, port=port)


def _prompt(question: str, default: str) -> str:
    """One question at the terminal; Ctrl-C (SIGTERM, SIGHUP) or a closed input is an
    interrupt, at once: nothing is written while the operator types."""
    try:
        with stops.interruptible():
            return str(typer.prompt(question, default=default or None, show_default=bool(default)))
    except typer.Abort:
        raise KeyboardInterrupt from None
