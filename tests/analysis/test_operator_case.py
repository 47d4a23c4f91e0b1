"""Operators' names matched with case folded (issue 54; a second new user's r5 F2b): "Ada",
"ada" and " ADA" were three operators, so the board (Ada's) was not applied to two of them
and none of their sessions pooled. Now they are one, shown as first typed, and said."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from analysis.batch.inputs import resolve_inputs
from analysis.batch.noise_pass import operator_heads, pooled_groups
from analysis.results import AnalysisOptions
from analysis.rig.scope import RigUse, placing_notes
from recorder.live.operator_noise import NoiseFile
from tests.lab import record
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.rig.file import RigFile
from twopose.uncertainty.noise import PlacingSigma
from twopose.uncertainty.operator_pool import SessionNoise
from twopose.values.operators import operator_key, operators_of, spelled_apart
from twopose.values.units import Units

STATS = SessionNoise(group="", chi2=np.array([2.0]), dof=np.array([3]),
                     share=np.array([[0.5, 0.5, 0.5]]), z2=np.array([[1.0, 0.5, 0.5]]))  # fmt: skip


def test_names_differing_only_in_case_are_one_operator_shown_as_first_typed() -> None:
    assert operator_key(" ADA ") == operator_key("ada") == operator_key("Ada")
    assert operator_key("Ada") != operator_key("Adam")
    assert operators_of(["Ada", "", " ada", "Bob", "ADA "]) == ("Ada", "Bob")
    assert spelled_apart(["Ada", "ada", "Bob", " Ada "]) == [("Ada", "ada")]


def test_sessions_of_one_operator_typed_in_two_cases_pool(tmp_path: Path) -> None:
    paths = [tmp_path / f"s{k}.mcap" for k in range(3)]
    for path, name in zip(paths, ["Ada", "ada", " ADA"], strict=True):
        record(path, 1, operator=name)
    inputs = resolve_inputs(paths)
    groups = pooled_groups(operator_heads(inputs, inputs.files), AnalysisOptions())
    assert set(groups.values()) == {"Ada (point)"}  # one operator, named as first typed
    assert len(groups) == 3
    said = " ".join(inputs.run_notes())
    assert "operator names Ada, ada, ADA differ only in case: taken as one operator (Ada)" in said


def test_a_rig_files_operator_matches_in_any_case() -> None:
    board = PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.01, measured_by="b.mcap", captures=16,
                         operators=("Ada",))  # fmt: skip
    use = RigUse(path="rig.toml", sha256="0", file=RigFile(constants=RigConstants(), placing=board))
    assert use.placing_for(("ada",)) is board
    assert use.placing_for((" ADA ",)) is board
    assert use.placing_for(("Cy",)) is None
    notes = placing_notes(use, {"a.mcap": ("ada",), "c.mcap": ("Cy",)})
    assert "not applied to 1 session of other operators (Cy: c.mcap)" in " ".join(notes)


def test_the_live_rig_check_matches_in_any_case() -> None:
    from recorder.live.result import _placing_of_operator
    from recorder.procedure.capture import CaptureSettings
    from tests.lab import new_info

    board = PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.02, measured_by="b.mcap", captures=16,
                         operators=("LAB",))  # fmt: skip
    options, _ = _placing_of_operator(CaptureSettings(placing=board), new_info())  # "lab"
    assert options.noise.placing == board


def test_the_noise_file_is_one_for_every_case_and_an_older_one_is_found(tmp_path: Path) -> None:
    NoiseFile("Ada", tmp_path).remember("a.mcap", Method.POINT, Units.IN, "typed", STATS)
    assert len(NoiseFile("ada", tmp_path).sessions()) == 1
    assert NoiseFile(" ADA ", tmp_path).path == NoiseFile("Ada", tmp_path).path
    # a file an earlier recorder wrote under the hash of the name as typed ("Eve")
    import hashlib

    NoiseFile("Eve", tmp_path).remember("e.mcap", Method.POINT, Units.IN, "typed", STATS)
    new = NoiseFile("Eve", tmp_path).path
    old = tmp_path / f"eve-{hashlib.sha256(b'Eve').hexdigest()[:8]}.toml"
    new.rename(old)
    found = NoiseFile("eve", tmp_path)
    assert found.path == old
    assert len(found.sessions()) == 1
