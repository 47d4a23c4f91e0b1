"""Sensitivity analysis (the thesis' section 6 left it open): how the estimate moves with
pixel noise, pose-measurement error per axis, the baseline, the target distance and the
finger angle, in the thesis' own geometry (f = 525 px, h = 9.625 in, camera 2 about 1.1 in
along x, target near x = 1.91, z = 8.375 in; Appendix D).

Each sweep is a seeded Monte Carlo through the real solvers: the image measurements come
from the true poses; the solver gets the typed poses (true + error) and noisy pixels.

What a method's sweep aims at, measures and moves farther is its geometry's
(:attr:`twopose.methods.specs.MethodSpec.geometry`, asked once through
:class:`twopose.methods.geometry.GeometryCases`): the dot for rays meeting at a point, the
finger pointing at the method's own plane (the ground, a registered wall) for planes cut by
a plane. A registered method on another plane is swept on that plane, with no switch here.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from typing_extensions import override

from twopose.arrays import F64
from twopose.camera.model import Intrinsics, project_points
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import METHOD_SPECS, Method, MethodSpec, label_of
from twopose.methods.targets import finger_axis
from twopose.solve.estimate import EstimateOptions, ViewBatch
from twopose.uncertainty.propagate import INPUTS_PER_VIEW

#: The methods the sweeps cover by default: those the thesis tested, in its geometry (the
#: registry's ``thesis_tested``: methods 1 and 2; the line has its own tests).
SWEPT: tuple[Method, ...] = tuple(m for m, s in METHOD_SPECS.items() if s.thesis_tested)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "SENSITIVITY_COLUMNS",
    "Geometry",
    "plot_sensitivity",
    "sensitivity",
    "worst_x_translation_effect",
    "x_translation_effect",
]

SENSITIVITY_COLUMNS = [
    "method",
    "sweep",
    "value",
    "unit",
    "rmse",
    "rmse_x",
    "rmse_z",
    "bias_x",
    "bias_z",
    "n_ok",
]


@dataclass(frozen=True, kw_only=True)
class Geometry:
    """One configuration: camera 1 at the origin, camera 2 at ``baseline`` (no rotation).

    ``ground_height`` and ``ground_point`` are the pointed-at plane's offset and the point's
    in-plane coordinates (the thesis' ground: its height and (x, z)); a method on another
    plane reads them on its own plane.
    """

    focal_px: float = 525.0
    ground_height: float = 9.625
    baseline: tuple[float, float, float] = (1.1, 0.0, 0.0)
    ground_point: tuple[float, float] = (1.91, 8.375)  # method 2's target (x, z)
    finger_tilt_deg: float = 35.0
    finger_azimuth_deg: float = 165.0
    point_target: tuple[float, float, float] = (0.5, 1.5, 11.0)  # method 1's dot
    pixel_sigma: float = 0.25  # centroid noise, px
    theta_sigma_deg: float = 0.1  # orientation noise
    pose_sigma: tuple[float, float, float] = (0.0, 0.0, 0.0)  # typed-translation error per axis

    @property
    def intrinsics(self) -> Intrinsics:
        return Intrinsics(
            width=640, height=480, fx=self.focal_px, fy=self.focal_px, cx=320.0, cy=240.0
        )

    def finger(self) -> tuple[F64, F64]:
        """Tip and base of the finger (the simulator's finger, see
        :mod:`twopose.methods.targets`)."""
        return finger_axis(
            self.ground_point, self.ground_height, self.finger_tilt_deg, self.finger_azimuth_deg
        )


class _Aim(ABC):
    """What a method's sweep aims at: its truth, its image measurements, its plane."""

    #: The method's plane the solver is given (a method on none is given the ground's,
    #: which its solver does not read).
    plane: ConstraintPlane = GROUND_PLANE
    #: Whether the finger's tilt is swept (a finger pointing at a plane).
    tilts = False

    @abstractmethod
    def truth(self, g: Geometry) -> F64:
        """(3,) the true position the estimate is compared with."""

    @abstractmethod
    def measured(self, g: Geometry, centres: F64) -> tuple[F64, F64]:
        """The true image measurements in each view: (2, 2) pixels and (2,) orientations."""

    @abstractmethod
    def farther(self, g: Geometry, scale: float) -> Geometry:
        """``g`` with the target ``scale`` times as deep."""


class _Dot(_Aim):
    """Rays meeting at a point (method 1): the dot, its centroid in each view."""

    @override
    def truth(self, g: Geometry) -> F64:
        return np.asarray(g.point_target, dtype=np.float64)

    @override
    def measured(self, g: Geometry, centres: F64) -> tuple[F64, F64]:
        target = np.asarray(g.point_target, dtype=np.float64)[None]
        px = np.stack([project_points(target, g.intrinsics, np.eye(3), c)[0] for c in centres])
        return px, np.zeros(2)  # the dot's orientation is unused

    @override
    def farther(self, g: Geometry, scale: float) -> Geometry:
        x, y, z = g.point_target
        return replace(g, point_target=(x, y, z * scale))


@dataclass(frozen=True)
class _Pointed(_Aim):
    """Planes cut by the method's plane (method 2, a wall): the finger pointing at it."""

    plane: ConstraintPlane = GROUND_PLANE
    tilts = True

    def finger(self, g: Geometry) -> tuple[F64, F64]:
        return finger_axis(
            g.ground_point, g.ground_height, g.finger_tilt_deg, g.finger_azimuth_deg,
            plane=self.plane,
        )  # fmt: skip

    @override
    def truth(self, g: Geometry) -> F64:
        return self.plane.point(g.ground_point, g.ground_height)

    @override
    def measured(self, g: Geometry, centres: F64) -> tuple[F64, F64]:
        tip, base = self.finger(g)
        obs = [project_points(np.stack([tip, base]), g.intrinsics, np.eye(3), c) for c in centres]
        theta = np.array([math.degrees(math.atan2(*(o[1] - o[0])[::-1])) for o in obs])
        return np.stack([o[0] for o in obs]), theta

    @override
    def farther(self, g: Geometry, scale: float) -> Geometry:
        # The point's second in-plane coordinate: the ground's z, a wall's z (the depth).
        return replace(g, ground_point=(g.ground_point[0], g.ground_point[1] * scale))


class _Aims:
    """Each geometry's aim (:class:`twopose.methods.geometry.GeometryCases`)."""

    def rays_to_point(self) -> _Aim | None:
        return _Dot()

    def planes_to_line(self) -> _Aim | None:
        return None  # a line's error is not a point's: the line has its own tests

    def planes_to_plane_point(self, plane: ConstraintPlane) -> _Aim | None:
        return _Pointed(plane)


def _aim(spec: MethodSpec) -> _Aim:
    """What ``spec``'s sweeps aim at, from its geometry; ValueError for one not swept."""
    aim = None if spec.geometry is None else spec.geometry.cases(_Aims(), spec.plane)
    if aim is None:
        raise ValueError(f"{spec.label} has no sensitivity sweep (its error is not a point's)")
    return aim


def _measured(g: Geometry, spec: MethodSpec) -> tuple[F64, F64]:
    """The true image measurements in each view: (2, 2) pixels and (2,) orientations (deg),
    the dot's centroid (its orientation unused) or the finger's tip and direction."""
    return _aim(spec).measured(g, np.array([[0.0, 0.0, 0.0], g.baseline]))


def _solved(g: Geometry, spec: MethodSpec, px: F64, theta: F64, typed: F64) -> F64:
    """(S, 3) estimates of S samples' pixels (S, 2, 2), orientations (S, 2) and typed camera
    centres (S, 2, 3), through the estimation's own solver; NaN where it gave up."""
    inputs = np.zeros((len(px), 2, len(INPUTS_PER_VIEW)))  # unrotated cameras: angles 0
    inputs[..., :2], inputs[..., 2], inputs[..., 3:6] = px, theta, typed
    k = g.intrinsics
    batch = ViewBatch(
        inputs=inputs,
        intrinsics=np.broadcast_to([k.fx, k.fy, k.cx, k.cy], (*inputs.shape[:2], 4)).copy(),
        valid=np.ones(inputs.shape[:2], dtype=bool),
    )
    normal, offset = _aim(spec).plane.plane(g.ground_height)
    plane = (np.asarray(normal, dtype=np.float64), offset)
    if spec.solver is None:
        raise ValueError(f"{spec.label} solves nothing: it has no sensitivity sweep")
    solved = spec.solver.load().solve(batch, plane, EstimateOptions().min_conditioning)
    return solved.point


def _estimate(g: Geometry, spec: MethodSpec, samples: int, rng: np.random.Generator) -> F64:
    """(samples, 3) estimates under the geometry's noise; NaN where the solver gave up."""
    centres = np.array([[0.0, 0.0, 0.0], g.baseline])
    typed = centres[None] + rng.normal(size=(samples, 2, 3)) * np.asarray(g.pose_sigma)
    px, theta = _measured(g, spec)
    noisy_px = px[None] + rng.normal(0.0, g.pixel_sigma, (samples, 2, 2))
    noisy_theta = theta[None] + rng.normal(0.0, g.theta_sigma_deg, (samples, 2))
    return _solved(g, spec, noisy_px, noisy_theta, typed)


def _row(
    g: Geometry, spec: MethodSpec, sweep: str, value: float, unit: str, samples: int, seed: int
) -> dict[str, object]:
    est = _estimate(g, spec, samples, np.random.default_rng(seed))
    err = est - _aim(spec).truth(g)
    ok = np.isfinite(err).all(axis=1)
    e = err[ok]
    return {
        "method": spec.method,
        "sweep": sweep,
        "value": value,
        "unit": unit,
        "rmse": float(np.sqrt((e**2).sum(axis=1).mean())) if len(e) else math.nan,
        "rmse_x": float(np.sqrt((e[:, 0] ** 2).mean())) if len(e) else math.nan,
        "rmse_z": float(np.sqrt((e[:, 2] ** 2).mean())) if len(e) else math.nan,
        "bias_x": float(e[:, 0].mean()) if len(e) else math.nan,
        "bias_z": float(e[:, 2].mean()) if len(e) else math.nan,
        "n_ok": int(ok.sum()),
    }


def sensitivity(
    samples: int = 2000,
    seed: int = 0,
    base: Geometry | None = None,
    methods: Sequence[MethodSpec] | None = None,
) -> pd.DataFrame:
    """All sweeps, for method 1 (point) and method 2 (ground), as one tidy table.

    Every sweep varies one thing from ``base`` (the thesis' geometry with 0.25 px centroid
    noise and 0.1 deg orientation noise): pixel noise; pose error on x, y, z; baseline length
    along x; baseline direction in the x-z plane; target distance; finger tilt (method 2).

    Parameters
    ----------
    samples : int
        Monte Carlo samples per row.
    seed : int
        The random seed: the same seed, the same table.
    base : Geometry, optional
        The geometry each sweep varies (default: the thesis').
    methods : sequence of MethodSpec, optional
        The methods swept (default: :data:`SWEPT`); a registered method on its own plane is
        swept on it. A method whose geometry has no sweep (the line) is refused
        (ValueError).

    Returns
    -------
    DataFrame
        One row per method, sweep and value (:data:`SENSITIVITY_COLUMNS`).
    """
    g0 = base or Geometry()
    rows = []
    specs = [METHOD_SPECS[m] for m in SWEPT] if methods is None else list(methods)
    for method in specs:
        aim = _aim(method)
        for s in (0.1, 0.25, 0.5, 1.0, 2.0):
            rows.append(
                _row(replace(g0, pixel_sigma=s), method, "pixel noise", s, "px", samples, seed)
            )
        for axis, name in enumerate("xyz"):
            for s in (0.025, 0.05, 0.1, 0.2):
                sigma = [0.0, 0.0, 0.0]
                sigma[axis] = s
                g = replace(g0, pose_sigma=(sigma[0], sigma[1], sigma[2]))
                rows.append(_row(g, method, f"pose error {name}", s, "in", samples, seed))
        for length in (0.25, 0.5, 1.1, 2.0, 4.0):
            g = replace(g0, baseline=(length, 0.0, 0.0), pose_sigma=(0.1, 0.0, 0.1))
            rows.append(_row(g, method, "baseline length", length, "in", samples, seed))
        for angle in (0.0, 30.0, 60.0, 90.0):
            a = math.radians(angle)
            g = replace(
                g0, baseline=(1.1 * math.cos(a), 0.0, 1.1 * math.sin(a)), pose_sigma=(0.1, 0.0, 0.1)
            )
            rows.append(_row(g, method, "baseline direction", angle, "deg from x", samples, seed))
        for scale in (0.75, 1.0, 1.5, 2.0):
            g = aim.farther(g0, scale)
            rows.append(_row(g, method, "target distance", scale, "x the thesis'", samples, seed))
        if aim.tilts:  # the finger's tilt
            for tilt in (15.0, 25.0, 35.0, 45.0, 55.0):
                rows.append(
                    _row(
                        replace(g0, finger_tilt_deg=tilt),
                        method,
                        "finger tilt",
                        tilt,
                        "deg",
                        samples,
                        seed,
                    )
                )
    return pd.DataFrame(rows, columns=SENSITIVITY_COLUMNS)


#: The thesis' claim of section 5.3 is method 2's, on the ground.
_METHOD_2 = METHOD_SPECS[Method.GROUND]


def x_translation_effect(error: float = 0.1, base: Geometry | None = None) -> float:
    """Largest change of method 2's x estimate when one camera's typed x is off by ``error``.

    The thesis (section 5.3) says a 0.1 in x-translation error can move the x estimate by up
    to about 0.2 in; this measures it, noise-free, in the thesis' geometry.
    """
    g = replace(base or Geometry(), pixel_sigma=0.0, theta_sigma_deg=0.0)
    truth = _aim(_METHOD_2).truth(g)
    worst = 0.0
    for camera in (0, 1):
        for sign in (-1.0, 1.0):
            shift = np.zeros((2, 3))
            shift[camera, 0] = sign * error
            est = _estimate_with_typed_offset(g, shift)
            worst = max(worst, abs(float(est[0] - truth[0])))
    return worst


def _estimate_with_typed_offset(g: Geometry, offset: F64) -> F64:
    """Method 2's noise-free estimate with the typed camera centres off by ``offset`` (2, 3)."""
    px, theta = _measured(g, _METHOD_2)
    typed = np.array([[0.0, 0.0, 0.0], g.baseline]) + offset
    return np.asarray(_solved(g, _METHOD_2, px[None], theta[None], typed[None])[0])


def worst_x_translation_effect(
    error: float = 0.1, base: Geometry | None = None
) -> tuple[float, float, float]:
    """:func:`x_translation_effect` maximised over finger orientations the thesis' photos
    allow (tilt 15-55 deg from vertical, pointing azimuth 135-225 deg): (effect, tilt, azimuth).

    The thesis does not record its finger's orientation, so its claim is checked against
    the worst case as well as against our default finger.
    """
    g0 = base or Geometry()
    best = (0.0, g0.finger_tilt_deg, 165.0)
    for tilt in np.arange(15.0, 56.0, 5.0):
        for azimuth in np.arange(135.0, 226.0, 15.0):
            g = replace(g0, finger_tilt_deg=float(tilt), finger_azimuth_deg=float(azimuth))
            effect = x_translation_effect(error, g)
            if effect > best[0]:
                best = (effect, float(tilt), float(azimuth))
    return best


def plot_sensitivity(table: pd.DataFrame) -> Figure:
    """One panel per sweep: RMS error against the swept value, method 1 and method 2."""
    from matplotlib.figure import Figure

    sweeps = list(dict.fromkeys(table["sweep"]))
    cols = 3
    rows = math.ceil(len(sweeps) / cols)
    fig = Figure(figsize=(4.0 * cols, 3.0 * rows), layout="constrained")
    for i, sweep in enumerate(sweeps):
        ax = fig.add_subplot(rows, cols, i + 1)
        for method, g in table[table["sweep"] == sweep].groupby("method"):
            ax.plot(g["value"], g["rmse"], marker="o", label=label_of(str(method)))
        unit = table.loc[table["sweep"] == sweep, "unit"].iloc[0]
        ax.set_xlabel(f"{sweep} ({unit})")
        ax.set_ylabel("RMS error (in)")
        ax.set_yscale("log")
        ax.set_title(f"error against {sweep}", fontsize=9)
        ax.legend(fontsize=7)
    fig.suptitle("Sensitivity in the thesis' geometry: RMS error, one input varied", fontsize=10)
    return fig
