"""The rig over several sessions (analysis/rig/calibrate.py, issue 22): each solved with its own
ground plane, intrinsics and units; given in any order, or twice, they give the same
constants; sessions in other units, and rigs implausible for them, refused."""

from __future__ import annotations

import itertools
import shutil
from pathlib import Path

import numpy as np
import pytest

from analysis.cli import app
from recorder.simulate.one_camera import simulate_session
from tests.analysis.rig_helpers import empty_session, rig_file, runner
from twopose.methods.specs import Method
from twopose.sim.scene import Scene
from twopose.values.units import Units

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def tables(exact_sessions: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two clean method 2 sessions, the tables at 9.625 in (the shared exact session) and
    10.5 in (the same seed, typing and trials; only the table is lower)."""
    high = tmp_path_factory.mktemp("tables") / "table_10.5.mcap"
    simulate_session(high, method=Method.GROUND, trials=4, frames=2, seed=22, pose_noise=0.0,
                     scene=Scene(ground_height=10.5))  # fmt: skip
    return {"9.625": exact_sessions / "ground.mcap", "10.5": high}


@pytest.mark.parametrize("order", list(itertools.permutations(range(3))))
def test_the_constants_do_not_depend_on_the_order_of_the_sessions(
    rig_sessions: dict[str, Path], tmp_path: Path, order: tuple[int, ...]
) -> None:
    """Every permutation of three sessions, one of them a copy of another: the same
    constants and sigmas, to the last digit, as the two distinct sessions give."""
    from analysis.rig.calibrate import calibrate

    copy = tmp_path / "copy_of_with.mcap"
    shutil.copyfile(rig_sessions["with"], copy)
    given = [rig_sessions["with"], rig_sessions["without"], copy]
    reference, _ = calibrate([str(rig_sessions["with"]), str(rig_sessions["without"])])
    fit, data = calibrate([str(given[i]) for i in order])
    assert len(data.trial_ids) == 20  # the copy's 10 trials are not counted again
    assert np.array_equal(fit.constants.vector(), reference.constants.vector())
    assert np.array_equal(fit.sigma, reference.sigma, equal_nan=True)
    assert (fit.free, fit.chi2, fit.dof) == (reference.free, reference.chi2, reference.dof)


def test_a_session_given_twice_is_counted_once(
    rig_sessions: dict[str, Path], tmp_path: Path
) -> None:
    """``rig S S`` and ``rig S copy-of-S`` fit what ``rig S`` fits, with a note (the
    duplicated trials fooled the leave-one-out selection and halved the variances)."""
    once, _ = rig_file(tmp_path, rig_sessions["with"])
    twice, output = rig_file(tmp_path, rig_sessions["with"], rig_sessions["with"])
    assert twice == once
    # As run and info say it (the same path twice: no "the same file as" itself).
    assert f"{rig_sessions['with']}: named more than once; counted once" in output
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(rig_sessions["with"], copy)
    copied, output = rig_file(tmp_path, rig_sessions["with"], copy)
    assert copied == once
    assert (
        f"{copy}: the same session as {rig_sessions['with']} (a byte copy); counted once" in output
    )


def test_tables_at_two_heights_fit_no_ground_height_error(
    tables: dict[str, Path], tmp_path: Path
) -> None:
    """Two clean method 2 sessions, tables at 9.625 and 10.5 in: each solved on its own
    table, so no ground height error appears, whichever is named first (both were solved
    on the first one's table: a ground height error of either sign, by the order)."""
    low, high = tables["9.625"], tables["10.5"]
    first, _ = rig_file(tmp_path, low, high)
    second, _ = rig_file(tmp_path, high, low)
    assert first == second
    assert first["rig"]["ground_height_error"] == 0  # type: ignore[index]
    assert first["sigma"]["ground_height_error"] == 0  # type: ignore[index]  # not fitted


def test_a_session_without_trials_changes_nothing(tables: dict[str, Path], tmp_path: Path) -> None:
    """A session with no trial, named first, on a table at 12 in: the others' fit is
    unchanged (its ground plane was everyone's), and a note says it informs nothing."""
    empty = empty_session(tmp_path / "empty.mcap", "ground", "in", ground=12.0)
    alone, _ = rig_file(tmp_path, tables["9.625"], tables["10.5"])
    with_empty, output = rig_file(tmp_path, empty, tables["9.625"], tables["10.5"])
    assert with_empty == alone
    assert f"{empty}: an empty session (no pose was recorded)" in output  # as run says it


def test_sessions_in_different_units_are_refused(
    rig_sessions: dict[str, Path], tmp_path: Path
) -> None:
    metric = tmp_path / "metric.mcap"  # trials to fit, in millimetres
    simulate_session(
        metric, method=Method.POINT, trials=2, frames=1, seed=5, scene=Scene().in_units(Units.MM)
    )
    out = tmp_path / "rig.toml"
    result = runner.invoke(app, ["rig", str(rig_sessions["with"]), str(metric), "--out", str(out)])
    assert result.exit_code == 3, result.output
    assert f"{rig_sessions['with']} (in), {metric} (mm)" in result.output
    assert not out.exists()


def test_run_refuses_a_rig_in_other_units(rig_sessions: dict[str, Path], tmp_path: Path) -> None:
    """A rig in mm for a session in inches: a clear error before any analysis (exit 3); a
    rig file from before units were recorded is read as before, with a note."""
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text('[rig]\nunits = "mm"\ncamera_offset = [3.0, 2.0, 4.0]\n')
    args = ["run", str(rig_sessions["without"]), "--out", str(tmp_path / "o"), "--no-scene"]
    result = runner.invoke(app, [*args, "--rig", str(rig_file)])
    assert result.exit_code == 3, result.output
    assert "is in mm, the session in in" in result.output
    assert not (tmp_path / "o").exists()
    rig_file.write_text("[rig]\ncamera_offset = [0.3, 0.2, 0.4]\n")
    result = runner.invoke(app, [*args, "--rig", str(rig_file)])
    assert result.exit_code == 0, result.output
    assert "records no units" in result.output
    assert "taken in the session's units (in)" in result.output


@pytest.mark.parametrize(
    ("line", "named"),
    [
        ("ground_height_error = 1e300", "ground_height_error = 1e+300 (within half the ground"),
        ("ground_height_error = 6.0", "ground_height_error = 6 (within half the ground height"),
        ("mount_rotation_deg = [180, 0, 0]", "mount_rotation_deg = [180, 0, 0] (each angle"),
        ("principal_offset_px = [1e300, 0]", "principal_offset_px = [1e+300, 0] (within a quar"),
    ],
)
def test_run_refuses_an_implausiblerig_file(
    tables: dict[str, Path], tmp_path: Path, line: str, named: str
) -> None:
    """What gave 6/6 'ok' trials with an infinite error or an RMSE of 13.8 in, or an
    'unexpected LinAlgError': refused before the analysis, naming the key and the limit."""
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text(f"[rig]\n{line}\n")
    out = tmp_path / "o"
    args = ["run", str(tables["9.625"]), "--out", str(out), "--no-scene", "--rig", str(rig_file)]
    result = runner.invoke(app, args)
    assert result.exit_code == 3, result.output
    assert "implausible for a laptop on grid paper" in result.output
    assert named in result.output
    assert "unexpected" not in result.output
    assert not out.exists()
