"""Which of ``new``'s options need which: an option given where it has no effect is refused.

What the operator gives is used or refused, never dropped (issue 55). Each rule names the
options it refuses, when they would have no effect in the combination given, and why, in
words that say what to do. ``twopose-record new`` checks them before anything is asked or
recorded (:func:`refuse_idle`); a board session's guidance options and ``--plan`` with
``--ui`` are refused where they always were (:mod:`recorder.cli.app`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from twopose.errors import InputValueError

__all__ = ["Combination", "refuse_idle"]


@dataclass(frozen=True, kw_only=True)
class Combination:
    """What ``new`` was given: the options given (by their names) and what they mean."""

    given: frozenset[str]
    #: The source's kind asks a camera for a frame rate (``camera:N``).
    source_takes_fps: bool = True
    #: A stop rule's precision: ``--target-precision``, or the continued session's.
    target: bool = False
    #: Where the target comes from, for the words ("--target-precision", a file's name).
    target_from: str = "--target-precision"
    continued: str = ""  # the continued session's file name ("": none)


@dataclass(frozen=True, kw_only=True)
class _Rule:
    options: tuple[str, ...]
    idle: Callable[[Combination], bool]  # they would have no effect
    why: Callable[[Combination], str]


#: What a plan sets itself: given with ``--plan`` they would be ignored.
_PLAN_SETS = (
    "--method", "--units", "--calibration", "--focal", "--principal", "--ground-height",
    "--plane-offset", "--ground-truth", "--board", "--square", "--board-corner", "--notes",
    "--frames", "--poses", "--width", "--height",
)  # fmt: skip

_RULES: tuple[_Rule, ...] = (
    _Rule(
        options=_PLAN_SETS,
        idle=lambda c: "--plan" in c.given,
        why=lambda _: (
            "a plan sets these itself (method, units, [camera], ground_height or plane_offset, "
            "ground_truth, "
            "[board], notes, frames, each trial's poses): leave them out or write them in "
            "the plan"
        ),
    ),
    _Rule(
        options=("--operator",),
        idle=lambda c: "--plan" in c.given and not c.continued,
        why=lambda _: (
            "a plan names its operator itself (operator = ...); --operator names who records "
            "a continuation (--continue): leave it out or write it in the plan"
        ),
    ),
    _Rule(
        options=("--square", "--board-corner", "--width", "--height"),
        idle=lambda c: bool(c.continued) and "--plan" not in c.given,
        why=lambda c: (
            f"a continuation keeps the setup of {c.continued} (its board, its "
            "camera and image size); leave them out"
        ),
    ),
    _Rule(
        options=("--focal", "--principal", "--width", "--height"),
        idle=lambda c: "--calibration" in c.given,
        why=lambda _: (
            "the calibration file gives the camera's focal length, principal point "
            "and image size; leave them out, or the calibration"
        ),
    ),
    _Rule(
        options=("--live-port",),
        idle=lambda c: "--live" not in c.given,
        why=lambda _: (
            "the port of the live view, which --live serves: give --live too, or leave it out"
        ),
    ),
    _Rule(
        options=("--port", "--host"),
        idle=lambda c: "--ui" not in c.given,
        why=lambda _: (
            "where the browser console listens, which --ui serves: give --ui too, or leave them out"
        ),
    ),
    _Rule(
        options=("--fps",),
        idle=lambda c: not c.source_takes_fps,
        why=lambda _: (
            "a frame rate is asked of a camera (--source camera:N); this source "
            "keeps its own: leave it out"
        ),
    ),
    _Rule(
        options=("--min-gain", "--max-poses"),
        idle=lambda c: not c.target and "--plan" not in c.given,
        why=lambda _: (
            "they shape the stop rule, which --target-precision sets; without one "
            "every trial has --poses poses: give --target-precision too, or leave them out"
        ),
    ),
    _Rule(
        options=("--poses",),
        idle=lambda c: c.target and "--plan" not in c.given,
        why=lambda c: (
            f"with the stop rule of {c.target_from} a trial has as many poses as it "
            "needs, at most --max-poses: leave --poses out"
            + ("" if c.continued else ", or --target-precision")
        ),
    ),
)


def refuse_idle(combination: Combination) -> None:
    """Raise :class:`InputValueError` naming the first options given that would have no
    effect in ``combination``, with the rule's reason."""
    for rule in _RULES:
        idle = [o for o in rule.options if o in combination.given]
        if idle and rule.idle(combination):
            raise InputValueError(f"{', '.join(idle)}: {rule.why(combination)}")
