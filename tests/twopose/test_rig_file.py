"""The rig file, format 2 (issues 54 item 5, 55 item 6): the constants' whole covariance and
the cameras they were fitted for, written by ``rig`` and read back by the one reader; a
rig refused for another camera; a placing sigma at the fit's floor an upper bound, never
"measured"; every table checked (a misspelt one refused); format 1 still read, with notes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.rig.fit import RigFit, rig_toml
from tests.helpers import load_benchmark
from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.rig.constants import SCALARS, RigConstants, RigCovariance, check_applicable
from twopose.rig.file import RIG_FILE_FORMAT, load_rig_file
from twopose.solve.margins import EstimateOptions
from twopose.solve.session import estimate_session
from twopose.uncertainty.noise import NoiseModel, PlacingSigma
from twopose.uncertainty.session_noise import placing_source
from twopose.values.units import Units

THESIS = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
OTHER = Intrinsics(width=1280, height=720, fx=900.0, fy=900.0, cx=640.0, cy=360.0)
NAMES = ("mount_ry_deg", "offset_x", "principal_dx_px")
#: offset_x and principal_dx_px strongly correlated, as a board finds them.
COV = np.array([[4e-4, 1e-5, 2e-3], [1e-5, 1e-3, 0.019], [2e-3, 0.019, 0.4]])


def _written(path: Path, constants: RigConstants, placing: PlacingSigma | None = None) -> Path:
    sigma = np.full(len(SCALARS), np.nan)
    if constants.covariance is not None:
        for name, value in constants.covariance.sigma().items():
            sigma[SCALARS.index(name)] = value
    fit = RigFit(
        constants=constants, sigma=sigma, free=constants.covariance.names if constants.covariance
        else (), fixed={}, chi2=1.0, dof=1, press=np.nan,
    )  # fmt: skip
    path.write_text(rig_toml(fit, ["board.mcap"], placing=placing))
    return path


def _rig(**kw: object) -> RigConstants:
    return RigConstants(
        units=Units.IN,
        camera_offset=(0.3, 0.2, 0.4),
        cameras=(THESIS,),
        covariance=RigCovariance.of(NAMES, COV),
        **kw,  # type: ignore[arg-type]
    )


def test_the_file_keeps_the_whole_covariance_and_the_camera(tmp_path: Path) -> None:
    found = load_rig_file(_written(tmp_path / "rig.toml", _rig()))
    assert found.format == RIG_FILE_FORMAT == 2
    assert found.constants.cameras == (THESIS,)
    covariance = found.constants.covariance
    assert covariance is not None
    assert covariance.names == NAMES
    np.testing.assert_allclose(covariance.array(), COV, rtol=1e-8)  # the correlations too


def test_a_rig_is_refused_for_another_camera_and_said_for_one_it_does_not_know(
    tmp_path: Path,
) -> None:
    rig = load_rig_file(_written(tmp_path / "rig.toml", _rig())).constants
    assert check_applicable(rig, Units.IN, cameras=[THESIS]) == []
    with pytest.raises(InputValueError, match=r"fitted for the camera 640x480, f 525 px.*1280x720"):
        check_applicable(rig, Units.IN, cameras=[OTHER])
    shifted = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=321.0, cy=240.0)
    with pytest.raises(InputValueError, match="principal point"):
        check_applicable(rig, Units.IN, cameras=[shifted])
    old = tmp_path / "old.toml"  # format 1: no camera, [sigma] only
    old.write_text('[rig]\nunits = "in"\n\n[sigma]\noffset_x = 0.02\nfocal_scale = 0\n')
    before = load_rig_file(old)
    assert before.format == 1
    notes = check_applicable(before.constants, Units.IN, cameras=[OTHER])
    assert any("records no camera" in n for n in notes), notes
    assert any("carried as independent" in n for n in notes), notes
    assert before.constants.covariance == RigCovariance.of(
        ("offset_x",), [[0.02**2]], independent=True
    )


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ('[placng]\nsigma = 0.1\n', r"unknown table\(s\) or key\(s\) \[placng\]"),
        ("oops = 1\n", r"\[oops\]"),
        ("format = 3\n", "format 3, written by a newer twopose"),
        ('format = "2"\n', "format must be a whole number"),
        ("[sigma]\noffset_q = 0.1\n", "\\[sigma\\]: unknown key\\(s\\) offset_q"),
        ("[sigma]\noffset_x = -1\n", "must be finite and >= 0"),
        ('[fixed]\noffset_x = 3\n', "must be text"),
        ('[[camera]]\nwidth = 640\nheight = 480\nfx = 525.0\nfy = 525.0\ncx = 320.0\n', "cy"),
        ("[covariance]\nnames = ['offset_x']\nmatrix = [[-1.0]]\n", "not a covariance"),
        ("[covariance]\nnames = ['offset_x', 'mount_rx_deg']\nmatrix = [[1.0, 0], [0, 1.0]]\n",
         "constants' order"),
        ("[covariance]\nnames = ['offset_x']\nmatrix = [[1e-4]]\n[sigma]\noffset_x = 0.5\n",
         "edited by hand"),
        ("[placing]\nsigma = 0.1\nsigma_sigma = 1e-5\ncaptures = 8\n", "more than the 24"),
        ("[placing]\nsigma = 0.1\nsigma_sigma = 0.02\nupper_bound = true\n", "upper bound"),
        # every number by the one grammar (issue 55): TOML's wider forms refused in its words
        ("format = 0x2\n", r"format: '0x2' is not a whole number \(digits 0-9"),
        ("[sigma]\noffset_x = 0.0_5\n", r"\[sigma\] offset_x: '0.0_5' is not a number"),
        ("[sigma]\noffset_x = inf\n", r"\[sigma\] offset_x: 'inf' is not a number"),
        ("[placing]\nsigma = 0.1\ncaptures = 1_6\n", r"captures: '1_6' is not a whole number"),
        ("[placing]\nsigma = 1e309\n", r"sigma = 1e309 in is not a placing error"),
        ("[[camera]]\nwidth = 0x280\nheight = 480\nfx = 525.0\nfy = 525.0\ncx = 320.0\n"
         "cy = 240.0\n", r"width: '0x280' is not a whole number"),
    ],
)  # fmt: skip
def test_every_table_is_checked_and_an_unknown_one_refused(
    tmp_path: Path, body: str, words: str
) -> None:
    path = tmp_path / "rig.toml"
    rig = '[rig]\nunits = "in"\n'
    # Top-level keys come before the first table in TOML.
    path.write_text(body + rig if not body.startswith("[") else rig + body)
    with pytest.raises(InputValueError, match=words):
        load_rig_file(path)


def test_a_rig_tables_keys_are_the_constants_alone(tmp_path: Path) -> None:
    path = tmp_path / "rig.toml"
    path.write_text('[rig]\nunits = "in"\ncameras = []\n')
    with pytest.raises(InputValueError, match=r"\[rig\]: unknown key\(s\) cameras"):
        load_rig_file(path)


def test_a_placing_sigma_at_the_fits_floor_is_an_upper_bound_never_measured(
    tmp_path: Path,
) -> None:
    bound = PlacingSigma(sigma_in=0.0012, measured_by="b0.mcap", captures=8, upper_bound=True)
    path = _written(tmp_path / "rig.toml", _rig(), bound)
    text = path.read_text()
    assert "upper_bound = true" in text
    assert "sigma_sigma" not in text
    found = load_rig_file(path).placing
    assert found is not None
    assert found.upper_bound
    assert (found.sigma_in, found.captures) == (bound.sigma_in, bound.captures)
    said = found.describe(Units.IN)
    assert said.startswith("placing sigma at most 0.0012 in, an upper bound")
    assert "measured by" not in said
    assert "regions start from each pose's typed resolution" in said
    # a bound is no measurement: the typed resolution's weak prior, never the bound as exact
    assert NoiseModel(placing=found).anchor() == NoiseModel().anchor()
    source = placing_source(EstimateOptions(noise=NoiseModel(placing=found)))
    assert source == "typed (not the upper bound from b0.mcap (8 captures))"  # trials.csv's


@pytest.mark.parametrize("sigma0", [True, False])
def test_an_upper_bound_never_shrinks_a_region_below_the_typed_resolutions(sigma0: bool) -> None:
    """Issue 54's adversary: a board placed exactly bounds the placing sigma at 0.001 in, and
    the regions took that bound as the sigma (20x narrower than the typed 1/16 in's)."""
    trials = load_benchmark("bench_noise").session(Method.POINT, 3, 4, 1.0)
    bound = PlacingSigma(sigma_in=0.001, measured_by="b0.mcap", captures=16, upper_bound=True)

    def cov(placing: PlacingSigma | None) -> np.ndarray:
        noise = NoiseModel(placing=placing, test_redundancy=sigma0)
        return estimate_session(trials, EstimateOptions(noise=noise), line_fits=False).estimates.cov

    np.testing.assert_allclose(cov(bound), cov(None), rtol=1e-9)


def test_a_nearly_exact_placing_sigma_says_no_absurd_degrees_of_freedom() -> None:
    exact = PlacingSigma(sigma_in=0.1, sigma_sigma_in=3e-5, measured_by="b.mcap")
    said = exact.describe(Units.IN)
    assert "5555556" not in said  # once "11057153 degrees of freedom"
    assert "its own uncertainty negligible" in said
    assert "degrees of freedom" in PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.02).describe(
        Units.IN
    )


_PSD = st.integers(1, len(SCALARS)).flatmap(
    lambda k: st.tuples(
        st.lists(st.sampled_from(SCALARS), min_size=k, max_size=k, unique=True),
        st.lists(st.floats(-1e3, 1e3), min_size=k * k, max_size=k * k),
        st.floats(-8, 1),
    )
)


@settings(max_examples=40, deadline=None)
@given(_PSD)
def test_any_covariance_round_trips_through_the_file(
    tmp_path_factory: pytest.TempPathFactory, drawn: tuple[list[str], list[float], float]
) -> None:
    names, entries, log_scale = drawn
    ordered = tuple(n for n in SCALARS if n in names)
    k = len(ordered)
    a = np.array(entries).reshape(k, k) * 10.0**log_scale
    cov = a @ a.T + np.eye(k) * 10.0 ** (2 * log_scale - 6)  # positive definite, any scale
    rig = RigConstants(units=Units.MM, covariance=RigCovariance.of(ordered, cov))
    path = _written(tmp_path_factory.mktemp("rig") / "rig.toml", rig)
    back = load_rig_file(path).constants.covariance
    assert back is not None
    assert back.names == ordered
    np.testing.assert_allclose(back.array(), cov, rtol=1e-7, atol=1e-8 * np.abs(cov).max())
