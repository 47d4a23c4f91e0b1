"""A rig's physical plausibility (issue 22): one validator in twopose.rig.constants, used by every
reader of a rig file and wherever a rig meets a session; its units recorded and checked."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from twopose.errors import InputValueError
from twopose.rig.constants import (
    RigConstants,
    check_applicable,
    check_plausible,
    corrected_ground,
    plausible_bounds,
)
from twopose.rig.file import load_rig
from twopose.values.units import Units

GROUND = (np.array([0.0, 1.0, 0.0]), 9.625)


def _file(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "rig.toml"
    path.write_text("[rig]\n" + body + "\n")
    return path


CASES = {
    "mount_rotation_deg = [180, 0, 0]": "mount_rotation_deg = [180, 0, 0] (each angle within ±30",
    "mount_rotation_deg = [0, -30.5, 0]": "mount_rotation_deg = [0, -30.5, 0] (each angle",
    'units = "in"\ncamera_offset = [0, 0, 3.5]': "[0, 0, 3.5] (each component within ±3 in)",
    'units = "mm"\ncamera_offset = [80, 0, 0]': "[80, 0, 0] (each component within ±76.2 mm (3 in",
    "focal_scale = 1.25": "focal_scale = 1.25 (within 1 ± 0.2)",
    "tape_scale = 0.94": "tape_scale = 0.94 (within 1 ± 0.05)",
    "principal_offset_px = [1e300, 0]": "principal_offset_px = [1e+300, 0] (within a quarter of",
    'units = "in"\nground_height_error = 1e300': "= 1e+300 (within ±24 in, half of a 48 in",
    'units = "cm"\nground_height_error = -70': "ground_height_error = -70 (within ±60.96 cm, half",
}


@pytest.mark.parametrize(("body", "named"), CASES.items())
def test_an_implausible_rig_file_is_refused_naming_the_key_and_the_limit(
    tmp_path: Path, body: str, named: str
) -> None:
    with pytest.raises(InputValueError, match="implausible for a laptop on grid paper") as err:
        load_rig(_file(tmp_path, body))
    assert named in str(err.value)
    assert str(tmp_path / "rig.toml") in str(err.value)


def test_every_limit_is_said_at_once(tmp_path: Path) -> None:
    body = "mount_rotation_deg = [40, 0, 0]\nfocal_scale = 0.7\ntape_scale = 1.2"
    with pytest.raises(InputValueError) as err:
        load_rig(_file(tmp_path, body))
    assert all(k in str(err.value) for k in ("mount_rotation_deg", "focal_scale", "tape_scale"))


def test_a_plausible_file_loads_with_its_units(tmp_path: Path) -> None:
    body = (
        'units = "mm"\nmount_rotation_deg = [30, -30, 0]\ncamera_offset = [76.2, -70, 0]\n'
        "focal_scale = 1.2\ntape_scale = 0.95\nprincipal_offset_px = [100, -100]\n"
        "ground_height_error = 12.5"
    )
    rig = load_rig(_file(tmp_path, body))
    assert rig.units == "mm"
    assert rig.camera_offset == (76.2, -70.0, 0.0)
    assert load_rig(_file(tmp_path, "focal_scale = 1.01")).units is None  # from before
    with pytest.raises(InputValueError, match="units must be one of in, mm, cm, m"):
        load_rig(_file(tmp_path, 'units = "furlong"'))


def test_where_a_rig_meets_a_session_its_units_ground_and_image_are_checked() -> None:
    rig = RigConstants(ground_height_error=0.5, units=Units.IN)
    assert check_applicable(rig, Units.IN, GROUND, [(640, 480)]) == []
    with pytest.raises(InputValueError, match="is in in, the session in mm"):
        check_applicable(rig, Units.MM, GROUND, [(640, 480)])
    notes = check_applicable(RigConstants(ground_height_error=0.5), Units.MM, None, [])
    assert len(notes) == 1
    assert "records no units" in notes[0]
    high = RigConstants(ground_height_error=5.0, units=Units.IN)  # 9.625 in: half is 4.8125
    with pytest.raises(InputValueError, match=r"ground_height_error = 5 \(within half the ground"):
        check_applicable(high, Units.IN, GROUND, [(640, 480)])
    with pytest.raises(InputValueError, match="within half the ground height"):
        corrected_ground(GROUND, high)  # every application, not only the command line's
    shifted = RigConstants(principal_offset_px=(100.0, 0.0), units=Units.IN)  # 320 x 240: 80 px
    assert check_applicable(shifted, Units.IN, None, [(640, 480)]) == []
    with pytest.raises(InputValueError, match=r"quarter of the image: ±80 px in x, ±60 px"):
        check_applicable(shifted, Units.IN, None, [(640, 480), (320, 240)])


def test_the_fit_looks_only_where_the_validator_accepts() -> None:
    """The fit's bounds are the validator's limits, so it never writes a refused file."""
    lower, upper = plausible_bounds(Units.MM, ground_height=250.0, image=(640, 480))
    np.testing.assert_allclose(upper[:3], 30.0)
    np.testing.assert_allclose(upper[3:6], 76.2)
    np.testing.assert_allclose([lower[6], upper[6]], [0.8, 1.2])
    np.testing.assert_allclose(upper[7:9], [160.0, 120.0])
    np.testing.assert_allclose([lower[9], upper[9]], [0.95, 1.05])
    np.testing.assert_allclose([lower[10], upper[10]], [-125.0, 125.0])
    for bound in (lower, upper):
        check_plausible(
            RigConstants.from_vector(bound, Units.MM), ground_height=250.0, image_size=(640, 480)
        )


def test_new_rig_refuses_an_implausible_file(tmp_path: Path) -> None:
    """``twopose-record new --rig`` reads the file with the same validator (the live
    result's exception had stopped the recording after trial 1)."""
    from recorder.cli.app import app

    rig_file = _file(tmp_path, "principal_offset_px = [1e300, 0]")
    out = tmp_path / "s.mcap"
    args = ["new", str(out), "--source", "synthetic", "--rig", str(rig_file)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 3, result.output
    assert "principal_offset_px = [1e+300, 0]" in result.output
    assert not out.exists()
