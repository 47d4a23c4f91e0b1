"""PAIR.toml (twopose.pair.pair_file): what is written is read back exactly, nothing is
overwritten, and every malformed file is refused in words naming the table and the key."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twopose.errors import InputValueError, SessionExistsError
from twopose.pair.board_fit import rotation_matrix
from twopose.pair.calibration import PairCalibration
from twopose.pair.holdout import HoldoutCheck
from twopose.pair.motion import thesis_pair
from twopose.pair.pair_file import read_pair_file, write_pair_file
from twopose.values.units import UNITS, Units, unit_factor


def _full() -> PairCalibration:
    """A calibration with every part: floor, check, sigmas, awkward names."""
    cov = np.diag([1e-6, 2e-6, 3e-6, 1e-4, 2e-4, 3e-4])
    cov[0, 3] = cov[3, 0] = 1e-6
    pc = thesis_pair(cov_extrinsic=cov, floor_cov=np.diag([1e-5, 0.0, 1e-5, 1e-3]))
    check = HoldoutCheck(
        folds=5, spacings=465, worst_sigmas=2.5, beyond=0, median_error=0.01,
        median_sigma=0.02, jackknife_ratio=(1.1, 1.2, 0.9, 1.5, 1.0, 1.3),
    )  # fmt: skip
    return dataclasses.replace(
        pc,
        rms_px=0.4478,
        n_views=5,
        sigma1={"fx": 1.5, "cy": 0.7, "k1": 0.01},
        sigma2={"fx": 2.5},
        view_names=('left "01".jpg & right01.jpg', "a\\b", "tab\there", "new\nline", "ü"),
        view_rms_px=(0.4, 0.5, 0.3, 0.45, 0.41),
        dropped=("left06.jpg & right06.jpg (RMS 9.10 px)",),
        intrinsics_from="calibration files L.toml and R.toml",
        check=check,
        cov_factor=1.7,
    )


def _same(a: PairCalibration, b: PairCalibration) -> None:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert np.array_equal(x, y), f.name
        elif f.name == "floor" and x is not None:
            assert np.array_equal(x.normal, y.normal)
            assert x.height == y.height
            assert np.array_equal(x.cov, y.cov)
        elif f.name == "check" and x is not None:
            assert dataclasses.replace(x, errors=(), sigmas=()) == y
        else:
            assert x == y, f.name


def test_what_is_written_is_read_back_exactly(tmp_path: Path) -> None:
    pc = _full()
    path = tmp_path / "PAIR.toml"
    write_pair_file(path, pc)
    _same(pc, read_pair_file(path))
    text = path.read_text("utf-8")
    assert "version = 1" in text
    assert "angles (rx, ry, rz; R = Rx Ry Rz) (0.0000, -10.0000, 0.0000) deg" in text
    # A bare pair: no floor, no check, no sigmas.
    bare = dataclasses.replace(thesis_pair(), floor=None)
    write_pair_file(tmp_path / "bare.toml", bare)
    _same(bare, read_pair_file(tmp_path / "bare.toml"))


def test_a_pair_file_is_never_overwritten(tmp_path: Path) -> None:
    path = tmp_path / "PAIR.toml"
    path.write_text("mine", "utf-8")
    with pytest.raises(SessionExistsError, match="already exists"):
        write_pair_file(path, thesis_pair())
    assert path.read_text("utf-8") == "mine"


def _edited(tmp_path: Path, old: str, new: str) -> Path:
    path = tmp_path / "PAIR.toml"
    write_pair_file(path, _full())
    text = path.read_text("utf-8")
    assert old in text, old
    path.write_text(text.replace(old, new, 1), "utf-8")
    return path


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        ("[camera2]", "[camera3]", r"unknown table\(s\) \[camera3\]"),
        ("[floor]", "[flor]", r"unknown table\(s\) \[flor\]"),
        ("views = 5", "views = 5\nview = 5", r"\[pair\]: unknown key\(s\) view"),
        ("version = 1", "version = 2", "pair file version 2; this twopose reads versions 1 to 1"),
        ("version = 1", 'version = "1"', "version must be a whole number"),
        ('units = "in"', 'units = "ft"', r"units must be one of in, mm, cm, m .*got 'ft'"),
        ('units = "in"', 'units = "m"', "6 m apart, beyond 5 m: are the units right"),
        ("height = 9.625", "height = 960.0", r"\[floor\] height 960 in is beyond"),
        ("height = 9.625", "height = -9.625", "floor's height must be a positive length"),
        ("R_2_to_1 = [[", "R_2_to_1 = [[2", "R_2_to_1 is not a rotation"),
        ("R_2_to_1 = [[", "R_2_to_1 = [[1.0, 0.0, 0.0], [", "R_2_to_1 must have 3 items, got 4"),
        (
            "t_2_in_1 = [6.0, 0.0, 0.0]",
            't_2_in_1 = [6.0, "0", 0.0]',
            r"t_2_in_1\[1\].*finite number",
        ),
        ("t_2_in_1 = [6.0, 0.0, 0.0]", "t_2_in_1 = [6.0, nan, 0.0]", r"t_2_in_1\[1\]"),
        ("t_2_in_1 = [6.0, 0.0, 0.0]", "t_2_in_1 = [6.0, 0.0]", "t_2_in_1 must have 3 items"),
        # what calibrate-pair never writes (a new user's hand edits, taken before)
        ("t_2_in_1 = [6.0, 0.0, 0.0]", "t_2_in_1 = [0.0, 0.0, 0.0]", "0 in apart: they share"),
        ("rms_px = 0.4478", "rms_px = 35.0", "rms_px 35 is above the 2 px"),
        ("rms_px = 0.4478", "", "missing"),
        (
            "passed = true",
            "passed = false",
            r"\[check\] passed = false but its worst_sigmas is 2.5",
        ),
        ("fx = 1.5", "fx = -1.5", "the sigma of fx must be >= 0"),
        ("fx = 1.5", "focal = 1.5", r"\[camera1\].sigma: unknown key\(s\) focal"),
        ("width = 640", "width = 0", r"\[camera1\]: image width must be a whole number > 0"),
        ("width = 640", "width = 640.5", "width must be a whole number"),
        ('and R.toml"', 'and R.toml"\n[pair.extra]\nx = 1', r"\[pair\]: unknown key\(s\) extra"),
        ("\n[pair]", "\n[pair", "not valid TOML"),
    ],
)
def test_a_malformed_pair_file_is_refused_naming_what(
    tmp_path: Path, old: str, new: str, words: str
) -> None:
    path = _edited(tmp_path, old, new)
    with pytest.raises(InputValueError, match=words) as caught:
        read_pair_file(path)
    assert str(path) in str(caught.value)


def test_a_missing_table_is_refused_saying_how_to_make_one(tmp_path: Path) -> None:
    path = tmp_path / "PAIR.toml"
    write_pair_file(path, _full())
    text = path.read_text("utf-8")
    path.write_text(text[: text.index("[camera2]")], "utf-8")
    with pytest.raises(InputValueError, match=r"no \[camera2\] table .*calibrate-pair"):
        read_pair_file(path)
    with pytest.raises(InputValueError, match="cannot read pair file"):
        read_pair_file(tmp_path / "absent.toml")


def test_the_covariance_must_be_one(tmp_path: Path) -> None:
    text = _edited(tmp_path, "cov_extrinsic = [[1e-06,", "cov_extrinsic = [[-1.0,").read_text()
    assert "-1.0" in text
    with pytest.raises(InputValueError, match="positive semi-definite"):
        read_pair_file(tmp_path / "PAIR.toml")


@settings(max_examples=25, deadline=None)
@given(
    rotation=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
    t=st.lists(st.floats(-100.0, 100.0), min_size=3, max_size=3).filter(
        lambda v: 1e-3 < float(np.linalg.norm(v)) < 100
    ),
    spread=st.lists(st.floats(-1.0, 1.0), min_size=36, max_size=36),
    units=st.sampled_from(UNITS),
    baseline_mm=st.floats(1.001, 4999.0),
)
def test_any_calibration_round_trips(
    tmp_path_factory: pytest.TempPathFactory,
    rotation: list[float],
    t: list[float],
    spread: list[float],
    units: Units,
    baseline_mm: float,
) -> None:
    A = np.array(spread).reshape(6, 6)
    # any direction, any baseline a pair file may state (1 mm to 5 m), in any unit
    length = baseline_mm * unit_factor(Units.MM, Units(units))
    pc = dataclasses.replace(
        thesis_pair(),
        R_2_to_1=rotation_matrix(np.array(rotation)),
        t_2_in_1=np.array(t) / np.linalg.norm(t) * length,
        cov_extrinsic=A @ A.T * 1e-6,
        units=units,
        floor=None,
    )
    path = tmp_path_factory.mktemp("pair") / "PAIR.toml"
    write_pair_file(path, pc)
    _same(pc, read_pair_file(path))


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("garbage = [", "is not valid TOML: Invalid value (at end of document)"),
        ("a = 1\nb c = 2\n", "(at line 2, column 3) ('b c = 2')"),
    ],
)
def test_a_corrupt_toml_file_is_said_where_it_is(tmp_path: Path, text: str, words: str) -> None:
    # tomlkit named the end of the file "Unexpected character: '\\x00' at line 1 col 0"
    path = tmp_path / "corrupt.toml"
    path.write_text(text, "utf-8")
    with pytest.raises(InputValueError) as caught:
        read_pair_file(path)
    assert words in str(caught.value)
    assert "x00" not in str(caught.value)


def test_a_failed_check_is_said_in_words_that_name_its_numbers() -> None:
    failed = HoldoutCheck(
        folds=13, spacings=624, worst_sigmas=9.5, beyond=40, median_error=0.01,
        median_sigma=0.02, jackknife_ratio=(1.0,) * 6,
    )  # fmt: skip
    said = failed.unconfirmed()
    assert said.startswith("the pair's covariance is not confirmed")
    assert "a held-out spacing 9.5 sigma off, 40 of 624 beyond 3" in said
    passed = _full().check
    assert passed is not None
    assert passed.unconfirmed() == ""
