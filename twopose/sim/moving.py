"""A moving target seen by two synthetic cameras, each on its own clock (issue 58 item 7).

Two cameras fixed to each other (a :class:`~twopose.pair.calibration.PairCalibration`:
camera 1 at the grid's origin, the grid frame its frame; camera 2 at ``t_2_in_1``, turned
``R_2_to_1``) share one scene: the table, the wall and the clutter of
:func:`twopose.sim.layout.build_layout`, and the method's target held by a hand (no
stand): the dot on its card (point) or the gloved finger (line, ground). The target moves
at a constant ``speed`` along straight segments through known grid points (the
**touches**: :func:`touch_points`), without turning (:class:`Trajectory`).

Rendering is fast: each camera's static background is ray cast once
(:func:`twopose.sim.render.render_radiance`, the target left out); each frame casts only
the rays about the target where it is at that frame's true instant
(:func:`twopose.sim.render.render_sprite`) and composites them over it, then exposes the frame as
every simulated frame is (:func:`twopose.sim.render.expose`: lighting, noise). Each camera
takes its frames on its own clock (:func:`camera_frames`: frame rate, phase, drift,
jitter, dropped frames, offset). Deterministic for a seed; no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F32, F64
from twopose.camera.model import Intrinsics
from twopose.errors import SceneError
from twopose.methods.planes import ConstraintPlane
from twopose.methods.specs import Method, spec_of
from twopose.pair.calibration import PairCalibration
from twopose.sim.layout import Layout, Primitive, build_layout, finger_axis
from twopose.sim.render import expose, render_radiance, render_sprite
from twopose.sim.scene import Scene
from twopose.values.units import Units, unit_factor

__all__ = ["ClockSettings", "Flash", "PairScene", "Trajectory", "camera_frames", "touch_points"]

#: Where the touches lie about the scene's target: a square of side 2 in (in inches), in
#: the plane facing the cameras (point) or level (line, ground: the floor).
_TOUCH_SQUARE_IN = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0))
#: The target comes in from one inch before the first touch and goes on one past the last.
_LEAD_IN = 1.0
#: A frame's jitter never moves its stamp by this share of a frame interval or more, so a
#: camera's stamps keep their frames' order (a driver's stamps never swap two frames).
_JITTER_CUT = 0.45
_MARGIN_PX = 4.0


@dataclass(frozen=True, kw_only=True)
class ClockSettings:
    """One camera's clock.

    ``fps``, ``drift_ppm`` (its interval ``1 + drift 1e-6`` times the nominal), ``jitter_s``
    (its stamps' 1-sigma), ``drop`` (the share of frames lost) and ``offset_s`` (its clock
    minus camera 1's).
    """

    fps: float = 30.0
    drift_ppm: float = 0.0
    jitter_s: float = 0.0
    drop: float = 0.0
    offset_s: float = 0.0


@dataclass(frozen=True, kw_only=True)
class Flash:
    """A flash: a light switched on at ``onset_s`` for ``lit_s`` (s from the trial's start).

    The scene's light is ``1 + gain`` times as bright meanwhile (a phone's torch held near
    it). A frame is exposed for its whole interval about its true instant (as
    :func:`twopose.pair.flash.offset_from_flash` takes it): lit for the share of it the
    flash overlaps.
    """

    onset_s: float
    lit_s: float
    gain: float

    def light(self, true_s: F64, interval_s: float) -> F64:
        """(N,) each frame's light, a factor on the scene's: ``1 + gain * lit share``."""
        start = np.asarray(true_s, dtype=np.float64) - interval_s / 2
        overlap = np.clip(
            np.minimum(start + interval_s, self.onset_s + self.lit_s)
            - np.maximum(start, self.onset_s),
            0.0,
            None,
        )
        return np.asarray(1.0 + self.gain * overlap / interval_s)


@dataclass(frozen=True, kw_only=True, eq=False)
class CameraFrames:
    """One camera's frames of a trial.

    ``true_s`` (N,) their true instants (camera 1's clock, s from the trial's start,
    increasing), ``stamp_s`` (N,) its clock's stamps (increasing), and the ``phase_s`` its
    first frame would have had.
    """

    true_s: F64
    stamp_s: F64
    phase_s: float


def camera_frames(
    clock: ClockSettings, duration_s: float, rng: np.random.Generator
) -> CameraFrames:
    """The frames a free-running camera takes in ``duration_s`` seconds (seeded).

    A random phase within the first interval; the jitter is Gaussian, cut at
    :data:`_JITTER_CUT` of an interval so that stamps keep their frames' order.
    """
    interval = (1.0 + 1e-6 * clock.drift_ppm) / clock.fps
    phase = float(rng.uniform(0.0, interval))
    n = int(np.floor((duration_s - phase) / interval)) + 1
    true = phase + interval * np.arange(max(n, 0), dtype=np.float64)
    cut = _JITTER_CUT * interval
    jitter = np.clip(rng.normal(0.0, clock.jitter_s, true.size), -cut, cut)
    kept = rng.random(true.size) >= clock.drop
    return CameraFrames(
        true_s=true[kept], stamp_s=(true + clock.offset_s + jitter)[kept], phase_s=phase
    )


def touch_points(scene: Scene, method: Method, pair: PairCalibration) -> F64:
    """(4, 3) the grid points the target touches.

    A square of side 2 in about the scene's target moved halfway toward the middle of the
    pair's baseline (both cameras see it). A method whose estimate lies on a plane (ground):
    where the finger's axis meets the plane, the square in the plane; else the finger's
    tip (line), the square level; else the dot's centre (point), the square facing the
    cameras.
    """
    k = unit_factor(Units.IN, Units(scene.units))
    spec = spec_of(method)
    if spec.plane is not None:
        axes = np.asarray(spec.plane.in_plane_grid, dtype=np.float64)
        centre = _on_plane(scene, spec.plane)
    elif spec.uses_image_lines:
        axes = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        centre = np.asarray(finger_axis(scene)[0], dtype=np.float64)
    else:
        axes = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        centre = np.asarray(scene.point.position, dtype=np.float64)
    centre = _toward_baseline(centre, pair)
    return np.array([centre + k * (a * axes[0] + b * axes[1]) for a, b in _TOUCH_SQUARE_IN])


def _on_plane(scene: Scene, plane: ConstraintPlane) -> F64:
    """Where the scene's finger's axis meets the method's ``plane``.

    The plane's offset is the scene's ground height.
    """
    tip, base = (np.asarray(p, dtype=np.float64) for p in finger_axis(scene, plane))
    n, d = np.asarray(plane.normal_grid, dtype=np.float64), tip - base
    return np.asarray(tip + (scene.ground_height - n @ tip) / (n @ d) * d)


def _toward_baseline(centre: F64, pair: PairCalibration) -> F64:
    """``centre`` moved in x halfway toward the middle of the pair's baseline."""
    middle = 0.5 * float(pair.t_2_in_1[0])
    return np.array([0.5 * (centre[0] + middle), centre[1], centre[2]])


@dataclass(frozen=True, kw_only=True, eq=False)
class Trajectory:
    """The target's reference point moving at ``speed`` through ``touches`` in order.

    It starts :data:`_LEAD_IN` (session units: one inch) before the first touch, along the
    first segment (waiting there ``hold_s`` first), stays ``dwell_s`` at each touch (a
    finger touching a point pauses on it) and ends as far past the last. ``touch_s`` (K,)
    the middle of each touch's stay; :meth:`at` where it is (the reference point: the
    dot's centre, the fingertip, the finger's floor point), ``duration_s`` the whole
    path's time.
    """

    touches: F64
    speed: float
    lead: float
    dwell_s: float = 0.0
    #: how long it waits at its start before it moves (a flash fired meanwhile)
    hold_s: float = 0.0

    @property
    def waypoints(self) -> F64:
        """(K + 2, 3) the path's corners: lead-in, the touches, lead-out."""
        p = self.touches
        first = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
        last = (p[-1] - p[-2]) / np.linalg.norm(p[-1] - p[-2])
        return np.vstack([p[0] - self.lead * first, p, p[-1] + self.lead * last])

    @property
    def _knots(self) -> tuple[F64, F64]:
        """(M,) times and (M, 3) points between which the target moves straight.

        Every corner; a touch's twice (its arrival, its departure).
        """
        w = self.waypoints
        steps = np.linalg.norm(np.diff(w, axis=0), axis=1) / self.speed
        times, points, t = [0.0], [w[0]], self.hold_s
        if self.hold_s > 0:
            times.append(t)
            points.append(w[0])
        for k in range(1, len(w)):
            t += steps[k - 1]
            times.append(t)
            points.append(w[k])
            if k < len(w) - 1:  # a touch: it stays
                t += self.dwell_s
                times.append(t)
                points.append(w[k])
        return np.asarray(times), np.asarray(points)

    @property
    def touch_s(self) -> F64:
        """(K,) the middle of the target's stay at each touch (s from the start)."""
        times, _ = self._knots
        if self.hold_s > 0:  # the wait at the start is no touch
            times = times[1:]
        return np.asarray(0.5 * (times[1:-1:2] + times[2:-1:2]))

    @property
    def duration_s(self) -> float:
        """The whole path's time (s)."""
        return float(self._knots[0][-1])

    def at(self, t_s: F64) -> F64:
        """(N, 3) the reference point at ``t_s`` (s from the start)."""
        times, points = self._knots
        t = np.clip(np.asarray(t_s, dtype=np.float64), 0.0, times[-1])
        return np.column_stack([np.interp(t, times, points[:, i]) for i in range(3)])


class PairScene:
    """The scene as two cameras see it, the target moved per frame.

    ``pair`` (the scene's units) places camera 2; ``intrinsics`` each camera's (the
    pair's). :meth:`frame` renders camera 1's or 2's frame with the target's reference
    point at a given place.
    """

    def __init__(
        self, scene: Scene, method: Method, pair: PairCalibration, rng: np.random.Generator
    ) -> None:
        self.scene, self.method, self.pair, self.rng = scene, method, pair, rng
        self._poses = (
            (np.eye(3), np.zeros(3)),
            (np.asarray(pair.R_2_to_1, np.float64), np.asarray(pair.t_2_in_1, np.float64)),
        )
        self._intrinsics = (pair.intrinsics1, pair.intrinsics2)
        # The clutter kept off the target's whole path (touches, lead-in and -out) in both
        # cameras' views: a decal where the finger passes merges with it in the glove's
        # colour mask (issue 58: the README's demo lost 2 of 4 touches so).
        views = [(i, R, t) for i, (R, t) in zip(self._intrinsics, self._poses, strict=True)]
        layout = build_layout(scene, method, rng, (views, self._path_shifts()))
        # build_layout puts the target first, then its stand's three parts (a hand holds
        # the moving target: no stand), then the scene's board if any
        self._target: Primitive = layout.primitives[0]
        self._static = Layout(primitives=layout.primitives[4:], decals=layout.decals)
        self._reference = self._reference_point()
        self._background = tuple(
            render_radiance(scene, self._static, intr, R, t)
            for intr, (R, t) in zip(self._intrinsics, self._poses, strict=True)
        )

    def _path_shifts(self) -> F64:
        """(S, 3) the target's shifts from its scene place along its whole path, sampled."""
        scene, method = self.scene, self.method
        plane = spec_of(method).plane
        if not spec_of(method).uses_image_lines:
            place = np.asarray(scene.point.position, dtype=np.float64)
        else:
            place = _on_plane(scene, plane) if plane is not None else finger_axis(scene)[0]
        lead = unit_factor(Units.IN, Units(scene.units)) * _LEAD_IN
        corners = Trajectory(touches=touch_points(scene, method, self.pair), speed=1.0, lead=lead)
        w = corners.waypoints
        steps = np.linspace(0.0, 1.0, 9)[:, None, None]  # each segment at 9 points
        path = (w[:-1] + steps * (w[1:] - w[:-1])[None]).reshape(-1, 3)
        return np.asarray(path - place)

    @property
    def direction(self) -> F64 | None:
        """(3,) the finger's unit direction, knuckle to tip (None: the dot)."""
        if self._target.kind != "capsule":
            return None
        d = self._target.b - self._target.a
        return np.asarray(d / np.linalg.norm(d))

    def _reference_point(self) -> F64:
        """Where the scene's target's reference point is (the dot, tip, floor point)."""
        prim = self._target
        if prim.kind != "capsule":
            return np.asarray(prim.dot_center, dtype=np.float64)
        plane = spec_of(self.method).plane
        if plane is not None:
            return _on_plane(self.scene, plane)
        return np.asarray(prim.b, dtype=np.float64)

    def tip(self, reference: F64) -> F64:
        """(N, 3) the fingertip (the dot's centre) when the reference point is there."""
        shift = self._tip_point() - self._reference
        return np.asarray(np.atleast_2d(reference) + shift)

    def _tip_point(self) -> F64:
        prim = self._target
        return np.asarray(prim.b if prim.kind == "capsule" else prim.dot_center, np.float64)

    def _moved(self, reference: F64) -> Primitive:
        shift = np.asarray(reference, dtype=np.float64) - self._reference
        prim = self._target
        return dataclasses.replace(
            prim, a=prim.a + shift, dot_center=prim.dot_center + shift,
            b=prim.b if prim.kind == "card" else prim.b + shift,  # a card's b: its half size
        )  # fmt: skip

    def check_in_view(self, references: F64) -> None:
        """Refuse a path the cameras do not both see whole (a scene error, in words)."""
        for k, (intr, (R, t)) in enumerate(
            zip(self._intrinsics, self._poses, strict=True), start=1
        ):
            for reference in references:
                rows, cols = self._box(self._moved(reference), intr, R, t)
                inside = (
                    rows[0] > _MARGIN_PX
                    and cols[0] > _MARGIN_PX
                    and rows[1] < intr.height - _MARGIN_PX
                    and cols[1] < intr.width - _MARGIN_PX
                )
                if not inside:
                    raise SceneError(
                        f"the moving target leaves camera {k}'s view at ("
                        + ", ".join(f"{v:.3g}" for v in np.asarray(reference, dtype=float))
                        + ") (scene units): move the scene's target toward both cameras' views"
                    )

    @staticmethod
    def _box(
        prim: Primitive, intr: Intrinsics, R: F64, t: F64
    ) -> tuple[tuple[int, int], tuple[int, int]]:
        """The pixel rows and columns (half-open) the primitive can cover, padded.

        A card's four corners projected; a capsule's two end spheres' image circles (a
        sphere of radius r at depth z spans at most ``f r / sqrt(z^2 - r^2)`` about its
        centre's image, times the off-axis stretch).
        """
        if prim.kind == "capsule":
            centres, radius = np.vstack([prim.a, prim.b]), prim.radius
        else:
            corners = [(sx * prim.b[0], sy * prim.b[1], 0.0) for sx in (-1, 1) for sy in (-1, 1)]
            centres, radius = prim.a + np.asarray(corners), 0.0
        q = (centres - t) @ R  # camera frame
        if (q[:, 2] <= radius + 1e-9).any():
            return (0, intr.height), (0, intr.width)
        u = intr.fx * q[:, 0] / q[:, 2] + intr.cx
        v = intr.fy * q[:, 1] / q[:, 2] + intr.cy
        stretch = 1.0 + np.hypot(q[:, 0], q[:, 1]) / q[:, 2]
        spread = radius / np.sqrt(q[:, 2] ** 2 - radius**2) * max(intr.fx, intr.fy) * stretch
        pad = float(spread.max()) + 3.0
        rows = (max(int(v.min() - pad), 0), min(int(v.max() + pad) + 2, intr.height))
        cols = (max(int(u.min() - pad), 0), min(int(u.max() + pad) + 2, intr.width))
        return rows, cols

    def radiance(self, camera: int, reference: F64) -> F32:
        """Camera 1's or 2's linear radiance with the target's reference point there."""
        intr, (R, t) = self._intrinsics[camera - 1], self._poses[camera - 1]
        prim = self._moved(reference)
        image = self._background[camera - 1].copy()
        rows, cols = self._box(prim, intr, R, t)
        if rows[1] > rows[0] and cols[1] > cols[0]:
            sprite, cover = render_sprite(self.scene, prim, intr, R, t, rows, cols)
            under = image[rows[0] : rows[1], cols[0] : cols[1]]
            image[rows[0] : rows[1], cols[0] : cols[1]] = under * (1.0 - cover[..., None]) + sprite
        return image

    def frame(self, camera: int, reference: F64, light: float = 1.0) -> NDArray[np.uint8]:
        """Camera 1's or 2's frame (BGR uint8), exposed with this scene's generator.

        Its light is ``light`` times the scene's (a flash: :class:`Flash`).
        """
        radiance = self.radiance(camera, reference)
        if light != 1.0:
            radiance = radiance * np.float32(light)
        return expose(radiance, self.scene, self.rng)
