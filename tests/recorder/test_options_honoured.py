"""Every option honoured or refused (issue 55, item 4): a continuation takes every guidance
setting its session recorded (format 1.5) and says which; an option with no effect in the
combination given is refused with the reason, each tested with and without its partner;
a value is shown back and written as it was given."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
from typer.testing import CliRunner

from analysis.cli import app as analyze
from recorder.cli.app import app as record
from recorder.cli.option_rules import Combination, refuse_idle
from recorder.console.server import ConsoleOptions, checked_setup
from recorder.console.state import ConsoleSession
from recorder.procedure.new_session import continued_given
from recorder.procedure.terminal import Operator, ask_setup
from recorder.setup.continuation import read_continued
from recorder.setup.form import FormRefusedError, form_fields, setup_from_answers
from recorder.setup.plan import load_plan
from recorder.setup.rules import GuidanceAsked, Setup
from tests.helpers import SMALL_SCENE
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import EXIT_ERROR, EXIT_INTERRUPTED, InputValueError
from twopose.format.entries import FORMAT_VERSION, GuidanceRecord, Note, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.options import read_option
from twopose.values.units import Units

runner = CliRunner()

#: A method 2 session in mm with every guidance setting given, as issue 55 saw dropped.
GIVEN = ["--target-precision", "5.0", "--grid", "1", "--reach", "2540", "--min-gain", "0",
         "--max-poses", "5", "--target-distance", "3.0e2"]  # fmt: skip
SETUP = ["--method", "ground", "--units", "mm", "--focal", "262.5", "--principal", "160,120",
         "--width", "320", "--height", "240", "--ground-height", "244.475", "--operator", "Ada",
         "--ground-truth", "48.514,244.475,212.725", "--frames", "1"]  # fmt: skip
ONE_CAPTURE = "0,0,0\n\nq\n"  # a pose, its rotation, then quit at the decision


@dataclass(frozen=True)
class Recorded:
    session: Path
    continuation: Path
    said: str  # what the continuation's `new` printed
    scene: Path


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    """S (recorded at the terminal with every guidance option) and S2 (its continuation,
    given none of them): one capture each, with the small scene's camera."""
    folder = tmp_path_factory.mktemp("honoured")
    scene = folder / "scene.toml"
    scene.write_text(SMALL_SCENE)
    session, continuation = folder / "S.mcap", folder / "S2.mcap"
    source = ["--source", f"synthetic:{scene}"]
    first = runner.invoke(record, ["new", str(session), *source, *SETUP, *GIVEN],
                          input=ONE_CAPTURE)  # fmt: skip
    assert first.exit_code == 0, first.output
    second = runner.invoke(
        record, ["new", str(continuation), "--continue", str(session), *source, "--frames", "1"],
        input=ONE_CAPTURE,
    )  # fmt: skip
    assert second.exit_code == 0, second.output
    return Recorded(session, continuation, second.output, scene)


def test_the_session_records_every_guidance_setting_as_given(recorded: Recorded) -> None:
    with SessionReader(recorded.session) as reader:
        assert reader.info.format_version == FORMAT_VERSION  # 1.5 on: the guidance recorded
        record = reader.info.guidance
    assert record == GuidanceRecord(
        target95=5.0, max_poses=5, min_gain=0.0, reach=2540.0, spacing=1.0,
        target_distance=300.0,
    )  # fmt: skip
    assert record is not None
    assert record.given == {"target_95": "5.0", "reach": "2540", "spacing": "1",
                            "target_distance": "3.0e2"}  # fmt: skip


def test_a_continuation_inherits_every_guidance_setting_and_says_which(
    recorded: Recorded,
) -> None:
    """It suggested on the 12.7 mm grid within 76.2 mm with a 10% least gain."""
    assert (
        "guidance from S.mcap: 95% within 5.0 mm, at most 5 poses, least gain 0 (none), "
        "suggested on the 1 mm grid, within 2540 mm of the first pose, the target taped "
        "3.0e2 mm from the first pose" in recorded.said
    )
    assert "stop rule: 95% within 5.0 mm (S.mcap's)" in recorded.said
    with SessionReader(recorded.session) as a, SessionReader(recorded.continuation) as b:
        first, again = a.info.guidance, b.info.guidance
    assert again == first  # what it ran with, recorded again
    assert again is not None
    assert first is not None
    assert again.given == first.given  # ... as given


def test_the_page_says_the_guidance_a_continuation_takes(recorded: Recorded) -> None:
    continued = read_continued(recorded.session)
    words = "guidance from S.mcap: 95% within 5.0 mm, at most 5 poses"
    page = ConsoleSession(recorded.continuation, continued_given(continued, None, guidance=words))
    assert page.message.startswith("Continuing S.mcap; the next trial is 2.")
    assert page.message.endswith(". Guidance from S.mcap: 95% within 5.0 mm, at most 5 poses")


@pytest.mark.parametrize(
    ("options", "changed"),
    [
        ({"reach": 100.0}, {"reach": 100.0}),
        ({"spacing": 2.0}, {"spacing": 2.0}),
        ({"max_poses": 7}, {"max_poses": 7}),
        ({"min_gain": 0.2}, {"min_gain": 0.2}),
        ({"target_distance": 500.0}, {"target_distance": 500.0}),
    ],
)
def test_an_option_given_beside_continue_replaces_that_setting_alone(
    recorded: Recorded, options: dict[str, float], changed: dict[str, float]
) -> None:
    continued = read_continued(recorded.session)
    asked, said = GuidanceAsked(**options).inherited(continued.guidance, Units.MM)  # type: ignore[arg-type]
    guidance = asked.guidance(Units.MM, 2, continued.target95)
    got = {"reach": guidance.reach.radius, "spacing": guidance.reach.spacing,
           "max_poses": guidance.max_poses, "min_gain": guidance.min_gain or 0.0,
           "target_distance": guidance.target_distance}  # fmt: skip
    assert got == {"reach": 2540, "spacing": 1, "max_poses": 5, "min_gain": 0,
                   "target_distance": 300} | changed  # fmt: skip
    assert len(said) == 4  # the four others, said


def test_a_session_without_a_stop_rule_gives_its_trials_poses(tmp_path: Path) -> None:
    record = GuidanceRecord(max_poses=3, min_gain=0.0, reach=3.0, spacing=0.5)
    asked, said = GuidanceAsked().inherited(record, Units.IN)
    assert asked.poses == 3
    assert said == [
        "3 poses a trial",
        "suggested on the 0.5 in grid",
        "within 3 in of the first pose",
    ]
    assert asked.guidance(Units.IN, asked.poses, None).max_poses == 3


def test_a_file_from_before_1_5_gives_its_guidance_by_its_note(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An older file recorded only the note (with a stop rule): it is read, every setting."""
    monkeypatch.setattr("twopose.format.entries.FORMAT_VERSION", "1.4")  # a 1.4 writer
    path = tmp_path / "old.mcap"
    k = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
    camera = Camera(camera_id="cam0", intrinsics=k)
    info = SessionInfo(method=Method.POINT, units=Units.IN, format_version="1.4")
    with SessionWriter(path, info, [camera]) as writer:
        writer.write_note(Note(text=(
            "guidance: a trial is complete once its 95% region is within 0.8 in, once the next "
            "pose would shrink it by less than 20%, or at 5 poses; next poses suggested on the "
            "0.25 in grid within 2.5 in of the first pose; the target taped 11 in from the "
            "first pose")))  # fmt: skip
    assert read_continued(path).guidance == GuidanceRecord(
        target95=0.8, max_poses=5, min_gain=0.2, reach=2.5, spacing=0.25, target_distance=11.0
    )


# --------------------------------------------------------------------------- partners


def _new(tmp: Path, *args: str) -> tuple[int, str]:
    """``new`` with ``args`` and no input: exit 3 with the refusal, or 130 when the options
    were taken (the terminal's first question found the input ended)."""
    result = runner.invoke(record, ["new", str(tmp / "x.mcap"), "--source", "synthetic", *args],
                           input="")  # fmt: skip
    assert "Traceback" not in result.output
    assert not (tmp / "x.mcap").exists()
    return result.exit_code, " ".join(result.output.split())


@pytest.mark.parametrize(
    ("alone", "partner", "why"),
    [
        (["--min-gain", "0.3"], ["--target-precision", "1"], "--min-gain: they shape the"),
        (["--max-poses", "5"], ["--target-precision", "1"], "--max-poses: they shape the"),
        (["--min-gain", "0.3", "--max-poses", "5"], ["--target-precision", "1"],
         "--min-gain, --max-poses: they shape the stop rule, which --target-precision sets"),
        (["--live-port", "9000"], ["--live"], "--live-port: the port of the live view"),
        (["--fps", "25"], ["--source", "camera:0"], "--fps: a frame rate is asked of a camera"),
    ],
)  # fmt: skip
def test_an_option_without_its_partner_is_refused_with_it_taken(
    tmp_path: Path, alone: list[str], partner: list[str], why: str
) -> None:
    """``--min-gain 0.3 --max-poses 5`` without ``--target-precision`` were ignored, the
    operator then told "2 poses, the most for a trial"."""
    code, said = _new(tmp_path, *alone)
    assert code == EXIT_ERROR, said
    assert why in said
    code, said = _new(tmp_path, *alone, *partner)
    assert code == EXIT_INTERRUPTED, said  # taken: the first question is asked
    assert "leave" not in said


@pytest.mark.parametrize(
    ("option", "against", "why"),
    [
        (["--poses", "3"], ["--target-precision", "1"], "--poses: with the stop rule of"),
        (["--focal", "500"], ["--calibration", "{cal}"], "--focal: the calibration file gives"),
        (["--width", "320"], ["--calibration", "{cal}"], "--width: the calibration file gives"),
        (["--operator", "Bo"], ["--plan", "{plan}"], "--operator: a plan names its operator"),
        (["--frames", "3"], ["--plan", "{plan}"], "--frames: a plan sets these itself"),
        (["--method", "line"], ["--plan", "{plan}"], "--method: a plan sets these itself"),
        (["--notes", "x"], ["--plan", "{plan}"], "--notes: a plan sets these itself"),
    ],
)
def test_an_option_that_another_makes_idle_is_refused_and_taken_without_it(
    tmp_path: Path, option: list[str], against: list[str], why: str
) -> None:
    """``--poses`` beside a stop rule, ``--focal`` beside a calibration and the setup
    options beside a plan were ignored."""
    files = {"{cal}": tmp_path / "cal.toml", "{plan}": tmp_path / "plan.toml"}
    for path in files.values():
        path.touch()
    against = [str(files.get(a, a)) for a in against]
    code, said = _new(tmp_path, *option, *against)
    assert code == EXIT_ERROR, said
    assert why in said
    code, said = _new(tmp_path, *option)
    assert code == EXIT_INTERRUPTED, said


@pytest.mark.parametrize("option", [["--square", "1"], ["--board-corner", "0,0,20"],
                                    ["--width", "320"], ["--height", "240"]])  # fmt: skip
def test_a_continuation_refuses_the_setup_options_it_used_to_drop(
    recorded: Recorded, tmp_path: Path, option: list[str]
) -> None:
    code, said = _new(tmp_path, "--continue", str(recorded.session), *option)
    assert code == EXIT_ERROR, said
    assert f"{option[0]}: a continuation keeps the setup of S.mcap" in said


def test_a_continuation_with_a_stop_rule_takes_min_gain_and_refuses_poses(
    recorded: Recorded, tmp_path: Path
) -> None:
    code, said = _new(tmp_path, "--continue", str(recorded.session), "--poses", "3")
    assert code == EXIT_ERROR, said
    assert "--poses: with the stop rule of S.mcap" in said
    small = f"synthetic:{recorded.scene}"
    code, said = _new(tmp_path, "--continue", str(recorded.session), "--min-gain", "0.2",
                      "--source", small)  # fmt: skip
    assert code == EXIT_INTERRUPTED, said  # S.mcap's stop rule is its partner


@pytest.mark.parametrize(
    ("given", "idle"),
    [
        ({"--port"}, True), ({"--port", "--ui"}, False), ({"--host"}, True),
        ({"--host", "--ui"}, False),
    ],
)  # fmt: skip
def test_the_consoles_address_needs_ui(given: set[str], idle: bool) -> None:
    """``--port``/``--host`` without ``--ui`` were ignored (with it the console serves)."""
    try:
        refuse_idle(Combination(given=frozenset(given)))
        refused = False
    except InputValueError as err:
        refused = "which --ui serves" in str(err)
    assert refused == idle


def test_the_console_options_without_ui_are_refused_on_the_command_line(tmp_path: Path) -> None:
    code, said = _new(tmp_path, "--port", "8081")
    assert code == EXIT_ERROR
    assert "--port: where the browser console listens, which --ui serves" in said


def test_run_refuses_jobs_with_dask(tmp_path: Path) -> None:
    result = runner.invoke(analyze, ["run", str(tmp_path), "--jobs", "2", "--dask", "tcp://x:1"])
    assert result.exit_code == EXIT_ERROR
    assert "--jobs: the Dask scheduler (--dask) runs the sessions" in " ".join(
        result.output.split()
    )


@pytest.mark.parametrize(
    ("guidance", "trial", "refused"),
    [
        ("min_gain = 0.3\n", "", "guidance.min_gain would have no effect"),
        ("max_poses = 5\n", "", "guidance.max_poses would have no effect"),
        ("max_poses = 5\n", 'poses = "guided"\n', ""),  # a guided trial takes it
        ("target_95 = 1\nmin_gain = 0.3\nmax_poses = 5\n", "", ""),
    ],
)
def test_a_plans_stop_rule_keys_need_its_target(
    tmp_path: Path, guidance: str, trial: str, refused: str
) -> None:
    poses = trial or "poses = [{t = [0, 0, 0]}, {t = [1, 0, 0]}]\n"
    path = tmp_path / "plan.toml"
    path.write_text(f'method = "point"\n[guidance]\n{guidance}[[trials]]\n{poses}')
    if refused:
        with pytest.raises(InputValueError, match=refused):
            load_plan(path)
    else:
        load_plan(path)


def test_poses_given_leaves_the_stop_rule_unasked_and_the_page_refuses_one() -> None:
    """``--poses 4`` then a target typed at the terminal: the trial ended at the target."""
    asked: list[str] = []

    def answer(question: str, default: str) -> str:
        asked.append(question)
        return default

    op = Operator(answer, lambda _s: None)
    setup = ask_setup(
        op, method=Method.POINT, units=Units.IN, intrinsics=None, focal=None, principal=None,
        size=(640, 480), ground_truth=[(0.0, 1.0, 11.0)], operator=None,
        guidance=GuidanceAsked(poses=4),
    )  # fmt: skip
    assert setup.target95 is None
    assert not any("stop a trial" in q for q in asked)
    options = ConsoleOptions(source="synthetic", given={"size": (640, 480)},
                             guidance=GuidanceAsked(poses=4))  # fmt: skip
    form = {"method": "point", "units": "in", "truth1": "0, 1, 11", "operator": "Bo",
            "target_precision": "0.5"}  # fmt: skip
    with pytest.raises(FormRefusedError) as caught:
        checked_setup(form, options)
    assert caught.value.errors["target_precision"].startswith("--poses 4 gives every trial 4")


def test_a_ground_height_for_a_method_on_no_plane_is_refused_on_every_path(
    tmp_path: Path,
) -> None:
    """``--method point --ground-height 9`` was taken and dropped (the page's too)."""
    code, said = _new(tmp_path, "--method", "point", "--ground-height", "9")
    assert code == EXIT_ERROR
    assert "--ground-height: a point session measures on no plane" in said
    code, said = _new(tmp_path, "--method", "ground", "--ground-height", "9")
    assert code == EXIT_INTERRUPTED, said
    with pytest.raises(FormRefusedError) as caught:  # the method chosen in the page
        setup_from_answers({"method": "line", "units": "in"}, {"ground_height": 9.0})
    assert caught.value.errors["method"].startswith("--ground-height: a line session measures")


# --------------------------------------------------------------------------- as given


@pytest.mark.parametrize("text", ["525.000", "1e3", "5.25e2", "+525"])
def test_a_value_given_is_shown_back_as_given(text: str) -> None:
    """``--focal 525.000`` was shown as 525, ``1e3`` as 1000."""
    read = read_option("FOCAL")
    value = read["parser"](text)
    assert str(value) == text
    fields = {f["name"]: f["value"] for f in form_fields({"method": "point", "focal": value})}
    assert fields["focal"] == text  # the page's form
    setup = Setup(
        method=Method.POINT, units=Units.IN, plane_offset=None, operator="Bo",
        intrinsics=Intrinsics(width=640, height=480, fx=value, fy=value, cx=320.0, cy=240.0),
        ground_truth=((0.0, 1.0, 11.0),),
    )  # fmt: skip
    session = ConsoleSession(Path("unused.mcap"), {})
    session.begin(setup, None)
    assert session.session_setup["camera"].startswith(f"f {text} px")


def test_the_pages_setup_line_shows_the_typed_truth_unrounded() -> None:
    """``4.8514,24.4475,21.2725`` read (4.851, 24.448, 21.273) on the setup line."""
    from recorder.setup.rules import parse_vector

    truth = parse_vector("4.8514,24.4475,21.2725", Units.IN)
    setup = Setup(
        method=Method.GROUND, units=Units.IN, plane_offset=parse_vector("0,24.4475,0", Units.IN)[1],
        operator="Bo", ground_truth=(truth,),
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )  # fmt: skip
    session = ConsoleSession(Path("unused.mcap"), {})
    session.begin(setup, None)
    assert session.session_setup["truth"] == [["4.8514", "24.4475", "21.2725"]]
    assert session.session_setup["plane"]["offset"] == "24.4475"


def test_a_mm_sessions_default_reach_is_written_as_its_bound_is() -> None:
    """The file's note read "within 76.19999999999999 mm"."""
    described = GuidanceAsked().guidance(Units.MM, 2, 5.0).describe(Units.MM)
    assert "on the 12.7 mm grid within 76.2 mm of the first pose" in described
    given = GuidanceAsked(min_gain=read_option("MIN_GAIN")["parser"]("2.50e-1"))
    assert "by less than 2.50e-1," in given.guidance(Units.MM, 2, 5.0).describe(Units.MM)
