"""The operator's noise file (issue 54): a file the recording's start set aside for its
numbers is not added to at its end (a new user's finding: the start said "set aside", the
end appended silently to a file no recorder would read again)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from recorder.live.operator_noise import NoiseFile, live_prior, remember_session
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.solve.estimate import EstimateOptions
from twopose.uncertainty.operator_pool import SessionNoise
from twopose.values.units import Units

STATS = SessionNoise(group="", chi2=np.array([2.0]), dof=np.array([3]),
                     share=np.array([[0.5, 0.5, 0.5]]), z2=np.array([[1.0, 0.5, 0.5]]))  # fmt: skip


def _impossible(noise: NoiseFile) -> str:
    """A well-formed file whose one session holds a negative chi-square."""
    noise.remember("a.mcap", Method.POINT, Units.IN, "typed", STATS)
    text = noise.path.read_text()
    bad = text.replace("chi2 = [2.0]", "chi2 = [-27.0]")
    assert bad != text
    noise.path.write_text(bad)
    return bad


def test_a_file_set_aside_for_its_numbers_is_not_appended_to(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TWOPOSE_NOISE_DIR", str(tmp_path))
    noise = NoiseFile("Eve")
    bad = _impossible(noise)
    _, said, _ = live_prior("Eve", Method.POINT, EstimateOptions(), Units.IN)
    assert said.startswith("the operator's noise file was set aside:")
    with pytest.raises(InputValueError, match="numbers no recorder writes"):
        noise.remember("b.mcap", Method.POINT, Units.IN, "typed", STATS)
    end = remember_session("Eve", Method.POINT, Units.IN, "b.mcap", EstimateOptions(), STATS)
    assert end.startswith("the operator's noise file was not updated:")
    assert "numbers no recorder writes" in end
    assert noise.path.read_text() == bad  # untouched, nothing lost or added


def test_a_good_file_is_added_to(tmp_path: Path) -> None:
    noise = NoiseFile("Eve", tmp_path)
    noise.remember("a.mcap", Method.POINT, Units.IN, "typed", STATS)
    noise.remember("b.mcap", Method.POINT, Units.IN, "typed", STATS)
    assert [s["file"] for s in noise.sessions()] == ["a.mcap", "b.mcap"]


@pytest.mark.parametrize(
    ("session", "words"),
    [
        ('file = "x.mcap"\nchi2 = "x"\ndof = [3]\nshare = [[1.0]]\nz2 = [[1.0]]\n', "not arrays"),
        ('file = "x.mcap"\nmethod = "line"\n', "lacks chi2, dof, share, z2"),
    ],
)
def test_a_session_of_another_method_that_cannot_be_read_is_said_at_the_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, session: str, words: str
) -> None:
    """A new user's finding: a malformed session of no method (or another method) was
    passed over at the start, which said "no earlier session ... this one is kept in FILE",
    and then refused at the end; the Python error ("could not convert string to float")
    leaked into the words."""
    monkeypatch.setenv("TWOPOSE_NOISE_DIR", str(tmp_path))
    noise = NoiseFile("Zed")
    bad = f'format = 1\noperator = "Zed"\n\n[[session]]\n{session}'
    noise.path.write_text(bad)
    _, said, _ = live_prior("Zed", Method.POINT, EstimateOptions(), Units.IN)
    assert said.startswith("the operator's noise file was set aside:")
    assert words in said
    assert "could not convert" not in said
    assert "no earlier session" not in said
    end = remember_session("Zed", Method.POINT, Units.IN, "b.mcap", EstimateOptions(), STATS)
    assert end.startswith("the operator's noise file was not updated:")
    assert noise.path.read_text() == bad


def _hand(typed_in: float, seed: int) -> SessionNoise:
    """Four trials of a 0.16 in hand typed ``typed_in`` (4 directions, 0.98 placing)."""
    rng = np.random.default_rng(seed)
    share = np.full((4, 4), 0.98)
    z2 = (1 + ((0.16 / typed_in) ** 2 - 1) * share) * rng.standard_normal((4, 4)) ** 2
    return SessionNoise(group="", chi2=z2.sum(axis=1), dof=np.full(4, 4), share=share, z2=z2,
                        placing_in=typed_in)  # fmt: skip


def test_sessions_typed_coarser_start_a_finer_one_from_the_operators_hand(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A new user's r5 F1 (live): three sessions typed 0.5 in by a 0.16 in hand started a
    session typed 0.16 in from their multiplier (0.1x of 0.16 in), and every trial was
    warned as a typo. The file keeps each session's placing sigma; the prior is the hand."""
    monkeypatch.setenv("TWOPOSE_NOISE_DIR", str(tmp_path))
    noise = NoiseFile("Cy")
    for seed in range(3):
        noise.remember(f"c{seed}.mcap", Method.POINT, Units.IN, "typed", _hand(0.5, seed))
    assert "placing_in = 0.5" in noise.path.read_text()
    _, said, live = live_prior("Cy", Method.POINT, EstimateOptions(), Units.IN)
    assert live is not None
    assert "their placing sigma 0.1" in said  # the hand, in inches, about 0.16
    fine = live.at(0.16)
    assert fine is not None
    assert 0.5 < fine.scale < 2.0
    coarse = live.at(0.5)
    assert coarse is not None
    assert 0.05 < coarse.scale < 0.2


def test_an_older_files_sessions_without_their_placing_sigma_are_set_aside_and_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TWOPOSE_NOISE_DIR", str(tmp_path))
    noise = NoiseFile("Cy")
    for seed in range(3):
        noise.remember(f"c{seed}.mcap", Method.POINT, Units.IN, "typed", _hand(0.5, seed))
    old = noise.path.read_text().replace("placing_in = 0.5\n", "")
    noise.path.write_text(old)
    _, said, live = live_prior("Cy", Method.POINT, EstimateOptions(), Units.IN)
    assert live is None
    assert "3 of them set aside: written before the file kept each session's placing" in said
    assert noise.prior(Method.POINT, "typed", EstimateOptions().noise.anchor(), 0.16) is None


def test_a_live_session_of_another_operator_starts_from_its_typed_resolution() -> None:
    """A new user's r5 F2, live: a rig file's [placing] is its board's operator's hand."""
    from recorder.live.result import _placing_of_operator
    from recorder.procedure.capture import CaptureSettings
    from tests.lab import new_info
    from twopose.uncertainty.noise import PlacingSigma

    board = PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.02, measured_by="b.mcap", captures=16,
                         operators=("Ada",))  # fmt: skip
    info = new_info()  # operator "lab"
    options, said = _placing_of_operator(CaptureSettings(placing=board), info)
    assert options.noise.placing is None
    assert said.endswith("the rig file's [placing] (b.mcap) is operator Ada's, not lab's")
    mine = PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.02, measured_by="b.mcap", captures=16,
                        operators=("lab",))  # fmt: skip
    options, said = _placing_of_operator(CaptureSettings(placing=mine), info)
    assert options.noise.placing == mine
