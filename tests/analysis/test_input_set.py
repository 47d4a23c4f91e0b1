"""analysis.batch.inputs: a batch's inputs resolved once. Copies are counted once, board
sessions are left to `rig` (not failed), empty sessions are said, results files skipped;
`run`'s tables do not depend on copies or order, and its terminal never pools two units."""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from analysis.batch.inputs import resolve_inputs
from analysis.batch.runner import run
from analysis.cli import app
from recorder.simulate.one_camera import simulate_session
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import SessionInfo
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

runner = CliRunner()

# Slow: its fixture simulates sessions of every kind and units (~30 s) and its tests run
# whole batches and every command (~40 s more); make test-all and CI run it. The quick loop
# keeps the rule through tests/analysis/test_session_identity.py's copies and links.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def kinds(tmp_path_factory: pytest.TempPathFactory, point_session: Path) -> dict[str, Path]:
    """A point session (and a copy), a session in centimetres, a board session, an empty
    session."""
    root = tmp_path_factory.mktemp("kinds")
    copy = root / "copy_of_point.mcap"
    shutil.copy(point_session, copy)
    scene = root / "cm.toml"
    scene.write_text('units = "cm"\n')
    from twopose.sim.scene import load_scene

    centimetres = root / "cm_point.mcap"
    simulate_session(
        centimetres, method=Method.POINT, trials=2, frames=2, seed=3, scene=load_scene(scene)
    )
    board = root / "board.mcap"
    simulate_session(board, method=Method.BOARD, trials=1, frames=1, seed=4)
    empty = root / "empty.mcap"
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=32, height=24, fx=30.0, fy=30.0, cx=16.0, cy=12.0),
    )
    with SessionWriter(empty, SessionInfo(method=Method.POINT, units=Units.IN), [cam], start_ns=0):
        pass
    # An MCAP cut short inside its opening metadata (cut after it, it would be a copy of
    # point.mcap, not a failure): the analysis says why it fails.
    broken = root / "broken.mcap"
    broken.write_bytes(point_session.read_bytes()[:300])
    return {
        "point": point_session,
        "copy": copy,
        "cm": centimetres,
        "board": board,
        "empty": empty,
        "broken": broken,
    }


def test_each_input_is_resolved_once_by_content_and_kind(kinds: dict[str, Path]) -> None:
    inputs = resolve_inputs([kinds[k] for k in ("point", "copy", "cm", "board", "empty")])
    assert inputs.files == [str(kinds["point"]), str(kinds["cm"])]
    assert inputs.copies == ((str(kinds["copy"]), str(kinds["point"])),)
    assert [s.path for s in inputs.boards] == [str(kinds["board"])]
    assert [s.path for s in inputs.empty] == [str(kinds["empty"])]
    assert inputs.units == ("in", "cm")
    said = " ".join(inputs.run_notes())
    assert "the same session as" in said
    assert "a board session" in said
    assert "`twopose-analyze rig`" in said
    assert "an empty session" in said


def test_run_counts_a_copy_once_leaves_boards_to_rig_and_says_so(
    kinds: dict[str, Path], tmp_path: Path
) -> None:
    junit = tmp_path / "run.xml"
    args = [str(kinds[k]) for k in ("point", "copy", "board", "empty")]
    result = runner.invoke(
        app, ["run", *args, "--out", str(tmp_path / "o"), "--no-scene", "--junit", str(junit)]
    )
    assert result.exit_code == 0, result.output  # a board session is no failure
    assert "twopose: 1 session(s)" in result.output
    assert "counted once" in result.output
    assert "for `twopose-analyze rig`" in result.output
    assert "an empty session" in result.output
    trials = pd.read_csv(tmp_path / "o" / "trials.csv")
    assert set(trials["session"]) == {str(kinds["point"])}
    suite = ET.parse(junit).getroot()
    assert suite.get("failures") in ("0", None)
    assert not list(suite.iter("failure"))
    page = (tmp_path / "o" / "report.html").read_text()
    assert "id='inputs'" in page
    assert "href='#inputs'" in page  # linked from the line that counts them, at the top
    # The answer first, the inputs' list after it (issue 47: the answer on the first screen
    # whatever failed or was left out).
    assert page.index("href='#inputs'") < page.index("id='answer'") < page.index("id='inputs'")


def test_the_terminal_never_pools_two_units(kinds: dict[str, Path], tmp_path: Path) -> None:
    result = runner.invoke(
        app,
        ["run", str(kinds["point"]), str(kinds["cm"]), "--out", str(tmp_path / "o"), "--no-scene"],
    )
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert "errors in inches:" in lines
    assert "errors in centimetres:" in lines or "errors in centimeters:" in lines
    assert not any("session units" in line for line in lines)
    point_rows = [line for line in lines if line.startswith("point ")]
    assert len(point_rows) == 2  # one per units, never one over both
    assert sum(1 for line in lines if "(point, cm)" in line) == 1


@settings(
    max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    order=st.permutations(["point", "copy", "cm", "board", "empty", "broken"]),
    twice=st.booleans(),
)
def test_the_tables_do_not_depend_on_order_or_copies(
    kinds: dict[str, Path], order: list[str], twice: bool
) -> None:
    paths = [kinds[k] for k in order] + ([kinds["point"]] if twice else [])
    result = run(paths)
    assert list(result.errors["session"]) == [str(kinds["broken"])]  # said, by name
    summary = result.summary
    assert sorted(summary["session"].map(lambda s: Path(s).name)) in (
        ["cm_point.mcap", "point.mcap"],
        ["cm_point.mcap", "copy_of_point.mcap"],  # the copy named first is the one kept
    )
    key = summary.sort_values("units").reset_index(drop=True)
    numbers = key[["units", "n_trials", "n_ok", "rmse", "median_err"]]
    reference = (
        run([kinds["point"], kinds["cm"]]).summary.sort_values("units").reset_index(drop=True)
    )
    pd.testing.assert_frame_equal(
        numbers, reference[["units", "n_trials", "n_ok", "rmse", "median_err"]]
    )


def test_a_file_named_twice_is_counted_once_and_said(
    kinds: dict[str, Path], tmp_path: Path
) -> None:
    """By the same path, through a symbolic link, or as a file of a folder also named:
    one session, and a note for each other naming (before, a silent dedupe)."""
    link = tmp_path / "link.mcap"
    link.symlink_to(kinds["point"])
    given = [kinds["point"], kinds["point"], link, kinds["point"].parent]
    inputs = resolve_inputs(given)
    assert inputs.files.count(str(kinds["point"])) == 1
    said = inputs.notes()
    repeats = [n for n in said if "named more than once" in n]
    # The same path again and the folder's own listing name it by the same path: one note;
    # the link another.
    assert len(repeats) == 2
    assert repeats[0] == f"{kinds['point']}: named more than once; counted once"
    assert (
        repeats[1]
        == f"{link}: named more than once (the same file as {kinds['point']}); counted once"
    )
    result = runner.invoke(app, ["info", *map(str, given[:3])])
    assert result.exit_code == 0, result.output
    assert "named more than once" in result.output


def test_each_command_finds_and_reads_its_inputs_once(
    kinds: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """run (with and without --rig) and rig resolve their inputs once: the output checks,
    the rig file's check and the analysis take the one set (each resolution hashes every
    file: a second would read a batch twice)."""
    import analysis.batch.inputs as input_set
    from twopose.format.reader import find_sessions

    searches: list[tuple[str, ...]] = []

    def counted(paths: Sequence[str | Path], **kwargs: Any) -> list[Path]:
        searches.append(tuple(map(str, paths)))
        return find_sessions(paths, **kwargs)

    monkeypatch.setattr(input_set, "find_sessions", counted)
    rig_file = tmp_path / "rig.toml"
    rig_file.write_text("[rig]\nfocal_scale = 1.0\n")
    point = str(kinds["point"])
    for args in (
        ["run", point, "--out", str(tmp_path / "a"), "--no-scene"],
        ["run", point, "--out", str(tmp_path / "b"), "--no-scene", "--rig", str(rig_file)],
        ["rig", point, str(kinds["copy"]), "--out", str(tmp_path / "rig_out.toml")],
    ):
        searches.clear()
        result = runner.invoke(app, args)
        assert len(searches) == 1, (args, searches, result.output)
