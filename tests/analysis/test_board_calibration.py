"""analysis.rig.board: ``twopose-analyze rig`` on board sessions, through real MCAP
files the simulator records (its one synthetic camera applies the rig's constants). The
constants come back within their uncertainty; the rig file is the one ``run --rig`` reads;
board and target sessions are not mixed; a board session is not analysed as a measurement;
a session named twice counts once; a capture that never saw the board is left out, said;
a simulated board session records the poses it was rendered from, and `rig` sets the
placing it measured against the placing the simulator drew."""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from analysis import run
from analysis.cli import app
from analysis.rig.board import calibrate_board, read_board_session
from analysis.rig.calibrate import calibrate_rig
from recorder.simulate.one_camera import simulate_session
from tests.helpers import rewrite_session
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.simulation import BOARD_TRUTH, SimulationTruth
from twopose.format.trials import iter_trials
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.rig.file import load_rig, load_rig_file
from twopose.sim.layout import BOARD_POSES
from twopose.sim.scene import load_scene
from twopose.values.units import Units

runner = CliRunner()

#: Board sessions rendered and fitted: behind the slow marker (CI runs them; the fit's own
#: tests on seeded corners, tests/twopose/test_board_rig.py, stay in the quick loop).
pytestmark = pytest.mark.slow

#: benchmarks/bench_rig.py's constants, with a principal offset.
TRUE = RigConstants(
    mount_rotation_deg=(0.8, -0.5, 0.3),
    camera_offset=(0.3, 0.2, 0.4),
    focal_scale=1.03,
    principal_offset_px=(4.0, -3.0),
)


@pytest.fixture(scope="module")
def board_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One board session of the default board, 8 typed poses of 3 frames, the laptop placed
    with the thesis sessions' error (0.04 in per axis), seen through TRUE."""
    scene = load_scene(
        None,
        systematic={
            "mount_rotation_deg": list(TRUE.mount_rotation_deg),
            "camera_offset": list(TRUE.camera_offset),
            "focal_scale": TRUE.focal_scale,
            "principal_offset_px": list(TRUE.principal_offset_px),
        },
        poses={"noise_sigma": 0.04, "rotation_noise_deg": 0.0},
    )
    path = tmp_path_factory.mktemp("board") / "board.mcap"
    simulate_session(path, method=Method.BOARD, trials=1, frames=3, seed=3, scene=scene)
    return path


def test_a_board_sessions_captures_are_every_pose_with_the_board_found(board_session: Path) -> None:
    captures = read_board_session(board_session)
    assert captures.left_out == ()
    assert captures.observed_px.shape == (len(BOARD_POSES), 54, 2)
    np.testing.assert_array_equal(captures.t_typed, np.array(BOARD_POSES))
    assert captures.t_sigma == pytest.approx(0.04)
    assert captures.units == "in"


def test_the_constants_come_back_within_their_uncertainty(board_session: Path) -> None:
    found = calibrate_board([board_session])
    error = found.board.rig.vector()[:-1] - TRUE.vector()[:-1]
    sigma = found.board.sigma[:-1]
    assert np.isfinite(sigma).all()
    assert (np.abs(error) <= 3 * sigma).all(), error / sigma
    assert found.board.rms_px < 0.5
    assert found.fit.fixed["ground_height_error"] == "a board does not see the ground"
    assert found.sessions == (str(board_session),)


def test_rig_writes_the_file_run_reads(board_session: Path, tmp_path: Path) -> None:
    out = tmp_path / "rig.toml"
    result = runner.invoke(app, ["rig", str(board_session), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "8 board capture(s), 432 corners" in result.stdout
    assert "  focal_scale = 1.0" in result.stdout  # 1.03 within its sigma, with it
    assert "# fitted on 8 board capture(s), 432 corners" in out.read_text()
    rig = load_rig(out)
    assert rig.focal_scale == pytest.approx(TRUE.focal_scale, abs=0.01)
    with out.open("rb") as f:
        assert tomllib.load(f)["sigma"]["focal_scale"] > 0
    assert str(board_session) in out.read_text()
    # The operator's placing error (0.04 in here) measured and written: [placing].
    placing = load_rig_file(out).placing
    assert placing is not None
    assert placing.measured_by == board_session.name
    assert placing.captures == 8
    assert abs(placing.sigma_in - 0.04) < 3 * placing.sigma_sigma_in, placing
    assert f"placing sigma {placing.sigma_in:.3g} ± " in result.stdout
    # H3: beside it, the placing the simulator drew, from the session's own truth.
    drawn_each = read_board_session(board_session).true_placing
    assert drawn_each is not None
    drawn = float(np.sqrt(np.mean(drawn_each**2)))
    assert (
        f"the placing the simulator drew (/simulation/truth): RMS {drawn:.3g} in over the 8 "
        f"captures' components; the measured sigma is {placing.sigma_in / drawn:.2f}x it"
    ) in result.stdout


def test_a_simulated_board_session_records_the_poses_it_was_rendered_from(
    board_session: Path,
) -> None:
    """H3 (issue 54's board target, checkable): one truth per trial, kind "board", every
    capture's true pose and the board's corners; the placing read back from it is the one
    drawn (0.04 in a component here), the rig's constants undone (their 0.3-0.4 in camera
    offset is no placing)."""
    with SessionReader(board_session) as reader:
        board = reader.info.board
        assert board is not None
        (trial,) = list(iter_trials(reader, with_frames=False))
    truth = trial.simulation_truth
    assert isinstance(truth, SimulationTruth)
    assert truth.kind == BOARD_TRUTH
    np.testing.assert_allclose(truth.points_grid, board.corners_grid())
    assert [p.pose for p in truth.poses] == list(range(1, len(BOARD_POSES) + 1))
    assert truth.rig is not None
    np.testing.assert_allclose(truth.rig, TRUE.vector())
    true_t = np.array([p.t_grid for p in truth.poses])
    typed = np.array([p.entry.t_grid for p in trial.poses])
    assert np.sqrt(np.mean((true_t - typed) ** 2)) > 0.2  # the camera, not the laptop
    placing = read_board_session(board_session).true_placing
    assert placing is not None
    assert placing.shape == (len(BOARD_POSES), 3)
    rms = float(np.sqrt(np.mean(placing**2)))
    assert 0.025 < rms < 0.055  # 24 draws of N(0, 0.04^2)
    assert calibrate_board([board_session]).true_placing == pytest.approx(rms)


def test_a_board_session_without_its_truth_is_calibrated_as_before(
    board_session: Path, tmp_path: Path
) -> None:
    """A board session simulated before its truth was written (or a recorded one): the same
    fit, no truth said."""
    old = rewrite_session(
        board_session, tmp_path / "old.mcap", drop=frozenset({"/simulation/truth"})
    )
    with SessionReader(old) as reader:
        assert all(t.simulation_truth is None for t in iter_trials(reader, with_frames=False))
    assert read_board_session(old).true_placing is None
    found, before = calibrate_board([old]), calibrate_board([board_session])
    assert found.true_placing is None
    np.testing.assert_allclose(found.board.rig.vector(), before.board.rig.vector())
    result = runner.invoke(app, ["rig", str(old), "--out", str(tmp_path / "rig.toml")])
    assert result.exit_code == 0, result.output
    assert "placing sigma" in result.stdout
    assert "/simulation/truth" not in result.stdout


def test_a_session_named_twice_or_copied_counts_once(board_session: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy.mcap"
    shutil.copy(board_session, copy)
    notes: list[str] = []
    once = calibrate_board([board_session])
    twice = calibrate_board([board_session, copy, board_session], on_note=notes.append)
    assert twice.board.n_captures == once.board.n_captures
    np.testing.assert_allclose(twice.board.rig.vector(), once.board.rig.vector())
    assert any("counted once" in n for n in notes), notes


def test_board_and_target_sessions_are_not_mixed(board_session: Path, tmp_path: Path) -> None:
    target = tmp_path / "point.mcap"
    simulate_session(target, method=Method.POINT, trials=2, frames=2, seed=1)
    with pytest.raises(InputValueError, match="calibrate with one kind"):
        calibrate_rig([str(board_session), str(target)])
    out = tmp_path / "r.toml"
    result = runner.invoke(app, ["rig", str(target), str(board_session), "--out", str(out)])
    assert result.exit_code != 0
    assert "calibrate with one kind" in result.output
    assert not out.exists()


def test_run_says_a_board_session_is_for_rig(board_session: Path) -> None:
    """A board session in a run is listed for `rig`, not failed (analysis.batch.inputs)."""
    result = run([board_session], None)
    assert result.trials.empty
    assert result.errors.empty
    (said,) = result.input_notes
    assert str(board_session) in said
    assert "for `twopose-analyze rig`" in said


def test_a_constant_a_board_cannot_see_is_refused(board_session: Path) -> None:
    with pytest.raises(InputValueError, match="cannot determine ground_height_error"):
        calibrate_board([board_session], groups=["ground_height_error"])
    only_focal = calibrate_board([board_session], groups=["focal_scale"])
    assert only_focal.fit.free == ("focal_scale",)
    assert np.isnan(only_focal.fit.sigma[0])  # the mount: not asked for, nominal
    assert only_focal.fit.fixed["mount_rx_deg"] == "not asked for (--constant)"


def test_a_capture_that_never_saw_the_board_is_left_out_and_said(tmp_path: Path) -> None:
    from recorder.setup.plan import load_plan, record_plan
    from recorder.sources.registry import SyntheticSource

    poses = [*BOARD_POSES, (40.0, 0.0, 0.0)]  # the last one looks past the board
    plan = tmp_path / "plan.toml"
    plan.write_text(
        'method = "board"\nframes = 2\n[board]\ninner_corners = [9, 6]\nsquare = 0.75\n'
        "first_corner = [-3.0, 8.125, 24.0]\n[[trials]]\nposes = ["
        + ", ".join(f"{{ t = [{x}, {y}, {z}] }}" for x, y, z in poses)
        + "]\n"
    )
    out = tmp_path / "board.mcap"
    record_plan(load_plan(plan), out, SyntheticSource(None, Method.BOARD, realtime=False))
    captures = read_board_session(out)
    assert captures.observed_px.shape[0] == len(BOARD_POSES)
    (why,) = captures.left_out
    assert why.endswith("trial 1, pose 9: the whole board was found in none of its frames")
    notes: list[str] = []
    calibrate_board([out], on_note=notes.append)
    assert notes == [f"left out {why}"]


def test_a_board_placed_exactly_gives_an_upper_bound_never_a_measured_sigma(
    tmp_path: Path,
) -> None:
    """Issue 55: the synthetic source with no placing error. `rig` wrote its fit's floor,
    `sigma = 0.001`, as measured; now the most the placing error can be, said as a bound on
    stderr, in the file and by every reader; and the file records the camera it was fitted
    for (640x480, f 525), which a session of another camera is refused."""
    board = tmp_path / "exact.mcap"
    simulate_session(board, method=Method.BOARD, trials=1, frames=1, seed=4, pose_noise=0.0)
    out = tmp_path / "rig.toml"
    result = runner.invoke(app, ["rig", str(board), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "written as an upper bound" in result.output
    assert f"applies it to every session in {tmp_path} and below" in result.output
    assert "placing sigma at most" in result.output
    text = out.read_text()
    assert "upper_bound = true" in text
    assert "sigma_sigma" not in text
    found = load_rig_file(out)
    assert found.placing is not None
    assert found.placing.upper_bound
    assert 1e-3 <= found.placing.sigma_in < 0.02
    assert "measured by" not in found.placing.describe(Units.IN)
    (camera,) = found.constants.cameras
    assert (camera.width, camera.height, camera.fx) == (640, 480, 525.0)


def test_the_placing_is_set_against_the_draw_in_the_sessions_units() -> None:
    """The words `rig` prints under the placing sigma: a ratio with its spread, a bound's
    ratio alone, and none for a draw of no placing (the board placed exactly)."""
    from analysis.rig.calibrate import placing_against_truth
    from twopose.uncertainty.noise import PlacingSigma

    measured = PlacingSigma(sigma_in=0.11, sigma_sigma_in=0.011, captures=16)
    said = placing_against_truth(measured, 0.1 * 25.4, Units.MM)
    assert said == (
        "the placing the simulator drew (/simulation/truth): RMS 2.54 mm over the 16 "
        "captures' components; the measured sigma is 1.10x it (± 0.11x)"
    )
    bound = PlacingSigma(sigma_in=0.002, captures=8, upper_bound=True)
    assert placing_against_truth(bound, 0.001, Units.IN).endswith("the upper bound is 2.00x it")
    assert placing_against_truth(bound, 1e-15, Units.IN).endswith(": none drawn")
