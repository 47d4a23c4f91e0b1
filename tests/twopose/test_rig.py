"""twopose.rig.constants: the rig's constants and how they map typed poses to true ones."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from twopose.camera.model import rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.rig.constants import (
    RIG_PARAMETERS,
    RigConstants,
    angles_deg_from_rotation,
    true_ground,
)
from twopose.values.units import Units

angle = st.floats(-89.0, 89.0)


@given(rx=st.floats(-179.0, 179.0), ry=angle, rz=st.floats(-179.0, 179.0))
def test_angles_round_trip_through_the_rotation(rx: float, ry: float, rz: float) -> None:
    R = rotation_from_angles_deg([rx, ry, rz])
    np.testing.assert_allclose(rotation_from_angles_deg(angles_deg_from_rotation(R)), R, atol=1e-9)


def test_the_constants_act_as_documented() -> None:
    rig = RigConstants(
        mount_rotation_deg=(0.8, -0.5, 0.3),
        camera_offset=(0.3, 0.2, 0.4),
        focal_scale=1.03,
        principal_offset_px=(2.0, -1.0),
        tape_scale=1.01,
        ground_height_error=0.1,
    )
    t_typed = np.array([[1.0, 0.0, -2.0], [0.0, 0.0, 0.0]])
    r_typed = np.array([[0.0, 0.0, 90.0], [0.0, 0.0, 0.0]])
    t, R = rig.true_poses(t_typed, r_typed)
    R_typed = rotation_from_angles_deg(r_typed)
    offset = np.einsum("nij,j->ni", R_typed, [0.3, 0.2, 0.4])
    np.testing.assert_allclose(t, 1.01 * t_typed + offset)
    np.testing.assert_allclose(R, R_typed @ rotation_from_angles_deg([0.8, -0.5, 0.3]))
    np.testing.assert_allclose(
        rig.true_intrinsics([525, 525, 320, 240]), [540.75, 540.75, 322, 239]
    )
    _, height = true_ground((np.array([0.0, 2.0, 0.0]), 2 * 9.625), rig)  # n . p = h |n|
    assert height / 2 == pytest.approx(9.525)
    assert RigConstants.from_vector(rig.vector()) == rig
    assert len(rig.vector()) == sum(len(v) for v in RIG_PARAMETERS.values()) == 11
    assert RigConstants().is_identity
    assert not rig.is_identity


small = st.floats(-3.0, 3.0)
vec = st.tuples(small, small, small)


@given(
    mount=vec,
    offset=vec,
    tape=st.floats(0.9, 1.1),
    t=st.tuples(st.floats(-40, 40), st.floats(-40, 40), st.floats(-40, 40)),
    r=st.tuples(st.floats(-60, 60), angle, st.floats(-60, 60)),
)
def test_placed_poses_undo_the_constants(
    mount: tuple[float, float, float],
    offset: tuple[float, float, float],
    tape: float,
    t: tuple[float, float, float],
    r: tuple[float, float, float],
) -> None:
    """Where a simulated board's laptop was placed, from its true camera pose (H3)."""
    rig = RigConstants(mount_rotation_deg=mount, camera_offset=offset, tape_scale=tape)
    t_true, R_true = rig.true_poses(t, r)
    t_placed, r_placed = rig.placed_poses(t_true, R_true)
    np.testing.assert_allclose(t_placed, t, atol=1e-9)
    np.testing.assert_allclose(
        rotation_from_angles_deg(r_placed), rotation_from_angles_deg(r), atol=1e-9
    )


@pytest.mark.parametrize(
    "kwargs", [{"focal_scale": 3.0}, {"tape_scale": 0.1}, {"ground_height_error": float("nan")}]
)
def test_impossible_constants_are_refused(kwargs: dict[str, float]) -> None:
    with pytest.raises(InputValueError, match="rig constants"):
        RigConstants(**kwargs)  # type: ignore[arg-type]


def test_the_priors_are_per_scalar_and_in_the_rigs_units() -> None:
    from twopose.rig.constants import RIG_PRIORS, against_priors, prior_sigma

    inches, mm = prior_sigma(Units.IN), prior_sigma(Units.MM)
    assert inches.shape == (11,)
    assert inches[3] == RIG_PRIORS["camera_offset"]
    assert mm[3] == pytest.approx(25.4 * RIG_PRIORS["camera_offset"])
    assert mm[6] == inches[6] == RIG_PRIORS["focal_scale"]  # unitless: the same
    assert mm[10] == pytest.approx(25.4 * RIG_PRIORS["ground_height_error"])
    delta = np.zeros(11)
    delta[9] = 0.005  # a tape 0.5% long: 5 prior sigmas
    (warning,) = against_priors(delta, Units.IN)
    assert warning.startswith("tape_scale = nominal +0.005 is 5.0 prior sigmas off")
    assert against_priors(delta, Units.IN, ("focal_scale",)) == ()  # only the fitted are judged
    assert against_priors(np.zeros(11), Units.MM) == ()
