"""A laptop-on-grid rig's hidden constants, and how they act on what the operator types.

Nobody measures them, yet each biases every trial the same way (the thesis' own
explanation of its bias, sections 5.3-5.4): averaging frames or adding poses does not
remove them. The simulator uses them to render (typed -> true); the analysis, once it has
estimated them, uses the same map to correct every view before solving; the recorder can
apply a calibrated rig to its live result. One home for the rule:

* ``mount_rotation_deg`` (rx, ry, rz): the webcam relative to the laptop body, the
  screen's tilt included: ``R_true = R_typed · R_mount``;
* ``camera_offset`` (x, y, z, session units): the camera centre relative to the point the
  operator measures with the tape, in the laptop's frame: ``t_true = tape_scale · t_typed +
  R_typed · camera_offset``;
* ``focal_scale``: true focal parameter = typed × scale (the thesis assumed 525 px);
* ``principal_offset_px`` (dx, dy): true principal point = typed + offset;
* ``tape_scale``: what the tape reads against the true distance (applied as above);
* ``ground_height_error``: the typed ground height minus the true one.

The lengths (``camera_offset``, ``ground_height_error``) are in the calibration sessions'
units, which a rig file records (``units``) and ``--rig`` checks against the session's.
Every rig read from a file is checked for physical plausibility (:func:`check_plausible`,
the limits in :data:`LIMITS`); where it meets a session, also against that session's
ground height, image and camera (:func:`check_applicable`: a rig is fitted for one
camera and refused for another). The fit looks only where these limits allow
(:func:`plausible_bounds`), so it never writes a file that is refused. The rig file's one
reader is :mod:`twopose.rig.file`; how the constants' covariance reaches every region,
:mod:`twopose.rig.carried`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.camera.model import Intrinsics, rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.format.entries import INCHES_PER_UNIT, UNITS
from twopose.rig.cameras import check_cameras
from twopose.rig.covariance import RIG_PARAMETERS, SCALARS, RigCovariance
from twopose.solve.estimate import GroundSpec, PoseView
from twopose.values.units import IS_LENGTH, Units, unit_spec

__all__ = [
    "LIMITS",
    "RIG_PARAMETERS",
    "RIG_PRIORS",
    "SCALARS",
    "RigConstants",
    "RigCovariance",
    "against_priors",
    "angles_deg_from_rotation",
    "check_applicable",
    "check_plausible",
    "check_units",
    "corrected_ground",
    "corrected_view",
    "ground_height",
    "plausible_bounds",
    "prior_sigma",
    "true_ground",
]


@dataclass(frozen=True, kw_only=True)
class RigConstants:
    """The rig's constants (see the module docstring); the defaults change nothing."""

    mount_rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    camera_offset: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), metadata=IS_LENGTH)
    focal_scale: float = 1.0
    principal_offset_px: tuple[float, float] = (0.0, 0.0)
    tape_scale: float = 1.0
    ground_height_error: float = field(default=0.0, metadata=IS_LENGTH)
    #: The lengths' units (a rig file's ``units``); None: not recorded (a file from before).
    units: Units | None = None
    #: The cameras the constants were fitted for (a rig file's ``[[camera]]``): a focal
    #: scale and a principal offset are relative to them, so any other camera is refused
    #: (:func:`check_applicable`); empty: not recorded (a file from before).
    cameras: tuple[Intrinsics, ...] = ()
    #: The fitted constants' covariance (a rig file's ``[covariance]``), carried into every
    #: region; None: not known (constants taken as exact).
    covariance: RigCovariance | None = None

    def __post_init__(self) -> None:
        """Check that the constants are finite and the scales plausible.

        A units' symbol given as text becomes its :class:`~twopose.values.units.Units`.
        """
        values = self.vector()
        if not np.isfinite(values).all():
            raise InputValueError(f"rig constants must be finite numbers, got {self}")
        if not (0.5 < self.focal_scale < 2.0 and 0.5 < self.tape_scale < 2.0):
            raise InputValueError(
                "rig constants: focal_scale and tape_scale must be within (0.5, 2), got "
                f"{self.focal_scale} and {self.tape_scale}"
            )
        if self.units is not None and self.units not in UNITS:
            raise InputValueError(
                f"rig constants: units must be one of {', '.join(UNITS)}, got {self.units!r}"
            )
        if self.units is not None:
            object.__setattr__(self, "units", Units(self.units))

    @property
    def is_identity(self) -> bool:
        """Whether these are the constants of a perfect rig (no correction)."""
        return bool(np.allclose(self.vector(), RigConstants().vector(), rtol=0.0, atol=0.0))

    def vector(self) -> F64:
        """The 11 scalars in :data:`RIG_PARAMETERS` order."""
        parts: list[float] = []
        for name in RIG_PARAMETERS:
            value = getattr(self, name)
            parts += list(value) if isinstance(value, tuple) else [value]
        return np.array(parts, dtype=np.float64)

    @classmethod
    def from_vector(cls, values: ArrayLike, units: Units | None = None) -> RigConstants:
        """The constants from the 11 scalars in :data:`RIG_PARAMETERS` order."""
        v = [float(x) for x in np.asarray(values, dtype=np.float64)]
        return cls(
            mount_rotation_deg=(v[0], v[1], v[2]),
            camera_offset=(v[3], v[4], v[5]),
            focal_scale=v[6],
            principal_offset_px=(v[7], v[8]),
            tape_scale=v[9],
            ground_height_error=v[10],
            units=units,
        )

    def true_poses(self, t_typed: ArrayLike, r_typed_deg: ArrayLike) -> tuple[F64, F64]:
        """Typed camera centres and angles to the true centres and rotations.

        Typed camera centres (..., 3) and angles (..., 3, degrees) -> the true centres (...,
        3) and rotations ``R_cam_to_grid`` (..., 3, 3).
        """
        t = np.asarray(t_typed, dtype=np.float64)
        R_typed = rotation_from_angles_deg(r_typed_deg)
        R_mount = rotation_from_angles_deg(self.mount_rotation_deg)
        offset = np.einsum("...ij,j->...i", R_typed, np.asarray(self.camera_offset))
        return self.tape_scale * t + offset, np.asarray(R_typed @ R_mount)

    def placed_poses(self, t_true: ArrayLike, R_true: ArrayLike) -> tuple[F64, F64]:
        """:meth:`true_poses` undone: where the laptop was placed and how it was turned.

        True centres (..., 3) and rotations (..., 3, 3) -> the placed centres (..., 3) and
        angles (..., 3; degrees).
        """
        R_typed = (
            np.asarray(R_true, dtype=np.float64)
            @ rotation_from_angles_deg(self.mount_rotation_deg).T
        )
        offset = np.einsum("...ij,j->...i", R_typed, np.asarray(self.camera_offset))
        t = (np.asarray(t_true, dtype=np.float64) - offset) / self.tape_scale
        return t, angles_deg_from_rotation(R_typed)

    def true_intrinsics(self, intrinsics: ArrayLike) -> F64:
        """Typed ``(fx, fy, cx, cy)`` (..., 4) -> the true ones."""
        k = np.array(intrinsics, dtype=np.float64)
        k[..., :2] *= self.focal_scale
        k[..., 2:] += np.asarray(self.principal_offset_px)
        return k


def angles_deg_from_rotation(R: ArrayLike) -> F64:
    """The angles ``(rx, ry, rz)`` in degrees of rotations ``R = Rx Ry Rz``.

    Shapes (..., 3, 3) to (..., 3); ``rotation_from_angles_deg`` of the result gives ``R`` back,
    with ry in [-90, 90].
    """
    m = np.asarray(R, dtype=np.float64)
    ry = np.arcsin(np.clip(m[..., 0, 2], -1.0, 1.0))
    rx = np.arctan2(-m[..., 1, 2], m[..., 2, 2])
    rz = np.arctan2(-m[..., 0, 1], m[..., 0, 0])
    angles: F64 = np.degrees(np.stack([rx, ry, rz], axis=-1))
    return angles


def corrected_view(view: PoseView, rig: RigConstants) -> PoseView:
    """A pose as the rig really had it: centre, angles and intrinsics corrected.

    Refused if the rig's principal offset is beyond a quarter of this view's image.
    """
    check_plausible(rig, image_size=view.width_height, only=["principal_offset_px"])
    t, R = rig.true_poses(view.t_grid, view.r_deg)
    return dataclasses.replace(
        view,
        t_grid=np.asarray(t, dtype=np.float64),
        r_deg=angles_deg_from_rotation(R),
        intrinsics=rig.true_intrinsics(view.intrinsics),
    )


def corrected_ground(ground: GroundSpec | None, rig: RigConstants) -> GroundSpec | None:
    """The ground plane at its true height.

    The typed plane minus the rig's error; refused if the error is beyond half the ground height.
    """
    if ground is None:
        return None
    check_plausible(rig, ground_height=ground_height(ground), only=["ground_height_error"])
    return true_ground(ground, rig)


def true_ground(ground: GroundSpec, rig: RigConstants) -> GroundSpec:
    """The typed ground plane moved to its true height (``n . p = h - error |n|``).

    Without the plausibility check: the rig fit tries constants on its way to them
    (:func:`corrected_ground` checks the ones a run corrects by).
    """
    normal, offset = ground
    return normal, offset - rig.ground_height_error * float(np.linalg.norm(normal))


def ground_height(ground: GroundSpec | None) -> float | None:
    """The typed distance from the grid's origin down to the ground plane.

    The grid's origin is the camera centre's height; the plane is ``n . p = offset``; the distance
    is in the session's units (None: no ground).
    """
    if ground is None:
        return None
    normal, offset = ground
    return abs(float(offset)) / float(np.linalg.norm(normal))


#: Prior 1-sigma of each constant about its nominal value (lengths in inches, converted to a
#: rig's units), used by both rig calibrations (board and target trials): a mount is set to a
#: few degrees, a camera sits within about an inch of where one would guess, a webcam's focal
#: parameter is good to about 10% and its principal point to ~20 px, a tape to 0.1%, and the
#: ground height, measured to a camera centre one cannot see, to about half an inch.
RIG_PRIORS = {
    "mount_rotation_deg": 3.0,
    "camera_offset": 1.0,  # inches
    "focal_scale": 0.10,
    "principal_offset_px": 20.0,
    "tape_scale": 0.001,
    "ground_height_error": 0.5,  # inches
}
_PRIOR_LENGTHS = ("camera_offset", "ground_height_error")


def prior_sigma(units: Units | None) -> F64:
    """The priors' 1-sigma per scalar (11, :data:`RIG_PARAMETERS` order).

    Lengths in ``units`` (inches when None).
    """
    per_inch = 1.0 / INCHES_PER_UNIT[units] if units is not None else 1.0
    scale = {g: per_inch if g in _PRIOR_LENGTHS else 1.0 for g in RIG_PARAMETERS}
    return np.concatenate(
        [np.full(len(RIG_PARAMETERS[g]), RIG_PRIORS[g] * scale[g]) for g in RIG_PARAMETERS]
    )


def against_priors(delta: F64, units: Units | None, names: tuple[str, ...] = ()) -> tuple[str, ...]:
    """A warning per constant moved more than two prior sigmas from nominal.

    ``delta`` (11,): the constants minus nominal (NaN or 0 where not fitted); ``names`` the
    fitted scalars (all when empty). A fit that pushes a constant that far says so, rather
    than reporting the value as if the data had decided it alone.
    """
    sigma = prior_sigma(units)
    all_names = [n for g in RIG_PARAMETERS for n in RIG_PARAMETERS[g]]
    return tuple(
        f"{name} = nominal {d:+.4g} is {abs(d) / s:.1f} prior sigmas off (prior sigma {s:.3g}): "
        "the data push it against its prior; check the rig, the typed poses and the targets"
        for name, d, s in zip(all_names, delta, sigma, strict=True)
        if (not names or name in names) and np.isfinite(d) and abs(d) > 2 * s
    )


#: What a laptop on grid paper allows (the plausibility of a rig, :func:`check_plausible`):
#: each mount angle within ±30 deg; each camera offset component within 3 in (converted
#: to the rig's units); the focal scale within ±20% and the tape scale within ±5% of 1; the
#: principal offset within a quarter of the image (x: its width, y: its height); the
#: ground height error within half the ground height. Where the image or the ground height
#: is not known yet (a rig file read before a session), the largest image a webcam gives
#: and the highest ground stand in for them.
LIMITS = {
    "mount_rotation_deg": 30.0,
    "camera_offset_in": 3.0,
    "focal_scale": 0.20,
    "tape_scale": 0.05,
    "principal_fraction": 0.25,
    "ground_fraction": 0.5,
    "largest_image_px": 4096.0,
    "highest_ground_in": 48.0,
}


def _limits(
    units: Units | None, height: float | None, image: tuple[int, int] | None
) -> dict[str, tuple[float | F64, str]]:
    """Per constant, the largest plausible deviation from nominal and its words.

    Per constant: the largest plausible deviation from nominal (one number, or one per
    scalar) and the limit in words (NaN-free; ``inf`` where it cannot be judged yet).
    """
    per_inch = 1.0 / INCHES_PER_UNIT[units] if units is not None else np.inf
    offset = LIMITS["camera_offset_in"] * per_inch
    largest = LIMITS["largest_image_px"]
    size = np.array(image if image is not None else (largest, largest), dtype=np.float64)
    principal = LIMITS["principal_fraction"] * size
    of_image = "the image" if image is not None else f"a {largest:g} px image, the largest"
    in_units = f" {units}" if units is not None else ""
    # The offset's limit is stated in inches: said too when the units are others.
    also_in_inches = units is not None and unit_spec(units).inches != 1.0
    if height is not None:
        ground = LIMITS["ground_fraction"] * height
        ground_text = f"within half the ground height, ±{ground:.4g}{in_units}"
    else:
        ground = LIMITS["ground_fraction"] * LIMITS["highest_ground_in"] * per_inch
        ground_text = (
            f"within ±{ground:.4g}{in_units}, half of a {LIMITS['highest_ground_in']:g} in "
            "ground height, the most a laptop on a table has"
        )
    return {
        "mount_rotation_deg": (
            LIMITS["mount_rotation_deg"],
            f"each angle within ±{LIMITS['mount_rotation_deg']:g} deg",
        ),
        "camera_offset": (
            offset,
            f"each component within ±{offset:.4g}{in_units}"
            + (f" ({LIMITS['camera_offset_in']:g} in)" if also_in_inches else ""),
        ),
        "focal_scale": (LIMITS["focal_scale"], f"within 1 ± {LIMITS['focal_scale']:g}"),
        "principal_offset_px": (
            principal,
            f"within a quarter of {of_image}: ±{principal[0]:g} px in x, ±{principal[1]:g} px in y",
        ),
        "tape_scale": (LIMITS["tape_scale"], f"within 1 ± {LIMITS['tape_scale']:g}"),
        "ground_height_error": (ground, ground_text),
    }


def plausible_bounds(
    units: Units | None, ground_height: float | None = None, image: tuple[int, int] | None = None
) -> tuple[F64, F64]:
    """The plausible constants' lower and upper bounds.

    11 each, in :data:`RIG_PARAMETERS` order: where a fit may look, so that it never writes a rig
    that is refused.
    """
    nominal = RigConstants().vector()
    limits = _limits(units, ground_height, image)
    half = np.concatenate(
        [np.broadcast_to(limits[g][0], (len(n),)) for g, n in RIG_PARAMETERS.items()]
    )
    return nominal - half, nominal + half


def check_plausible(
    rig: RigConstants,
    *,
    units: Units | None = None,
    ground_height: float | None = None,
    image_size: tuple[int, int] | None = None,
    what: str = "rig",
    only: Iterable[str] | None = None,
) -> None:
    """Refuse a rig a laptop on grid paper cannot have.

    The limits are :data:`LIMITS`; each constant beyond its limit is named with the limit. The
    lengths are judged in ``rig.units`` (else ``units``; neither: not judged); ``ground_height``
    (session units) and ``image_size`` (width, height) are the session's, where known; ``only``:
    these constants alone.
    """
    units = rig.units or units
    limits = _limits(units, ground_height, image_size)
    values, nominal = rig.vector(), RigConstants().vector()
    groups = set(RIG_PARAMETERS if only is None else only)
    problems, k = [], 0
    for group, names in RIG_PARAMETERS.items():
        half, text = limits[group]
        deviation = np.abs(values[k : k + len(names)] - nominal[k : k + len(names)])
        k += len(names)
        if group not in groups:
            continue
        bound = np.broadcast_to(np.asarray(half, dtype=np.float64), deviation.shape)
        if (deviation > bound * (1 + 1e-6)).any():  # the file's 6 digits may round up
            problems.append(f"{group} = {_shown(getattr(rig, group))} ({text})")
    if problems:
        raise InputValueError(
            f"{what}: implausible for a laptop on grid paper: " + "; ".join(problems)
        )


def _shown(value: float | tuple[float, ...]) -> str:
    if isinstance(value, tuple):
        return "[" + ", ".join(f"{v:g}" for v in value) + "]"
    return f"{value:g}"


def check_applicable(
    rig: RigConstants,
    units: Units,
    ground: GroundSpec | None = None,
    image_sizes: Iterable[tuple[int, int]] = (),
    what: str = "rig",
    *,
    cameras: Iterable[Intrinsics] = (),
) -> list[str]:
    """Refuse a rig for a session it cannot apply to; return the notes to show.

    Refused: a session in other units than the rig's (:func:`check_units`), a camera the
    rig was not fitted for (:func:`check_cameras`), or one the rig is implausible for (its
    ground height and each camera's ``(width, height)``, ``image_sizes`` and ``cameras``).
    A rig without units or cameras, from before they were recorded, is taken as it is,
    with a note; so are constants whose covariance is known only by their 1-sigmas.
    """
    cameras = list(cameras)
    notes = check_units(rig, units, what) + check_cameras(rig.cameras, cameras, what)
    if rig.covariance is not None and rig.covariance.independent:
        notes.append(
            f"{what} records each constant's 1-sigma but not their covariance (written before "
            "rig files did): carried as independent, which can overstate each region; write "
            "it again with `twopose-analyze rig`"
        )
    sizes = [*image_sizes, *((k.width, k.height) for k in cameras)]
    smallest = (min(w for w, _ in sizes), min(h for _, h in sizes)) if sizes else None
    check_plausible(
        rig, units=units, ground_height=ground_height(ground), image_size=smallest, what=what
    )
    return notes


def check_units(rig: RigConstants, units: Units, what: str = "rig") -> list[str]:
    """Refuse a rig in other units than the session's; the note for one without any."""
    if rig.units is None:
        return [
            f"{what} records no units (written before rig files did): its lengths are taken "
            f"in the session's units ({units}); write it again with `twopose-analyze rig` "
            "to have them checked"
        ]
    if rig.units != units:
        raise InputValueError(
            f"{what} is in {rig.units}, the session in {units}: its camera offset and ground "
            f"height error are lengths; calibrate a rig from sessions in {unit_spec(units).name}"
        )
    return []
