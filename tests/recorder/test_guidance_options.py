"""The guidance options of issue 46: the taped target distance and the information-gain
stop, read by their one bound on the command line and in a plan, and carried into the
recording's guidance."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from recorder.cli.app import app
from recorder.setup.plan import load_plan
from recorder.setup.rules import GuidanceAsked
from twopose.errors import EXIT_ERROR, EXIT_USAGE, InputValueError
from twopose.guidance.advice import MIN_GAIN as DEFAULT_MIN_GAIN
from twopose.values.bounds import MIN_GAIN, TARGET_DISTANCE, Quantity
from twopose.values.units import Units

runner = CliRunner()
_OPTION = {MIN_GAIN: "--min-gain", TARGET_DISTANCE: "--target-distance"}
_KEY = {MIN_GAIN: "min_gain", TARGET_DISTANCE: "target_distance"}


def _command_line(quantity: Quantity, text: str, tmp: Path) -> str | None:
    """``new``'s refusal of the option (None: read; the run then refuses --plan with --ui)."""
    plan = tmp / "p.toml"
    plan.touch()
    args = ["new", str(tmp / "s.mcap"), "--plan", str(plan), "--ui", "--units", "cm"]
    result = runner.invoke(app, [*args, _OPTION[quantity], text])
    if result.exit_code == EXIT_ERROR:
        return None
    assert result.exit_code == EXIT_USAGE, result.output
    line = next(li for li in result.output.splitlines() if "Invalid value" in li)
    return line.split(f"Invalid value for '{_OPTION[quantity]}': ", 1)[1]


def _plan(quantity: Quantity, text: str, tmp: Path) -> str | None:
    path = tmp / "plan.toml"
    path.write_text(
        'method = "point"\nunits = "cm"\n[guidance]\ntarget_95 = 1\n'
        f"{_KEY[quantity]} = {text}\n[[trials]]\nposes = [{{t = [0, 0, 0]}}, {{t = [1, 0, 0]}}]\n"
    )
    try:
        load_plan(path)
    except InputValueError as err:
        return str(err).removeprefix(f"plan: guidance.{_KEY[quantity]}: ")
    return None


@pytest.mark.parametrize(
    ("quantity", "text", "refused"),
    [
        (MIN_GAIN, "0.05", False),
        (MIN_GAIN, "0", False),
        (MIN_GAIN, "0.7", True),
        (MIN_GAIN, "-0.1", True),
        (TARGET_DISTANCE, "30.5", False),
        (TARGET_DISTANCE, "0", True),
        (TARGET_DISTANCE, "1.1", True),  # 11 mm typed as cm: nearer than a webcam focuses
        (TARGET_DISTANCE, "600", True),  # 508 cm is the bound
    ],
)
def test_the_command_line_and_a_plan_refuse_the_same_values_with_the_same_words(
    tmp_path: Path, quantity: Quantity, text: str, refused: bool
) -> None:
    try:
        quantity.read(text, Units.CM)
        expected = None
    except InputValueError as err:
        expected = str(err)
    assert (expected is not None) == refused
    assert _command_line(quantity, text, tmp_path) == expected
    assert _plan(quantity, text, tmp_path) == expected


def test_the_options_reach_the_recordings_guidance() -> None:
    asked = GuidanceAsked(target_distance=25.0, min_gain=0.1)
    guidance = asked.guidance(Units.CM, poses=2, target95=1.0)
    assert guidance.target_distance == 25.0
    assert guidance.min_gain == 0.1
    assert "shrink it by less than 0.1," in guidance.describe(Units.CM)
    assert "taped 25 cm" in guidance.describe(Units.CM)
    # The default least gain, with a target precision only; 0 turns it off.
    assert GuidanceAsked().guidance(Units.IN, 2, 1.0).min_gain == DEFAULT_MIN_GAIN
    assert GuidanceAsked().guidance(Units.IN, 2, None).min_gain is None
    assert GuidanceAsked(min_gain=0.0).guidance(Units.IN, 2, 1.0).min_gain is None
    with pytest.raises(InputValueError, match="target distance must be"):
        GuidanceAsked(target_distance=-1.0).guidance(Units.IN, 2, 1.0)


def test_a_plans_guidance_carries_them(tmp_path: Path) -> None:
    path = tmp_path / "plan.toml"
    path.write_text(
        'method = "point"\nunits = "in"\n[guidance]\ntarget_95 = 0.5\ntarget_distance = 12\n'
        "min_gain = 0.08\n[[trials]]\nposes = [{t = [0, 0, 0]}, {t = [1, 0, 0]}]\n"
    )
    guidance = load_plan(path).guidance
    assert guidance is not None
    assert (guidance.target_distance, guidance.min_gain) == (12.0, 0.08)
