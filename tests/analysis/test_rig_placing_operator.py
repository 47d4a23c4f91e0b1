"""A board's ``[placing]`` is its operator's hand (issue 54; a new user's r5 F2): a rig
file's placing, measured by Ada's board, was every operator's placing sigma below it,
Cy's sessions too. The rig file now records the board's operators; a session of another
operator starts from its typed resolution, and a rig file that names none is said to
apply to every operator."""

from __future__ import annotations

from pathlib import Path

from analysis.batch.inputs import resolve_inputs
from analysis.results import AnalysisOptions
from analysis.rig.scope import RIG_BESIDE, rig_scope
from tests.analysis.test_rig_scope import RIG
from tests.lab import record
from twopose.rig.file import load_rig_file, placing_table
from twopose.uncertainty.noise import PlacingSigma
from twopose.values.units import Units


def _lab(tmp_path: Path, placing_operators: str) -> tuple[Path, list[str]]:
    """lab/s.mcap (operator "lab", tests/lab.py) under a rig.toml whose [placing] names
    ``placing_operators`` (a TOML line, or "")."""
    folder = tmp_path / "lab"
    folder.mkdir()
    record(folder / "s.mcap", 1)
    (folder / RIG_BESIDE).write_text(RIG.format(x=0.1) + placing_operators)
    notes: list[str] = []
    scope = rig_scope(resolve_inputs([folder]), on_note=notes.append)
    options = scope.options_for(str(folder / "s.mcap"), AnalysisOptions())
    return folder, [*notes, repr(options.estimate.noise.placing)]


def test_another_operators_board_is_not_this_sessions_placing(tmp_path: Path) -> None:
    folder, said = _lab(tmp_path, 'operators = ["Ada"]\n')
    assert said[-1] == "None"  # the regions start from the typed resolution
    assert (
        f"rig file {folder / RIG_BESIDE}'s [placing] (board.mcap) is operator Ada's: not "
        "applied to 1 session of other operators (lab: s.mcap): their regions start from "
        "their typed resolution"
    ) in said


def test_the_boards_own_operator_takes_it(tmp_path: Path) -> None:
    _, said = _lab(tmp_path, 'operators = ["lab"]\n')
    assert said[-1].startswith("PlacingSigma(sigma_in=0.1")
    assert not any("[placing]" in s for s in said[:-1])


def test_a_rig_file_naming_no_operator_is_said_to_apply_to_every_one(tmp_path: Path) -> None:
    _, said = _lab(tmp_path, "")
    assert said[-1].startswith("PlacingSigma(sigma_in=0.1")
    assert any("records no operator: it is applied to every operator's sessions" in s
               for s in said)  # fmt: skip


def test_the_operators_are_written_and_read_back(tmp_path: Path) -> None:
    placing = PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.02, measured_by="b.mcap",
                           captures=16, operators=('A "da"',))  # fmt: skip
    text = RIG.format(x=0.1).split("[placing]")[0] + "\n".join(placing_table(placing, Units.IN))
    (tmp_path / "rig.toml").write_text(text + "\n")
    read = load_rig_file(tmp_path / "rig.toml").placing
    assert read is not None
    assert read.operators == ('A "da"',)
